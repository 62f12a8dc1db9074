"""Step 3 of the pipeline (paper sec. 3.3): interior boundaries and their vertices.

Visually distinct parts of a sprite (a sleeve and a hand, an eye and a face) are separated by
colour edges. Vertices along those edges, and - in the default preset - triangle edges along
them, let the parts deform independently.
"""

from __future__ import annotations

from itertools import pairwise

import cv2
import numpy as np

from .geometry import dp_indices
from .params import MesherParams


def edge_map(image: np.ndarray, mask: np.ndarray, p: MesherParams) -> np.ndarray:
    """Interior edge pixels: paper sec. 3.3 steps 1 to 3 (:func:`_edge_map`), worked out around the mask only.

    On RGBA art every texel outside the mask is blacked out, so nothing can make an edge
    there: the filters run on the mask's bounding box grown by :func:`_edge_margin`, which
    gives the very same edges as the whole image at a fraction of the cost where the art
    leaves space around it (a third of the filtered pixels on the corpus).
    """
    box = _edge_box(mask, p) if image.shape[2] == 4 else None
    if box is None:
        return _edge_map(image, mask, p)
    x0, y0, x1, y1 = box
    edges = np.zeros(mask.shape, np.uint8)
    edges[y0:y1, x0:x1] = _edge_map(image[y0:y1, x0:x1], mask[y0:y1, x0:x1], p)
    return edges


#: Texels a vectorised row loop of OpenCV may take at once, at most: a box starts on a
#: multiple of it and ends at least this far past the art (or at the image's edge), so that
#: every texel near the art is worked out by the same code path as in the whole image.
SIMD_TEXELS = 64


def _edge_margin(p: MesherParams) -> int:
    """How far (px) past the mask an edge can depend on anything: the bilateral filter's
    reach (``bilateral_d / 2``), Canny's gradient and suppression (2), the closing
    (``close_kernel / 2``), with room to spare; Canny's linking never leaves the texels of
    non-zero gradient, which lie within that reach."""
    return p.bilateral_d + p.close_kernel + 4


