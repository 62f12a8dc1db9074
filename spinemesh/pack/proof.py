"""The proof a packed atlas passes before it is written: every texel drawing can read is the original's.

:func:`prove_packed` takes the original atlas and pages and the packed atlas *as it will be
written* (its text parsed back, its pages decoded back from the bytes to be written) and checks,
region by region, that every texel a runtime may read while drawing the region holds on the new
page what it held on the original one:

- a region that only meshes draw (:func:`spinemesh.pack.uses.rectangle_reason`): every texel
  a bilinear sample inside any of its meshes' triangles reads, at the UVs as the runtime maps them;
- any other region: its stored rectangle and the one-texel ring its quad's edge samples.

Texels are compared where the runtime reads them, page against page: the region's upright frame
is mapped onto each page by the formula the runtimes use for UVs (``updateUVs`` / ``computeUVs``
of spine-ts and spine-c, 3.7 and later; 3.6 maps UVs over the stored rectangle), so the proof
does not trust the packer's own geometry code (:func:`spinemesh.pack.outlines.stored_index`).
Texels beyond a page's edge read the edge (clamped), or wrap where the page repeats.

The texels a triangle reads are found exactly, not by supersampling as the packer's footprints
are (:func:`spinemesh.pack.outlines.sampled_texels`): a sample at ``p`` reads the texels whose
centres lie less than one texel from ``p`` on both axes, so a texel is read when its centre lies
inside the triangle grown by the open square ``(-1, 1)^2``; row by row that is an open interval.
Two different methods: a footprint cut short fails the proof.

Besides the texels, the proof checks what else decides what a runtime draws: the same regions
under the same names in the same order, their fields other than geometry, their page's fields
other than ``size``, the image size every UV is scaled by, and every new page's ``size:`` line
against its image (:func:`spinemesh.atlas.page_mismatches`).
"""

from __future__ import annotations

import numpy as np

from ..atlas import Atlas, AtlasPage, AtlasRegion, RegionGeometry, page_mismatches
from ..limits import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE
from .outlines import content_box, mesh_points
from .uses import RegionUses, rectangle_reason

#: Region fields that say where and how it is stored (the packer rewrites them; the rest must stay).
GEOMETRY_KEYS = {"bounds", "offsets", "xy", "size", "orig", "offset", "rotate"}

#: Triangle-row pairs rasterised at once (memory: about 100 bytes each).
ROW_BATCH = 1 << 18


class ProofFailed(Exception):
    """The packed atlas would not draw as the original: the message says where and how."""


