"""``spinemesh upgrade``: the main job.

The options are declared once each above the command (typer reads them from the
annotations); the command builds :class:`spinemesh.upgrade.Options`, runs the upgrade with
a progress bar and prints what became of every region attachment.
"""

from __future__ import annotations

from pathlib import Path
from typing import List, NamedTuple

import typer

from ..limits import MAX_JOBS
from ._app import (
    Annotated, MaskSource, Optional, Preset, app, console, console_text, err_console, finite, positive_finite,
    phase_progress, progress_bar, refuse_default_preset_options,
)
from ._summary import say_files_outside
from .pack import PageSides, _KeepFiles, _MaxPage, _Pages, share_change
from .weights import Weights

# The command's options, one declaration each (see --help for what they do).
_Project = Annotated[Path, typer.Argument(metavar="PROJECT", help="Project folder, one skeleton file (.json/.skel), or a folder of "
                                              "projects (each upgraded to the same place under OUT).")]
_Out = Annotated[Path, typer.Option("--out", "-o", metavar="OUT", help="Output folder: not the project folder, not inside "
                                    "it; refused if not empty, unless --overwrite.")]
_Overwrite = Annotated[bool, typer.Option("--overwrite", help="Write OUT again (only a folder spinemesh "
                                          "wrote): the files the earlier run wrote are removed, any other kept.")]
_Preview = Annotated[Optional[Path], typer.Option(
    "--preview", metavar="DIR", help="Write HTML pages that open from disk (DIR/index.html): texels drawn "
                      "before and after, one page per skeleton with the original and upgraded skeleton "
                      "side by side in a player, every upgraded image's old quad and new mesh; for a "
                      "folder of projects, one index for all.")]
_Preset = Annotated[Preset, typer.Option("--preset", "-p", help="Mesher preset: default (for animation) or "
                                         "paper (the paper's section 3 exactly: every region meshed; the "
                                         "options that tune the default preset are refused with it).")]
_Mask = Annotated[MaskSource, typer.Option(
    "--mask", help="Where the foreground comes from. auto (here: alpha, which is what the runtime draws); "
                   "alpha; model (the segmentation network, which may cut drawn pixels).")]
_Density = Annotated[Optional[float], typer.Option(
    "--density", callback=positive_finite, help="Vertex density, above 0: below 1 sparser, above 1 "
                                                "denser (default 1). Default preset only.")]
_MaxVertices = Annotated[Optional[int], typer.Option("--max-vertices", min=3,
                                                     help="Hard vertex budget per mesh (default: none, as many as the "
                                                          "art's outline and --density ask). Default preset only.")]
_Only = Annotated[List[str], typer.Option("--only", metavar="GLOB", help="Glob on slot, attachment name or image path; "
                                          "repeatable. Others are kept as regions.")]
_Exclude = Annotated[List[str], typer.Option("--exclude", metavar="GLOB", help="Glob on slot, attachment name or image "
                                             "path; repeatable.")]
_MinSize = Annotated[float, typer.Option("--min-size", min=0, callback=finite, help="Keep as regions those whose larger "
                                         "side is below this many pixels.")]
_MinSaving = Annotated[Optional[float], typer.Option(
    "--min-saving", min=0.0, max=1.0, callback=finite,
    help="Keep a region when its mesh would draw less than this share fewer pixels than the region's "
         "quad (0..1; default 0.05). Art whose outline needs over 200 vertices (many scattered "
         "islands) and saves under 500 pixels per vertex is kept a region too. Kept regions are "
         "reported with the reason. Default preset only.")]
_DryRun = Annotated[bool, typer.Option("--dry-run", help="Plan and report only; write nothing.")]
_Report = Annotated[Optional[Path], typer.Option("--report", metavar="FILE", help="Write a JSON report of every "
                                                 "attachment.")]
_Jobs = Annotated[Optional[int], typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Processes meshing, weighting, "
                                              "packing and sampling the preview in parallel (default: the CPU "
                                              "cores this process may use).")]
_Dask = Annotated[Optional[str], typer.Option(
    "--dask", metavar="ADDRESS", help="Mesh on a Dask cluster: a scheduler address (tcp://host:8786), a "
                                      "scheduler file, or 'local' (--jobs workers here). Same output as a "
                                      "local run; needs the 'cluster' extra.")]
