"""One project in, its unique attachment images out (runs in worker processes).

A *project* is a folder that holds a Spine project: the first folder, walking down from
a corpus argument, that directly holds a skeleton, an atlas or a ``.source.json``. Its
*game* decides the train/validation split: the ``repo`` of its ``.source.json`` (so that
all projects taken from one game repository land on the same side), else the project
folder's own name (so ``examples/3.8/hero`` and ``examples/4.2/hero`` are one game).
"""

from __future__ import annotations

import functools
import hashlib
import json
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ImageMemoryError, SpineMeshError
from ..files.names import name_as_text
from ..images.sources import AtlasImages, FolderImages
from ..images.content_ids import content_id as image_content_id
from ..memory import image_memory
from ..project import (SOURCE_FILE, find_project, find_projects, image_source_for,  # noqa: F401 (re-exported)
                       images_folder_for, needed_images, project_atlases, project_pages, skeletons_to_read)
from ..skeleton import (AttachmentRef, checked_attachments, image_paths,
                        iter_skins, linked_source, load_skeleton, spine_version)
from .format import VAL_FRACTION, crop, encode_mesh, encode_png, mask_of, tight_box


def game_of(project: Path) -> str:
    """The game a project belongs to: its source repository, else its folder name.

    Raises
    ------
    SpineMeshError
        For a :data:`SOURCE_FILE` that cannot be read or has no ``repo`` string: falling
        back to the folder name would silently move the project to another game, and so
        perhaps across the train/validation split.
    """
    source = project / SOURCE_FILE
    if not source.is_file():
        return name_as_text(project.name)  # a name of bytes not UTF-8 ended the data set in a traceback
    try:
        doc = json.loads(source.read_text("utf-8"))
    except OSError as e:
        raise SpineMeshError(f"cannot read: {e.strerror}", source) from None
    except (UnicodeDecodeError, ValueError) as e:
        raise SpineMeshError(f"malformed JSON ({e}); the project's game cannot be told", source) from None
    repo = doc.get("repo") if isinstance(doc, dict) else None
    if not isinstance(repo, str) or not repo:
        raise SpineMeshError("no \"repo\" string; the project's game cannot be told", source)
    return repo


def split_of(game: str, val_fraction: float = VAL_FRACTION) -> str:
    """``"val"`` for a fixed ~10 % of games, by a hash of the game name, else ``"train"``.

    A hash rather than a draw over the games seen: the answer never changes when the
    corpus grows or a run is resumed, and no game can be on both sides.
    """
    h = int.from_bytes(hashlib.blake2b(game.encode("utf-8"), digest_size=8).digest(), "big")
    return "val" if h / 2.0**64 < val_fraction else "train"


def empty_side_said(data: list, side: str) -> str:
    """The line that says the data sets ``data`` (paths, named joined by commas) give no sprite on
    one ``side`` (``"train"``, ``"val"``) of their game split, and what to do: ``segment-eval``,
    ``segment-export`` and ``train`` said only "no held-out sprites in DS", which a data set of one
    or two games always gives."""
    held = "held-out" if side == "val" else "training"
    return (f"no {held} sprites in {', '.join(map(str, data))}: none of its games falls on the {side} side of "
            f"the split (a game's side is fixed by a hash of its name, about one game in {round(1 / VAL_FRACTION)} "
            f"held out); build the data set from the projects of more games, or add another data set with --data")


def content_id(rgba: np.ndarray, box: tuple | None = None) -> str:
    """:func:`spinemesh.images.content_ids.content_id` over the image's tight box.

    Only the pixels inside ``box`` (:func:`~spinemesh.dataset.format.tight_box`, computed
    when not given) are hashed, with the size and the box: everything outside is zero, so
    this identifies the whole image at a fraction of the cost.
    """
    return image_content_id(rgba, tight_box(rgba) if box is None else box)


