"""``mesh_image``: the whole pipeline, image in, :class:`Mesh` out."""

from __future__ import annotations

import cv2
import numpy as np
import shapely

from ..errors import ImageError
from . import exterior, interior, triangulate
from .geometry import clip_loop_to_rect, inset_loop, segments_cross, signed_area, successors
from .mask import compute_mask
from .mesh import Mesh
from .params import PRESETS, MesherParams
from .raster import boundary_index_edges
from .worth import NotWorthMeshing, art_share_reason, hull_reason, islands_reason


def resolve_params(preset: str | MesherParams = "default", **overrides) -> MesherParams:
    """Preset name (or params) plus overrides -> :class:`MesherParams`."""
    if isinstance(preset, MesherParams):
        base = preset
    else:
        try:
            base = PRESETS[preset]
        except KeyError:
            raise ValueError(f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}") from None
    return base.with_overrides(**overrides) if overrides else base


def mesh_image(image: np.ndarray, preset: str | MesherParams = "default", mask: np.ndarray | None = None,
               **overrides) -> Mesh:
    """Turn one sprite image into a triangle mesh.

    Parameters
    ----------
    image : ndarray, shape (H, W, 4) or (H, W, 3), uint8
        Straight RGBA (or RGB) at its original size.
    preset : {"default", "paper"} or MesherParams
        See :mod:`spinemesh.mesher.params`.
    mask : ndarray, shape (H, W), bool, optional
        Foreground to use instead of computing one (e.g. from a segmentation model).
    **overrides
        Any :class:`MesherParams` field, e.g. ``density=2.0``, ``max_vertices=40``.

    Returns
    -------
    Mesh

    Raises
    ------
    ImageError
        If the image is not an (H, W, 3|4) uint8 array or has no foreground pixel.
    """
    p = resolve_params(preset, **overrides)
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] not in (3, 4) or image.dtype != np.uint8:
        raise ImageError(f"expected an (H, W, 3|4) uint8 image, got shape {image.shape} {image.dtype}")
    if mask is None:
        mask = compute_mask(image, p.mask_source, p.alpha_threshold)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != image.shape[:2]:
        raise ImageError(f"mask shape {mask.shape} differs from image shape {image.shape[:2]}")
    if not mask.any():
        raise ImageError("the image has no opaque pixel (alpha >= "
                         f"{p.alpha_threshold}): nothing to mesh")
    if p.style == "paper":
        mesh = _paper(image, mask, p)
    elif p.style == "default":
        mesh = _default(image, mask, p)
    else:
        raise ValueError(f"unknown mesher style {p.style!r}")
    return mesh


# --------------------------------------------------------------------------- paper
def _paper(image: np.ndarray, mask: np.ndarray, p: MesherParams) -> Mesh:
    h, w = mask.shape
    loops = exterior.paper_loops(mask, p.mask_blur_sigma, p.min_component_area, p.dp_epsilon_ratio, p.n_target)
    if not loops:
        raise ImageError(f"no foreground component of at least {p.min_component_area:g} px^2")
    ext = np.concatenate(loops)
    chains = interior.interior_chains(image, mask, p)
    inner = np.concatenate(chains) if chains else np.zeros((0, 2))
    pts, is_int = merge_close_points(np.vstack([ext, inner]),
                                     np.r_[np.zeros(len(ext), bool), np.ones(len(inner), bool)], p.triangulation_dedup)
    verts, tris = triangulate.delaunay_centroid_filter(pts, mask)
    return finish_mesh(verts, tris, is_int, np.zeros((0, 2), np.int64), w, h, preset="paper")


