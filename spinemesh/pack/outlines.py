"""Footprints: the texels of a page that drawing a region can read, in the region's upright frame.

Everything here works in *upright* texel coordinates: the region's original image, unrotated,
``(0, 0)`` at its top-left, ``original_width x original_height`` texels (the stored part is
the *content box*; the rest was stripped whitespace). A footprint is a window of that frame
(it may reach beyond the image) with a mask of the texels that must travel with the region:

- a region drawn by meshes only: every texel that bilinear sampling may read while any of its
  meshes' triangles is drawn (centres less than a texel from the triangle on both axes);
- any other region: its stored rectangle grown by one texel (the quad's edge samples the
  texels just outside it).

The texels under the mask are copied from the original page, whatever they are (stripped
whitespace, padding, a neighbour's edge): the copy then samples exactly as the original did.

A footprint's *hard* texels (:func:`hard_texels`) are those within one texel of a texel of the
original page that is not all zero; the rest are *soft*: all zero (R = G = B = A = 0), and no
bilinear read of anything visible includes them. A soft texel only has to stay all zero, so two
footprints may share their soft texels (:mod:`spinemesh.pack.place`): all-zero texels draw
nothing in every blend mode, premultiplied or not, and a read of all-zero texels gives zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..atlas import RegionGeometry
from .place import block_any
from .uses import MeshUse, RegionUses

#: Largest supersampled raster of one region's meshes (texels x supersampling squared).
MAX_RASTER = 16_000_000

#: How far (in UV units) a mesh vertex may lie outside its image before the region keeps its rectangle.
UV_SLACK = 0.01


@dataclass
class Footprint:
    """One region's footprint.

    Attributes
    ----------
    window : (int, int, int, int)
        ``(x0, y0, x1, y1)`` in upright texels; may start below 0 or end past the image.
    core : ndarray, shape (y1 - y0, x1 - x0), bool
        Texels to copy and to keep clear of other footprints.
    content : (int, int, int, int)
        The stored part after packing, ``(x0, y0, x1, y1)`` in upright texels, inside ``window``.
    by_outline : bool
        Packed by its meshes' outline (False: by its stored rectangle).
    reason : str
        Why it keeps its rectangle ("" when by outline).
    """

    window: tuple[int, int, int, int]
    core: np.ndarray
    content: tuple[int, int, int, int]
    by_outline: bool
    reason: str = ""


def content_box(g: RegionGeometry) -> tuple[int, int, int, int]:
    """The stored part of the original image, ``(x0, y0, x1, y1)`` in upright texels (y down)."""
    top = g.original_height - g.offset_y - g.height
    return g.offset_x, top, g.offset_x + g.width, top + g.height


def mesh_points(uvs: np.ndarray, g: RegionGeometry, honours_offsets: bool) -> np.ndarray:
    """Mesh UVs as upright texel coordinates, shape (N, 2), as the runtime of the version maps them.

    3.7 and later map UVs over the original image; 3.6 over the stored rectangle (see
    :func:`spinemesh.pack.uses.honours_offsets`).
    """
    if honours_offsets:
        return uvs * (g.original_width, g.original_height)
    x0, y0, _, _ = content_box(g)
    return uvs * (g.width, g.height) + (x0, y0)


def sampled_texels(points: np.ndarray, triangles: np.ndarray, origin: tuple[int, int],
                   shape: tuple[int, int]) -> np.ndarray:
    """Texels that bilinear sampling may read while the triangles are drawn, shape ``shape``, bool.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Vertices in texel coordinates (a texel ``(i, j)`` is the square ``[i, i+1] x [j, j+1]``,
        its centre at ``(i + 0.5, j + 0.5)``).
    triangles : ndarray, shape (T, 3)
    origin : (int, int)
        The texel coordinates of the raster's top-left texel.
    shape : (int, int)
        ``(height, width)`` of the raster.

    A sample at ``p`` reads the texels whose centres lie less than one texel from ``p`` on
    both axes. The triangles are drawn on a grid ``s`` times finer (``s`` = 4 unless the
    raster would exceed :data:`MAX_RASTER`) and grown by one fine cell, so that every point of
    a triangle lies in a set cell; a texel is then kept when a set cell lies within one texel
    (plus half a cell) of its centre, which is every cell from ``s/2`` cells before its own to
    ``s/2`` cells after.
    """
    import cv2

    h, w = shape
    s = 4
    while s > 1 and h * w * s * s > MAX_RASTER:
        s //= 2
    fine = np.zeros((h * s, w * s), np.uint8)
    shift = 4  # sub-cell precision of the vertex coordinates (cv2 fixed point)
    pts = np.round((points - origin) * s * (1 << shift)).astype(np.int64)
    limit = np.iinfo(np.int32).max // 2
    pts = np.clip(pts, -limit, limit).astype(np.int32)
    for tri in triangles:
        cv2.fillConvexPoly(fine, pts[tri], 1, lineType=cv2.LINE_8, shift=shift)
    fine = cv2.dilate(fine, np.ones((3, 3), np.uint8))
    return block_any(fine, s, grow=-(-s // 2))[:h, :w]


#: How far (texels, square neighbourhood) a hard texel may lie from a texel that is not all zero:
#: the reach of a bilinear read, so that no read touching visible art includes a soft texel.
HARD_REACH = 1


def hard_texels(core: np.ndarray, texels: np.ndarray) -> np.ndarray:
    """The footprint's texels within :data:`HARD_REACH` of a footprint texel that is not all zero, bool.

    Parameters
    ----------
    core : ndarray, shape (h, w), bool
        The footprint's mask (:attr:`Footprint.core`).
    texels : ndarray, shape (h, w, 4), uint8
        The original page's texels under its window (:func:`window_texels`).

    Returns
    -------
    ndarray, shape (h, w), bool
        Within ``core``; ``core`` minus it is the footprint's soft part (all-zero texels away from
        anything visible).
    """
    import cv2

    drawn = (core & texels.any(axis=2)).astype(np.uint8)
    size = 2 * HARD_REACH + 1
    return core & cv2.dilate(drawn, np.ones((size, size), np.uint8), borderValue=0).astype(bool)


def rectangle_footprint(g: RegionGeometry, reason: str) -> Footprint:
    """The stored rectangle and the one-texel ring its quad's edge samples."""
    x0, y0, x1, y1 = content_box(g)
    core = np.ones((y1 - y0 + 2, x1 - x0 + 2), bool)
    return Footprint((x0 - 1, y0 - 1, x1 + 1, y1 + 1), core, (x0, y0, x1, y1), False, reason)


