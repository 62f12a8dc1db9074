"""Small polygon helpers on numpy arrays (pixel coordinates, x right, y down)."""

from __future__ import annotations

import numpy as np
import shapely


def clamp(values: np.ndarray, low, high) -> np.ndarray:
    """``np.clip(values, low, high)``, the same values, without its Python layers.

    The mesher clamps small arrays hundreds of thousands of times per library run, where
    ``np.clip``'s wrappers cost about as much as the work.
    """
    return np.minimum(np.maximum(values, low), high)


def successors(a: np.ndarray) -> np.ndarray:
    """``np.roll(a, -1, axis=0)``: each row's next one, the first after the last (a loop's
    next vertices), the same values without ``np.roll``'s Python layers (the mesher rolls
    small loops about a hundred thousand times per library run, at several times the cost
    of the copy)."""
    return np.concatenate((a[1:], a[:1]))


def predecessors(a: np.ndarray) -> np.ndarray:
    """``np.roll(a, 1, axis=0)``: each row's previous one, the last before the first."""
    return np.concatenate((a[-1:], a[:-1]))


def signed_area(loop: np.ndarray) -> float:
    """Shoelace area of a closed polygon (n, 2); positive = the mesh winding (clockwise on screen)."""
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, successors(y)) - np.dot(successors(x), y))


def dp_indices(points: np.ndarray, eps: float, closed: bool = True, splits: dict | None = None) -> np.ndarray:
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
    splits : dict, optional
        The farthest point of each stretch, kept between calls on the same ``points`` and
        ``closed``: where a stretch splits does not depend on ``eps`` (only whether it does),
        so a finer tolerance after a coarser one computes only the stretches the coarser
        one did not split. Filled by the call; the caller gives an empty dict for new points.
    """
    n = len(points)
    if n <= 2:
        return np.arange(n)
    splits = {} if splits is None else splits
    if closed:
        if "far" not in splits:
            splits["far"] = int(np.argmax(np.hypot(*(points - points[0]).T)))
        far = splits["far"]
        if far == 0:
            return np.array([0])
        ext = np.vstack([points, points[:1]])
        a = _dp(ext, 0, far, eps, splits)
        b = _dp(ext, far, n, eps, splits)
        idx = np.unique(np.concatenate([a, b])) % n
        return np.unique(idx)
    return _dp(points, 0, n - 1, eps, splits)


def _dp(points: np.ndarray, i0: int, i1: int, eps: float, splits: dict) -> np.ndarray:
    """The kept indices between ``i0`` and ``i1``; each stretch's farthest point ``(k, distance)``
    is looked up in (or added to) ``splits``."""
    keep = [i0, i1]
    stack = [(i0, i1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        found = splits.get((a, b))
        if found is None:
            found = splits[(a, b)] = _farthest_of_stretch(points, a, b)
        k, far = found
        if far > eps:
            m = a + 1 + k
            keep.append(m)
            stack.append((a, m))
            stack.append((m, b))
    return np.array(sorted(set(keep)))


def _farthest_of_stretch(points: np.ndarray, a: int, b: int) -> tuple[int, float]:
    """``(k, d)``: the point ``a + 1 + k`` of ``points[a + 1:b]`` farthest from the segment
    ``points[a]``-``points[b]``, and its distance (the first of equal ones)."""
    seg = points[a + 1:b]
    if b - a > LONG_STRETCH:
        return _farthest(_point_segment_offsets(seg, points[a], points[b]))
    d = _point_segment_distance(seg, points[a], points[b])
    k = int(np.argmax(d))
    return k, d[k]


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(*_point_segment_offsets(p, a, b).T)


def _point_segment_offsets(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """From the nearest point of segment ``a``-``b`` to each point of ``p`` (n, 2): (n, 2)."""
    ab = b - a
    L2 = float(ab @ ab)
    if L2 == 0:
        return p - a
    t = clamp(((p - a) @ ab) / L2, 0, 1)
    q = a + t[:, None] * ab
    return p - q


#: Stretches of more points than this find their farthest point with :func:`_farthest`.
LONG_STRETCH = 128
#: Margin between a squared length (rounded) and the square of ``np.hypot`` of the same
#: offset: both lie within a few units in the last place (about 1e-15) of the true value.
SQUARED_MARGIN = 1e-9


def _farthest(offsets: np.ndarray) -> tuple[int, float]:
    """``(k, d[k])`` for ``d = np.hypot(*offsets.T)`` and ``k = np.argmax(d)``, the same values,
    with ``np.hypot`` (about twenty times a multiplication) taken only for the offsets whose
    squared length lies within :data:`SQUARED_MARGIN` of the largest: no other can be the
    largest, and the first of equal lengths wins as with ``argmax``."""
    squared = offsets[:, 0] * offsets[:, 0] + offsets[:, 1] * offsets[:, 1]
    top = squared.max()
    if not np.isfinite(top):  # an overflow or NaN: the plain way
        d = np.hypot(*offsets.T)
        k = int(np.argmax(d))
        return k, d[k]
    near = np.flatnonzero(squared >= top * (1 - SQUARED_MARGIN))
    d = np.hypot(*offsets[near].T)
    i = int(np.argmax(d))
    return int(near[i]), d[i]


def points_in_loops(points: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """Even-odd test of points against closed loops (hull and holes together).

    Returns
    -------
    ndarray, shape (n,), bool
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    inside = np.zeros(len(pts), dtype=bool)
    for loop in loops:
        inside ^= shapely.contains_xy(shapely.Polygon(loop), pts[:, 0], pts[:, 1])
    return inside


