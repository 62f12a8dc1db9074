"""``spinemesh pack``: atlas pages packed anew by the outlines of the meshes that draw each region."""

from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from ..limits import MAX_JOBS
from ._app import Annotated, Optional, app, console, console_text, progress_bar, shortened_text


class PageSides(str, Enum):
    """What sides packed pages may have (see the guide: which engines need what)."""

    original = "original"
    any = "any"
    power_of_two = "power-of-two"
    multiple_of_4 = "multiple-of-4"


_Pages = Annotated[PageSides, typer.Option(
    "--pages", help="Sides of the packed pages. original: powers of two where every original page's are, "
                    "else any; any: any size (WebGL 2, Unity, Godot, any GPU of the last decade); "
                    "power-of-two: always (WebGL 1 mipmaps and repeats only those); multiple-of-4: any multiple of 4 "
                    "(for block-compressed GPU formats).")]
_MaxPage = Annotated[Optional[int], typer.Option(
    "--max-page", min=16, max=16384, metavar="SIDE", help="Longest side of a packed page (a page may then take "
    "SIDE x SIDE texels). Default: the longest original side, and no page of more texels than the "
    "largest original page.")]
_KeepFiles = Annotated[bool, typer.Option(
    "--keep-files-as-exported", help="Copy an atlas that is not packed byte for byte. Default: its PNG pages are "
    "written anew by oxipng where that is smaller, losslessly (same texels, colour type, palette, gamma and "
    "colour profile; checked), its atlas file as it was.")]
_Jobs = Annotated[Optional[int], typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, metavar="N", help="Processes packing side by side: "
                                              "atlases, and the placements tried for one atlas (default: the "
                                              "CPU cores this process may use).")]


@app.command()
def pack(
    project: Annotated[Path, typer.Argument(metavar="PROJECT", help="Project folder, one skeleton file (its folder "
                                            "is packed), or a folder of projects (each packed to the same place "
                                            "under OUT).")],
    out: Annotated[Path, typer.Option("--out", "-o", metavar="OUT", help="Output folder: not the project folder, not "
                                      "inside it; refused if not empty, unless --overwrite.")],
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Write OUT again (only a folder spinemesh "
                                            "wrote): the files the earlier run wrote are removed, any other kept.")] = False,
    report: Annotated[Optional[Path], typer.Option("--report", metavar="FILE", help="Write a JSON report: per atlas, "
                                                   "pages, texels and bytes before and after, regions packed by "
                                                   "outline and by rectangle, and why.")] = None,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", metavar="DIR", help="Write an HTML page (DIR/index.html) with every page before and after, "
                                         "its pictures as files beside it (DIR/img/); a folder beside OUT, "
                                         "not inside it.")] = None,
    rotate: Annotated[bool, typer.Option("--rotate/--no-rotate", help="Let regions be stored turned by 90 "
                                         "degrees (every runtime reads it).")] = True,
    padding: Annotated[Optional[int], typer.Option(
        "--padding", min=0, max=64, help="Texels between what two regions draw. Default: the original pages' "
                                         "padding, at least 2 (4 under MipMap filters).")] = None,
    pages: _Pages = PageSides.original,
    max_page: _MaxPage = None,
    jobs: _Jobs = None,
    larger_files: Annotated[bool, typer.Option(
        "--larger-files", help="Write a packed atlas even where its files take more bytes than the original's "
                               "(fewer page texels, a larger download). Default: such an atlas is kept.")] = False,
    keep_files_as_exported: _KeepFiles = False,
) -> None:
    """Pack atlas pages anew by the outlines of the meshes that draw each region.

    A region drawn only by meshes (mesh attachments, linked meshes, sequence frames, in every
    skin of every skeleton that loads the atlas) is packed by the union of its meshes'
    outlines, grown by what bilinear sampling reads; any other region keeps its stored
    rectangle. Rectangles may overlap where outlines do not. Skeletons are copied byte for
    byte; atlases and page images are rewritten, page fields kept. An atlas that cannot be
    packed, or would not get smaller in page texels or in bytes, keeps its layout, with the reason
    in the report; its PNG pages are re-encoded where smaller (copied as they
    are with --keep-files-as-exported). Pages are written as small as oxipng makes them (PNG), proven lossless.

    Exit status: 0 when every atlas was packed or kept on purpose; 3 when something failed
    (it is copied as it was; the report says why); 2 when the project (for a folder of projects:
    every one of them) has no usable atlas (nothing is written).

    \b
    Example: spinemesh pack project/ --out packed/ --preview pack-preview/
    Example: spinemesh pack project/ --out packed/ --pages any --max-page 4096
    Example: spinemesh upgrade project/ --out meshed/ --pack
    """
    import time

    from ..cluster import available_cores
    from ..files.guard import check_outputs, refuse_overlapping_outputs
    from ..files.inputs import named_project, project_folder
    from ..pack.atlas_pack import PageRules
    from ..pack.run import PackOptions, pack_library, pack_project
    from ..upgrade import library_projects
    from ..written_folder import check_written_folder

    project = named_project(project)  # its files named by the folder's name in the report, from anywhere

    check_outputs([project_folder(project)], files=[report], folders=[preview])
    check_written_folder(preview)  # a folder of a user's files: refused, not written over
    # as upgrade does: pictures of the preview inside OUT would ship with the packed project
    refuse_overlapping_outputs(out, {"--preview": preview}, report)
    options = PackOptions(overwrite=overwrite, rotate=rotate, padding=padding,
                          rules=PageRules(pages.value, max_page), jobs=jobs or available_cores(),
                          larger_files=larger_files, keep_files_as_exported=keep_files_as_exported)
    projects = library_projects(project)  # found once, handed to the run
    if projects is not None and preview is not None:
        raise typer.BadParameter("--preview shows one project; give one project, not a folder of them")
    t0 = time.perf_counter()
    with progress_bar("pack", transient=True) as bars:
        progress = atlas_bars(bars)
        if projects is not None:
            result = pack_library(project, out, options, progress=progress, folders=projects)
        else:
            result = pack_project(project, out, options, keep_previews=preview is not None, progress=progress)
    finish_pack(result, time.perf_counter() - t0, options.jobs, report, preview, project, out, projects)