_Images = Annotated[Optional[Path], typer.Option(
    "--images", metavar="DIR", help="Also write the original-size images here, for re-import in the editor.")]
_ImagesIn = Annotated[Optional[Path], typer.Option(
    "--from-images", metavar="DIR", help="Read attachment images from this folder instead of atlases.")]
_Repack = Annotated[bool, typer.Option(
    "--repack/--no-repack", help="Mesh sequences whose frames were trimmed differently: their frames are "
                                 "stored whole on new atlas pages (the atlas is rewritten in OUT; the input "
                                 "is untouched; a frame's art on its trimmed border then also draws its "
                                 "half-texel fringe). Default: such sequences stay regions. With --pack their "
                                 "new pages are packed too, but may store more than the export.")]
_Pack = Annotated[bool, typer.Option(
    "--pack", help="Then pack the atlas pages anew by the upgraded meshes' outlines, as 'spinemesh pack' "
                   "does (skeletons unchanged; each atlas only when it gets smaller than exported). "
                   "Add --repack to also mesh sequences trimmed differently.")]
_Weights = Annotated[Weights, typer.Option(
    "--weights", help="none: meshes bound to their slot's bone, as the regions were; auto: also bound "
                      "to the bones an artist would bind, with vertices at the joints and automatic "
                      "weights (as 'spinemesh weights' chooses them, --bones auto; the same choice "
                      "picks the regions that bend). A mesh bends only where a bone besides its slot's "
                      "is likely for its art (a sleeve over an elbow); the others follow their slot's "
                      "bone, and the console counts both.")]


@app.command()
def upgrade(
    project: _Project,
    out: _Out,
    overwrite: _Overwrite = False,
    preview: _Preview = None,
    preset: _Preset = Preset.default,
    mask: _Mask = MaskSource.auto,
    density: _Density = None,
    max_vertices: _MaxVertices = None,
    only: _Only = [],
    exclude: _Exclude = [],
    min_size: _MinSize = 0.0,
    min_saving: _MinSaving = None,
    dry_run: _DryRun = False,
    report: _Report = None,
    jobs: _Jobs = None,
    dask: _Dask = None,
    images: _Images = None,
    images_in: _ImagesIn = None,
    repack: _Repack = False,
    pack: _Pack = False,
    weights: _Weights = Weights.none,
    pages: _Pages = PageSides.original,
    max_page: _MaxPage = None,
    keep_files_as_exported: _KeepFiles = False,
) -> None:
    """Upgrade every region attachment of a project to a mesh attachment.

    Skeletons are written in the format and version they came in (.json or .skel); atlases,
    page images and other files are copied. For one skeleton file, only that skeleton and
    the atlases or images it uses are written.

    Region attachments left as they are on purpose are counted as "kept" with the reason in
    the report: those that --only, --exclude or --min-size leave out, fully transparent
    images, sequences trimmed differently on the atlas page unless --repack, and regions a
    mesh would not make cheaper to draw (see --min-saving).
    Exit status: 0 when everything asked was done;
    3 when some attachment or skeleton failed (it stays as it was; the report says why), or
    when the skeletons were written but the --report could not be;
    2 when there was nothing to upgrade: no skeleton found, or --only/--exclude matched nothing
    (as for an invalid option). A project with nothing to mesh (already meshes, or every region
    kept) exits 0 with a warning, or, with --pack, with what was packed.

    A folder holding several projects (any depth: a project is the first folder holding a
    skeleton or an atlas) is upgraded project by project into the same tree under OUT, on one
    set of workers, with one report.

    \b
    Example: spinemesh upgrade project/ --out meshed/ --preview meshed-preview/
    Example: spinemesh upgrade library/ --out meshed/ --report report.json -j 8
    Example: spinemesh upgrade project/hero.skel --out meshed/ --only 'head*'
    Example: spinemesh upgrade project/ --out meshed-packed/ --pack
    Example: spinemesh upgrade project/ --out packed/ --pack --max-page 2048
    """
    from ..cluster import available_cores
    from ..files.inputs import named_project, project_folder
    from ..pack.atlas_pack import PageRules
    from ..upgrade import Options

    _refuse_pack_options_without_pack(pack, pages, max_page, keep_files_as_exported)
    refuse_default_preset_options(preset, {"--density": density, "--max-vertices": max_vertices,
                                           "--min-saving": min_saving})
    project = named_project(project)  # its files named by the folder's name in the report, from anywhere
    _check_outputs(project_folder(project), out, report, preview, images, images_in)
    overrides = {name: value for name, value in (("density", density), ("max_vertices", max_vertices))
                 if value is not None}
    options = Options(preset=preset.value, mask=mask.value, only=only, exclude=exclude, min_size=min_size,
                      dry_run=dry_run, jobs=jobs or available_cores(), dask=dask, images_out=images,
                      images_in=images_in, overrides=overrides, overwrite=overwrite, repack=repack, pack=pack, weights=weights.value,
                      pack_rules=PageRules(pages.value, max_page), pack_keep_files=keep_files_as_exported,
                      **({} if min_saving is None else {"min_saving": min_saving}))
    result, projects = _run(project, out, options)
    report_error = _write_report(result, report, out, dry_run, project_folder(project))
    _print_result(result, dry_run)
    say_files_outside(project, projects)
    _say_written(dry_run, pack, images)
    nothing = _nothing_to_do(result, project, only or exclude)
    if preview is not None and not dry_run and result.written:
        _write_preview(result, project, out, preview, images_in, options.jobs, projects)
    _exit(result, nothing, report_error)


