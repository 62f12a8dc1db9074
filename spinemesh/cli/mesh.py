"""``spinemesh mesh``: auto-mesh one image or a folder of images."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from ..errors import SpineMeshError
from ..fsutil import atomic_write_json, atomic_write_png
from ..images import IMAGE_EXTENSIONS, load_rgba
from ._app import app, console, err_console


def _overrides(density, max_vertices, alpha_threshold, mask) -> dict:
    out = {}
    if density is not None:
        out["density"] = density
    if max_vertices is not None:
        out["max_vertices"] = max_vertices
    if alpha_threshold is not None:
        out["alpha_threshold"] = alpha_threshold
    if mask is not None:
        out["mask_source"] = mask
    return out


def _one(image_path: Path, preset: str, overrides: dict, out: Path, preview: Optional[Path],
         steps: Optional[Path]):
    from ..mesher import compute_mask, mesh_image, resolve_params
    from ..mesher.preview import preview as draw_preview
    from ..mesher.preview import steps_figure

    rgba = load_rgba(image_path)
    params = resolve_params(preset, **overrides)
    mask = compute_mask(rgba, params.mask_source, params.alpha_threshold)
    mesh = mesh_image(rgba, params, mask=mask)
    mesh.info["preset"] = preset
    mesh.info["image"] = image_path.name
    doc = mesh.to_json()
    doc["info"].pop("ms", None)  # timing would make the file differ from run to run
    atomic_write_json(out, doc, indent=None)
    if preview is not None:
        atomic_write_png(preview, draw_preview(rgba, mesh))
    if steps is not None:
        atomic_write_png(steps, steps_figure(rgba, mask, mesh))
    return mesh


@app.command()
def mesh(
    image: Path = typer.Argument(..., help="An image (PNG, WebP, AVIF, JPEG) or a folder of images."),
    preset: str = typer.Option("default", "--preset", "-p", help="default (for animation) or paper (sec. 3 exactly)."),
    out: Optional[Path] = typer.Option(None, "--out", "-o",
                                       help="mesh.json to write (a folder when IMAGE is a folder). "
                                            "Default: IMAGE.mesh.json beside the image, or IMAGE-meshes/ for a folder."),
    preview: Optional[Path] = typer.Option(None, "--preview", help="PNG of the wireframe over the sprite (a folder for a folder)."),
    steps: Optional[Path] = typer.Option(None, "--steps", help="PNG of the paper's six-panel pipeline figure (a folder for a folder)."),
    density: Optional[float] = typer.Option(None, "--density", help="Vertex density: 1 artist-like (default), ~4 paper-like."),
    max_vertices: Optional[int] = typer.Option(None, "--max-vertices", help="Hard vertex budget per image."),
    alpha_threshold: Optional[int] = typer.Option(None, "--alpha-threshold", help="Art is alpha >= this (default 8; paper 129)."),
    mask: Optional[str] = typer.Option(None, "--mask", help="alpha, model or auto (network for images without alpha)."),
) -> None:
    """Auto-mesh sprite images into triangle meshes (mesh.json, see docs in spinemesh.mesher.mesh).

    Exterior vertices are drawn blue and interior vertices yellow in --preview and --steps;
    --steps is the paper's six panels (input, mask, exterior, interior, triangles, final) for
    tuning parameters on one image.

    Example: spinemesh mesh ../shared/spine-examples/4.2/spineboy/images/torso.png --out torso.json --preview torso.png --steps steps.png

    Example: spinemesh mesh ../shared/spine-examples/4.2/owl/images --out owl-meshes/ --preview owl-previews/
    """
    overrides = _overrides(density, max_vertices, alpha_threshold, mask)
    from ..mesher import PRESETS

    if preset not in PRESETS:
        raise typer.BadParameter(f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}")
    if image.is_dir():
        files = sorted(p for p in image.rglob("*") if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS)
        if not files:
            raise SpineMeshError("no image files in this folder", image)
        out_dir = out or image.with_name(image.name + "-meshes")
        rows = []
        failed = 0
        with Progress(TextColumn("[bold]meshing"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                      TextColumn("{task.description}"), console=err_console) as bar:
            task = bar.add_task("", total=len(files))
            for f in files:
                rel = f.relative_to(image).with_suffix("")
                bar.update(task, description=str(rel))
                try:
                    m = _one(f, preset, overrides, out_dir / rel.with_suffix(".json"),
                             preview / rel.with_suffix(".png") if preview else None,
                             steps / rel.with_suffix(".png") if steps else None)
                    rows.append((str(rel), m))
                except SpineMeshError as e:
                    failed += 1
                    err_console.print(f"[yellow]skipped:[/] {e}")
                bar.advance(task)
        verts = sorted(len(m.vertices) for _, m in rows)
        console.print(f"{len(rows)} meshes written to {out_dir}"
                      + (f", median {verts[len(verts) // 2]} vertices" if verts else "")
                      + (f"; {failed} image(s) skipped" if failed else ""))
        if failed and not rows:
            raise typer.Exit(2)
        return
    target = out or image.with_name(image.name + ".mesh.json")
    m = _one(image, preset, overrides, target, preview, steps)
    t = Table(title=f"{image.name} ({m.width}x{m.height}, preset {preset})")
    for col in ("vertices", "hull", "interior", "triangles", "constrained edges"):
        t.add_column(col, justify="right")
    t.add_row(str(len(m.vertices)), str(m.hull), str(int(m.is_interior.sum())), str(len(m.triangles)), str(len(m.edges)))
    console.print(t)
    console.print(f"wrote {target}" + (f", {preview}" if preview else "") + (f", {steps}" if steps else ""))
