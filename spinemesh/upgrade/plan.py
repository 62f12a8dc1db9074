"""Reading and planning: which region attachments become meshes, and the unique images to mesh.

:func:`plan_project` reads every skeleton of a project and gives a :class:`ProjectPlan`:
per skeleton a :class:`SkeletonPlan` (its document, its :class:`~.report.Target` rows and
its image source), and the :class:`MeshTask` of every unique image, each holding only the
part the atlas stores (a small crop, not a page). Per attachment, the :class:`Planner`
decides which image(s) it needs and which texels a mesh must cover
(:func:`texels_to_cover`), or why it is left alone; with ``--weights auto`` the regions whose
art may bend are listed, to be tested once their plain mesh is known (:mod:`.bending`).
Nothing is meshed or written here but the editor images (``--images``), written as they are
met.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from functools import lru_cache, partial
from pathlib import Path

import numpy as np

from ..attachment_geometry import frames_on_one_grid
from ..cluster import ProcessWorkers, Workers, shared_array
from ..errors import SpineMeshError
from ..files.disk import file_stamp
from ..files.names import OneFilePerName
from ..foreground import alpha_above
from ..images import decode
from ..images.content_ids import part_content_id
from ..images.pages import PREFETCH_PAGES_PER_WORKER, PagePrefetch
from ..images.sources import FolderImages, RegionImage
from ..images.texels import FAINT_TEXEL
from ..processes import keep_buffers_on_heap
from ..project import Project, image_source_for, project_pages
from ..skeleton import checked_attachments, image_paths, linked_source, load_skeleton
from ..skeleton_check import animations_keyed_twice, is_number
from ..written_folder import mark_written_folder
from .editor_images import write_editor_image
from .options import Options, skip_reason
from .progress import SILENT, Progress
from .report import Result, Target


@dataclass
class MeshTask:
    """What a worker needs to mesh one unique image: small, and the same wherever it runs.

    Attributes
    ----------
    key : str
        Content key of the image: :func:`spinemesh.images.content_ids.part_content_id` of the stored part
        and of ``drawn``.
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
            self.drawn = alpha_above(self.rgba, 0)


def composite_image(images: list[np.ndarray]) -> np.ndarray:
    """One image whose alpha covers every frame of a sequence (max over frames).

    Colours come from the first frame, which is what interior boundaries are found on. One
    frame is its own composite (returned as it is, not copied).
    """
    if len(images) == 1:
        return images[0]
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
    return np.count_nonzero(visible) == np.count_nonzero(visible[y0:y1, x0:x1])


def _any_frame(masks: list[np.ndarray]) -> np.ndarray:
    """Per texel, whether any frame's mask holds it (one frame's mask as it is)."""
    return masks[0] if len(masks) == 1 else np.logical_or.reduce(masks)


def source_identity(source) -> tuple:
    """Sources with equal identities give equal images for equal paths (twin skeletons share one)."""
    atlases = getattr(source, "atlases", None)
    if atlases is not None:
        return ("atlas",) + tuple(str(a.path) for a in atlases)
    return ("folder", str(getattr(source, "folder", id(source))))


def why_no_new_page(frames: list[RegionImage], source=None) -> str:
    """Why ``--repack`` cannot move ``frames`` to a new page; empty when it can.

    A new page is written at 8 bits a channel, still, upright and shared by regions: a page of 16
    bits a channel would lose its low bits, and a page that repeats, is animated or is turned by
    its EXIF orientation would be drawn otherwise (``pack``'s tests of those pages,
    :func:`spinemesh.pack.checks.check_no_repeat` and :func:`~spinemesh.pack.checks.check_one_upright_image`).
    ``source``: the :class:`~spinemesh.images.sources.AtlasImages` the frames were cut from, which says their
    pages (an images folder has none).
    """
    from ..pack.atlas_pack import PackRefused
    from ..pack.checks import check_no_repeat
    from ..pack.png import png_file_bit_depth

    for f in frames:
        if (png_file_bit_depth(f.source) or 0) > 8:
            return f"their page {Path(f.source).name!r} has 16 bits a channel, and new pages are written at 8"
    for f in frames:
        for atlas in getattr(source, "atlases", ()):
            region = atlas.find(f.name)
            if region is None or not 0 <= region.page < len(atlas.pages):
                continue
            try:
                check_no_repeat(atlas.pages[region.page])
            except PackRefused as e:
                return str(e)
            if why := _page_drawn_otherwise(str(f.source), atlas.pages[region.page].name):
                return why
            break
    return ""


