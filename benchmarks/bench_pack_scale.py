"""How long ``spinemesh pack`` takes and how much memory it holds, one process against several,
and this checkout against another (an older release, unpacked anywhere).

Two measures, each run in a fresh process (wall seconds, CPU seconds of the process and its
workers, peak resident memory of the largest of them):

- ``PROJECT ...``: ``spinemesh pack PROJECT --jobs J`` for every ``--jobs`` given, with this
  checkout's code and with each ``--code DIR`` (another checkout's root), side by side, with the
  ratio of each wall time to the first row's;
- ``--many N``: one atlas of ``N`` regions on one ``--side`` page, made here (random texels in
  rectangles of random sizes, drawn by no skeleton, so every region keeps its rectangle), packed by
  :func:`spinemesh.pack.atlas_pack.pack_atlas` alone: CPU seconds and peak memory;
- ``--made PAGES REGIONS``: one atlas of ``REGIONS`` regions on ``PAGES`` pages, made here
  (:func:`make_atlas_project`: pages of 2048x2048, 2048x1024 and 1024x1024 in turn, each region a
  shape with an alpha outline drawn by a skeleton it also writes), upgraded by ``spinemesh
  upgrade`` (so its regions are drawn by meshes and packed by outline), then ``spinemesh pack``
  of the upgraded project timed for every ``--jobs`` as above, with where one process's time goes
  (``--phases``: the pack with ``--jobs 1`` again under cProfile).

Usage::

    .venv/bin/python benchmarks/bench_pack_scale.py CORPUS/degamex-degamers --jobs 1 2 --code /tmp/old
    .venv/bin/python benchmarks/bench_pack_scale.py --many 10000 --side 4096 --code /tmp/old
    .venv/bin/python benchmarks/bench_pack_scale.py --made 18 236 --jobs 1 2 --phases
    .venv/bin/python benchmarks/bench_pack_scale.py CORPUS/degamex-degamers --jobs 1 2 --oxipng-threads 0 1
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
import json, os, resource, sys, time
mode = sys.argv[1]
t0, c0 = time.perf_counter(), time.process_time()
if mode == "pack":
    from spinemesh.cli import app
    calls = os.environ.get("BENCH_OXIPNG_CALLS")
    if calls:  # every oxipng call's process, start and end (workers are forked: they inherit this)
        from spinemesh.pack import png
        compress = png._compress
        def timed(*args, **kwargs):
            start = time.time()
            try:
                return compress(*args, **kwargs)
            finally:
                with open(calls, "a") as f:
                    f.write(f"{os.getpid()} {start} {time.time()}\n")
        png._compress = timed
    project, out, jobs = sys.argv[2:5]
    args = ["pack", project, "--out", out, "--report", out + ".json"]
    if jobs != "-":
        args += ["--jobs", jobs]
    profile = sys.argv[5] if len(sys.argv) > 5 else ""
    if profile:
        import cProfile
        profiler = cProfile.Profile(time.process_time)  # CPU seconds of this process (oxipng's threads too)
        profiler.enable()
    try:
        app(args, standalone_mode=False)
    except SystemExit:
        pass
    if profile:
        profiler.disable()
        profiler.dump_stats(profile)
    rows = json.load(open(out + ".json"))["totals"]
    extra = {"pages": rows["pages_after"], "texels": rows["texels_after"], "by_outline": rows["by_outline"],
             "by_rectangle": rows["by_rectangle"], "bytes_before": rows["bytes_before"],
             "bytes_after": rows["bytes_after"]}
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


def measure(code: Path, mode: str, *args: str, env: dict | None = None) -> dict:
    """One measure of :data:`_CHILD` with the package at ``code`` first on the path; ``env``: more
    variables for it."""
    env = dict(os.environ, PYTHONPATH=str(code), COLUMNS="120", **(env or {}))
    done = subprocess.run([sys.executable, "-c", _CHILD, mode, *args], capture_output=True, text=True, env=env,
                          cwd=tempfile.gettempdir())
    if done.returncode != 0:
        raise SystemExit(f"{code}: {done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def oxipng_calls(path: Path) -> dict:
    """What the oxipng calls logged by a ``pack`` measure (``BENCH_OXIPNG_CALLS``) took: their
    seconds summed (``sum``), the wall seconds while at least one ran (``wall``), the most running
    at once (``at_once``) and in how many processes (``processes``)."""
    calls = [line.split() for line in path.read_text().splitlines()] if path.exists() else []
    spans = sorted((float(a), float(b)) for _, a, b in calls)
    wall, end = 0.0, float("-inf")
    for a, b in spans:
        wall += max(0.0, b - max(a, end))
        end = max(end, b)
    edges = sorted([(a, 1) for a, _ in spans] + [(b, -1) for _, b in spans])
    running = at_once = 0
    for _, step in edges:
        running += step
        at_once = max(at_once, running)
    return {"calls": len(spans), "sum": sum(b - a for a, b in spans), "wall": wall, "at_once": at_once,
            "processes": len({pid for pid, _, _ in calls})}


def oxipng_table(projects: list[Path], jobs: list[str], threads: list[int]) -> str:
    """``pack`` of each project for every ``--jobs`` and oxipng thread count (``RAYON_NUM_THREADS``;
    0: oxipng's default, one per core), with where its oxipng calls ran: are pages optimised side
    by side over ``--jobs``, and what do oxipng's own threads add or cost there."""
    lines = ["| project | --jobs | oxipng threads | wall s | CPU s | oxipng calls | their seconds summed | wall "
             "s with one running | most at once | in processes | share of the wall |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for project in projects:
        for n in jobs:
            for t in threads:
                with tempfile.TemporaryDirectory(prefix="bench-pack-scale-") as scratch:
                    log = Path(scratch) / "oxipng.calls"
                    env = {"BENCH_OXIPNG_CALLS": str(log), **({"RAYON_NUM_THREADS": str(t)} if t else {})}
                    m = measure(REPO, "pack", str(project.resolve()), str(Path(scratch) / "out"), n, env=env)
                    o = oxipng_calls(log)
                lines.append(f"| {project.name} | {n} | {t or 'default'} | {m['wall']:.1f} | {m['cpu']:.1f} | "
                             f"{o['calls']} | {o['sum']:.1f} | {o['wall']:.1f} | {o['at_once']} | {o['processes']} | "
                             f"{o['wall'] / m['wall']:.0%} |")
                print(lines[-1], file=sys.stderr, flush=True)
    return "\n".join(lines)


def make_atlas_project(folder: Path, pages: int, regions: int, seed: int = 0, gap: int | None = None) -> Path:
    """Write a project of one atlas of ``regions`` regions on ``pages`` pages, drawn by one 4.2 skeleton.

    Pages are 2048x2048, 2048x1024 and 1024x1024 in turn (PNG, as Pillow writes them); each holds
    an equal share of the regions, each sized 55-95% of a grid cell on each axis. ``gap``: the
    regions laid row by row from the top left with ``gap`` texels between them, as a packer with
    that padding leaves them (Spine's packs with 2 by default); None: one region at the corner of
    each cell (then the padding ``pack`` measures between them is the least gap of the grid,
    about 150 texels). A region is a shape with an alpha outline (a polygon of 7 to 12 corners at
    random distances from its centre, cropped to its box, as packers strip whitespace), coloured
    by a gradient with a little noise, as painted art compresses. The skeleton has one slot and one
    region attachment per region, so ``upgrade`` meshes them and ``pack`` packs them by outline.
    """
    import math

    import numpy as np
    from PIL import Image, ImageDraw

    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    sides = [(2048, 2048), (2048, 1024), (1024, 1024)]
    counts = [regions // pages + (k < regions % pages) for k in range(pages)]
    lines, slots, skin = [], [], {}
    index = 0
    for k, count in enumerate(counts):
        width, height = sides[k % len(sides)]
        columns = math.ceil(math.sqrt(count * width / height))
        rows = math.ceil(count / columns)
        cell_w, cell_h = width // columns, height // rows
        page = Image.new("RGBA", (width, height), (0, 0, 0, 0))
        name = f"made{k + 1}.png" if k else "made.png"
        lines += [name, f"size: {width}, {height}", "filter: Linear, Linear"]
        row_x = row_y = row_h = 0
        for c in range(count):
            w, h = (int(cell * f) for cell, f in zip((cell_w, cell_h), rng.uniform(0.55, 0.95, 2)))
            corners = int(rng.integers(7, 13))
            angles = np.sort(rng.uniform(0, 2 * np.pi, corners))
            radii = rng.uniform(0.45, 1.0, corners)
            shape = Image.new("L", (w, h), 0)
            ImageDraw.Draw(shape).polygon([(w / 2 + w / 2 * r * np.cos(a), h / 2 + h / 2 * r * np.sin(a))
                                           for a, r in zip(angles, radii)], fill=255)
            alpha = np.asarray(shape)
            ys, xs = np.nonzero(alpha)
            alpha = alpha[ys.min():ys.max() + 1, xs.min():xs.max() + 1]
            h, w = alpha.shape
            yy, xx = np.mgrid[0:h, 0:w]
            base = rng.integers(40, 215, 3)
            colour = np.stack([base[i] + 40 * (xx / w if i % 2 else yy / h) for i in range(3)], axis=-1)
            colour += rng.normal(0, 3, colour.shape)
            art = np.dstack([np.clip(colour, 0, 255), alpha]).astype(np.uint8)
            art[alpha == 0] = 0
            if gap is None:
                x, y = (c % columns) * cell_w + 2, (c // columns) * cell_h + 2
            else:
                if row_x + w > width:  # the next row
                    row_x, row_y, row_h = 0, row_y + row_h + gap, 0
                x, y = row_x, row_y
                row_x, row_h = row_x + w + gap, max(row_h, h)
            page.paste(Image.fromarray(art), (x, y))
            region = f"part{index:03d}"
            lines += [region, f"bounds: {x}, {y}, {w}, {h}"]
            slots.append({"name": region, "bone": "root", "attachment": region})
            skin[region] = {region: {"x": float(index % 20 * 50), "y": float(index // 20 * 50), "width": w,
                                     "height": h}}
            index += 1
        page.save(folder / name)
        lines.append("")  # a blank line before the next page
    (folder / "made.atlas").write_text("\n".join(lines) + "\n")
    skeleton = {"skeleton": {"spine": "4.2.40", "images": "./images/"}, "bones": [{"name": "root"}],
                "slots": slots, "skins": [{"name": "default", "attachments": skin}], "animations": {}}
    (folder / "made.json").write_text(json.dumps(skeleton))
    return folder


def phases(stats_file: str, top: int = 12) -> str:
    """Where one process's CPU time went: functions by their own CPU time, the largest first."""
    import pstats

    stats = pstats.Stats(stats_file).stats
    own: dict[str, float] = {}
    for (path, _, name), (_, _, tottime, _, _) in stats.items():
        where = "spinemesh." + Path(path).stem if "spinemesh" in path else Path(path).name or "built-in"
        key = f"{where}:{name}"
        own[key] = own.get(key, 0.0) + tottime
    total = sum(own.values())
    lines = ["| function (own time) | s | share |", "|---|---:|---:|"]
    for key, seconds in sorted(own.items(), key=lambda kv: -kv[1])[:top]:
        lines.append(f"| {key} | {seconds:.2f} | {seconds / total:.0%} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--jobs", nargs="+", default=["1", "2"], help="--jobs values to run (default 1 2)")
    ap.add_argument("--code", nargs="*", type=Path, default=[], metavar="DIR",
                    help="other checkouts to compare with (their root, holding spinemesh/)")
    ap.add_argument("--many", type=int, metavar="N", help="instead: N regions on one page")
    ap.add_argument("--side", type=int, default=4096, help="with --many: the page's side (default 4096)")
    ap.add_argument("--made", type=int, nargs=2, metavar=("PAGES", "REGIONS"), help="instead: an atlas of REGIONS "
                    "regions on PAGES pages made here, upgraded, then packed")
    ap.add_argument("--gap", type=int, default=2, help="with --made: texels between the regions, laid row by row "
                    "(default 2, as Spine's packer leaves them); -1: one region a grid cell, far apart")
    ap.add_argument("--keep", type=Path, metavar="DIR", help="with --made: make and upgrade it here once, and reuse")
    ap.add_argument("--phases", action="store_true", help="with --made: where the CPU time of --jobs 1 goes")
    ap.add_argument("--oxipng-threads", type=int, nargs="+", metavar="N", help="instead: pack each PROJECT for "
                    "every --jobs with oxipng on N threads each (0: its default, one per core), and say where its "
                    "oxipng calls ran (summed, side by side, in how many processes)")
    args = ap.parse_args(argv)
    if args.oxipng_threads:
        print(f"load average before: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
        print(oxipng_table(args.projects, args.jobs, args.oxipng_threads))
        print(f"load average after: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
        return 0
    codes = [("this checkout", REPO)] + [(str(c), c.resolve()) for c in args.code]
    if args.many:
        print("| code | regions | page | CPU s | peak memory MB | outcome |\n|---|---:|---|---:|---:|---|")
        for label, code in codes:
            m = measure(code, "many", str(args.many), str(args.side))
            outcome = m.get("kept") or f"{m['pages']} page(s), {m['texels']:,} texels"
            print(f"| {label} | {args.many:,} | {args.side}x{args.side} | {m['cpu']:.1f} | {m['peak_mb']:.0f} | "
                  f"{outcome} |", flush=True)
        return 0
    if args.made:
        return made(args, codes)
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


def made(args, codes: list) -> int:
    """``--made``: make the atlas, upgrade it, then time ``pack`` of it for every ``--jobs`` and code."""
    import time

    pages, regions = args.made
    folder = args.keep or Path(tempfile.mkdtemp(prefix="bench-pack-made-"))
    project, meshed = folder / "made", folder / "meshed"
    if not (meshed / ".upgraded").exists():
        sys.path.insert(0, str(REPO))
        from spinemesh.upgrade import Options, upgrade_project

        make_atlas_project(project, pages, regions, gap=None if args.gap < 0 else args.gap)
        t0 = time.perf_counter()
        upgrade_project(project, meshed, Options(jobs=int(args.jobs[-1]), overwrite=True))
        (meshed / ".upgraded").write_text("")
        print(f"made {pages} pages, {regions} regions in {project}; upgraded in {time.perf_counter() - t0:.1f} s "
              f"to {meshed}", flush=True)
    print(f"load average before: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    print("| code | --jobs | wall s | wall against the first row | CPU s | peak memory MB | pages | page texels "
          "| by outline | by rectangle | bytes |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    first = None
    for label, code in codes:
        for jobs in args.jobs:
            with tempfile.TemporaryDirectory(prefix="bench-pack-scale-") as scratch:
                m = measure(code, "pack", str(meshed.resolve()), str(Path(scratch) / "out"), jobs)
            first = first or m["wall"]
            print(f"| {label} | {jobs} | {m['wall']:.1f} | {m['wall'] / first:.2f} | {m['cpu']:.1f} | "
                  f"{m['peak_mb']:.0f} | {pages} -> {m['pages']} | {m['texels']:,} | {m['by_outline']} | "
                  f"{m['by_rectangle']} | {m['bytes_before']:,} -> {m['bytes_after']:,} |", flush=True)
    print(f"load average after: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    if args.phases:
        with tempfile.TemporaryDirectory(prefix="bench-pack-scale-") as scratch:
            stats = str(Path(scratch) / "pack.prof")
            m = measure(REPO, "pack", str(meshed.resolve()), str(Path(scratch) / "out"), "1", stats)
            print(f"\n--jobs 1 under cProfile: wall {m['wall']:.1f} s, CPU {m['cpu']:.1f} s")
            print(phases(stats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
