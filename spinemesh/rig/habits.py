"""A project's binding habits, from its artist-weighted meshes: features for the ``learned`` bone choice.

Which bones an artist binds depends on the studio's habits as much as on the rig: some bind
the slot's bone to every mesh, some never bind a point, some bind a chain down to its last
bone, some one bone per part. A project being upgraded often already holds meshes its artists
weighted, and those show the habits. This module tallies them (:func:`tally`, one vector per
weighted mesh, from the same candidate features the per-bone model reads,
:data:`.learned.FEATURES`) and turns the tally of a project's *other* weighted meshes into
:data:`HABIT_FEATURES` for each candidate of a mesh being bound (:func:`habit_features`):

- per kind of candidate (its place in the tree relative to the slot's bone, and whether it is
  a point, over the art or beside it; its place alone; its
  constraint role; whether the ``rule`` takes it), the share of such candidates the project's
  artists bound;
- whether they bind the slot's bone, how many bones a mesh gets, how many against the bones
  over its art;
- how many weighted meshes the habits come from;
- for the set stage (:mod:`.bone_sets`), the shapes of the artists' whole sets
  (:data:`SET_PATTERNS`: how many bones, the slot's bone alone, every bone over the art, the
  ``rule``'s set, with a point, an ancestor or a bone below the slot's bone, ...), and the sets
  bound by the meshes on the same slot bone of the same skeleton (:meth:`ProjectHabits.neighbours`),
  or on its mirror image (:func:`mirror_bones`: the same name on the other side), their sets
  moved across by their places in the bone tree (:func:`mirror_set`).

Each share is smoothed toward the rate over every training project (the *prior*, shipped in
the model) with :data:`PSEUDO_COUNT` made-up candidates or meshes: a project with no weighted
mesh gets the prior itself, one with many its own rates.

A tally is a flat vector (:data:`TALLY_SIZE`): tallies of several meshes add up, and leaving a
mesh out is a subtraction.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

#: Habit features, in the order of the columns appended to the per-bone features.
HABIT_FEATURES = (
    "habit_kind", "habit_relation", "habit_role", "habit_rule", "habit_slot_bound", "habit_bones",
    "habit_bones_per_on_art", "habit_meshes",
)

#: Made-up candidates (for a share of candidates) or meshes (for a mesh-level habit) at the
#: prior's rate added to a project's own: with fewer real ones, the prior weighs more.
PSEUDO_COUNT = 5.0

#: The groupings of candidates whose bound share is a habit, each with its number of kinds
#: (:func:`candidate_kinds`).
GROUPINGS = (("kind", 18), ("relation", 5), ("role", 3), ("rule", 2))

#: Where each grouping's kinds start in a tally (each kind: candidates seen, candidates bound).
_OFFSETS = np.cumsum([0] + [2 * n for _, n in GROUPINGS])

#: Mesh-level entries after the candidate kinds: meshes, meshes whose slot bone could be
#: bound, of those the meshes binding it, the artist's bones, bones per bone over the art,
#: meshes whose artist's bones are all candidates (their set's :data:`SET_PATTERNS` follow).
_MESHES, _SLOT_SEEN, _SLOT_BOUND, _BONES, _PER_ON_ART, _SETS_SEEN = range(int(_OFFSETS[-1]), int(_OFFSETS[-1]) + 6)

#: The shapes of a whole bone set the set stage compares with the project's artists' sets
#: (:func:`set_patterns`). Measured held out (set stage with and without them, the same
#: per-bone probabilities): exact bone sets 32.3% -> 34.1%.
SET_PATTERNS = (
    "one bone", "two bones", "three bones", "four or five bones", "six bones or more", "the slot bone alone",
    "every bone over the art", "only bones over the art and the slot bone", "the rule's set", "a point",
    "an ancestor of the slot bone", "a bone below the slot bone",
)

#: Where the patterns' counts start in a tally.
_PATTERNS = _SETS_SEEN + 1

#: Length of a tally vector.
TALLY_SIZE = _PATTERNS + len(SET_PATTERNS)

#: Places in the tree and states of the ``kind`` kinds: the relations, with the slot bone's
#: children apart from the bones farther below (artists differ most there).
PLACES = ("slot bone", "ancestor of the slot bone", "child of the slot bone", "farther below the slot bone",
          "sibling of the slot bone", "elsewhere in the tree")
STATES = ("a point", "over the art", "beside the art")

#: Relations to the slot's bone, in the order of the ``relation`` kinds.
RELATIONS = ("slot bone", "ancestor of the slot bone", "below the slot bone", "sibling of the slot bone",
             "elsewhere in the tree")


def _columns(names: tuple[str, ...]) -> dict[str, int]:
    return {f: i for i, f in enumerate(names)}


def candidate_kinds(features: np.ndarray, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Each candidate's kind in every grouping of :data:`GROUPINGS`.

    Parameters
    ----------
    features : ndarray, shape (C, F)
        Candidates' per-bone features, columns named by ``names`` (:data:`.learned.FEATURES`).

    Returns
    -------
    dict of str to ndarray of int, shape (C,)
        ``relation`` (0 slot bone, 1 ancestor, 2 below it, 3 sibling, 4 elsewhere: :data:`RELATIONS`),
        ``kind`` (:data:`PLACES` times three, plus 0 for a point, 1 for a bone over the art, 2
        for one beside it: :data:`STATES`), ``role`` (0 none, 1 moved by a
        constraint, 2 a constraint's target), ``rule`` (1 when the ``rule`` takes it).
    """
    f = np.asarray(features, float).reshape(-1, len(names))
    key = (tuple(names), f.shape, f.tobytes())
    last, kinds = _KINDS[0]
    if last == key:
        return kinds
    col = _columns(names)
    relation = np.select([f[:, col["is_slot_bone"]] == 1, f[:, col["is_ancestor"]] == 1,
                          f[:, col["is_descendant"]] == 1, f[:, col["is_sibling"]] == 1], [0, 1, 2, 3], 4)
    role = np.where(f[:, col["is_control"]] == 1, 2, np.where(f[:, col["is_constrained"]] == 1, 1, 0))
    # below the slot bone: its children apart from the bones farther down (artists differ most there)
    place = np.where(relation == 2, np.where(f[:, col["tree_distance"]] <= 1, 2, 3),
                     np.where(relation > 2, relation + 1, relation))
    state = np.where(f[:, col["is_point"]] == 1, 0, np.where(f[:, col["over_art_per_diag"]] > 0, 1, 2))
    out = {"kind": 3 * place + state, "relation": relation, "role": role,
           "rule": (f[:, col["rule_chose"]] == 1).astype(int)}
    for kinds in out.values():
        kinds.flags.writeable = False
    _KINDS[0] = (key, out)
    return out


