"""Small polygon helpers on numpy arrays (pixel coordinates, x right, y down)."""

from __future__ import annotations

import numpy as np


def signed_area(loop: np.ndarray) -> float:
    """Shoelace area of a closed polygon (n, 2); positive = the mesh winding (clockwise on screen)."""
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def dp_indices(points: np.ndarray, eps: float, closed: bool = True) -> np.ndarray:
    """Douglas-Peucker simplification, returning the indices of the kept points (sorted).

    Our own few lines rather than ``cv2.approxPolyDP`` because the exterior step needs to know
    which stretch of the contour each simplified edge replaces.

    Parameters
    ----------
    points : ndarray, shape (n, 2)
    eps : float
        Largest allowed distance (px) of a dropped point from its replacing segment.
    closed : bool
        Treat ``points`` as a loop (the first point is always kept, and the farthest point
        from it splits the loop in two chains).
    """
    n = len(points)
    if n <= 2:
        return np.arange(n)
    if closed:
        far = int(np.argmax(np.hypot(*(points - points[0]).T)))
        if far == 0:
            return np.array([0])
        ext = np.vstack([points, points[:1]])
        a = _dp(ext, 0, far, eps)
        b = _dp(ext, far, n, eps)
        idx = np.unique(np.concatenate([a, b])) % n
        return np.unique(idx)
    return _dp(points, 0, n - 1, eps)


