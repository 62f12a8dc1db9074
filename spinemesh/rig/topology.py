"""Rig-aware topology: vertices where the skeleton bends.

A mesh made from the art alone has no vertex where a bone crosses it, and may span a whole
limb with long slivers fanning from one hull vertex: such a mesh cannot fold at a joint.
Given the bone segments that cross the art, this adds, inside the hull:

1. a vertex on each joint (a bone's origin) that lies on the art;
2. a row of vertices across the art at each joint, perpendicular to the bone (the mean of
   the bone's and its parent's directions when the parent crosses the art too), so that
   the mesh can fold there;
3. vertices along each bone segment, ``spacing`` apart, so that no triangle runs far along
   a bone.

Then the mesh is triangulated again with the constrained Delaunay triangulation the
upgrade uses (:func:`spinemesh.attachment_geometry.spine_triangles`): the hull and the
constrained edges stay as they are, and the new vertices are interior. New vertices get
their UVs from the triangle of the old mesh they fall in (exact for an upgraded region,
whose UVs are an affine map of its positions). The vertex budget holds: no more vertices
are added than it allows, joints first.
"""

from __future__ import annotations

import numpy as np

#: Vertices along a bone and across a joint are this share of the art's larger side apart.
SPACING = 0.12

#: Without an explicit budget, at most this many vertices are added to a mesh.
DEFAULT_ADDED = 24

#: Steps from a joint towards the outline tested at once (:func:`_row`).
STEPS_AT_ONCE = 16


def _inside(loop: np.ndarray, points: np.ndarray, margin: float) -> np.ndarray:
    """Which points lie inside the closed polygon ``loop`` by at least ``margin``."""
    import cv2

    contour = np.asarray(loop, np.float32).reshape(-1, 1, 2)
    test = cv2.pointPolygonTest
    # one OpenCV call per point: the points as Python pairs, not numpy rows (half the time around it)
    pairs = np.asarray(points, float).reshape(-1, 2).tolist()
    return np.fromiter((test(contour, p, True) for p in pairs), float, len(pairs)) >= margin


def _far_from(points: np.ndarray, others: np.ndarray, distance: float) -> np.ndarray:
    if len(others) == 0 or len(points) == 0:
        return np.ones(len(points), bool)
    d = np.linalg.norm(points[:, None] - others[None], axis=2)
    return d.min(axis=1) >= distance