#: The last features :func:`candidate_kinds` read (names, shape, bytes) and their kinds: one
#: mesh's choice asks for them with and without the project's habits and for each habit note.
#: One tuple replaced whole (threads of one worker read it: a reader sees one mesh's or another's).
_KINDS: list = [(None, None)]


def tally(features: np.ndarray, bound: np.ndarray, artist_count: int, names: tuple[str, ...]) -> np.ndarray:
    """The habits one artist-weighted mesh shows, as a vector of counts (:data:`TALLY_SIZE`).

    Parameters
    ----------
    features : ndarray, shape (C, F)
        Its candidates' per-bone features (columns ``names``).
    bound : ndarray of bool, shape (C,)
        Which candidates the artist bound.
    artist_count : int
        How many bones the artist bound (candidates or not).
    """
    col = _columns(names)
    f = np.asarray(features, float).reshape(-1, len(names))
    bound = np.asarray(bound, bool)
    out = np.zeros(TALLY_SIZE)
    every = candidate_kinds(f, names)
    for (name, n), start in zip(GROUPINGS, _OFFSETS):
        kinds = every[name]
        out[start:start + 2 * n:2] = np.bincount(kinds, minlength=n)
        out[start + 1:start + 2 * n:2] = np.bincount(kinds, weights=bound.astype(float), minlength=n)
    slot = (f[:, col["is_slot_bone"]] == 1) & (f[:, col["not_exact"]] == 0) & (f[:, col["skin_inactive"]] == 0)
    on_art = float(f[0, col["bones_on_art"]]) if len(f) else 0.0
    out[_MESHES] = 1
    out[_SLOT_SEEN] = float(slot.any())
    out[_SLOT_BOUND] = float((slot & bound).any())
    out[_BONES] = artist_count
    out[_PER_ON_ART] = artist_count / max(on_art, 1.0)
    if bound.any() and int(bound.sum()) == artist_count:   # the artist's whole set is among the candidates
        out[_SETS_SEEN] = 1
        out[_PATTERNS:] = set_patterns(np.flatnonzero(bound), f, names)
    return out


