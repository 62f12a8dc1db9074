"""``spinemesh weights``: bind and weight the mesh attachments of whole projects.

Every skeleton of the project is read (``.json`` or ``.skel``, any version the package
reads), its mesh attachments are weighted (:func:`.document.weight_document`; the learned
bone choice with the habits of the artist-weighted meshes of all of them), and it is
written to the output folder in the format and version it came in; every other file is
copied. The input is never modified and the output folder may not be inside it.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..cluster import WorkerLost, Workers, open_workers
from ..errors import SpineMeshError
from ..files.atomic import atomic_write_json, stop_if_every_write_refused
from ..files.names import named_within
from ..project import Project, find_project
from ..runs import RunSummary
from ..skeleton import load_skeleton
from ..skeleton_check import animations_keyed_twice
from .document import Outcome, WeightOptions, build_rig, mesh_count, uses_learned, weigh_meshes, weight_document
from .learned import share_project_habits
from .upgraded_meshes import MESHES_PER_JOB


@dataclass
class WeightResult(RunSummary):
    """Every mesh attachment's outcome, the skeletons written and the problems met."""

    outcomes: list[Outcome] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    #: what is written as one runtime reads it only (an animation naming a key twice), each naming its skeleton
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def _items(self):
        return self.outcomes


def weight_project(project: str | Path, out: str | Path, options: WeightOptions | None = None,
                   preview: str | Path | None = None, overwrite: bool = False, progress=None,
                   jobs: int = 1) -> WeightResult:
    """Weight every skeleton of a project into ``out``.

    Parameters
    ----------
    project : path
        A project folder or one skeleton file.
    out : path
        Output folder; refused if it is the project folder or inside it, and when it is not
        empty, unless ``overwrite`` (:func:`spinemesh.output.output_folder`: a user's file of a
        skeleton's name there was replaced).
    options : WeightOptions
    preview : path, optional
        Folder for one picture per weighted attachment (:mod:`.preview`).
    overwrite : bool, default False
        Write ``out`` again when an earlier run wrote it (:func:`~spinemesh.output.output_folder`).
    progress : spinemesh.upgrade.progress.Progress, optional
        Told the steps of the phases ``weights`` (each mesh attachment) and ``preview`` (each
        picture), as they become known and as they are done.
    jobs : int, default 1
        Worker processes weighing the meshes (:func:`_weight_on_workers`; the same output
        whatever the number); 1 weighs them in this process.

    Returns
    -------
    WeightResult
        Nothing is written (not even ``out``) when the project has no skeleton.
    """
    from ..output import check_output_folder, copy_other_files, output_folder, write_skeleton
    from ..written_folder import check_written_folder, rewriting_folder

    options = options or WeightOptions()
    out = Path(out)
    proj = find_project(project)
    check_output_folder(proj.root, out)
    if preview is not None:
        check_output_folder(proj.root, Path(preview))
        check_written_folder(preview)  # a folder of a user's files: refused, not written over
    result = WeightResult(errors=list(proj.problems))  # files left out (a folder not read, a symlink out), said
    if not proj.skeletons:  # nothing to weigh (the command says so): no output folder, as upgrade
        return result
    start = time.perf_counter()
    written, read = set(), _read_skeletons(proj, options, result)
    if uses_learned(options):  # the learned choice reads the artists' habits over every skeleton first
        share_project_habits([(doc, rig) for _, doc, rig in read])
    if progress is not None:
        progress.add("weights", sum(mesh_count(doc) for _, doc, _ in read))
    pictures: set[str] = set()  # the preview's file names so far, every skeleton's apart
    with (output_folder(out, overwrite), rewriting_folder(preview),  # no stale picture of an earlier run stays
          open_workers(jobs) as workers):
        for path, doc, rig in read:
            rel = path.relative_to(proj.root).as_posix()
            outcomes, asked = _weight_on_workers(workers, doc, rel, options, rig, progress)
            result.outcomes += outcomes
            if asked:  # what the motion guard read linear, if it sampled
                result.warnings += rig.motion.said_lines(rel)
            try:
                write_skeleton(doc, path, out / rel)
            except SpineMeshError as e:
                stop_if_every_write_refused(e)
                result.errors.append(f"{rel}: not written: {e}")
                continue
            written.add(path.resolve())
            result.written.append(rel)
            if preview is not None:
                from .preview import write_previews

                if progress is not None:
                    progress.add("preview", sum(o.status == "weighted" for o in outcomes))
                result.errors += write_previews(doc, path, proj, rig, outcomes, Path(preview),
                                                None if progress is None else lambda: progress.advance("preview"),
                                                pictures)
        result.errors += copy_other_files(proj, out, written)
    result.seconds = time.perf_counter() - start
    return result


