"""How long ``spinemesh pack`` takes and how much memory it holds, one process against several,
and this checkout against another (an older release, unpacked anywhere).

Two measures, each run in a fresh process (wall seconds, CPU seconds of the process and its
workers, peak resident memory of the largest of them):

- ``PROJECT ...``: ``spinemesh pack PROJECT --jobs J`` for every ``--jobs`` given, with this
  checkout's code and with each ``--code DIR`` (another checkout's root), side by side, with the
  ratio of each wall time to the first row's;
- ``--many N``: one atlas of ``N`` regions on one ``--side`` page, made here (random texels in
  rectangles of random sizes, drawn by no skeleton, so every region keeps its rectangle), packed by
  :func:`spinemesh.pack.atlas_pack.pack_atlas` alone: CPU seconds and peak memory.

Usage::

    .venv/bin/python benchmarks/bench_pack_scale.py CORPUS/degamex-degamers --jobs 1 2 --code /tmp/old
    .venv/bin/python benchmarks/bench_pack_scale.py --many 10000 --side 4096 --code /tmp/old
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Runs one measure in a fresh interpreter and prints it as JSON (argv: mode, arguments).
_CHILD = r'''
import json, resource, sys, time
mode = sys.argv[1]
t0, c0 = time.perf_counter(), time.process_time()
if mode == "pack":
    from spinemesh.cli import app
    project, out, jobs = sys.argv[2:5]
    args = ["pack", project, "--out", out, "--report", out + ".json"]
    if jobs != "-":
        args += ["--jobs", jobs]
    try:
        app(args, standalone_mode=False)
    except SystemExit:
        pass
    rows = json.load(open(out + ".json"))["totals"]
    extra = {"pages": rows["pages_after"], "texels": rows["texels_after"]}
else:
    import numpy as np
    from spinemesh.atlas import parse_atlas
    from spinemesh.pack.atlas_pack import PackRefused, pack_atlas
    n, side = int(sys.argv[2]), int(sys.argv[3])
    rng = np.random.default_rng(0)
    cell = side // int(np.ceil(np.sqrt(n)))
    per = side // cell
    lines = ["page.png", f"size: {side},{side}", "filter: Linear,Linear", ""]
    page = np.zeros((side, side, 4), np.uint8)
    for i in range(n):
        x, y = (i % per) * cell, (i // per) * cell
        w, h = (int(v) for v in rng.integers(cell // 2, cell - 2, 2))
        lines[-1:] = [f"r{i}", f"bounds: {x},{y},{w},{h}", ""]
        page[y:y + h, x:x + w] = rng.integers(1, 255, (h, w, 4), dtype=np.uint8)
    atlas = parse_atlas("\n".join(lines) + "\n", "many.atlas")
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        packed = pack_atlas(atlas, [page], {})
        extra = {"pages": len(packed.pages), "texels": packed.texels_after}
    except PackRefused as e:
        extra = {"kept": str(e)}
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"wall": time.perf_counter() - t0,
                  "cpu": time.process_time() - c0 + kids.ru_utime + kids.ru_stime,
                  "peak_mb": max(me.ru_maxrss, kids.ru_maxrss) / 1024, **extra}))
'''


def measure(code: Path, mode: str, *args: str) -> dict:
    """One measure of :data:`_CHILD` with the package at ``code`` first on the path."""
    env = dict(os.environ, PYTHONPATH=str(code), COLUMNS="120")
    done = subprocess.run([sys.executable, "-c", _CHILD, mode, *args], capture_output=True, text=True, env=env,
                          cwd=tempfile.gettempdir())
    if done.returncode != 0:
        raise SystemExit(f"{code}: {done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--jobs", nargs="+", default=["1", "2"], help="--jobs values to run (default 1 2)")
    ap.add_argument("--code", nargs="*", type=Path, default=[], metavar="DIR",
                    help="other checkouts to compare with (their root, holding spinemesh/)")
    ap.add_argument("--many", type=int, metavar="N", help="instead: N regions on one page")
    ap.add_argument("--side", type=int, default=4096, help="with --many: the page's side (default 4096)")
    args = ap.parse_args(argv)
    codes = [("this checkout", REPO)] + [(str(c), c.resolve()) for c in args.code]
    if args.many:
        print("| code | regions | page | CPU s | peak memory MB | outcome |\n|---|---:|---|---:|---:|---|")
        for label, code in codes:
            m = measure(code, "many", str(args.many), str(args.side))
            outcome = m.get("kept") or f"{m['pages']} page(s), {m['texels']:,} texels"
            print(f"| {label} | {args.many:,} | {args.side}x{args.side} | {m['cpu']:.1f} | {m['peak_mb']:.0f} | "
                  f"{outcome} |", flush=True)
        return 0
    print("| project | code | --jobs | wall s | wall against the first row | CPU s | peak memory MB | pages | "
          "page texels |\n|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for project in args.projects:
        first = None
        for label, code in codes:
            for jobs in args.jobs:
                with tempfile.TemporaryDirectory(prefix="bench-pack-scale-") as scratch:
                    # an older checkout may have no --jobs: run it once, as it is
                    has_jobs = (code / "spinemesh" / "pack" / "parallel.py").exists()
                    if not has_jobs and jobs != args.jobs[0]:
                        continue
                    m = measure(code, "pack", str(project.resolve()), str(Path(scratch) / "out"),
                                jobs if has_jobs else "-")
                first = first or m["wall"]
                print(f"| {project.name} | {label} | {jobs if has_jobs else '-'} | {m['wall']:.1f} | "
                      f"{m['wall'] / first:.2f} | {m['cpu']:.1f} | {m['peak_mb']:.0f} | {m['pages']} | "
                      f"{m['texels']:,} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