def segments_cross(s: np.ndarray, t: np.ndarray, ignore: np.ndarray | None = None) -> np.ndarray:
    """Which pairs of segments meet, other than at a shared end point.

    Two segments that share an end point and lie on one line, overlapping, also meet.

    Parameters
    ----------
    s : ndarray, shape (n, 2, 2)
    t : ndarray, shape (m, 2, 2)
    ignore : ndarray, shape (n, m), bool, optional
        Pairs not to test (False in the result): neighbours in a loop, which always share
        an end point.

    Returns
    -------
    ndarray, shape (n, m), bool
    """
    s = np.asarray(s, dtype=np.float64).reshape(-1, 2, 2)
    t = np.asarray(t, dtype=np.float64).reshape(-1, 2, 2)
    out = np.zeros((len(s), len(t)), dtype=bool)
    if len(s) == 0 or len(t) == 0:
        return out
    i, j, ls, lt = _intersecting_pairs(s, t, ignore)
    if len(i) == 0:
        return out
    # a meeting at a common end point is not a crossing, unless the segments overlap there
    shared = _shares_end(s[i], t[j])
    meet = ~shared | shapely.overlaps(ls, lt) | shapely.equals(ls, lt)
    if shared.any():
        # meeting elsewhere as well (a segment folding back onto the other)
        inter = shapely.intersection(ls[shared], lt[shared])
        meet[shared] |= shapely.get_num_coordinates(inter) > 1
    out[i[meet], j[meet]] = True
    return out


#: Pairs of segments up to which :func:`_intersecting_pairs` compares bounding boxes directly.
DIRECT_PAIRS = 65536


def _intersecting_pairs(s: np.ndarray, t: np.ndarray, ignore: np.ndarray | None = None):
    """Index pairs ``(i, j)`` of segments ``s[i]`` and ``t[j]`` that intersect, and their linestrings.

    Pairs where ``ignore`` (n, m) is True are left out.

    Few pairs (a loop's changed edges against the loop): their bounding boxes are compared
    directly and only the pairs whose boxes meet are made into geometries, which is
    several times faster than building a spatial index over ``t``; many pairs: the
    spatial index. The two find the same pairs: an index query tests exactly the pairs
    whose boxes meet, with the same predicate.
    """
    if len(s) * len(t) > DIRECT_PAIRS:
        ls, lt = shapely.linestrings(s), shapely.linestrings(t)
        i, j = shapely.STRtree(lt).query(ls, predicate="intersects")
        if ignore is not None:
            keep = ~ignore[i, j]
            i, j = i[keep], j[keep]
        return i, j, ls[i], lt[j]
    lo_s, hi_s, lo_t, hi_t = s.min(axis=1), s.max(axis=1), t.min(axis=1), t.max(axis=1)
    boxes_meet = ((lo_s[:, None] <= hi_t[None]) & (lo_t[None] <= hi_s[:, None])).all(axis=-1)
    if ignore is not None:
        boxes_meet &= ~ignore
    i, j = np.nonzero(boxes_meet)
    ls, lt = shapely.linestrings(s[i]), shapely.linestrings(t[j])
    hit = shapely.intersects(ls, lt)
    return i[hit], j[hit], ls[hit], lt[hit]