def pattern_sets(features: np.ndarray, names: tuple[str, ...]) -> tuple[set[int], ...]:
    """The candidates (indices) that :func:`set_patterns` compares a set with: the slot's bone,
    the bones over the art (points left out) and the ``rule``'s bones, each where it can be bound;
    then the points, the ancestors of the slot's bone and the bones below it.

    The same for every set of one mesh: :func:`.bone_sets.habit_set_features` finds them once.
    """
    col = _columns(names)
    f = np.atleast_2d(np.asarray(features, float))   # columns past ``names`` (the habits) are not read
    allowed = (f[:, col["not_exact"]] == 0) & (f[:, col["skin_inactive"]] == 0)
    slot = set(np.flatnonzero(allowed & (f[:, col["is_slot_bone"]] == 1)).tolist())
    over = set(np.flatnonzero(allowed & (f[:, col["over_art_per_diag"]] > 0) & (f[:, col["is_point"]] == 0)).tolist())
    rule = set(np.flatnonzero(allowed & (f[:, col["rule_chose"]] == 1)).tolist())
    marked = (set(np.flatnonzero(f[:, col[c]] == 1).tolist()) for c in ("is_point", "is_ancestor", "is_descendant"))
    return (slot, over, rule, *marked)


def set_patterns(members, features: np.ndarray, names: tuple[str, ...],
                 mesh: tuple[set[int], ...] | None = None) -> np.ndarray:
    """Which :data:`SET_PATTERNS` a set of candidates shows, as 0/1 (len(SET_PATTERNS),).

    Parameters
    ----------
    members : sequence of int
        The set, indices into the candidates (non-empty).
    features : ndarray, shape (C, F)
        The mesh's candidates' per-bone features (the first columns named ``names``).
    mesh : tuple of set, optional
        :func:`pattern_sets` of ``features``, when the caller has it (found here otherwise).
    """
    slot, over, rule, points, ancestors, below = pattern_sets(features, names) if mesh is None else mesh
    chosen = {int(k) for k in members}
    size = (0, 0, 1, 2, 3, 3)[len(chosen)] if len(chosen) < 6 else 4
    out = np.zeros(len(SET_PATTERNS))
    out[size] = 1
    out[5:] = [bool(slot) and chosen == slot, bool(over) and chosen == over, chosen <= over | slot,
               bool(rule) and chosen == rule, not points.isdisjoint(chosen),
               not ancestors.isdisjoint(chosen), not below.isdisjoint(chosen)]
    return out


def pattern_shares(others: np.ndarray, base: np.ndarray) -> np.ndarray:
    """The share (len(SET_PATTERNS),) of the project's artists' whole sets showing each of
    :data:`SET_PATTERNS`, from the tally of its other weighted meshes ``others`` smoothed toward
    the prior ``base`` (both :data:`TALLY_SIZE`) as :func:`habit_features` does."""
    return _share(np.full(len(SET_PATTERNS), others[_SETS_SEEN]), others[_PATTERNS:],
                  np.full(len(SET_PATTERNS), base[_SETS_SEEN]), base[_PATTERNS:])


