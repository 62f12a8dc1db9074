"""Stage 3, apply: the meshes put into the documents (and, with ``--weights auto``, weighted).

:func:`apply_project` settles the regions that may bend (:mod:`.bending`), then puts each
:class:`~.meshing.MeshResult` into the documents of a :class:`~.plan.ProjectPlan` in place
(:func:`apply_meshes`), and with ``--weights auto`` binds and weights the new meshes, here or on
the workers (:func:`weight_on_workers`). Each problem is one target's status, never an abort.
"""

from __future__ import annotations

import time

from ..attachment_geometry import mesh_attachment
from ..cluster import WorkerLost, Workers
from ..errors import SpineMeshError
from ..skeleton import iter_attachments
from .bending import settle_bending
from .meshing import MeshResult
from .plan import MeshTask, ProjectPlan
from .progress import SILENT, Progress
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