def _shares_end(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per pair of segments (k, 2, 2), whether they have an end point in common."""
    return ((a[:, :, None, :] == b[:, None, :, :]).all(-1)).any((1, 2))


def loop_is_simple(loop: np.ndarray, edges: np.ndarray | None = None) -> bool:
    """True if no two non-adjacent edges of the closed polygon meet, and no vertex repeats.

    ``edges`` (indices of edges, edge ``i`` runs from vertex ``i`` to ``i + 1``) may name the
    edges that changed in a loop known to be simple; the test is then the same but it is
    answered by a spatial index query of only those edges.
    """
    loop = np.asarray(loop, dtype=np.float64)
    n = len(loop)
    if n < 3:
        return False
    following = np.concatenate([loop[1:], loop[:1]])  # vertex i + 1 of each vertex i
    if (following == loop).all(axis=1).any():
        return False
    if edges is None:
        return bool(shapely.is_simple(shapely.linearrings(loop))) and _no_repeat(loop)
    seg = np.stack([loop, following], axis=1)
    rows = np.unique(np.asarray(edges, dtype=np.int64) % n)
    r = np.arange(len(rows))
    neighbours = np.zeros((len(rows), n), dtype=bool)  # an edge and the two it shares a vertex with
    neighbours[r, rows] = neighbours[r, (rows + 1) % n] = neighbours[r, (rows - 1) % n] = True
    return not segments_cross(seg[rows], seg, neighbours).any() and _no_repeat(loop)


def _no_repeat(loop: np.ndarray) -> bool:
    """Whether no two vertices (n, 2) are equal.

    Each vertex as one complex number (x + iy, the same two floats): sorted, equal vertices
    are neighbours. Several times faster than ``np.unique(loop, axis=0)``.
    """
    points = np.ascontiguousarray(loop, dtype=np.float64) + 0.0  # "+ 0.0": -0.0 and 0.0 are one value
    points = np.sort(points.view(np.complex128).ravel())
    return not (points[1:] == points[:-1]).any()


def clip_loop_to_rect(loop: np.ndarray, width: float, height: float) -> np.ndarray:
    """The part of a closed polygon inside ``[0, width] x [0, height]``, as one loop.

    Used to keep the hull inside the image, since UVs outside 0..1 would sample neighbouring
    atlas regions. Orientation is kept; repeated and exactly collinear vertices are removed.
    When the clip leaves several pieces (a loop leaving the image and coming back), the
    largest is returned.
    """
    loop = np.asarray(loop, dtype=np.float64)
    poly = shapely.Polygon(loop)
    box = shapely.box(0.0, 0.0, float(width), float(height))
    if shapely.contains_properly(box, poly) or len(loop) < 3:
        return drop_redundant(loop) if len(loop) >= 3 else loop.reshape(-1, 2)
    part = shapely.clip_by_rect(poly, 0.0, 0.0, float(width), float(height))
    if part.is_empty:
        return np.zeros((0, 2))
    pieces = list(getattr(part, "geoms", [part]))
    piece = max((g for g in pieces if g.geom_type == "Polygon"), key=lambda g: g.area, default=None)
    if piece is None:
        return np.zeros((0, 2))
    out = np.asarray(piece.exterior.coords)[:-1]
    if np.sign(signed_area(out)) != np.sign(signed_area(loop)):
        out = out[::-1]
    return drop_redundant(out)


def drop_redundant(loop: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Remove repeated consecutive vertices and vertices lying on the segment of their neighbours."""
    changed = True
    while changed and len(loop) > 3:
        changed = False
        d = np.hypot(*(successors(loop) - loop).T)
        if (d <= tol).any():
            loop = loop[d > tol]
            changed = True
            continue
        prev, nxt = predecessors(loop), successors(loop)
        u, w = loop - prev, nxt - loop
        cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        straight = (np.abs(cross) <= tol * np.maximum(1.0, np.hypot(*u.T) * np.hypot(*w.T))) & ((u * w).sum(1) > 0)
        if straight.any():
            loop = loop[~straight]
            changed = True
    return loop


def inset_loop(loop: np.ndarray, distance: float, width: float, height: float) -> np.ndarray | None:
    """``loop`` with every edge moved ``distance`` px inwards, except edges on the image border.

    Each convex vertex off the border goes to the intersection of its two edges' moved
    lines, each reflex one ``distance`` along its bisector, the others stay (the vertex count and order stay, and the result contains the erosion by a disc of
    radius ``distance`` of ``loop`` united with everything outside the image
    ``[0, width] x [0, height]``: edges on the image border stay). Used for the sampling margin: a hull around a mask grown by one texel may lie
    half a texel inside it (``MesherParams.hull_inset``).

    Parameters
    ----------
    loop : ndarray, shape (n, 2)
        A simple loop inside the image, either winding.
    distance : float
        How far to move the edges (px).

    Returns
    -------
    ndarray, shape (n, 2), or None
        None when moving the edges would turn one round, make the loop cross itself (an
        edge shorter than the move, a narrow neck) or leave the image (a reflex corner's
        mitre near the border): the caller keeps ``loop``.
    """
    loop = np.asarray(loop, np.float64)
    n = len(loop)
    a, b = loop, successors(loop)
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    if n < 3 or (length <= 0).any():
        return None
    # inward normal of each edge: left of the direction for a positive (clockwise on screen) loop
    sign = 1.0 if signed_area(loop) > 0 else -1.0
    normal = sign * np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]
    on_border = (((a[:, 0] == 0) & (b[:, 0] == 0)) | ((a[:, 0] == width) & (b[:, 0] == width))
                 | ((a[:, 1] == 0) & (b[:, 1] == 0)) | ((a[:, 1] == height) & (b[:, 1] == height)))
    shift = np.where(on_border, 0.0, distance)
    # vertex i joins edge i-1 (into it) and edge i (out of it)
    n0, n1 = predecessors(normal), normal
    s0, s1 = predecessors(shift), shift
    # solve p . n0 = a_i . n0 + s0 and p . n1 = a_i . n1 + s1 for the moved vertex p = a_i + q
    det = n0[:, 0] * n1[:, 1] - n0[:, 1] * n1[:, 0]
    nearly_straight = np.abs(det) < 1e-6
    q = np.stack([(s0 * n1[:, 1] - s1 * n0[:, 1]), (n0[:, 0] * s1 - n1[:, 0] * s0)], axis=1)
    q = q / np.where(nearly_straight, 1.0, det)[:, None]
    q[nearly_straight] = (n1[nearly_straight] * np.maximum(s0, s1)[nearly_straight, None])
    # At a reflex vertex the erosion is rounded about the vertex (the moved lines' crossing
    # would cut into it): the vertex goes onto that arc, on the bisector, and its edges run
    # outside the erosion. A vertex between a border edge and a moved one stays (its moved
    # edge then runs between the old and the moved line).
    d_in = predecessors(d)
    reflex = (sign * (d_in[:, 0] * d[:, 1] - d_in[:, 1] * d[:, 0]) < 0) & ~nearly_straight
    bisector = n0 + n1
    bisector /= np.maximum(np.hypot(bisector[:, 0], bisector[:, 1]), 1e-12)[:, None]
    q[reflex] = bisector[reflex] * s1[reflex, None]
    q[s0 != s1] = 0.0
    out = loop + q
    if (out < 0).any() or (out[:, 0] > width).any() or (out[:, 1] > height).any():
        return None  # a reflex corner's mitre would leave the image
    moved = successors(out) - out
    if ((moved * d).sum(axis=1) <= 0).any() or not loop_is_simple(out):
        return None
    return out
