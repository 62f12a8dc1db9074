"""Stage 4, write: documents to files, every other file copied.

:func:`write_skeletons` writes each document (its meshes applied by :mod:`.apply`) in the format
and version it came in; :func:`copying_other_files` copies atlases, pages and everything else on
threads meanwhile (what is copied: :func:`spinemesh.output.files_to_copy`);
:func:`write_repacked_atlases` rewrites the atlases whose sequences ``--repack`` stores
whole. Each problem is one line in the :class:`~.report.Result`, never an abort.
"""

from __future__ import annotations

import contextlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterator

from ..errors import SpineMeshError
from ..files.atomic import atomic_copy, stop_if_every_write_refused
from ..output import atlas_pages, copy_atlases_last, files_needed, files_to_copy, write_skeleton
from .plan import ProjectPlan
from .progress import SILENT, Progress
from .repack import write_repacked_atlas
from .report import Result


def write_skeletons(plan: ProjectPlan, out: Path, result: Result, progress: Progress = SILENT) -> None:
    """Write every document of ``plan`` under ``out``; those written go to ``result.written``.

    Stage 4 of :mod:`.run`: each skeleton in the format and version it came in, at its path
    under the project (:func:`spinemesh.output.write_skeleton`).

    Parameters
    ----------
    plan : ProjectPlan
        The documents, meshes applied (:func:`.apply.apply_project`).
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
            stop_if_every_write_refused(e)
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
    failed = set()
    try:
        yield
        for real, copy in copies:
            try:
                copy.result()
            except SpineMeshError as e:
                stop_if_every_write_refused(e)
                failed.add(real)
                result.errors.append(f"not copied: {e}")
    except BaseException:  # the run stops (a full disk, Ctrl-C): no copy not yet started starts
        copier.shutdown(cancel_futures=True)
        raise
    copier.shutdown()
    result.errors += copy_atlases_last([(source, dest) for source, dest, real in pairs if real in pages_of],
                                       pages_of, failed=failed)


def write_repacked_atlases(plan: ProjectPlan, out: Path, result: Result) -> None:
    """``--repack``: rewrite each atlas whose sequences are stored whole (:mod:`.repack`) under ``out``."""
    for atlas_path, names in sorted(plan.untrimmed.items()):
        try:
            write_repacked_atlas(atlas_path, names, plan.project.root, out)
        except SpineMeshError as e:
            stop_if_every_write_refused(e)
            result.errors.append(f"{atlas_path}: not re-packed: {e}")
