"""Step 2 of the pipeline (paper sec. 3.2): the outer loop, and the holes.

Two algorithms:

:func:`paper_loops`
    The paper's: smooth the mask (Gaussian, sigma 1), ``findContours``, keep components of at
    least 100 px^2, Douglas-Peucker with ``eps = 0.003 P``, adaptive arc subdivision with
    ``n_target = 50`` exterior vertices split between components by perimeter. Vertices lie
    *on* the contour, so the mesh cuts through the edge pixels: it clips anti-aliased art.

:func:`covering_hull`
    The default: a single simple loop that contains every art pixel square. The contour is
    simplified with Douglas-Peucker, then each simplified edge is pushed outward, parallel to
    itself, until the pixel squares it replaced are on its inner side; vertices are the
    intersections of consecutive pushed edges. An exact rasterised check follows, and any pixel
    still outside pulls the nearest edge out through its far corner. If all else fails the
    convex hull of the pixel squares is used, which always covers.

Islands (several separate pieces of art in one image): Spine's editor expects one hull loop,
so we join the pieces into one: the pieces are linked by a minimum spanning tree of shortest
bridges (3 px wide strips drawn into the coverage mask) and the hull wraps the result. The
bridge area is small compared with a convex hull around all pieces, and one loop keeps every
piece deformable by the same bones. Tiny specks are covered too: never clipping wins.

Holes (transparent regions enclosed by art, e.g. a ring): the hull stays one loop; each hole
of at least ``min_hole_area`` px^2 becomes a second loop of constrained edges, *inscribed* in
the hole (shrunk by about one tolerance so it never touches an art pixel), and the triangles
inside it are removed. Smaller holes are meshed over (their waste is small and a hole costs
vertices).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from itertools import pairwise

import cv2
import numpy as np

from .geometry import clamp, clip_loop_to_rect, dp_indices, loop_is_simple, predecessors, signed_area, successors
from .raster import (any_centre_inside, any_crossed, centres_inside, crossed_pixels, loop_segments, pair_keys,
                     touched_pixels)


# --------------------------------------------------------------------------- paper
def paper_loops(mask: np.ndarray, blur_sigma: float = 1.0, min_area: float = 100.0,
                dp_ratio: float = 0.003, n_target: int = 50) -> list[np.ndarray]:
    """Exterior vertices of each component, as in the paper (sec. 3.2).

    Parameters
    ----------
    mask : ndarray, shape (H, W), bool
    blur_sigma : float
        Gaussian smoothing of the mask before contouring (1 px).
    min_area : float
        Components with a contour area below this (px^2) are skipped (100).
    dp_ratio : float
        DP tolerance as a share of each contour's perimeter (0.003).
    n_target : int
        Exterior vertices to aim for over all components together (50): the longest arc between
        vertices is ``sum(P) / n_target``, so each component gets a share proportional to its
        perimeter.

    Returns
    -------
    list of ndarray, shape (n, 2)
        One loop per component, pixel-centre coordinates, largest component first.
    """
    m = mask.astype(np.float32)
    if blur_sigma > 0:
        m = cv2.GaussianBlur(m, (0, 0), blur_sigma)
    m = (m >= 0.5).astype(np.uint8)
    contours, _ = cv2.findContours(np.pad(m, 1), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    contours = [c.reshape(-1, 2).astype(np.float64) - 1 + 0.5 for c in contours]
    if not contours:
        return []
    contours.sort(key=lambda c: (-abs(signed_area(c)), c[0, 0], c[0, 1]))
    # a sprite smaller than min_area would vanish entirely; keep its largest piece instead
    contours = [c for i, c in enumerate(contours) if i == 0 or abs(signed_area(c)) >= min_area]
    if len(contours[0]) < 3:
        return []
    perims = [_perimeter(c) for c in contours]
    l_max = sum(perims) / max(n_target, 1)
    return [_arc_subdivide(c, dp_indices(c, dp_ratio * P), l_max) for c, P in zip(contours, perims)]


def _perimeter(c: np.ndarray) -> float:
    return float(np.hypot(*(successors(c) - c).T).sum())


def _arc_subdivide(c: np.ndarray, keys: np.ndarray, l_max: float) -> np.ndarray:
    """Adaptive arc subdivision (sec. 3.2 step 3).

    Keypoints are always kept. A stretch between two keypoints is subdivided along the contour
    path every ``l_max`` when it is part of a curve, i.e. when the polygon angle at both of its
    keypoints is obtuse (> 90 degrees); a stretch ending at a sharp (acute) corner stays one
    straight edge, which keeps the corner crisp.
    """
    n = len(c)
    k = len(keys)
    if k < 3:
        return c[keys]
    seg_len = np.hypot(*(successors(c) - c).T)
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    kp = c[keys]
    prev, nxt = predecessors(kp), successors(kp)
    u, w = prev - kp, nxt - kp
    cosang = (u * w).sum(1) / np.maximum(np.hypot(*u.T) * np.hypot(*w.T), 1e-12)
    obtuse = cosang < 0
    out = []
    for j in range(k):
        a, b = keys[j], keys[(j + 1) % k]
        out.append(c[a])
        if not (obtuse[j] and obtuse[(j + 1) % k]):
            continue
        s0, s1 = cum[a], cum[b] if b > a else cum[b] + cum[n]
        m = int(np.ceil((s1 - s0) / l_max)) if l_max > 0 else 1
        for s in np.linspace(s0, s1, m + 1)[1:-1]:
            i = int(np.searchsorted(cum, s % cum[n])) % n
            out.append(c[i])
    pts = np.asarray(out)
    _, first = np.unique(np.round(pts, 6), axis=0, return_index=True)
    return pts[np.sort(first)]


# --------------------------------------------------------------------------- default
def pieces(mask: np.ndarray) -> tuple[int, np.ndarray]:
    """The 8-connected pieces of ``mask`` (H, W) bool: ``(n, labels)``, ``n`` counting the
    background as one label and ``labels`` (H, W) int32, as ``cv2.connectedComponents``
    gives them."""
    return cv2.connectedComponents(np.asarray(mask, dtype=np.uint8), connectivity=8)


def bridge_islands(mask: np.ndarray, width: int = 3, labels: tuple[int, np.ndarray] | None = None) -> np.ndarray:
    """Join all 8-connected pieces of ``mask`` with the shortest bridges (a spanning tree).

    ``labels``: :func:`pieces` of ``mask`` when the caller has them already. Returns a mask
    with the bridges drawn in (a superset of ``mask``, one piece).
    """
    n, labels = pieces(mask) if labels is None else labels
    if n <= 2:
        return mask
    out = mask.astype(np.uint8).copy()
    # boundary points of each piece, thinned to at most ~200 per piece
    # RETR_LIST: pieces lying inside another piece's hole have no external contour of their own
    contours, _ = cv2.findContours(out, cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)
    by_label: dict[int, list] = {}
    for c in contours:
        c = c.reshape(-1, 2)
        lab = int(labels[c[0, 1], c[0, 0]])
        by_label.setdefault(lab, []).append(c)
    labs = sorted(by_label)
    pts, owner = [], []
    for i, lab in enumerate(labs):
        p = np.concatenate(by_label[lab])
        step = max(1, len(p) // 200)
        pts.append(p[::step].astype(np.float64))
        owner.append(np.full(len(pts[-1]), i))
    for p, q in _bridges(pts, np.concatenate(owner)):
        cv2.line(out, (int(p[0]), int(p[1])), (int(q[0]), int(q[1])), 1, width)
    return out.astype(bool)


def _bridges(pts: list[np.ndarray], owner: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The shortest bridges that join all pieces: a minimum spanning tree over pieces.

    Parameters
    ----------
    pts : list of ndarray, shape (n_i, 2)
        Boundary points of each piece.
    owner : ndarray, shape (sum n_i,)
        The piece of each point, in the order of ``pts`` concatenated.

    Returns
    -------
    list of (p, q): one bridge per tree edge, its end points on two pieces.

    The closest pair of points between two groups is a Delaunay edge (the circle on it as a
    diameter holds no other point: that point would be closer to one end), so the tree over
    pieces only needs the Delaunay edges of all points, not every pair (scipy's csgraph
    finds the tree).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import minimum_spanning_tree

    allp = np.concatenate(pts)
    k = len(pts)
    a, b = _delaunay_edges(allp)
    cross = owner[a] != owner[b]
    a, b = a[cross], b[cross]
    d = np.hypot(*(allp[a] - allp[b]).T)
    # per pair of pieces, the shortest link (ties: the lowest point indices)
    pa, pb = np.minimum(owner[a], owner[b]), np.maximum(owner[a], owner[b])
    order = np.lexsort((b, a, d, pb, pa))
    pair = pa[order] * k + pb[order]
    first = order[np.r_[True, pair[1:] != pair[:-1]]]
    graph = coo_matrix((d[first], (pa[first], pb[first])), shape=(k, k)).tocsr()
    tree = minimum_spanning_tree(graph).tocoo()
    link = {(int(i), int(j)): (allp[a[e]], allp[b[e]]) for e, i, j in zip(first, pa[first], pb[first])}
    return [link[(int(i), int(j))] for i, j in sorted(zip(tree.row.tolist(), tree.col.tolist()))]


def _delaunay_edges(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (a, b) of the Delaunay edges of ``points``; every pair when there are too few."""
    from scipy.spatial import Delaunay, QhullError

    n = len(points)
    try:
        if n < 4:
            raise QhullError("too few points")
        tri = Delaunay(points).simplices
        e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    except QhullError:  # all points on one line, or too few: every pair (they are few then)
        i, j = np.triu_indices(n, 1)
        e = np.stack([i, j], axis=1)
    e = np.sort(e, axis=1).astype(np.int64)
    keys = np.unique(pair_keys(e))  # the rows of np.unique(e, axis=0), in its order
    m = int(e[:, 1].max()) + 1 if len(e) else 1
    return keys // m, keys % m