def _page_drawn_otherwise(path: str, name: str) -> str:
    """Why the page file at ``path`` is drawn otherwise than its texels (animated, turned by EXIF:
    :func:`spinemesh.pack.checks.check_one_upright_image`); empty when it is not, or cannot be read
    (its decode says why). Each file read once (by path and :func:`~spinemesh.files.disk.file_stamp`)."""
    stamp = file_stamp(path)
    return "" if stamp is None else _page_drawn_otherwise_once(path, name, stamp)


@lru_cache(maxsize=64)
def _page_drawn_otherwise_once(path: str, name: str, stamp: tuple) -> str:
    from ..pack.atlas_pack import PackRefused
    from ..pack.checks import check_one_upright_image

    try:
        check_one_upright_image(decode.image_file_bytes(path), name)
    except PackRefused as e:
        return str(e)
    except SpineMeshError:  # unreadable: its decode says why
        pass
    return ""


def task_for_frames(frames: list[RegionImage], options: Options, blend: str = "normal",
                    source=None) -> tuple[MeshTask | None, str, str]:
    """The mesh task of an attachment's frame image(s), or ``(None, status, reason)``.

    ``blend`` is the slot's blend mode: with ``normal`` the mesh must cover the texels that
    can show (:attr:`RegionImage.shown`), with any other every texel drawn (see
    :func:`texels_to_cover`). ``source``: the image source the frames were cut from, for
    ``--repack``'s tests of their pages (:func:`why_no_new_page`).
    """
    # Frames of different sizes are compared where the runtime draws them: relative to their size.
    frames = frames_on_one_grid(frames)
    one = frames[0] if len(frames) == 1 and frames[0].stored is not None else None
    if one is not None and stored_box([one.content]) is not None:
        # One frame given by its stored part (RegionImage.from_stored): zero outside that part,
        # so every test below answers the same on the part alone, and the crop is the part.
        shape, (x0, y0, x1, y1) = one.shape, one.content
        part = one.stored[0]
        drawn = one.stored_mask(shown=blend == "normal")  # as _to_cover picks it
        # shown is part of drawn: where it holds a texel, something is drawn (drawn not made)
        anything_drawn = bool(drawn.any()) or (blend == "normal" and bool(one.stored_mask(shown=False).any()))
        if reason := _nothing_to_mesh(options, anything_drawn, drawn):
            return None, "kept", reason
        crop, drawn = np.ascontiguousarray(part), np.ascontiguousarray(drawn)
    else:
        rgba = composite_image([f.rgba for f in frames])
        shape = rgba.shape
        drawn = _any_frame(texels_to_cover(frames, blend))
        if reason := _nothing_to_mesh(options, _any_frame([f.drawn for f in frames]).any(), drawn):
            return None, "kept", reason
        box = stored_box([f.content for f in frames])
        if box is None or not _inside(drawn, box):
            why = ("sequence frames were trimmed differently on the atlas page, so one mesh would sample "
                   "neighbouring regions")
            if not options.repack:
                return None, "kept", f"{why}; --repack stores them whole"
            if no_page := why_no_new_page(frames, source):
                # a new page is 8-bit, still, upright, shared: the frames would be drawn otherwise there
                return None, "kept", f"{why}, and --repack cannot store them whole: {no_page}"
            # --repack stores every frame whole (see needs_repack): the mesh may use the whole image.
            box = (0, 0, rgba.shape[1], rgba.shape[0])
        x0, y0, x1, y1 = box
        # Meshing the stored part only keeps every vertex where the atlas has this image's texels.
        crop = np.ascontiguousarray(rgba[y0:y1, x0:x1])
        drawn = np.ascontiguousarray(drawn[y0:y1, x0:x1])
    # The texels to cover are part of the identity: premultiplied light (alpha 0, colour > 0)
    # is not in the straight pixels, faint texels are covered or not by the slot's blending.
    key = part_content_id(shape, (x0, y0, x1 - x0, y1 - y0), crop, drawn)
    size = (shape[1], shape[0])
    return MeshTask(key, crop, (x0, y0), size, options.mesh_settings(), drawn), "planned", ""


