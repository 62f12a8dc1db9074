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
rule kept are tested for bending (:meth:`spinemesh.rig.upgraded_meshes.BendingRegions.bends`, on the
box of their art), as each plain mesh arrives (:class:`BendingTests`, while the workers mesh
the others), and meshed again as bending tasks; :func:`settle_bending` collects them before the
meshes go into the documents. Testing every region before meshing gave the same meshes for
about five times the tests (1,243 against 225 on the 45 skeletons of
``benchmarks/bench_upgrade_weights.py``), all in this process while the workers waited.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

from ..cluster import WorkerLost, Workers
from ..memory import out_of_memory
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
        except Exception as e:  # its worker lost, or no memory to hand the job over or its answer back
            if not (isinstance(e, WorkerLost) or out_of_memory(e)):
                raise
            parts.append(document_habits(doc, rig))  # read here instead, the same way
    plan.habits = habits_of(parts)
    for _, rig in reading.documents:
        rig.habits = plan.habits


@dataclass
class BendingTests:
    """The regions of a plan that may bend (:attr:`~.plan.ProjectPlan.may_bend`), tested as
    their plain meshes arrive (:meth:`arrived`, while the workers mesh the others), those that
    bend sent to the workers at once as bending tasks; :func:`settle_bending` collects them."""

    plan: ProjectPlan
    workers: Workers
    #: image key -> the targets drawing it that may bend, each with its test, not tested yet
    waiting: dict[str, list[tuple]] = field(default_factory=dict)
    #: the bending tasks sent, by key, and their meshing (:func:`.meshing.start_meshing`)
    tasks: dict = field(default_factory=dict)
    sent: list = field(default_factory=list)

    @classmethod
    def of(cls, plan: ProjectPlan, workers: Workers) -> BendingTests:
        tests = cls(plan, workers)
        for t, bends in plan.may_bend:
            tests.waiting.setdefault(t.key, []).append((t, bends))
        return tests

    def arrived(self, res) -> None:
        """Test the targets drawing the image of ``res`` (a :class:`~.meshing.MeshResult` of a
        plain task) when the keep rule kept it; send the bending task of those that bend."""
        from .meshing import start_meshing

        waiting = self.waiting.pop(res.key, [])
        if not waiting or not res.kept:
            return  # meshed (or failed) plain: its bending task gives the same
        gather_habits(self.plan)  # the test reads them
        task = self.plan.tasks[res.key]
        box = art_box(task)
        for t, bends in waiting:
            if bends(box):
                variant = bending_task(task)
                if variant.key not in self.tasks:
                    self.tasks[variant.key] = variant
                    self.sent.append(start_meshing({variant.key: variant}, self.workers))
                t.key = variant.key


def bending_tests(plan: ProjectPlan, workers: Workers) -> BendingTests | None:
    """With ``--weights auto``, the :class:`BendingTests` of ``plan`` on ``workers``, kept on the
    plan for :func:`settle_bending` (give :meth:`BendingTests.arrived` each plain mesh as it
    arrives); else None."""
    if plan.options is None or plan.options.weights != "auto":
        return None
    plan.bending = BendingTests.of(plan, workers)
    return plan.bending


def settle_bending(plan: ProjectPlan, meshes: dict, workers: Workers | None, result=None,
                   progress: Progress = SILENT) -> None:
    """With ``--weights auto``, before the meshes go into the documents: the project's habits
    given to its rigs (:func:`gather_habits`), every region of ``plan`` that may bend
    (:attr:`~.plan.ProjectPlan.may_bend`) whose plain mesh the keep rule kept tested for
    bending (those not tested as their meshes arrived, :func:`bending_tests`), and the bending
    tasks of those that bend meshed on ``workers`` (this process without), into ``meshes`` and
    ``plan.tasks``, their targets' ``key`` set to it. Once: a second call does nothing. Its time
    counts as meshing (``result.seconds["mesh"]``).
    """
    from .meshing import finish_meshing

    if plan.options is None or plan.options.weights != "auto":
        return
    t0 = time.perf_counter()
    gather_habits(plan)
    tests = plan.bending if plan.bending is not None else BendingTests.of(plan, workers or Workers())
    for key in list(tests.waiting):  # not tested as they arrived: tested now
        tests.arrived(meshes[key])
    plan.may_bend, plan.bending = [], None
    if tests.tasks:
        progress.add("mesh", len(tests.tasks))
        for meshing in tests.sent:
            meshes.update(finish_meshing(meshing, tests.tasks, tests.workers, lambda n: progress.advance("mesh", n)))
        plan.tasks.update((key, task) for key, task in tests.tasks.items() if key not in plan.tasks)
    if result is not None:
        result.seconds["mesh"] += time.perf_counter() - t0