def meshes_in(tallies: np.ndarray) -> np.ndarray:
    """How many weighted meshes each tally (..., TALLY_SIZE) sums."""
    return np.asarray(tallies)[..., _MESHES]


def prior(tallies: np.ndarray) -> np.ndarray:
    """The habits over every mesh of ``tallies`` (M, TALLY_SIZE): their sum, scaled to one mesh
    (the rates :func:`habit_features` smooths a project's toward)."""
    total = np.asarray(tallies, float).sum(axis=0)
    return total / max(total[_MESHES], 1.0)


def _share(seen: np.ndarray, hits: np.ndarray, base_seen: np.ndarray, base_hits: np.ndarray) -> np.ndarray:
    """Smoothed share: ``hits`` of ``seen`` plus :data:`PSEUDO_COUNT` at the prior's rate."""
    rate = base_hits / np.maximum(base_seen, 1e-9)
    return (hits + PSEUDO_COUNT * rate) / (seen + PSEUDO_COUNT)


def habit_features(features: np.ndarray, names: tuple[str, ...], others: np.ndarray,
                   base: np.ndarray) -> np.ndarray:
    """:data:`HABIT_FEATURES` (C, len(HABIT_FEATURES)) for the candidates of one mesh.

    Parameters
    ----------
    features : ndarray, shape (C, F)
        The mesh's candidates' per-bone features (columns ``names``).
    others : ndarray, shape (TALLY_SIZE,)
        The tally of the project's other artist-weighted meshes (zeros when none).
    base : ndarray, shape (TALLY_SIZE,)
        The prior (:func:`prior`).
    """
    f = np.asarray(features, float).reshape(-1, len(names))
    kinds = candidate_kinds(f, names)
    out = np.zeros((len(f), len(HABIT_FEATURES)))
    for k, ((name, n), start) in enumerate(zip(GROUPINGS, _OFFSETS)):
        share = _share(others[start:start + 2 * n:2], others[start + 1:start + 2 * n:2],
                       base[start:start + 2 * n:2], base[start + 1:start + 2 * n:2])
        out[:, k] = share[kinds[name]]
    k = len(GROUPINGS)
    out[:, k] = _share(others[_SLOT_SEEN], others[_SLOT_BOUND], base[_SLOT_SEEN], base[_SLOT_BOUND])
    for j, entry in enumerate((_BONES, _PER_ON_ART), start=k + 1):
        out[:, j] = (others[entry] + PSEUDO_COUNT * base[entry]) / (others[_MESHES] + PSEUDO_COUNT)
    out[:, k + 3] = math.log1p(others[_MESHES])
    return out


def keys_of(slot: str, name: str) -> set[str]:
    """A mesh's names for :func:`others_of`: its slot's and its attachment's."""
    return {f"slot:{slot}", f"name:{name}"}


