"""Upgrading whole projects: every region attachment becomes a mesh attachment.

The work is split so that each part can be read on its own:

1. :func:`plan_project` reads the skeletons and decides, per region attachment, which
   image(s) it needs or why it is left alone; each unique image becomes one
   :class:`MeshTask` holding only the part the atlas stores (a small crop, not a page);
2. :func:`mesh_tasks` hands the tasks to workers (this process, local processes or a
   Dask cluster, see :mod:`spinemesh.cluster`), largest first, and collects the meshes as
   they come back;
3. :func:`write_project` puts the meshes into the skeletons, writes them in the format and
   version they came in, and copies everything else.

:func:`upgrade_project` runs the three for one project, :func:`upgrade_library` for every
project under a folder, with one set of workers. One bad attachment never aborts a
project: it stays a region and the report says why. The output does not depend on the
workers: results are put back by image, never by arrival order.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fnmatch
import os
import shutil
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

try:
    import fcntl  # POSIX: a run holds its output folder
except ImportError:  # Windows: no lock
    fcntl = None

from ..cluster import Workers, open_workers
from ..errors import SpineMeshError
from ..fsutil import (
    OutputGuard, atomic_copy, make_folder, atomic_write_bytes, atomic_write_json, atomic_write_png, atomic_write_text, resolve_inside,
)
from ..images import FAINT_TEXEL, RegionImage, content_id
from ..mesher.worth import DEFAULT_MIN_SAVING, MAX_HULL_TOLERANCE
from ..project import Project, find_project, find_projects, image_source_for
from ..runs import RunSummary
from ..skeleton import AttachmentRef, dumps_skeleton, image_paths, is_binary_skeleton, iter_attachments, load_skeleton
from .geometry import frames_on_one_grid, mesh_attachment, spine_triangles
from .repack import write_repacked_atlas

#: A file that marks a folder as written by ``upgrade``: only such a folder is replaced by
#: ``overwrite`` (a mistyped ``--out ~/Documents --overwrite`` must not delete a user's files).
OUTPUT_MARKER = ".spinemesh-output"


@dataclass
class Options:
    """What the user asked for (see ``spinemesh upgrade --help``)."""

    preset: str = "default"
    mask: str = "auto"
    only: list[str] = field(default_factory=list)
    exclude: list[str] = field(default_factory=list)
    min_size: float = 0.0
    dry_run: bool = False
    jobs: int = 1
    dask: str | None = None
    images_out: Path | None = None
    images_in: Path | None = None
    overrides: dict = field(default_factory=dict)
    overwrite: bool = False
    repack: bool = False  # store sequence frames whole where one mesh cannot fit them trimmed
    # keep a region when its mesh would save less than this share of drawn pixels (or needs
    # too many vertices): spinemesh.mesher.worth; None meshes every region
    min_saving: float | None = DEFAULT_MIN_SAVING
    weights: str = "none"  # auto: bind and weight the upgraded meshes (spinemesh.rig)

    def mesh_settings(self) -> tuple:
        """What, besides the pixels, decides a mesh: part of every cache key."""
        overrides = {**self.overrides, "min_saving": self.min_saving}
        return (self.preset, mask_source_for_upgrade(self.mask), tuple(sorted(overrides.items())))


def mask_source_for_upgrade(mask: str) -> str:
    """The mask source that ``upgrade`` uses for ``--mask``.

    ``auto`` means alpha here: an atlas region is drawn by the runtime through its alpha (a
    page without alpha is drawn whole), so alpha is what keeps every drawn pixel inside the
    mesh. The network's guess (``model``) may cut drawn pixels off and is used only when asked.
    """
    return "alpha" if mask == "auto" else mask


@dataclass
class Target:
    """One region attachment and what became of it."""

    skeleton: str
    skin: str
    slot: str
    name: str
    paths: list[str]
    # meshed | kept (a deliberate, documented skip; ``reason`` says why) | failed;
    # planned while the run is under way, "would mesh" in a dry run.
    status: str = "pending"
    reason: str = ""
    key: str = ""                    # content key of its (composited) image
    vertices: int = 0
    triangles: int = 0
    coverage: float | None = None
    waste: float | None = None
    seconds: float = 0.0

    weights: dict | None = None      # --weights auto: bones chosen and why (spinemesh.rig.upgrade)
    # --weights auto, meshed only because it would bend: the keep rule's reason, and the region
    # it replaced (put back if the mesh does not get more than one bone); not report columns
    overruled: str = ""
    region: dict | None = None

    def row(self) -> dict:
        return {k: v for k, v in self.__dict__.items()
                if k not in ("key", "overruled", "region") and not (k == "weights" and v is None)}


@dataclass
class MeshTask:
    """What a worker needs to mesh one unique image: small, and the same wherever it runs.

    Attributes
    ----------
    key : str
        Content key of the image (:func:`spinemesh.images.content_id` of the stored part).
    rgba : ndarray, shape (h, w, 4), uint8
        The part of the original image that the atlas stores (straight alpha).
    origin : (int, int)
        Where that part starts in the original image, in pixels (x, y).
    size : (int, int)
        The original image's width and height in pixels.
    settings : tuple
        ``(preset, mask source, overrides)`` as :meth:`Options.mesh_settings` gives them.
    drawn : ndarray, shape (h, w), bool, optional
        Texels of ``rgba`` the mesh must cover (any frame): those that can show in the
        attachment's slot (:func:`texels_to_cover`); default ``alpha > 0``.
    bends : bool
        ``--weights auto``: the art would bend with the skeleton (:func:`bending_task`), so a
        keep rule on saving alone does not keep it; the result says what the rule said.
    """

    key: str
    rgba: np.ndarray
    origin: tuple[int, int]
    size: tuple[int, int]
    settings: tuple
    drawn: np.ndarray | None = None
    bends: bool = False

    def __post_init__(self):
        if self.drawn is None:
            self.drawn = self.rgba[..., 3] > 0


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


def _matches(patterns: list[str], ref: AttachmentRef, paths: list[str]) -> bool:
    names = [ref.slot, ref.name, *paths]
    return any(fnmatch.fnmatchcase(n, p) for p in patterns for n in names)


def composite_image(images: list[np.ndarray]) -> np.ndarray:
    """One image whose alpha covers every frame of a sequence (max over frames).

    Colours come from the first frame, which is what interior boundaries are found on.
    """
    out = images[0].copy()
    for im in images[1:]:
        out[..., 3] = np.maximum(out[..., 3], im[..., 3])
    return out


def stored_box(boxes: list[tuple[int, int, int, int]]) -> tuple[int, int, int, int] | None:
    """The part of the original image that every frame stores on the atlas page (intersection)."""
    x0, y0 = max(b[0] for b in boxes), max(b[1] for b in boxes)
    x1, y1 = min(b[2] for b in boxes), min(b[3] for b in boxes)
    return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None


def _inside(visible: np.ndarray, box: tuple[int, int, int, int]) -> bool:
    x0, y0, x1, y1 = box
    return int(visible.sum()) == int(visible[y0:y1, x0:x1].sum())


def skip_reason(ref: AttachmentRef, paths: list[str], options: Options) -> str:
    """Why the user's options leave this region alone (``""`` when they do not)."""
    if options.only and not _matches(options.only, ref, paths):
        return "not matched by --only"
    if options.exclude and _matches(options.exclude, ref, paths):
        return "matched by --exclude"
    w, h = float(ref.attachment.get("width", 32)), float(ref.attachment.get("height", 32))
    if max(w, h) < options.min_size:
        return f"smaller than --min-size {options.min_size:g}"
    return ""