def _weight_on_workers(workers: Workers, doc: dict, rel: str, options: WeightOptions, rig,
                       progress=None) -> tuple[list[Outcome], bool]:
    """:func:`.document.weight_document` of ``doc``, its meshes weighed on ``workers`` in jobs of
    at most :data:`.upgraded_meshes.MESHES_PER_JOB` (:func:`.document.weigh_meshes`; one whose
    worker was lost weighed here), each put back by its place, never by arrival order: the same document and
    outcomes byte for byte whatever the workers. Returns the outcomes and whether the motion
    guard asked for the animations (their ``said_lines`` are said only then)."""
    def advance(count: int = 1) -> None:
        if progress is not None:
            progress.advance("weights", count)

    if workers.slots == 1:
        outcomes = weight_document(doc, rel, options, rig, on_mesh=advance)
        return outcomes, rig.motion is not None and rig.motion.asked
    handed: list[tuple] = []
    outcomes = weight_document(doc, rel, options, rig, weigh=lambda ref, outcome: handed.append((ref, outcome)))
    advance(mesh_count(doc) - len(handed))  # those not weighed: skipped or failed already
    light = {k: v for k, v in doc.items() if k != "animations"}  # the rig holds what it needs of them
    sent = dataclasses.replace(rig, choices={})  # its motion goes as sampled frames (.drift.Motion)
    # two jobs a worker at least: one skeleton of 30 meshes was 24 and 6, one worker weighing 80%
    size = max(1, min(MESHES_PER_JOB, -(-len(handed) // (2 * workers.slots))))
    chunks = [handed[s:s + size] for s in range(0, len(handed), size)]
    jobs = [(chunk, (light, rel, options, sent, {(r.skin, r.slot, r.name) for r, _ in chunk})) for chunk in chunks]
    futures = {workers.submit(weigh_meshes, job): (chunk, job) for chunk, job in jobs}
    asked = rig.motion is not None and rig.motion.asked
    for future in workers.as_completed(list(futures)):
        chunk, job = futures[future]
        try:
            done, asked_there = future.result()
        except WorkerLost:  # weighed here instead, on a copy as a worker gets (the job weighs in place)
            done, asked_there = weigh_meshes(copy.deepcopy(job))
        asked = asked or asked_there
        for (ref, outcome), (attachment, made) in zip(chunk, done):
            ref.attachment.clear()  # the attachment's own dict keeps its place among its siblings
            ref.attachment.update(attachment)
            outcome.__dict__.update(made.__dict__)
        advance(len(chunk))
    return outcomes, asked


def _read_skeletons(proj: Project, options: WeightOptions, result: WeightResult) -> list[tuple[Path, dict, object]]:
    """``(path, document, rig)`` of each skeleton of ``proj`` that loads (:func:`build_rig`); one
    that does not goes to ``result.errors``, an animation keyed twice to its warnings."""
    read = []
    for path in proj.skeletons:
        try:
            doc = load_skeleton(path)
        except SpineMeshError as e:
            result.errors.append(str(e))
            continue
        read.append((path, doc, build_rig(doc, options.sample_motion)))
        rel = path.relative_to(proj.root).as_posix()
        result.warnings += [f"{rel}: {line}" for line in animations_keyed_twice(doc)]  # passed through, said
    return read


def write_report(result: WeightResult, path: str | Path, project: str | Path | None = None) -> None:
    """``report.json``: one row per mesh attachment (bones chosen and why, time), plus totals; the
    files of ``project`` (the folder weighted) named from its name (:func:`~spinemesh.files.names.named_within`)."""
    atomic_write_json(path, named_within({
        "counts": result.counts(),
        "skeletons_written": result.written,
        "errors": result.errors,
        "warnings": result.warnings,
        "seconds": round(result.seconds, 3),
        "attachments": [o.row() for o in result.outcomes],
    }, project))
