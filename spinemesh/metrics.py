"""Mesh quality measures, shared by tests, benchmarks and the diff command.

Pixel rule (used everywhere here): pixel ``(row r, column c)`` is the closed unit square
``[c, c+1] x [r, r+1]`` in mesh coordinates (x right, y down). A pixel is

- *inside* a mesh when its whole square lies in the union of the triangles. This is the rule
  behind :func:`coverage`: the Spine runtime samples the texture bilinearly, so a pixel whose
  square is entirely covered is never clipped;
- *touched* when its square meets the mesh at all (:func:`mesh_coverage_mask` ``rule="touch"``);
- *centred* when its centre ``(c+0.5, r+0.5)`` lies in the mesh (area estimates).

The rasteriser is exact, not sampled: a square meets the mesh boundary if and only if a
boundary segment has an endpoint in it or crosses one of its four sides, and the rest is an
even-odd test of the centre along each row. The union is taken from the boundary edges (edges
used by exactly one triangle), which is exact for a valid mesh (no overlaps).
"""

from __future__ import annotations

import numpy as np

#: Alpha at or above which a pixel is art that must never be clipped.
OPAQUE_ALPHA = 8

#: The open-source CLAUDE-SPINE mesher, figures as quoted in issue 4 (not measured by us).
PEER_CLAUDE_SPINE = {"waste": 0.09, "vertices": 76, "coverage": "misses some pixels"}


