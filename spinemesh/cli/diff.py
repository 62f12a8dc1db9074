"""``spinemesh diff``: compare generated meshes with the artists' meshes of projects."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ..errors import escaped
from ..runs import EXIT_BAD_INPUT
from ._app import Annotated, app, console_text, console, progress_bar
from ._summary import print_errors


@app.command()
def diff(
    projects: Annotated[List[Path], typer.Argument(metavar="PROJECT...", help="Project folders (or skeleton files); each is searched "
                                                        "for skeletons and their atlases or images folder.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder: report.md, report.json, index.html, "
                                      "assets/.")],
    methods: Annotated[Optional[str], typer.Option(
        "--methods", help="Comma-separated subset of: default, paper, hull, grid, shi-tomasi (default: all).")] = None,
    images: Annotated[Optional[Path], typer.Option(
        "--images", help="Take the images from this folder instead of the atlases.")] = None,
    limit: Annotated[Optional[int], typer.Option("--limit", min=1, help="Compare at most this many "
                                                 "attachments, the first found (default: every one).")] = None,
    originals: Annotated[bool, typer.Option(
        "--originals/--atlas", help="Mesh the editor's original images when an images folder holds them "
                                    "(default), or the atlas regions at atlas resolution.")] = True,
) -> None:
    """Compare every artist mesh with our presets and the paper's three baselines.

    For each "type": "mesh" attachment, the same image is meshed by the default and paper
    presets and by the paper's baselines (alpha-only hull, uniform grid, Shi-Tomasi corners);
    each is measured (vertex and triangle counts, coverage, waste, boundary adherence, angle
    ratio) and compared with the artist's mesh (hull IoU, Chamfer distance in px). The report
    has one row per attachment, an aggregate table like the paper's comparison table, and an
    HTML page: the sprite with the artist's mesh in green and ours in orange (exterior
    vertices blue, interior yellow). linkedmesh attachments are skipped (they reuse a parent).
    Images are the editor's originals when an images/ folder holds them, else atlas regions.

    \b
    Example: spinemesh diff hero/ --out hero-diff/
    Example: spinemesh diff projects/*/ --out diff/ --methods default,paper
    """
    from ..diff.report import REPORT_FOLDER, aggregate, aggregate_markdown, write_report
    from ..diff.run import METHODS, run_diff
    from ..files.guard import check_outputs
    from ..files.inputs import named_project, project_folder
    from ..written_folder import check_written_folder

    projects = [named_project(p) for p in projects]  # "." named by its folder's name in the report

    check_outputs([*map(project_folder, projects), images], folders=[out])
    check_written_folder(out, REPORT_FOLDER, "report")  # before the work; write_report checks it again

    # each named once, in the order given
    chosen = tuple(dict.fromkeys(m.strip() for m in methods.split(",") if m.strip())) if methods else METHODS
    bad = [m for m in chosen if m not in METHODS]
    if bad or not chosen:  # `--methods ,` named none: a report of the artists' meshes alone, exit 0
        named = f"unknown method(s) {', '.join(bad)}" if bad else f"no method named in {methods!r}"
        print_errors([f"{named}; choose from {', '.join(METHODS)}"])
        raise typer.Exit(EXIT_BAD_INPUT)
    with progress_bar("comparing", transient=True) as bar:  # a pipe or a log gets no bar, as with the others
        task = bar.add_task("reading projects", total=None)

        def progress(done: int, total: int, label: str) -> None:
            bar.update(task, completed=done, total=total, description=console_text(label))

        result = run_diff(projects, chosen, images=images, limit=limit, originals=originals, progress=progress)
    if not result.rows:
        print_errors([_nothing_compared_said(projects, result.skipped)])
        raise typer.Exit(EXIT_BAD_INPUT)
    paths = write_report(result, out)
    console.print(aggregate_markdown(aggregate(result)), markup=False, highlight=False, soft_wrap=True)
    console.print(f"{len(result.rows)} attachments compared, {len(result.skipped)} skipped")
    console.print(escaped(f"wrote {paths['markdown']}, {paths['json']}, {paths['html']}"), markup=False)  # paths, no markup


def _nothing_compared_said(projects: list[Path], skipped: list[dict]) -> str:
    """The one error line of a run that compared nothing, naming the projects given: what was
    skipped, or that they hold no skeleton, or no mesh (a project of regions: the line said
    ``no artist mesh attachment found`` and no more, naming nothing)."""
    from ..project import find_project, no_skeleton_said

    named = ", ".join(map(str, projects))
    if skipped:
        return f"{named}: no artist mesh attachment found{_skipped_said(skipped)}"
    if not any(find_project(p).skeletons for p in projects):
        return f"{named}: {no_skeleton_said()}"
    return (f"{named}: no artist mesh attachment found: diff compares each mesh attachment your artists drew "
            "with ours, and the skeletons there hold none (regions only: 'spinemesh upgrade' meshes them)")


def _skipped_said(skipped: list[dict]) -> str:
    """Why nothing was compared, for the one error line: the first attachment passed over, its
    skeleton and reason, and how many more (the report that lists them all is not written).

    Examples
    --------
    >>> _skipped_said([{"project": "p", "skeleton": "a.json", "slot": "s", "attachment": "m", "reason": "why"}] * 3)
    " (3 skipped: p/a.json slot 's' attachment 'm': why; and 2 more)"
    >>> _skipped_said([])
    ''
    """
    if not skipped:
        return ""
    first = skipped[0]
    more = f"; and {len(skipped) - 1} more" if len(skipped) > 1 else ""
    return (f" ({len(skipped)} skipped: {first['project']}/{first['skeleton']} slot {first['slot']!r} "
            f"attachment {first['attachment']!r}: {first['reason']}{more})")
