"""``spinemesh mesh``: auto-mesh one image or a folder of images."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import (
    Annotated,
    MaskSource,
    Optional,
    Preset,
    app,
    console_text,
    console,
    err_console,
    positive_finite,
    progress_bar,
    refuse_default_preset_options,
)


def _overrides(density, max_vertices, alpha_threshold, mask) -> dict:
    out = {"mask_source": mask}
    if density is not None:
        out["density"] = density
    if max_vertices is not None:
        out["max_vertices"] = max_vertices
    if alpha_threshold is not None:
        out["alpha_threshold"] = alpha_threshold
    return out


def default_out(image: Path) -> Path:
    """Where ``mesh`` writes without ``--out``: the current folder, never beside the source art."""
    return Path(image.name + "-meshes") if image.is_dir() else Path(image.stem + ".mesh.json")


def _one(image_path: Path, preset: str, overrides: dict, out: Path, preview: Optional[Path],
         steps: Optional[Path], before_write=None, folder: Optional[Path] = None):
    """Mesh one image and write its outputs; ``before_write()``, when given, is called once the
    mesh is made, before the first file is written (a folder run marks its folders then). The
    ``info`` names the image by its file name, or, in a ``folder`` run, from the folder's name
    as reports name a project's files (:func:`~spinemesh.files.names.named_from`):
    ``images/sub/x.png`` and ``images/x.png`` are two images."""
    from ..errors import SpineMeshError
    from ..files.atomic import atomic_write_json, atomic_write_png
    from ..files.names import name_as_text, named_from
    from ..images.decode import load_rgba
    from ..memory import image_memory
    from ..mesher import compute_mask, mesh_image, resolve_params
    from ..mesher.preview import preview as draw_preview
    from ..mesher.preview import steps_figure

    rgba = load_rgba(image_path)
    with image_memory("mesh", image_path, rgba.shape[1], rgba.shape[0]):  # fails as this image
        params = resolve_params(preset, **overrides)
        try:
            mask = compute_mask(rgba, params.mask_source, params.alpha_threshold)
            mesh = mesh_image(rgba, params, mask=mask)
        except SpineMeshError as e:
            if e.path is None:  # the mesher's words name no file ("nothing to mesh"): this image is it
                e.path = str(image_path)
            raise
        mesh.info["preset"] = preset
        # a name of bytes not UTF-8 refused the mesh
        mesh.info["image"] = name_as_text(image_path.name if folder is None else named_from(image_path, folder))
        doc = mesh.to_json()
        doc["info"].pop("ms", None)  # timing would make the file differ from run to run
        if before_write is not None:
            before_write()
        atomic_write_json(out, doc, indent=None)
    with image_memory("draw", image_path, rgba.shape[1], rgba.shape[0]):  # the mesh is written already
        if preview is not None:
            atomic_write_png(preview, draw_preview(rgba, mesh))
        if steps is not None:
            atomic_write_png(steps, steps_figure(rgba, mask, mesh))
    return mesh


@app.command()
def mesh(
    image: Annotated[Path, typer.Argument(metavar="IMAGE", help="An image (PNG, WebP, AVIF, JPEG) or a folder of images.")],
    preset: Annotated[Preset, typer.Option("--preset", "-p", help="default: for animation; paper: the "
                                           "paper's section 3 exactly.")] = Preset.default,
    out: Annotated[Optional[Path], typer.Option(
        "--out", "-o", metavar="PATH", help="mesh.json to write (a folder when IMAGE is a folder). Default: NAME.mesh.json, "
                            "or FOLDER-meshes/ for a folder, in the current folder.")] = None,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", metavar="PATH", help="PNG of the wireframe over the sprite (a folder for a folder).")] = None,
    steps: Annotated[Optional[Path], typer.Option(
        "--steps", metavar="PATH", help="PNG of the paper's six-panel pipeline figure (a folder for a folder).")] = None,
    density: Annotated[Optional[float], typer.Option(
        "--density", callback=positive_finite,
        help="Vertex density, above 0: 1 artist-like (default), about 4 paper-like. Default preset only.")] = None,
    max_vertices: Annotated[Optional[int], typer.Option(
        "--max-vertices", min=3, help="Hard vertex budget per image (default: none, as many as the art's outline and "
             "--density ask). Default preset only.")] = None,
    alpha_threshold: Annotated[Optional[int], typer.Option(
        "--alpha-threshold", min=1, max=255, help="Art is alpha >= this (default 8; paper 129).")] = None,
    mask: Annotated[MaskSource, typer.Option(
        "--mask", help="auto: alpha when the image has a meaningful alpha channel, else the segmentation "
                       "network (a JPEG, a sprite on a solid background); alpha; model.")] = MaskSource.auto,
) -> None:
    """Auto-mesh sprite images into triangle meshes (mesh.json: see spinemesh.mesher.mesh).

    Exterior vertices are drawn blue and interior vertices yellow in --preview and --steps;
    --steps is the paper's six panels (input, mask, exterior, interior, triangles, final) for
    tuning parameters on one image. Files are written into the current folder unless --out
    says otherwise, never beside the source art. For a folder, exit status 3 means some
    images could not be meshed (each named), 2 that none could.

    \b
    Example: spinemesh mesh art/torso.png --preview torso.png --steps torso-steps.png
    Example: spinemesh mesh art/ --out art-meshes/ --preview art-previews/ --density 2
    """
    from ..files.guard import check_outputs, refuse_one_output_twice
    from ..files.inputs import existing
    from ..written_folder import check_written_folder

    refuse_default_preset_options(preset, {"--density": density, "--max-vertices": max_vertices})
    existing(image)  # one line as every command says it, a Windows path told what to write
    overrides = _overrides(density, max_vertices, alpha_threshold, mask.value)
    target = out or default_out(image)
    if image.is_dir():
        check_outputs([image], folders=[target, preview, steps])
        refuse_one_output_twice([preview, steps])  # both write <image>.png: one folder would keep the steps alone
        for folder, what, holds in _written_folders(target, preview, steps):
            check_written_folder(folder, what, holds)  # a folder of a user's files: refused, not written over
        _mesh_folder(image, target, preview, steps, preset.value, overrides)
    else:
        check_outputs([image], files=[target, preview, steps])
        _mesh_file(image, target, preview, steps, preset.value, overrides)


def _written_folders(out_dir: Path, preview: Optional[Path], steps: Optional[Path]) -> list[tuple[Path, str, str]]:
    """The folders ``mesh DIR`` writes, each with what it is and holds, as a refusal says them."""
    return [(f, what, holds) for f, what, holds in ((out_dir, "--out folder", "meshes"),
                                                     (preview, "--preview folder", "previews"),
                                                     (steps, "--steps folder", "pictures")) if f is not None]


def _mesh_folder(image: Path, out_dir: Path, preview: Optional[Path], steps: Optional[Path], preset: str,
                 overrides: dict) -> None:
    """``mesh`` on a folder: every image below it, one line per image that fails, a summary line;
    exit status 3 when some failed, 2 when all did."""
    import contextlib

    from ..errors import SpineMeshError, escaped

    from ..files.atomic import stop_if_every_write_refused
    from ..files.guard import OutputGuard
    from ..files.inside import real
    from ..files.names import OneFilePerName
    from ..files.walk import walk_files
    from ..written_folder import WRITTEN_MARKER, mark_written_folder, rewriting_folder
    from ..images.decode import IMAGE_EXTENSIONS

    folders = list({real(f): f for f, _, _ in _written_folders(out_dir, preview, steps)}.values())
    marked = []

    def mark() -> None:
        """Mark the folders as spinemesh's before their first file (a run cut short is written into
        again); a marker there already keeps its list of the earlier run's files."""
        if not marked:
            for folder in folders:
                if not (folder / WRITTEN_MARKER).is_file():
                    mark_written_folder(folder)
            marked.append(True)

    # regular files inside the folder by real path: no symlink out, no FIFO, no loop
    left_out: list[str] = []  # a folder not read (permission denied), a symlink leading out: each said
    files = [p for p in walk_files(image, left_out) if p.suffix.lower() in IMAGE_EXTENSIONS]
    for line in left_out:
        err_console.print("[yellow]skipped:[/] " + console_text(line), highlight=False)
    if not files:
        raise SpineMeshError("no image files in this folder", image)
    rows = []
    failed = 0
    # hero.png and hero.webp (or Hero.png on a disk that ignores case) would write one hero.json
    outputs = OneFilePerName()
    with contextlib.ExitStack() as held, progress_bar("meshing", transient=True) as bar:  # no bar in a log
        for folder in folders:  # an earlier run's files this one does not write again are removed
            held.enter_context(rewriting_folder(folder))
        mark()  # before the first image: a folder the system refuses (full, umask 777) ends the run in one line
        task = bar.add_task("", total=len(files))
        for f in files:
            rel = f.relative_to(image).with_suffix("")
            bar.update(task, description=console_text(rel))
            try:
                outputs.claim(rel.with_suffix(".json"), f, "its mesh")
                # Each file too: a symlink planted inside an output folder is not written through.
                m = _one(f, preset, overrides,
                         OutputGuard([image], out_dir).check(out_dir / rel.with_suffix(".json")),
                         OutputGuard([image], preview).check(preview / rel.with_suffix(".png")) if preview else None,
                         OutputGuard([image], steps).check(steps / rel.with_suffix(".png")) if steps else None,
                         mark, folder=image)
                rows.append((str(rel), m))
            except SpineMeshError as e:
                stop_if_every_write_refused(e)
                failed += 1
                err_console.print("[yellow]skipped:[/] " + console_text(e), highlight=False)
            bar.advance(task)
    verts = sorted(len(m.vertices) for _, m in rows)
    console.print(escaped(f"{len(rows)} meshes written to {out_dir}")
                  + (f", median {verts[len(verts) // 2]} vertices" if verts else "")
                  + (f"; {failed} image(s) failed" if failed else ""), highlight=False, markup=False)
    if failed or left_out:
        from ..runs import EXIT_BAD_INPUT, EXIT_PARTIAL

        raise typer.Exit(EXIT_PARTIAL if rows else EXIT_BAD_INPUT)  # none meshed: nothing written, as a refusal


def _mesh_file(image: Path, target: Path, preview: Optional[Path], steps: Optional[Path], preset: str,
               overrides: dict) -> None:
    """``mesh`` on one image: the mesh written to ``target`` and its counts as a table."""
    from rich.table import Table

    from ..errors import escaped

    m = _one(image, preset, overrides, target, preview, steps)
    t = Table(title=console_text(image.name) + f" ({m.width}x{m.height}, preset {preset})")
    for col in ("vertices", "hull", "interior", "triangles", "constrained edges"):
        t.add_column(col, justify="right")
    t.add_row(str(len(m.vertices)), str(m.hull), str(int(m.is_interior.sum())), str(len(m.triangles)), str(len(m.edges)))
    console.print(t)
    console.print(escaped(f"wrote {target}" + (f", {preview}" if preview else "") + (f", {steps}" if steps else "")),
                  highlight=False, markup=False)  # paths, never markup