def texels_to_cover(frames: list[RegionImage], blend: str) -> list[np.ndarray]:
    """Per frame, the texels a mesh drawn in a slot with this ``blend`` mode must cover.

    Normal blending: the texels that can move a pixel by more than
    :data:`~spinemesh.images.texels.FAINT_TEXEL`/255 (:attr:`RegionImage.shown`); fainter ones
    cannot, in one layer, wherever and however large they are drawn. Additive, multiply and
    screen slots are made to be stacked (glows, particles), where faint layers add up: every
    texel drawn (:attr:`RegionImage.drawn`). Measured with the runtime proof: leaving texels
    of at most 2/255 out in additive slots too, one corpus skeleton of eight stacked additive
    particle layers lost 44,509 visible pixels (worst 16/255).
    """
    return [_to_cover(f.drawn, f.shown, blend) for f in frames]


def _nothing_to_mesh(options: Options, anything_drawn: bool, to_cover: np.ndarray) -> str:
    """Why an image with the alpha mask stays a region before meshing: ``""``, or nothing drawn
    at all, or only texels too faint to cover (``to_cover``, from :func:`texels_to_cover`)."""
    if options.mask == "model":
        return ""
    if not anything_drawn:
        return "image is fully transparent"
    if not to_cover.any():
        return f"only faint texels (none above {FAINT_TEXEL}/255), drawn with normal blending"
    return ""


def _to_cover(drawn: np.ndarray, shown: np.ndarray, blend: str) -> np.ndarray:
    """:func:`texels_to_cover` of one frame's ``drawn`` and ``shown`` masks."""
    return shown if blend == "normal" else drawn


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


def art_box(task: MeshTask) -> np.ndarray:
    """The corners (4, 2) of the box around the texels ``task`` must cover, as image points
    (u, v), 0..1 over the original image, in the order of a region's quad
    (:data:`spinemesh.rig.upgraded_meshes.QUAD_UV`); the whole quad when it covers none.

    What :class:`spinemesh.rig.upgraded_meshes.BendingRegions` tests (:mod:`.bending`): the quad reaches
    past the art wherever the image has transparent margins, and bones there are not the art's.
    """
    ys, xs = np.nonzero(task.drawn)
    (x0, y0), (width, height) = task.origin, task.size
    if not len(xs):
        x_lo, y_lo, x_hi, y_hi = 0, 0, width, height
    else:
        x_lo, y_lo, x_hi, y_hi = x0 + xs.min(), y0 + ys.min(), x0 + xs.max() + 1, y0 + ys.max() + 1
    u0, u1, v0, v1 = x_lo / width, x_hi / width, y_lo / height, y_hi / height
    return np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]], float)


def needs_repack(frames: list[RegionImage], task: MeshTask) -> bool:
    """Whether ``task`` meshes beyond what some frame stores, so those frames must be re-packed whole."""
    return task.origin == (0, 0) and tuple(task.rgba.shape[1::-1]) == task.size and any(
        tuple(f.content) != (0, 0, f.shape[1], f.shape[0]) for f in frames)


def _unlike(image: tuple[int, int], attachment: tuple) -> str:
    """Why an image of an images folder is another picture than its region attachment, or ``""``.

    The mesh is made on the image and scaled to the attachment's width and height, over the
    region the runtime draws: an image of other proportions (trimmed, cropped, another
    drawing) would put the outline beside the art. Another scale of the same proportions (a 2x
    export) fits; a pixel of rounding on either side is allowed.
    """
    (iw, ih), (aw, ah) = image, attachment
    if not all(is_number(v) and v > 0 for v in (aw, ah)):
        return ""
    if abs(ih * aw / iw - ah) <= max(1.0, 0.01 * ah) and abs(iw * ah / ih - aw) <= max(1.0, 0.01 * aw):
        return ""
    return (f"its image is {iw}x{ih}, other proportions than the attachment's {aw:g}x{ah:g}: another picture "
            "than the region drawn, which its mesh would not fit")


