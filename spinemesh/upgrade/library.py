"""A library run: every project under a folder, on one set of workers started once.

This process plans projects ahead while the workers mesh earlier ones, and writes each
project (in order) once its meshes are back, so that the workers never wait for reading or
writing. Each project goes through the same stages as :func:`.run.upgrade_project`;
its :class:`~.report.Result` is merged into the library's.

With local worker processes, the atlas pages are decoded on the workers too: each project's
skeletons are read one project ahead of its planning (:func:`.plan.read_project`), which
names the pages the planning will cut from, and those are decoded by the workers ahead of
their meshing (:class:`~spinemesh.images.pages.PagePrefetch`) while this process plans the
project before. Decoding was most of this process's reading and planning, the one part of a
run that no added core shortened.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path

from ..cluster import Workers, open_workers
from ..errors import SpineMeshError
from ..images.pages import PagePrefetch
from ..output import check_output_folder, output_folder
from ..project import find_project, find_projects
from ..written_folder import check_written_folder, mark_written_folder, rewriting_folder
from .bending import HabitsReading, bending_tests, start_habits
from .meshing import Meshing, finish_meshing, start_meshing
from .options import Options
from .pack import PackAhead
from .plan import ProjectPlan, ProjectReading, decode_pages_ahead, page_prefetch, plan_read_project, read_project
from .progress import SILENT, Progress
from .report import Result, mark_would_mesh, merge
from .run import finish_project


def is_library(folder: str | Path) -> bool:
    """Whether ``folder`` holds several projects (or one below it) rather than being one project
    (:func:`library_projects`)."""
    return library_projects(folder) is not None


def library_projects(folder: str | Path) -> list[Path] | None:
    """The projects under ``folder`` (:func:`spinemesh.project.find_projects`) when it holds
    several (or one below it); ``None`` when it is one project.

    A folder holding none (empty, or no skeleton nor atlas in it or below it) is one project, to
    be refused as one: it is no folder of projects, whatever was meant. A run hands the list to
    :func:`upgrade_library` (or ``pack_library``, the preview): finding the projects reads the
    skeletons of folders that may be halves of one project, work not worth doing twice.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return None
    projects = find_projects(folder)
    return None if projects in ([folder], []) else projects


def files_outside_projects(library: str | Path, projects: list[Path]) -> list[Path]:
    """The files under ``library`` that lie in none of its ``projects`` (:func:`library_projects`),
    which a library run does not copy (a ``NOTES.txt`` beside the projects), walked as
    :func:`spinemesh.project.find_projects` walks (hidden files and folders left out), sorted.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> for name in ("hero/hero.json", "NOTES.txt", "docs/brief.md", ".DS_Store"):
    ...     (root / name).parent.mkdir(exist_ok=True)
    ...     _ = (root / name).write_text("{}")
    >>> [p.relative_to(root).as_posix() for p in files_outside_projects(root, [root / "hero"])]
    ['NOTES.txt', 'docs/brief.md']
    """
    from ..files.walk import walk_folder

    inside = {Path(p) for p in projects}
    outside: list[Path] = []
    for here, subfolders, files in walk_folder(library):
        subfolders[:] = [p for p in subfolders if p not in inside]
        if here not in inside:
            outside.extend(files)
    return sorted(outside)


def upgrade_library(library: str | Path, out: str | Path, options: Options | None = None,
                    progress: Progress = SILENT, projects: list[Path] | None = None) -> Result:
    """Upgrade every project under ``library`` into the same place under ``out``; one result.

    Projects are found as :func:`spinemesh.project.find_projects` finds them; each is
    upgraded as :func:`.run.upgrade_project` would, to ``out/<its path under library>``, on one
    set of workers started once. Files outside every project are not copied.

    Parameters
    ----------
    library : path
        A folder of project folders (:func:`is_library`).
    out : path
        The output folder; refused if it is the library or inside it.
    options : Options, optional
        As for one project; ``images_in`` (``--from-images``) is refused. Default: ``Options()``.
    progress : Progress, optional
        Told each phase's work as projects are planned, meshed and written (:mod:`.progress`);
        default: nobody.
    projects : list of path, optional
        The projects under ``library``, as :func:`library_projects` found them; found when not given.

    Returns
    -------
    Result
        Every project's targets, skeletons and errors, named by their path under ``library``.
    """
    options = options or Options()
    library, out = Path(library), Path(out)
    check_output_folder(library, out)
    if options.images_out is not None:  # a user's pictures: refused, not written over
        check_written_folder(options.images_out, "images folder", "images")
    if options.images_in is not None:
        raise SpineMeshError("--from-images reads one project's images; give one project, not a folder of them",
                             options.images_in)
    with contextlib.ExitStack() as held:
        if not options.dry_run:
            held.enter_context(output_folder(out, options.overwrite))
            held.enter_context(rewriting_folder(options.images_out))  # no stale image of an earlier run stays
        folders = find_projects(library) if projects is None else [Path(p) for p in projects]
        result = _upgrade_library(library, folders, out, options, progress)
    if options.images_out is not None and Path(options.images_out).is_dir():  # the projects' folders' folder
        mark_written_folder(options.images_out)
    return result


