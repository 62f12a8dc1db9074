"""How far each mesh an upgrade made moves from where its region drew the same art, in every animation.

    .venv/bin/python scripts/watch_bending.py PROJECT UPGRADED [--step 0.1] [--top 25]

``UPGRADED`` is ``spinemesh upgrade PROJECT --out UPGRADED`` (with ``--weights auto``: the meshes
that bend). For each skeleton, skin (at most four) and animation, sampled every ``--step`` seconds
with spinemesh's pose sampler on one game loop, every attachment drawn as a region in the original
and as a mesh in the upgrade is compared: each mesh vertex against the point of the region's quad
that draws the same texel (the quad's affine map of its UVs). A mesh that follows its slot's bone
alone is at 0; one that bends moves its vertices by how much it bends; a bone that carries the art
away shows as a distance as large as the art. Prints the worst pose of each attachment, largest
share of the region's size first: world units, that share, skeleton, skin, animation, time, slot
and attachment, the vertex, the region's larger side.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def quad_distances(region, mesh) -> np.ndarray:
    """Per vertex of ``mesh`` (a drawn slot of :class:`spinemesh.anim.Sampler`), its distance
    from where the quad of ``region`` (the same attachment drawn as a region) puts its UV."""
    quad = np.asarray(region.vertices, float).reshape(-1, 2)
    uv = np.asarray(region.uvs, float).reshape(-1, 2)
    affine, *_ = np.linalg.lstsq(np.c_[uv, np.ones(len(uv))], quad, rcond=None)
    muv = np.asarray(mesh.uvs, float).reshape(-1, 2)
    want = np.c_[muv, np.ones(len(muv))] @ affine
    return np.linalg.norm(np.asarray(mesh.vertices, float).reshape(-1, 2) - want, axis=1)


def watch(project: Path, upgraded: Path, step: float) -> list[tuple]:
    from spinemesh.anim import Sampler, atlas_regions
    from spinemesh.atlas import read_atlas
    from spinemesh.player.frames import sampled_skins
    from spinemesh.project import find_project
    from spinemesh.skeleton import load_skeleton

    proj = find_project(project)
    regions = atlas_regions(read_atlas(proj.atlases[0])) if proj.atlases else None
    rows = []
    for path in proj.skeletons:
        rel = path.relative_to(proj.root)
        before, after = load_skeleton(path), load_skeleton(upgraded / rel)
        for skin in sampled_skins(after):
            arg = None if skin == "default" else skin
            a, b = Sampler(before, arg, regions), Sampler(after, arg, regions)
            for name in [None] + a.animation_names():
                duration = float(a.duration(name)) if name else 0.0
                times = list(np.arange(0.0, duration, step)) if duration > 0 else [0.0]
                pairs = zip(a.play(name, times), b.play(name, times)) if name else [(a.pose(None), b.pose(None))]
                for t, (x, y) in zip(times, pairs):
                    drawn = {(s.slot, s.key): s for s in x.slots}
                    for s in y.slots:
                        r = drawn.get((s.slot, s.key))
                        if r is None or r.type != "region" or s.type != "mesh" or len(r.vertices) != 4:
                            continue
                        d = quad_distances(r, s)
                        size = float(max(np.ptp(np.asarray(r.vertices, float).reshape(-1, 2), axis=0).max(), 1e-9))
                        label = skin if isinstance(skin, str) else " + ".join(skin)
                        rows.append((float(d.max()), float(d.max()) / size, str(rel), label, name, round(float(t), 3),
                                     s.slot, s.key, int(d.argmax()), size))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("project", type=Path)
    ap.add_argument("upgraded", type=Path)
    ap.add_argument("--step", type=float, default=0.1, help="seconds between the poses compared (default 0.1)")
    ap.add_argument("--top", type=int, default=25, help="attachments printed (default 25)")
    args = ap.parse_args()
    rows = sorted(watch(args.project.resolve(), args.upgraded.resolve(), args.step), key=lambda r: -r[1])
    worst = {}
    for r in rows:
        worst.setdefault((r[2], r[3], r[6], r[7]), r)
    print(f"{len(rows)} attachment poses; the worst of each attachment:")
    print("   units  share  skeleton  skin  animation  time  slot/attachment  vertex  region size")
    for r in list(worst.values())[:args.top]:
        print(f"{r[0]:8.1f} {r[1]:6.2f}  {r[2]}  {r[3]}  {r[4]}  t={r[5]}  {r[6]}/{r[7]}  v{r[8]}  {r[9]:.0f}")


if __name__ == "__main__":
    main()