def mesh_pixels(att: dict, width: int, height: int) -> dict:
    """An artist mesh in image pixels.

    Parameters
    ----------
    att : dict
        A mesh attachment of the skeleton document (``uvs``, ``triangles``, ``hull``,
        ``edges``). UVs run over the original image, u right and v down, so they give pixel
        positions whether the skeleton vertices are weighted or not.
    width, height : int
        The image size in pixels.

    Returns
    -------
    dict
        ``vertices`` (N, 2) float32, ``triangles`` (T, 3) int32, ``hull`` (H,) int32 (the
        first ``hull`` vertices, Spine's outline), ``edges`` (E, 2) int32 vertex pairs
        (Spine writes edges as float-array indices, i.e. twice the vertex index).
    """
    uvs = np.asarray(att.get("uvs", []), np.float64).reshape(-1, 2)
    vertices = (uvs * (width, height)).astype(np.float32)
    triangles = np.asarray(att.get("triangles", []), np.int32).reshape(-1, 3)
    hull = np.arange(min(int(att.get("hull", 0) or 0), len(vertices)), dtype=np.int32)
    edges = (np.asarray(att.get("edges", []) or [], np.int32) // 2).reshape(-1, 2)
    n = len(vertices)
    if triangles.size and (triangles.min() < 0 or triangles.max() >= n):
        raise ValueError(f"triangle index out of range for {n} vertices")
    return {"vertices": vertices, "triangles": triangles, "hull": hull, "edges": edges}


@dataclass
class Sample:
    """One unique image of a project, encoded, with its index row (no shard fields yet)."""

    row: dict
    image: bytes
    mask: bytes
    mesh: bytes | None


@dataclass
class ProjectResult:
    """What one project yielded: samples, and what was skipped and why."""

    project: str
    game: str
    samples: list[Sample] = field(default_factory=list)
    skipped: dict[str, int] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    skeletons: int = 0

    def skip(self, reason: str, n: int = 1) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + n

    def error(self, message: str) -> None:
        """Record a problem once, however many images it touches."""
        if message not in self.errors:
            self.errors.append(message)


@dataclass
class _Want:
    """An image some attachment draws; a mesh wins over a region for the same image."""

    kind: str          # "atlas" or "folder"
    where: Path        # atlas file or images folder
    order: tuple       # (page, name) for atlases: cut page by page
    name: str
    attachment: str    # region, mesh or linkedmesh
    mesh: dict | None
    skeleton: str
    version: str
    ref: list          # [skin, slot, attachment name] of the first attachment that drew it


def _linked_parent(doc: dict, ref: AttachmentRef) -> dict | None:
    """The mesh a linked mesh takes its geometry from (see :func:`~spinemesh.skeleton.linked_source`)."""
    skin, slot, parent = linked_source(ref)
    for name, slots in iter_skins(doc):
        if name == skin:
            att = (slots.get(slot) or {}).get(parent)
            if isinstance(att, dict) and att.get("type", "region") == "mesh":
                return att
    return None


def extract_project(folder: str | Path, name: str, min_side: int = 1) -> ProjectResult:
    """Extract every unique attachment image of one project.

    Parameters
    ----------
    folder : path
        The project folder.
    name : str
        How the project is called in the index (e.g. ``examples/4.2/hero``).
    min_side : int
        Images smaller than this in width or height are skipped (1: keep all non-empty).

    Returns
    -------
    ProjectResult
        Never raises for bad input: a broken skeleton, atlas or image is recorded in
        ``errors`` / ``skipped`` and the rest of the project goes on.
    """
    folder = Path(folder)
    try:
        game = game_of(folder)
    except SpineMeshError as e:  # its split cannot be decided: the project is left out, said why
        return ProjectResult(project=name, game=folder.name, errors=[f"{e}; project not used".replace(str(folder), name)])
    result = ProjectResult(project=name, game=game)
    try:
        _extract(folder, result, min_side)
    except Exception as e:  # a bug or an unforeseen input must not stop the other projects
        result.samples.clear()
        last = traceback.extract_tb(e.__traceback__)[-1]
        result.errors.append(f"{folder}: internal error {type(e).__name__}: {e} "
                             f"({Path(last.filename).name}:{last.lineno})")
    # the data set names files by the project's name, not by the path it was given by (relative,
    # absolute, another machine's): the same projects give the same bytes
    result.errors = [error.replace(str(folder), name) for error in result.errors]
    return result


def _extract(folder: Path, result: ProjectResult, min_side: int) -> None:
    project = find_project(folder)
    atlases = project_atlases(project)  # broken ones are in project.problems, reported below

    wants: dict[tuple, _Want] = {}
    for skel in skeletons_to_read(project.skeletons):
        try:
            doc = load_skeleton(skel)
        except SpineMeshError as e:
            result.errors.append(str(e))
            continue
        result.skeletons += 1
        _collect(doc, skel, project, wants, result)
    result.errors += project.problems

    seen: dict[str, int] = {}  # content id -> index in result.samples
    ordered = sorted(wants.values(), key=lambda w: (w.kind, str(w.where), w.order))
    source, source_at = None, None
    for w in ordered:
        if source_at != (w.kind, w.where):
            # one source per atlas, decoding through the project's pages (each decoded once)
            source = (AtlasImages([atlases[w.where]], root=project.root, pages=project_pages(project))
                      if w.kind == "atlas"
                      else FolderImages(w.where))
            source_at = (w.kind, w.where)
        try:
            image = source.get(w.name, coverage=False)  # texels are what a sample stores
        except SpineMeshError as e:
            result.skip("image unreadable")
            result.error(str(e))
            continue
        try:  # an image there is no memory for fails alone, as an unreadable one
            with image_memory("sample", f"{w.skeleton}: image {w.name!r}", image.shape[1], image.shape[0]):
                _add_sample(w, image, seen, result, folder, min_side)
        except ImageMemoryError as e:
            result.skip("image unreadable")
            result.error(str(e))


def _add_sample(w: _Want, image, seen: dict[str, int], result: ProjectResult, folder: Path, min_side: int) -> None:
    """Add the sample of one image to ``result`` (or count why not), once per content."""
    rgba = image.rgba
    if rgba.shape[0] < min_side or rgba.shape[1] < min_side:
        result.skip("empty image")
        return
    box = tight_box(rgba)
    cid = content_id(rgba, box)
    if cid in seen:
        result.skip("same image in this project")
        # The same pixels drawn by a region and by a mesh: keep the mesh, it says more.
        if w.mesh is not None and result.samples[seen[cid]].mesh is None:
            result.samples[seen[cid]] = _sample(w, rgba, float(image.scale), box, cid, result, folder)
        return
    seen[cid] = len(result.samples)
    result.samples.append(_sample(w, rgba, float(image.scale), box, cid, result, folder))


def _sample(w: _Want, rgba: np.ndarray, scale: float, box: tuple, cid: str, result: ProjectResult,
            folder: Path) -> Sample:
    """Encode one image (cropped to ``box``), its mask and its mesh, with its index row."""
    h, wd = rgba.shape[:2]
    mesh = None
    if w.mesh is not None:
        try:
            mesh = mesh_pixels(w.mesh, wd, h)
        except (ValueError, TypeError) as e:
            result.skip("mesh unreadable (kept as region)")
            result.error(f"{w.skeleton}: mesh for {w.name!r}: {e}")
    row = {"id": cid, "project": result.project, "game": result.game, "version": w.version,
           "split": split_of(result.game), "type": "mesh" if mesh is not None else "region",
           "attachment": w.attachment, "name": w.name, "skeleton": w.skeleton, "ref": w.ref,
           "source": _relative(w.where, folder), "width": int(wd), "height": int(h),
           "scale": scale, "n_vertices": len(mesh["vertices"]) if mesh else 0,
           "n_triangles": len(mesh["triangles"]) if mesh else 0, "box": list(box)}
    part = crop(rgba, box)
    return Sample(row, encode_png(part), encode_png(mask_of(part)), encode_mesh(mesh) if mesh else None)


def _collect(doc: dict, skel: Path, project, wants: dict, result: ProjectResult) -> None:
    """Add the images one skeleton draws to ``wants``, located in one atlas or folder."""
    rel = name_as_text(skel.relative_to(project.root).as_posix())  # a row's text: UTF-8 whatever the disk holds
    version = spine_version(doc)
    usable = []
    for ref, problem in checked_attachments(doc):
        if problem:  # counted, not lost (a skeleton all of whose art is such needs no image, and says so too)
            if ref.attachment.get("type", "region") in ("region", "mesh", "linkedmesh"):
                result.skip("attachment of unusable fields")  # a mesh of broken numbers says nothing true of its art
            continue
        usable.append(ref)
    try:
        source = image_source_for(doc, skel, project)
    except SpineMeshError as e:
        result.errors.append(str(e))
        return
    if source is None:
        if not needed_images(doc):
            return  # a skeleton without image attachments (only clipping, paths, ...)
        result.errors.append(f"{skel}: no atlas or images folder holds this skeleton's images")
        return
    # A downscaled atlas beside an images folder: the folder holds the originals (editor
    # images are at skeleton size), so images it has are read from it at full size.
    originals = images_folder_for(doc, skel, project) if isinstance(source, AtlasImages) else None
    originals = FolderImages(originals) if originals is not None else None
    for ref in usable:
        mesh = None
        if ref.type == "mesh":
            mesh = ref.attachment
        elif ref.type == "linkedmesh":
            mesh = _linked_parent(doc, ref)
        try:
            paths = image_paths(ref)
        except SpineMeshError as e:  # a malformed sequence: only this attachment is left out
            result.error(f"{skel}: {e}")
            continue
        for path in paths:
            where = _locate(source, path)
            if where is not None and originals is not None and _downscaled(source, where) and path in originals:
                where = ("folder", originals.folder, (0, path))
            if where is None:
                result.skip("image not found")
                continue
            key = (where[0], where[1], path)
            old = wants.get(key)
            if old is None or (old.mesh is None and mesh is not None):
                wants[key] = _Want(where[0], where[1], where[2], path, ref.type, mesh, rel, version,
                                   [ref.skin, ref.slot, ref.name])


@functools.lru_cache(maxsize=256)
def _relative(path: Path, folder: Path) -> str:
    """``path`` relative to ``folder`` (real paths), or its name; cached: one per atlas or folder."""
    try:
        return name_as_text(Path(path).resolve().relative_to(folder.resolve()).as_posix())
    except ValueError:
        return name_as_text(Path(path).name)


def _downscaled(source: AtlasImages, where: tuple) -> bool:
    """Whether an atlas location's page was exported below full size (``scale:`` under 1)."""
    kind, path, (page, _name) = where
    atlas = next((a for a in source.atlases if a.path == path), None)
    return kind == "atlas" and atlas is not None and float(atlas.pages[page].scale) < 1.0


def _locate(source, name: str) -> tuple[str, Path, tuple] | None:
    """Which atlas (and page) or folder serves ``name``, or None when it is missing."""
    if isinstance(source, AtlasImages):
        for atlas in source.atlases:
            region = atlas.find(name)
            if region is not None:
                return "atlas", atlas.path, (region.page, name)
        return None
    if name in source:
        return "folder", source.folder, (0, name)
    return None
