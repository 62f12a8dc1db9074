"""Which bones a mesh is bound to.

``keep``: the bones it is bound to now (its slot's bone for an unweighted mesh).

``rule`` (``--bones rule``; it was ``auto`` until a learned choice measured better), from the
setup pose: the slot's bone, plus every bone whose segment (origin to origin + length along
the bone's x axis) passes over the art, where the art is the mesh's triangles in world space
(within ``OVER_ART`` of them, a share of their size).
Typically these are the parent and the children across the joints the art spans. Not
chosen automatically: the root bone (it moves the whole skeleton, never a part);
zero-length bones (points: effects and controls more often than parts); control bones that constraints aim at (animators'
handles); bones that only some skins activate (unless this attachment's skin does); and
bones whose setup transform is not exact (see :mod:`.bones`). Of the bones that qualify,
only those joined to the slot bone through the bone tree by qualifying bones are kept: art
of another part overlapping this one (a rider on a mount, a weapon over a body) hangs off
elsewhere in the tree. When more than ``MAX_AUTO_BONES`` remain, the nearest to the slot
bone in the tree are kept, then those with the longest segment over the art.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .bones import bone_segments

#: A bone counts as near the art within this share of the art's bounding-box diagonal (the
#: weights give such a bone a handle on the art; see :func:`.weights.handles`).
NEAR = 0.05

#: A bone is chosen when its segment passes within this share of the art's diagonal. Measured
#: on the rig replay (1,211 artist meshes): bones only *near* the art (0.05) are more often
#: bones the artists did not bind than bones they did; requiring the segment on the art
#: brings the median error ratio to the rigid baseline from 1.51 to 1.33 (offline replay of
#: the artists' animations, 847 meshes drawn in the setup pose).
OVER_ART = 0.0

#: Most bones chosen automatically for one mesh.
MAX_AUTO_BONES = 8


@dataclass
class Choice:
    """Bones chosen for one mesh, in skeleton order, and why each (or why left out)."""

    bones: list[int]
    why: dict[int, str]
    left_out: dict[int, str]


#: Point-edge (and point-triangle) pairs :func:`distance_to_art` measures at once: small enough
#: for the temporaries to stay in cache (20,000 at once was 8% slower on the training meshes'
#: candidates, 200,000 20% slower).
PAIRS_AT_ONCE = 5_000


def outline_edges(world: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The edges (E, 2) of the triangles that may bound their union: every edge but those two
    triangles share from opposite sides (art on both sides of it).

    Outside the art, the nearest point of the art lies on one of these, so they are all the
    edges :func:`distance_to_art` measures (on an editor's mesh, its hull and little more). An
    edge of a fold (two triangles on the same side of it) is kept.
    """
    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    opposite = np.concatenate([tri[:, 2], tri[:, 0], tri[:, 1]])     # each edge's third corner
    lo, hi = edges.min(axis=1), edges.max(axis=1)
    _, inverse, count = np.unique(lo * (int(tri.max()) + 1) + hi, return_inverse=True, return_counts=True)
    a, b, c = world[lo], world[hi], world[opposite]
    side = np.sign((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    same_side = np.bincount(inverse, weights=side, minlength=len(count)) != 0
    flat = np.bincount(inverse, weights=side == 0, minlength=len(count)) > 0
    return edges[((count != 2) | same_side | flat)[inverse]]


#: Triangles each point is tested against at once by :func:`inside_triangles`, the largest
#: first: a point found inside one is not tested against the rest (on the 2,962 distance
#: measurements of ``--weights auto`` on the 45 skeletons of ``bench_upgrade_weights.py``, 8
#: took 1.7 s of CPU where 32 took 1.9 s and 64 2.6 s; all triangles at once, 3.2 s).
TRIANGLES_AT_ONCE = 8


def distance_to_art(points: np.ndarray, world: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance of each point (P, 2) to the union of the mesh's triangles (0 on or inside one), world units.

    0 for the points inside a triangle (:func:`inside_triangles`, tested only for those within
    the art's bounding box); for the others, the distance to the nearest of the
    :func:`outline_edges` (:func:`distance_to_outline`). Most of the points the bone choices
    measure lie on the art (bones over it): they are not measured against the edges. No
    triangles: every distance is infinite. :class:`ArtDistance` measures several sets of
    points against one art.

    Examples
    --------
    >>> square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    >>> points = np.array([[1.0, 1.0], [2.0, 1.0], [5.0, 2.0], [1.0, -1.0]])
    >>> distance_to_art(points, square, np.array([[0, 1, 2], [0, 2, 3]]))
    array([0., 0., 3., 1.])
    """
    return ArtDistance(world, triangles)(points)


class ArtDistance:
    """:func:`distance_to_art` of one mesh's art (``world`` (N, 2), ``triangles`` (T, 3)), for
    several sets of points: what depends on the art alone (its triangles' corners and box, their
    order by area, the :func:`outline_edges`) is prepared once, on the first set that needs it
    (the learned bone choice measures each mesh's art twice: the rule's samples, then its own).
    Each point's distance is the same, to the bit, whatever other points are measured with it.
    """

    def __init__(self, world: np.ndarray, triangles: np.ndarray):
        self.world = world
        self.tri = np.asarray(triangles, np.int64).reshape(-1, 3)
        self.corner = world[self.tri]                                       # (T, 3, 2)
        if len(self.tri):
            self.lo, self.hi = self.corner.reshape(-1, 2).min(axis=0), self.corner.reshape(-1, 2).max(axis=0)

    @cached_property
    def _largest_first(self) -> tuple:
        return _largest_first(self.corner)

    @cached_property
    def _outline(self) -> tuple:
        return _outline_arrays(self.world, self.tri)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Distance (P,) of each point (P, 2) to the art, world units (:func:`distance_to_art`)."""
        points = np.asarray(points, float).reshape(-1, 2)
        out = np.full(len(points), np.inf)
        if not len(points) or not len(self.tri):
            return out
        test = np.flatnonzero((points >= self.lo).all(axis=1) & (points <= self.hi).all(axis=1))
        inside = np.zeros(len(points), bool)
        if len(test):
            inside[test[_inside_largest_first(points[test], self._largest_first)]] = True
        out[inside] = 0.0
        rest = np.flatnonzero(~inside)
        if len(rest):
            out[rest] = _outline_distance(points[rest], self._outline)
        return out


def distance_to_outline(points: np.ndarray, world: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance of each point (P, 2) to the nearest of the :func:`outline_edges` of the
    triangles (T, 3) (at least one), world units: outside the art, its distance to the art.

    By the point-to-segment formula GEOS uses, so that distances match shapely's to the last
    bit. Edges run down the temporaries and points across them (a minimum over a few rows is
    fast), at most :data:`PAIRS_AT_ONCE` pairs at a time.
    """
    return _outline_distance(points, _outline_arrays(world, triangles))


def _outline_arrays(world: np.ndarray, triangles: np.ndarray) -> tuple:
    """The :func:`outline_edges`' ends and spans as columns (E, 1), for :func:`_outline_distance`."""
    e = outline_edges(world, triangles)
    ax, ay = world[e[:, 0], :1], world[e[:, 0], 1:]                   # (E, 1)
    bx, by = world[e[:, 1], :1], world[e[:, 1], 1:]
    abx, aby = bx - ax, by - ay
    return ax, ay, bx, by, abx, aby, abx * abx + aby * aby


def _outline_distance(points: np.ndarray, outline: tuple) -> np.ndarray:
    """:func:`distance_to_outline` of the points (P, 2), the outline's :func:`_outline_arrays` given."""
    ax, ay, bx, by, abx, aby, length2 = outline
    out = np.empty(len(points))
    step = max(1, PAIRS_AT_ONCE // len(ax))
    for s in range(0, len(points), step):
        px, py = points[s:s + step, 0], points[s:s + step, 1]
        dx, dy = px - ax, py - ay                                       # (E, P)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (dx * abx + dy * aby) / length2                         # where along the edge, 0..1
            across = np.abs((dx * aby - dy * abx) / length2) * np.sqrt(length2)
        to_a = np.sqrt(dx * dx + dy * dy)
        to_b = np.sqrt((px - bx) ** 2 + (py - by) ** 2)
        d = np.where((r <= 0) | (length2 == 0), to_a, np.where(r >= 1, to_b, across))
        out[s:s + step] = d.min(axis=0)
    return out


def inside_triangles(points: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """Whether each point (P, 2) lies in one of the triangles ``corner`` (T, 3, 2) (P,) bool; on
    an edge within rounding counts as in.

    The triangles are tested :data:`TRIANGLES_AT_ONCE` at a time, the largest first, and a point
    found in one is not tested against the others: whether it lies in any of them does not
    depend on which ones it was tested against after the first it lies in.
    """
    return _inside_largest_first(points, _largest_first(corner))


def _largest_first(corner: np.ndarray) -> tuple:
    """The triangles ``corner`` (T, 3, 2), largest first, as :func:`_inside_largest_first` reads
    them: corners and edges, x and y apart, (3, T, 1) each."""
    cx, cy = corner[..., 0], corner[..., 1]                             # (T, 3)
    area = np.abs((cx[:, 1] - cx[:, 0]) * (cy[:, 2] - cy[:, 0]) - (cy[:, 1] - cy[:, 0]) * (cx[:, 2] - cx[:, 0]))
    order = np.argsort(-area, kind="stable")
    cx, cy = cx[order].T[..., None], cy[order].T[..., None]             # (3, T, 1)
    ex, ey = cx[[1, 2, 0]] - cx, cy[[1, 2, 0]] - cy                     # each triangle's edges in turn
    return cx, cy, ex, ey


def _inside_largest_first(points: np.ndarray, triangles: tuple) -> np.ndarray:
    """:func:`inside_triangles` of the points (P, 2), the triangles' :func:`_largest_first` given."""
    cx, cy, ex, ey = triangles
    count = cx.shape[1]
    found = np.zeros(len(points), bool)
    block = min(count, TRIANGLES_AT_ONCE)
    step = max(1, PAIRS_AT_ONCE // block)
    for s in range(0, len(points), step):
        idx = np.arange(s, min(s + step, len(points)))
        for b in range(0, count, block):
            px, py = points[idx, 0], points[idx, 1]
            at = slice(b, b + block)
            u, v = ex[:, at] * (py - cy[:, at]), ey[:, at] * (px - cx[:, at])   # (3, block, P)
            cross = u - v
            # on an edge within rounding counts as on it: a point on an edge two triangles share
            # is in one of them, and on the outline is on the art
            slack = 1e-13 * (np.abs(u) + np.abs(v))
            hit = ((cross >= -slack).all(axis=0) | (cross <= slack).all(axis=0)).any(axis=0)
            found[idx[hit]] = True
            idx = idx[~hit]
            if not len(idx):
                break
    return found


def rule_samples(bones, world: np.ndarray, triangles: np.ndarray, near: float,
                 samples: int = 65, art: ArtDistance | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distances to the art that :func:`lengths_on_art` measures its bones by (``art``: the
    :class:`ArtDistance` of ``world`` and ``triangles``, when the caller has it already).

    Returns
    -------
    ids : ndarray of int, shape (B,)
        The bones whose segment's bounding box meets the art's grown by ``near``, in order.
    point : ndarray of bool, shape (B,)
        Zero-length bones (points): measured at their origin only.
    distance : ndarray, shape (B, samples)
        World units, 0 on the art: ``samples`` evenly spaced points from origin to tip (a
        point bone's row is its origin's distance throughout).
    """
    lo, hi = world.min(axis=0) - near, world.max(axis=0) + near
    segs = bone_segments(bones)
    meets = ~((segs.max(axis=1) < lo).any(axis=1) | (segs.min(axis=1) > hi).any(axis=1))
    idx = np.flatnonzero(meets)
    # a zero-length bone is measured at one point, not ``samples``: sampled like the others
    # (as :func:`.learned.segment_samples` does), the rule took 1.7x as long on the corpus
    point = np.array([bones[i].length == 0 for i in idx], bool)
    a, b = segs[idx, 0], segs[idx, 1]
    t = np.linspace(0, 1, samples)[None, :, None]
    sampled = (a[~point][:, None] + t * (b - a)[~point][:, None]).reshape(-1, 2)
    art = art if art is not None else ArtDistance(world, triangles)
    d = art(np.concatenate([sampled, a[point]]))
    distance = np.empty((len(idx), samples))
    distance[~point] = d[:len(sampled)].reshape(-1, samples)
    distance[point] = d[len(sampled):, None]
    return idx, point, distance


def lengths_on_art(bones, world: np.ndarray, triangles: np.ndarray, near: float,
                   samples: int = 65, measured: tuple | None = None) -> dict[int, float]:
    """Each bone's length over the art, for the bones that reach the art; a bone missing it is absent.

    The length over the art is the segment's length times the share of ``samples`` evenly
    spaced points of it within ``near`` of the art; a zero-length bone on the art has 0.

    All bones are measured in one pass over their sample points (a rig of hundreds of bones
    near the art would otherwise take one distance computation per bone). A bone whose
    segment's bounding box misses the art's (grown by ``near``) is rejected without measuring.
    ``measured``: :func:`rule_samples` of these arguments, when the caller has them already.
    """
    if not len(bones):
        return {}
    idx, point, distance = measured if measured is not None else rule_samples(bones, world, triangles, near, samples)
    segs = bone_segments(bones)[idx]
    a, b = segs[:, 0], segs[:, 1]
    on_segment = distance[~point] <= near
    span = np.linalg.norm((b - a)[~point], axis=1)
    # a bone scaled to nothing is a point: on the art it counts as ``near``
    length = np.where(span > 0, span * on_segment.mean(axis=1), np.where(on_segment[:, 0], near, 0.0))
    out = {int(i): float(x) for i, x in zip(idx[~point], length) if x > 0}
    out.update({int(i): 0.0 for i, c in zip(idx[point], distance[point, 0] <= near) if c})
    return out


def rule_near(world: np.ndarray) -> float:
    """How near the art (world units) a bone's segment passes to count as over it: :data:`OVER_ART`
    of the diagonal of the art's box (``world``, (N, 2))."""
    return OVER_ART * float(np.linalg.norm(np.ptp(world, axis=0)))


def _largest_group(bones, slot_bone: int, over: dict[int, float], touching: set[int]) -> int | None:
    """The top bone of the group of bones on the art, below ``slot_bone``, with the most length over it.

    A group is a set of bones on the art (``touching``) joined through parent and child
    links among themselves; ``over`` maps each bone that may be chosen to its length over
    the art, and only those count.
    """
    best, best_total = None, 0.0
    for i in touching:
        if bones[i].parent in touching:
            continue  # not the top of its group
        j = i
        while j is not None and j != slot_bone:
            j = bones[j].parent
        if j is None:
            continue  # not below the slot bone
        group, stack = {i}, [i]
        while stack:
            for c in bones[stack.pop()].children:
                if c in touching and c not in group:
                    group.add(c)
                    stack.append(c)
        total = sum(over.get(g, 0.0) for g in group)
        if total > best_total:
            best, best_total = i, total
    return best


def choose_by_rule(bones, slot_bone: int, world: np.ndarray, triangles: np.ndarray,
                   skin_bones: set[int], measured: tuple | None = None) -> Choice:
    """The rule (module docstring, ``--bones rule``) for a mesh with setup world vertices ``world`` (N, 2).

    ``measured``: :func:`rule_samples` at :func:`rule_near`, when the caller has them already.
    """
    why: dict[int, str] = {}
    left_out: dict[int, str] = {}
    on_art = lengths_on_art(bones, world, triangles, rule_near(world), measured=measured)

    scored = []
    touching = set()  # every bone on the art, chosen or not: the tree is walked through them
    for bone in bones:
        length = None if bone.index == slot_bone else on_art.get(bone.index)
        if length is None:
            continue
        touching.add(bone.index)
        if bone.length == 0:
            left_out[bone.index] = "zero-length bone: a point (effects, controls), not a part the art bends with"
        elif bone.parent is None:
            left_out[bone.index] = "root bone: moves the whole skeleton"
        elif bone.target_of:
            left_out[bone.index] = f"control bone: target of the {bone.target_of}"
        elif not bone.exact:
            left_out[bone.index] = bone.why
        elif bone.skin_required and bone.index not in skin_bones:
            left_out[bone.index] = "only active in other skins"
        else:
            scored.append((-length, bone.index))
    # Keep the bones connected to the slot bone through the bone tree by bones that are also
    # on the art: overlapping art of another part (a rider over a mount, a weapon over a body,
    # an effect over a character) hangs off elsewhere in the tree.
    over = {i: -neg for neg, i in scored}
    depth = {slot_bone: 0}
    frontier = [slot_bone]
    if slot_bone not in on_art and over:
        # The slot bone is elsewhere (often the root, for art bound to a whole limb or body
        # chain): the art follows the group of bones below it that covers most of it.
        top = _largest_group(bones, slot_bone, over, touching)
        if top is not None:
            depth[top] = 1
            frontier = [top]
    while frontier:
        nxt = []
        for i in frontier:
            b = bones[i]
            for j in b.children + ([b.parent] if b.parent is not None else []):
                # A point or control bone on the art joins bones without being chosen (a hip).
                if j in touching and j not in depth:
                    depth[j] = depth[i] + 1
                    nxt.append(j)
        frontier = nxt
    ranked = sorted((depth[i], -over[i], i) for i in over if i in depth)
    for i in over:
        if i not in depth:
            left_out[i] = "over the art, but not joined to the slot bone through bones on the art"
    for rank, (_, neg, i) in enumerate(ranked):
        if rank + 1 >= MAX_AUTO_BONES:
            left_out[i] = f"more than {MAX_AUTO_BONES} bones qualify; farther from the slot bone in the tree"
            continue
        why[i] = f"segment over the art ({-neg:.1f} units)"
    why[slot_bone] = "slot bone"
    return Choice(sorted(why), why, left_out)
