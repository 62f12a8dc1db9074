"""``spinemesh pack``: atlas pages packed anew by the outlines of the meshes that draw each region."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import Annotated, Optional, app, console


@app.command()
def pack(
    project: Annotated[Path, typer.Argument(metavar="PROJECT", help="Project folder, one skeleton file (its folder "
                                            "is packed), or a folder of projects (each packed to the same place "
                                            "under OUT).")],
    out: Annotated[Path, typer.Option("--out", "-o", metavar="OUT", help="Output folder: not the project folder, not "
                                      "inside it; refused if not empty, unless --overwrite.")],
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace OUT as a whole (only a folder spinemesh "
                                            "wrote), so that no stale file stays.")] = False,
    report: Annotated[Optional[Path], typer.Option("--report", metavar="FILE", help="Write a JSON report: per atlas, "
                                                   "pages, texels and bytes before and after, regions packed by "
                                                   "outline and by rectangle, and why.")] = None,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", metavar="DIR", help="Write a self-contained HTML page (DIR/index.html) with every page before "
                                         "and after.")] = None,
    rotate: Annotated[bool, typer.Option("--rotate/--no-rotate", help="Let regions be stored turned by 90 "
                                         "degrees (every runtime reads it).")] = True,
    padding: Annotated[Optional[int], typer.Option(
        "--padding", min=0, max=64, help="Texels between what two regions draw. Default: the original pages' "
                                         "padding, at least 2 (4 under MipMap filters).")] = None,
) -> None:
    """Pack atlas pages anew by the outlines of the meshes that draw each region.

    A region drawn only by meshes (mesh attachments, linked meshes, sequence frames, in every
    skin of every skeleton that loads the atlas) is packed by the union of its meshes'
    outlines, grown by what bilinear sampling reads; any other region keeps its stored
    rectangle. Rectangles may overlap where outlines do not. Skeletons are copied byte for
    byte; atlases and page images are rewritten, page fields kept. An atlas that cannot be
    packed, or would not get smaller, is copied as it is, with the reason in the report.

    Exit status: 0 when every atlas was packed or kept on purpose; 3 when something failed
    (it is copied as it was; the report says why); 2 when the project has no atlas.

    \b
    Example: spinemesh pack project/ --out packed/ --report pack.json --preview pack-preview/
    Example: spinemesh upgrade project/ --out meshed/ --pack
    """
    from ..fsutil import check_outputs, project_folder
    from ..pack.run import PackOptions, pack_library, pack_project, write_report
    from ..runs import EXIT_BAD_INPUT, EXIT_PARTIAL
    from ..upgrade import is_library

    check_outputs([project_folder(project)], files=[report], folders=[preview])
    options = PackOptions(overwrite=overwrite, rotate=rotate, padding=padding)
    library = is_library(project)
    if library and preview is not None:
        raise typer.BadParameter("--preview shows one project; give one project, not a folder of them")
    if library:
        result = pack_library(project, out, options)
    else:
        result = pack_project(project, out, options, keep_previews=preview is not None)
    if report is not None:
        write_report(result, report)
    if preview is not None:
        from ..pack.preview import write_preview

        write_preview(result, preview)
    print_pack_table(result.atlases, result.errors)
    if not result.atlases:
        console.print("no atlas found")
        raise typer.Exit(EXIT_BAD_INPUT)
    if result.partial:
        raise typer.Exit(EXIT_PARTIAL)


def print_pack_table(atlases: list, errors: list[str] = ()) -> None:
    """One row per atlas (pages, page texels and bytes before and after, regions by outline and
    by rectangle, why it was kept), then the errors."""
    from rich.markup import escape  # names and reasons come from the project: never markup
    from rich.table import Table

    table = Table(title="spinemesh pack")
    for col in ("atlas", "pages", "page texels", "bytes", "by outline", "by rectangle", "note"):
        table.add_column(col, justify="left" if col in ("atlas", "note") else "right")

    def change(before: int, after: int) -> str:
        return f"{before:,} -> {after:,} ({after / before - 1:+.0%})" if before else "-"

    for a in atlases:
        table.add_row(escape(a.atlas), f"{a.pages_before} -> {a.pages_after}", change(a.texels_before, a.texels_after),
                      change(a.bytes_before, a.bytes_after), str(a.by_outline), str(a.by_rectangle),
                      escape(a.reason if a.status != "packed" else ""))
    if atlases:
        console.print(table)
    for e in errors:
        console.print(f"[yellow]{escape(e)}[/yellow]")