@dataclass
class ProjectHabits:
    """The habits of a project's artist-weighted meshes, one tally each, with their names.

    Attributes
    ----------
    tallies : ndarray, shape (M, TALLY_SIZE)
        Each weighted mesh's :func:`tally`.
    keys : list of set of str
        Each one's names (:func:`keys_of`).
    bound : list of (str, str, frozenset of str)
        Each one's skeleton (:func:`rig_key`), slot bone and the bones its artist bound, by
        name; the set empty when some of them are not among its candidates.
    """

    tallies: np.ndarray
    keys: list[set[str]]
    bound: list[tuple[str, str, frozenset]] = field(default_factory=list)

    def neighbours(self, keys: set[str], rig: str, slot_bone: str) -> dict[frozenset, int]:
        """The sets of bones (names) the artists bound on the meshes of skeleton ``rig`` on the
        same slot bone, each with how many meshes bound it, leaving out the meshes that share a
        name with ``keys`` (as :meth:`others`)."""
        at = self._index[1].get((rig, slot_bone), [])
        return neighbour_counts([self.bound[m] for m in at], [self.keys[m] for m in at], keys, rig, slot_bone)

    def others(self, keys: set[str]) -> np.ndarray:
        """The tally (TALLY_SIZE,) of the meshes that share no name with ``keys``: a mesh being
        bound leaves out itself and its near-duplicates across skins and skeletons (same slot
        or attachment name), which would show its own answer."""
        keep = np.ones(len(self.keys), bool)
        for key in keys:
            keep[self._index[0].get(key, [])] = False
        return np.asarray(self.tallies, float).reshape(-1, TALLY_SIZE)[keep].sum(axis=0)

    @cached_property
    def _index(self) -> tuple[dict[str, list[int]], dict[tuple, list[int]]]:
        """The meshes (their order) by name, and by skeleton and slot bone: every mesh being bound
        asks :meth:`others` and :meth:`neighbours`: a walk over all of them for each grows with
        the square of the project's weighted meshes."""
        by_name: dict[str, list[int]] = {}
        by_place: dict[tuple, list[int]] = {}
        for m, names in enumerate(self.keys):
            for name in names:
                by_name.setdefault(name, []).append(m)
        for m, (rig, slot_bone, _) in enumerate(self.bound):
            by_place.setdefault((rig, slot_bone), []).append(m)
        return by_name, by_place


def neighbour_counts(bound: list[tuple], keys: list[set[str]], own: set[str], rig, slot_bone) -> dict[frozenset, int]:
    """:meth:`ProjectHabits.neighbours` over any labels: ``bound`` (skeleton, slot bone, set)
    and ``keys`` per mesh; the sets of the meshes of ``rig`` and ``slot_bone`` sharing no key
    with ``own``, counted (empty sets left out)."""
    return dict(Counter(chosen for (r, b, chosen), k in zip(bound, keys)
                        if chosen and r == rig and b == slot_bone and not (k & own)))


def rig_key(bone_names) -> str:
    """A skeleton's identity for :meth:`ProjectHabits.neighbours`: its bones' names, in order
    (skeletons of a project exported from the same rig share it)."""
    return "\n".join(str(n) for n in bone_names)


#: Side markers in bone names: the words left and right, and an l or r not followed by a letter
#: (``arm_L``, ``L_arm``, ``armR``, ``r-leg2``), in any case. Two bones whose names differ only
#: there are each other's mirror image (:func:`mirror_bones`).
SIDE_MARKER = re.compile(r"left|right|[lr](?![a-z])", re.IGNORECASE)


def mirror_bones(names: list[str], bone: int) -> list[int]:
    """The bones (indices into ``names``) whose names differ from bone ``bone``'s only in their
    side markers (:data:`SIDE_MARKER`): its mirror images, such as ``arm_R`` for ``arm_L``.

    Artists bind the two sides of a symmetric character alike: the sets bound on a mirror image
    of a mesh's slot bone, moved across (:func:`mirror_set`), are its neighbours' too. Measured
    held out (the same per-bone probabilities): exact bone sets 40.2% -> 41.0%; counting names
    that differ only in their numbers as well (``hair_3`` for ``hair_4``): 41.2%, but fewer on
    the examples (30.4% -> 29.9%).
    """
    stem = SIDE_MARKER.sub("<side>", names[bone])
    if stem == names[bone]:
        return []
    return [i for i, name in enumerate(names) if i != bone and SIDE_MARKER.sub("<side>", name) == stem]