def taken_for_meshes(doc: dict, refs) -> dict[tuple[str, str, str], str]:
    """Region attachments that a linked mesh names as its parent mesh, or that an animation keys a
    deform of, by ``(skin, slot, name)``, with why each stays a region.

    No runtime loads such a skeleton (spine-ts and libGDX stop at the linked mesh or the deform,
    spine-c and spine-cpp read the region as a mesh), and spinemesh's sampler draws neither.
    Meshed, the region would make it load, the linked mesh drawing its own image over the new
    mesh, the deform moving its vertices: a picture the original never showed.
    """
    out = {}
    for ref in refs:
        if ref.type == "linkedmesh":
            skin, slot, name = linked_source(ref)
            out.setdefault((skin, slot, name), f"linked mesh {ref.name!r} of skin {ref.skin!r} names it as its parent "
                                               "mesh: no runtime loads that, and a mesh here would make it draw")
    for animation, keyed in _deforms_keyed(doc):
        out.setdefault(keyed, f"animation {animation!r} keys a deform of it: no runtime loads that, and a mesh here "
                              "would play it")
    return out


def _deforms_keyed(doc: dict):
    """``(animation, (skin, slot, attachment))`` of every deform timeline (4.1+ under
    ``attachments``, earlier ``deform``, 3.x also ``ffd``)."""
    def mapping(value) -> dict:
        return value if isinstance(value, dict) else {}

    for animation, anim in mapping(doc.get("animations")).items():
        anim = mapping(anim)
        for skin, slots in mapping(anim.get("attachments")).items():
            for slot, names in mapping(slots).items():
                for name, timelines in mapping(names).items():
                    if "deform" in mapping(timelines):
                        yield animation, (str(skin), str(slot), str(name))
        for key in ("deform", "ffd"):
            for skin, slots in mapping(anim.get(key)).items():
                for slot, names in mapping(slots).items():
                    for name in mapping(names):
                        yield animation, (str(skin), str(slot), str(name))


