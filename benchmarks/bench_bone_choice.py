"""Speed of the ``auto`` bone choice's measurement: all bones in one pass against one bone at a time.

:func:`spinemesh.rig.choice.lengths_on_art` measures every bone's length over the art from
arrays (segments, box test, sample points, distances in cache-sized chunks). The alternative
is what it replaced: for each bone, a box test, then :func:`~spinemesh.rig.choice.distance_to_art`
on that bone's own samples. Both are run on the same inputs, taking turns, and must give the
same lengths (the script stops otherwise). Inputs, per skeleton of the given projects:

- *region quads*: every region attachment's rectangle in the setup pose, as
  ``upgrade --weights auto`` tests it before meshing (:class:`spinemesh.rig.upgraded_meshes.BendingRegions`);
- *artist meshes*: every mesh attachment's setup-pose triangles, as ``spinemesh weights --bones auto``
  measures them.

Times are this process's CPU seconds, best of ``--repeat`` rounds per project.

Usage::

    .venv/bin/python benchmarks/bench_bone_choice.py [PROJECT ...] [--repeat 3]

Without projects: the 4.2 examples and the corpus beside the repository (``../shared``).
"""

from __future__ import annotations

import argparse
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.rig.binding import parse_vertices, setup_world  # noqa: E402
from spinemesh.rig.choice import distance_to_art, lengths_on_art  # noqa: E402
from spinemesh.rig.document import build_rig  # noqa: E402
from spinemesh.rig.upgraded_meshes import QUAD_TRIANGLES, QUAD_UV, BendingRegions  # noqa: E402
from spinemesh.skeleton import iter_attachments, load_skeleton  # noqa: E402

SHARED = REPO.parent / "shared"


def one_bone_at_a_time(bones, world: np.ndarray, triangles: np.ndarray, near: float,
                       samples: int = 65) -> dict[int, float]:
    """The alternative: :func:`lengths_on_art`'s result, measured bone by bone."""
    lo, hi = world.min(axis=0) - near, world.max(axis=0) + near
    out = {}
    for bone in bones:
        a, b = seg = bone.segment()
        if (seg.max(axis=0) < lo).any() or (seg.min(axis=0) > hi).any():
            continue
        if bone.length == 0:
            if distance_to_art(a[None], world, triangles)[0] <= near:
                out[bone.index] = 0.0
            continue
        span = float(np.linalg.norm(b - a))
        close = distance_to_art(a + np.linspace(0, 1, samples)[:, None] * (b - a), world, triangles) <= near
        length = span * float(close.mean()) if span else (near if close[0] else 0.0)
        if length > 0:
            out[bone.index] = length
    return out


def inputs(project: Path) -> dict[str, list[tuple]]:
    """``(bones, world, triangles)`` of every region quad and mesh of the project's skeletons."""
    out = {"region quads": [], "artist meshes": []}
    for skel in sorted(project.rglob("*.json")) + sorted(project.rglob("*.skel")):
        try:
            doc = load_skeleton(skel)
            rig = build_rig(doc)
        except (SpineMeshError, ValueError, KeyError, TypeError):
            continue  # not a skeleton the rig reads: nothing to measure
        regions = BendingRegions.of(rig)
        for ref in iter_attachments(doc):
            try:
                if ref.type == "region":
                    world = regions.world(ref, QUAD_UV)
                    if world is not None:
                        out["region quads"].append((rig.bones, world, QUAD_TRIANGLES))
                elif ref.type == "mesh" and ref.slot in rig.slot_bone:
                    mesh = parse_vertices(ref.attachment, len(rig.bones))
                    tris = np.asarray(ref.attachment.get("triangles", []), int).reshape(-1, 3)
                    if len(tris) and tris.max() < mesh.count:
                        out["artist meshes"].append((rig.bones, setup_world(mesh, rig.worlds, rig.slot_bone[ref.slot]), tris))
            except SpineMeshError:
                continue  # an attachment the rig cannot place
    return out


def best_cpu(fn, cases: list[tuple], repeat: int) -> tuple[float, list]:
    """``fn(*case)`` for every case, ``repeat`` rounds: the best round's CPU seconds, and the results."""
    best, results = float("inf"), []
    for _ in range(repeat):
        t = time.process_time()
        results = [fn(*case) for case in cases]
        best = min(best, time.process_time() - t)
    return best, results


def default_projects() -> list[Path]:
    """The 4.2 examples and the corpus beside the repository."""
    return (sorted(p for p in (SHARED / "spine-examples" / "4.2").iterdir() if p.is_dir())
            + sorted(p for p in (SHARED / "spine-corpus").iterdir() if p.is_dir()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    projects = args.projects or default_projects()
    totals = {k: [0, 0.0, 0.0] for k in ("region quads", "artist meshes")}
    slowest = []
    for project in projects:
        for kind, cases in inputs(project).items():
            if not cases:
                continue
            # taking turns, so that what load there is hits both alike
            old, expected = best_cpu(partial(one_bone_at_a_time, near=0.0), cases, args.repeat)
            new, got = best_cpu(partial(lengths_on_art, near=0.0), cases, args.repeat)
            for e, g in zip(expected, got):
                if e.keys() != g.keys() or any(abs(e[k] - g[k]) > 1e-9 * max(1.0, abs(e[k])) for k in e):
                    sys.exit(f"{project.name}: the two measurements differ ({kind})")
            totals[kind][0] += len(cases)
            totals[kind][1] += old
            totals[kind][2] += new
            slowest.append((old, project.name, kind, len(cases), new))
    print("| input | count | one bone at a time, CPU s | all bones at once, CPU s | speed-up |")
    print("|---|--:|--:|--:|--:|")
    for kind, (n, old, new) in totals.items():
        print(f"| {kind} | {n:,} | {old:.2f} | {new:.2f} | {old / max(new, 1e-9):.2f}x |")
    print("\nslowest projects (one bone at a time):\n")
    print("| project | input | count | one bone at a time, CPU s | all bones at once, CPU s | speed-up |")
    print("|---|---|--:|--:|--:|--:|")
    for old, name, kind, n, new in sorted(slowest, reverse=True)[:5]:
        print(f"| {name} | {kind} | {n:,} | {old:.2f} | {new:.2f} | {old / max(new, 1e-9):.2f}x |")


if __name__ == "__main__":
    main()