def source_identity(source) -> tuple:
    """Sources with equal identities give equal images for equal paths (twin skeletons share one)."""
    atlases = getattr(source, "atlases", None)
    if atlases is not None:
        return ("atlas",) + tuple(str(a.path) for a in atlases)
    return ("folder", str(getattr(source, "folder", id(source))))


def task_for_frames(frames: list[RegionImage], options: Options,
                    blend: str = "normal") -> tuple[MeshTask | None, str, str]:
    """The mesh task of an attachment's frame image(s), or ``(None, status, reason)``.

    ``blend`` is the slot's blend mode: with ``normal`` the mesh must cover the texels that
    can show (:attr:`RegionImage.shown`), with any other every texel drawn (see
    :func:`texels_to_cover`).
    """
    # Frames of different sizes are compared where the runtime draws them: relative to their size.
    frames = frames_on_one_grid(frames)
    rgba = composite_image([f.rgba for f in frames])
    if options.mask != "model" and not np.logical_or.reduce([f.drawn for f in frames]).any():
        return None, "kept", "image is fully transparent"
    drawn = np.logical_or.reduce(texels_to_cover(frames, blend))
    if options.mask != "model" and not drawn.any():
        return None, "kept", f"only faint texels (none above {FAINT_TEXEL}/255), drawn with normal blending"
    box = stored_box([f.content for f in frames])
    if box is None or not _inside(drawn, box):
        if not options.repack:
            return None, "kept", ("sequence frames were trimmed differently on the atlas page, so one mesh "
                                  "would sample neighbouring regions; --repack stores them whole")
        # --repack stores every frame whole (see needs_repack): the mesh may use the whole image.
        box = (0, 0, rgba.shape[1], rgba.shape[0])
    x0, y0, x1, y1 = box
    # Meshing the stored part only keeps every vertex where the atlas has this image's texels.
    crop = np.ascontiguousarray(rgba[y0:y1, x0:x1])
    drawn = np.ascontiguousarray(drawn[y0:y1, x0:x1])
    key = content_id(rgba, (x0, y0, x1 - x0, y1 - y0))
    if not np.array_equal(drawn, crop[..., 3] > 0):
        # Premultiplied light (alpha 0, colour > 0) is not in the straight pixels: key it too.
        key += "-" + content_id(np.repeat(drawn[..., None], 4, axis=-1).astype(np.uint8), (0, 0, x1 - x0, y1 - y0))[:16]
    size = (rgba.shape[1], rgba.shape[0])
    return MeshTask(key, crop, (x0, y0), size, options.mesh_settings(), drawn), "planned", ""


