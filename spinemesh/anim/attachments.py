"""Drawn attachments prepared once per skeleton, and their world vertices in a pose.

Region attachments draw a quad over the part of their image the atlas stored (a trimmed
region covers less than the original image): the runtimes place its corners from the
attachment's size, scale, rotation and offset and the atlas region's offsets, in the order
bottom-left, top-left, top-right, bottom-right. Without an atlas the whole image is assumed
stored. Mesh attachments (linked meshes take their parent's geometry) place each vertex in
the slot bone's space, or, weighted, as the sum over its bones of ``weight * bone @ local``.
An animation's deform replaces an unweighted mesh's local positions, or offsets each weighted
influence. Clipping attachments are vertex attachments too (their polygon).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import SpineMeshError
from ..rig.binding import parse_vertices
from ..rig.transform import DEG_RAD
from ..skeleton import AttachmentRef, linked_source, sequence_paths
from ..skeleton_check import attachment_problem, is_int, is_number
from .curves import _number
from .timelines import color_channels


@dataclass
class RegionGeometry:
    """What a region quad needs of its atlas region (pixels): stored size, offsets, original size."""

    width: float
    height: float
    offset_x: float
    offset_y: float
    original_width: float
    original_height: float


def region_corners(att: dict, region: RegionGeometry | None) -> tuple[np.ndarray, np.ndarray]:
    """A region attachment's corners in its bone's space and in its image, as the runtimes compute them.

    Returns
    -------
    offsets : ndarray, shape (4, 2)
        Bottom-left, top-left, top-right, bottom-right, in the slot bone's space (float32, as stored).
    uvs : ndarray, shape (4, 2)
        The same corners in the original image: u right, v down, 0..1.
    """
    width, height = _number(att.get("width", 32), 32), _number(att.get("height", 32), 32)
    scale_x, scale_y = _number(att.get("scaleX", 1), 1), _number(att.get("scaleY", 1), 1)
    x, y, rotation = _number(att.get("x", 0), 0), _number(att.get("y", 0), 0), _number(att.get("rotation", 0), 0)
    if region is None or region.original_width <= 0 or region.original_height <= 0:
        region = RegionGeometry(width, height, 0.0, 0.0, width, height) if width and height else \
            RegionGeometry(1, 1, 0, 0, 1, 1)
    rsx = width / region.original_width * scale_x
    rsy = height / region.original_height * scale_y
    lx = -width / 2 * scale_x + region.offset_x * rsx
    ly = -height / 2 * scale_y + region.offset_y * rsy
    lx2, ly2 = lx + region.width * rsx, ly + region.height * rsy
    r = rotation * DEG_RAD
    cos, sin = math.cos(r), math.sin(r)
    xc, xs, yc, ys = lx * cos + x, lx * sin, ly * cos + y, ly * sin
    x2c, x2s, y2c, y2s = lx2 * cos + x, lx2 * sin, ly2 * cos + y, ly2 * sin
    offsets = np.array([[xc - ys, yc + xs], [xc - y2s, y2c + xs], [x2c - y2s, y2c + x2s], [x2c - ys, yc + x2s]])
    u1 = region.offset_x / region.original_width
    u2 = (region.offset_x + region.width) / region.original_width
    v_bottom = 1 - region.offset_y / region.original_height
    v_top = 1 - (region.offset_y + region.height) / region.original_height
    uvs = np.array([[u1, v_bottom], [u1, v_top], [u2, v_top], [u2, v_bottom]])
    return offsets.astype(np.float32).astype(np.float64), uvs


class VertexGeometry:
    """A vertex attachment's vertices laid out for fast world positions.

    ``setup`` is the runtimes' deform layout of the setup vertices (2N positions when
    unweighted; zeros, one pair per bone influence, when weighted).
    """

    def __init__(self, att: dict, count: int, bone_count: int, uvs: list | None = None):
        mesh = parse_vertices({"uvs": uvs if uvs is not None else [0.0] * (2 * count),
                               "vertices": att.get("vertices")}, bone_count)
        self.count = mesh.count
        self.weighted = mesh.weighted
        if not mesh.weighted:
            self.local = mesh.local.astype(np.float32).astype(np.float64)
            self.setup = self.local.reshape(-1).copy()
        else:
            rows = [(v, b, x, y, w) for v, entry in enumerate(mesh.influences) for b, x, y, w in entry]
            arr = np.array(rows, np.float64).reshape(-1, 5)
            self.vertex = arr[:, 0].astype(np.intp)
            self.bone = arr[:, 1].astype(np.intp)
            self.local = arr[:, 2:4].astype(np.float32).astype(np.float64)
            self.weight = arr[:, 4].astype(np.float32).astype(np.float64)
            self.setup = np.zeros(2 * len(arr))

    def world(self, worlds: np.ndarray, slot_bone: int, deform: np.ndarray | None = None) -> np.ndarray:
        """World positions (N, 2) with the bones' world transforms ``worlds`` (B, 2, 3) and an
        optional deform (the layout of ``setup``)."""
        if not self.weighted:
            local = self.local if deform is None else deform.reshape(-1, 2)
            m = worlds[slot_bone]
            return local @ m[:, :2].T + m[:, 2]
        local = self.local if deform is None else self.local + deform.reshape(-1, 2)
        x, y = local[:, 0], local[:, 1]
        m = worlds.reshape(-1, 6).take(self.bone, axis=0).T    # (6, M): a, b, worldX, c, d, worldY
        out = np.empty((self.count, 2))
        for axis, (a, b, w) in enumerate(((0, 1, 2), (3, 4, 5))):
            # (a * x + b * y + worldX) * weight per influence, in the runtimes' order, on
            # rows of one number each: each rounds as it did on the (M, 2, 3) copy, at half the cost or less
            p = m[a] * x
            p += m[b] * y
            p += m[w]
            p *= self.weight
            out[:, axis] = np.bincount(self.vertex, p, self.count)
        return out


@dataclass
class Prepared:
    """One attachment of one skin, ready to draw."""

    skin: str
    slot: int
    key: str                      # its name in the skin
    name: str                     # the runtime's attachment name (``name`` field, else the key)
    path: str                     # image path (``path``, else the name)
    type: str                     # region, mesh, clipping, path, other
    color: tuple[float, float, float, float]
    geometry: VertexGeometry | None = None
    offsets: np.ndarray | None = None          # region: (4, 2), or one per sequence frame (S, 4, 2)
    uvs: np.ndarray | None = None              # (N, 2) original-image uvs; region sequences (S, 4, 2)
    triangles: np.ndarray | None = None
    hull: int | None = None
    timeline_key: tuple[str, int, str] = ("", 0, "")   # the attachment deform timelines key on
    sequence_count: int = 0
    setup_index: int = 0
    end_slot: str | None = None               # clipping
    frame_paths: list[str] | None = None

    @cached_property
    def rgba(self) -> np.ndarray:
        """``color`` as an array (4,), made once (read only: a pose multiplies it into a new one)."""
        return np.array(self.color)

    def frame(self, index: int) -> int:
        """The sequence frame shown for a slot's sequence index (-1: the setup frame)."""
        if not self.sequence_count:
            return 0
        i = self.setup_index if index < 0 else index
        return min(max(i, 0), self.sequence_count - 1)


