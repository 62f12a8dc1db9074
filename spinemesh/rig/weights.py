"""Bone weights of mesh vertices: bounded biharmonic weights (Jacobson et al., SIGGRAPH 2011).

Bones are handles: the points along each bone's segment (origin to origin + length along
its x axis) that lie on the mesh are fixed to weight 1 for that bone and 0 for the others;
every other point gets, bone by bone, the smoothest weights (minimal Laplacian energy
``w^T L M^-1 L w``, libigl's operator) bounded to [0, 1]. This is what the Spine editor's
automatic weights are credited to. Each bone's bound-constrained QP is solved by PIQP's
sparse interior-point solver (:func:`bounded_biharmonic`); libigl's own active-set ``bbw``
stays available as ``method="bbw-libigl"``: on 2,000-point refinements of artists' meshes it
took about 3 times as long and left its active set unfinished after its 50 steps on 30 of
195 meshes (weights outside [0, 1], clipped).

A mesh as drawn by an artist or by the mesher has few vertices (often 10 to 50), too few
for a smooth solution or for handles to fall on bone segments. The weights are therefore
solved on a *refinement* of the mesh: every triangle is cut into ``k * k`` similar triangles
(shared edges get the same points), which keeps the domain exactly, including concave
outlines and pieces joined only at a vertex. The original vertices are vertices of the
refinement, so their weights are read off directly. The refinement has up to
``REFINED_VERTEX_BUDGET`` points: replayed against the artists' own weights and animations
(``benchmarks/bench_weights_offline.py``), 1,600 points bend closer to them than 600 did
(geometric-mean error ratio to rigid binding 0.877 against 0.935), at 1.6 times the time of
libigl's ``bbw`` on 600; 2,000 points gain a little more (0.865) at 2.3 times.

Per vertex, weights are then made sparse for the runtime: at most ``max_bones`` bones,
weights below ``min_weight`` dropped, the rest renormalised to sum 1.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the annotation only: scipy is imported where a solve needs it
    import scipy.sparse

#: Upper bound on the vertices of the refinement the weights are solved on (speed).
REFINED_VERTEX_BUDGET = 1600

#: PIQP's absolute and relative tolerance (:func:`bounded_biharmonic`, on the mesh scaled to unit size).
SOLVER_TOLERANCE = 1e-7

#: Most triangles per original triangle side (``k``).
MAX_SUBDIVISION = 16

#: Falloff of ``method="geodesic"`` (:func:`geodesic_weights`): each bone weighs ``d ** -GEODESIC_FALLOFF``
#: for the point's graph distance ``d`` along the art to the bone's handles, rows normalised.
GEODESIC_FALLOFF = 8.0


def refine(vertices: np.ndarray, triangles: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Cut every triangle into ``k * k`` similar triangles, sharing points along shared edges.

    Parameters
    ----------
    vertices : ndarray, shape (N, 2)
    triangles : ndarray, shape (M, 3)
    k : int
        Points per side minus one; 1 returns the mesh unchanged.

    Returns
    -------
    points : ndarray, shape (P, 2)
        The first N are the original vertices, in order.
    faces : ndarray, shape (M * k * k, 3)
    """
    vertices = np.asarray(vertices, float).reshape(-1, 2)
    given = np.asarray(triangles, np.int64).reshape(-1, 3)
    n, m = len(vertices), len(given)
    grid = [(a, b, k - a - b) for a in range(k + 1) for b in range(k + 1 - a)]
    at = {g[:2]: i for i, g in enumerate(grid)}
    local = []
    for a in range(k):
        for b in range(k - a):
            local.append((at[a + 1, b], at[a, b + 1], at[a, b]))
            if a + b + 1 < k:
                local.append((at[a + 1, b], at[a + 1, b + 1], at[a, b + 1]))
    if not m:
        return vertices.copy(), np.zeros((0, 3), np.int64)
    # Each grid point as integer weights (summing to k) on its triangle's corners, the corners
    # in increasing order and a corner named twice (a degenerate triangle) merged: a point on
    # an edge then reads the same (corner, corner, weight) from every triangle with that edge.
    order = np.argsort(given, axis=1, kind="stable")
    corner = np.take_along_axis(given, order, 1)[:, None, :].repeat(len(grid), 1)   # (M, G, 3)
    weight = np.take_along_axis(np.asarray(grid, np.int64)[None].repeat(m, 0), order[:, None, :], 2)
    for s in (2, 1):
        same = (corner[:, :1, s] == corner[:, :1, s - 1])
        weight[..., s - 1] += np.where(same, weight[..., s], 0)
        weight[..., s] = np.where(same, 0, weight[..., s])
    on = weight > 0
    count = on.sum(axis=2).ravel()
    first, last = on.argmax(axis=2)[..., None], 2 - on[..., ::-1].argmax(axis=2)[..., None]
    c0 = np.take_along_axis(corner, first, 2).ravel()
    c1 = np.take_along_axis(corner, last, 2).ravel()
    w0 = np.take_along_axis(weight, first, 2).ravel()
    ids = np.where(count == 1, c0, -1)  # an original vertex keeps its index
    # New points are numbered in the order a walk over the triangles and their grids meets
    # them: an edge point at its first meeting, an inner point (in one triangle only) at its own.
    met = np.arange(len(count))
    edge = np.flatnonzero(count == 2)
    span = max(n, int(given.max()) + 1)
    _, head, back = np.unique((c0[edge] * span + c1[edge]) * (k + 1) + w0[edge],
                              return_index=True, return_inverse=True)
    met[edge] = edge[head][back.reshape(-1)]
    new = np.flatnonzero(count >= 2)
    heads = np.unique(met[new])
    ids[new] = n + np.searchsorted(heads, met[new])
    w = weight.reshape(-1, 3)[heads]
    added = (vertices[corner.reshape(-1, 3)[heads]] * w[..., None]).sum(axis=1) / k
    faces = ids.reshape(m, len(grid))[:, np.asarray(local, np.int64)]
    return np.concatenate([vertices, added]), faces.reshape(-1, 3)