def texels_to_cover(frames: list[RegionImage], blend: str) -> list[np.ndarray]:
    """Per frame, the texels a mesh drawn in a slot with this ``blend`` mode must cover.

    Normal blending: the texels that can move a pixel by more than
    :data:`~spinemesh.images.FAINT_TEXEL`/255 (:attr:`RegionImage.shown`); fainter ones
    cannot, in one layer, wherever and however large they are drawn. Additive, multiply and
    screen slots are made to be stacked (glows, particles), where faint layers add up: every
    texel drawn (:attr:`RegionImage.drawn`). Measured with the runtime proof: leaving texels
    of at most 2/255 out in additive slots too, one corpus skeleton of eight stacked additive
    particle layers lost 44,509 visible pixels (worst 16/255).
    """
    return [f.shown if blend == "normal" else f.drawn for f in frames]


#: Key prefix of a :class:`MeshTask` meshed because its art bends: the same image keyed apart,
#: so that an image shared by a bending and a non-bending attachment gets both results.
BENDS_KEY = "bends:"


def bending_task(task: MeshTask) -> MeshTask:
    """The same image meshed for an attachment that bends (``--weights auto``).

    Bending with the skeleton is worth a mesh whatever it saves: the keep rule's saving tests
    (:mod:`spinemesh.mesher.worth` rules 1 and 3) are dropped for it; its vertex-cost tests
    (scattered islands, a huge outline) still hold, since nobody bends a rain sheet. Where the
    rule does not keep the image, the mesh is the one the plain task gives.
    """
    return dataclasses.replace(task, key=BENDS_KEY + task.key, bends=True)


def needs_repack(frames: list[RegionImage], task: MeshTask) -> bool:
    """Whether ``task`` meshes beyond what some frame stores, so those frames must be re-packed whole."""
    return task.origin == (0, 0) and tuple(task.rgba.shape[1::-1]) == task.size and any(
        tuple(f.content) != (0, 0, f.rgba.shape[1], f.rgba.shape[0]) for f in frames)


def write_editor_image(frame: RegionImage, folder: Path) -> None:
    """``<folder>/<path>.png``, the original-size image the editor re-imports.

    Atlas images exported at a scale other than 1 are resized back to skeleton size.
    """
    rgba = frame.rgba
    if frame.scale != 1:
        import cv2

        h, w = rgba.shape[:2]
        size = (max(1, round(w / frame.scale)), max(1, round(h / frame.scale)))
        rgba = cv2.resize(rgba, size, interpolation=cv2.INTER_CUBIC)
    atomic_write_png(resolve_inside(folder, frame.name + ".png", folder, "--images folder"), rgba)


