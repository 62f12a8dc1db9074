"""Memory of ``upgrade`` over large atlas pages decoded ahead by workers, side by side with another tree.

A library of ``--projects`` copies of the demo project (drawn by our own code), each with its
page grown to ``--side`` x ``--side`` texels (the demo's art in a corner, the rest transparent,
so that decoding a page makes ``4 * side**2`` bytes while the file stays small), is upgraded
with ``--jobs 1`` and ``--jobs 2``. The peak memory of the whole process tree (the sum of the
proportional set sizes, ``Pss`` of ``/proc/PID/smaps_rollup``, so that a page shared between a
worker and the parent counts once) is sampled every 50 ms. Each tree named by ``--tree`` (a
source checkout: its folder goes first on ``PYTHONPATH``) runs the same commands, taking turns.

Usage::

    .venv/bin/python benchmarks/bench_page_memory.py [--projects 12] [--side 9400] [--tree . --tree ../main]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def make_library(root: Path, projects: int, side: int) -> Path:
    """``root/L/d0 ... dN``: the demo project with a ``side`` x ``side`` page, colours differing per copy."""
    import numpy as np
    from PIL import Image

    demo = REPO / "examples" / "demo"
    library = root / "L"
    art = np.array(Image.open(demo / "demo.png").convert("RGBA"))
    for i in range(projects):
        dest = library / f"d{i}"
        shutil.copytree(demo, dest, ignore=shutil.ignore_patterns("*.skel", "images"))
        corner = art.copy()
        corner[..., :3] = (corner[..., :3].astype(int) + 7 * (i + 1)) % 256
        page = np.zeros((side, side, 4), np.uint8)
        page[:art.shape[0], :art.shape[1]] = corner
        Image.fromarray(page).save(dest / "demo.png", compress_level=1)
        del page
        atlas = dest / "demo.atlas"
        atlas.write_text(atlas.read_text().replace("size: 512, 256", f"size: {side}, {side}"))
    return library


def _tree_pss(pid: int) -> int:
    """Bytes of proportional set size of ``pid`` and its descendants."""
    total, stack = 0, [pid]
    while stack:
        p = stack.pop()
        try:
            for line in Path(f"/proc/{p}/smaps_rollup").read_text().splitlines():
                if line.startswith("Pss:"):
                    total += int(line.split()[1]) * 1024
            for task in Path(f"/proc/{p}/task").iterdir():
                stack += [int(c) for c in (task / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            pass
    return total


def peak_memory(tree: Path, args: list[str], cwd: Path) -> tuple[int, float, int]:
    """Peak tree PSS (bytes), wall seconds and exit status of ``python -m spinemesh ARGS``."""
    env = {**os.environ, "PYTHONPATH": str(tree.resolve()), "COLUMNS": "80"}
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "spinemesh", *args], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    peak = 0
    while proc.poll() is None:
        peak = max(peak, _tree_pss(proc.pid))
        time.sleep(0.05)
    return peak, time.perf_counter() - t0, proc.returncode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--projects", type=int, default=12)
    parser.add_argument("--side", type=int, default=9400)
    parser.add_argument("--tree", type=Path, action="append", help="source checkout to run (repeatable; "
                        "default: this one)")
    parser.add_argument("--jobs", type=int, action="append", help="--jobs values (default 1 and 2)")
    a = parser.parse_args()
    trees = a.tree or [REPO]
    jobs = a.jobs or [1, 2]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        make_library(tmp, a.projects, a.side)
        page_mb = 4 * a.side * a.side / 1e6
        print(f"{a.projects} projects, one {a.side}x{a.side} page each ({page_mb:,.0f} MB decoded)\n")
        print(f"| tree | --jobs | peak of the process tree (MB) | vs first tree | wall (s) | exit |")
        print("|---|---|---|---|---|---|")
        first: dict[int, int] = {}
        for j in jobs:
            for tree in trees:
                out = tmp / "o"
                shutil.rmtree(out, ignore_errors=True)
                peak, wall, code = peak_memory(tree, ["upgrade", "L", "--out", str(out), "--jobs", str(j)], tmp)
                first.setdefault(j, peak)
                print(f"| {tree} | {j} | {peak / 1e6:,.0f} | {peak / first[j]:.2f} | {wall:.1f} | {code} |",
                      flush=True)


if __name__ == "__main__":
    main()
