"""Binding mesh attachments to bones, exactly in the setup pose.

A weighted mesh stores, per vertex, its bone count, then per bone: the bone's index, the
vertex's position in that bone's local space, and the weight. The runtime draws the vertex
at ``sum(weight * M_bone @ local)``. Writing ``local = M_bone^-1 @ p`` with ``p`` the
vertex's setup-pose world position, and weights that sum to exactly 1, the weighted mesh
is drawn where the mesh was in the setup pose, whatever the weights are. ``M_bone`` comes
from :mod:`.bones`, which follows the runtime; a bone whose setup transform it cannot
reproduce is never bound to.

Numbers are rounded for the JSON export (positions to what moves the vertex 1e-4 world
units at most, weights to 1e-4 with the heaviest taking the remainder so that each vertex's
weights still sum to 1), and the binding is proved before it is written: drawn from the numbers
as written (and as a runtime of 32-bit floats reads them) the vertices must lie where they were.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SpineMeshError
from ..skeleton_check import vertices_problem


@dataclass
class MeshVertices:
    """A mesh attachment's vertices: unweighted ``(N, 2)`` local positions, or bone influences."""

    count: int
    local: np.ndarray | None = None                      # (N, 2) in the slot bone's space
    influences: list[list[tuple[int, float, float, float]]] = field(default_factory=list)

    @property
    def weighted(self) -> bool:
        return self.local is None

    def bones(self) -> list[int]:
        return sorted({b for inf in self.influences for b, *_ in inf})


def parse_vertices(att: dict, bone_count: int) -> MeshVertices:
    """Read a mesh attachment's ``vertices`` (the JSON layout, also what the binary reader gives).

    Raises
    ------
    SpineMeshError
        When the list does not match ``uvs`` or names a bone that does not exist.
    """
    uvs, verts = att.get("uvs"), att.get("vertices")
    if not isinstance(uvs, list) or not isinstance(verts, list) or len(uvs) % 2:
        raise SpineMeshError("mesh has no uvs/vertices lists")
    n = len(uvs) // 2
    if len(verts) == 2 * n:
        try:
            return MeshVertices(n, local=np.asarray(verts, float).reshape(n, 2))
        except (ValueError, TypeError, OverflowError) as e:  # no number (a path's, which no load checked)
            raise SpineMeshError(f"vertices do not parse: {e}") from None
    try:  # one walk of the layout for every reader: the one made when the skeleton is read
        problem = vertices_problem(verts, n, bone_count)
    except (ValueError, TypeError, OverflowError) as e:  # an attachment not checked at load
        problem = f"weighted vertices do not parse: {e}"
    if problem:
        raise SpineMeshError(problem)
    try:  # a value that is no number (text, a list, false), in a list no load checked (a path's)
        return MeshVertices(n, influences=_influences(verts, n))
    except (ValueError, TypeError, OverflowError, IndexError) as e:
        raise SpineMeshError(f"weighted vertices do not parse: {e}") from None


def _influences(verts: list, n: int) -> list[list[tuple[int, float, float, float]]]:
    """The ``n`` vertices of a weighted ``vertices`` list, each as its (bone, x, y, weight) influences."""
    out, i = [], 0
    for _ in range(n):
        k = int(verts[i])
        out.append([(int(verts[i + 1 + 4 * j]), float(verts[i + 2 + 4 * j]), float(verts[i + 3 + 4 * j]),
                     float(verts[i + 4 + 4 * j])) for j in range(k)])
        i += 1 + 4 * k
    return out


def mesh_triangles(att: dict, count: int) -> np.ndarray:
    """A mesh attachment's ``triangles`` as (T, 3) vertex indices, each below ``count``.

    Raises
    ------
    SpineMeshError
        When the list is empty, not whole triangles (a length that is not a multiple of 3), or
        holds an index that is not one of the ``count`` vertices: files from other tools hold such
        lists, and the runtimes read them as they come.
    """
    try:
        flat = np.asarray(att.get("triangles", []), float).ravel()
    except (ValueError, TypeError) as e:
        raise SpineMeshError(f"triangles do not parse: {e}") from None
    if not len(flat) or len(flat) % 3 or not np.isfinite(flat).all() or (flat != np.round(flat)).any() \
            or flat.min() < 0 or flat.max() >= count:
        raise SpineMeshError("triangles do not index the vertices")
    return flat.astype(np.int64).reshape(-1, 3)


def deformed(mesh: MeshVertices, deform) -> MeshVertices:
    """``mesh`` with an animation's deform applied, as the runtimes apply it: unweighted, the
    deform holds the vertices' local positions (2N numbers); weighted, an offset added to each
    bone influence's local position (2 numbers per influence, in order)."""
    d = np.asarray(deform, float).reshape(-1, 2)
    if not mesh.weighted:
        return MeshVertices(mesh.count, local=d[:mesh.count])
    out = MeshVertices(mesh.count)
    k = 0
    for entry in mesh.influences:
        row = []
        for b, x, y, w in entry:
            dx, dy = d[k] if k < len(d) else (0.0, 0.0)
            row.append((b, x + float(dx), y + float(dy), w))
            k += 1
        out.influences.append(row)
    return out


def _apply(m: np.ndarray, xy: np.ndarray) -> np.ndarray:
    return xy @ m[:, :2].T + m[:, 2]