def _check_outputs(project: Path, out: Path, report: Path | None, preview: Path | None, images: Path | None,
                   images_in: Path | None) -> None:
    """Every output checked before any work: never inside the project, onto an input, or through a
    symlink; a ``--preview`` or ``--images`` folder of a user's files refused, not written over."""
    from ..files.guard import check_outputs, refuse_overlapping_outputs
    from ..written_folder import check_written_folder

    check_outputs([project, images_in], files=[report], folders=[preview, images])
    check_written_folder(preview)
    check_written_folder(images, "--images folder", "images")
    refuse_overlapping_outputs(out, {"--images": images, "--preview": preview}, report)


def _say_dry_run(pack: bool) -> None:
    """What a dry run's counts mean; packing reads the meshes written, and a dry run writes none."""
    packed = " nor packed (--pack packs the meshes a run writes)" if pack else ""
    console.print(f"dry run: nothing meshed or written{packed}; \"would mesh\" counts the regions planned, "
                  "before the test of what is worth meshing", highlight=False, markup=False)


def _write_report(result, report: Path | None, out: Path, dry_run: bool, root: Path) -> str:
    """``--report``: the run's report as JSON, never over a file the run wrote in OUT. Returns ``""``,
    or, when the report cannot be written once skeletons were, the error line saying so (the run
    goes on to say what it wrote, and ends done in part); with nothing written, the error is raised
    (refused, exit 2)."""
    from ..output import run_report_error
    from ..upgrade import write_report
    from ..words import counted

    if report is not None and dry_run:  # no output folder
        write_report(result, report, root)
        return ""
    written = f"the {counted(len(result.written), 'skeleton')} listed above" if result.written else ""
    return run_report_error(report, out, lambda path: write_report(result, path, root), written)


def _say_written(dry_run: bool, pack: bool, images: Path | None) -> None:
    """The line after the table: that a dry run wrote nothing, else where ``--images`` wrote."""
    if dry_run:
        _say_dry_run(pack)
    elif images is not None:
        _say_images(images)


def _say_images(images: Path) -> None:
    """Where ``--images`` wrote the original-size images, and how many: the run wrote them without
    a word, and the table above speaks of OUT only."""
    from ..words import counted
    from ._summary import say_preview

    written = sum(1 for _ in images.rglob("*.png")) if images.is_dir() else 0
    if not written:  # nothing meshed: the lines above say why
        return
    say_preview(images, f"{counted(written, 'image')} at their original size, for the editor's images folder",
                what="images")