def subdivision_for(triangles: int) -> int:
    """The ``k`` of :func:`refine` that keeps the refinement within the vertex budget."""
    k = int(np.sqrt(2 * REFINED_VERTEX_BUDGET / max(triangles, 1)))
    return int(np.clip(k, 1, MAX_SUBDIVISION))


def segment_distances(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance of each point (P, 2) to each segment (S, 2, 2) (to its origin where it has zero
    length), shape (P, S).

    Examples
    --------
    >>> bone, point_bone = [[0.0, 0.0], [2.0, 0.0]], [[3.0, 1.0], [3.0, 1.0]]
    >>> segment_distances(np.array([[0.0, 1.0], [3.0, 0.0]]), np.array([bone, point_bone]))
    array([[1., 3.],
           [1., 1.]])
    """
    points = np.asarray(points, float).reshape(-1, 2)
    segments = np.asarray(segments, float).reshape(-1, 2, 2)
    a, ab = segments[:, 0], segments[:, 1] - segments[:, 0]                 # (S, 2)
    denom = np.matmul(ab[:, None, :], ab[:, :, None])[:, 0, 0]               # (S,)
    along = np.matmul(points[None] - a[:, None], ab[:, :, None])[..., 0]     # (S, P)
    t = np.where(denom[:, None] == 0, 0.0, np.clip(along / np.where(denom == 0, 1.0, denom)[:, None], 0.0, 1.0))
    return np.linalg.norm(points[None] - (a[:, None] + t[..., None] * ab[:, None]), axis=2).T


def _components(n: int, faces: np.ndarray) -> np.ndarray:
    """Connected component label of each of ``n`` points, through shared faces."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    g = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def handles(points: np.ndarray, faces: np.ndarray, segments: np.ndarray, spacing: float,
            reach: float, prefer: int | None = None) -> dict[int, int]:
    """Which refined point is fixed to which bone: ``{point: bone column}``.

    A point within ``spacing / 2`` of a bone's segment is a handle of the nearest such bone.
    A bone whose segment misses the art but passes within ``reach`` of it gets the nearest
    point as its one handle; a bone farther away gets none and ends with weight 0 (its
    motion says little about this art). A connected piece of the mesh with no handle at all
    follows bone ``prefer`` (the slot's bone) if given, else the bone nearest to it (one
    handle on its nearest point), so that every piece has a solution.
    """
    used = np.unique(faces)
    dist = segment_distances(points[used], segments)  # (U, B)
    near = dist.min(axis=1) <= spacing / 2
    if dist.shape[1] > 1:
        # A point as near to two bones (a joint) is left free: the solve blends it.
        two = np.sort(dist, axis=1)[:, :2]
        near &= two[:, 1] - two[:, 0] > 1e-6 * max(spacing, 1e-9)
    out = {int(used[i]): int(dist[i].argmin()) for i in np.flatnonzero(near)}
    have = set(out.values())
    for bone in range(len(segments)):
        r = int(dist[:, bone].argmin())
        if bone not in have and dist[r, bone] <= reach and int(used[r]) not in out:
            out[int(used[r])] = bone
    labels = _components(len(points), faces)[used]
    for piece in np.unique(labels):
        rows = np.flatnonzero(labels == piece)
        if any(int(used[r]) in out for r in rows):
            continue
        if prefer is not None:
            r, bone = int(dist[rows, prefer].argmin()), prefer
        else:
            r, bone = np.unravel_index(int(dist[rows].argmin()), dist[rows].shape)
        out[int(used[rows[r]])] = int(bone)
    return out