def setup_world(mesh: MeshVertices, worlds: list[np.ndarray], slot_bone: int) -> np.ndarray:
    """World positions, shape (N, 2), of the vertices in the setup pose, as the runtime draws them."""
    if not mesh.weighted:
        return _apply(worlds[slot_bone], mesh.local)
    out = np.zeros((mesh.count, 2))
    # the j-th influence of every vertex at once, j after j: each vertex's terms are added in
    # its own order, and each position is a (1, 2) row times its bone's matrix, as one at a time
    for j in range(max(map(len, mesh.influences), default=0)):
        at = [v for v, entry in enumerate(mesh.influences) if len(entry) > j]
        bone, x, y, w = zip(*(mesh.influences[v][j] for v in at))
        m = np.array([worlds[b] for b in bone], float).reshape(-1, 2, 3)
        xy = np.column_stack([x, y])[:, None, :]
        out[at] += np.array(w)[:, None] * (np.matmul(xy, m[:, :, :2].transpose(0, 2, 1))[:, 0] + m[:, :, 2])
    return out


def rounded_weights(row) -> list[float]:
    """Weights (a row: ndarray or list of floats) rounded to 1e-4 that still sum to 1: the
    heaviest (the first of equals) takes the remainder."""
    row = [float(x) for x in row]
    w = [round(x, 4) for x in row]
    top = max(range(len(row)), key=row.__getitem__)
    w[top] = round(1.0 - sum(x for i, x in enumerate(w) if i != top), 4)
    return w


#: Farthest, in world units, a bound vertex may be drawn from its setup position (:func:`bind`'s
#: proof), beside a millionth of the position's own size (what a runtime's 32-bit floats can hold).
BIND_TOLERANCE = 1e-3


def local_decimals(m: np.ndarray) -> int:
    """Decimals a position in the space of a bone of world transform ``m`` (shape (2, 3)) is
    rounded to: the fewest, and 4 at least, that move the drawn vertex 1e-4 world units at most
    (a bone scaled by 1e6 holds a 240-unit mesh in 2.4e-4; 4 decimals drew it at the bone's
    origin). Rounding to ``d`` decimals moves a position ``sqrt(2) / 2 * 10**-d`` at most, which
    the bone stretches by its largest scale: 4 decimals hold up to a scale of ``sqrt(2)``, so the
    bones of ordinary rigs (a scale of 1 read as 1.00000001 from a .skel's 32-bit floats, or
    1.0000000000000002 from a turned bone's norm) keep 4.

    Examples
    --------
    >>> local_decimals(np.array([[1.0, 0, 5], [0, 1, 0]])), local_decimals(np.array([[1e6, 0, 0], [0, 2, 0]]))
    (4, 10)
    >>> local_decimals(np.array([[0.6, -0.8, 0], [0.8, 0.6, 0]]) * 1.00000001), local_decimals(np.diag([3.0, 1.0, 0])[:2])
    (4, 5)
    """
    scale = float(np.linalg.norm(m[:, :2], 2)) / math.sqrt(2)
    return 4 + max(0, math.ceil(math.log10(scale))) if math.isfinite(scale) and scale > 1 else 4


def _binding_error(world: np.ndarray, vertices: list, worlds: list[np.ndarray]) -> float:
    """Farthest a vertex of the weighted ``vertices`` list is drawn from ``world`` (N, 2), its
    positions read as written and as 32-bit floats (the binary format, and the JSON readers of
    the C, C++, C# and libGDX runtimes)."""
    mesh = MeshVertices(len(world), influences=_influences(vertices, len(world)))
    single = MeshVertices(mesh.count, influences=[[(b, float(np.float32(x)), float(np.float32(y)), w)
                                                   for b, x, y, w in row] for row in mesh.influences])
    return max(float(np.abs(setup_world(m, worlds, 0) - world).max()) for m in (mesh, single))


def bind(world: np.ndarray, weights: np.ndarray, bone_ids: list[int], worlds: list[np.ndarray]) -> list:
    """The JSON ``vertices`` list of a weighted mesh.

    Parameters
    ----------
    world : ndarray, shape (N, 2)
        Setup-pose world positions of the vertices.
    weights : ndarray, shape (N, B)
        Sparse weights (rows sum to 1) over ``bone_ids``.
    bone_ids : list of int
        Skeleton index of each weight column.
    worlds : list of ndarray (2, 3)
        Setup world transform of every bone of the skeleton.

    Returns
    -------
    list
        Per vertex: bone count, then (bone index, local x, local y, weight) per bone.

    Raises
    ------
    SpineMeshError
        When a vertex has no weight, a number is not finite, or the list would draw a vertex
        farther than :data:`BIND_TOLERANCE` from where it is (a bone near no scale at all).
    """
    local, decimals = [], [local_decimals(worlds[b]) for b in bone_ids]
    for b in bone_ids:
        m = worlds[b]
        inv2 = np.linalg.inv(m[:, :2])
        # every vertex as a (1, 2) row times the bone's matrix: the same product, to the bit, as
        # one vertex at a time (one (N, 2) matrix product rounds some positions differently)
        local.append(_apply(np.c_[inv2, -inv2 @ m[:, 2]], world[:, None, :])[:, 0].tolist())
    out: list = []
    for v, row in enumerate(np.asarray(weights, float).tolist()):
        cols = [c for c, x in enumerate(row) if x > 0]
        if not cols:  # no bone to follow (a NaN row): this mesh alone fails, with a reason
            raise SpineMeshError(f"vertex {v} has no positive bone weight")
        keep = [(c, w) for c, w in zip(cols, rounded_weights([row[c] for c in cols])) if w > 0]
        out.append(len(keep))
        for c, w in keep:
            x, y = local[c][v]
            out += [int(bone_ids[c]), round(x, decimals[c]), round(y, decimals[c]), w]
    if not all(math.isfinite(x) for x in out):
        raise SpineMeshError("binding produced a non-finite number")
    error = _binding_error(world, out, worlds)
    if not error <= BIND_TOLERANCE + 1e-6 * float(np.abs(world).max(initial=0.0)):
        raise SpineMeshError(f"bound to its bones it would be drawn {error:.3g} units from where it is "
                             "in the setup pose")
    return out