def _write_preview(result, project: Path, out: Path, preview: Path, images_in, jobs: int,
                   projects: list[Path] | None) -> None:
    """``--preview``: the page, with a bar of the animations sampled for the players (the work:
    a skeleton may have hundreds) and the skeletons written, then where it is and the seconds
    it took (written after the run's timing line, so not in it: rendering every skeleton may take
    longer than the upgrade). Skeletons' pages are written over ``--jobs`` processes."""
    import time

    from ..upgrade.preview import write_preview
    from ._summary import say_preview

    t0 = time.perf_counter()
    with progress_bar("preview", transient=True, phases=True) as bars:
        task = bars.add_task("preview", total=None, project="animations sampled, pages written")
        page = write_preview(result, project, out, preview, images_in=images_in, jobs=jobs, projects=projects,
                             on_progress=lambda done, total: bars.update(task, completed=done, total=total))
    say_preview(page, f"{time.perf_counter() - t0:.1f} s")


def _refuse_pack_options_without_pack(pack: bool, pages, max_page, keep_files: bool) -> None:
    """Refuse the packing options without ``--pack``: the run would pack nothing and say nothing,
    and a user who asked for pages of any size would ship the export's pages unknowingly."""
    from ..errors import SpineMeshError

    given = [name for name, value in (("--pages", pages is not PageSides.original), ("--max-page", max_page is not None),
                                      ("--keep-files-as-exported", keep_files)) if value]
    if given and not pack:
        raise SpineMeshError(f"{' and '.join(given)} {'applies' if len(given) == 1 else 'apply'} to packing only: "
                             "add --pack (without it, every atlas is copied as exported)")


def _run(project: Path, out: Path, options) -> tuple:
    """Upgrade ``project`` with a bar per phase (read, mesh, weights, write). Returns the result and
    the projects of a library (``None`` for one project), found once: the preview uses them too."""
    from ..upgrade import library_projects, upgrade_library, upgrade_project

    projects = library_projects(project)
    with progress_bar("upgrade", transient=True, phases=True) as bars:
        progress = phase_progress(bars)
        if projects is not None:
            return upgrade_library(project, out, options, progress, projects), projects
        return upgrade_project(project, out, options, progress), None


def _print_result(result, dry_run: bool) -> None:
    """A table per skeleton, the timings, what the weights did, the skeletons not read, why regions
    were kept, what failed and the other errors."""
    import statistics


    from ..errors import escaped
    from ..upgrade.report import selection_left_nothing
    from ._summary import print_left_alone, print_warnings, skeleton_table, weights_lines

    def cells(targets: list) -> list[str]:
        verts = [t.vertices for t in targets if t.status == "meshed"]
        counts = [str(sum(t.status in ("meshed", "would mesh") for t in targets)),
                  str(sum(t.status == "kept" for t in targets)), str(sum(t.status == "failed" for t in targets))]
        # a dry run plans: no mesh, so no vertices to count
        return counts if dry_run else [*counts, f"{statistics.median(verts):g}" if verts else "-"]

    if result.targets or result.written:
        columns = ("would mesh", "kept", "failed") if dry_run else ("meshed", "kept", "failed", "median vertices")
        console.print(skeleton_table("spinemesh upgrade" + (" (dry run)" if dry_run else ""), columns,
                                     result.targets, cells, skeletons=result.written))
    # the phases that ran: a dry run, or one whose --only/--exclude matched nothing, only reads
    # (and plans); a run that found no skeleton, none
    read_only = dry_run or selection_left_nothing(result)
    ran = {phase: seconds for phase, seconds in result.seconds.items()
           if (phase != "weights" or seconds) and (phase == "read" or not read_only)}
    if result.targets or result.written or result.not_read or result.errors:
        console.print(", ".join(f"{phase} {seconds:.1f} s" for phase, seconds in ran.items()), highlight=False)
    if result.atlases:
        from .pack import print_pack_table

        print_pack_table(result.atlases)
    for line in weights_lines(result.targets):
        console.print(escaped(line), highlight=False, markup=False)
    print_warnings(result.warnings)  # each names its atlas and page
    for error in result.not_read.values():  # each names its file and says why
        err_console.print(f"[red]not read:[/] {console_text(error)}", highlight=False)
    unread = set(result.not_read.values())
    print_left_alone(result.targets, [e for e in result.errors if e not in unread],
                     "kept", "kept as region", "left a region")


