"""Pose sampling speed: spinemesh.anim beside the official runtime (Node harness).

For each skeleton, its first animation is sampled at 30 frames per second over one loop:

* ``ours pose``: :meth:`spinemesh.anim.Sampler.pose` per frame (each pose on its own: with
  4.2 physics, a replay of the game loop from 0);
* ``ours play``: :meth:`~spinemesh.anim.Sampler.play`, one game loop through all frames;
* ``runtime``: the harness's dump of the same poses (``dump.mjs --poses``), minus its load
  time, per pose; it also plays each pose from 0, like ``ours pose``.

Times are milliseconds per frame (best of ``--repeat``); the ratio columns are ours / runtime.

    .venv/bin/python benchmarks/bench_poses.py [--repeat 3]

``stream``: ``spinemesh pose`` of this checkout beside an older checkout (``--old``, a folder
holding its ``spinemesh`` package), each run in its own process: wall seconds, peak resident
memory (the child's own, from ``wait4``), bytes written, whether the two files are the same
bytes, and the ratios new / old. Each case is ``SKELETON:ANIMATION:TIMES``, the times being
``0, 1/60, 2/60, ...`` (a long animation sampled at 60 frames per second; the track loops).
A run that ends in an error is shown as refused with its line.

    .venv/bin/python benchmarks/bench_poses.py stream --old OLD CASE [CASE ...] [--work DIR]
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from spinemesh.anim import Sampler, atlas_regions  # noqa: E402
from spinemesh.anim.dump import js_number  # noqa: E402
from spinemesh.atlas import read_atlas  # noqa: E402
from spinemesh.skeleton import load_skeleton  # noqa: E402

from conftest import EXAMPLES  # noqa: E402
from runtime_tool import install, node  # noqa: E402

#: (skeleton, atlas) under the examples: small and large rigs, 3.8 and 4.2, with and without physics.
CASES = [("3.8/spineboy/spineboy-pro.json", "spineboy.atlas"), ("4.2/spineboy/spineboy-pro.skel", "spineboy.atlas"),
         ("4.2/mix-and-match/mix-and-match-pro.skel", "mix-and-match.atlas"),
         ("4.2/cloud-pot/cloud-pot.skel", "cloud-pot.atlas"), ("4.2/sack/sack-pro.skel", "sack.atlas")]


def best(fn, repeat: int) -> float:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def run_pose(checkout: Path, skeleton: Path, animation: str, count: int, out: Path) -> dict:
    """``spinemesh pose`` of the package in ``checkout``, in its own process, at ``count`` times
    60 a second apart: its wall seconds, peak resident memory (bytes), exit status and the last
    line it printed on failure."""
    times = ",".join(js_number(i / 60) for i in range(count))
    args = [sys.executable, "-m", "spinemesh", "pose", str(skeleton), "-a", animation, "--times", times,
            "--out", str(out)]
    env = {**os.environ, "PYTHONPATH": str(checkout), "COLUMNS": "200"}
    out.unlink(missing_ok=True)
    t0 = time.perf_counter()
    child = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=checkout)
    err = child.stderr.read().decode(errors="replace")
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - t0
    child.returncode = os.waitstatus_to_exitcode(status)
    lines = [x for x in err.splitlines() if x.startswith("error:")]
    return {"wall": wall, "rss": usage.ru_maxrss * 1024, "rc": child.returncode,
            "bytes": out.stat().st_size if out.is_file() else 0, "error": lines[-1] if lines else err[-200:]}


def stream(argv) -> int:
    ap = argparse.ArgumentParser(description="spinemesh pose: this checkout beside an older one")
    ap.add_argument("--old", type=Path, required=True, help="an older checkout (holding its spinemesh package)")
    ap.add_argument("cases", nargs="+", metavar="SKELETON:ANIMATION:TIMES")
    ap.add_argument("--work", type=Path, help="where the outputs are written (default: a temporary folder)")
    args = ap.parse_args(argv)
    work = args.work or Path(tempfile.mkdtemp(prefix="bench-pose-stream-"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"{'skeleton':40s} {'times':>6s} {'MB':>8s} {'old s':>7s} {'new s':>7s} {'new/old':>7s} "
          f"{'old MiB':>8s} {'new MiB':>8s} {'new/old':>7s}  same bytes")
    failed = 0
    for case in args.cases:
        skeleton, animation, count = case.rsplit(":", 2)
        old, new = work / "old.json", work / "new.json"
        o = run_pose(args.old.resolve(), Path(skeleton).resolve(), animation, int(count), old)
        n = run_pose(REPO, Path(skeleton).resolve(), animation, int(count), new)
        failed += n["rc"] != 0
        name = "/".join(Path(skeleton).parts[-2:])
        size = f"{n['bytes'] / 1e6:8.1f}" if n["rc"] == 0 else f"{'-':>8s}"
        if o["rc"] == 0 and n["rc"] == 0:
            same = "yes" if filecmp.cmp(old, new, shallow=False) else "NO"
            failed += same != "yes"
            print(f"{name:40s} {count:>6s} {size} {o['wall']:7.1f} {n['wall']:7.1f} {n['wall'] / o['wall']:7.2f} "
                  f"{o['rss'] / 2**20:8.0f} {n['rss'] / 2**20:8.0f} {n['rss'] / o['rss']:7.2f}  {same}")
        else:
            print(f"{name:40s} {count:>6s} {size} {o['wall']:7.1f} {n['wall']:7.1f} {'-':>7s} "
                  f"{o['rss'] / 2**20:8.0f} {n['rss'] / 2**20:8.0f} {'-':>7s}  -")
            for who, r in (("old", o), ("new", n)):
                if r["rc"]:
                    print(f"    {who} refused (exit {r['rc']}): {r['error']}")
        old.unlink(missing_ok=True)
        new.unlink(missing_ok=True)
    return 1 if failed else 0


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["stream"]:
        return stream(argv[1:])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tool", type=Path, help="an installed copy of the harness (default: install one)")
    args = ap.parse_args(argv)
    tool = args.tool.resolve() if args.tool else install(Path(tempfile.mkdtemp(prefix="bench-poses-")) / "tool")
    rows = []
    for rel, atlas_name in CASES:
        skeleton, atlas = EXAMPLES / rel, EXAMPLES / rel.split("/")[0] / rel.split("/")[1] / atlas_name
        if not skeleton.is_file():
            print(f"{skeleton} is absent: skipped", file=sys.stderr)
            continue
        doc = load_skeleton(skeleton)
        sampler = Sampler(doc, None, atlas_regions(read_atlas(atlas)))
        anim = next((a for a in doc["animations"] if sampler.duration(a) > 0.5), next(iter(doc["animations"])))
        duration = sampler.duration(anim)
        times = [i / 30 for i in range(max(1, round(duration * 30)))]
        pose = best(lambda: [sampler.pose(anim, t) for t in times], args.repeat) / len(times)
        play = best(lambda: list(sampler.play(anim, times)), args.repeat) / len(times)
        out = Path(tempfile.mkdtemp()) / "d.json"
        poses = ",".join(f"{anim}@{js_number(t)}" for t in times)
        runtime = []
        for _ in range(args.repeat):
            r = node(tool, "dump.mjs", atlas, skeleton, "--poses", poses, "--out", out)
            if r.returncode:
                sys.exit(r.stderr[-500:])
            ms = json.loads(out.read_text())["timing_ms"]
            runtime.append((ms["total"] - ms["load"]) / 1000 / (len(times) + 1))
        rt = min(runtime)
        rows.append((rel, len(doc.get("bones", [])), len(sampler.physics), len(times), pose, play, rt))
    print(f"{'skeleton':44s} {'bones':>5s} {'phys':>4s} {'frames':>6s} {'ours pose':>10s} {'ours play':>10s} "
          f"{'runtime':>9s} {'pose/rt':>8s} {'play/rt':>8s}")
    for rel, bones, phys, n, pose, play, rt in rows:
        print(f"{rel:44s} {bones:5d} {phys:4d} {n:6d} {pose * 1e3:9.2f}ms {play * 1e3:9.2f}ms {rt * 1e3:8.2f}ms "
              f"{pose / rt:8.1f} {play / rt:8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
