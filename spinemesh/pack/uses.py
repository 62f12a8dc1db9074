"""How every skeleton of a project draws each atlas region: by a mesh (whose outline) or otherwise.

A region may be packed by its meshes' outline only when every use of it, in every skin of
every skeleton that loads its atlas, is a mesh: a mesh attachment, a linked mesh (drawn
with its source mesh's UVs) or a frame of a mesh's sequence. Anything else (a region
attachment, a malformed mesh, a skeleton that cannot be read) pins the region to its stored
rectangle; :class:`RegionUses` keeps the first reason.

No file says which atlas a game loads with a skeleton (a project often holds the same regions
in a straight and a premultiplied atlas), so a use counts for the region of that name in
*every* atlas of the project that has one, as the runtimes' ``findRegion`` finds it (the first
region of the name). That can only keep more rectangles, never draw a texel wrongly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..project import Project, image_source_for, project_atlases
from ..skeleton import (
    AttachmentRef,
    attachment_path,
    checked_attachments,
    image_paths,
    iter_skins,
    linked_source,
    load_skeleton,
    spine_version,
)
from ..skeleton_version import major_minor


@dataclass
class MeshUse:
    """One mesh drawing a region.

    Attributes
    ----------
    uvs : ndarray, shape (N, 2), float64
        The mesh's region UVs as the skeleton stores them (0..1).
    triangles : ndarray, shape (T, 3), int64
    honours_offsets : bool or None
        Whether the runtime of the skeleton's version maps UVs over the original image,
        stripped whitespace included (3.7 and later), or over the stored rectangle only
        (3.6); None when the version is unknown (both are assumed).
    """

    uvs: np.ndarray
    triangles: np.ndarray
    honours_offsets: bool | None


@dataclass
class RegionUses:
    """Everything known about how one region is drawn."""

    meshes: list[MeshUse] = field(default_factory=list)
    #: why the region keeps its stored rectangle ("" while only meshes use it)
    pinned: str = ""

    def pin(self, reason: str) -> None:
        if not self.pinned:
            self.pinned = reason


@dataclass
class ProjectUses:
    """Per atlas path, per region name, its uses; and why whole atlases keep their rectangles."""

    regions: dict[Path, dict[str, RegionUses]] = field(default_factory=dict)
    #: a reason that pins every region of every atlas (a skeleton that cannot be read)
    everything_pinned: str = ""
    problems: list[str] = field(default_factory=list)

    def of(self, atlas: Path, name: str) -> RegionUses:
        return self.regions.setdefault(atlas, {}).setdefault(name, RegionUses())


def rectangle_reason(region, first: bool, uses: RegionUses | None, pinned: str = "") -> str:
    """Why drawing ``region`` may read its whole stored rectangle; "" when only meshes draw it.

    Parameters
    ----------
    region : AtlasRegion
    first : bool
        Whether it is the first region of its name in its atlas (the one runtimes find).
    uses : RegionUses or None
        How the skeletons draw it (None: no skeleton does).
    pinned : str
        A reason that holds for every region (a skeleton that cannot be read).
    """
    if pinned:
        return pinned
    if not first:
        return "another region of the same name comes first, which runtimes use"
    if region.get("split") is not None or region.get("pad") is not None:
        return "nine-patch region (split/pad)"
    if uses is None or not uses.meshes and not uses.pinned:
        return "not drawn by any skeleton"
    return uses.pinned


def honours_offsets(version: str) -> bool | None:
    """Whether meshes of this editor version map UVs over the original image (3.7 and later).

    The official runtimes of 3.6 compute mesh UVs over the stored rectangle (``region.u`` to
    ``u2``); from 3.7 on every runtime subtracts the stripped whitespace (``offsetX``,
    ``originalWidth``), so a stored rectangle may be cropped without changing the UVs.
    """
    known = major_minor(version)
    return None if known is None else known >= (3, 7)


def mesh_arrays(att: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """``(uvs (N, 2) float64, triangles (T, 3) int64)`` of a mesh attachment dict, or None when malformed."""
    uvs, tris = att.get("uvs"), att.get("triangles")
    if not isinstance(uvs, list) or not isinstance(tris, list) or len(uvs) < 6 or len(uvs) % 2 or len(tris) % 3:
        return None
    try:
        uv = np.asarray(uvs, np.float64).reshape(-1, 2)
        tri = np.asarray(tris, np.int64).reshape(-1, 3)
    except (TypeError, ValueError):
        return None
    if not np.isfinite(uv).all() or tri.size == 0 or tri.min() < 0 or tri.max() >= len(uv):
        return None
    return uv, tri


def _find_attachment(doc: dict, skin: str, slot: str, name: str) -> dict | None:
    for skin_name, slots in iter_skins(doc):
        if skin_name == skin:
            found = slots.get(slot, {}) if isinstance(slots.get(slot), dict) else {}
            att = found.get(name)
            return att if isinstance(att, dict) else None
    return None


def _mesh_of(doc: dict, ref: AttachmentRef) -> tuple[dict | None, str]:
    """The attachment dict whose UVs draw ``ref`` (itself, or a linked mesh's source), or why none."""
    if ref.type == "mesh":
        return ref.attachment, ""
    skin, slot, name = linked_source(ref)
    source = _find_attachment(doc, skin, slot, name)
    if source is None or source.get("type", "region") != "mesh":
        return None, f"linked mesh whose source mesh {name!r} is not found"
    return source, ""


def collect_uses(project: Project, elsewhere: dict[Path, Path] | None = None) -> ProjectUses:
    """Read every skeleton of ``project`` and record how it draws each atlas region.

    Every skeleton counts, ``.json`` and ``.skel`` twins alike: a game may load either.
    ``elsewhere``: skeletons that load the project's atlases but are not in its folder, by the
    path each would have there (it finds its atlases as from that place) to the file to read:
    the other skeletons of the folder that ``upgrade`` was given one skeleton file of.
    """
    uses = ProjectUses()
    atlases = project_atlases(project)
    elsewhere = elsewhere or {}
    for path in [*project.skeletons, *elsewhere]:
        rel = path.relative_to(project.root).as_posix()
        try:
            doc = load_skeleton(elsewhere.get(path, path))
            source = image_source_for(doc, path, project)
        except SpineMeshError as e:
            uses.problems.append(str(e))
            if not uses.everything_pinned:
                uses.everything_pinned = f"skeleton {rel} cannot be read, so what it draws is unknown"
            continue
        if not getattr(source, "atlases", None):
            continue  # drawn from an images folder: no atlas region is involved
        honours = honours_offsets(spine_version(doc))
        for ref, problem in checked_attachments(doc):
            try:
                paths = image_paths(ref)
            except SpineMeshError as e:  # a malformed sequence: its path is pinned in every atlas
                for atlas in atlases.values():
                    if atlas.find(attachment_path(ref)) is not None:
                        uses.of(atlas.path, attachment_path(ref)).pin(f"{rel}: {e}")
                continue
            if not paths:
                continue
            # an attachment of unusable fields is drawn all the same by some runtime (one naming a
            # field twice by every one): what it draws of its region is not known, so all of it
            mesh, why = (None, problem) if ref.type == "region" or problem else _mesh_of(doc, ref)
            arrays = mesh_arrays(mesh) if mesh is not None else None
            use = None if arrays is None else MeshUse(arrays[0], arrays[1], honours)
            for name in paths:
                for atlas in atlases.values():
                    if atlas.find(name) is None:
                        continue
                    region = uses.of(atlas.path, name)
                    if ref.type == "region" and not problem:
                        region.pin(f"drawn as a region attachment ({rel}, slot {ref.slot!r})")
                    elif use is None:
                        region.pin(f"{why or 'mesh with malformed uvs or triangles'} ({rel}, slot {ref.slot!r})")
                    elif not region.pinned:
                        region.meshes.append(use)
    if not project.skeletons and not elsewhere:  # an atlas given apart from its skeletons (art/ alone)
        uses.everything_pinned = ("the project holds no skeleton, so nothing says how its regions are drawn: "
                                  "pack the folder that also holds the skeletons that load it")
    for atlas in atlases.values():
        uses.regions.setdefault(atlas.path, {})
    return uses
