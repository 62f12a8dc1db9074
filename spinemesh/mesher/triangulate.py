"""Step 4 of the pipeline (paper sec. 3.4): triangles.

Both presets use pythoncdt (MPL-2.0, free for commercial use). Without constraints it gives
the plain Delaunay triangulation the paper gets from OpenCV's ``Subdiv2D`` (the two can differ
only where four points are co-circular).
"""

from __future__ import annotations

import numpy as np
import pythoncdt as cdt

from .geometry import points_in_loops


def _triangulation(points: np.ndarray, edges: np.ndarray | None):
    t = cdt.Triangulation(cdt.VertexInsertionOrder.AS_PROVIDED,
                          cdt.IntersectingConstraintEdges.TRY_RESOLVE, 0.0)
    t.insert_vertices(np.ascontiguousarray(points, dtype=np.float64))
    if edges is not None and len(edges):
        t.insert_edges(np.ascontiguousarray(edges, dtype=np.uint32))
    return t


def _arrays(t) -> tuple[np.ndarray, np.ndarray]:
    v = t.vertices_array()
    verts = np.stack([v["x"], v["y"]], axis=1).astype(np.float64)
    tris = t.triangles_array()["vertices"].astype(np.int64)
    return verts, tris


def delaunay_centroid_filter(points: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Paper sec. 3.4: Delaunay of all points, dropping triangles whose centroid is off the mask.

    Returns
    -------
    vertices : ndarray, shape (N, 2)
    triangles : ndarray, shape (M, 3), positive signed area
    """
    t = _triangulation(points, None)
    t.erase_super_triangle()
    verts, tris = _arrays(t)
    if len(tris) == 0:
        return verts, tris
    cen = verts[tris].mean(axis=1)
    h, w = mask.shape
    c = np.clip(np.floor(cen[:, 0]).astype(int), 0, w - 1)
    r = np.clip(np.floor(cen[:, 1]).astype(int), 0, h - 1)
    return verts, tris[mask[r, c]]


def constrained(points: np.ndarray, edges: np.ndarray, loops: list[np.ndarray],
                min_angle: float = 0.0, max_steiner: int = 0, min_edge: float = 0.0):
    """Constrained Delaunay triangulation of ``points`` keeping ``edges``, cut to ``loops``.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
    edges : ndarray, shape (K, 2)
        Constrained edges (hull loop, hole loops, interior chains), as point indices.
    loops : list of ndarray
        The hull loop and hole loops; a triangle is kept when its centroid is inside them
        (even-odd), which is exact because every loop edge is a triangle edge.
    min_angle, max_steiner, min_edge : float, int, float
        Optional Delaunay refinement: insert at most ``max_steiner`` points to lift the smallest
        angle towards ``min_angle`` degrees, never making edges shorter than ``min_edge`` px.

    Returns
    -------
    vertices : ndarray, shape (N', 2)
        ``points`` first, then any point the refinement added.
    triangles : ndarray, shape (M, 3), positive signed area
    edges : ndarray, shape (K', 2)
        The constrained edges after refinement (a split edge is replaced by its pieces).
    hole_triangles : ndarray, shape (H, 3)
        The triangles inside the hole loops (``loops[1:]``): with them the hull polygon is
        triangulated entirely, as Spine's mesh model wants.
    """
    t = _triangulation(points, edges)
    if max_steiner > 0 and min_angle > 0:
        # refine only inside: outer and hole triangles are excluded (pythoncdt takes radians)
        skip = t.collect_outer_triangles_and_holes()
        t.refine_triangles(int(max_steiner), cdt.RefinementCriterion.SMALLEST_ANGLE,
                           float(np.radians(min_angle)), skip, float(min_edge))
    t.erase_super_triangle()
    verts, tris = _arrays(t)
    fixed = np.array(sorted((e.v1, e.v2) for e in t.fixed_edges), dtype=np.int64).reshape(-1, 2)
    cen = verts[tris].mean(axis=1)
    keep = points_in_loops(cen, loops)
    in_hull = points_in_loops(cen, loops[:1])
    return verts, tris[keep], fixed, tris[in_hull & ~keep]