def _exit(result, nothing: "NothingDone | None", report_error: str = "") -> None:
    """Exit 3 when something failed (an attachment, a skeleton, the report of a run that wrote its
    skeletons: ``report_error`` is then the run's last line); 2 with an error when there was nothing
    to upgrade (no skeleton, or --only/--exclude left nothing), 0 with a warning when every
    attachment was already done."""
    from ..runs import EXIT_BAD_INPUT, EXIT_PARTIAL
    from ._summary import print_errors, print_warnings

    if report_error:  # its output is written, its report is not
        print_errors([report_error])
    if result.partial or report_error:
        raise typer.Exit(EXIT_PARTIAL)
    if nothing is None:
        return
    if nothing.refused:  # nothing to work on (no skeleton, --only/--exclude left nothing): exit 2
        print_errors([nothing.why])
        raise typer.Exit(EXIT_BAD_INPUT)
    # a finished run with nothing left to mesh, exit 0; --pack did something (packed, cleared pages
    # outside their rectangles, or wrote a kept atlas's pages smaller): say what, not that the run
    # did nothing
    if any(a.status in ("packed", "cleared") or a.pages_reencoded for a in result.atlases):
        console.print(console_text(packed_line(result.atlases, nothing.why)), highlight=False)
    else:
        print_warnings([nothing.line])


def packed_line(atlases: list, meshed_nothing: str) -> str:
    """What a run that meshed nothing packed: ``meshed_nothing`` (why), then the atlases packed
    (pages and page texels), those cleared outside their rectangles, the pages of kept atlases
    written smaller, and the atlases' bytes (texts and pages)."""
    packed = [a for a in atlases if a.status == "packed"]
    plural = "es" if len(atlases) > 1 else ""
    if packed:
        before, after = sum(a.texels_before for a in packed), sum(a.texels_after for a in packed)
        pages_before = sum(a.pages_before for a in packed)
        pages = f"{pages_before} page{'s' if pages_before > 1 else ''} into {sum(a.pages_after for a in packed)}"
        did = [f"packed {len(packed)} of {len(atlases)} atlas{plural}: {pages}, {before - after:,} fewer page "
               f"texels ({1 - after / before:.0%})"]
    else:
        did = [f"packed none of {len(atlases)} atlas{plural}"]
    cleared = sum(a.status == "cleared" for a in atlases)
    if cleared:
        did.append(f"{cleared} atlas{'es' if cleared > 1 else ''} cleared outside {'its' if cleared == 1 else 'their'} "
                   "rectangles (the layout kept)")
    reencoded = sum(a.pages_reencoded for a in atlases if a.status == "kept")
    if reencoded:
        did.append(f"{reencoded} page{'s' if reencoded > 1 else ''} of kept atlases re-encoded losslessly")
    before, after = sum(a.bytes_before for a in atlases), sum(a.bytes_after for a in atlases)
    if before:
        did.append(f"atlas files {before:,} -> {after:,} bytes ({share_change(before, after)})")
    return f"nothing meshed: {meshed_nothing}; " + "; ".join(did)


class NothingDone(NamedTuple):
    """Why a run upgraded nothing (:func:`_nothing_to_do`).

    ``refused``: there was nothing to work on (no skeleton, --only/--exclude left nothing), an
    error, exit 2, ``why`` the whole line; else the run finished with nothing left to mesh, a
    warning, exit 0, ``why`` the reason (every attachment already a mesh, every region kept).
    """

    why: str
    refused: bool

    @property
    def line(self) -> str:
        """What the run says."""
        return self.why if self.refused else f"nothing to upgrade: {self.why}"


def _nothing_to_do(result, project: Path, filtered: bool) -> NothingDone | None:
    """Why the run upgraded nothing, with a hint (an error where nothing was written), or None."""
    from ..project import no_skeleton_said
    from ..upgrade.report import selection_left_nothing

    if result.errors or any(t.status in ("meshed", "would mesh", "failed") for t in result.targets):
        return None
    if not result.written and not result.targets:
        return NothingDone(f"{project}: {no_skeleton_said()}", refused=True)
    if filtered and selection_left_nothing(result):
        return NothingDone("--only/--exclude left no region attachment to upgrade; patterns match the slot, the "
                           "attachment name or the image path, e.g. --only 'head*' --only 'arms/*'", refused=True)
    if not result.targets:
        return NothingDone("every attachment is already a mesh (or of another type); files were copied", refused=False)
    return NothingDone("every region attachment was kept (see the reasons above)", refused=False)
