"""Mesh quality measures, shared by tests, benchmarks and the diff command.

Pixels are unit squares and a pixel is *inside*, *touched by* or *centred in* a mesh as
defined by the exact rasteriser, :mod:`spinemesh.mesher.raster`.
"""

from __future__ import annotations

import cv2
import numpy as np

from .foreground import foreground
from .mesher.interior import edge_map, long_contours
from .mesher.params import PAPER
from .mesher.raster import (boundary_index_edges, boundary_segments, crossed_pixels, mesh_coverage_mask,
                             polygon_coverage_mask)

#: Alpha at or above which a pixel is art that must never be clipped.
OPAQUE_ALPHA = 8


# --------------------------------------------------------------------------- measures
def opaque_mask(image: np.ndarray, alpha: int = OPAQUE_ALPHA) -> np.ndarray:
    """Pixels that are art: ``alpha >= alpha`` (all pixels of an RGB image); see :func:`foreground`."""
    return foreground(image, alpha)


def coverage(vertices, triangles, art: np.ndarray) -> float:
    """Share of art pixels whose square lies entirely inside the mesh (1.0 = nothing clipped).

    ``art`` is an (H, W) bool mask, e.g. :func:`opaque_mask`.
    """
    art = np.asarray(art, dtype=bool)
    if not art.any():
        return 1.0
    return _covered_share(mesh_coverage_mask(vertices, triangles, art.shape, "inside"), art)


def _covered_share(inside: np.ndarray, art: np.ndarray) -> float:
    """Share of the ``art`` pixels that ``inside`` holds (1.0 without art); both (H, W) bool."""
    n = int(np.count_nonzero(art))  # the integers of .sum(), counted without widening each to int64
    return 1.0 if n == 0 else float(np.count_nonzero(inside & art)) / n


def uncovered_pixels(vertices, triangles, art: np.ndarray) -> np.ndarray:
    """(K, 2) array of ``(x, y)`` of art pixels not entirely inside the mesh."""
    inside = mesh_coverage_mask(vertices, triangles, art.shape, "inside")
    r, c = np.nonzero(art & ~inside)
    return np.stack([c, r], axis=1)


def triangle_areas(vertices, triangles) -> np.ndarray:
    """Signed areas (px^2), positive for the winding documented in :mod:`spinemesh.mesher.mesh`."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def mesh_area(vertices, triangles) -> float:
    """Total area of the triangles (px^2)."""
    return float(np.abs(triangle_areas(vertices, triangles)).sum())


def waste(vertices, triangles, art: np.ndarray) -> float:
    """Transparent share of the mesh area: ``1 - (art pixels centred in the mesh) / mesh area``.

    Area outside the image counts as transparent. 0 is a perfect fit; artists' meshes of the
    4.2 examples and real game projects are around 0.2.
    """
    area = mesh_area(vertices, triangles)
    if area <= 0:
        return 0.0
    return _transparent_share(mesh_coverage_mask(vertices, triangles, art.shape, "centre"), art, area)


def _transparent_share(centre: np.ndarray, art: np.ndarray, area: float) -> float:
    """:func:`waste` from the pixels ``centre`` (H, W) centred in a mesh of ``area`` px^2 (> 0)."""
    return float(max(0.0, 1.0 - int(np.count_nonzero(centre & art)) / area))


def coverage_and_waste(vertices, triangles, art: np.ndarray) -> tuple[float, float]:
    """:func:`coverage` and :func:`waste` of one mesh, its outline rasterised once (the same values)."""
    art = np.asarray(art, dtype=bool)
    segments = boundary_segments(vertices, triangles)
    centre = polygon_coverage_mask(segments, art.shape, "centre")
    # "inside" (polygon_coverage_mask) is "centre" less the squares an outline segment crosses
    cov = _covered_share(centre & ~crossed_pixels(segments, art.shape), art) if art.any() else 1.0
    area = mesh_area(vertices, triangles)
    return cov, 0.0 if area <= 0 else _transparent_share(centre, art, area)


def angle_ratios(vertices, triangles) -> np.ndarray:
    """Per triangle, smallest angle / largest angle (1 = equilateral, 0 = degenerate)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(t) == 0:
        return np.zeros(0)
    p = v[t]
    angles = []
    for i in range(3):
        a, b, c = p[:, i], p[:, (i + 1) % 3], p[:, (i + 2) % 3]
        u, w = b - a, c - a
        cosv = (u * w).sum(1) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1), 1e-300)
        angles.append(np.arccos(np.clip(cosv, -1, 1)))
    ang = np.stack(angles, axis=1)
    return ang.min(1) / np.maximum(ang.max(1), 1e-300)


def angle_ratio(vertices, triangles) -> float:
    """Mean of :func:`angle_ratios`: the paper's triangle regularity (sec. 4.4; 0.42 there)."""
    r = angle_ratios(vertices, triangles)
    return float(r.mean()) if len(r) else 0.0


