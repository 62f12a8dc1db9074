"""Pose sampling speed: spinemesh.anim beside the official runtime (Node harness).

For each skeleton, its first animation is sampled at 30 frames per second over one loop:

* ``ours pose``: :meth:`spinemesh.anim.Sampler.pose` per frame (each pose on its own: with
  4.2 physics, a replay of the game loop from 0);
* ``ours play``: :meth:`~spinemesh.anim.Sampler.play`, one game loop through all frames;
* ``runtime``: the harness's dump of the same poses (``dump.mjs --poses``), minus its load
  time, per pose; it also plays each pose from 0, like ``ours pose``.

Times are milliseconds per frame (best of ``--repeat``); the ratio columns are ours / runtime.

    .venv/bin/python benchmarks/bench_poses.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
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


def main(argv=None) -> int:
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
