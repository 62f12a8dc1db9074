"""Writing: meshes into the documents, documents to files, every other file copied.

:func:`apply_project` puts each :class:`~.meshing.MeshResult` into the documents of a
:class:`~.plan.ProjectPlan` (and, with ``--weights auto``, binds and weights the new
meshes); :func:`write_skeletons` writes each document in the format and version it came in;
:func:`copying_other_files` copies atlases, pages and everything else on threads meanwhile
(what is copied: :func:`spinemesh.output.files_to_copy`);
:func:`write_repacked_atlases` rewrites the atlases whose sequences ``--repack`` stores
whole. Each problem is one line in the :class:`~.report.Result`, never an abort.
"""

from __future__ import annotations

import contextlib
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterator

from ..attachment_geometry import mesh_attachment
from ..cluster import WorkerLost, Workers
from ..errors import SpineMeshError
from ..fsutil import atomic_copy
from ..output import atlas_pages, copy_atlases_last, files_needed, files_to_copy, write_skeleton
from ..skeleton import iter_attachments
from .bending import settle_bending
from .meshing import MeshResult
from .plan import MeshTask, ProjectPlan
from .progress import SILENT, Progress
from .repack import write_repacked_atlas
from .report import Result, Target


def apply_meshes(doc: dict, targets: list[Target], meshes: dict[str, MeshResult],
                 tasks: dict[str, MeshTask], source_name: str) -> None:
    """Replace each planned region in ``doc`` by its mesh attachment, in place, keeping key order."""
    by_place = {(t.skin, t.slot, t.name): t for t in targets if t.status == "planned"}
    for ref in list(iter_attachments(doc)):
        t = by_place.get((ref.skin, ref.slot, ref.name))
        if t is None:
            continue
        res = meshes[t.key]
        t.seconds = round(res.seconds, 4)
        if res.vertices is None:
            t.status, t.reason = ("kept", res.kept) if res.kept else ("failed", res.error)
            continue
        task = tasks[t.key]
        w, h = task.size
        (x0, y0), (bh, bw) = task.origin, task.rgba.shape[:2]
        try:
            mesh = mesh_attachment(ref.attachment, res.vertices, res.triangles, res.hull, res.edges, w, h,
                                   source_name, box=(x0, y0, x0 + bw, y0 + bh))
        except SpineMeshError as e:
            t.status, t.reason = "failed", str(e)
            continue
        if res.overruled:  # meshed only because it bends: the region comes back if it does not
            t.overruled, t.region = res.overruled, dict(ref.attachment)
        # The document's own dict, changed in place: it keeps its place among its siblings.
        ref.attachment.clear()
        ref.attachment.update(mesh)
        t.status = "meshed"
        t.vertices = len(res.vertices)
        t.triangles = len(res.triangles)
        t.coverage = None if res.coverage is None else round(res.coverage, 6)
        t.waste = None if res.waste is None else round(res.waste, 6)


def apply_project(plan: ProjectPlan, meshes: dict[str, MeshResult], result: Result | None = None,
                  progress: Progress = SILENT, workers: Workers | None = None) -> None:
    """Put the meshes into every document of ``plan``, in place; ``--weights auto`` also weights them.

    Stage 3 of :mod:`.run`. Before anything goes in, the regions that may bend are settled
    (:func:`.bending.settle_bending`: ``meshes`` and ``plan.tasks`` get the bending tasks' meshes).

    Parameters
    ----------
    plan : ProjectPlan
        Its documents are changed in place: each planned region attachment becomes the mesh
        attachment of :func:`spinemesh.attachment_geometry.mesh_attachment`, its
        :class:`~.report.Target` marked ``meshed`` (or ``kept``/``failed`` with the reason).
    meshes : dict of str to MeshResult
        From :func:`.meshing.mesh_tasks`, by image key.
    result : Result, optional
        Gets the weights' time in ``seconds["weights"]``.
    progress : Progress, optional
        Told each mesh weighted (phase ``weights``); default: nobody.
    workers : Workers, optional
        With workers that are not this process, the meshes are weighted on them
        (:func:`weight_on_workers`); default: here.
    """
    settle_bending(plan, meshes, workers, result, progress)
    for sk in plan.skeletons:
        apply_meshes(sk.doc, sk.targets, meshes, plan.tasks, str(sk.path))
    if plan.options is None or plan.options.weights != "auto":
        return
    from ..rig.upgraded_meshes import weight_upgraded

    t0 = time.perf_counter()
    progress.add("weights", sum(t.status == "meshed" for sk in plan.skeletons for t in sk.targets))
    max_vertices = plan.options.overrides.get("max_vertices")
    here = [(sk, sk.targets) for sk in plan.skeletons]
    if workers is not None and type(workers) is not Workers:
        here = weight_on_workers(workers, plan.skeletons, max_vertices, progress)
    for sk, targets in here:
        weight_upgraded(sk.doc, targets, max_vertices, sk.rig, on_mesh=lambda: progress.advance("weights"))
    if result is not None:
        result.seconds["weights"] += time.perf_counter() - t0
        # what the motion guard and the bending checks read linear, where they sampled the animations
        result.warnings += [line for sk in plan.skeletons if sk.rig is not None and sk.rig.motion is not None
                            for line in sk.rig.motion.said_lines(sk.rel)]