def significant_edges(image: np.ndarray, mask: np.ndarray | None = None, min_length: float = 150.0) -> np.ndarray:
    """Pixels of the significant internal edges of a sprite, as in the paper's ablation.

    The paper's interior edge map (sec. 3.3: bilateral 9/75/75, Canny 40/120 on gray, R, G, B,
    masked by the mask eroded 11x11 twice, closed 3x3), keeping contours of at least
    ``min_length`` px.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    if mask is None:
        mask = opaque_mask(image, 129)
    edges = edge_map(image, mask, PAPER)
    out = np.zeros(mask.shape, dtype=np.uint8)
    for c in long_contours(edges, min_length):
        cv2.polylines(out, [c.astype(np.int32).reshape(-1, 1, 2)], False, 1, 1)
    return (out > 0) & (edges > 0)


def boundary_adherence(vertices, edge_pixels: np.ndarray, radius: float = 10.0) -> float:
    """Share of significant internal edge pixels with a mesh vertex within ``radius`` px.

    The paper (sec. 4.4) counts "significant internal edges that have a vertex within 10 px";
    we count per edge pixel, so that a long edge with one vertex at its end scores low.
    Returns 1.0 when the image has no significant internal edge.
    """
    edge_pixels = np.asarray(edge_pixels, dtype=bool)
    n = int(edge_pixels.sum())
    if n == 0:
        return 1.0
    h, w = edge_pixels.shape
    seeds = np.full((h, w), 255, dtype=np.uint8)
    v = np.asarray(vertices, dtype=np.float64)
    c = np.clip(np.floor(v[:, 0]).astype(int), 0, w - 1)
    r = np.clip(np.floor(v[:, 1]).astype(int), 0, h - 1)
    seeds[r, c] = 0
    dist = cv2.distanceTransform(seeds, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return float((dist[edge_pixels] <= radius).sum()) / n


def mesh_problems(vertices, triangles, hull: int | None = None, min_distance: float = 0.0,
                  min_area: float = 1e-6) -> list[str]:
    """Validity check: degenerate, inverted or overlapping triangles, close vertices, bad hull.

    Returns a list of human-readable problems (empty when the mesh is valid).
    """
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    problems = []
    if len(t) == 0:
        return ["no triangles"]
    if t.min() < 0 or t.max() >= len(v):
        return ["triangle index out of range"]
    areas = triangle_areas(v, t)
    if (np.abs(areas) <= min_area).any():
        problems.append(f"{int((np.abs(areas) <= min_area).sum())} degenerate triangle(s)")
    if (areas < -min_area).any():
        problems.append(f"{int((areas < -min_area).sum())} inverted triangle(s)")
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    directed, dcounts = np.unique(e, axis=0, return_counts=True)
    if (dcounts > 1).any():
        problems.append("overlapping triangles (a directed edge is used twice)")
    e.sort(axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    if (counts > 2).any():
        problems.append("overlapping triangles (an edge has more than two triangles)")
    # a valid mesh's area equals the area enclosed by its outline
    segs = boundary_segments(v, t)
    enclosed = 0.5 * float((segs[:, 0, 0] * segs[:, 1, 1] - segs[:, 1, 0] * segs[:, 0, 1]).sum())
    if not problems and abs(abs(enclosed) - np.abs(areas).sum()) > 1e-6 * max(1.0, np.abs(areas).sum()):
        problems.append("overlapping triangles (area differs from the outline's)")
    if min_distance > 0 and len(v) > 1:
        d = _min_pair_distance(v)
        if d < min_distance:
            problems.append(f"two vertices {d:.3f} px apart (< {min_distance})")
    if hull is not None and hull >= 3:
        seg = {tuple(sorted((i, (i + 1) % hull))) for i in range(hull)}
        b = {tuple(sorted(x)) for x in boundary_index_edges(t)}
        if not seg <= b:
            problems.append("the first `hull` vertices do not form a boundary loop")
    return problems


def _min_pair_distance(v: np.ndarray) -> float:
    # sort-and-sweep on x keeps this fast for thousands of vertices
    order = np.argsort(v[:, 0], kind="stable")
    p = v[order]
    best = np.inf
    for k in range(1, min(len(p), 64)):
        d = np.hypot(*(p[k:] - p[:-k]).T)
        best = min(best, float(d.min()))
        if k < len(p) - 1 and (p[k:, 0] - p[:-k, 0]).min() > best:
            break
    return best


def mesh_metrics(mesh, image: np.ndarray, art_alpha: int = OPAQUE_ALPHA, edge_pixels: np.ndarray | None = None) -> dict:
    """All measures of one mesh over its image.

    Parameters
    ----------
    mesh : spinemesh.mesher.Mesh (or anything with ``vertices``, ``triangles``, ``hull``)
    image : ndarray, shape (H, W, 4|3), uint8
    art_alpha : int
        Art pixels are ``alpha >= art_alpha`` (8).
    edge_pixels : ndarray (H, W) bool, optional
        Precomputed :func:`significant_edges` (they depend only on the image).

    Returns
    -------
    dict
        ``coverage``, ``waste``, ``boundary_adherence``, ``angle_ratio``, ``vertices``,
        ``triangles``, ``hull``, ``interior``, ``problems``.
    """
    art = opaque_mask(image, art_alpha)
    v, t = mesh.vertices, mesh.triangles
    if edge_pixels is None:
        edge_pixels = significant_edges(image)
    cov, wst = coverage_and_waste(v, t, art)
    return {
        "coverage": cov,
        "waste": wst,
        "boundary_adherence": boundary_adherence(v, edge_pixels),
        "angle_ratio": angle_ratio(v, t),
        "vertices": len(v),
        "triangles": len(t),
        "hull": int(getattr(mesh, "hull", 0)),
        "interior": int(len(v) - getattr(mesh, "hull", 0)),
        "problems": mesh_problems(v, t, getattr(mesh, "hull", None)),
    }
