"""``spinemesh weights``: bind mesh attachments to bones and compute their weights."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import List

import typer

from ..limits import MAX_JOBS
from ._app import Annotated, Optional, app, console, phase_progress, progress_bar


class BoneChoice(str, Enum):
    """Which bones a mesh is bound to (:mod:`spinemesh.rig.choice`)."""

    keep = "keep"
    auto = "auto"
    rule = "rule"
    learned = "learned"


class Weights(str, Enum):
    """``upgrade --weights``: leave upgraded meshes on their slot's bone, or weight them."""

    none = "none"
    auto = "auto"


class WeightMethod(str, Enum):
    """How weights are computed (:data:`spinemesh.rig.document.METHODS`)."""

    bbw = "bbw"
    harmonic = "harmonic"
    biharmonic = "biharmonic"
    geodesic = "geodesic"


@app.command()
def weights(
    project: Annotated[Path, typer.Argument(metavar="PROJECT", help="Project folder, or one skeleton file (.json/.skel).")],
    out: Annotated[Path, typer.Option("--out", "-o", metavar="OUT", help="Output folder (not the project folder, not "
                                      "inside it); refused if not empty, unless --overwrite.")],
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Write OUT again (only a folder spinemesh "
                                            "wrote): the files the earlier run wrote are removed, any other kept.")] = False,
    replace: Annotated[bool, typer.Option("--replace", help="Also recompute meshes that are already "
                                          "weighted.")] = False,
    bones: Annotated[BoneChoice, typer.Option(
        "--bones", help="keep: the bones a mesh is bound to now (its slot's bone when unweighted); rule: the "
                        "slot's bone and the bones whose segments pass over the art, joined to it through the "
                        "bone tree; learned: the bones a model fitted to artists' bindings finds likely, given how "
                        "the project's artists bound its other weighted meshes; auto: "
                        "the one of the two that measures closer to artists' bindings (today: learned).")] = BoneChoice.auto,
    max_bones: Annotated[int, typer.Option("--max-bones", min=1, max=16, help="Most bones per vertex.")] = 4,
    method: Annotated[WeightMethod, typer.Option(
        "--method", help="bbw: bounded biharmonic weights (Jacobson et al. 2011); harmonic: heat-diffusion-"
                         "like weights, faster; biharmonic: unbounded, clipped; geodesic: falling off with the "
                         "distance along the art to each bone (Dionne and de Lasa 2013), fastest.")] = WeightMethod.bbw,
    only: Annotated[List[str], typer.Option("--only", metavar="GLOB", help="Glob on slot, attachment name or image path; "
                                            "repeatable.")] = [],
    exclude: Annotated[List[str], typer.Option("--exclude", metavar="GLOB", help="Glob on slot, attachment name or image "
                                               "path; repeatable.")] = [],
    report: Annotated[Optional[Path], typer.Option("--report", metavar="FILE", help="Write a JSON report: per attachment, "
                                                   "the bones chosen and why, and the time.")] = None,
    preview: Annotated[Optional[Path], typer.Option(
        "--preview", metavar="DIR", help="Write one PNG per weighted attachment here: the wireframe over the sprite with "
                          "vertices coloured by bone, and the mesh in one bent pose, with a legend of its bones "
                          "(number, colour, name); beside it NAME.json names every bone in full. A folder "
                          "beside OUT, not inside it.")] = None,
    jobs: Annotated[Optional[int], typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, metavar="N", help="Processes "
                                                "weighting the meshes in parallel (default: the CPU cores this "
                                                "process may use).")] = None,
) -> None:
    """Bind the mesh attachments of a project to bones and compute their weights.

    Meshes that are not weighted yet are treated (all of them with --replace). The setup pose
    does not change: each vertex is bound at its setup-pose position in each bone's space.
    Meshes keyed by deform timelines, and meshes whose bones a constraint moves in the setup
    pose, are left as they are, with the reason in the report. Exit status 3 when some
    attachment or skeleton failed.

    \b
    Example: spinemesh weights project/ --out weighted/ --report report.json
    Example: spinemesh weights project/hero.skel --out weighted/ --preview pics/
    Example: spinemesh weights project/ --out weighted/ --replace --bones keep
    """
    from ..anim.bone_worlds import sampled_bone_worlds
    from ..cluster import available_cores
    from ..files.inputs import named_project, project_folder
    from ..output import run_report_error
    from ..project import no_skeleton_said
    from ..rig.document import WeightOptions
    from ..rig.run import weight_project, write_report
    from ..runs import EXIT_BAD_INPUT, EXIT_PARTIAL
    from ..words import counted
    from ._summary import ONE_BONE_CHOSEN, print_errors, say_preview

    project = named_project(project)  # its files named by the folder's name in the report, from anywhere
    _check_outputs(project, out, report, preview)
    options = WeightOptions(bones=bones.value, max_bones=max_bones, replace=replace, method=method.value,
                            only=only, exclude=exclude, sample_motion=sampled_bone_worlds)
    with progress_bar("weights", transient=True, phases=True) as bars:  # a bar per phase: weights, preview
        result = weight_project(project, out, options, preview=preview, overwrite=overwrite, progress=phase_progress(bars),
                                jobs=jobs or available_cores())
    report_error = run_report_error(report, out, lambda path: write_report(result, path, project_folder(project)),
                                    counted(len(result.written), "skeleton") if result.written else "")
    _print_result(result, ONE_BONE_KEPT if bones.value == "keep" else ONE_BONE_CHOSEN)
    if preview is not None:
        say_preview(preview, counted(sum(o.status == "weighted" for o in result.outcomes), "picture"))
    if report_error:  # the run's last line: its skeletons are written, its report is not (exit 3)
        print_errors([report_error])
    if result.partial or report_error:
        raise typer.Exit(EXIT_PARTIAL)
    if not result.written:
        print_errors([f"{project}: {no_skeleton_said()}"])
        raise typer.Exit(EXIT_BAD_INPUT)