def page_texel(g: RegionGeometry, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Page texel ``(column, row)`` under the upright texel ``(i, j)`` of a region stored as ``g``.

    The runtimes map a point ``(px, py)`` of the upright original image (y down, ``original_width
    x original_height``) onto the page as below (their UV formulas, in texels); a texel's centre
    is mapped and the page texel holding it returned.
    """
    ox, oy, w, h, ow, oh = g.offset_x, g.offset_y, g.width, g.height, g.original_width, g.original_height
    px, py = i + 0.5, j + 0.5
    if g.degrees == 90:
        x, y = g.x - (oh - oy - h) + py, g.y - (ow - ox - w) + ow - px
    elif g.degrees == 180:
        x, y = g.x - (ow - ox - w) + ow - px, g.y - oy + oh - py
    elif g.degrees == 270:
        x, y = g.x - oy + oh - py, g.y - ox + px
    else:
        x, y = g.x - ox + px, g.y - (oh - oy - h) + py
    return np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)


def triangle_reads(points: np.ndarray, triangles: np.ndarray) -> tuple[tuple[int, int], np.ndarray]:
    """The texels bilinear sampling reads while the triangles are drawn, exactly.

    Parameters
    ----------
    points : ndarray, shape (N, 2), float
        Vertices in texel coordinates (texel ``(i, j)`` is the square ``[i, i+1] x [j, j+1]``).
    triangles : ndarray, shape (T, 3), int

    Returns
    -------
    origin : (int, int)
        Texel ``(x, y)`` of the mask's top-left.
    mask : ndarray, shape (h, w), bool
        Texels whose centre lies less than one texel, on both axes, from a point of a triangle.

    Raises
    ------
    ProofFailed
        When the triangles span more texels than an image may have (UVs far outside their image).
    """
    tri = points[triangles]  # (T, 3, 2)
    lo = np.floor(points.min(axis=0)).astype(np.int64) - 2
    hi = np.ceil(points.max(axis=0)).astype(np.int64) + 2
    width, height = int(hi[0] - lo[0]), int(hi[1] - lo[1])
    if width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE or width * height > MAX_IMAGE_PIXELS:
        # UVs far outside the image (the packer keeps such a region's rectangle): not proven, never allocated
        raise ProofFailed(f"a mesh reaches {width}x{height} texels, beyond the limits of an image")
    tri = tri - lo  # small coordinates: exact enough in float64
    ys = tri[..., 1]
    # rows j whose band (j - 0.5, j + 1.5) meets the triangle: j > ymin - 1.5 and j < ymax + 0.5
    first = np.floor(ys.min(axis=1) - 1.5).astype(np.int64) + 1
    last = np.ceil(ys.max(axis=1) + 0.5).astype(np.int64) - 1
    counts = np.maximum(0, last - first + 1)
    diff = np.zeros((height, width + 1), np.int32)
    order = np.arange(len(tri))
    start = 0
    while start < len(tri):
        # whole triangles per batch, about ROW_BATCH rows
        stop = start + max(1, int(np.searchsorted(np.cumsum(counts[start:]), ROW_BATCH)))
        idx = np.repeat(order[start:stop], counts[start:stop])
        rows = (np.arange(idx.size) - np.repeat(np.cumsum(counts[start:stop]) - counts[start:stop], counts[start:stop])
                + first[idx])
        a, b = _x_range(tri[idx], rows - 0.5, rows + 1.5)
        with np.errstate(invalid="ignore"):  # a band no part of the triangle lies in: left out below
            i0 = np.floor(a - 1.5).astype(np.int64) + 1  # centres i + 0.5 in (a - 1, b + 1)
            i1 = np.ceil(b + 0.5).astype(np.int64) - 1
        keep = np.isfinite(a) & np.isfinite(b) & (i1 >= i0) & (rows >= 0) & (rows < height)
        rows, i0, i1 = rows[keep], np.clip(i0[keep], 0, width), np.clip(i1[keep] + 1, 0, width)
        np.add.at(diff, (rows, i0), 1)
        np.add.at(diff, (rows, i1), -1)
        start = stop
    mask = np.cumsum(diff, axis=1)[:, :width] > 0
    return (int(lo[0]), int(lo[1])), mask


def _x_range(tri: np.ndarray, y0: np.ndarray, y1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least and greatest x of each triangle ``(M, 3, 2)`` within the band ``y0 <= y <= y1``: its
    vertices inside the band and where its edges cross the band's lines."""
    xs, ys = tri[..., 0], tri[..., 1]
    cands = [np.where((ys >= y0[:, None]) & (ys <= y1[:, None]), xs, np.nan)]
    for k in range(3):
        xa, ya, xb, yb = xs[:, k], ys[:, k], xs[:, (k + 1) % 3], ys[:, (k + 1) % 3]
        dy = yb - ya
        for line in (y0, y1):
            crosses = ((ya - line) * (yb - line) <= 0) & (dy != 0)
            t = np.divide(line - ya, dy, out=np.zeros_like(dy), where=dy != 0)
            cands.append(np.where(crosses, xa + t * (xb - xa), np.nan)[:, None])
    allx = np.concatenate(cands, axis=1)
    return np.fmin.reduce(allx, axis=1), np.fmax.reduce(allx, axis=1)  # NaN (no candidate) left out


def _uv_frame(g: RegionGeometry, honours: bool | None) -> tuple:
    """What mesh UVs are scaled over in a region stored as ``g`` (see :func:`mesh_points`): the
    original image from 3.7, the stored rectangle in 3.6 (both when the version is unknown)."""
    whole = (g.original_width, g.original_height)
    stored = (g.width, g.height, content_box(g))
    return whole if honours else stored if honours is False else (whole, stored)


def _reads(region: AtlasRegion, g: RegionGeometry, uses: RegionUses | None, meshes_only: bool):
    """The upright texels drawing ``region`` reads: ``(origin, mask)`` pieces."""
    if not meshes_only:
        x0, y0, x1, y1 = content_box(g)
        return [((x0 - 1, y0 - 1), np.ones((y1 - y0 + 2, x1 - x0 + 2), bool))]
    pieces = []
    for m in uses.meshes:
        for honours in (True, False) if m.honours_offsets is None else (m.honours_offsets,):
            pieces.append(triangle_reads(mesh_points(m.uvs, g, honours), m.triangles))
    return pieces


def _texels(page: np.ndarray, repeat: str, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The page's texels (as uint32 words) at ``(cols, rows)``: clamped to the edge, or wrapped
    on an axis the page repeats."""
    h, w = page.shape[:2]
    cols = cols % w if "x" in repeat else np.clip(cols, 0, w - 1)
    rows = rows % h if "y" in repeat else np.clip(rows, 0, h - 1)
    words = np.ascontiguousarray(page).view(np.uint32)[..., 0]
    return words[rows, cols]


def page_repeat(page: AtlasPage) -> str:
    """The axes a page repeats on, as its ``repeat:`` field says (``x``, ``y``, ``xy``), lower case;
    ``none`` when it has none."""
    v = page.get("repeat")
    return v[0].strip().lower() if v else "none"


def _other_fields(entries) -> list:
    return [(e.key, [v.strip() for v in e.values]) for e in entries if e.key not in GEOMETRY_KEYS]


def _page_fields(page: AtlasPage) -> list:
    return [(e.key, [v.strip().lower() for v in e.values]) for e in page.entries if e.key != "size"]


def prove_packed(before: Atlas, before_pages: list[np.ndarray], after: Atlas, after_pages: list[np.ndarray],
                 uses: dict[str, RegionUses], pinned: str = "") -> int:
    """Check that ``after`` draws every region as ``before`` does, texel for texel.

    Parameters
    ----------
    before : Atlas
        The original atlas.
    before_pages : list of ndarray
        Its pages' texels, (H, W, 4) uint8, in page order.
    after : Atlas
        The packed atlas, parsed from the text to be written.
    after_pages : list of ndarray
        Its pages' texels as decoded from the bytes to be written, in page order.
    uses, pinned
        How the project's skeletons draw each region (:func:`spinemesh.pack.uses.collect_uses`).

    Returns
    -------
    int
        Texels compared.

    Raises
    ------
    ProofFailed
        With the first region (or page) that would draw differently, and how.
    """
    for m in page_mismatches(after, [(int(p.shape[1]), int(p.shape[0])) for p in after_pages]):
        raise ProofFailed(f"the packed atlas is inconsistent: {m.message}")
    by_name: dict[str, list[AtlasRegion]] = {}
    for r in after.regions:
        by_name.setdefault(r.name, []).append(r)
    if sorted(by_name) != sorted({r.name for r in before.regions}) or len(after.regions) != len(before.regions):
        raise ProofFailed("the packed atlas does not hold the same regions")
    seen: dict[str, int] = {}
    first_of: dict[str, AtlasRegion] = {}
    compared = 0
    for r in before.regions:
        k = seen.get(r.name, 0)
        seen[r.name] = k + 1
        first = first_of.setdefault(r.name, r) is r
        if k >= len(by_name[r.name]):
            raise ProofFailed(f"region {r.name!r} is missing from the packed atlas")
        n = by_name[r.name][k]
        if _other_fields(r.entries) != _other_fields(n.entries):
            raise ProofFailed(f"region {r.name!r}: its fields besides its place changed")
        pa, pb = before.pages[r.page], after.pages[n.page]
        if _page_fields(pa) != _page_fields(pb):
            raise ProofFailed(f"region {r.name!r}: its new page's fields differ from its page's")
        ga, gb = r.geometry(), n.geometry()
        region_uses = uses.get(r.name)
        meshes_only = not rectangle_reason(r, first, region_uses, pinned)
        frames = [{_uv_frame(g, m.honours_offsets) for m in region_uses.meshes} if meshes_only
                  else (g.original_width, g.original_height, g.width, g.height, content_box(g)) for g in (ga, gb)]
        if frames[0] != frames[1]:
            raise ProofFailed(f"region {r.name!r}: its UVs would map onto another part of its image")
        for (x0, y0), mask in _reads(r, ga, region_uses, meshes_only):
            jj, ii = np.nonzero(mask)
            ii, jj = ii + x0, jj + y0
            old = _texels(before_pages[r.page], page_repeat(pa), *page_texel(ga, ii, jj))
            new = _texels(after_pages[n.page], page_repeat(pb), *page_texel(gb, ii, jj))
            differ = np.count_nonzero(old != new)
            if differ:
                raise ProofFailed(f"region {r.name!r}: {differ:,} of the {old.size:,} texels drawing it reads "
                                  f"would differ")
            compared += old.size
    return compared
