"""``spinemesh info``: what a project holds."""

from __future__ import annotations

from pathlib import Path

import typer

from ..runs import EXIT_BAD_INPUT, EXIT_PARTIAL
from ._app import Annotated, app, console, console_text, err_console

@app.command()
def info(project: Annotated[Path, typer.Argument(metavar="PROJECT", help="Project folder or skeleton file (.json/.skel).")]) -> None:
    """Show the Spine version, attachments by type, atlas pages and regions, and missing images.

    Exits with 2 when no skeleton was found, 3 when a skeleton, an attachment or atlas could not be read.

    \b
    Example: spinemesh info project/
    Example: spinemesh info project/hero.skel
    """
    from collections import Counter

    from rich.table import Table

    from ..errors import SpineMeshError
    from ..files.guard import check_outputs
    from ..files.inputs import named_project
    from ..files.names import named_from
    from ..project import find_project, image_source_for, no_skeleton_said, project_atlases
    from ..skeleton import checked_attachments, image_paths, load_skeleton, spine_version
    from ..words import unusable_said

    # what stdout says (often kept in a file) names the project's folders from its name, the same
    # bytes from any folder; the problems on stderr give whole paths, to open
    proj = find_project(named_project(project))
    check_outputs([proj.root], product="the table")  # its table (standard output) never into the project
    atlases = project_atlases(proj)
    table = Table(title="Atlases in " + console_text(named_from(proj.root, proj.root)))
    for col in ("atlas", "syntax", "pages", "regions", "scale", "pma"):
        table.add_column(col)
    for p, a in atlases.items():
        table.add_row(console_text(str(p.relative_to(proj.root))), a.syntax, str(len(a.pages)), str(len(a.regions)),
                      ",".join(sorted({f"{pg.scale:g}" for pg in a.pages})), "yes" if any(pg.pma for pg in a.pages) else "no")
    console.print(table)
    if not proj.skeletons:
        from ._summary import print_errors

        print_errors([f"{project}: {no_skeleton_said()}"])
        raise typer.Exit(EXIT_BAD_INPUT)
    for path in proj.skeletons:
        try:
            doc = load_skeleton(path)
        except SpineMeshError as e:
            proj.problems.append(f"unreadable skeleton: {e}")
            continue
        checked = list(checked_attachments(doc))
        refs = [r for r, problem in checked if not problem]
        # an attachment of broken numbers is counted and said, not lost (upgrade fails it alike)
        proj.problems += unusable_said([problem for _, problem in checked if problem], path, "{problem}",
                                       "... and {more:,} more attachments that cannot be used")
        counts = Counter(str(r.type) for r, _ in checked)
        source = image_source_for(doc, path, proj)
        missing = set()
        for r in refs:
            try:
                paths = image_paths(r)
            except SpineMeshError as e:
                proj.problems.append(f"{path}: skin {r.skin!r} slot {r.slot!r} attachment {r.name!r}: {e}")
                continue
            missing |= {(r.skin, r.slot, r.name, p) for p in paths if source is None or p not in source}
        console.print(f"\n[bold]{console_text(str(path.relative_to(proj.root)))}[/]  "
                      + console_text(f"Spine {spine_version(doc) or '?'}  images from: {_describe(source, proj.root)}"))
        t = Table()
        t.add_column("attachment type")
        t.add_column("count", justify="right")
        for kind, n in sorted(counts.items()):
            t.add_row(console_text(str(kind)), str(n))
        t.add_row("[bold]total[/]", str(len(checked)))
        console.print(t)
        _say_images(missing, source, proj)
    for problem in proj.problems:  # broken atlases, symlinks leading outside, unreadable skeletons
        err_console.print(f"problem: {console_text(problem)}", highlight=False, soft_wrap=True)
    for warning in proj.warnings:  # pages runtimes draw differently (spinemesh.atlas.page_mismatches)
        err_console.print(f"warning: {console_text(warning)}", highlight=False, soft_wrap=True)
    if proj.problems:
        raise typer.Exit(EXIT_PARTIAL)


def _say_images(missing: set, source, proj) -> None:
    """The images a skeleton's attachments name that are not found (``missing``: skin, slot,
    attachment, image), else how many of its atlases' pages are not whole images (each named as a problem)."""
    if missing:
        console.print(f"[yellow]{len(missing)} attachment image(s) not found:[/]")
        for skin, slot, name, p in sorted(missing)[:50]:
            console.print(f"  skin {skin!r} slot {slot!r} attachment {name!r}: image {p!r}", markup=False)
        if len(missing) > 50:
            console.print(f"  ... and {len(missing) - 50} more")
        return
    unreadable = _unreadable_pages(source, proj.root)
    if not unreadable:
        console.print("every attachment image was found")
        return
    # each page is named once, with the run's other problems on stderr (what a script reads, and
    # what makes the exit 3); here only how many, so that the skeleton's part does not say "found"
    console.print(f"[yellow]every attachment's page is present, but {len(unreadable)} page(s) cannot be read "
                  "(each said as a problem)[/]")
    proj.problems += [line for line in unreadable if line not in proj.problems]


def _unreadable_pages(source, root: Path) -> list[str]:
    """One line per page of ``source``'s atlases whose file is not a whole image, from its header
    and, for a PNG, its chunks' heads (a few bytes a chunk: no page is decoded)."""
    from ..images.decode import image_size
    from ..pack.png import png_file_cut_short

    out = []
    for atlas in getattr(source, "atlases", ()):
        for page in atlas.pages:
            path = source.page_path(atlas, page.name, root)
            if image_size(path) is None:
                out.append(f"{path}: page image {page.name!r} cannot be read as an image")
            elif (at := png_file_cut_short(path)) is not None:
                out.append(f"{path}: page image {page.name!r} is cut short at byte {at:,}")
    return out


def _describe(source, root: Path) -> str:
    """Where a skeleton's images come from: its atlases by name, or the folder of images named
    from the project's name (:func:`~spinemesh.files.names.named_from`)."""
    from ..files.names import named_from

    if source is None:
        return "none"
    if hasattr(source, "atlases"):
        return ", ".join(a.path.name for a in source.atlases)
    return named_from(source.folder, root)
