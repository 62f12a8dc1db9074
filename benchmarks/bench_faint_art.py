"""What covering faint art costs: which texels ``upgrade`` meshes, and with what margin.

For a sample of region images of real projects (each with the blend mode of the slot it is
drawn in), each is meshed the way ``upgrade`` does (stored part only, sampling margin), side
by side:

- ``alpha >= 8``: the mesher's default threshold (what ``upgrade`` did before issue #17);
- ``every drawn texel``: alpha >= 1, on premultiplied pages also colour > 0 at alpha 0, with a
  whole texel of margin (what ``upgrade`` did after #17);
- ``per slot``: in normal slots the texels that can move a pixel by more than 2/255
  (``images.FAINT_TEXEL``), in additive/multiply/screen slots every drawn texel; whole-texel
  margin;
- ``per slot, half-texel margin, tolerance <= 16 px``: the same with the hull moved half a
  texel back in (``MesherParams.hull_inset``) and its tolerance capped on large art
  (``MesherParams.max_hull_tolerance``): what ``upgrade`` does now.

Printed per variant: images, vertices (median, mean, p90), mesh area as a share of the image,
waste (share of the mesh area over texels that draw nothing), images whose mesh is the whole
stored rectangle, texels the runtime draws that lie outside the mesh, and texels that can show
in their slot (the per-slot rule) that lie outside it.

    .venv/bin/python benchmarks/bench_faint_art.py ../shared/spine-corpus --sample 200
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from spinemesh.errors import SpineMeshError
from spinemesh.metrics import mesh_area, uncovered_pixels
from spinemesh.project import find_project, image_source_for
from spinemesh.skeleton import image_paths, iter_attachments, load_skeleton
from spinemesh.upgrade.meshing import mesh_one
from spinemesh.upgrade.options import Options
from spinemesh.upgrade.plan import task_for_frames

#: name -> (slot blend mode to plan with: None for the attachment's own, mesher overrides)
BEFORE_20 = {"hull_inset": 0.0, "max_hull_tolerance": 0.0}  # the margin and tolerance before #20's follow-up
VARIANTS = {"alpha >= 8": ("additive", {"alpha_threshold": 8, **BEFORE_20}),
            "every drawn texel": ("additive", BEFORE_20),
            "per slot": (None, BEFORE_20),
            "per slot, half-texel margin, tolerance <= 16 px": (None, {})}


def sample_tasks(roots: list[Path], sample: int) -> list:
    """Up to ``sample`` unique single-image regions ``(frames, blend)``, about as many from each project under ``roots``."""
    tasks = {}
    folders = [p for root in roots for p in sorted(root.iterdir()) if p.is_dir()]
    per = sample // max(1, len(folders)) + 1
    for folder in folders:
        before = len(tasks)
        try:
            proj = find_project(folder)
        except SpineMeshError:
            continue
        for skeleton in proj.skeletons:
            try:
                doc = load_skeleton(skeleton)
                source = image_source_for(doc, skeleton, proj)
            except SpineMeshError:
                continue
            if source is None:
                continue
            blends = {s.get("name"): s.get("blend", "normal") for s in doc.get("slots", [])}
            for ref in iter_attachments(doc):
                if ref.type != "region" or ref.attachment.get("sequence"):
                    continue
                try:
                    frames = [source.get(p) for p in image_paths(ref)]
                except SpineMeshError:
                    continue
                blend = blends.get(ref.slot, "normal")
                task, status, _ = task_for_frames(frames, Options(), blend)
                if task is not None:
                    tasks.setdefault(task.key, (frames, blend))
                if len(tasks) - before >= per:
                    break
            if len(tasks) - before >= per:
                break
    return list(tasks.values())[:sample]


def measure(sampled: tuple, variant: tuple) -> dict:
    """Mesh one sampled image as ``variant`` says; vertices, area share, waste, texels left out."""
    frames, blend = sampled
    plan_blend, overrides = variant
    task, _, reason = task_for_frames(frames, Options(), plan_blend or blend)
    if task is None:
        return {"failed": reason}
    drawn = task_for_frames(frames, Options(), "additive")[0].drawn  # every texel drawn
    shows = task_for_frames(frames, Options(), blend)[0].drawn  # what can show in its slot
    task.settings = ("default", "alpha", tuple(sorted(overrides.items())))
    res = mesh_one(task)
    if res.vertices is None:
        return {"failed": res.error}
    h, w = task.rgba.shape[:2]
    local = res.vertices - task.origin
    area = mesh_area(local, res.triangles)
    rect = float(w * h)
    return {"vertices": len(res.vertices), "area": area / rect,
            "waste": max(0.0, 1.0 - float(drawn.sum()) / area) if area > 0 else 0.0,
            "whole": area >= rect * (1 - 1e-9),
            "left_out": len(uncovered_pixels(local, res.triangles, drawn)),
            "shown_left_out": len(uncovered_pixels(local, res.triangles, shows))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("roots", nargs="+", type=Path, help="folders of projects")
    ap.add_argument("--sample", type=int, default=200)
    args = ap.parse_args(argv)
    tasks = sample_tasks(args.roots, args.sample)
    rows = {name: [measure(t, v) for t in tasks] for name, v in VARIANTS.items()}
    print(f"{len(tasks)} unique region images, {sum(b != 'normal' for _, b in tasks)} of them in "
          f"additive, multiply or screen slots\n")
    print("| mask | meshed | vertices median / mean / p90 | mesh area / image | waste | whole rectangle | "
          "drawn texels left out | texels that can show left out |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for name, results in rows.items():
        ok = [r for r in results if "failed" not in r]
        v = np.array([r["vertices"] for r in ok])
        print(f"| {name} | {len(ok)} | {np.median(v):.0f} / {v.mean():.1f} / {np.percentile(v, 90):.0f} | "
              f"{np.mean([r['area'] for r in ok]):.3f} | {np.mean([r['waste'] for r in ok]):.3f} | "
              f"{sum(r['whole'] for r in ok)} | {sum(r['left_out'] for r in ok)} | "
              f"{sum(r['shown_left_out'] for r in ok)} |")
    names = list(rows)
    for before, after in zip(names, names[1:]):
        changed = sum(a.get("area") != b.get("area") for a, b in zip(rows[before], rows[after]))
        print(f"\nimages whose mesh changed from {before!r} to {after!r}: {changed} of {len(tasks)}", end="")
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
