"""Upgrading one project: every region attachment becomes a mesh attachment.

The stages, in the order they run, each a module of its own, with the data they pass on:

1. read and plan (:mod:`.plan`): the skeletons are read and each region attachment is
   planned -> a :class:`~.plan.ProjectPlan` (documents, a :class:`~.report.Target` per
   region, one :class:`~.plan.MeshTask` per unique image); with local worker processes,
   the atlas pages the planning cuts from are decoded by them meanwhile, and with
   ``--weights auto`` the project's habits read (:mod:`.bending`);
2. mesh (:mod:`.meshing`): every task meshed once, on this process, local processes or a
   Dask cluster -> a :class:`~.meshing.MeshResult` per image key;
3. apply (:mod:`.apply`): the meshes put into the documents (and weighted, with
   ``--weights auto``, once the regions the keep rule kept are tested for bending and meshed
   again where they bend, :mod:`.bending`); the documents now hold the mesh attachments;
4. write (:mod:`.write`): the documents written in the format and version they came in,
   every other file copied, re-packed atlases written;
4b. pack (:mod:`.pack`, with ``--pack``): the written atlases packed anew by the meshes'
   outlines, in place;
5. report (:mod:`.report`): the targets, as rows of :func:`~.report.write_report`.

A stage that changes the meshed documents before they are written goes between 3 and 4, in
:func:`finish_project`; one that works on the files written (packing atlas pages) after 4.
:func:`upgrade_project` runs them for one project; :mod:`.library` for every project under a
folder, with one set of workers; :mod:`spinemesh.output` holds the output-folder rules both
follow. One bad attachment never aborts a project: it stays a region and the report says
why. The output does not depend on the workers: results are put back by image, never by
arrival order.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

from ..cluster import Workers
from ..output import check_output_folder, output_folder
from ..project import find_project
from ..written_folder import check_written_folder, rewriting_folder
from .apply import apply_project
from .bending import bending_tests, start_habits
from .meshing import MeshResult, mesh_tasks, meshing_workers
from .options import Options
from .pack import pack_written
from .plan import ProjectPlan, decode_pages_ahead, page_prefetch, plan_read_project, read_project
from .progress import SILENT, Progress
from .report import Result, mark_would_mesh, selection_left_nothing
from .write import copying_other_files, write_repacked_atlases, write_skeletons


def upgrade_project(project: str | Path, out: str | Path, options: Options | None = None,
                    progress: Progress = SILENT, mesh_cache: dict | None = None,
                    workers: Workers | None = None) -> Result:
    """Upgrade every skeleton of a project into ``out``.

    Parameters
    ----------
    project : path
        A project folder or one skeleton file.
    out : path
        Output folder; refused if it is the project folder or inside it.
    options : Options
    progress : Progress, optional
        Told each phase's work and steps as the run goes (:mod:`.progress`); default: nobody.
    mesh_cache : dict, optional
        Meshes kept across calls (see :func:`~.meshing.mesh_tasks`); None meshes afresh.
    workers : Workers, optional
        Workers to mesh on (kept open by the caller across projects); default: opened here
        from ``options.jobs`` and ``options.dask``.

    Returns
    -------
    Result
        Every region attachment with its status, for the report; ``partial`` is true when
        any attachment or skeleton failed. Nothing is written (not even ``out``) when the
        project has no skeleton, or when ``options.only``/``options.exclude`` leave no region
        attachment to upgrade (:func:`~.report.selection_left_nothing`).
    """
    options = options or Options()
    out = Path(out)
    proj = find_project(project)
    check_output_folder(proj.root, out, options.images_in)
    if options.images_out is not None:
        check_output_folder(proj.root, Path(options.images_out), options.images_in)
        check_written_folder(options.images_out, "images folder", "images")  # a user's pictures: refused
    if not proj.skeletons:  # nothing to upgrade (the caller says so): no output folder of copies alone
        return Result()
    with contextlib.ExitStack() as held:
        if not options.dry_run:  # its images are cut while reading: no stale image of an earlier run stays
            held.enter_context(rewriting_folder(options.images_out))
        result = Result()
        reading = read_project(proj, options, result, progress)       # 1. read and plan
        if selection_left_nothing(result):  # --only/--exclude matched nothing: nothing to write
            return result
        if not options.dry_run:  # held from here: reading the skeletons writes nothing
            held.enter_context(output_folder(out, options.overwrite))
        pages = reading.pages_to_decode()
        habits = [sk for sk in reading.skeletons if sk.rig is not None] if not options.dry_run else []
        if workers is None and not options.dry_run and options.jobs > 1 and not options.dask \
                and len(pages) + len(habits) > 1:
            # The workers that will mesh are opened before the planning, to decode its pages
            # and read the project's habits (--weights auto) meanwhile (local processes only,
            # see page_prefetch): with N of them, that takes about 1/N of this process's time.
            workers = held.enter_context(meshing_workers(options, None, tasks=len(pages) + len(habits)))
        decode_pages_ahead(reading, page_prefetch(workers))
        # read before any document changes: on the workers while this process cuts the images
        t0 = time.perf_counter()
        reading_habits = start_habits(habits, workers) if habits else None
        result.seconds["read"] += time.perf_counter() - t0
        plan = plan_read_project(reading)
        plan.habits = reading_habits
        plan.only_needed = Path(project).is_file()
        if options.dry_run:
            mark_would_mesh(result)
            return result
        if workers is None and options.weights == "auto":
            # opened here, not for the meshing alone: the new meshes are weighted on them too
            workers = held.enter_context(meshing_workers(options, None, 2 * len(plan.tasks)))
        meshes = mesh_project(plan, options, result, workers, progress, mesh_cache)  # 2. mesh
        finish_project(plan, meshes, out, result, progress, workers)  # 3.-4. apply, write
        return result                                                 # 5. the report's rows


def mesh_project(plan: ProjectPlan, options: Options, result: Result, workers: Workers | None,
                 progress: Progress, mesh_cache: dict | None) -> dict[str, MeshResult]:
    """Stage 2 for one project: mesh its unique images on ``workers`` (or ones opened for it).

    Parameters
    ----------
    plan : ProjectPlan
        From stage 1; with ``--weights auto`` its regions that may bend are tested as their
        meshes arrive (:func:`.bending.bending_tests`).
    options : Options
        ``jobs`` and ``dask``: the workers opened when ``workers`` is None.
    result : Result
        Gets the meshing time in ``seconds["mesh"]``.
    workers : Workers or None
        The caller's workers, kept open after this stage; None opens them for it.
    progress : Progress
        Told each image meshed (phase ``mesh``).
    mesh_cache : dict or None
        Meshes kept across calls (:func:`~.meshing.mesh_tasks`); None meshes afresh.

    Returns
    -------
    dict of str to MeshResult
        One per key of ``plan.tasks``.
    """
    t0 = time.perf_counter()
    progress.add("mesh", len(plan.tasks))
    with meshing_workers(options, workers, len(plan.tasks)) as w:
        # --weights auto: the regions that may bend tested as their meshes arrive, their bending
        # tasks sent meanwhile, on the caller's workers (they outlive this stage)
        tests = bending_tests(plan, workers) if workers is not None else None
        meshes = mesh_tasks(plan.tasks, w, lambda n: progress.advance("mesh", n), mesh_cache,
                            arrived=tests.arrived if tests is not None else None)
    result.seconds["mesh"] += time.perf_counter() - t0
    return meshes


def finish_project(plan: ProjectPlan, meshes: dict[str, MeshResult], out: Path, result: Result,
                   progress: Progress = SILENT, workers: Workers | None = None) -> None:
    """Stages 3 and 4 for one project: the meshes into its documents (weighted on ``workers``
    with ``--weights auto``, :func:`.apply.apply_project`), then everything written to ``out``
    (and packed with ``--pack``, on ``workers`` when given).

    Parameters
    ----------
    plan : ProjectPlan
        From stage 1; its documents are changed in place.
    meshes : dict of str to MeshResult
        From stage 2, by image key.
    out : Path
        The output folder, already checked and held (:func:`spinemesh.output.output_folder`).
    result : Result
        Gets the targets' statuses, the skeletons written, the problems, ``--pack``'s atlas
        rows, and the time of each stage in ``seconds`` (``write`` without the weights, the
        packing and the bending regions meshed again, which have lines of their own).
    progress : Progress, optional
        Told the phases ``weights``, ``write`` and ``pack``; default: nobody.
    workers : Workers, optional
        Where the weights and the packing run; default: this process.
    """
    t0 = time.perf_counter()
    weights_before, pack_before = result.seconds["weights"], result.seconds.get("pack", 0.0)
    mesh_before = result.seconds["mesh"]  # regions meshed again because they bend (.bending)
    with copying_other_files(plan, out, result):  # atlases, pages, other files: on threads meanwhile
        apply_project(plan, meshes, result, progress, workers)
        # A stage that changes the meshed documents before they are written goes here; it
        # sees every skeleton of the project. Files it replaces are left out of the copies
        # (output.files_to_copy, through copying_other_files above).
        write_skeletons(plan, out, result, progress)
    write_repacked_atlases(plan, out, result)
    if plan.options is not None and plan.options.pack:
        # --pack changes no document: it packs the atlases by the skeleton files written
        # (a game loads those), --repack's untrimmed pages included, so it runs last, in place
        pack_written(out, result, plan.options, workers, progress, source=plan.project, told=plan.pack_told)
    # every stage counted once: the meshing, the weights and the packing have lines of their own
    others = (result.seconds["weights"] - weights_before) + (result.seconds.get("pack", 0.0) - pack_before) \
        + (result.seconds["mesh"] - mesh_before)
    result.seconds["write"] += time.perf_counter() - t0 - others