# --------------------------------------------------------------------------- rasteriser
def boundary_segments(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Segments of the mesh outline: edges used by exactly one triangle, in triangle direction.

    Returns
    -------
    ndarray, shape (E, 2, 2), float64
        ``[[x0, y0], [x1, y1]]`` per boundary edge.
    """
    b = _boundary_index_edges(np.asarray(triangles, dtype=np.int64).reshape(-1, 3))
    v = np.asarray(vertices, dtype=np.float64)
    return np.stack([v[b[:, 0]], v[b[:, 1]]], axis=1) if len(b) else np.zeros((0, 2, 2))


def loop_segments(loops) -> np.ndarray:
    """Segments of closed polygons given as a list of (n, 2) point arrays."""
    segs = [np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in loops if len(p) >= 2]
    return np.concatenate(segs) if segs else np.zeros((0, 2, 2))


def centres_inside(segments: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Even-odd test of every pixel centre against closed outline segments.

    Parameters
    ----------
    segments : ndarray, shape (E, 2, 2)
        Outline segments (hull and hole loops, in any order and orientation).
    shape : (H, W)

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    h, w = shape
    s = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    y0, y1 = s[:, 0, 1], s[:, 1, 1]
    x0, x1 = s[:, 0, 0], s[:, 1, 0]
    lo, hi = np.minimum(y0, y1), np.maximum(y0, y1)
    # rows r whose centre r+0.5 is in [lo, hi): half-open, so shared vertices count once
    r_start = np.clip(np.ceil(lo - 0.5), 0, h).astype(np.int64)
    r_stop = np.clip(np.ceil(hi - 0.5), 0, h).astype(np.int64)
    n = np.maximum(r_stop - r_start, 0)
    toggles = np.zeros((h, w + 1), dtype=np.int32)
    if n.sum():
        idx = np.repeat(np.arange(len(s)), n)
        rows = np.repeat(r_start, n) + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n))
        yc = rows + 0.5
        t = (yc - y0[idx]) / (y1[idx] - y0[idx])
        xc = x0[idx] + t * (x1[idx] - x0[idx])
        # pixels whose centre lies right of the crossing are toggled
        col = np.clip(np.floor(xc - 0.5).astype(np.int64) + 1, 0, w)
        np.add.at(toggles, (rows, col), 1)
    return (np.cumsum(toggles, axis=1)[:, :w] & 1).astype(bool)


def touched_pixels(segments: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Pixels whose closed square meets at least one segment (exact, conservative).

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    h, w = shape
    out = np.zeros((h, w), dtype=bool)
    s = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    if len(s) == 0:
        return out
    rows, cols = [], []
    # endpoints
    for p in (s[:, 0], s[:, 1]):
        rows.append(np.floor(p[:, 1]).astype(np.int64))
        cols.append(np.floor(p[:, 0]).astype(np.int64))
    # crossings of vertical grid lines x = k and horizontal grid lines y = k
    for ax in (0, 1):
        a0, a1 = s[:, 0, ax], s[:, 1, ax]
        b0, b1 = s[:, 0, 1 - ax], s[:, 1, 1 - ax]
        lo, hi = np.minimum(a0, a1), np.maximum(a0, a1)
        k0 = np.ceil(lo).astype(np.int64)
        n = np.maximum(np.floor(hi).astype(np.int64) - k0 + 1, 0)
        n[a0 == a1] = 0  # a segment lying on a grid line is covered by the other axis
        if not n.sum():
            continue
        idx = np.repeat(np.arange(len(s)), n)
        k = np.repeat(k0, n) + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n))
        t = (k - a0[idx]) / (a1[idx] - a0[idx])
        b = b0[idx] + t * (b1[idx] - b0[idx])
        bf = np.floor(b).astype(np.int64)
        on_line = b == bf
        for da in (-1, 0):
            for bb in (bf, np.where(on_line, bf - 1, bf)):
                a_idx = k + da
                if ax == 0:
                    cols.append(a_idx), rows.append(bb)
                else:
                    rows.append(a_idx), cols.append(bb)
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    ok = (r >= 0) & (r < h) & (c >= 0) & (c < w)
    out[r[ok], c[ok]] = True
    return out


def crossed_pixels(segments: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Pixels whose *open* square a segment passes through (exact).

    Each segment is cut at every grid line it crosses; every piece lies in one closed cell,
    and its midpoint is inside that cell's open square unless the piece runs along a grid
    line (then it only borders squares, which does not make them leave the mesh).
    """
    h, w = shape
    out = np.zeros((h, w), dtype=bool)
    s = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    if len(s) == 0:
        return out
    ts, ids = [np.zeros(len(s)), np.ones(len(s))], [np.arange(len(s))] * 2
    for ax in (0, 1):
        a0, a1 = s[:, 0, ax], s[:, 1, ax]
        lo, hi = np.minimum(a0, a1), np.maximum(a0, a1)
        k0 = np.ceil(lo).astype(np.int64)
        n = np.maximum(np.floor(hi).astype(np.int64) - k0 + 1, 0)
        n[a0 == a1] = 0
        if not n.sum():
            continue
        idx = np.repeat(np.arange(len(s)), n)
        k = np.repeat(k0, n) + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n))
        ts.append((k - a0[idx]) / (a1[idx] - a0[idx]))
        ids.append(idx)
    t = np.concatenate(ts)
    i = np.concatenate(ids)
    order = np.lexsort((t, i))
    t, i = t[order], i[order]
    same = i[1:] == i[:-1]
    tm = 0.5 * (t[1:] + t[:-1])[same]
    seg = i[1:][same]
    p = s[seg, 0] + tm[:, None] * (s[seg, 1] - s[seg, 0])
    f = np.floor(p)
    interior = (p[:, 0] != f[:, 0]) & (p[:, 1] != f[:, 1])
    c, r = f[interior, 0].astype(np.int64), f[interior, 1].astype(np.int64)
    ok = (r >= 0) & (r < h) & (c >= 0) & (c < w)
    out[r[ok], c[ok]] = True
    return out


def polygon_coverage_mask(segments: np.ndarray, shape: tuple[int, int], rule: str = "inside") -> np.ndarray:
    """:func:`mesh_coverage_mask` for a region given by its outline segments."""
    centre = centres_inside(segments, shape)
    if rule == "centre":
        return centre
    if rule == "inside":
        return centre & ~crossed_pixels(segments, shape)
    if rule == "touch":
        return centre | touched_pixels(segments, shape)
    raise ValueError(f"rule must be 'inside', 'touch' or 'centre', not {rule!r}")