def _dp(points: np.ndarray, i0: int, i1: int, eps: float) -> np.ndarray:
    keep = [i0, i1]
    stack = [(i0, i1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        seg = points[a + 1:b]
        d = _point_segment_distance(seg, points[a], points[b])
        k = int(np.argmax(d))
        if d[k] > eps:
            m = a + 1 + k
            keep.append(m)
            stack.append((a, m))
            stack.append((m, b))
    return np.array(sorted(set(keep)))


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    L2 = float(ab @ ab)
    if L2 == 0:
        return np.hypot(*(p - a).T)
    t = np.clip(((p - a) @ ab) / L2, 0, 1)
    q = a + t[:, None] * ab
    return np.hypot(*(p - q).T)


def points_in_loops(points: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """Even-odd test of points against closed loops (hull and holes together).

    Returns
    -------
    ndarray, shape (n,), bool
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    inside = np.zeros(len(pts), dtype=bool)
    for loop in loops:
        a = loop
        b = np.roll(loop, -1, axis=0)
        px, py = pts[:, 0:1], pts[:, 1:2]
        cond = (a[None, :, 1] > py) != (b[None, :, 1] > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = a[None, :, 0] + (py - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
        inside ^= (cond & (px < xc)).sum(axis=1) % 2 == 1
    return inside


def segments_cross(s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Which pairs of segments properly intersect or touch (excluding shared endpoints).

    Parameters
    ----------
    s : ndarray, shape (n, 2, 2)
    t : ndarray, shape (m, 2, 2)

    Returns
    -------
    ndarray, shape (n, m), bool
    """
    p, r = s[:, None, 0], s[:, None, 1] - s[:, None, 0]
    q, u = t[None, :, 0], t[None, :, 1] - t[None, :, 0]

    def cross(a, b):
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    denom = cross(r, u)
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        tt = cross(qp, u) / denom
        uu = cross(qp, r) / denom
    eps = 1e-9
    proper = (denom != 0) & (tt > eps) & (tt < 1 - eps) & (uu > eps) & (uu < 1 - eps)
    # T-junctions: an endpoint of one lying on the interior of the other
    touching = (denom != 0) & (((np.abs(tt) <= eps) | (np.abs(tt - 1) <= eps)) & (uu > eps) & (uu < 1 - eps)
                               | ((np.abs(uu) <= eps) | (np.abs(uu - 1) <= eps)) & (tt > eps) & (tt < 1 - eps))
    # collinear overlaps
    col = (denom == 0) & (np.abs(cross(qp, r)) < 1e-9)
    if col.any():
        rr = np.maximum((r * r).sum(-1), 1e-300)
        t0 = (qp * r).sum(-1) / rr
        t1 = t0 + (u * r).sum(-1) / rr
        lo, hi = np.minimum(t0, t1), np.maximum(t0, t1)
        col &= (hi > eps) & (lo < 1 - eps)
    return proper | touching | col


def loop_is_simple(loop: np.ndarray, edges: np.ndarray | None = None) -> bool:
    """True if no two non-adjacent edges of the closed polygon meet, and no vertex repeats.

    ``edges`` (indices of edges, edge ``i`` runs from vertex ``i`` to ``i + 1``) limits the test
    to those edges against all others: enough when only they changed in a loop known to be
    simple, and it turns an O(n^2) test into O(n).
    """
    n = len(loop)
    if n < 3:
        return False
    # "+ 0.0" turns -0.0 into 0.0: unique(axis=0) compares rows bit by bit
    if len(np.unique(np.round(loop, 9) + 0.0, axis=0)) != n:
        return False
    seg = np.stack([loop, np.roll(loop, -1, axis=0)], axis=1)
    rows = np.arange(n) if edges is None else np.unique(np.asarray(edges, dtype=np.int64) % n)
    x = segments_cross(seg[rows], seg)
    r = np.arange(len(rows))
    x[r, rows] = False
    x[r, (rows + 1) % n] = False
    x[r, (rows - 1) % n] = False
    return not x.any()


def changed_edges(old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """Indices of the edges of closed polygon ``new`` that are not edges of ``old``."""
    def keys(loop):
        nxt = np.roll(loop, -1, axis=0)
        return [(*a, *b) for a, b in zip(np.round(loop, 9).tolist(), np.round(nxt, 9).tolist())]

    before = set(keys(old))
    return np.array([i for i, k in enumerate(keys(new)) if k not in before], dtype=np.int64)


def loops_disjoint(a: np.ndarray, b: np.ndarray) -> bool:
    """True if the edges of two closed polygons do not meet."""
    sa = np.stack([a, np.roll(a, -1, axis=0)], axis=1)
    sb = np.stack([b, np.roll(b, -1, axis=0)], axis=1)
    return not segments_cross(sa, sb).any()


def clip_loop_to_rect(loop: np.ndarray, width: float, height: float) -> np.ndarray:
    """Sutherland-Hodgman clip of a closed polygon to ``[0, width] x [0, height]``.

    Exact for the region: the result encloses ``polygon ∩ rectangle``. Used to keep the hull
    inside the image, since UVs outside 0..1 would sample neighbouring atlas regions.
    Consecutive duplicate vertices and exactly collinear vertices on the rectangle are removed.
    """
    pts = [tuple(p) for p in np.asarray(loop, dtype=np.float64)]
    for axis, bound, keep_less in ((0, 0.0, False), (0, float(width), True), (1, 0.0, False), (1, float(height), True)):
        if not pts:
            break
        out = []
        for i in range(len(pts)):
            cur, prev = pts[i], pts[i - 1]
            cin = cur[axis] <= bound if keep_less else cur[axis] >= bound
            pin = prev[axis] <= bound if keep_less else prev[axis] >= bound
            if cin != pin:
                t = (bound - prev[axis]) / (cur[axis] - prev[axis])
                x = (prev[0] + t * (cur[0] - prev[0]), prev[1] + t * (cur[1] - prev[1]))
                x = (bound, x[1]) if axis == 0 else (x[0], bound)
                out.append(x)
            if cin:
                out.append(cur)
        pts = out
    if len(pts) < 3:
        return np.asarray(pts).reshape(-1, 2)
    return drop_redundant(np.asarray(pts))


def drop_redundant(loop: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Remove repeated consecutive vertices and vertices lying on the segment of their neighbours."""
    changed = True
    while changed and len(loop) > 3:
        changed = False
        d = np.hypot(*(np.roll(loop, -1, axis=0) - loop).T)
        if (d <= tol).any():
            loop = loop[d > tol]
            changed = True
            continue
        prev, nxt = np.roll(loop, 1, axis=0), np.roll(loop, -1, axis=0)
        u, w = loop - prev, nxt - loop
        cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        straight = (np.abs(cross) <= tol * np.maximum(1.0, np.hypot(*u.T) * np.hypot(*w.T))) & ((u * w).sum(1) > 0)
        if straight.any():
            loop = loop[~straight]
            changed = True
    return loop