def weight_on_workers(workers: Workers, skeletons: list, max_vertices: int | None,
                      progress: Progress = SILENT) -> list[tuple]:
    """Weight the upgraded meshes of ``skeletons`` on ``workers``, in jobs of a few meshes
    (:func:`spinemesh.rig.upgraded_meshes.weighting_jobs`); the weighting is the same wherever it runs,
    and each job's result is put back by place, never by arrival order, so the output is the
    same byte for byte. Returns ``(skeleton, targets)`` left to weight here: the skeletons without
    a rig (their weighting reports why per mesh) and the targets of jobs whose worker was lost.
    """
    from ..rig.upgraded_meshes import put_back_weighted, weight_apart, weighting_jobs

    here, jobs = [(sk, sk.targets) for sk in skeletons if sk.rig is None], {}
    for sk in skeletons:
        if sk.rig is not None:
            for job in weighting_jobs(sk.doc, sk.targets, max_vertices, sk.rig):
                # first: ahead of the meshing of the projects a library run planned ahead, which
                # would otherwise hold up this project's weights (and its bar) until they are meshed
                jobs[workers.submit(weight_apart, job, first=True)] = (sk, job[1])
    for future in workers.as_completed(list(jobs)):
        sk, targets = jobs[future]
        try:
            put_back_weighted(sk.doc, targets, future.result())
        except WorkerLost:  # weighted here instead, the same way
            here.append((sk, targets))
            continue
        progress.advance("weights", len(targets))
    return here


def write_skeletons(plan: ProjectPlan, out: Path, result: Result, progress: Progress = SILENT) -> None:
    """Write every document of ``plan`` under ``out``; those written go to ``result.written``.

    Stage 4 of :mod:`.run`: each skeleton in the format and version it came in, at its path
    under the project (:func:`spinemesh.output.write_skeleton`).

    Parameters
    ----------
    plan : ProjectPlan
        The documents, meshes applied (:func:`apply_project`).
    out : Path
        The output folder, already checked and marked (:func:`spinemesh.output.output_folder`).
    result : Result
        Gets each skeleton written (its path under the project) in ``written``; one that cannot
        be written goes to ``errors``, and its targets that were meshed become ``failed``.
    progress : Progress, optional
        Told each skeleton written (phase ``write``); default: nobody.
    """
    progress.add("write", len(plan.skeletons))
    for sk in plan.skeletons:
        progress.advance("write")
        try:
            write_skeleton(sk.doc, sk.path, out / sk.rel)
        except SpineMeshError as e:
            result.errors.append(f"{sk.path}: not written: {e}")
            for t in sk.targets:  # not counted as meshed: the output does not hold them
                if t.status == "meshed":
                    t.status, t.reason = "failed", "its skeleton was not written"
            continue
        result.written.append(sk.rel)



#: Threads copying a project's other files (atlases, pages) while its skeletons are written.
COPY_THREADS = 4


@contextlib.contextmanager
def copying_other_files(plan: ProjectPlan, out: Path, result: Result) -> Iterator[None]:
    """Copy the project's other files (:func:`files_to_copy`) on threads while the body runs.

    Copies are disk work (reads, writes, fsync) that leaves the interpreter free: they run
    while this thread finishes and writes the skeletons. Files not copied go to
    ``result.errors`` when the body ends.
    """
    needed = set().union(*(files_needed(sk.doc, sk.source) for sk in plan.skeletons)) if plan.only_needed else None
    skeletons = {sk.path.resolve() for sk in plan.skeletons}
    pages_of = atlas_pages(plan.project)
    pairs = [(source, dest, source.resolve()) for source, dest in files_to_copy(plan.project, out, skeletons, needed)]
    copier = ThreadPoolExecutor(COPY_THREADS)
    # atlases last, each only once its pages are copied (a full disk would leave one without them)
    copies = [(real, copier.submit(atomic_copy, source, dest)) for source, dest, real in pairs if real not in pages_of]
    yield
    failed = set()
    for real, copy in copies:
        try:
            copy.result()
        except SpineMeshError as e:
            failed.add(real)
            result.errors.append(f"not copied: {e}")
    copier.shutdown()
    result.errors += copy_atlases_last([(source, dest) for source, dest, real in pairs if real in pages_of],
                                       pages_of, failed=failed)


def write_repacked_atlases(plan: ProjectPlan, out: Path, result: Result) -> None:
    """``--repack``: rewrite each atlas whose sequences are stored whole (:mod:`.repack`) under ``out``."""
    for atlas_path, names in sorted(plan.untrimmed.items()):
        try:
            write_repacked_atlas(atlas_path, names, plan.project.root, out)
        except SpineMeshError as e:
            result.errors.append(f"{atlas_path}: not re-packed: {e}")