def _upgrade_library(library: Path, folders: list[Path], out: Path, options: Options, progress: Progress) -> Result:
    result = Result()
    from .. import mesher  # noqa: F401  (loaded before workers fork, see meshing_workers)

    # Projects are planned ahead while the workers mesh earlier ones (see the module's
    # docstring); how far ahead is bounded by the pixels sent and not yet written.
    cache: dict = {}
    inflight: dict = {}
    # --pack: the whole packing work known before the first project is packed (its total grew by projects)
    packing = PackAhead.of(library, folders) if options.pack and not options.dry_run else None
    with open_workers(options.jobs, options.dask) as workers:
        prefetch = page_prefetch(workers)
        ahead: deque[_LibraryProject] = deque()
        read: _LibraryProject | None = None  # read, its pages decoding, not planned yet
        for folder in [*folders, None]:
            following = _read_library_project(library, folder, options, workers, prefetch, progress) if folder else None
            if read is not None:
                ahead.append(_plan_library_project(read, workers, cache, inflight, progress))
                while ahead and sum(p.pixels for p in ahead) > AHEAD_PIXELS:
                    _finish_library_project(ahead.popleft(), out, workers, cache, inflight, result, progress, packing)
            read = following
        while ahead:
            _finish_library_project(ahead.popleft(), out, workers, cache, inflight, result, progress, packing)
    return result


#: Image pixels a library run sends to its workers ahead of writing: enough that workers
#: stay busy across small projects, few enough to bound memory (4 bytes each: 128 MB).
AHEAD_PIXELS = 32_000_000


@dataclass
class _LibraryProject:
    """One project of a library between planning and writing."""

    rel: str
    options: Options
    result: Result
    reading: ProjectReading | None = None
    habits: HabitsReading | None = None  # --weights auto: the project's habits being read
    plan: ProjectPlan | None = None
    meshing: Meshing | None = None

    @property
    def pixels(self) -> int:
        """Pixels of the images this project sent to the workers."""
        return sum(t.rgba.shape[0] * t.rgba.shape[1] for t in self.plan.tasks.values()) if self.plan else 0


def _read_library_project(library: Path, folder: Path, options: Options, workers: Workers,
                          prefetch: PagePrefetch | None, progress: Progress) -> _LibraryProject:
    """A project's skeletons read (:func:`.plan.read_project`), its pages handed to ``prefetch``
    and, with ``--weights auto``, its habits to ``workers`` (:func:`.bending.start_habits`)."""
    rel = folder.relative_to(library).as_posix()
    sub = dataclasses.replace(options, images_out=None if options.images_out is None
                              else Path(options.images_out) / rel)
    p = _LibraryProject(rel, sub, Result())
    try:
        p.reading = read_project(find_project(folder), sub, p.result, progress)
    except SpineMeshError as e:
        p.result.errors.append(str(e))
        return p
    decode_pages_ahead(p.reading, prefetch)
    if sub.weights == "auto" and not sub.dry_run:
        t0 = time.perf_counter()
        p.habits = start_habits([sk for sk in p.reading.skeletons if sk.rig is not None], workers)
        p.result.seconds["read"] += time.perf_counter() - t0
    return p


def _plan_library_project(p: _LibraryProject, workers: Workers, cache: dict, inflight: dict,
                          progress: Progress) -> _LibraryProject:
    """A project read by :func:`_read_library_project` planned, and its meshing started."""
    if p.reading is None:
        return p
    try:
        p.plan = plan_read_project(p.reading)
    except SpineMeshError as e:
        p.result.errors.append(str(e))
        return p
    finally:
        p.reading = None
    p.plan.habits, p.habits = p.habits, None
    sub = p.options
    if not sub.dry_run:
        t0 = time.perf_counter()  # with workers, sending only; in this process, the meshing itself
        # told as each mesh arrives: the workers mesh this project while earlier ones are weighted and written
        progress.add("mesh", len(p.plan.tasks), p.rel)
        p.meshing = start_meshing(p.plan.tasks, workers, cache, inflight, lambda n: progress.advance("mesh", n))
        p.result.seconds["mesh"] += time.perf_counter() - t0
    return p


def _finish_library_project(p: _LibraryProject, out: Path, workers: Workers, cache: dict, inflight: dict,
                            result: Result, progress: Progress, packing: PackAhead | None = None) -> None:
    progress.project(p.rel)
    if p.plan is not None and p.options.dry_run:
        mark_would_mesh(p.result)
    elif p.plan is not None:
        if packing is not None:
            p.plan.pack_told = functools.partial(packing.tell, progress, p.rel)
        t0 = time.perf_counter()
        tests = bending_tests(p.plan, workers)  # --weights auto: tested as their meshes arrive
        meshes = finish_meshing(p.meshing, p.plan.tasks, workers, cache=cache, inflight=inflight,
                                arrived=tests.arrived if tests is not None else None)
        p.result.seconds["mesh"] += time.perf_counter() - t0
        try:
            finish_project(p.plan, meshes, out / p.rel, p.result, progress, workers)
        except SpineMeshError as e:
            p.result.errors.append(str(e))
    if packing is not None:
        packing.settle(progress, p.rel)
    merge(result, p.result, "" if p.rel == "." else p.rel + "/")