def merge_close_points(pts: np.ndarray, flags: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Drop each point closer than ``radius`` to an earlier kept point (paper sec. 3.4: 2 px).

    Parameters
    ----------
    pts : ndarray, shape (n, 2)
    flags : ndarray, shape (n,)
        Carried along with the points (e.g. "interior").
    radius : float
        Pixels; 0 keeps every point.

    Returns
    -------
    (pts, flags) of the kept points, in their order.
    """
    from scipy.spatial import cKDTree

    if radius <= 0 or len(pts) < 2:
        return pts, flags
    near = cKDTree(pts).query_pairs(radius, output_type="ndarray")
    near = near[np.hypot(*(pts[near[:, 0]] - pts[near[:, 1]]).T) < radius]  # strictly closer
    earlier: dict[int, list[int]] = {}
    for i, j in near.tolist():  # query_pairs gives i < j
        earlier.setdefault(j, []).append(i)
    kept = np.zeros(len(pts), bool)
    for i in range(len(pts)):
        kept[i] = not any(kept[j] for j in earlier.get(i, ()))
    return pts[kept], flags[kept]


# --------------------------------------------------------------------------- default
def _default(image: np.ndarray, mask: np.ndarray, p: MesherParams) -> Mesh:
    h, w = mask.shape
    # Huge images are analysed at an integer downscale s. The coverage mask is max-pooled, so
    # each low-res pixel square holds every full-res art pixel inside it, and a loop covering the
    # low-res squares covers the full-res ones exactly once scaled by s.
    s = max(1, int(np.ceil(max(h, w) / max(p.analysis_max_side, 16))))
    cover = _maxpool(mask, s)
    labels = None  # the pieces of cover: counted by rule 2, then bridged by the hull
    if p.min_saving is not None:  # keep-region rules 1 and 2, before any geometry
        reason = art_share_reason(mask, p.min_saving)
        if not reason:
            labels = exterior.pieces(cover)
            reason = islands_reason(cover, pixel_area=s * s, labels=labels)
        if reason:
            raise NotWorthMeshing(reason)
    density = max(p.density, 1e-6)
    eps = max(0.5, p.hull_tolerance * np.sqrt(float(cover.sum())) / density)
    if p.max_hull_tolerance > 0:  # large art: a few more hull vertices save many pixels
        eps = max(0.5, min(eps, p.max_hull_tolerance / s))
    loops = _hull_and_holes(cover, eps, p, s, labels)
    if s > 1:
        # the analysis grid may overhang the image by < s px: clip exactly at full size
        loops = [clip_loop_to_rect(loops[0] * s, w, h)] + [l * s for l in loops[1:]]
    if p.hull_inset > 0:
        loops[0] = _inset_hull(loops, p.hull_inset, w, h)
    if p.min_saving is not None:  # rule 3, before the interior edges and the triangulation
        reason = hull_reason(loops[0], w, h, p.min_saving)
        if reason:
            raise NotWorthMeshing(reason)
    ring = np.concatenate(loops)
    budget = p.max_vertices
    chains = []
    if p.max_segment > 0 and (budget is None or budget > len(ring)):
        chains = _interior(image, mask, p, s, ring, density, cover if s > 1 else None)
        chains = _drop_crossing(chains, loops)
        if budget is not None:
            chains = _fit_budget(chains, budget - len(ring))
    return _triangulate(loops, chains, p, w, h)


def _inset_hull(loops: list[np.ndarray], distance: float, w: int, h: int) -> np.ndarray:
    """The hull moved ``distance`` px inwards off the image border (``hull_inset``), or as it is.

    Kept as it is where the move is not clean (:func:`inset_loop`) or would touch a hole loop.
    """
    inset = inset_loop(loops[0], distance, w, h)
    if inset is None:
        return loops[0]
    if len(loops) > 1:
        hull = shapely.Polygon(inset)
        if not all(hull.contains(shapely.Polygon(hole)) for hole in loops[1:]):
            return loops[0]
    return inset


def _hull_and_holes(cover: np.ndarray, eps: float, p: MesherParams, s: int,
                    labels: tuple[int, np.ndarray] | None = None) -> list[np.ndarray]:
    """The covering hull and the hole loops, in analysis pixels, within ``max_vertices``.

    Over the budget, holes are given up first (last first), then the hull is simplified
    further (``eps`` x 1.5 per try) until the loops fit or cannot shrink. ``labels``:
    :func:`~.exterior.pieces` of ``cover``, when known.
    """
    budget = p.max_vertices
    hull, region = exterior.covering_hull(cover, eps, min_distance=p.min_vertex_distance / s, labels=labels)
    holes = exterior.hole_loops(region, cover, p.min_hole_area / (s * s), eps)
    while budget is not None and len(hull) + sum(map(len, holes)) > budget:
        if holes:
            holes = holes[:-1]
            continue
        if len(hull) <= 3:
            break
        eps *= 1.5
        new, region = exterior.covering_hull(cover, eps, min_distance=p.min_vertex_distance / s, labels=labels)
        if len(new) >= len(hull) and eps > 4 * max(cover.shape):
            break
        hull = new if len(new) < len(hull) else hull
    return [hull] + holes


def _triangulate(loops: list[np.ndarray], chains: list[np.ndarray], p: MesherParams, w: int, h: int) -> Mesh:
    """Constrained Delaunay of loops and chains, refined, without sliver-making chain vertices.

    A chain vertex almost on the line of two others can give a sliver triangle that would
    leave a T-junction (a crack when animated): that vertex is dropped and the points are
    triangulated again (at most four times).
    """
    density = max(p.density, 1e-6)
    n_loop = sum(map(len, loops))
    for _ in range(4):
        pts, is_int, edges = _assemble(loops, chains)
        n_steiner = _steiner_budget(p, len(pts), density)
        if p.max_vertices is not None:
            n_steiner = max(0, min(n_steiner, p.max_vertices - len(pts)))
        verts, tris, edges, holes = triangulate.constrained(pts, edges, loops, p.min_angle, n_steiner,
                                                            p.min_vertex_distance)
        middle = [i for i in _sliver_middles(verts, tris) if n_loop <= i < len(pts)]
        if not middle:
            break
        chains = _drop_chain_vertices(chains, [i - n_loop for i in middle])
    if len(verts) > len(pts):  # refinement points: interior unless they ended up on the hull
        is_int = np.r_[is_int, np.ones(len(verts) - len(pts), bool)]
    return finish_mesh(verts, tris, is_int, edges, w, h, preset="default", hole_triangles=holes)


def _assemble(loops: list[np.ndarray], chains: list[np.ndarray]):
    """Points (loops first, then chains), their interior flags and the constrained edges."""
    pts = np.concatenate(loops + chains)
    n_loops = sum(map(len, loops))
    is_int = np.r_[np.zeros(n_loops, bool), np.ones(len(pts) - n_loops, bool)]
    edges, start = [], 0
    for loop in loops:
        n = len(loop)
        edges += [(start + i, start + (i + 1) % n) for i in range(n)]
        start += n
    for c in chains:
        edges += [(start + i, start + i + 1) for i in range(len(c) - 1)]
        start += len(c)
    return pts, is_int, np.asarray(edges, dtype=np.int64).reshape(-1, 2)


def _sliver_middles(verts: np.ndarray, tris: np.ndarray, min_area: float = 1e-6) -> list[int]:
    """For each near-zero-area triangle, the vertex at its largest angle (the one "in between")."""
    a = verts[tris]
    sa = (a[:, 1, 0] - a[:, 0, 0]) * (a[:, 2, 1] - a[:, 0, 1]) - (a[:, 2, 0] - a[:, 0, 0]) * (a[:, 1, 1] - a[:, 0, 1])
    out = []
    for t in np.flatnonzero(np.abs(sa) <= 2 * min_area):
        p = a[t]
        lens = [np.hypot(*(p[(k + 1) % 3] - p[(k + 2) % 3])) for k in range(3)]
        out.append(int(tris[t][int(np.argmax(lens))]))  # opposite the longest side
    return sorted(set(out))


def _drop_chain_vertices(chains: list[np.ndarray], flat: list[int]) -> list[np.ndarray]:
    drop = set(flat)
    out, start = [], 0
    for c in chains:
        keep = [i for i in range(len(c)) if start + i not in drop]
        if keep:
            out.append(c[keep])
        start += len(c)
    return out


def _interior(image: np.ndarray, mask: np.ndarray, p: MesherParams, s: int, ring: np.ndarray,
              density: float, cover: np.ndarray | None = None) -> list[np.ndarray]:
    """Interior chains in full-size pixel coordinates.

    The edge detection (a bilateral filter costs ``d^2`` per pixel) runs on a copy whose longer
    side is at most ``interior_max_side``; lengths are scaled to match, so the chains are the
    same boundaries at the resolution that decides vertex spacing anyway.
    """
    h, w = mask.shape
    si = max(s, int(np.ceil(max(h, w) / p.interior_max_side))) if p.interior_max_side else s
    if si == 1:
        small, small_mask = image, mask
    else:
        size = (max(1, round(w / si)), max(1, round(h / si)))
        small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        # from the analysis-size cover when there is one: 1/s^2 of the pixels to read
        src = mask if cover is None else cover
        small_mask = cv2.resize(src.astype(np.uint8) * 255, size, interpolation=cv2.INTER_AREA) >= 128
    sx, sy = w / small_mask.shape[1], h / small_mask.shape[0]
    f = max(sx, sy)
    scaled = p.with_overrides(min_contour_length=p.min_contour_length / f, max_segment=p.max_segment / f,
                              dedup_radius=p.dedup_radius / f, border_distance=p.border_distance / f)
    taken = ring / [sx, sy]
    chains = interior.interior_chains(small, small_mask, scaled, scale=density, taken=taken)
    return [c * [sx, sy] for c in chains]


def _steiner_budget(p: MesherParams, n_points: int, density: float) -> int:
    """How many points the angle refinement may add: ``fill_ratio`` of the placed points."""
    if p.min_angle <= 0 or p.fill_ratio <= 0:
        return 0
    return int(min(p.max_fill_vertices * density, np.ceil(p.fill_ratio * n_points)))


def _maxpool(mask: np.ndarray, s: int) -> np.ndarray:
    """Block-wise "any" over ``s x s`` blocks of ``mask`` (H, W) bool (the last blocks padded
    with background; no padded copy when the blocks fill the mask)."""
    if s == 1:
        return mask
    h, w = mask.shape
    H, W = -(-h // s), -(-w // s)
    if H * s == h and W * s == w:
        pad = np.asarray(mask, bool).view(np.uint8)  # the same 0 and 1 bytes
    else:
        pad = np.zeros((H * s, W * s), np.uint8)
        pad[:h, :w] = mask
    if s <= 15:
        # OpenCV's area resize at an integer factor is the exact block mean; one art pixel in
        # a block of 255s gives at least 255 / 225 >= 1, so "> 0" is "any" (and ~10x faster)
        return cv2.resize(pad * np.uint8(255), (W, H), interpolation=cv2.INTER_AREA) > 0
    # reduce the contiguous axis first: much faster than one any() over two strided axes
    cols = pad.reshape(H * s, W, s).max(axis=2)
    return cols.reshape(H, s, W).max(axis=1).astype(bool)


def _drop_crossing(chains: list[np.ndarray], loops: list[np.ndarray]) -> list[np.ndarray]:
    """Split chains where a segment would cross a loop or an earlier chain's kept segment.

    All crossings are found at once (two spatial-index queries), then the chains are walked
    in order, so a segment is dropped only for the segments kept before it.
    """
    if not chains:
        return []
    walls = np.concatenate([np.stack([l, successors(l)], axis=1) for l in loops])
    pieces = [np.stack([c[:-1], c[1:]], axis=1) for c in chains]
    segs = np.concatenate(pieces) if any(len(x) for x in pieces) else np.zeros((0, 2, 2))
    hits_loop = segments_cross(segs, walls).any(axis=1)
    hits_chain = segments_cross(segs, segs)
    kept = np.zeros(len(segs), bool)
    out, k = [], 0
    for c in chains:
        run = [c[0]]
        for b in c[1:]:
            if hits_loop[k] or (hits_chain[k] & kept).any():
                # the chain would cut a loop or another chain: it goes on as a new run
                out.append(np.asarray(run))
                run = [b]
            else:
                kept[k] = True
                run.append(b)
            k += 1
        out.append(np.asarray(run))
    return out


def _fit_budget(chains: list[np.ndarray], room: int) -> list[np.ndarray]:
    """Keep the longest chains that fit in ``room`` vertices."""
    if room <= 0:
        return []
    order = sorted(range(len(chains)), key=lambda i: (-len(chains[i]), i))
    keep, used = [], 0
    for i in order:
        if used + len(chains[i]) <= room:
            keep.append(i)
            used += len(chains[i])
    return [chains[i] for i in sorted(keep)]


# --------------------------------------------------------------------------- common
def finish_mesh(verts: np.ndarray, tris: np.ndarray, is_int: np.ndarray, edges: np.ndarray,
                w: int, h: int, preset: str, hole_triangles: np.ndarray | None = None) -> Mesh:
    """The :class:`Mesh` of a triangulation: unused vertices dropped, the outer loop first.

    Triangles are oriented positively and degenerate ones dropped; constrained edges that the
    triangulation split are replaced by their pieces. ``hole_triangles`` (triangles filling
    the mesh's holes, for a fully triangulated hull) are carried along, re-indexed.
    """
    tris = _oriented(verts, tris)
    holes = _oriented(verts, hole_triangles if hole_triangles is not None else np.zeros((0, 3), np.int64))
    loop = _outer_loop(tris, verts)
    used = np.union1d(np.unique(tris), np.unique(holes))
    rest = np.setdiff1d(used, loop)
    order = np.concatenate([loop, rest]).astype(np.int64)
    remap = np.full(len(verts), -1, np.int64)
    remap[order] = np.arange(len(order))
    new_edges = remap[edges] if len(edges) else np.zeros((0, 2), np.int64)
    new_edges = new_edges[(new_edges >= 0).all(axis=1)]
    # edges that the triangulation split are replaced by their pieces: keep only real triangle edges
    tri_new = remap[tris]
    te = np.concatenate([tri_new[:, [0, 1]], tri_new[:, [1, 2]], tri_new[:, [2, 0]]])
    te_set = {tuple(sorted(e)) for e in te.tolist()}
    new_edges = np.array([e for e in new_edges.tolist() if tuple(sorted(e)) in te_set], dtype=np.int64).reshape(-1, 2)
    hull_edges = [[i, (i + 1) % len(loop)] for i in range(len(loop))]
    have = {tuple(sorted(e)) for e in new_edges.tolist()}
    extra = [e for e in hull_edges if tuple(sorted(e)) not in have]
    if extra:
        new_edges = np.vstack([np.asarray(extra, dtype=np.int64).reshape(-1, 2), new_edges])
    interior_flag = is_int[order].copy()
    interior_flag[:len(loop)] = False
    return Mesh(vertices=verts[order], triangles=tri_new, hull=len(loop), edges=new_edges,
                width=w, height=h, is_interior=interior_flag, info={"preset": preset},
                hole_triangles=remap[holes])


def _oriented(verts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Triangles (M, 3) with positive signed area; degenerate ones (|area| <= 1e-9) dropped."""
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    a = verts[tris]
    sa = (a[:, 1, 0] - a[:, 0, 0]) * (a[:, 2, 1] - a[:, 0, 1]) - (a[:, 2, 0] - a[:, 0, 0]) * (a[:, 1, 1] - a[:, 0, 1])
    tris = np.where((sa < 0)[:, None], tris[:, [0, 2, 1]], tris)
    return tris[np.abs(sa) > 1e-9]


def _outer_loop(tris: np.ndarray, verts: np.ndarray) -> np.ndarray:
    """The boundary loop of largest area, in the triangles' direction, as vertex indices.

    With several loops (islands of the paper preset) the largest is the hull; the others stay
    in the mesh as ordinary vertices.
    """
    if len(tris) == 0:
        return np.zeros(0, np.int64)
    b = boundary_index_edges(tris)
    nxt: dict[int, list[int]] = {}
    for i, j in sorted(b.tolist()):
        nxt.setdefault(i, []).append(j)
    used = set()
    loops = []
    for start in sorted(nxt):
        for j0 in nxt[start]:
            if (start, j0) in used:
                continue
            loop = [start]
            used.add((start, j0))
            cur = j0
            while cur != start and len(loop) <= len(b):
                loop.append(cur)
                options = [j for j in nxt.get(cur, []) if (cur, j) not in used]
                if not options:
                    break
                j = options[0]
                used.add((cur, j))
                cur = j
            if cur == start:
                loops.append(loop)
    if not loops:
        return np.zeros(0, np.int64)
    loops = [part for l in loops for part in _simple_parts(l)]
    best = max(loops, key=lambda l: (signed_area(verts[l]), -min(l)))
    k = best.index(min(best))  # start at the lowest index: deterministic
    return np.asarray(best[k:] + best[:k], dtype=np.int64)


def _simple_parts(loop: list[int]) -> list[list[int]]:
    """Split a boundary walk that passes a vertex twice (a pinch) into simple loops."""
    seen: dict[int, int] = {}
    for j, v in enumerate(loop):
        if v in seen:
            i = seen[v]
            return _simple_parts(loop[i:j]) + _simple_parts(loop[:i] + loop[j:])
        seen[v] = j
    return [loop] if len(loop) >= 3 else []
