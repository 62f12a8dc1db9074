"""Meshing: every unique image meshed once, on the workers asked for.

:func:`mesh_one` is the worker's whole job, a pure function of a :class:`~.plan.MeshTask`
that gives a :class:`MeshResult`, so that this process, local processes and a Dask cluster
(:mod:`spinemesh.cluster`) all give the same answer. :func:`start_meshing` sends the tasks,
largest first; :func:`finish_meshing` collects the results by image key, never by arrival
order, so the output does not depend on the workers. A library run starts one project's
meshing while it writes an earlier one (:mod:`.library`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from ..attachment_geometry import spine_triangles
from ..cluster import WorkerLost, Workers, open_workers
from ..errors import ImageMemoryError, SpineMeshError
from ..memory import image_memory, memory_message, out_of_memory
from ..mesher.worth import MAX_HULL_TOLERANCE
from .options import Options
from .plan import MeshTask


@dataclass
class MeshResult:
    """A worker's answer for one :class:`MeshTask`.

    ``vertices`` (N, 2) float64 are pixels of the original image; the first ``hull`` are
    the outline in order. ``triangles`` (T, 3) int64 triangulate the whole hull polygon
    (Spine's mesh model), ``edges`` (E, 2) int64 are kept boundaries. On failure
    ``vertices`` is None and ``error`` says why. ``seconds`` is the meshing time.
    """

    key: str
    vertices: np.ndarray | None = None
    triangles: np.ndarray | None = None
    hull: int = 0
    edges: np.ndarray | None = None
    error: str = ""
    kept: str = ""  # why the image stays a region (spinemesh.mesher.worth); "" when meshed or failed
    overruled: str = ""  # a bending task meshed although the keep rule gave this reason
    seconds: float = 0.0
    coverage: float | None = None
    waste: float | None = None


#: How far (texels) the hull may lie inside the squares of the :func:`sampling_margin` mask.
SAMPLING_INSET = 0.5


def sampling_margin(mask: np.ndarray) -> np.ndarray:
    """Grow the art mask by one texel on every side.

    Runtimes sample textures bilinearly: a screen pixel whose sample point falls within half
    a texel of a visible texel's square (within one texel of its centre) takes some of its
    colour. A mesh that covers only the visible texels cuts those pixels off at its edge.
    The mask can only grow by whole texels, so the mesher covers the grown mask's squares
    and then moves the hull :data:`SAMPLING_INSET` texels back inwards
    (``MesherParams.hull_inset``): every point within half a texel of a visible texel's
    square stays inside. (Mipmapped pages, minified, sample further; the corpus has none.)
    """
    import cv2

    return cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def drawn_art(task: MeshTask, params, overrides: dict) -> np.ndarray:
    """What a mesh must cover, before :func:`sampling_margin`: shape (h, w), bool.

    With the alpha mask (``alpha`` or ``auto``) and no ``alpha_threshold`` asked for, it is
    every texel that can show where the attachment is drawn (:attr:`MeshTask.drawn`, from
    :func:`~.plan.texels_to_cover`): in additive, multiply and screen slots every texel the runtime
    draws (faint glows stacked over each other add up, and a premultiplied page's light,
    alpha 0 and colour > 0, adds to what lies below); in normal slots those that can move a
    pixel by more than :data:`~spinemesh.images.texels.FAINT_TEXEL`/255. A single alpha threshold
    would lose pixels the original draws. Otherwise the mesher's own mask.
    """
    from ..mesher import compute_mask

    if params.mask_source in ("alpha", "auto") and "alpha_threshold" not in overrides:
        return task.drawn
    return compute_mask(task.rgba, params.mask_source, params.alpha_threshold)


def mesh_one(task: MeshTask) -> MeshResult:
    """Worker: mesh one image and triangulate its whole hull, as Spine needs.

    A pure function of the task, so that any worker (local or on a cluster) gives the same
    answer. Problems of the image (:class:`SpineMeshError`), memory that cannot be had for it
    included (:func:`~spinemesh.memory.image_memory`), become the result's ``error``.

    Parameters
    ----------
    task : MeshTask
        The stored part of one unique image, its place in the original image and the mesher
        settings.

    Returns
    -------
    MeshResult
        ``vertices`` (N, 2) in pixels of the original image, the first ``hull`` the outline;
        ``triangles`` (T, 3); or ``vertices`` None with ``kept`` (the keep rule of
        :mod:`spinemesh.mesher.worth`: the region stays) or ``error`` saying why.

    Examples
    --------
    >>> import numpy as np
    >>> from spinemesh.upgrade import Options
    >>> from spinemesh.upgrade.plan import MeshTask
    >>> rgba = np.zeros((64, 64, 4), np.uint8)
    >>> y, x = np.mgrid[:64, :64]
    >>> rgba[(y - 32) ** 2 + (x - 32) ** 2 < 400] = 255   # an opaque disc in a 64 x 64 region
    >>> res = mesh_one(MeshTask("disc", rgba, (0, 0), (64, 64), Options().mesh_settings()))
    >>> res.error, res.kept, res.vertices.shape[1], res.triangles.shape[1], res.hull <= len(res.vertices)
    ('', '', 2, 3, True)
    """
    try:
        with image_memory("mesh", None, task.rgba.shape[1], task.rgba.shape[0]):
            return _mesh_one(task)
    except ImageMemoryError as e:
        return MeshResult(task.key, error=str(e))


def _mesh_one(task: MeshTask) -> MeshResult:
    from ..mesher import NotWorthMeshing, mesh_image, resolve_params
    from ..metrics import coverage_and_waste, opaque_mask

    preset, mask_source, overrides = task.settings
    start = time.perf_counter()
    try:
        # the mask grows the art by a whole texel; bilinear sampling needs half (sampling_margin);
        # large art: a tighter hull pays for its vertices (worth.MAX_HULL_TOLERANCE)
        params = resolve_params(preset, **{"hull_inset": SAMPLING_INSET, "max_hull_tolerance": MAX_HULL_TOLERANCE,
                                           **dict(overrides), "mask_source": mask_source})
        mask = sampling_margin(drawn_art(task, params, dict(overrides)))
        overruled = ""
        try:
            mesh = mesh_image(task.rgba, params, mask=mask)
        except NotWorthMeshing as e:
            if not task.bends or not params.min_saving:
                raise
            # art that bends is worth a mesh for that alone: only the vertex-cost rules stay
            overruled = str(e)
            mesh = mesh_image(task.rgba, dataclasses.replace(params, min_saving=0.0), mask=mask)
    except NotWorthMeshing as e:  # decided early, from the mask and the hull
        return MeshResult(task.key, kept=str(e), seconds=time.perf_counter() - start)
    except SpineMeshError as e:
        return MeshResult(task.key, error=str(e), seconds=time.perf_counter() - start)
    seconds = time.perf_counter() - start
    cov, wst = coverage_and_waste(mesh.vertices, mesh.triangles, opaque_mask(task.rgba))
    vertices = np.asarray(mesh.vertices, np.float64) + task.origin
    edges = np.asarray(mesh.edges, np.int64).reshape(-1, 2)
    # the mesher's own triangles with its holes filled; a fresh triangulation only for meshes
    # that are not one hull polygon (the paper preset's several loops)
    triangles = mesh.hull_triangles()
    if triangles is None:
        triangles = spine_triangles(vertices, mesh.hull, edges)
    if triangles is None:
        return MeshResult(task.key, error="mesh is not one fully triangulated hull polygon", seconds=seconds)
    return MeshResult(task.key, vertices, np.asarray(triangles, np.int64), int(mesh.hull), edges,
                      seconds=seconds, coverage=cov, waste=wst, overruled=overruled)


class ArrivalCount:
    """Tells ``progress(1)`` once per future: when its worker ends it (a done callback, on the
    workers' thread) or when this process collects it, whichever comes first. A future's waiters
    wake before its callbacks run, so a run that counted on the callbacks alone could end with
    a mesh not yet told."""

    def __init__(self, progress: Callable[[int], None]):
        self.progress, self.told, self.lock = progress, set(), threading.Lock()

    def __call__(self, future) -> None:
        with self.lock:
            if future in self.told:
                return
            self.told.add(future)
        self.progress(1)


@dataclass
class Meshing:
    """Meshes on their way: those known already, and the futures of those being made."""

    known: dict[str, MeshResult]
    futures: list
    #: the image key of each future, to name the task when its worker died (WorkerLost)
    keys: dict = field(default_factory=dict)
    #: told as each mesh arrives (:func:`start_meshing`); None: the progress is told as they are collected
    arrivals: ArrivalCount | None = None


def start_meshing(tasks: dict[str, MeshTask], workers: Workers, cache: dict | None = None,
                  inflight: dict | None = None, progress: Callable[[int], None] | None = None) -> Meshing:
    """Send every task whose mesh is not known yet to the workers, largest first.

    Largest first, so that no big image starts last and keeps one worker busy while the
    others idle. ``cache`` (results by image key and mesher settings) and ``inflight``
    (futures by the same key) let runs over many projects mesh each image only once, even
    while an earlier project's copy of it is still being meshed. ``progress(n)``, when given,
    is told the meshes known at once, then each as its worker ends it (on a thread of the
    workers' own): a library run meshes projects ahead while this process weights and writes
    an earlier one, and the meshing's bar moves meanwhile, not only once they are collected.
    """
    known: dict[str, MeshResult] = {}
    futures = []
    keys = {}
    for t in sorted(tasks.values(), key=lambda t: (-t.rgba.shape[0] * t.rgba.shape[1], t.key)):
        key = (t.key, t.settings)
        if cache is not None and key in cache:
            known[t.key] = cache[key]
        elif inflight is not None and key in inflight:
            futures.append(inflight[key])
            keys[inflight[key]] = t.key
        else:
            future = workers.submit(mesh_one, t)
            futures.append(future)
            keys[future] = t.key
            if inflight is not None:
                inflight[key] = future
    arrivals = None
    if progress is not None:
        if known:
            progress(len(known))
        arrivals = ArrivalCount(progress)
        for future in futures:
            future.add_done_callback(arrivals)
    return Meshing(known, futures, keys, arrivals)


def finish_meshing(meshing: Meshing, tasks: dict[str, MeshTask], workers: Workers,
                   progress: Callable[[int], None] | None = None, cache: dict | None = None,
                   inflight: dict | None = None,
                   arrived: Callable[[MeshResult], None] | None = None) -> dict[str, MeshResult]:
    """Collect the meshes as they arrive; ``progress(n)`` is told how many came (unless
    :func:`start_meshing` was given one: it was told as they arrived), ``arrived`` each mesh
    (those known first)."""
    if meshing.arrivals is not None:
        progress = None
    results = dict(meshing.known)
    if progress and results:
        progress(len(results))
    for res in results.values() if arrived else ():
        arrived(res)
    for future in workers.as_completed(meshing.futures):
        try:
            res = future.result()
        except WorkerLost as e:  # the others go on; this image's attachments stay regions
            res = MeshResult(meshing.keys[future], error=str(e))
        except Exception as e:
            if not out_of_memory(e):  # no memory to hand the task over or its answer back
                raise
            key = meshing.keys[future]
            shape = tasks[key].rgba.shape
            res = MeshResult(key, error=memory_message("mesh", shape[1], shape[0]))
        results[res.key] = res
        key = (res.key, tasks[res.key].settings)
        if cache is not None:
            cache[key] = res
        if inflight is not None:
            inflight.pop(key, None)
        if meshing.arrivals is not None:
            meshing.arrivals(future)
        elif progress:
            progress(1)
        if arrived:
            arrived(res)
    return results


def mesh_tasks(tasks: dict[str, MeshTask], workers: Workers,
               progress: Callable[[int], None] | None = None,
               cache: dict | None = None, arrived: Callable[[MeshResult], None] | None = None) -> dict[str, MeshResult]:
    """Mesh every unique image once (:func:`start_meshing`, then :func:`finish_meshing`).

    Stage 2 of :mod:`.run`.

    Parameters
    ----------
    tasks : dict of str to MeshTask
        The plan's tasks (:attr:`.plan.ProjectPlan.tasks`), by content key.
    workers : Workers
        Where :func:`mesh_one` runs (:mod:`spinemesh.cluster`); the answer is the same on any.
    progress : callable, optional
        ``progress(n)``: told how many tasks ended, as they end; default: nobody.
    cache : dict, optional
        Keeps results across calls (keyed by image and mesher settings), so that runs over
        projects sharing images (the same art exported for several Spine versions) mesh each
        image only once; default: none.
    arrived : callable, optional
        Told each :class:`MeshResult` as it arrives (``--weights auto``'s bending tests).

    Returns
    -------
    dict of str to MeshResult
        One result per key of ``tasks``, whatever order the workers answered in.
    """
    return finish_meshing(start_meshing(tasks, workers, cache, progress=progress), tasks, workers, cache=cache,
                          arrived=arrived)


@contextlib.contextmanager
def meshing_workers(options: Options, workers: Workers | None, tasks: int) -> Iterator[Workers]:
    """The given workers, or ones opened for this run (none for a single image)."""
    if workers is not None:
        yield workers
        return
    # Loaded before workers fork, so that they start with the mesher already imported.
    from .. import mesher  # noqa: F401

    jobs = options.jobs if tasks > 1 else 1
    with open_workers(jobs, options.dask) as opened:
        yield opened