def _unique_meshes(meshes: list[MeshUse]) -> list[MeshUse]:
    seen, out = set(), []
    for m in meshes:
        key = (m.uvs.tobytes(), m.triangles.tobytes(), m.honours_offsets)
        if key not in seen:
            seen.add(key)
            out.append(m)
    return out


def mesh_footprint(g: RegionGeometry, meshes: list[MeshUse]) -> Footprint | str:
    """The union of the meshes' triangles, grown by what bilinear sampling reads, or why it cannot be used.

    The stored rectangle is cropped to the footprint only when every mesh's runtime maps UVs
    over the original image (3.7 and later): the offsets then move with the crop and the UVs
    stay valid. For 3.6 meshes the rectangle stays whole (their UVs span it).
    """
    box = content_box(g)
    placed: list[np.ndarray] = []
    tris: list[np.ndarray] = []
    crop = True
    for m in _unique_meshes(meshes):
        lo, hi = m.uvs.min(axis=0), m.uvs.max(axis=0)
        if (lo < -UV_SLACK).any() or (hi > 1 + UV_SLACK).any():
            return "a mesh's UVs reach outside its image"
        for honours in ((True, False) if m.honours_offsets is None else (m.honours_offsets,)):
            placed.append(mesh_points(m.uvs, g, honours))
            tris.append(m.triangles)
            crop = crop and honours
    allpts = np.concatenate(placed)
    lo = np.floor(allpts.min(axis=0)).astype(int) - 2
    hi = np.ceil(allpts.max(axis=0)).astype(int) + 2
    shape = (int(hi[1] - lo[1]), int(hi[0] - lo[0]))
    core = np.zeros(shape, bool)
    for pts, tri in zip(placed, tris):
        core |= sampled_texels(pts, tri, (int(lo[0]), int(lo[1])), shape)
    ys, xs = np.nonzero(core)
    if ys.size == 0:
        return "its meshes cover no texel"
    fx0, fy0, fx1, fy1 = lo[0] + xs.min(), lo[1] + ys.min(), lo[0] + xs.max() + 1, lo[1] + ys.max() + 1
    if crop:
        content = (max(box[0], fx0), max(box[1], fy0), min(box[2], fx1), min(box[3], fy1))
        if content[2] <= content[0] or content[3] <= content[1]:
            return "its meshes draw none of its stored texels"
    else:
        content = box
    wx0, wy0 = min(fx0, content[0]), min(fy0, content[1])
    wx1, wy1 = max(fx1, content[2]), max(fy1, content[3])
    window_core = np.zeros((wy1 - wy0, wx1 - wx0), bool)
    # the core's texels inside the window (the window holds the footprint's bounding box)
    sy0, sx0 = wy0 - lo[1], wx0 - lo[0]
    src = core[max(0, sy0):sy0 + (wy1 - wy0), max(0, sx0):sx0 + (wx1 - wx0)]
    window_core[max(0, -sy0):max(0, -sy0) + src.shape[0], max(0, -sx0):max(0, -sx0) + src.shape[1]] = src
    return Footprint((int(wx0), int(wy0), int(wx1), int(wy1)), window_core,
                     tuple(int(v) for v in content), True)