def _turned_for_meshes_only(source, paths: list[str]) -> str:
    """Why a region attachment of ``paths`` cannot become a mesh, or ``""``: a region stored
    turned by 180 or 270 degrees, which every runtime turns for a mesh but draws unturned for a
    region attachment (it turns one by 90 degrees only), so a mesh would draw other texels."""
    for name in paths:
        atlas = next((a for a in getattr(source, "atlases", ()) if a.find(name) is not None), None)
        degrees = atlas.find(name).geometry(str(atlas.path)).degrees if atlas is not None else 0
        if degrees in (180, 270):
            return (f"its atlas region {name!r} is stored turned by {degrees} degrees, which the runtimes turn "
                    "for a mesh only: they draw this region attachment unturned, which its mesh would not")
    return ""


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
    #: ``--images``: the files written there, one per name on every disk (Hero.png, hero.png)
    editor_files: OneFilePerName = field(default_factory=OneFilePerName)
    #: ``--repack``: atlas path -> names of the regions to store untrimmed.
    untrimmed: dict[Path, set[str]] = field(default_factory=dict)
    #: Targets read but not decided yet (:meth:`read_skeleton`), with what deciding needs:
    #: ``(target, source, paths, blend, bends, (width, height) of the attachment)``, in the order read.
    undecided: list[tuple] = field(default_factory=list)
    #: ``--weights auto``: targets decided to be meshed whose art may bend, each with its test
    #: (``bends(art_box)``), in the order read: tested once meshed (:mod:`.bending`)
    may_bend: list[tuple] = field(default_factory=list)

    def pages_to_decode(self) -> list[Path]:
        """The atlas page files :meth:`decide` will cut from, in the order it will first cut them."""
        pages: dict[Path, None] = {}
        for _, source, paths, *_ in self.undecided:
            if hasattr(source, "page_files"):  # AtlasImages; an images folder has no pages
                pages.update(dict.fromkeys(source.page_files(paths)))
        return list(pages)

    def decide(self) -> None:
        """Decide every target read and not decided yet, in the order read (images cut here)."""
        undecided, self.undecided = self.undecided, []
        for t, source, paths, blend, bends, size in undecided:
            t.status, t.reason, t.key = self._decide(source, paths, blend, size)
            if bends is not None and t.key:
                self.may_bend.append((t, bends))

    def read_skeleton(self, doc: dict, skeleton: str, source, bending=None) -> list[Target]:
        """A :class:`Target` for every region attachment of ``doc``, in document order.

        Those that need their image are left to :meth:`decide` (:attr:`undecided`), so that
        the pages they are cut from can be decoded meanwhile (:meth:`pages_to_decode`).
        ``bending`` (:class:`spinemesh.rig.upgraded_meshes.BendingRegions` of ``doc``, with
        ``--weights auto``) tells which regions would bend, given the box of their art
        (:func:`art_box`): those the keep rule keeps are tested once meshed (:attr:`may_bend`).
        """
        targets = []
        # the slot's blend mode decides which faint texels a mesh must cover (texels_to_cover)
        blends = {s.get("name"): s.get("blend", "normal") for s in doc.get("slots", []) if isinstance(s, dict)}
        checked = list(checked_attachments(doc))
        parents = taken_for_meshes(doc, [ref for ref, _ in checked])
        for ref, problem in checked:
            if ref.type != "region" and isinstance(ref.type, str):
                continue
            if problem:  # a field of the wrong type or an unusable number: this one stays as it is
                targets.append(Target(skeleton, ref.skin, ref.slot, ref.name, [], "failed", problem))
                continue
            if linked := parents.get((ref.skin, ref.slot, ref.name)):
                targets.append(Target(skeleton, ref.skin, ref.slot, ref.name, [], "failed", linked))
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
                bends = partial(bending.bends, ref) if bending is not None and self.options.min_saving else None
                size = (ref.attachment.get("width"), ref.attachment.get("height"))
                self.undecided.append((t, source, paths, blends.get(ref.slot, "normal"), bends, size))
        return targets

    def _decide(self, source, paths: list[str], blend: str = "normal",
                size: tuple = (None, None)) -> tuple[str, str, str]:
        """``(status, reason, task key)`` of an attachment's image(s), decided once per image and
        blend; ``size``: the attachment's width and height, which an images folder's image must fit."""
        seen = (source_identity(source), tuple(paths), blend == "normal")
        if seen not in self.decided:
            try:
                frames = [source.get(p) for p in paths]
            except SpineMeshError as e:
                self.decided[seen] = ("failed", str(e), "")
            else:
                task, status, reason = task_for_frames(frames, self.options, blend, source)
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
        if key and isinstance(source, FolderImages) and (unlike := _unlike(self.found[key].size, size)):
            return "failed", unlike, ""  # another picture than the region the runtime draws: its mesh would not fit
        if key and (turned := _turned_for_meshes_only(source, paths)):
            return "failed", turned, ""
        if key:
            self.tasks.setdefault(key, self.found[key])
        return status, reason, key

    def _write_editor_images(self, frames: list[RegionImage]) -> None:
        folder = self.options.images_out
        if folder is None or self.options.dry_run:
            return
        for frame in frames:  # every frame's name first: no frame of a refused sequence written
            if frame.name not in self.editor_images:
                self.editor_files.claim(frame.name + ".png", frame.name, "editor image", frame.source)
        for frame in frames:
            if not self.editor_images:  # before its first image: a later run writes into it again
                mark_written_folder(Path(folder))
            if frame.name not in self.editor_images:
                self.editor_images.add(frame.name)
                write_editor_image(frame, Path(folder))


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
    """Everything the later stages need (:func:`.run.finish_project`), and the unique images to mesh."""

    project: Project
    skeletons: list[SkeletonPlan]
    tasks: dict[str, MeshTask]
    only_needed: bool = False  # one skeleton file was asked for: copy only the files it uses
    untrimmed: dict[Path, set[str]] = field(default_factory=dict)  # --repack: atlas -> regions
    options: Options | None = None
    #: --weights auto: targets that may bend, with their test (:attr:`Planner.may_bend`)
    may_bend: list[tuple] = field(default_factory=list)
    #: --weights auto: the project's habits being read (:func:`.bending.start_habits`), until
    #: :func:`.bending.gather_habits` gives them to the rigs
    habits: object = None
    #: --weights auto: the regions that may bend being tested as their meshes arrive
    #: (:func:`.bending.bending_tests`), until :func:`.bending.settle_bending`
    bending: object = None
    #: --pack in a library run: ``pack_told()``, the packing work told ahead for this project
    #: (:meth:`.pack.PackAhead.tell`)
    pack_told: object = None