#: Why every mesh weighted with ``--bones keep`` follows one bone.
ONE_BONE_KEPT = "--bones keep: the bone each was bound to"


def _check_outputs(project: Path, out: Path, report: Path | None, preview: Path | None) -> None:
    """Refuse, before any work, an output inside the project or onto it (standard output too),
    and a ``--preview`` folder of a user's files or overlapping OUT."""
    from ..files.guard import OutputGuard, refuse_overlapping_outputs
    from ..written_folder import check_written_folder

    guard = OutputGuard([project])
    guard.check_standard_output()
    guard.check_folder(out)
    if report is not None:
        guard.check(report, "report")
    refuse_overlapping_outputs(out, {}, report)  # the report is no folder, nor above OUT
    if preview is not None:
        guard.check_folder(preview, "preview folder")
        check_written_folder(preview)
        # its pictures are no part of the game: inside OUT they were shipped with it (upgrade and
        # pack refuse it the same way)
        refuse_overlapping_outputs(out, {"--preview": preview})


def _print_result(result, one_bone: str) -> None:
    """The run's table (weighted, skipped, failed, median bones per skeleton), what was left as it
    was and why, how many meshes bend, its time, and its warnings (each naming its skeleton).
    ``one_bone``: why every weighted mesh follows one bone, where they all do."""

    from ..words import counted
    from ._summary import bending_said, print_left_alone, print_warnings, skeleton_table

    def cells(rows: list) -> list[str]:
        done = sorted(len(o.bones) for o in rows if o.status == "weighted")
        return [str(len(done)), str(sum(o.status == "skipped" for o in rows)),
                str(sum(o.status == "failed" for o in rows)), str(done[len(done) // 2]) if done else "-"]

    # every skeleton written is a row, one without a mesh too (it was left out, as if not read)
    console.print(skeleton_table("spinemesh weights", ("weighted", "skipped", "failed", "median bones"),
                                 result.outcomes, cells, skeletons=result.written))
    print_left_alone(result.outcomes, result.errors, "skipped", "left as it was", "left as it was",
                     reason=lambda o: o.reason.split(" (")[0] if o.reason.startswith("keyed") else o.reason)
    weighted = [len(o.bones) for o in result.outcomes if o.status == "weighted"]
    if weighted:  # "weighted" alone read as bending: most meshes of an effects rig follow one bone
        console.print(f"bones: {counted(len(weighted), 'mesh', 'meshes')} weighted"
                      f"{bending_said(weighted, one_bone)}", highlight=False)
    console.print(f"{result.seconds:.1f} s", highlight=False)
    print_warnings(result.warnings + _nothing_to_weight(result))


def _nothing_to_weight(result) -> list[str]:
    """Why a run that read its skeletons weighted nothing, where no line above says it: none of them
    holds a mesh (an export whose art is all regions printed an empty table and its time, exit 0)."""
    if result.outcomes or not result.written or result.errors:
        return []
    return [("nothing to weight: no skeleton holds a mesh attachment (weights binds meshes; "
             "spinemesh upgrade --weights auto makes meshes of the regions and binds them); files were copied")]
