"""What covering faint art costs: ``upgrade`` meshes every texel the runtime draws, not just alpha >= 8.

For a sample of region images of real projects, each is meshed the way ``upgrade`` does
(stored part only, one texel of sampling margin) twice, side by side:

- ``alpha >= 8``: the mesher's default threshold (what ``upgrade`` did before);
- ``drawn``: every texel the runtime draws anything with (alpha >= 1; on premultiplied pages
  also colour > 0 at alpha 0), what ``upgrade`` does now.

Printed per variant: images, vertices (median, mean, p90), mesh area as a share of the image,
waste (share of the mesh area over texels that draw nothing), images whose mesh is the whole
stored rectangle, and texels the runtime draws that lie outside the mesh.

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
from spinemesh.upgrade.run import Options, mesh_one, task_for_frames

VARIANTS = {"alpha >= 8": {"alpha_threshold": 8}, "drawn": {}}


def sample_tasks(roots: list[Path], sample: int) -> list:
    """Up to ``sample`` unique single-image region tasks, about as many from each project under ``roots``."""
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
            for ref in iter_attachments(doc):
                if ref.type != "region" or ref.attachment.get("sequence"):
                    continue
                try:
                    frames = [source.get(p) for p in image_paths(ref)]
                except SpineMeshError:
                    continue
                task, status, _ = task_for_frames(frames, Options())
                if task is not None:
                    tasks.setdefault(task.key, task)
                if len(tasks) - before >= per:
                    break
            if len(tasks) - before >= per:
                break
    return list(tasks.values())[:sample]


def measure(task, overrides: dict) -> dict:
    """Mesh ``task`` with ``overrides``; vertices, area share, waste and drawn texels left out."""
    task.settings = ("default", "alpha", tuple(sorted(overrides.items())))
    res = mesh_one(task)
    if res.vertices is None:
        return {"failed": res.error}
    h, w = task.rgba.shape[:2]
    local = res.vertices - task.origin
    area = mesh_area(local, res.triangles)
    drawn_area = float(task.drawn.sum())
    rect = float(w * h)
    return {"vertices": len(res.vertices), "area": area / rect,
            "waste": max(0.0, 1.0 - drawn_area / area) if area > 0 else 0.0,
            "whole": area >= rect * (1 - 1e-9),
            "left_out": len(uncovered_pixels(local, res.triangles, task.drawn))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("roots", nargs="+", type=Path, help="folders of projects")
    ap.add_argument("--sample", type=int, default=200)
    args = ap.parse_args(argv)
    tasks = sample_tasks(args.roots, args.sample)
    rows = {name: [measure(t, o) for t in tasks] for name, o in VARIANTS.items()}
    print(f"{len(tasks)} unique region images\n")
    print("| mask | meshed | vertices median / mean / p90 | mesh area / image | waste | whole rectangle | drawn texels left out |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for name, results in rows.items():
        ok = [r for r in results if "failed" not in r]
        v = np.array([r["vertices"] for r in ok])
        print(f"| {name} | {len(ok)} | {np.median(v):.0f} / {v.mean():.1f} / {np.percentile(v, 90):.0f} | "
              f"{np.mean([r['area'] for r in ok]):.3f} | {np.mean([r['waste'] for r in ok]):.3f} | "
              f"{sum(r['whole'] for r in ok)} | {sum(r['left_out'] for r in ok)} |")
    changed = sum(a.get("vertices") != b.get("vertices") for a, b in zip(*rows.values()))
    print(f"\nimages whose mesh changed: {changed} of {len(tasks)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