def finish_pack(result, seconds: float, jobs: int, report: Optional[Path], preview: Optional[Path],
                project: Path, out: Path, projects: Optional[list] = None) -> None:
    """Write what a pack run was asked for (report, preview), print its table and exit as it ended:
    a run that packed no atlas at all (all of them failed to load) ends with one line naming
    ``project`` (exit 2); a project or folder without a usable atlas was refused before.
    ``projects``: a library's (its files in no project are said), ``None`` for one project."""
    from ..errors import SpineMeshError
    from ..files.inputs import project_folder
    from ..output import run_report_error
    from ..pack.report import failed_lines, write_report
    from ..runs import EXIT_PARTIAL
    from ..words import counted
    from ._summary import print_errors, say_files_outside, say_preview

    listed = f"the {counted(len(result.atlases), 'atlas', 'atlases')} listed above" if result.atlases else ""
    report_error = run_report_error(report, out, lambda path: write_report(result, path, project_folder(project)),
                                    listed)
    page = None
    if preview is not None:
        from ..pack.preview import write_preview

        page = write_preview(result, preview, project_folder(project))
    # a failed atlas is named on stderr, as upgrade --pack names it (exit 3)
    print_pack_table(result.atlases, [*result.errors, *failed_lines(result.atlases)], result.warnings)
    if result.atlases:
        console.print(f"{outcome_line(result.atlases)}; {seconds:.1f} s on {jobs} process{'es' if jobs > 1 else ''}",
                      highlight=False)
    if page is not None:
        say_preview(page)
    say_files_outside(project, projects)
    if not result.atlases:
        raise SpineMeshError("no atlas to pack in any of its projects", project)
    if report_error:  # the run's last line: its atlases are written, its report is not (exit 3)
        print_errors([report_error])
        raise typer.Exit(EXIT_PARTIAL)
    if result.partial:
        raise typer.Exit(EXIT_PARTIAL)


def share_change(before: int, after: int) -> str:
    """``after`` against ``before`` (> 0) as a signed share: ``-50%``; ``same`` when equal, and
    with the first digit that is not zero when whole percents would round a change to ``-0%``."""
    ratio = after / before - 1
    if after == before:
        return "same"
    if abs(ratio) >= 0.005:
        return f"{ratio:+.0%}"
    digits = 1
    while abs(round(ratio * 100, digits)) == 0:
        digits += 1
    return f"{ratio:+.{digits}%}"