@dataclass
class ProjectReading:
    """A project's skeletons read, their regions not yet decided (:func:`read_project`)."""

    project: Project
    options: Options
    result: Result
    planner: Planner
    skeletons: list[SkeletonPlan]

    def pages_to_decode(self) -> list[Path]:
        """The atlas pages :func:`plan_read_project` will cut from, in the order it will cut them."""
        return self.planner.pages_to_decode()


def plan_project(proj: Project, options: Options, result: Result, progress: Progress = SILENT) -> ProjectPlan:
    """Read every skeleton of ``proj`` and plan its regions (stage 1 of :mod:`.run`).

    :func:`read_project`, then :func:`plan_read_project`; :func:`.run.upgrade_project` calls
    the halves apart, to decode the pages on its workers between them.

    Parameters
    ----------
    proj : Project
        The project (:func:`spinemesh.project.find_project`).
    options : Options
        What the user asked for: presets, ``--only``/``--exclude``, ``--weights``, ``--repack``.
    result : Result
        Filled in place: one :class:`~.report.Target` per region attachment (status
        ``planned``, or ``kept``/``failed`` with the reason), ``errors``, ``warnings``, and
        ``seconds["read"]``. Unreadable skeletons go to ``errors`` and ``not_read``; the others
        are planned all the same.
    progress : Progress, optional
        Told each skeleton read (phase ``read``); default: nobody.

    Returns
    -------
    ProjectPlan
        Per skeleton a :class:`SkeletonPlan`, and one :class:`MeshTask` per unique image
        (``tasks``, by content key: an image drawn by several attachments or skeletons is
        meshed once).

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> from spinemesh.project import find_project
    >>> from spinemesh.upgrade import Options
    >>> from spinemesh.upgrade.report import Result
    >>> result = Result()
    >>> plan = plan_project(find_project(make_demo_project("demo")), Options(), result)
    >>> [sk.rel for sk in plan.skeletons], len(result.targets), len(plan.tasks)
    (['demo-binary.skel', 'demo.json'], 12, 6)
    """
    return plan_read_project(read_project(proj, options, result, progress))


def read_project(proj: Project, options: Options, result: Result, progress: Progress = SILENT) -> ProjectReading:
    """The first half of :func:`plan_project`: every skeleton read and its targets listed, no image cut.

    Between the halves, the pages the second will cut from (:meth:`ProjectReading.pages_to_decode`)
    can be decoded elsewhere (:meth:`spinemesh.images.pages.PageStore.decode_ahead`).

    Parameters
    ----------
    proj, options, result, progress
        As for :func:`plan_project`; ``result`` gets the targets, the skeletons not read and
        the warnings of attachments copied as they are.

    Returns
    -------
    ProjectReading
        The documents read (with ``--weights auto``, each one's rig) and the planner that
        :func:`plan_read_project` finishes.
    """
    t0 = time.perf_counter()
    planner = Planner(options)
    loaded = []
    progress.add("read", len(proj.skeletons))
    for path in proj.skeletons:
        progress.advance("read")
        rel = path.relative_to(proj.root).as_posix()
        try:
            doc = load_skeleton(path)
            source = image_source_for(doc, path, proj, images=options.images_in)
        except SpineMeshError as e:
            result.errors.append(str(e))
            result.not_read[rel] = str(e)
            continue
        loaded.append((path, rel, doc, source, bending_regions(doc) if options.weights == "auto" else None))
    skeletons = []
    for path, rel, doc, source, bending in loaded:
        targets = planner.read_skeleton(doc, rel, source, bending)
        result.targets += targets
        # an attachment that is not upgraded (a mesh, a path) and that a runtime would refuse
        # (weighted vertices cut short, a bone beyond the skeleton's) is copied as it is: said so
        result.warnings += [f"{rel}: {problem}; copied as the input holds it"
                            for ref, problem in checked_attachments(doc)
                            if problem and ref.type != "region" and isinstance(ref.type, str)]
        result.warnings += [f"{rel}: {line}" for line in animations_keyed_twice(doc)]  # passed through, said
        skeletons.append(SkeletonPlan(path, rel, doc, targets, source, bending.rig if bending else None))
    result.seconds["read"] += time.perf_counter() - t0
    return ProjectReading(proj, options, result, planner, skeletons)