def mirror_set(parents: list[int], source: int, target: int, members) -> tuple[int, ...] | None:
    """A set of bones bound on a mesh on slot bone ``source``, moved to slot bone ``target`` by
    each bone's place in the tree relative to the slot bone.

    Each bone is reached from ``source`` by going up to the first ancestor of ``source`` it hangs
    from, then down through the children in their order; the same path from ``target`` gives
    its counterpart (an ancestor both share, such as the body, is itself).

    Parameters
    ----------
    parents : list of int
        Each bone's parent (-1: none); children are in the order of the bones.
    source, target : int
        The slot bones.
    members : iterable of int
        The bones bound.

    Returns
    -------
    tuple of int or None
        The counterparts, sorted, or None when some bone has none (the trees differ there).
    """
    children: dict[int, list[int]] = {}
    for i, q in enumerate(parents):
        children.setdefault(q, []).append(i)

    def up(b):
        out = [b]
        while parents[out[-1]] >= 0 and len(out) <= len(parents):
            out.append(parents[out[-1]])
        return out

    above, there = up(source), up(target)
    mapped = set()
    for b in members:
        path, at = [], b
        while at not in above:
            if parents[at] < 0:
                return None
            path.append(children[parents[at]].index(at))
            at = parents[at]
        steps = above.index(at)
        if steps >= len(there):
            return None
        at = there[steps]
        for i in reversed(path):
            kids = children.get(at, [])
            if i >= len(kids):
                return None
            at = kids[i]
        mapped.add(at)
    return tuple(sorted(mapped))


def mirror_counts(parents: list[int], names: list[str], slot_bone: int, bound_on) -> Counter:
    """The sets bound on the mirror images of ``slot_bone`` (:func:`mirror_bones`), moved to it
    (:func:`mirror_set`), each with how many meshes bound it; ``bound_on(bone)``: the sets
    (bone indices) bound on the meshes on slot bone ``bone``, to how many bound each."""
    out: Counter = Counter()
    for other in mirror_bones(names, slot_bone):
        for chosen, count in bound_on(other).items():
            mapped = mirror_set(parents, other, slot_bone, chosen)
            if mapped:
                out[mapped] += count
    return out


def others_of(tallies: np.ndarray, pools: np.ndarray, keys: list[set[str]] | None = None) -> np.ndarray:
    """For each mesh, the tally of the other meshes of its pool (its project), leaving out itself
    and, with ``keys``, every mesh of the pool sharing a key with it (:meth:`ProjectHabits.others`).

    Parameters
    ----------
    tallies : ndarray, shape (M, TALLY_SIZE)
    pools : ndarray, shape (M,)
        Each mesh's project (any labels).
    keys : list of set of str, optional
        Each mesh's names (:func:`keys_of`); without them only the mesh itself is left out.

    Returns
    -------
    ndarray, shape (M, TALLY_SIZE)
    """
    tallies = np.asarray(tallies, float)
    keys = keys if keys is not None else [set() for _ in range(len(tallies))]
    keys = [k | {f"#{m}"} for m, k in enumerate(keys)]
    pools = np.asarray(pools)
    out = np.zeros_like(tallies)
    for pool in np.unique(pools):
        members = np.flatnonzero(pools == pool)
        project = ProjectHabits(tallies[members], [keys[m] for m in members])
        for m in members:
            out[m] = project.others(keys[m])
    return out


def reason(features: np.ndarray, names: tuple[str, ...], others: np.ndarray, k: int) -> str:
    """A report's words on candidate ``k``'s habit: how many candidates of its kind (same place
    in the tree, point, over or beside the art) the project's artists bound, in how many
    weighted meshes.

    ``features``: the mesh's per-bone features (C, F), columns ``names``; ``others``: the
    tally of the project's other weighted meshes (:data:`TALLY_SIZE`).
    """
    kind = int(candidate_kinds(features, names)["kind"][k])   # each row's kinds are its own
    seen, hits = others[int(_OFFSETS[0]) + 2 * kind:][:2]
    kind = f"{PLACES[kind // 3]}, {STATES[kind % 3]}"
    meshes = int(others[_MESHES])
    return (f"the project's habits: its artists bound {int(hits)} of {int(seen)} such bones ({kind}) "
            f"in {meshes} weighted mesh{'es' if meshes != 1 else ''}")