def outcome_line(atlases: list) -> str:
    """What a pack run did to its atlases, counted by outcome, e.g. ``"packed 1 of 4 atlases, 1
    cleared outside its rectangles, 2 kept in their layout (the note says why)"``: an atlas counts
    as packed only where its layout was written anew, not where its pages were only cleared
    outside its regions' rectangles or re-encoded."""
    packed = sum(a.status == "packed" for a in atlases)
    cleared = sum(a.status == "cleared" for a in atlases)
    kept = sum(a.status == "kept" for a in atlases)
    failed = len(atlases) - packed - cleared - kept
    line = f"packed {packed} of {len(atlases)} atlas{'es' if len(atlases) > 1 else ''}"
    if cleared:
        line += f", {cleared} cleared outside {'its' if cleared == 1 else 'their'} rectangles"
    if kept:
        line += f", {kept} kept in {'its' if kept == 1 else 'their'} layout (the note says why)"
    if failed:
        line += f", {failed} failed"
    return line


def atlas_bars(bars):
    """A :class:`spinemesh.pack.run.PackProgress` that shows one bar per atlas on ``bars`` (a rich
    progress), its steps the atlas's work (reading, placing, writing and proving its pages, by
    their texels: :mod:`spinemesh.pack.progress`) shown done in percent, each bar named by its atlas
    and what that atlas is doing (reading pages, placing regions, ...); with several atlases, a bar
    counts those done and each atlas's own bar goes once it is done. (``upgrade --pack`` shows its
    packing on its ``pack`` phase's bar instead: :class:`spinemesh.upgrade.pack.PhaseProgress`.)"""
    from ..pack.run import PackProgress

    def total(task: int) -> float:
        # by id, not by place: tasks done are removed, and rich's list then shifts
        return next(t.total for t in bars.tasks if t.id == task) or 0

    class Bars(PackProgress):
        def __init__(self) -> None:
            self.tasks: dict[str, int] = {}
            self.labels: dict[str, str] = {}
            self.whole: int | None = None  # the run's atlases done, with the time left for them all

        def atlases(self, count: int) -> None:
            if count > 1:  # one atlas: its own bar says it all
                self.whole = bars.add_task("atlases", total=count)

        def atlas(self, name: str, steps: int) -> None:
            if name not in self.tasks:
                label = self.labels[name] = shortened_text(name, 30)
                self.tasks[name] = bars.add_task(label, total=steps, percent=True)
            else:
                task = self.tasks[name]
                bars.update(task, total=total(task) + steps)

        def step(self, name: str, what: str) -> None:
            # what the atlas does (its steps are of several kinds: placements, pages), then the atlas:
            # a narrow terminal cuts the end
            if name in self.tasks:
                bars.update(self.tasks[name], description=f"{console_text(what)}: {self.labels[name]}")

        def advance(self, name: str, steps: int = 1) -> None:
            if name in self.tasks:
                bars.advance(self.tasks[name], steps)
                bars.update(self.tasks[name], since=bars.get_time())

        def done(self, name: str) -> None:
            if name in self.tasks:
                task = self.tasks[name]
                if self.whole is not None:  # counted there: a library of many atlases keeps a few lines
                    bars.remove_task(self.tasks.pop(name))
                else:
                    bars.update(task, completed=total(task) or 1, total=total(task) or 1)
                    self.step(name, "done")
            if self.whole is not None:
                bars.advance(self.whole)

    return Bars()


#: Terminal columns from which the pack table holds its notes (below: a line each under it).
NOTES_IN_TABLE_FROM = 160
#: The narrowest the notes' column gets in a wide terminal (its words wrap).
NOTE_MIN_WIDTH = 20