def _clean_faces(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces with a usable area (degenerate ones make the cotangent Laplacian infinite)."""
    p = points[faces]
    area = 0.5 * np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                        - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    scale = float(np.ptp(points, axis=0).max()) if len(points) else 1.0
    return faces[area > 1e-10 * max(scale, 1.0) ** 2]


def solve_weights(vertices: np.ndarray, triangles: np.ndarray, segments: np.ndarray,
                  method: str = "bbw", reach: float = 0.0, prefer: int | None = None) -> np.ndarray:
    """Dense weights of each vertex for each bone.

    Parameters
    ----------
    vertices : ndarray, shape (N, 2)
        Setup-pose world positions of the mesh vertices.
    triangles : ndarray, shape (M, 3)
    segments : ndarray, shape (B, 2, 2)
        Each bone's world segment (origin, tip); a zero-length bone is a point.
    reach : float
        A bone whose segment misses the art by at most this much still gets a handle
        (see :func:`handles`); world units.
    prefer : int, optional
        Column of the bone that art reached by no bone follows (the slot's bone).
    method : {"bbw", "bbw-libigl", "harmonic", "biharmonic", "geodesic"}
        Bounded biharmonic weights (:func:`bounded_biharmonic`; harmonic weights where its
        solver fails); the same problem solved by libigl's active-set ``bbw`` (slower, stops
        after 50 active-set steps); harmonic weights (a linear solve, like heat diffusion);
        unbounded biharmonic weights clipped to [0, 1]; or weights falling off with the
        distance along the art to each bone's handles (:func:`geodesic_weights`, no solve).

    Returns
    -------
    ndarray, shape (N, B)
        Non-negative, rows summing to 1; a bone with no handle has a zero column. A vertex
        in no usable triangle follows the nearest bone.
    """
    vertices = np.asarray(vertices, float)
    segments = np.asarray(segments, float).reshape(-1, 2, 2)
    n, nb = len(vertices), len(segments)
    if nb == 1:
        return np.ones((n, 1))
    tris = np.asarray(triangles, np.int64).reshape(-1, 3)
    points, faces = refine(vertices, tris, subdivision_for(len(tris)))
    faces = _clean_faces(points, faces)
    nearest = segment_distances(vertices, segments).argmin(axis=1)
    out = np.eye(nb)[nearest]
    if len(faces) == 0:
        return out
    # The refinement's typical edge: handles are the points within half of it of a bone.
    e = points[faces[:, [1, 2, 0]]] - points[faces]
    spacing = float(np.median(np.linalg.norm(e, axis=2)))
    fixed = handles(points, faces, segments, spacing, reach, prefer)
    w = _solve(points, faces, fixed, nb, method)
    used = np.zeros(len(points), bool)
    used[np.unique(faces)] = True
    ok = used[:n] & np.isfinite(w[:n]).all(axis=1)
    out[ok] = w[:n][ok]
    out = np.clip(out, 0.0, None)
    total = out.sum(axis=1, keepdims=True)
    bad = total[:, 0] <= 0
    out[bad] = np.eye(nb)[nearest[bad]]
    return out / out.sum(axis=1, keepdims=True)


#: Most distinct inputs :func:`solve_weights_once` keeps the weights of, per process (the oldest
#: dropped first): the 45 skeletons of five slot-game libraries made 1,091 solves of 702.
REMEMBERED_SOLVES = 4096

_remembered: dict[tuple, np.ndarray] = {}


def solve_weights_once(vertices: np.ndarray, triangles: np.ndarray, segments: np.ndarray,
                       method: str = "bbw", reach: float = 0.0, prefer: int | None = None) -> np.ndarray:
    """:func:`solve_weights`, each distinct input solved once per process: a copy of the weights
    solved before for the same bytes of every input (vertices, triangles, segments, method,
    reach, preferred bone) and the same refinement limits.

    The same art on the same bones recurs: one region in several skins, and the skeletons of a
    library built on one rig (the characters or symbols of a game) sharing art at one place.
    The weights are a function of these inputs alone, so the output is the same byte for byte.
    """
    v, t = np.ascontiguousarray(vertices, float), np.ascontiguousarray(triangles, np.int64)
    s = np.ascontiguousarray(segments, float)
    key = (v.shape, v.tobytes(), t.shape, t.tobytes(), s.shape, s.tobytes(), method, float(reach), prefer,
           REFINED_VERTEX_BUDGET, MAX_SUBDIVISION)
    w = _remembered.get(key)
    if w is None:
        w = solve_weights(v, t, s, method, reach, prefer)
        if REMEMBERED_SOLVES > 0:
            while len(_remembered) >= REMEMBERED_SOLVES:
                del _remembered[next(iter(_remembered))]
            _remembered[key] = w
    return w.copy()


def _solve(points: np.ndarray, faces: np.ndarray, fixed: dict[int, int], nb: int, method: str) -> np.ndarray:
    """The chosen method on the refinement; rows of points in no face are left at 0."""
    if method == "geodesic":
        return geodesic_weights(points, faces, fixed, nb)
    import igl

    # libigl wants every point in some face: solve on the used points only.
    used = np.unique(faces)
    remap = np.full(len(points), -1, np.int64)
    remap[used] = np.arange(len(used))
    v = np.ascontiguousarray(points[used])
    f = np.ascontiguousarray(remap[faces])
    b = np.array(sorted(fixed), np.int64)
    bc = np.zeros((len(b), nb))
    bc[np.arange(len(b)), [fixed[i] for i in b]] = 1.0
    b = np.ascontiguousarray(remap[b])
    if method in ("harmonic", "biharmonic"):
        # Unbounded k-harmonic weights; negative lobes are clipped by the caller.
        w = igl.harmonic(v, f, b, bc, 1 if method == "harmonic" else 2)
    elif method == "bbw-libigl":
        try:
            w = igl.bbw(v, f, b, bc, partition_unity=False, max_iter=50)
        except RuntimeError:
            # libigl's active-set solver gives up on some meshes ("failed to compute weights").
            w = igl.harmonic(v, f, b, bc, 1)
    else:
        w = bounded_biharmonic(v, f, b, bc)
        if w is None:
            # The QP solver did not converge; harmonic weights always exist, so the mesh
            # is still weighted.
            w = igl.harmonic(v, f, b, bc, 1)
    out = np.zeros((len(points), nb))
    out[used] = w
    return out


def geodesic_weights(points: np.ndarray, faces: np.ndarray, fixed: dict[int, int], nb: int,
                     falloff: float | None = None) -> np.ndarray:
    """Weights falling off with the distance along the art to each bone's handles.

    In the spirit of geodesic voxel binding (Dionne and de Lasa, "Geodesic Voxel Binding for
    Production Character Meshes", SCA 2013), on the refinement instead of voxels: the shortest
    path along the refinement's edges (Euclidean lengths, Dijkstra from all of a bone's handles
    at once) from every point to each bone, then ``w_j = d_j ** -falloff``, rows normalised.
    A path never crosses a gap in the art, so a point across a gap from a bone's handles weighs
    less on it than one at the same straight-line distance along the art. No solve: one
    Dijkstra per bone.

    Parameters
    ----------
    points : ndarray, shape (P, 2)
    faces : ndarray, shape (F, 3)
        Triangles of usable area (:func:`_clean_faces`).
    fixed : dict of int to int
        ``{point: bone column}`` (:func:`handles`); a handle weighs 1 on its bone.
    nb : int
        Bones (columns).
    falloff : float, optional
        The exponent; :data:`GEODESIC_FALLOFF` by default.

    Returns
    -------
    ndarray, shape (P, nb)
        Rows of points in some face in [0, 1] summing to 1 (a point no handle reaches follows
        nothing: 0); a bone with no handle has a zero column; rows of points in no face are 0.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    p = float(GEODESIC_FALLOFF if falloff is None else falloff)
    n = len(points)
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    e = np.unique(e[:, 0] * n + e[:, 1])
    a, b = e // n, e % n
    length = np.linalg.norm(points[a] - points[b], axis=1)
    keep = length > 0  # a zero-length edge would read as no edge: its ends are one place
    # One source node per bone (numbered after the points) with an edge to each of its handles,
    # far shorter than any of the art's: one Dijkstra call gives every bone's distances. Those
    # edges lead out of the source only, or a path would hop between two handles of a bone.
    tiny = 1e-9 * float(length[keep].min()) if keep.any() else 1.0
    ends = np.array(sorted(fixed), np.int64)
    bone = np.array([fixed[i] for i in ends], np.int64)
    rows = np.concatenate([a[keep], b[keep], n + bone])
    cols = np.concatenate([b[keep], a[keep], ends])
    lengths = np.concatenate([length[keep], length[keep], np.full(len(ends), tiny)])
    graph = coo_matrix((lengths, (rows, cols)), shape=(n + nb, n + nb)).tocsr()
    dist = np.full((n, nb), np.inf)
    have = np.unique(bone)
    if len(have):
        dist[:, have] = dijkstra(graph, directed=True, indices=n + have)[:, :n].T - tiny
    dist[ends, bone] = 0.0
    # Distances relative to the nearest bone's keep the powers finite; a handle (distance 0)
    # weighs 1 on its own bone alone.
    nearest = dist.min(axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(np.isfinite(dist), (nearest / dist) ** p, 0.0)
    at = np.flatnonzero(nearest[:, 0] == 0)
    w[at] = 0.0
    w[at, dist[at].argmin(axis=1)] = 1.0
    total = w.sum(axis=1, keepdims=True)
    w = np.divide(w, total, out=np.zeros_like(w), where=total > 0)
    used = np.zeros(n, bool)
    used[np.unique(faces)] = True
    w[~used] = 0.0
    return w


def bounded_biharmonic(v: np.ndarray, f: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray | None:
    """Bounded biharmonic weights, one bound-constrained QP per bone (Jacobson et al. 2011, eq. 3).

    Minimises ``w^T Q w`` with ``Q = L M^-1 L`` (libigl's cotangent Laplacian ``L`` and
    Voronoi mass matrix ``M``, the operator of libigl's ``bbw``), ``w[b] = bc`` and
    ``0 <= w <= 1``, each bone on its own (no partition of unity: the caller normalises
    rows). PIQP's sparse interior-point solver does the solving: about 20 factorisations
    per bone (median 20 on artists' meshes), where libigl's active set refactorises once per
    step and, capped at 50 steps, ends outside [0, 1] on 15% of 2,000-point refinements.
    Exact active-set methods (projected Newton, primal-dual) move the bounds' front about a
    ring of points a step and cost more than PIQP even from good starts, and the unconstrained
    minimiser is never inside [0, 1] (``benchmarks/bench_weight_solves.py``).

    Three facts of the problem save solves exactly: a bone with no handle has weight 0
    everywhere (0 is feasible with energy 0); when one bone alone has handles its weight is 1
    everywhere (``Q 1 = 0`` since ``L 1 = 0``: 1 keeps the bounds and handles at energy 0, and
    every connected piece has a handle, so nothing else has it; the solver's answer, a hair
    under 1, normalised per vertex by :func:`solve_weights`, was exactly that 1 already); and
    when exactly two bones have handles the second bone's weights are one minus the first's
    (``1 - w`` keeps the bounds and handles, and has the same energy as ``w``).

    Parameters
    ----------
    v : ndarray, shape (P, 2)
        Points, each in some face of ``f``.
    f : ndarray, shape (F, 3)
    b : ndarray, shape (H,)
        Handle points; every connected piece of the mesh needs one.
    bc : ndarray, shape (H, B)
        Each handle's weights, one 1 per row.

    Returns
    -------
    ndarray, shape (P, B), or None
        None when the solver reports no solution for some bone (or the operator is not finite).
    """
    n, nb = len(v), bc.shape[1]
    free = np.setdiff1d(np.arange(n), b)
    w = np.zeros((n, nb))
    w[b] = bc
    bones = [j for j in range(nb) if bc[:, j].any()]
    if not len(free) or not bones:
        return w
    if len(bones) == 1:  # the art reached by one bone's handles alone follows it (docstring)
        w[free, bones[0]] = 1.0
        return w
    qp = biharmonic_qp(v, f, free, b)
    if qp is None:
        return None
    q_free, q_fixed = qp
    solved = bones[:1] if len(bones) == 2 else bones
    x = solve_box_qps(q_free, np.asarray(q_fixed @ bc[:, solved]))
    if x is None:
        return None
    w[np.ix_(free, solved)] = x
    if len(bones) == 2:
        w[free, bones[1]] = 1.0 - w[free, bones[0]]
    return w


def biharmonic_qp(v: np.ndarray, f: np.ndarray, free: np.ndarray, b: np.ndarray):
    """The quadratic form of :func:`bounded_biharmonic` split between free and fixed points.

    Parameters
    ----------
    v : ndarray, shape (P, 2)
        Points, each in some face of ``f``.
    f : ndarray, shape (F, 3)
    free, b : ndarray of int, shapes (P - H,) and (H,)
        The free points and the handles, together every point once.

    Returns
    -------
    tuple of sparse matrices, or None
        ``Q[free][:, free]`` (CSC, shape (P - H, P - H)) and ``Q[free][:, b]`` (CSR, shape
        (P - H, H)) of ``Q = L M^-1 L`` on the points scaled to unit size; None when the
        operator is not finite (a degenerate face).
    """
    import igl
    from scipy import sparse

    # Q scales as 1 / size^2 (L is scale-free in 2-D, M is an area): solve at unit size so
    # the solver's absolute tolerances mean the same on every mesh.
    v = (v - v.mean(axis=0)) / max(float(np.ptp(v, axis=0).max()), 1e-12)
    lap = igl.cotmatrix(v, f).tocsc()
    mass = igl.massmatrix(v, f, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    if not (np.all(np.isfinite(lap.data)) and np.all(mass > 0)):
        return None
    rows = (lap @ sparse.diags(1.0 / mass) @ lap).tocsr()[free]
    return rows[:, free].tocsc(), rows[:, b]


def solve_box_qps(q: scipy.sparse.csc_matrix, linear: np.ndarray, tolerance: float | None = None,
                  **settings) -> np.ndarray | None:
    """Minimise ``x^T q x / 2 + c^T x`` subject to ``0 <= x <= 1`` for each column ``c`` of ``linear``.

    PIQP's sparse interior-point solver, set up once (``q`` is shared) and updated per column.

    Parameters
    ----------
    q : sparse matrix, shape (F, F)
        Symmetric positive definite.
    linear : ndarray, shape (F, K)
    tolerance : float, optional
        PIQP's absolute and relative tolerance; default ``SOLVER_TOLERANCE``.
    **settings
        Further PIQP settings by name (benchmarks compare them).

    Returns
    -------
    ndarray, shape (F, K), or None
        None when PIQP reports no solution for some column.
    """
    import piqp
    from scipy import sparse

    solver = piqp.SparseSolver()
    solver.settings.verbose = False
    solver.settings.eps_abs = solver.settings.eps_rel = SOLVER_TOLERANCE if tolerance is None else tolerance
    for name, value in settings.items():
        setattr(solver.settings, name, value)
    out = np.zeros(linear.shape)
    for i in range(linear.shape[1]):
        c = np.ascontiguousarray(linear[:, i])
        if i == 0:
            solver.setup(sparse.triu(q, format="csc"), c, x_l=np.zeros(len(c)), x_u=np.ones(len(c)))
        else:
            solver.update(c=c)
        if solver.solve() != piqp.PIQP_SOLVED:
            return None
        out[:, i] = solver.result.x
    return out


def sparsify(weights: np.ndarray, max_bones: int = 4, min_weight: float = 0.01) -> np.ndarray:
    """At most ``max_bones`` weights per row, none below ``min_weight``, rows summing to 1.

    Parameters
    ----------
    weights : ndarray, shape (N, B)
        Non-negative weights whose rows sum to 1.

    Returns
    -------
    ndarray, shape (N, B)
        The heaviest bone of a row always stays.
    """
    w = np.asarray(weights, float).copy()
    if w.shape[1] > max_bones:
        order = np.argsort(-w, axis=1, kind="stable")
        w[np.arange(len(w))[:, None], order[:, max_bones:]] = 0.0
    heaviest = w.argmax(axis=1)
    keep = w >= min_weight
    keep[np.arange(len(w)), heaviest] = True
    w = np.where(keep, w, 0.0)
    return w / w.sum(axis=1, keepdims=True)