def decode_page_shared(path: Path):
    """:func:`~spinemesh.images.decode.load_rgba` on a local worker, answered as shared memory
    (:func:`~spinemesh.cluster.shared_array`): a page decoded ahead of the planning.

    ``path`` is a page's real path, checked to lie inside its project by the planning process
    (:meth:`~spinemesh.images.sources.AtlasImages.page_file`); the size limits are ``load_rgba``'s.
    """
    # looked up on its module at each call, as PageStore.page does: whoever wraps it (a
    # benchmark counting decodes) sees the decodes of both processes
    return shared_array(decode.load_rgba(path))


def page_prefetch(workers: Workers | None) -> PagePrefetch | None:
    """Pages decoded ahead of the planning by ``workers``, where they are local processes; else None.

    Only where the workers share this machine's memory: on Dask the texels would travel
    through the network, and one process has no one to decode ahead. Pages go to the workers
    before their queued meshes, at most :data:`~spinemesh.images.pages.PREFETCH_PAGES_PER_WORKER`
    per worker not yet taken.
    """
    if not isinstance(workers, ProcessWorkers):
        return None
    keep_buffers_on_heap()  # as if this process still decoded pages (see there)
    return PagePrefetch(lambda path: workers.submit(decode_page_shared, path, first=True),
                        PREFETCH_PAGES_PER_WORKER * workers.slots)


def decode_pages_ahead(reading: ProjectReading, prefetch: PagePrefetch | None) -> None:
    """Have ``prefetch`` decode the pages :func:`plan_read_project` will cut from (nothing without one).

    The time it takes here (listing and handing over the pages) counts as reading.
    """
    if prefetch is None:
        return
    t0 = time.perf_counter()
    pages = project_pages(reading.project)
    pages.prefetch = prefetch
    pages.decode_ahead(reading.pages_to_decode())
    reading.result.seconds["read"] += time.perf_counter() - t0


def plan_read_project(reading: ProjectReading) -> ProjectPlan:
    """The second half of :func:`plan_project`: every target decided (images cut), in the order read.

    Parameters
    ----------
    reading : ProjectReading
        From :func:`read_project`; its ``result`` gets the project's problems and warnings.

    Returns
    -------
    ProjectPlan
        As :func:`plan_project` returns it. The project's decoded pages are released: each
        :class:`MeshTask` holds the crop it meshes.
    """
    t0 = time.perf_counter()
    proj, result, planner = reading.project, reading.result, reading.planner
    planner.decide()
    result.errors += proj.problems  # files left out: symlinks leading outside, broken atlases
    result.warnings += [w for w in proj.warnings if w not in result.warnings]  # pages runtimes draw apart
    # every skeleton decoded its pages through this one store (each page once); the tasks hold
    # the crops they mesh, so the pages need not outlive the planning
    project_pages(proj).release()
    result.seconds["read"] += time.perf_counter() - t0
    return ProjectPlan(proj, reading.skeletons, planner.tasks, untrimmed=planner.untrimmed,
                       options=reading.options, may_bend=planner.may_bend)


def bending_regions(doc: dict):
    """:class:`spinemesh.rig.upgraded_meshes.BendingRegions` of ``doc``, or None when its rig cannot be built.

    The rig samples the skeleton's animations when a choice first needs them (the motion guard
    of :func:`spinemesh.rig.upgraded_meshes.upgrade_choice`)."""
    from ..anim.bone_worlds import sampled_bone_worlds
    from ..rig.document import build_rig
    from ..rig.upgraded_meshes import BendingRegions

    try:
        return BendingRegions.of(build_rig(doc, sample_motion=sampled_bone_worlds))
    except SpineMeshError:
        return None  # the weighting reports it, per mesh