def grown_for_mipmaps(g: RegionGeometry, fp: Footprint) -> Footprint:
    """A footprint by outline grown by the region's own stored texels that its first mipmap
    level reads: the texel beyond the core (drawn texels and their ring) within its stored
    rectangle. A level-1 texel averages a block of 2 x 2 and bilinear sampling reads the next
    block too, so it reaches 2 texels beyond what is drawn; art the meshes do not draw lies
    there, which the original's level averages in, and the packed page then holds it too (with
    the region's blocks falling alike, its level-1 texels under every mesh are the original's).
    Beyond the stored rectangle lie the exporter's padding and other regions: not copied. A
    footprint by rectangle already holds its whole rectangle: returned as it is."""
    if not fp.by_outline:
        return fp
    wx0, wy0, wx1, wy1 = fp.window
    core = np.pad(fp.core, 1)
    grown = core.copy()
    grown[1:, :] |= core[:-1, :]
    grown[:-1, :] |= core[1:, :]
    near = grown.copy()
    near[:, 1:] |= grown[:, :-1]
    near[:, :-1] |= grown[:, 1:]
    x0, y0, x1, y1 = content_box(g)
    own = np.zeros_like(core)
    own[max(0, y0 - wy0 + 1):max(0, y1 - wy0 + 1), max(0, x0 - wx0 + 1):max(0, x1 - wx0 + 1)] = True
    return Footprint((wx0 - 1, wy0 - 1, wx1 + 1, wy1 + 1), core | (near & own), fp.content, True, fp.reason)


def footprint(g: RegionGeometry, uses: RegionUses | None) -> Footprint:
    """The footprint of a region from how it is drawn (by outline when only meshes draw it)."""
    if uses is None or (not uses.meshes and not uses.pinned):
        return rectangle_footprint(g, "not drawn by any skeleton")
    if uses.pinned:
        return rectangle_footprint(g, uses.pinned)
    found = mesh_footprint(g, uses.meshes)
    if isinstance(found, str):
        return rectangle_footprint(g, found)
    return found


def stored_index(i, j, width: int, height: int, k: int):
    """Where texel ``(i, j)`` of an upright ``width x height`` image lies once stored turned by ``k`` x 90 degrees.

    The atlas convention (:func:`spinemesh.images.regions.upright_at_original_size`): a region stored
    with ``rotate: 90`` holds its upright image turned counter-clockwise. Returns ``(row,
    column)`` in the stored array; works for indices outside the image too (linear).
    """
    if k == 0:
        return j, i
    if k == 1:
        return width - 1 - i, j
    if k == 2:
        return height - 1 - j, width - 1 - i
    return i, height - 1 - j


def window_texels(page: np.ndarray, g: RegionGeometry, window: tuple[int, int, int, int]) -> np.ndarray:
    """The page's texels under an upright window of a region, turned upright, shape (h, w, 4).

    Texels beyond the page's edge repeat the edge (what a clamped texture samples there).
    """
    x0, y0, x1, y1 = content_box(g)
    k = g.degrees // 90
    cw, ch = x1 - x0, y1 - y0
    wx0, wy0, wx1, wy1 = window
    corners = [stored_index(i - x0, j - y0, cw, ch, k) for i in (wx0, wx1 - 1) for j in (wy0, wy1 - 1)]
    rows = [r for r, _ in corners]
    cols = [c for _, c in corners]
    r0, r1 = g.y + min(rows), g.y + max(rows) + 1
    c0, c1 = g.x + min(cols), g.x + max(cols) + 1
    ph, pw = page.shape[:2]
    if 0 <= r0 and r1 <= ph and 0 <= c0 and c1 <= pw:  # a view: an atlas's windows cover its pages again
        return np.rot90(page[r0:r1, c0:c1], -k)
    # clamped indices: texels beyond the page repeat its edge, as a clamped texture samples them
    stored = page[np.ix_(np.clip(np.arange(r0, r1), 0, ph - 1), np.clip(np.arange(c0, c1), 0, pw - 1))]
    return np.rot90(stored, -k)