def outer_contour(mask: np.ndarray) -> np.ndarray:
    """The outer contour of the largest piece, as pixel indices (n, 2) ``(col, row)``, int."""
    contours, _ = cv2.findContours(np.pad(mask.astype(np.uint8), 1), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    c = max(contours, key=lambda c: (cv2.contourArea(c), len(c)))
    return c.reshape(-1, 2) - 1


def _push_out(contour: np.ndarray, keys: np.ndarray, orient: float) -> np.ndarray:
    """Move each simplified edge outward until the pixel squares of its stretch are inside.

    Parameters
    ----------
    contour : ndarray, shape (n, 2)
        Pixel indices along the loop.
    keys : ndarray, shape (k,)
        Indices of the simplified polygon's vertices on the contour.
    orient : float
        Sign of the contour's signed area (decides which side is outward).

    Returns
    -------
    ndarray, shape (m, 2): the pushed polygon (bevels may add vertices).
    """
    k = len(keys)
    centre = contour.astype(np.float64) + 0.5
    kp = centre[keys]
    # every edge's direction, length and outward normal at once: the same element-wise
    # operations as one edge at a time; for a positive (clockwise on screen) loop the normal
    # is (dy, -dx)
    d = successors(kp) - kp
    length = np.hypot(d[:, 0], d[:, 1])
    normals = np.stack([d[:, 1], -d[:, 0]], axis=1) / length[:, None] * orient
    reach = 0.5 * (np.abs(normals[:, 0]) + np.abs(normals[:, 1]))
    offsets = np.zeros(k)
    starts, ends = keys.tolist(), successors(keys).tolist()
    for j in range(k):
        a, b = starts[j], ends[j]
        pts = centre[a:b + 1] if b > a else np.concatenate([centre[a:], centre[:b + 1]])
        # farthest corner of each pixel square along the normal: centre + 0.5 (|nx| + |ny|);
        # the product as before (one matrix-vector product per edge: batching them would
        # round differently), the reach added to its largest value only (rounding is monotone)
        offsets[j] = max(0.0, float(((pts - kp[j]) @ normals[j]).max() + reach[j])) + 1e-6
    # each edge's line n . p = c, as before from the vector products
    lines = [float(normals[j] @ kp[j] + offsets[j]) for j in range(k)]
    nx, ny = normals[:, 0].tolist(), normals[:, 1].tolist()
    out = []
    for j in range(k):
        i = j - 1
        n1, c1 = normals[i], lines[i]
        n2, c2 = normals[j], lines[j]
        det = nx[i] * ny[j] - ny[i] * nx[j]
        corner = kp[j]
        if abs(det) > 0.15:
            x = np.array([(c1 * ny[j] - c2 * ny[i]) / det, (nx[i] * c2 - nx[j] * c1) / det])
            limit = 2.0 * max(offsets[i], offsets[j]) + 2.0
            if np.hypot(*(x - corner)) <= limit:
                out.append(x)
                continue
        # nearly parallel edges or a sharp spike: a short bevel instead of a far miter, between
        # the corner pushed onto each line (made only here: most corners take the miter)
        p1 = corner + (c1 - n1 @ corner) * n1
        p2 = corner + (c2 - n2 @ corner) * n2
        if np.hypot(*(p1 - p2)) < 1e-6:
            out.append(p1)
        else:
            out.extend([p1, p2])
    return np.asarray(out)


def _uncovered(loop: np.ndarray, cover: np.ndarray) -> np.ndarray:
    """Pixels of ``cover`` (row, col) whose square is not entirely inside ``loop``."""
    segs = loop_segments([loop])
    inside = centres_inside(segs, cover.shape) & ~crossed_pixels(segs, cover.shape)
    return np.argwhere(cover & ~inside)


def _repair(loop: np.ndarray, cover: np.ndarray, max_rounds: int = 30) -> np.ndarray | None:
    """Pull edges out through the far corner of any art pixel they still leave outside."""
    orient = np.sign(signed_area(loop)) or 1.0
    for _ in range(max_rounds):
        bad = _uncovered(loop, cover)
        if len(bad) == 0:
            return loop
        corners = np.concatenate([bad[:, ::-1] + off for off in ([0, 0], [1, 0], [0, 1], [1, 1])]).astype(np.float64)
        a = loop
        b = successors(loop)
        ab = b - a
        L = np.maximum(np.hypot(*ab.T), 1e-12)
        nrm = np.stack([ab[:, 1], -ab[:, 0]], axis=1) / L[:, None] * orient
        # distance of each corner to each edge, and how far outside each edge's line it is
        t = np.clip(((corners[:, None, :] - a[None]) * ab[None]).sum(-1) / (L ** 2)[None], 0, 1)
        q = a[None] + t[..., None] * ab[None]
        dist = np.hypot(*(corners[:, None, :] - q).transpose(2, 0, 1))
        out_dist = ((corners[:, None, :] - a[None]) * nrm[None]).sum(-1)
        edge = np.argmin(dist, axis=1)
        new = dict()
        for ci, e in enumerate(edge):
            od = out_dist[ci, e]
            if od > 0 and (e not in new or od > new[e][0]):
                new[e] = (od, corners[ci])
        if not new:
            return None
        pts = []
        for j in range(len(loop)):
            pts.append(loop[j])
            if j in new:
                pts.append(new[j][1])  # exactly the corner: the open-square rule lets it touch
        loop = np.asarray(pts)
    return loop if len(_uncovered(loop, cover)) == 0 else None


def convex_cover(cover: np.ndarray, orient: float = 1.0) -> np.ndarray:
    """Convex hull of all art pixel squares: always a valid covering loop."""
    rc = np.argwhere(cover)
    pts = np.concatenate([rc[:, ::-1] + off for off in ([0, 0], [1, 0], [0, 1], [1, 1])]).astype(np.float32)
    hull = cv2.convexHull(pts).reshape(-1, 2).astype(np.float64)
    return hull if np.sign(signed_area(hull)) == orient else hull[::-1]


#: Widest closing (px) tried before a covering loop falls back to the convex hull.
MAX_CLOSE_KERNEL = 129


#: Narrowest closing (px) made row by row on packed bits (:func:`_closing_by_rows`); OpenCV's
#: morphology, whose cost grows with the kernel's area, is as fast below it.
ROW_CLOSING_KERNEL = 17


def _closed(region: np.ndarray, kernel: int) -> np.ndarray:
    """``region`` with gaps narrower than ``kernel`` px closed (morphological closing, elliptic).

    The closing of ``region`` on an unbounded empty plane (OpenCV's closing of the region padded
    by ``kernel`` px), cut back to the image; wide kernels by :func:`_closing_by_rows`, the same
    pixels.
    """
    if kernel <= 1:
        return region
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kernel, kernel))
    if kernel >= ROW_CLOSING_KERNEL:
        return region | _closing_by_rows(region, _kernel_rows(k))
    closed = cv2.morphologyEx(np.pad(region, kernel).astype(np.uint8), cv2.MORPH_CLOSE, k)[kernel:-kernel, kernel:-kernel]
    return region | closed.astype(bool)