def mesh_coverage_mask(vertices: np.ndarray, triangles: np.ndarray, shape: tuple[int, int],
                       rule: str = "inside") -> np.ndarray:
    """Rasterise a mesh onto the pixel grid, without anti-aliasing.

    Parameters
    ----------
    vertices : ndarray, shape (N, 2)
        Pixel coordinates (x right, y down).
    triangles : ndarray, shape (M, 3)
    shape : (H, W)
    rule : {"inside", "touch", "centre"}
        ``"inside"``: the pixel square lies entirely in the mesh (what :func:`coverage` uses);
        ``"touch"``: the pixel square meets the mesh; ``"centre"``: the pixel centre is in it.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    return polygon_coverage_mask(boundary_segments(vertices, triangles), shape, rule)


# --------------------------------------------------------------------------- measures
def opaque_mask(image: np.ndarray, alpha: int = OPAQUE_ALPHA) -> np.ndarray:
    """Pixels that are art: ``alpha >= alpha`` (all pixels of an RGB image)."""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 4:
        return image[:, :, 3] >= alpha
    return np.ones(image.shape[:2], dtype=bool)


def coverage(vertices, triangles, art: np.ndarray) -> float:
    """Share of art pixels whose square lies entirely inside the mesh (1.0 = nothing clipped).

    ``art`` is an (H, W) bool mask, e.g. :func:`opaque_mask`.
    """
    art = np.asarray(art, dtype=bool)
    n = int(art.sum())
    if n == 0:
        return 1.0
    inside = mesh_coverage_mask(vertices, triangles, art.shape, "inside")
    return float((inside & art).sum()) / n


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
    centre = mesh_coverage_mask(vertices, triangles, art.shape, "centre")
    return float(max(0.0, 1.0 - (centre & art).sum() / area))


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
    from .mesher.interior import edge_map, long_contours
    from .mesher.params import PAPER

    if mask is None:
        mask = opaque_mask(image, 129)
    edges = edge_map(image, mask, PAPER)
    out = np.zeros(mask.shape, dtype=np.uint8)
    import cv2
    for c in long_contours(edges, min_length):
        cv2.polylines(out, [c.astype(np.int32).reshape(-1, 1, 2)], False, 1, 1)
    return (out > 0) & (edges > 0)


def boundary_adherence(vertices, edge_pixels: np.ndarray, radius: float = 10.0) -> float:
    """Share of significant internal edge pixels with a mesh vertex within ``radius`` px.

    The paper (sec. 4.4) counts "significant internal edges that have a vertex within 10 px";
    we count per edge pixel, so that a long edge with one vertex at its end scores low.
    Returns 1.0 when the image has no significant internal edge.
    """
    import cv2

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
        loop = v[:hull]
        seg = {tuple(sorted((i, (i + 1) % hull))) for i in range(hull)}
        b = {tuple(sorted(x)) for x in _boundary_index_edges(t)}
        if not seg <= b:
            problems.append("the first `hull` vertices do not form a boundary loop")
        del loop
    return problems


def _boundary_index_edges(t: np.ndarray) -> np.ndarray:
    """Directed edges ``(i, j)`` used by exactly one triangle (either direction)."""
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[counts[inv.reshape(-1)] == 1]


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
    return {
        "coverage": coverage(v, t, art),
        "waste": waste(v, t, art),
        "boundary_adherence": boundary_adherence(v, edge_pixels),
        "angle_ratio": angle_ratio(v, t),
        "vertices": int(len(v)),
        "triangles": int(len(t)),
        "hull": int(getattr(mesh, "hull", 0)),
        "interior": int(len(v) - getattr(mesh, "hull", 0)),
        "problems": mesh_problems(v, t, getattr(mesh, "hull", None)),
    }
