"""``spinemesh upgrade``: the main job."""

from __future__ import annotations

import statistics
import sys
from pathlib import Path
from typing import List, Optional

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..upgrade import EXIT_PARTIAL, Options, upgrade_project, write_report
from ._app import app, console, err_console


@app.command()
def upgrade(
    project: Path = typer.Argument(..., help="Project folder, or one skeleton file (.json/.skel)."),
    out: Path = typer.Option(..., "--out", "-o", help="Output folder (not the project folder, not inside it)."),
    preset: str = typer.Option("default", "--preset", "-p", help="Mesher preset: default (for animation) or paper."),
    mask: str = typer.Option("alpha", "--mask", help="Where the foreground comes from: alpha, model or auto."),
    density: Optional[float] = typer.Option(None, "--density", help="Vertex density: below 1 sparser, above 1 denser."),
    max_vertices: Optional[int] = typer.Option(None, "--max-vertices", help="Hard vertex budget per mesh."),
    only: List[str] = typer.Option([], "--only", help="Glob on slot, attachment or image path; repeatable."),
    exclude: List[str] = typer.Option([], "--exclude", help="Glob on slot, attachment or image path; repeatable."),
    min_size: float = typer.Option(0.0, "--min-size", help="Leave regions whose larger side is below this many pixels."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Plan and report only; write nothing."),
    report: Optional[Path] = typer.Option(None, "--report", help="Write a JSON report of every attachment."),
    jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="Processes meshing in parallel."),
    images: Optional[Path] = typer.Option(None, "--images",
                                          help="Also write the original-size images here, for re-import in the editor."),
    images_in: Optional[Path] = typer.Option(None, "--from-images",
                                             help="Read attachment images from this folder instead of atlases."),
) -> None:
    """Upgrade every region attachment of a project to a mesh attachment.

    Skeletons are written in the format and version they came in (.json or .skel); atlases
    and page images are copied. An attachment whose image is missing or broken stays a
    region; the exit code is then 3 (partial success).

    Example: spinemesh upgrade project/ --out meshed/ --report meshed/report.json
    """
    overrides = {}
    if density is not None:
        overrides["density"] = density
    if max_vertices is not None:
        overrides["max_vertices"] = max_vertices
    options = Options(preset=preset, mask=mask, only=only, exclude=exclude, min_size=min_size,
                      dry_run=dry_run, jobs=jobs, images_out=images, images_in=images_in, overrides=overrides)
    with Progress(TextColumn("[bold]meshing"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=err_console, transient=True) as bar:
        task = bar.add_task("mesh", total=None)
        result = upgrade_project(project, out, options,
                                 on_start=lambda n: bar.update(task, total=n),
                                 on_progress=lambda n: bar.advance(task, n))
    if report is not None:
        write_report(result, report)

    table = Table(title="spinemesh upgrade" + (" (dry run)" if dry_run else ""))
    for col in ("skeleton", "meshed", "skipped", "failed", "median vertices"):
        table.add_column(col, justify="right" if col != "skeleton" else "left")
    by_skel: dict[str, list] = {}
    for t in result.targets:
        by_skel.setdefault(t.skeleton, []).append(t)
    for name, targets in by_skel.items():
        verts = [t.vertices for t in targets if t.status == "meshed"]
        table.add_row(name, str(sum(t.status in ("meshed", "would mesh") for t in targets)),
                      str(sum(t.status == "skipped" for t in targets)),
                      str(sum(t.status == "failed" for t in targets)),
                      f"{statistics.median(verts):g}" if verts else "-")
    console.print(table)
    s = result.seconds
    console.print(f"read {s['read']:.1f} s, mesh {s['mesh']:.1f} s, write {s['write']:.1f} s")
    for t in result.targets:
        if t.status == "failed":
            err_console.print(f"[yellow]left a region:[/] {t.skeleton} skin {t.skin!r} slot {t.slot!r} "
                              f"attachment {t.name!r}: {t.reason}")
    for e in result.errors:
        err_console.print(f"[red]error:[/] {e}")
    if result.partial:
        sys.exit(EXIT_PARTIAL)