def prepare(doc_skins: dict, skin: str, slot: int, slot_name: str, key: str, att: dict, bone_count: int,
            region_of, slot_index: dict | None = None) -> Prepared | None:
    """Prepare one attachment; None when it cannot be drawn (a broken mesh, a missing parent, a
    field :func:`~spinemesh.skeleton_check.attachment_problem` refuses).

    ``doc_skins`` maps skin name to ``{slot name: {key: attachment}}``; ``region_of(path)``
    gives the atlas region's geometry or None; ``slot_index`` maps slot name to index (a 4.3
    linked mesh may take its source mesh, and its deform and sequence keys, from another slot).
    """
    # A number no float32 holds (y: 1e300, an integer of 400 digits) is an infinity in the
    # runtimes; drawn with the field's default, the quad was written where no runtime puts it.
    if attachment_problem(att):
        return None
    kind = att.get("type", "region")
    name = str(att.get("name", key))
    path = str(att.get("path") or name)
    color = tuple(color_channels(att.get("color", "ffffffff"), 4))
    out = Prepared(skin, slot, key, name, path, "other", color, timeline_key=(skin, slot, key))
    seq = att.get("sequence") if isinstance(att.get("sequence"), dict) else None
    if seq is not None:
        try:
            out.frame_paths = sequence_paths(path, seq)
        except SpineMeshError:
            return None
        out.sequence_count = len(out.frame_paths)
        out.setup_index = int(_number(seq.get("setup", 0), 0))
    paths = out.frame_paths or [path]
    if kind == "region":
        out.type = "region"
        corners = [region_corners(att, region_of(p)) for p in paths]
        out.offsets = np.stack([c[0] for c in corners])
        out.uvs = np.stack([c[1] for c in corners])
        out.triangles = np.array([0, 1, 2, 2, 3, 0])
        return out
    if kind in ("mesh", "linkedmesh"):
        source = att
        if kind == "linkedmesh":
            # 4.3: the source mesh may sit in another slot ("slot"), whose keys then drive it too
            parent_skin, source_slot, parent_key = linked_source(AttachmentRef(skin, slot_name, key, att))
            source = ((doc_skins.get(parent_skin) or {}).get(source_slot) or {}).get(parent_key)
            if not isinstance(source, dict) or source.get("type", "region") != "mesh":
                return None
            inherit = att.get("timelines", att.get("deform", True)) is not False
            if inherit:
                out.timeline_key = (parent_skin, (slot_index or {}).get(source_slot, slot), parent_key)
        uvs = source.get("uvs")
        try:
            out.geometry = VertexGeometry(source, len(uvs) // 2 if isinstance(uvs, list) else 0, bone_count, uvs)
        except SpineMeshError:
            return None
        out.type = "mesh"
        out.uvs = np.asarray(uvs, np.float64).reshape(-1, 2)
        out.triangles = np.asarray(source.get("triangles") or [], np.intp)
        hull = source.get("hull")
        out.hull = int(hull) if is_number(hull) else None
        return out
    if kind in ("clipping", "path"):
        count = att.get("vertexCount")
        verts = att.get("vertices")
        # each vertex takes a number at least: a count beyond them (2**31) is unreadable, never allocated
        numbers = len(verts) if isinstance(verts, list) else 0
        if not is_int(count) or not 0 < count <= numbers:
            return None
        try:
            out.geometry = VertexGeometry(att, count, bone_count)
        except SpineMeshError:
            return None
        out.type = kind
        end = att.get("end")
        out.end_slot = str(end) if end is not None else None
        return out
    return out
