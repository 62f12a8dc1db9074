"""Speed of the bone choice's distances to the art, against the two ways it replaced.

The learned bone choice measures, for every bone near a mesh, how far 33 points along its
segment lie from the art (:func:`spinemesh.rig.learned.sample_distances`); the rule measures
65 (:func:`spinemesh.rig.choice.lengths_on_art`). Both now call
:func:`spinemesh.rig.choice.distance_to_art`: the distance to the nearest edge of the art's
outline (:func:`~spinemesh.rig.choice.outline_edges`), 0 inside a triangle. The alternatives,
run on the same points, taking turns:

- *STRtree*: shapely's spatial index of the triangles and its nearest query, which the
  learned choice used. ``distance_to_art`` must give its distances to the last bit (the
  script stops otherwise): the learned model was fitted on them.
- *every edge*: every edge of every triangle at once, which the rule used. Its distances
  may differ in the last bits, and it tests each triangle alone: a point on an edge two
  triangles share may be rounded off both, and a point a rounding away from the outline may
  come out on the art or off it. Both are counted, with how far the latter lie.

Inputs, per skeleton of the given projects (as :mod:`bench_bone_choice` reads them): the
sample points of every bone within the learned choice's reach of each region quad
(``upgrade --weights auto``) and each artist mesh (``spinemesh weights``).

Times are this process's CPU seconds, best of ``--repeat`` rounds per project.

Usage::

    .venv/bin/python benchmarks/bench_art_distance.py [PROJECT ...] [--repeat 3] [--every-edge]

Without projects: the 4.2 examples and the corpus beside the repository (``../shared``).
``--every-edge`` adds the third column (slow: minutes on the corpus).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bench_bone_choice import best_cpu, default_projects, inputs  # noqa: E402

from spinemesh.rig.choice import PAIRS_AT_ONCE, distance_to_art  # noqa: E402
from spinemesh.rig.learned import REACH, segment_samples  # noqa: E402


def strtree(points: np.ndarray, world: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The alternative the learned choice used: shapely's STRtree of the triangles, nearest query."""
    import shapely

    tri = world[np.asarray(triangles, int).reshape(-1, 3)]
    tree = shapely.STRtree(shapely.polygons(np.concatenate([tri, tri[:, :1]], axis=1)))
    (index, _), dist = tree.query_nearest(shapely.points(points), return_distance=True, all_matches=False)
    out = np.full(len(points), np.inf)
    np.minimum.at(out, index, dist)
    return out


def every_edge(points: np.ndarray, world: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The alternative the rule used: all points against every edge of every triangle, in chunks."""
    tri = world[np.asarray(triangles, int).reshape(-1, 3)]
    a, b = tri[None], tri[None][:, :, [1, 2, 0]]
    ab = b - a
    denom = np.maximum((ab ** 2).sum(-1), 1e-12)
    step = max(1, PAIRS_AT_ONCE // len(tri))
    out = []
    for s in range(0, len(points), step):
        p = points[s:s + step, None, None, :]
        cross = ab[..., 0] * (p[..., 1] - a[..., 1]) - ab[..., 1] * (p[..., 0] - a[..., 0])
        inside = ((cross >= 0).all(-1) | (cross <= 0).all(-1)).any(-1)
        t = np.clip(((p - a) * ab).sum(-1) / denom, 0, 1)
        d = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(axis=(1, 2))
        out.append(np.where(inside, 0.0, d))
    return np.concatenate(out) if out else np.zeros(0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--every-edge", action="store_true", help="also time every edge of every triangle (slow)")
    args = ap.parse_args()
    projects = args.projects or default_projects()
    ways = {"outline": distance_to_art, "STRtree": strtree} | ({"every edge": every_edge} if args.every_edge else {})
    totals = {k: {"cases": 0, "points": 0, "off the art": 0, "onto the art": 0, "farthest onto": 0.0,
                  **{w: 0.0 for w in ways}}
              for k in ("region quads", "artist meshes")}
    slowest = []
    for project in projects:
        for kind, found in inputs(project).items():
            cases = []
            for bones, world, tris in found:
                diag = max(float(np.linalg.norm(np.ptp(world, axis=0))), 1e-9)
                _, points = segment_samples(bones, world, REACH * diag)
                if len(points):
                    cases.append((points, world, np.asarray(tris, int).reshape(-1, 3)))
            if not cases:
                continue
            times, results = {}, {}
            for way, fn in ways.items():  # taking turns, so that what load there is hits all alike
                times[way], results[way] = best_cpu(fn, cases, args.repeat)
            for ours, theirs in zip(results["outline"], results["STRtree"]):
                if not np.array_equal(ours, theirs):
                    sys.exit(f"{project.name}: the outline's distances differ from the STRtree's ({kind})")
            row = totals[kind]
            for ours, theirs in zip(results["outline"], results.get("every edge", [])):
                # every edge tests a point against each triangle alone: rounding may put a point
                # on an edge two triangles share (a quad's diagonal) outside both; and a point a
                # rounding away from the outline may come out on it or off it
                row["off the art"] += int(((ours == 0) & (theirs > 0)).sum())
                onto = (ours > 0) & (theirs == 0)
                row["onto the art"] += int(onto.sum())
                row["farthest onto"] = max(row["farthest onto"], float(ours[onto].max(initial=0.0)))
            row["cases"] += len(cases)
            row["points"] += sum(len(c[0]) for c in cases)
            for way in ways:
                row[way] += times[way]
            slowest.append((times["STRtree"], project.name, kind, len(cases), times))
    names = list(ways)
    head = " | ".join(f"{w}, CPU s" for w in names)
    ratio = " | ".join(f"{w} / outline" for w in names[1:])
    print(f"| input | count | points | {head} | {ratio} |")
    print("|---|--:|--:|" + "--:|" * (2 * len(names) - 1))
    for kind, row in totals.items():
        cells = " | ".join(f"{row[w]:.2f}" for w in names)
        ratios = " | ".join(f"{row[w] / max(row['outline'], 1e-9):.1f}x" for w in names[1:])
        print(f"| {kind} | {row['cases']:,} | {row['points']:,} | {cells} | {ratios} |")
    if args.every_edge:
        print("\npoints on the art (outline and STRtree: 0) that every edge puts off it: "
              + ", ".join(f"{kind} {row['off the art']:,}" for kind, row in totals.items()))
        print("points off the art (outline and STRtree) that every edge puts on it: "
              + ", ".join(f"{kind} {row['onto the art']:,} (at most {row['farthest onto']:.1e} units away)"
                          for kind, row in totals.items()))
    print("\nslowest projects (STRtree):\n")
    print(f"| project | input | count | {head} | {ratio} |")
    print("|---|---|--:|" + "--:|" * (2 * len(names) - 1))
    for _, name, kind, n, times in sorted(slowest, key=lambda r: -r[0])[:5]:
        cells = " | ".join(f"{times[w]:.2f}" for w in names)
        ratios = " | ".join(f"{times[w] / max(times['outline'], 1e-9):.1f}x" for w in names[1:])
        print(f"| {name} | {kind} | {n:,} | {cells} | {ratios} |")


if __name__ == "__main__":
    main()