def _edge_box(mask: np.ndarray, p: MesherParams) -> tuple[int, int, int, int] | None:
    """``(x0, y0, x1, y1)`` of the texels :func:`edge_map` works on, or None for the whole image."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return None
    h, w = mask.shape
    m = _edge_margin(p)
    x0 = max(0, int(cols[0]) - m) // SIMD_TEXELS * SIMD_TEXELS
    x1 = min(w, int(cols[-1]) + 1 + m + SIMD_TEXELS)
    y0, y1 = max(0, int(rows[0]) - m), min(h, int(rows[-1]) + 1 + m)
    return None if (x0, y0, x1, y1) == (0, 0, w, h) else (x0, y0, x1, y1)


def _edge_map(image: np.ndarray, mask: np.ndarray, p: MesherParams) -> np.ndarray:
    """Interior edge pixels: paper sec. 3.3 steps 1 to 3.

    Bilateral filter (``bilateral_d``, ``bilateral_sigma_color``, ``bilateral_sigma_space``),
    Canny (``canny_low``, ``canny_high``) on gray, R, G and B OR-ed together, masked by the mask
    eroded with an ``erode_kernel`` square ``erode_iterations`` times, then closed with a
    ``close_kernel`` square.

    Parameters
    ----------
    image : ndarray, shape (H, W, 3|4), uint8
    mask : ndarray, shape (H, W), bool

    Returns
    -------
    ndarray, shape (H, W), uint8 (0 or 255)
    """
    rgb = np.ascontiguousarray(image[:, :, :3])
    if image.shape[2] == 4:
        # transparent pixels often hold arbitrary colour; black them out so that they make
        # no edges (the mask erosion removes the silhouette edge anyway)
        rgb = np.where(mask[:, :, None], rgb, 0).astype(np.uint8)
    smooth = cv2.bilateralFilter(rgb, p.bilateral_d, p.bilateral_sigma_color, p.bilateral_sigma_space)
    gray = cv2.cvtColor(smooth, cv2.COLOR_RGB2GRAY)
    edges = cv2.Canny(gray, p.canny_low, p.canny_high)
    for ch in range(3):
        edges |= cv2.Canny(np.ascontiguousarray(smooth[:, :, ch]), p.canny_low, p.canny_high)
    k = np.ones((p.erode_kernel, p.erode_kernel), np.uint8)
    inner = cv2.erode(mask.astype(np.uint8), k, iterations=p.erode_iterations,
                      borderType=cv2.BORDER_CONSTANT, borderValue=0)
    edges &= inner * 255
    if p.close_kernel > 1:
        edges = cv2.morphologyEx(edges, cv2.MORPH_CLOSE, np.ones((p.close_kernel, p.close_kernel), np.uint8))
    return edges


def long_contours(edges: np.ndarray, min_length: float) -> list[np.ndarray]:
    """Contours of the edge map at least ``min_length`` px long (paper sec. 3.3 step 4).

    Returns
    -------
    list of ndarray, shape (n, 2), float64
        Pixel-centre coordinates ``(x + 0.5, y + 0.5)`` along each contour, in order.
        A one-pixel-wide edge traced by ``findContours`` goes out and back; we keep the
        first half of such a contour so that each edge is one open chain.
    """
    contours, _ = cv2.findContours(edges, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    out = []
    for c in contours:
        c = c.reshape(-1, 2)
        length = cv2.arcLength(c.reshape(-1, 1, 2), False)
        if length < min_length:
            continue
        out.append(_open_chain(c).astype(np.float64) + 0.5)
    return out


def _open_chain(c: np.ndarray) -> np.ndarray:
    """Cut a traced thin edge (which returns along itself) to its first pass."""
    n = len(c)
    if n < 4:
        return c
    # the trace of a 1-px curve visits each pixel twice; stop at the first revisit of the start
    # region, i.e. where the trace turns back onto pixels already seen
    seen = {}
    for i, (x, y) in enumerate(map(tuple, c)):
        if (x, y) in seen:
            return c[:i]
        seen[(x, y)] = i
    return c


def simplify_chain(c: np.ndarray, dp_ratio: float, max_segment: float) -> np.ndarray:
    """Douglas-Peucker with ``eps = dp_ratio * arc length``, then split long segments along the path.

    Paper sec. 3.3 step 4: ``dp_ratio = 0.012``, ``max_segment = 40``.

    Returns
    -------
    ndarray, shape (k, 2): vertices along the chain, in order.
    """
    # The chain's points lie a pixel or more apart, so a segment split finer than a pixel picks
    # the same points again: --density 1e9 asked billions of them (minutes and gigabytes).
    max_segment = max(max_segment, 1.0)
    length = float(np.hypot(*np.diff(c, axis=0).T).sum())
    idx = dp_indices(c, dp_ratio * length, closed=False)
    pts = []
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(c, axis=0).T))])
    for a, b in pairwise(idx):
        pts.append(c[a])
        arc = cum[b] - cum[a]
        if arc > max_segment:
            n = int(np.ceil(arc / max_segment))
            for s in np.linspace(cum[a], cum[b], n + 1)[1:-1]:
                j = int(np.searchsorted(cum, s))
                pts.append(c[min(j, len(c) - 1)])
    pts.append(c[idx[-1]])
    return np.asarray(pts, dtype=np.float64)


def interior_chains(image: np.ndarray, mask: np.ndarray, p: MesherParams, scale: float = 1.0,
                    taken: np.ndarray | None = None) -> list[np.ndarray]:
    """Interior vertices along colour boundaries, as chains (paper sec. 3.3 steps 4 and 5).

    Parameters
    ----------
    image, mask : as in :func:`edge_map`
    p : MesherParams
        Lengths are divided by ``scale`` (``density`` for the default preset).
    taken : ndarray, shape (k, 2), optional
        Vertices already placed (the hull); new vertices keep ``dedup_radius`` away from them.

    Returns
    -------
    list of ndarray, shape (n, 2)
        Runs of consecutive vertices; consecutive vertices of a run are joined by an edge in
        the default preset. Vertices are at least ``border_distance`` px from the mask border
        and ``dedup_radius / scale`` px from each other.
    """
    edges = edge_map(image, mask, p)
    dist = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, 5)[1:-1, 1:-1]
    radius = p.dedup_radius / scale
    accepted = [np.asarray(taken, dtype=np.float64).reshape(-1, 2)] if taken is not None else []
    acc = np.concatenate(accepted) if accepted else np.zeros((0, 2))
    chains = []
    contours = long_contours(edges, p.min_contour_length / scale)
    # longest first, so that the most significant boundaries win the deduplication
    contours.sort(key=lambda c: (-len(c), c[0, 0], c[0, 1]))
    h, w = mask.shape
    for c in contours:
        pts = simplify_chain(c, p.interior_dp_ratio, p.max_segment / scale)
        run = []
        for q in pts:
            xi, yi = min(int(q[0]), w - 1), min(int(q[1]), h - 1)
            ok = dist[yi, xi] >= p.border_distance
            near_own = False
            if ok and len(acc):
                d = np.hypot(*(acc - q).T)
                ok = float(d.min()) >= radius
                # too close only to the previous vertex of this run: skip it, keep the run going
                near_own = (not ok and bool(run) and np.array_equal(acc[int(np.argmin(d))], run[-1])
                            and float(np.sort(d)[1] if len(d) > 1 else np.inf) >= radius)
            if ok:
                run.append(q)
                acc = np.vstack([acc, q[None]])
            elif near_own:
                continue
            elif run:
                chains.append(np.asarray(run))
                run = []
        if run:
            chains.append(np.asarray(run))
    return chains