def print_pack_table(atlases: list, errors: list[str] = (), warnings: list[str] = ()) -> None:
    """One row per atlas (pages, page texels and bytes before and after, regions by outline and
    by rectangle, why it was kept), then the warnings and the errors."""
    from rich.table import Table

    from ..runs import short_names
    from ..words import counted
    from ._summary import print_errors, print_warnings

    # a note of 20 words in a column of a narrow terminal took a line a word: there, each note is
    # a line of its own under the table
    below = console.width < NOTES_IN_TABLE_FROM

    def change(before: int, after: int) -> str:
        return f"{before:,} -> {after:,} ({share_change(before, after)})" if before else "-"

    def regions(a) -> tuple[str, str]:
        # None: its layout was kept (its regions stay where they were), see AtlasRow
        return ("-", "-") if a.by_outline is None else (str(a.by_outline), str(a.by_rectangle))

    rows = [[a.atlas, f"{a.pages_before} -> {a.pages_after}", change(a.texels_before, a.texels_after),
             change(a.bytes_before, a.bytes_after), *regions(a)] for a in atlases]
    total_note = ""
    if len(atlases) > 1:
        from ..pack.report import atlas_totals

        total = atlas_totals(atlases)
        rows.append(["total", f"{total['pages_before']} -> {total['pages_after']}",
                     change(total["texels_before"], total["texels_after"]),
                     change(total["bytes_before"], total["bytes_after"]),
                     # every atlas kept its layout: "-" as in each row (the total said 0 and 0)
                     *(("-", "-") if all(a.by_outline is None for a in atlases)
                       else (str(total["by_outline"]), str(total["by_rectangle"])))])
        if total["shared_pages"]:  # each row counts it: the total would not be the sum of the rows
            total_note = (f"{counted(total['shared_pages'], 'page file')} named by several atlases "
                          "counted once")
    columns = ("atlas", "pages", "page texels", "bytes", "by outline", "by rectangle")
    widths = _fitted_widths([list(columns), *rows], console.width - (0 if below else 3 + NOTE_MIN_WIDTH))
    shown = short_names([a.atlas for a in atlases], widths[0]) if widths else {}
    table = Table(title="spinemesh pack")
    for i, col in enumerate(columns):
        table.add_column(col, justify="left" if i == 0 else "right", no_wrap=i == 0,
                         width=widths[i] if widths else None)
    if not below:
        table.add_column("note", justify="left", min_width=NOTE_MIN_WIDTH)
    notes = [a.reason for a in atlases] + [total_note]
    for i, (row, note) in enumerate(zip(rows, notes)):
        if i == len(atlases):
            table.add_section()  # the total
        table.add_row(console_text(shown.get(row[0], row[0]) if i < len(atlases) else row[0]), *row[1:],
                      *(() if below else (console_text(note),)))
    if atlases:
        console.print(table)
        for a in atlases if below else ():
            if a.reason:
                console.print(f"note: {console_text(a.atlas)}: {console_text(a.reason)}", highlight=False, soft_wrap=True)
        if below and total_note:
            console.print(f"note: total: {total_note}", highlight=False, soft_wrap=True)
    print_warnings(warnings)
    print_errors(errors)


def _fitted_widths(cells: list[list[str]], width: int) -> list[int] | None:
    """The widths of a table's columns (text, without padding or borders) that fit ``width``
    terminal columns: the first column (names, never wrapped) takes what the others leave, the
    others (figures, wrapped at their spaces) are never narrower than their longest word; None
    when the table fits as it is.

    At 80 columns the pack table cut each atlas's name to its first letters (``HalloweenC…``),
    so the log did not say which atlas was packed, while its figures took two lines anyway.

    Parameters
    ----------
    cells : list of list of str
        The header, then each row, a text per column.
    width : int
        Terminal columns the table may take, its borders and padding included.
    """
    columns = range(len(cells[0]))
    natural = [max(len(row[i]) for row in cells) for i in columns]
    least = [max((len(word) for row in cells for word in row[i].split()), default=1) for i in columns]
    room = width - 3 * len(natural) - 1  # a space each side of a cell, a border between and around
    if sum(natural) <= room:
        return None
    fitted = [min(natural[0], max(room - sum(least[1:]), len(cells[0][0]))), *least[1:]]
    spare = room - sum(fitted)
    for i in sorted(columns[1:], key=lambda i: natural[i] - fitted[i]):  # the shortest whole first: fewer lines
        grown = min(spare, natural[i] - fitted[i])
        fitted[i] += grown
        spare -= grown
    return fitted