def _edge_distance(points: np.ndarray, vertices: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Distance of each point to the nearest of the given edges (inf without edges)."""
    if len(edges) == 0 or len(points) == 0:
        return np.full(len(points), np.inf)
    a, b = vertices[edges[:, 0]][None], vertices[edges[:, 1]][None]
    p = points[:, None]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab ** 2).sum(-1), 1e-12), 0, 1)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(axis=1)


def _row(loop: np.ndarray, start: np.ndarray, normal: np.ndarray, spacing: float, margin: float) -> list:
    """Points from a joint towards the outline along ``normal``, evenly spread over the art's width.

    At least one point however narrow the art (unless it is narrower than ``margin``), so
    that a fold line crosses the art at every joint.
    """
    size = float(np.ptp(loop, axis=0).max())
    steps = np.arange(1.0, size, 1.0)
    reach = size
    # the first step outside the art, tested a few steps at a time (a joint is rarely far from
    # the outline across the bone, and each step is one point-in-polygon test)
    for s in range(0, len(steps), STEPS_AT_ONCE):
        some = steps[s:s + STEPS_AT_ONCE]
        ok = _inside(loop, start + some[:, None] * normal, 0.0)
        if not ok.all():
            reach = float(some[np.argmin(ok)])
            break
    count = max(1, int(reach // spacing))
    cand = np.array([start + normal * reach * k / (count + 1) for k in range(1, count + 1)])
    return list(cand[_inside(loop, cand, min(margin, reach / (count + 1) / 2))])


def _steps_over(a: np.ndarray, d: np.ndarray, n: float, spacing: float, lo: np.ndarray,
                hi: np.ndarray) -> tuple[int, int]:
    """The first and last ``k`` (from 1) whose point ``a + d * k * spacing / n``, of the segment
    from ``a`` along ``d`` (length ``n``), lies in the box ``lo``..``hi``; ``(1, 0)`` for none.

    Examples
    --------
    >>> _steps_over(np.array([-1e9, 0.0]), np.array([2e9, 0.0]), 2e9, 4.0, np.zeros(2), np.full(2, 10.0))
    (250000000, 250000002)
    """
    t0, t1 = 0.0, 1.0  # the part of the segment in the box (Liang and Barsky's clipping)
    for axis in range(2):
        if d[axis] == 0:
            if not lo[axis] <= a[axis] <= hi[axis]:
                return 1, 0
            continue
        ends = sorted(((lo[axis] - a[axis]) / d[axis], (hi[axis] - a[axis]) / d[axis]))
        t0, t1 = max(t0, ends[0]), min(t1, ends[1])
    if t0 > t1:
        return 1, 0
    return max(1, int(np.ceil(t0 * n / spacing))), int(np.floor(t1 * n / spacing))


def rig_points(vertices: np.ndarray, hull: int, segments: np.ndarray, parents: list[int | None],
               budget: int) -> np.ndarray:
    """Candidate vertices for the joints, rows across joints and bone segments, in priority order.

    Parameters
    ----------
    vertices : ndarray, shape (N, 2)
        The mesh in pixels of its image (the first ``hull`` are the outline).
    segments : ndarray, shape (B, 2, 2)
        Bone segments in the same pixel space (origin, tip).
    parents : list
        For each segment, the index of its parent's segment in ``segments``, or None.
    budget : int
        Most points returned.

    Returns
    -------
    ndarray, shape (K, 2)
    """
    loop = vertices[:hull]
    size = float(np.ptp(vertices, axis=0).max())
    spacing = max(SPACING * size, 4.0)
    margin = spacing / 3
    joints, rows, along = [], [], []
    for i, (a, b) in enumerate(segments):
        d = b - a
        n = float(np.linalg.norm(d))
        direction = d / n if n > 0 else None
        p = parents[i]
        if p is not None:
            pd = segments[p][1] - segments[p][0]
            pn = float(np.linalg.norm(pd))
            if pn > 0:
                direction = pd / pn if direction is None else (direction + pd / pn)
        if _inside(loop, a[None], margin)[0]:
            joints.append(a)
            if direction is not None and np.linalg.norm(direction) > 0:
                normal = np.array([-direction[1], direction[0]]) / np.linalg.norm(direction)
                rows += _row(loop, a, normal, spacing, margin) + _row(loop, a, -normal, spacing, margin)
        if n > 0:
            # the steps over the art's box alone: the others are not on the art (a bone a billion
            # units long was stepped through, point by point, for hours)
            first, last = _steps_over(a, d, n, spacing, vertices.min(axis=0), vertices.max(axis=0))
            for k in range(first, last + 1):
                along.append(a + d * (k * spacing / n))
    cands = np.array(joints + rows + along, float).reshape(-1, 2)
    if len(cands) == 0:
        return cands
    cands = cands[_inside(loop, cands, margin)]
    cands = cands[_far_from(cands, vertices, spacing / 2)]
    out: list[np.ndarray] = []
    for c in cands:
        if len(out) >= budget:
            break
        if _far_from(c[None], np.array(out).reshape(-1, 2), spacing / 2)[0]:
            out.append(c)
    return np.array(out, float).reshape(-1, 2)


def _barycentric_uvs(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray,
                     uvs: np.ndarray) -> np.ndarray | None:
    """UVs of ``points`` interpolated in the triangles that hold them; None if one is outside all."""
    out = np.zeros((len(points), 2))
    tri = vertices[triangles]                                          # (T, 3, 2)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b - a, c - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    for i, p in enumerate(points):
        v2 = p - a
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
            t = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        ok = np.flatnonzero((s >= -1e-9) & (t >= -1e-9) & (s + t <= 1 + 1e-9) & np.isfinite(s))
        if len(ok) == 0:
            return None
        j = ok[0]
        tu = uvs[triangles[j]]
        out[i] = tu[0] + s[j] * (tu[1] - tu[0]) + t[j] * (tu[2] - tu[0])
    return out


def add_rig_vertices(att: dict, segments_local: np.ndarray, parents: list[int | None],
                     max_vertices: int | None = None) -> int:
    """Add joint, row and bone vertices to an unweighted mesh attachment, in place.

    Parameters
    ----------
    att : dict
        Mesh attachment with unweighted ``vertices`` (slot bone space), ``uvs``, ``hull``,
        ``edges``, ``triangles``, ``width``, ``height``.
    segments_local : ndarray, shape (B, 2, 2)
        Bone segments in the slot bone's space.
    parents : list
        Parent segment index of each segment, or None.
    max_vertices : int, optional
        Vertex budget of the whole mesh; without one, at most ``DEFAULT_ADDED`` are added.

    Returns
    -------
    int
        How many vertices were added (0 leaves ``att`` unchanged).
    """
    from ..attachment_geometry import spine_triangles

    uvs = np.asarray(att["uvs"], float).reshape(-1, 2)
    local = np.asarray(att["vertices"], float).reshape(-1, 2)
    n, hull = len(uvs), int(att["hull"])
    size = np.array([float(att.get("width", 32)), float(att.get("height", 32))])
    pixels = uvs * size
    edges = np.asarray(att.get("edges", []), int).reshape(-1, 2) // 2
    triangles = np.asarray(att["triangles"], int).reshape(-1, 3)
    budget = (max_vertices - n) if max_vertices else DEFAULT_ADDED
    if budget <= 0 or len(segments_local) == 0:
        return 0
    # Local (slot bone) space -> pixels: affine fit over the mesh (exact for an upgraded region).
    design = np.c_[local, np.ones(n)]
    to_px, *_ = np.linalg.lstsq(design, pixels, rcond=None)
    if np.abs(design @ to_px - pixels).max() > 0.01 * max(size.max(), 1):
        return 0  # UVs are not an affine image of the positions: not a region-made mesh
    seg_px = (np.c_[segments_local.reshape(-1, 2), np.ones(2 * len(segments_local))] @ to_px).reshape(-1, 2, 2)
    new = rig_points(pixels, hull, seg_px, parents, budget)
    loop = np.stack([np.arange(hull), (np.arange(hull) + 1) % hull], axis=1)
    keep = _edge_distance(new, pixels, np.concatenate([loop, edges])) >= 1.0
    new = new[keep]
    if len(new) == 0:
        return 0
    new_uv = _barycentric_uvs(new, pixels, triangles, uvs)
    if new_uv is None:
        return 0
    all_px = np.concatenate([pixels, new_uv * size])
    tris = spine_triangles(all_px, hull, edges)
    if tris is None:
        return 0
    from_px = np.linalg.lstsq(np.c_[pixels, np.ones(n)], local, rcond=None)[0]
    new_local = np.c_[new_uv * size, np.ones(len(new))] @ from_px
    att["uvs"] = [round(float(c), 6) for c in np.concatenate([uvs, new_uv]).ravel()]
    att["vertices"] = [round(float(c), 4) for c in np.concatenate([local, new_local]).ravel()]
    att["triangles"] = [int(i) for i in tris.ravel()]
    return len(new)
