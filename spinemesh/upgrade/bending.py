"""``--weights auto`` around the meshing: the project's habits read on the workers, and the
regions the keep rule kept tested for bending once meshed.

The learned bone choice reads the habits of the project's artist-weighted meshes
(:func:`spinemesh.rig.learned.project_habits`): :func:`start_habits` hands each skeleton's part
to the workers, ahead of the meshes, while this process cuts the images; :func:`gather_habits`
puts them together, in skeleton order, and gives them to every rig before anything is tested
for bending or weighted.

A region whose art bends with the skeleton is meshed even where the keep rule
(:mod:`spinemesh.mesher.worth`) would keep it for saving too few pixels (its
:func:`~.plan.bending_task`). That task's mesh differs from the plain one only where the plain
one is kept: so every image is meshed plain first, and only the regions whose plain mesh the
rule kept are tested for bending (:meth:`spinemesh.rig.upgrade.BendingRegions.bends`, on the
box of their art) and meshed again as bending tasks (:func:`mesh_bending`). Testing every
region before meshing gave the same meshes for about five times the tests (1,243 against
about 225 on the 45 skeletons of ``benchmarks/bench_upgrade_weights.py``), all in this process.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

from ..cluster import WorkerLost, Workers
from .plan import ProjectPlan, art_box, bending_task
from .progress import SILENT, Progress


@dataclass
class HabitsReading:
    """The habits of a project's skeletons being read, one job per skeleton with a rig."""

    #: ``(doc, rig)`` of each skeleton, in order: a job whose worker was lost is read here
    documents: list[tuple]
    futures: list


def start_habits(skeletons, workers: Workers | None) -> HabitsReading:
    """Hand the :func:`~spinemesh.rig.learned.document_habits` of each skeleton with a rig to
    ``workers`` (read here, now, without). ``skeletons``: :class:`~.plan.SkeletonPlan` s.

    Each job holds its document without the animations and its rig without what the choices
    made on it or its sampled motion: neither is read.
    """
    from ..rig.learned import document_habits_job

    documents = [(sk.doc, sk.rig) for sk in skeletons if sk.rig is not None]
    if workers is None or type(workers) is Workers:  # read here, now, as Workers.submit does
        return HabitsReading(documents, [Workers().submit(document_habits_job, d) for d in documents])
    jobs = [({k: v for k, v in doc.items() if k != "animations"}, dataclasses.replace(rig, choices={}, motion=None))
            for doc, rig in documents]
    return HabitsReading(documents, [workers.submit(document_habits_job, job) for job in jobs])


def gather_habits(plan: ProjectPlan) -> None:
    """Give every rig of ``plan`` the project's habits, read by :func:`start_habits` (here, now,
    when nobody started them); once, before any document changes: a job still waiting for its
    worker would read the document as it is then."""
    from ..rig.habits import ProjectHabits
    from ..rig.learned import document_habits, habits_of

    reading = plan.habits
    if isinstance(reading, ProjectHabits):
        return
    if reading is None:
        reading = start_habits(plan.skeletons, None)
    parts = []
    for (doc, rig), future in zip(reading.documents, reading.futures):
        try:
            parts.append(future.result())
        except WorkerLost:  # read here instead, the same way
            parts.append(document_habits(doc, rig))
    plan.habits = habits_of(parts)
    for _, rig in reading.documents:
        rig.habits = plan.habits


def settle_bending(plan: ProjectPlan, meshes: dict, workers: Workers | None, result=None,
                   progress: Progress = SILENT) -> None:
    """With ``--weights auto``, before the meshes go into the documents: the project's habits
    given to its rigs (:func:`gather_habits`), then the regions of ``plan`` that may bend
    (:attr:`~.plan.ProjectPlan.may_bend`) whose plain mesh the keep rule kept tested for
    bending, and those that bend meshed again as bending tasks on ``workers`` (this process
    without), into ``meshes`` and ``plan.tasks``, their targets' ``key`` set to it. Once: a
    second call does nothing. Its time counts as meshing (``result.seconds["mesh"]``).
    """
    from .meshing import mesh_tasks

    if plan.options is None or plan.options.weights != "auto":
        return
    t0 = time.perf_counter()
    gather_habits(plan)
    again = {}
    for t, bends in plan.may_bend:
        if not meshes[t.key].kept:
            continue  # meshed (or failed) plain: its bending task gives the same
        task = plan.tasks[t.key]
        if bends(art_box(task)):
            variant = bending_task(task)
            again.setdefault(variant.key, variant)
            t.key = variant.key
    plan.may_bend = []
    if again:
        progress.add("mesh", len(again))
        plan.tasks.update((key, task) for key, task in again.items() if key not in plan.tasks)
        meshes.update(mesh_tasks(again, workers or Workers(), lambda n: progress.advance("mesh", n)))
    if result is not None:
        result.seconds["mesh"] += time.perf_counter() - t0