@dataclass
class Planner:
    """Plans skeletons one after another, sharing what they share.

    Each image is decoded once: twin skeletons (``.json`` and ``.skel`` of one project)
    reuse the first one's decision, and the editor images (``--images``) are written from
    that same decode.
    """

    options: Options
    tasks: dict[str, MeshTask] = field(default_factory=dict)
    decided: dict[tuple, tuple[str, str, str]] = field(default_factory=dict)
    #: tasks decided, by key; in ``tasks`` only once an attachment uses them (a bending
    #: attachment uses its bending variant instead)
    found: dict[str, MeshTask] = field(default_factory=dict)
    editor_images: set[str] = field(default_factory=set)
    #: ``--repack``: atlas path -> names of the regions to store untrimmed.
    untrimmed: dict[Path, set[str]] = field(default_factory=dict)

    def plan_skeleton(self, doc: dict, skeleton: str, source, bending=None) -> list[Target]:
        """A :class:`Target` for every region attachment of ``doc``, in document order.

        ``bending`` (:class:`spinemesh.rig.upgrade.BendingRegions` of ``doc``, with
        ``--weights auto``) tells which regions would bend: those get :func:`bending_task`.
        """
        targets = []
        # the slot's blend mode decides which faint texels a mesh must cover (texels_to_cover)
        blends = {s.get("name"): s.get("blend", "normal") for s in doc.get("slots", []) if isinstance(s, dict)}
        for ref in iter_attachments(doc):
            if ref.type != "region":
                continue
            try:
                paths = image_paths(ref)
            except SpineMeshError as e:  # a malformed sequence: this attachment alone stays a region
                targets.append(Target(skeleton, ref.skin, ref.slot, ref.name, [], "failed", str(e)))
                continue
            t = Target(skeleton, ref.skin, ref.slot, ref.name, paths)
            targets.append(t)
            try:
                reason = skip_reason(ref, paths, self.options)
            except (TypeError, ValueError):
                t.status, t.reason = "failed", "width/height are not numbers"
                continue
            if reason:
                t.status, t.reason = "kept", reason
            elif source is None:
                t.status, t.reason = "failed", "no atlas or images folder holds its image"
            else:
                # only with a keep rule on saving (min_saving > 0): without it every region is meshed
                bends = bending is not None and bool(self.options.min_saving) and bending.bends(ref)
                t.status, t.reason, t.key = self._decide(source, paths, blends.get(ref.slot, "normal"), bends)
        return targets

    def _decide(self, source, paths: list[str], blend: str = "normal",
                bends: bool = False) -> tuple[str, str, str]:
        seen = (source_identity(source), tuple(paths), blend == "normal")
        if seen not in self.decided:
            try:
                frames = [source.get(p) for p in paths]
            except SpineMeshError as e:
                self.decided[seen] = ("failed", str(e), "")
            else:
                task, status, reason = task_for_frames(frames, self.options, blend)
                if task is not None:
                    try:
                        self._write_editor_images(frames)
                    except SpineMeshError as e:
                        # Without its editor image the mesh could not be re-imported: stays a region.
                        task, status, reason = None, "failed", f"editor image not written: {e}"
                if task is not None:
                    self.found[task.key] = task
                    if self.options.repack and needs_repack(frames, task):
                        for name in paths:
                            atlas = next(a for a in source.atlases if a.find(name) is not None)
                            self.untrimmed.setdefault(atlas.path, set()).add(name)
                self.decided[seen] = (status, reason, task.key if task else "")
        status, reason, key = self.decided[seen]
        if key:
            task = self.found[key]
            if bends:
                task = bending_task(task)
            self.tasks.setdefault(task.key, task)
            key = task.key
        return status, reason, key

    def _write_editor_images(self, frames: list[RegionImage]) -> None:
        folder = self.options.images_out
        if folder is None or self.options.dry_run:
            return
        for frame in frames:
            if frame.name not in self.editor_images:
                self.editor_images.add(frame.name)
                write_editor_image(frame, Path(folder))


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
    :func:`texels_to_cover`): in additive, multiply and screen slots every texel the runtime
    draws (faint glows stacked over each other add up, and a premultiplied page's light,
    alpha 0 and colour > 0, adds to what lies below); in normal slots those that can move a
    pixel by more than :data:`~spinemesh.images.FAINT_TEXEL`/255. A single alpha threshold
    would lose pixels the original draws. Otherwise the mesher's own mask.
    """
    from ..mesher import compute_mask

    if params.mask_source in ("alpha", "auto") and "alpha_threshold" not in overrides:
        return task.drawn
    return compute_mask(task.rgba, params.mask_source, params.alpha_threshold)


def mesh_one(task: MeshTask) -> MeshResult:
    """Worker: mesh one image and triangulate its whole hull, as Spine needs.

    A pure function of the task, so that any worker (local or on a cluster) gives the same
    answer. Problems of the image (:class:`SpineMeshError`) become the result's ``error``.
    """
    from ..mesher import NotWorthMeshing, mesh_image, resolve_params
    from ..metrics import coverage, opaque_mask, waste

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
    art = opaque_mask(task.rgba)
    cov = coverage(mesh.vertices, mesh.triangles, art) if art.any() else 1.0
    wst = waste(mesh.vertices, mesh.triangles, art)
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


@dataclass
class Meshing:
    """Meshes on their way: those known already, and the futures of those being made."""

    known: dict[str, MeshResult]
    futures: list


def start_meshing(tasks: dict[str, MeshTask], workers: Workers, cache: dict | None = None,
                  inflight: dict | None = None) -> Meshing:
    """Send every task whose mesh is not known yet to the workers, largest first.

    Largest first, so that no big image starts last and keeps one worker busy while the
    others idle. ``cache`` (results by image key and mesher settings) and ``inflight``
    (futures by the same key) let runs over many projects mesh each image only once, even
    while an earlier project's copy of it is still being meshed.
    """
    known: dict[str, MeshResult] = {}
    futures = []
    for t in sorted(tasks.values(), key=lambda t: (-t.rgba.shape[0] * t.rgba.shape[1], t.key)):
        key = (t.key, t.settings)
        if cache is not None and key in cache:
            known[t.key] = cache[key]
        elif inflight is not None and key in inflight:
            futures.append(inflight[key])
        else:
            future = workers.submit(mesh_one, t)
            futures.append(future)
            if inflight is not None:
                inflight[key] = future
    return Meshing(known, futures)


def finish_meshing(meshing: Meshing, tasks: dict[str, MeshTask], workers: Workers,
                   progress: Callable[[int], None] | None = None, cache: dict | None = None,
                   inflight: dict | None = None) -> dict[str, MeshResult]:
    """Collect the meshes as they arrive; ``progress(n)`` is told how many came."""
    results = dict(meshing.known)
    if progress and results:
        progress(len(results))
    for future in workers.as_completed(meshing.futures):
        res = future.result()
        results[res.key] = res
        key = (res.key, tasks[res.key].settings)
        if cache is not None:
            cache[key] = res
        if inflight is not None:
            inflight.pop(key, None)
        if progress:
            progress(1)
    return results


def mesh_tasks(tasks: dict[str, MeshTask], workers: Workers,
               progress: Callable[[int], None] | None = None,
               cache: dict | None = None) -> dict[str, MeshResult]:
    """Mesh every unique image once (:func:`start_meshing`, then :func:`finish_meshing`).

    ``cache``, if given, keeps results across calls (keyed by image and mesher settings), so
    that runs over projects sharing images (the same art exported for several Spine
    versions) mesh each image only once.
    """
    return finish_meshing(start_meshing(tasks, workers, cache), tasks, workers, progress, cache)


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


def check_output_folder(project_root: Path, out: Path, images_in: Path | None = None) -> None:
    """Refuse an output folder that is an input, lies inside one or holds one (see :class:`OutputGuard`)."""
    OutputGuard([project_root, images_in]).check_folder(out, may_hold_inputs=False)


@contextlib.contextmanager
def output_folder(out: Path, overwrite: bool):
    """Hold ``out`` for one run: an empty folder marked as ours, or refused.

    An existing non-empty ``out`` is refused unless ``overwrite``; then its contents are
    removed (no stale file of an earlier run stays), but only if an earlier ``upgrade`` wrote
    it (:data:`OUTPUT_MARKER`). The folder itself is kept and locked (``flock``) while the
    run lasts: a second run into the same folder waits for the first to end instead of
    deleting or overwriting its files half-way.
    """
    if out.exists() and not out.is_dir():
        raise SpineMeshError("output folder exists and is not a folder", out)
    make_folder(out)
    fd = os.open(out, os.O_RDONLY)
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX)
        entries = list(out.iterdir())
        if entries:
            if not overwrite:
                raise SpineMeshError("output folder is not empty; pass --overwrite to replace it as a whole", out)
            if not (out / OUTPUT_MARKER).is_file():
                raise SpineMeshError("output folder is not empty and was not written by spinemesh upgrade; "
                                     "refusing to delete it, choose another --out", out)
            for entry in entries:
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
        atomic_write_text(out / OUTPUT_MARKER, "written by spinemesh upgrade; --overwrite may replace this folder\n")
        yield out
    finally:
        os.close(fd)  # releases the lock


def files_needed(doc: dict, source) -> set[Path]:
    """The files a skeleton needs beside it (real paths): its atlases and their pages, or its images."""
    from ..images import AtlasImages, FolderImages
    from ..project import needed_images

    if isinstance(source, AtlasImages):
        return {Path(a.path).resolve() for a in source.atlases} | {
            source.page_file(a, i).resolve() for a in source.atlases for i in range(len(a.pages))}
    if isinstance(source, FolderImages):
        return {p.resolve() for p in map(source.path_of, sorted(needed_images(doc))) if p is not None}
    return set()


@dataclass
class Result(RunSummary):
    """What a run did: every target, the skeletons written and the problems met."""

    targets: list[Target] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    seconds: dict = field(default_factory=lambda: {"read": 0.0, "mesh": 0.0, "write": 0.0})

    def _items(self):
        return self.targets


@dataclass
class SkeletonPlan:
    """One skeleton read and planned: its document, targets and image source."""

    path: Path
    rel: str
    doc: dict
    targets: list[Target]
    source: object
    rig: object = None  # --weights auto: spinemesh.rig.document.Rig, built once per skeleton


@dataclass
class ProjectPlan:
    """Everything :func:`write_project` needs, and the unique images to mesh."""

    project: Project
    skeletons: list[SkeletonPlan]
    tasks: dict[str, MeshTask]
    only_needed: bool = False  # one skeleton file was asked for: copy only the files it uses
    untrimmed: dict[Path, set[str]] = field(default_factory=dict)  # --repack: atlas -> regions
    options: Options | None = None


def plan_project(proj: Project, options: Options, result: Result) -> ProjectPlan:
    """Read every skeleton of ``proj`` and plan its regions; unreadable skeletons go to ``result.errors``."""
    t0 = time.perf_counter()
    planner = Planner(options)
    skeletons = []
    for path in proj.skeletons:
        rel = path.relative_to(proj.root).as_posix()
        try:
            doc = load_skeleton(path)
            source = image_source_for(doc, path, proj, images=options.images_in)
        except SpineMeshError as e:
            result.errors.append(str(e))
            continue
        bending = bending_regions(doc) if options.weights == "auto" else None
        targets = planner.plan_skeleton(doc, rel, source, bending)
        result.targets += targets
        skeletons.append(SkeletonPlan(path, rel, doc, targets, source, bending.rig if bending else None))
    result.errors += proj.problems  # files left out: symlinks leading outside, broken atlases
    result.seconds["read"] += time.perf_counter() - t0
    return ProjectPlan(proj, skeletons, planner.tasks, untrimmed=planner.untrimmed, options=options)


def bending_regions(doc: dict):
    """:class:`spinemesh.rig.upgrade.BendingRegions` of ``doc``, or None when its rig cannot be built."""
    from ..rig.document import build_rig
    from ..rig.upgrade import BendingRegions

    try:
        return BendingRegions.of(build_rig(doc))
    except SpineMeshError:
        return None  # the weighting reports it, per mesh


def write_skeleton(doc: dict, path: Path, dest: Path) -> None:
    """Write ``doc`` to ``dest`` in the format ``path`` came in (binary ``.skel`` or JSON).

    JSON keeps the text of ``path`` wherever ``doc`` did not change, in its formatting, so
    that a version-control diff shows only the upgraded attachments.
    """
    if is_binary_skeleton(path):
        from ..skeleton_binary import write_skel

        atomic_write_bytes(dest, write_skel(doc, dest))
    else:
        original = path.read_bytes().decode("utf-8-sig")
        atomic_write_text(dest, dumps_skeleton(doc, dest, like=original))


def copy_other_files(proj: Project, out: Path, written: set[Path], needed: set[Path] | None = None) -> None:
    """Copy every file of the project that is not a skeleton (atlases, pages, anything else)."""
    for source, dest in files_to_copy(proj, out, written, needed):
        atomic_copy(source, dest)


def files_to_copy(proj: Project, out: Path, written: set[Path], needed: set[Path] | None = None
                  ) -> list[tuple[Path, Path]]:
    """``(source, destination)`` of every file of the project that is copied as it is.

    Every file but the skeletons (atlases, pages, anything else).

    With ``needed`` (real paths), skeletons, atlases and images are copied only if listed: one
    skeleton asked for does not bring its twins (``hero.json`` beside ``hero.skel``) or other
    skeletons' atlases along; other files (a licence, audio) still come.
    """
    from ..images import IMAGE_EXTENSIONS
    from ..project import ATLAS_SUFFIXES, is_skeleton_file

    pairs = []
    for f in proj.files:  # only files inside the project by real path (see find_project)
        if f.resolve() in written:
            continue
        if f in proj.skeletons:
            continue  # a skeleton that could not be upgraded is not copied as if it had been
        if needed is not None and f.resolve() not in needed and (
                f.suffix.lower() in IMAGE_EXTENSIONS or f.name.lower().endswith(ATLAS_SUFFIXES)
                or is_skeleton_file(f)):
            continue
        pairs.append((f, out / f.relative_to(proj.root)))
    return pairs


#: Threads copying a project's other files (atlases, pages) while its skeletons are written.
COPY_THREADS = 4


def write_project(plan: ProjectPlan, meshes: dict[str, MeshResult], out: Path, result: Result) -> None:
    """Put the meshes into the skeletons, write them, and copy every other file to ``out``."""
    t0 = time.perf_counter()
    needed = set().union(*(files_needed(sk.doc, sk.source) for sk in plan.skeletons)) if plan.only_needed else None
    skeletons = {sk.path.resolve() for sk in plan.skeletons}
    # Copies are disk work (reads, writes, fsync) that leaves the interpreter free: they run
    # on threads while this thread writes the skeletons.
    copier = ThreadPoolExecutor(COPY_THREADS)
    copies = [copier.submit(atomic_copy, source, dest)
              for source, dest in files_to_copy(plan.project, out, skeletons, needed)]
    written = set()
    for sk in plan.skeletons:
        apply_meshes(sk.doc, sk.targets, meshes, plan.tasks, str(sk.path))
        if plan.options is not None and plan.options.weights == "auto":
            from ..rig.upgrade import weight_upgraded

            weight_upgraded(sk.doc, sk.targets, plan.options.overrides.get("max_vertices"), sk.rig)
        try:
            write_skeleton(sk.doc, sk.path, out / sk.rel)
        except SpineMeshError as e:
            result.errors.append(f"{sk.path}: not written: {e}")
            continue
        written.add(sk.path.resolve())
        result.written.append(sk.rel)
    for copy in copies:
        try:
            copy.result()
        except SpineMeshError as e:
            result.errors.append(f"not copied: {e}")
    copier.shutdown()
    for atlas_path, names in sorted(plan.untrimmed.items()):
        try:
            write_repacked_atlas(atlas_path, names, plan.project.root, out)
        except SpineMeshError as e:
            result.errors.append(f"{atlas_path}: not re-packed: {e}")
    result.seconds["write"] += time.perf_counter() - t0


def _mark_would_mesh(result: Result) -> None:
    """A dry run: what would have been meshed says so."""
    for t in result.targets:
        if t.status == "planned":
            t.status = "would mesh"


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


def _mesh_and_write(plan: ProjectPlan, out: Path, options: Options, result: Result, workers: Workers | None,
                    on_start, on_progress, mesh_cache) -> None:
    if options.dry_run:
        _mark_would_mesh(result)
        return
    t0 = time.perf_counter()
    if on_start:
        on_start(len(plan.tasks))
    with meshing_workers(options, workers, len(plan.tasks)) as w:
        meshes = mesh_tasks(plan.tasks, w, on_progress, mesh_cache)
    result.seconds["mesh"] += time.perf_counter() - t0
    write_project(plan, meshes, out, result)


def upgrade_project(project: str | Path, out: str | Path, options: Options | None = None,
                    on_start: Callable[[int], None] | None = None,
                    on_progress: Callable[[int], None] | None = None,
                    mesh_cache: dict | None = None, workers: Workers | None = None) -> Result:
    """Upgrade every skeleton of a project into ``out``.

    Parameters
    ----------
    project : path
        A project folder or one skeleton file.
    out : path
        Output folder; refused if it is the project folder or inside it.
    options : Options
    on_start, on_progress : callable, optional
        Told the number of unique images to mesh, then the number meshed as they finish.
    mesh_cache : dict, optional
        Meshes kept across calls (see :func:`mesh_tasks`); None meshes afresh.
    workers : Workers, optional
        Workers to mesh on (kept open by the caller across projects); default: opened here
        from ``options.jobs`` and ``options.dask``.

    Returns
    -------
    Result
        Every region attachment with its status, for the report; ``partial`` is true when
        any attachment or skeleton failed.
    """
    options = options or Options()
    out = Path(out)
    proj = find_project(project)
    check_output_folder(proj.root, out, options.images_in)
    if options.images_out is not None:
        check_output_folder(proj.root, Path(options.images_out), options.images_in)
    with contextlib.ExitStack() as held:
        if not options.dry_run:
            held.enter_context(output_folder(out, options.overwrite))
        result = Result()
        plan = plan_project(proj, options, result)
        plan.only_needed = Path(project).is_file()
        _mesh_and_write(plan, out, options, result, workers, on_start, on_progress, mesh_cache)
        return result


def is_library(folder: str | Path) -> bool:
    """Whether ``folder`` holds several projects (or one below it) rather than being one project."""
    folder = Path(folder)
    return folder.is_dir() and find_projects(folder) != [folder]


def upgrade_library(library: str | Path, out: str | Path, options: Options | None = None,
                    on_start: Callable[[int], None] | None = None,
                    on_progress: Callable[[int], None] | None = None,
                    on_project: Callable[[str], None] | None = None) -> Result:
    """Upgrade every project under ``library`` into the same place under ``out``; one result.

    Projects are found as :func:`spinemesh.project.find_projects` finds them; each is
    upgraded as :func:`upgrade_project` would, to ``out/<its path under library>``, on one
    set of workers started once. Files outside every project are not copied. In the
    result, skeletons (and errors) are named by their path under ``library``.
    """
    options = options or Options()
    library, out = Path(library), Path(out)
    check_output_folder(library, out)
    if options.images_in is not None:
        raise SpineMeshError("--from-images reads one project's images; give one project, not a folder of them",
                             options.images_in)
    with contextlib.ExitStack() as held:
        if not options.dry_run:
            held.enter_context(output_folder(out, options.overwrite))
        return _upgrade_library(library, out, options, on_start, on_progress, on_project)


def _upgrade_library(library: Path, out: Path, options: Options, on_start, on_progress, on_project) -> Result:
    result = Result()
    from .. import mesher  # noqa: F401  (loaded before workers fork, see meshing_workers)

    # This process plans projects ahead while the workers mesh earlier ones, and writes each
    # project (in order) once its meshes are back: the workers never wait for reading or
    # writing. How far ahead is bounded by the pixels sent and not yet written.
    cache: dict = {}
    inflight: dict = {}
    with open_workers(options.jobs, options.dask) as workers:
        ahead: deque[_LibraryProject] = deque()
        for folder in find_projects(library):
            ahead.append(_start_library_project(library, folder, options, workers, cache, inflight))
            while ahead and sum(p.pixels for p in ahead) > AHEAD_PIXELS:
                _finish_library_project(ahead.popleft(), out, workers, cache, inflight, result,
                                        on_start, on_progress, on_project)
        while ahead:
            _finish_library_project(ahead.popleft(), out, workers, cache, inflight, result,
                                    on_start, on_progress, on_project)
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
    plan: ProjectPlan | None = None
    meshing: Meshing | None = None

    @property
    def pixels(self) -> int:
        """Pixels of the images this project sent to the workers."""
        return sum(t.rgba.shape[0] * t.rgba.shape[1] for t in self.plan.tasks.values()) if self.plan else 0


def _start_library_project(library: Path, folder: Path, options: Options, workers: Workers,
                           cache: dict, inflight: dict) -> _LibraryProject:
    rel = folder.relative_to(library).as_posix()
    sub = dataclasses.replace(options, images_out=None if options.images_out is None
                              else Path(options.images_out) / rel)
    p = _LibraryProject(rel, sub, Result())
    try:
        p.plan = plan_project(find_project(folder), sub, p.result)
    except SpineMeshError as e:
        p.result.errors.append(str(e))
        return p
    if not sub.dry_run:
        t0 = time.perf_counter()  # with workers, sending only; in this process, the meshing itself
        p.meshing = start_meshing(p.plan.tasks, workers, cache, inflight)
        p.result.seconds["mesh"] += time.perf_counter() - t0
    return p


def _finish_library_project(p: _LibraryProject, out: Path, workers: Workers, cache: dict, inflight: dict,
                            result: Result, on_start, on_progress, on_project) -> None:
    if on_project:
        on_project(p.rel)
    if p.plan is not None and p.options.dry_run:
        _mark_would_mesh(p.result)
    elif p.plan is not None:
        t0 = time.perf_counter()
        if on_start:
            on_start(len(p.plan.tasks))
        meshes = finish_meshing(p.meshing, p.plan.tasks, workers, on_progress, cache, inflight)
        p.result.seconds["mesh"] += time.perf_counter() - t0
        try:
            write_project(p.plan, meshes, out / p.rel, p.result)
        except SpineMeshError as e:
            p.result.errors.append(str(e))
    _merge(result, p.result, "" if p.rel == "." else p.rel + "/")


def _merge(into: Result, part: Result, prefix: str) -> None:
    """Add one project's result to a library's, naming its skeletons by their path in the library."""
    for t in part.targets:
        t.skeleton = prefix + t.skeleton
    into.targets += part.targets
    into.written += [prefix + w for w in part.written]
    into.errors += part.errors  # they name their files already
    for k, v in part.seconds.items():
        into.seconds[k] += v


def write_report(result: Result, path: str | Path) -> None:
    """``report.json``: one row per region attachment, plus totals and timings."""
    atomic_write_json(path, {
        "counts": result.counts(),
        "skeletons_written": result.written,
        "errors": result.errors,
        "seconds": {k: round(v, 3) for k, v in result.seconds.items()},
        "attachments": [t.row() for t in result.targets],
    })