def _kernel_rows(kernel: np.ndarray) -> list[tuple[int, int, int]]:
    """The rows of a structuring element (k, k) whose set cells are one run: ``(dy, lo, hi)``,
    offsets from its centre (OpenCV's anchor, ``k // 2``): row ``dy`` spans columns ``lo..hi``."""
    a = kernel.shape[0] // 2
    rows = []
    for i, row in enumerate(kernel):
        on = np.flatnonzero(row)
        if len(on):
            if on[-1] - on[0] + 1 != len(on):
                raise ValueError("a row of the kernel is not one run")
            rows.append((i - a, int(on[0]) - a, int(on[-1]) - a))
    return rows


def _closing_by_rows(region: np.ndarray, rows: list[tuple[int, int, int]]) -> np.ndarray:
    """The closing (dilation, then erosion) of ``region`` (H, W) bool by a kernel given as its
    :func:`_kernel_rows`, on an unbounded empty plane, cut back to ``region``'s shape.

    OpenCV takes a non-rectangular kernel cell by cell (a 129 px ellipse has 13,000 of them);
    here each row of the kernel is one run: a pixel's dilation is the "any" of its kernel
    rows, each the "any" of a run of pixels in the row at that offset. Rows are packed 64
    pixels to a word, runs come from a table of runs of 1, 2, 4, ... pixels (any run is two
    overlapping ones), and the erosion is the complement of the dilation of the complement
    (OpenCV uses the same offsets for both). The padding (the kernel's reach above and below,
    twice that on the left and right, where the runs of the table start) holds everything
    either step reaches from the image.
    """
    reach = max(max(abs(dy), -lo, hi) for dy, lo, hi in rows)
    h, w = region.shape
    words = -(-(w + 4 * reach) // 64)
    pad = np.zeros((h + 2 * reach, 64 * words), np.uint8)
    pad[reach:reach + h, 2 * reach:2 * reach + w] = region
    bits = np.packbits(pad, axis=1, bitorder="little").view("<u8")
    eroded = ~_dilate_bits(~_dilate_bits(bits, rows), rows)
    out = np.unpackbits(eroded.view(np.uint8), axis=1, bitorder="little")
    return out[reach:reach + h, 2 * reach:2 * reach + w].astype(bool)


def _dilate_bits(bits: np.ndarray, rows: list[tuple[int, int, int]]) -> np.ndarray:
    """Dilation of packed rows ``bits`` (H, n) little-endian uint64, 64 pixels to a word (bit
    ``b`` of word ``j`` is pixel ``64 j + b``), by a kernel of :func:`_kernel_rows`:
    ``out[y, x]`` is the "any" of ``bits[y + dy, x + lo .. x + hi]`` over its rows. Nothing is
    read beyond the edges (pixels there count as empty)."""
    runs = {1: bits}  # runs[p][y, x]: any of bits[y, x .. x + p - 1]
    longest = max(hi - lo + 1 for _, lo, hi in rows)
    p = 1
    while 2 * p <= longest:
        runs[2 * p] = runs[p] | _shift_bits(runs[p], p)
        p *= 2
    spans = {}
    for _, lo, hi in rows:
        if (lo, hi) not in spans:
            p = 1 << ((hi - lo + 1).bit_length() - 1)
            spans[(lo, hi)] = _shift_bits(runs[p], lo) | _shift_bits(runs[p], hi - p + 1)
    h = bits.shape[0]
    out = np.zeros_like(bits)
    for dy, lo, hi in rows:
        span = spans[(lo, hi)]
        if dy >= 0:
            out[:h - dy] |= span[dy:]
        else:
            out[-dy:] |= span[:h + dy]
    return out


def _shift_bits(bits: np.ndarray, s: int) -> np.ndarray:
    """Packed rows (see :func:`_dilate_bits`) whose pixel ``x`` is pixel ``x + s`` of ``bits``
    (empty beyond the edges)."""
    if s == 0:
        return bits
    n = bits.shape[1]
    q, r = divmod(abs(s), 64)
    out = np.zeros_like(bits)
    if q >= n:
        return out
    if s > 0:
        src = bits[:, q:]
        if r == 0:
            out[:, :n - q] = src
        else:
            out[:, :n - q] = src >> np.uint64(r)
            out[:, :n - q - 1] |= src[:, 1:] << np.uint64(64 - r)
    else:
        src = bits[:, :n - q]
        if r == 0:
            out[:, q:] = src
        else:
            out[:, q:] = src << np.uint64(r)
            out[:, q + 1:] |= src[:, :-1] >> np.uint64(64 - r)
    return out


def _simple_covering_loop(region: np.ndarray, cover: np.ndarray, tolerances: tuple[float, ...],
                          min_distance: float) -> np.ndarray | None:
    """A simple loop around ``region``'s outer contour containing every square of ``cover``, or None.

    Douglas-Peucker at each of ``tolerances`` in turn (px) with each edge pushed out over the
    squares it replaced (:func:`_push_out`), repaired, clipped to the image and spread
    (``min_distance``); the first that gives a simple loop.
    """
    contour = outer_contour(region)
    points = contour.astype(np.float64)
    orient = 1.0
    c_orient = np.sign(signed_area(points)) or 1.0
    first = None
    splits: dict = {}  # each finer tolerance refines the coarser one's splits (dp_indices)
    for e in tolerances:
        keys = dp_indices(points, e, splits=splits)
        if len(keys) < 3:
            continue
        loop = _push_out(contour, keys, c_orient)
        if c_orient != orient:
            loop = loop[::-1]
        loop = _dedupe_loop(loop)
        if not loop_is_simple(loop):
            continue
        repaired = _repair(loop, cover)
        if repaired is None:
            continue
        loop = clip_loop_to_rect(repaired, cover.shape[1], cover.shape[0])
        if len(loop) >= 3 and loop_is_simple(loop):
            # the repair made it cover; the clip may have changed that only along its new edges
            loop = _spread(loop, cover, min_distance, covers=_clip_keeps_cover(repaired, loop, cover), simple=True)
            if _shortest_edge(loop) >= min_distance:
                return loop
            # a too-short edge that cannot be removed: try a finer tolerance, keep this as fallback
            first = loop if first is None else first
    return first


def covering_hull(cover: np.ndarray, eps: float, close_kernel: int = 5, min_distance: float = 0.0,
                  labels: tuple[int, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One simple loop containing every pixel square of ``cover``, with few vertices.

    Parameters
    ----------
    cover : ndarray, shape (H, W), bool
        Art that must be covered (all pixels with alpha >= the threshold).
    eps : float
        Douglas-Peucker tolerance (px). The loop strays at most about ``eps + 1`` px outside
        the art; larger means fewer vertices and more waste.
    close_kernel : int
        Gaps narrower than this (px) between parts are closed before contouring, so the loop
        does not squeeze into cracks it cannot follow without touching itself.
    min_distance : float
        Vertices closer than this (px) to their successor are dropped where the loop still
        covers the art without them.
    labels : (int, ndarray), optional
        :func:`pieces` of ``cover``, when the caller has them already.

    The loop is clipped to the image rectangle ``[0, W] x [0, H]``: UVs outside the image
    would sample neighbouring regions of the atlas page.

    Returns
    -------
    loop : ndarray, shape (n, 2)
        Vertices in order, positive signed area (clockwise on screen).
    region : ndarray, shape (H, W), bool
        The bridged, closed mask the loop wraps (its holes are candidate mesh holes).
    """
    bridged = bridge_islands(cover, labels=labels)
    region = _closed(bridged, close_kernel)
    tolerances = (eps, eps / 2, eps / 4, 0.5)
    loop = _simple_covering_loop(region, cover, tolerances, min_distance)
    if loop is not None:
        return loop, region
    # A loop pushed out from both sides of a slit narrower than about 2 eps crosses itself. A
    # wider closing fills such slits: tried before the convex hull (which may draw most of the
    # image for art touching the border in several places), coarsest tolerance first, so that
    # a wider closing wins over a finer tolerance (fewer vertices).
    kernels = [k for k in (9, 17, 33, 65, MAX_CLOSE_KERNEL) if close_kernel < k <= max(cover.shape) // 2]
    closings: dict[int, np.ndarray] = {}
    for e in tolerances:
        for k in kernels:
            if k not in closings:
                closings[k] = _closed(bridged, k)
            loop = _simple_covering_loop(closings[k], cover, (e,), min_distance)
            if loop is not None:
                return loop, closings[k]
    orient = 1.0
    loop = clip_loop_to_rect(convex_cover(cover, orient), cover.shape[1], cover.shape[0])
    return _spread(loop, cover, min_distance), region


def _snap_to_border(loop: np.ndarray, i: int, shape: tuple[int, int], reach: float) -> np.ndarray:
    """Move vertex ``i`` onto the image border when it is within ``reach`` of it (else no-op).

    Near the border this moves the vertex outward, so its short edge can then be stretched
    along the border.
    """
    out = loop.copy()
    x, y = out[i]
    h, w = shape
    d = [x, w - x, y, h - y]
    side = int(np.argmin(d))
    if 0 < d[side] < reach:
        out[i] = [(0, y), (w, y), (x, 0), (x, h)][side]
    return out


def _shortest_edge(loop: np.ndarray) -> float:
    return float(np.hypot(*(successors(loop) - loop).T).min())


def _clamp(loop: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``loop`` (n, 2) moved into the image ``[0, W] x [0, H]``, both columns in one call."""
    return clamp(loop, 0, (shape[1], shape[0]))


#: Most candidate loops :func:`_spread` checks for one hull (keeps huge speckled hulls fast).
MAX_SPREAD_TRIES = 1500


def _spread(loop: np.ndarray, cover: np.ndarray, min_distance: float, covers: bool = False,
            simple: bool = False) -> np.ndarray:
    """Drop a vertex of each too-short edge when the loop still covers and stays simple.

    Short edges are taken shortest first; spreading ends at the first short edge that can be
    neither removed nor moved onto the image border (further changes would only make the
    hull hug the art more tightly, which costs render fidelity at the silhouette more than
    the vertex saves).

    Each candidate changes the edges around one short edge of a loop known to cover the art
    and to be simple, so only those edges are checked: against the other edges for
    crossings, and the pixels in their bounding box for coverage. A short edge whose
    candidates all failed is not tried again until one of the four vertices around it moves.

    ``covers``: the loop is known to cover every square of ``cover`` (else it is checked
    here). A covering loop lets each candidate be checked on its changed edges alone
    (:func:`_still_covers`); one that does not (never seen) is checked as it was before
    (:func:`_covers_in_box`), which gives the same answers where the art is covered.
    ``simple``: the loop is known to be simple (else it is checked here, and one that is not
    is returned as it is).
    """
    if min_distance <= 0:
        return loop
    tries = 0
    if not simple and not loop_is_simple(loop):
        return loop
    covers = covers or len(_uncovered(loop, cover)) == 0
    still_covers = _still_covers if covers else _covers_in_box
    failed: set[tuple] = set()
    for _ in range(len(loop)):
        d = np.hypot(*(successors(loop) - loop).T)
        short = np.flatnonzero(d < min_distance)
        short = short[np.argsort(d[short], kind="stable")]  # shortest first
        if len(short) == 0 or len(loop) <= 3:
            break
        done = False
        for j in short:
            n = len(loop)
            k = (j + 1) % n
            window = loop[[(j - 1) % n, j, k, (k + 1) % n]]
            around = tuple(np.round(window, 9).ravel().tolist())
            if around in failed:
                continue
            for cand, changed in _spread_candidates(loop, j, k, d[j], cover.shape, min_distance):
                if cand is None:  # an end that is not near the border: nothing more to try
                    return loop
                if len(cand) < 3:
                    continue
                tries += 1
                if tries > MAX_SPREAD_TRIES:
                    return loop
                # both are pure tests; coverage first: it rejects about two candidates in
                # three on corpus art, the simplicity test about one in twenty
                if still_covers(window, cand, changed, cover) and loop_is_simple(cand, changed):
                    loop, done = cand, True
                    break
            if done:
                break
            failed.add(around)
        if not done:
            break
    return loop


def _spread_candidates(loop: np.ndarray, j: int, k: int, length: float, shape: tuple[int, int],
                       min_distance: float) -> Iterator[tuple[np.ndarray | None, np.ndarray | None]]:
    """Loops without the short edge ``j -> k``, each with the indices of the edges it changed.

    In order: drop either end, merge both into the midpoint, stretch the edge to
    ``min_distance`` along its own line (on the image border this only adds area, where the
    art touches the border at a single spot), drop both, snap either end onto the border.
    Edge ``i`` runs from vertex ``i`` to ``i + 1``. An end not near the border gives
    ``(None, None)`` in place of its snap: the spreading stops there. Made one at a time, as
    they are tried (the first that fits ends the search).
    """
    n = len(loop)
    for drop in (j, k):  # the edge joining the neighbours of the dropped vertex is new
        yield _without(loop, drop), np.array([(drop - 1) % (n - 1)])
    mid = _without(loop, k)
    jj = j if k > j else j - 1
    mid[jj] = 0.5 * (loop[j] + loop[k])
    yield mid, np.array([(jj - 1) % (n - 1), jj])
    u = (loop[j] - loop[k]) / max(length, 1e-12)
    grow = 0.5 * (min_distance - length) + 1e-6
    apart = loop.copy()
    apart[j] = _clamp(apart[j:j + 1] + u * grow, shape)[0]
    apart[k] = _clamp(apart[k:k + 1] - u * grow, shape)[0]
    yield apart, np.array([(j - 1) % n, j, k])
    both = _without(_without(loop, max(j, k)), min(j, k))
    first = min(j, k) if k > j else k  # both removed: the neighbours' new edge starts before them
    yield both, np.array([(first - 1) % max(n - 2, 1)])
    for i in (j, k):
        snapped = _snap_to_border(loop, i, shape, min_distance)
        yield (snapped, np.array([(i - 1) % n, i])) if not np.array_equal(snapped, loop) else (None, None)


def _without(loop: np.ndarray, i: int) -> np.ndarray:
    """``np.delete(loop, i, axis=0)`` for one row ``0 <= i < len(loop)`` of a loop (n, 2), without its Python layers."""
    return np.concatenate([loop[:i], loop[i + 1:]])


def _change_box(window: np.ndarray, new: np.ndarray, changed: np.ndarray,
                shape: tuple[int, int]) -> tuple[int, int, int, int] | None:
    """Pixels ``(x0, y0, x1, y1)`` around the old and new vertices of the changed edges (one
    pixel more on each side), within the image; None when empty."""
    return _pixel_box(window.tolist() + _changed_ends(new, changed), shape)


def _changed_ends(new: np.ndarray, changed: np.ndarray) -> list:
    """The start and the end points of the edges ``changed`` of the loop ``new``, as lists
    ``[x, y]``: starts in order, then ends."""
    n = len(new)
    ends = changed.tolist()
    return new[[i % n for i in ends] + [(i + 1) % n for i in ends]].tolist()


def _pixel_box(points, shape: tuple[int, int]) -> tuple[int, int, int, int] | None:
    """Pixels ``(x0, y0, x1, y1)`` around ``points`` ((k, 2) array, or a list of ``[x, y]``),
    one pixel more on each side, within an image of ``shape``; None when empty.

    A short list (the mesher's local checks, thousands per image) is bounded in plain
    Python: the same floors and ceilings of the same values.
    """
    h, w = shape
    if isinstance(points, list):
        xs, ys = [p[0] for p in points], [p[1] for p in points]
        if all(map(math.isfinite, xs + ys)):
            x0, y0 = math.floor(min(xs)) - 1, math.floor(min(ys)) - 1
            x1, y1 = math.ceil(max(xs)) + 1, math.ceil(max(ys)) + 1
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            return None if x1 <= x0 or y1 <= y0 else (x0, y0, x1, y1)
        points = np.asarray(points, np.float64).reshape(-1, 2)
    x0, y0 = np.floor(points.min(0)).astype(int) - 1
    x1, y1 = np.ceil(points.max(0)).astype(int) + 1
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    return None if x1 <= x0 or y1 <= y0 else (x0, y0, x1, y1)


def _still_covers(window: np.ndarray, new: np.ndarray, changed: np.ndarray, cover: np.ndarray) -> bool:
    """Whether ``new`` covers ``cover``, given that the old loop does and differs only locally.

    ``window`` holds four consecutive old vertices around every edge that changed,
    ``changed`` the indices (in order along the loop) of the new loop's edges that changed.
    The two loops enclose different regions only inside the bounding box of those edges
    (:func:`_change_box`), and only by the polygon between the old path and the new one:
    a pixel centre's even-odd count against ``new`` is its count against the old loop plus
    its counts against the two paths, each segment toggling the same centres wherever it
    is counted. Every art centre counts odd against the old loop and no old edge crosses an
    art square, so ``new`` covers the art exactly when no art centre counts odd against the
    two paths and no new edge crosses an art square: the answer of
    :func:`_covers_in_box` from a handful of segments instead of every one across the box.
    The few points are handled as Python lists (the same values).
    """
    old = window.tolist()
    ends = _changed_ends(new, changed)
    box = _pixel_box(old + ends, cover.shape)  # _change_box
    if box is None:
        return True
    path = ends[:len(changed)] + ends[-1:]  # starts and ends on unchanged vertices
    first = [i for i, p in enumerate(old) if p == path[0]]
    last = [i for i, p in enumerate(old) if p == path[-1]]
    if len(first) != 1 or len(last) != 1 or first[0] >= last[0]:
        return _covers_in_box(window, new, changed, cover)
    old = old[first[0]:last[0] + 1]
    return _swap_keeps_cover(list(pairwise(old)), list(pairwise(path)), cover, box)


def _swap_keeps_cover(removed, added, cover: np.ndarray, box: tuple[int, int, int, int]) -> bool:
    """Whether a loop covering every square of ``cover`` still does once its segments
    ``removed`` are replaced by ``added`` ((k, 2, 2) arrays, or lists of ``(start, end)``
    points), all of them inside ``box`` ``(x0, y0, x1, y1)`` with a pixel to spare (the art
    elsewhere keeps its counts).

    A centre's even-odd count changes by its counts against both sets (each segment
    toggles the same centres wherever it is counted); art centres count odd against the
    covering loop, whose segments cross no art square. See :func:`_still_covers`.
    """
    x0, y0, x1, y1 = box
    art = cover[y0:y1, x0:x1]
    if not art.any():
        return True
    # in the box's pixels: the same subtraction, float minus whole number, as on arrays
    removed, added = ([((a - x0, b - y0), (c - x0, d - y0)) for (a, b), (c, d) in
                       (s if isinstance(s, list) else s.tolist())] for s in (removed, added))
    # the crossing test first: it alone rejects most candidates that fail (all that fail, on
    # corpus art), and stops at the first art square; both are pure, so the answer is the same
    if any_crossed(added, art):
        return False
    return not any_centre_inside(removed + added, art)


def _edges_in(points: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Per edge ``i -> i + 1`` of the loop ``points`` (n, 2), whether the loop ``other`` has it too.

    Vertices are looked up as complex numbers in ``other`` sorted; a vertex ``other`` holds
    twice may make an edge it has look absent, never one it lacks look present.
    """
    mine = np.ascontiguousarray(points, np.float64).view(np.complex128).ravel()
    theirs = np.ascontiguousarray(other, np.float64).view(np.complex128).ravel()
    order = np.argsort(theirs, kind="stable")
    at = np.minimum(np.searchsorted(theirs[order], mine), len(theirs) - 1)
    found = theirs[order][at] == mine
    where = np.where(found, order[at], -1)
    return found & successors(found) & (successors(where) == (where + 1) % len(theirs))


def _clip_keeps_cover(loop: np.ndarray, clipped: np.ndarray, cover: np.ndarray) -> bool:
    """Whether ``clipped`` (:func:`clip_loop_to_rect` of ``loop``, which covers ``cover``) covers it too.

    Checked on the edges the clip took away and those it made (:func:`_swap_keeps_cover`):
    the clip keeps the others as they were.
    """
    def segments(points: np.ndarray, kept: np.ndarray) -> np.ndarray:
        return np.stack([points, successors(points)], axis=1)[~kept]

    removed = segments(loop, _edges_in(loop, clipped))
    added = segments(clipped, _edges_in(clipped, loop))
    ends = np.concatenate([removed, added]).reshape(-1, 2)
    box = _pixel_box(ends, cover.shape) if len(ends) else None
    return box is None or _swap_keeps_cover(removed, added, cover, box)


def _covers_in_box(window: np.ndarray, new: np.ndarray, changed: np.ndarray, cover: np.ndarray) -> bool:
    """:func:`_still_covers` from every segment of ``new`` across the change's box.

    The rasterising of :func:`_uncovered` restricted to :func:`_change_box`: the answer
    wherever the old loop covers the art, and the only one where it does not.
    """
    box = _change_box(window, new, changed, cover.shape)
    if box is None:
        return True
    x0, y0, x1, y1 = box
    art = cover[y0:y1, x0:x1]
    if not art.any():
        return True
    start = new - [x0, y0]
    end = np.concatenate([start[1:], start[:1]])
    h, w = y1 - y0, x1 - x0
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    # rows: only segments spanning the box's rows toggle its centres (those left of it too,
    # none lying right of it); crossings: only segments meeting the box
    rows = (hi[:, 1] >= 0) & (lo[:, 1] <= h) & (lo[:, 0] < w)
    meets = rows & (hi[:, 0] >= 0)
    segs = np.stack([start, end], axis=1)
    # a square lies inside when its centre does and no segment crosses it; an art pixel whose
    # centre lies outside answers already (the cheaper half, and most rejections)
    if (art & ~centres_inside(segs[rows], (h, w))).any():
        return False
    return not (art & crossed_pixels(segs[meets], (h, w))).any()


def _dedupe_loop(loop: np.ndarray, tol: float = 1e-3) -> np.ndarray:
    # near-duplicates come from pushing two almost parallel edges; the repair step that
    # follows wins back any sliver this costs
    d = np.hypot(*(successors(loop) - loop).T)
    return loop[d > tol]


def hole_loops(region: np.ndarray, cover: np.ndarray, min_area: float, eps: float) -> list[np.ndarray]:
    """Loops inscribed in the transparent holes of ``region`` that are big enough to cut out.

    Each hole is eroded by ``ceil(eps) + 1`` px and its contour simplified with tolerance
    ``<= eps``, so the loop stays at least about half a pixel off every art pixel; a loop that
    would still touch art (checked exactly) is dropped and the hole is meshed over.

    Returns
    -------
    list of ndarray, shape (n, 2): loops with negative signed area (holes run the other way).
    """
    m = region.astype(np.uint8)
    contours, hier = cv2.findContours(np.pad(m, 1), cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hier is None:
        return []
    out = []
    h, w = region.shape
    for c, hh in zip(contours, hier[0]):
        if hh[3] < 0:  # outer contours have no parent; holes do
            continue
        c = c.reshape(-1, 2) - 1
        if abs(cv2.contourArea(c.reshape(-1, 1, 2).astype(np.float32))) < min_area:
            continue
        x0, y0 = np.maximum(c.min(0) - 2, 0)
        x1, y1 = np.minimum(c.max(0) + 3, [w, h])
        sub = region[y0:y1, x0:x1]
        fill = np.zeros(sub.shape, np.uint8)
        cv2.drawContours(fill, [(c - [x0, y0]).reshape(-1, 1, 2).astype(np.int32)], -1, 1, -1)
        hole = (fill > 0) & ~sub
        # half the hull tolerance: a hole's band of waste is paid on both sides of its loop
        e = max(0.9, min(0.5 * eps, 0.1 * np.sqrt(hole.sum())))
        k = int(np.ceil(e)) + 1
        inner = cv2.erode(hole.astype(np.uint8), np.ones((3, 3), np.uint8), iterations=k)
        if inner.sum() < 9:
            continue
        cc, _ = cv2.findContours(inner, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        cc = max(cc, key=cv2.contourArea).reshape(-1, 2).astype(np.float64) + 0.5
        loop = cc[dp_indices(cc, min(e, k - 0.6))] + [x0, y0]
        if len(loop) < 3 or not loop_is_simple(loop):
            continue
        if signed_area(loop) > 0:
            loop = loop[::-1]
        segs = loop_segments([loop])
        touch = centres_inside(segs, cover.shape) | touched_pixels(segs, cover.shape)
        if (touch & cover).any():
            continue
        out.append(loop)
    return out
