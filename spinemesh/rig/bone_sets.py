"""The set-level stage of the ``learned`` bone choice: which whole set of candidate bones to bind.

The per-bone model (:mod:`.learned`) gives each candidate bone the probability that an artist
binds it, one bone at a time. Artists choose sets: a chain across the joints the art spans,
the slot's bone with the next one down, as many bones as parts of that size usually take.
This stage proposes a few sets built from the per-bone probabilities (:func:`candidate_sets`:
the likeliest 1..8 bones, those with or without the slot's bone, with the gaps along a chain
filled, with the next bone in the tree added, those the project's artists bound on its other
meshes on the same slot bone or its mirror image, ...), describes each set as a whole
(:data:`SET_FEATURES`: its size against the bones likely one at a time, how likely it is if
each bone were independent, how much of the art its bones are nearest to, whether it is
connected in the bone tree, with the project's habits how many of its artists' sets share its
shape, :data:`SET_HABIT_FEATURES`, ...), and a second tree ensemble, fitted to rank the artist's
exact set first, scores each set. The best-scoring set is bound when it scores above the
per-bone choice's set by more than the margin (:func:`pick`); else the per-bone choice stays.
"""

from __future__ import annotations

import heapq

import numpy as np

from .choice import MAX_AUTO_BONES
from .habits import pattern_sets, set_patterns

#: Set features, in the order of the columns the set model reads.
SET_FEATURES = (
    "size", "likely_count", "size_minus_likely", "size_minus_expected", "log_likelihood", "likelihood_gap",
    "min_in", "max_out", "margin", "mean_in", "slot_in", "slot_probability",
    "components", "gaps", "edges", "nearest_share_in", "over_art_in", "over_art_out_max",
    "points_in", "controls_in", "constrained_in", "ancestors_in", "descendants_in", "siblings_in",
    "rule_in", "rule_out", "tree_distance_max", "distance_max", "length_min", "length_max",
    "log_art_diag", "candidate_count", "bones_on_art", "rule_bone_count", "allowed_count",
    "is_prefix", "is_threshold_choice",
)

#: Set features from the project's habits (:mod:`.habits`), after :data:`SET_FEATURES` in a
#: set model that reads them: how many of the project's artists' sets are of the set's size,
#: share alike in each other :data:`.habits.SET_PATTERNS` (the share when the set shows it,
#: one minus it when not), the log of their product over every pattern; how many sets the
#: meshes on the same slot bone of the same skeleton bound, the share of them equal to this
#: set, whether it is the most bound of them. Measured held out (the same per-bone
#: probabilities): exact bone sets 32.3% -> 35.1%.
SET_HABIT_FEATURES = (
    "habit_size", "habit_slot_alone", "habit_every_over_art", "habit_over_art_and_slot", "habit_rule_set",
    "habit_point", "habit_ancestor", "habit_below", "habit_patterns", "neighbour_sets", "neighbour_share",
    "neighbour_most",
)

#: Format tag of the set model inside the bone-choice model file.
SET_MODEL_FORMAT = "spinemesh-bone-sets/2"  # /1: a classifier, its probability the score

#: The likeliest sets with independent bones among the candidate sets (:func:`likeliest_sets`).
LIKELIEST = 20

#: A set replaces the per-bone choice only when the set model scores it more than this above
#: the per-bone choice's set (the ranker's scores; the classifier before it measured 0.05 in
#: probability best). Measured held out (the same per-bone probabilities): exact bone sets
#: 41.9% at 0, 42.0% at 0.1, 41.9% at 0.25, 41.7% at 0.5.
SET_MARGIN = 0.1

#: Probabilities are clipped to [EPS, 1 - EPS] in the log-likelihood of a set.
EPS = 1e-4

#: A mesh takes the set the artists bound on the other meshes on its slot bone of the same
#: skeleton (:meth:`.habits.ProjectHabits.neighbours`), whatever the set model scores, when at
#: least ``AGREED_MESHES`` of them show their whole set and ``AGREED_SHARE`` of those bound the
#: same one (:func:`agreed_set`): parts hung on one bone are bound alike in most projects.
AGREED_MESHES, AGREED_SHARE = 3, 0.7


def candidate_ancestors(bones: np.ndarray, parents: np.ndarray) -> list[set[int]]:
    """For each candidate, the candidates (indices into ``bones``) above it in the bone tree.

    Only chains through candidates are followed: a bone outside the candidates ends the walk
    (its own parent is not known here).
    """
    at = {int(b): k for k, b in enumerate(bones)}
    out = []
    for k in range(len(bones)):
        seen: set[int] = set()
        j = at.get(int(parents[k]))
        while j is not None and j not in seen and j != k:
            seen.add(j)
            j = at.get(int(parents[j]))
        out.append(seen)
    return out


def candidate_descendants(ancestors: list[set[int]]) -> list[set[int]]:
    """For each candidate, the candidates below it: those whose :func:`candidate_ancestors` hold it."""
    out: list[set[int]] = [set() for _ in ancestors]
    for m, above in enumerate(ancestors):
        for j in above:
            out[j].add(m)
    return out


def likeliest_sets(p: np.ndarray, allowed: np.ndarray, count: int, most: int = MAX_AUTO_BONES) -> list[tuple[int, ...]]:
    """The ``count`` likeliest sets of allowed candidates if each bone were bound independently
    with its probability ``p`` (C,), likeliest first; empty sets and sets over ``most`` skipped.

    The likeliest set takes every bone over 1/2; each other set flips some of those decisions,
    at a cost of ``|log(p / (1 - p))|`` each: the sets come in increasing total cost, from
    the classic enumeration of subset sums in order (each subset of flips, its largest flip
    ``i``, leads to the subsets with ``i`` moved to ``i + 1`` or ``i + 1`` added).
    """
    ok = np.flatnonzero(allowed)
    if not len(ok) or count <= 0:
        return []
    q = np.clip(p[ok], EPS, 1 - EPS)
    gain = np.log(q) - np.log1p(-q)
    order = np.argsort(np.abs(gain), kind="stable")
    # Python numbers in the loop: the same doubles, summed in the same order, without numpy's
    # cost per scalar (the loop was a tenth of the learned choice)
    cost, bone = np.abs(gain)[order].tolist(), ok[order].tolist()
    base = set(ok[gain > 0].tolist())
    # a flip takes a bone out of the set (-1) or puts one in (+1): each entry carries its set's
    # size, and only a set of a size taken is built (most of the sets met on meshes of many
    # likely bones are too large). Entries never tie on (total, flips): each subset of flips
    # is reached once.
    step = [-1 if b in base else 1 for b in bone]
    out: list[tuple[int, ...]] = []
    heap: list[tuple[float, tuple[int, ...], int]] = [(0.0, (), len(base))]
    popped = 0
    while heap and len(out) < count and popped < 50 * count:
        total, flips, size = heapq.heappop(heap)
        popped += 1
        if 0 < size <= most:
            out.append(tuple(sorted(base.symmetric_difference([bone[i] for i in flips]))))
        last = flips[-1] if flips else -1
        if last + 1 < len(cost):
            heapq.heappush(heap, (total + cost[last + 1], flips + (last + 1,), size + step[last + 1]))
            if flips:
                heapq.heappush(heap, (total - cost[last] + cost[last + 1], flips[:-1] + (last + 1,),
                                      size - step[last] + step[last + 1]))
    return out


def candidate_sets(p: np.ndarray, allowed: np.ndarray, slot: int | None, ancestors: list[set[int]],
                   parents_at: np.ndarray, threshold: float, rule: np.ndarray, likely: int = LIKELIEST,
                   most: int = MAX_AUTO_BONES, known=()) -> list[tuple[tuple[int, ...], bool]]:
    """The sets of candidates the set model chooses from, each with whether it is a likeliest-k prefix.

    Parameters
    ----------
    p : ndarray, shape (C,)
        Each candidate's probability (the per-bone model).
    allowed : ndarray of bool, shape (C,)
        Candidates that can be bound.
    slot : int or None
        The slot bone's index among the candidates (None when it cannot be bound).
    ancestors : list of set of int
        :func:`candidate_ancestors`.
    parents_at : ndarray of int, shape (C,)
        Each candidate's parent's index among the candidates, -1 when not a candidate.
    threshold : float
        The per-bone model's threshold: the set of the bones at or above it (the per-bone
        choice) is always among the sets.
    rule : ndarray of bool, shape (C,)
        The ``rule`` choice's bones.
    likely : int
        The sets also hold the ``likely`` likeliest sets with independent bones (:func:`likeliest_sets`).
    known : iterable of tuple of int
        Sets (indices) also weighed when all their bones are allowed: those the artists bound on
        the project's meshes on the same slot bone (:meth:`.habits.ProjectHabits.neighbours`).

    Returns
    -------
    list of (tuple of int, bool)
        Distinct non-empty sets of at most ``most`` allowed candidates (sorted indices), the
        first the per-bone choice.
    """
    order = [int(k) for k in np.argsort(-p, kind="stable") if allowed[k]]
    if not order:
        return []
    n = min(len(order), most)
    sets: dict[tuple[int, ...], bool] = {}

    def add(members, prefix=False):
        key = tuple(sorted(set(members)))
        if key and len(key) <= most:
            sets[key] = sets.get(key, False) or prefix

    below = candidate_descendants(ancestors)
    above = [k for k in order if p[k] >= threshold][:most]
    add(above or ([slot] if slot is not None else order[:1]))
    for k in range(1, n + 1):
        prefix = order[:k]
        add(prefix, True)
        if k < len(order):
            add(order[:k - 1] + [order[k]])                      # the k-th likeliest skipped
        if slot is not None and slot not in prefix:
            add(prefix + [slot])
        if slot is not None and slot in prefix and k > 1:
            add([j for j in prefix if j != slot])
        inside = set(prefix)
        gaps = [j for j in order if j not in inside and not ancestors[j].isdisjoint(inside)
                and not below[j].isdisjoint(inside)]
        if gaps:
            add(prefix + gaps)                                   # a chain's gaps filled
        near = [j for j in order if j not in inside and (parents_at[j] in inside or
                                                          any(parents_at[m] == j for m in inside))]
        if near:
            add(prefix + near[:1])                               # the likeliest tree neighbour added
    if slot is not None:
        add([slot])
    add([k for k in order if rule[k]])
    for members in likeliest_sets(p, allowed, likely, most):
        add(members)
    for members in known:
        if all(allowed[k] for k in members):
            add(members)
    return list(sets.items())


def _tree_shape(members: tuple[int, ...], ancestors: list[set[int]], below: list[set[int]], parents_at: list[int],
                candidates: list[int]) -> tuple[int, int, int]:
    """Connected components and parent-child edges of a set in the bone tree, and its gaps:
    candidates outside it that lie on a chain between two of its members (one of them above it,
    :func:`candidate_ancestors`, one below, :func:`candidate_descendants`)."""
    inside = set(members)
    edges = sum(parents_at[m] in inside for m in members)
    gaps = sum(1 for j in candidates if j not in inside and not ancestors[j].isdisjoint(inside)
               and not below[j].isdisjoint(inside))
    return len(members) - edges, edges, gaps


def set_features(sets: list[tuple[tuple[int, ...], bool]], p: np.ndarray, allowed: np.ndarray,
                 features: np.ndarray, names: tuple[str, ...], slot: int | None, ancestors: list[set[int]],
                 parents_at: np.ndarray, threshold: float, habits: tuple | None = None) -> np.ndarray:
    """Each set's :data:`SET_FEATURES` (S, len(SET_FEATURES)), then with ``habits`` its
    :data:`SET_HABIT_FEATURES`.

    ``features``: the candidates' per-bone features (C, F), columns named by ``names``
    (:data:`.learned.FEATURES`); ``habits``: the project's pattern shares
    (:func:`.habits.pattern_shares`) and its neighbour sets (candidate indices, sorted, to how
    many meshes bound each); the other parameters as :func:`candidate_sets`.
    """
    col = {f: i for i, f in enumerate(names)}
    pa = np.clip(p, EPS, 1 - EPS)
    ok = np.flatnonzero(allowed)
    likely = int((p[ok] >= threshold).sum())
    expected = float(p[ok].sum())
    base = float(np.log1p(-pa[ok]).sum())
    gain = np.log(pa) - np.log1p(-pa)
    best = base + float(np.clip(gain[ok], 0, None).sum())
    mesh = features[0] if len(features) else np.zeros(len(names))
    first = sets[0][0] if sets else ()
    allowed_list = ok.tolist()
    below, parent_list = candidate_descendants(ancestors), np.asarray(parents_at).tolist()
    # Minima, maxima and counts of 0/1 columns come out the same in any order: taken over every
    # set at once through its members' mask; the sums of fractions stay one set at a time, in
    # the members' order, to the last bit.
    inside = np.zeros((len(sets), len(p)), bool)
    for k, (members, _) in enumerate(sets):
        inside[k, list(members)] = True
    outside = np.asarray(allowed, bool) & ~inside
    any_out = outside.any(axis=1)

    def lowest(mask, values):
        return np.where(mask, values, np.inf).min(axis=1)

    def highest(mask, values):
        return np.where(mask, values, -np.inf).max(axis=1)

    p_in = lowest(inside, p)
    p_out = np.where(any_out, highest(outside, p), 0.0)
    over = features[:, col["over_art_per_diag"]]
    counted = ("is_point", "is_control", "is_constrained", "is_ancestor", "is_descendant", "is_sibling", "rule_chose")
    counts = inside.astype(float) @ features[:, [col[c] for c in counted]]  # (S, 7) whole numbers
    rule_out = np.where(any_out, outside.astype(float) @ features[:, col["rule_chose"]], 0.0)
    length = features[:, col["length_per_diag"]]
    per_set = np.column_stack([
        p_in, p_out, p_in - p_out, np.where(any_out, highest(outside, over), 0.0), counts, rule_out,
        highest(inside, features[:, col["tree_distance"]]), highest(inside, features[:, col["distance_per_diag"]]),
        lowest(inside, length), highest(inside, length),
    ]).reshape(len(sets), 16)
    rows = []
    for (members, prefix), (p_min, p_max, margin, over_out, *rest) in zip(sets, per_set.tolist()):
        m = np.asarray(members, int)
        f = features[m]
        loglik = base + float(gain[m].sum())
        components, edges, gaps = _tree_shape(members, ancestors, below, parent_list, allowed_list)
        rows.append([
            len(m), likely, len(m) - likely, len(m) - expected, loglik, best - loglik,
            p_min, p_max, margin, float(p[m].mean()),
            slot is not None and slot in members, float(p[slot]) if slot is not None else 0.0,
            components, gaps, edges,
            float(f[:, col["nearest_vertex_share"]].sum()), float(f[:, col["over_art_per_diag"]].sum()), over_out,
            *rest,
            *(float(mesh[col[c]]) for c in ("log_art_diag", "candidate_count", "bones_on_art", "rule_bone_count")),
            len(ok), prefix, members == first,
        ])
    out = np.asarray(rows, float).reshape(len(sets), len(SET_FEATURES))
    if habits is None:
        return out
    return np.hstack([out, habit_set_features([m for m, _ in sets], features, names, *habits)])


def habit_set_features(sets: list[tuple[int, ...]], features: np.ndarray, names: tuple[str, ...],
                       shares: np.ndarray, neighbours: dict) -> np.ndarray:
    """:data:`SET_HABIT_FEATURES` (S, len(SET_HABIT_FEATURES)) of sets of candidates (indices).

    ``shares``: :func:`.habits.pattern_shares`; ``neighbours``: sorted tuples of candidate
    indices to how many of the meshes on the same slot bone bound that set.
    """
    total = sum(neighbours.values())
    most = max(neighbours.values()) if neighbours else 0
    rows = []
    mesh = pattern_sets(features, names)
    for members in sets:
        shown = set_patterns(members, features, names, mesh)
        agree = np.where(shown == 1, shares, 1 - shares)
        count = neighbours.get(tuple(members), 0)
        rows.append([float(agree[:5][shown[:5] == 1].sum()), *agree[5:],
                     float(np.log(np.clip(agree, EPS, 1)).sum()), total, count / total if total else -1.0,
                     float(count > 0 and count == most)])
    return np.asarray(rows, float).reshape(len(sets), len(SET_HABIT_FEATURES))


def mesh_inputs(bones: np.ndarray, parents: np.ndarray) -> tuple[list[set[int]], np.ndarray]:
    """The tree relations among one mesh's candidates: :func:`candidate_ancestors` and each
    candidate's parent's index among them (-1 when its parent is not a candidate)."""
    at = {int(b): k for k, b in enumerate(bones)}
    return candidate_ancestors(bones, parents), np.array([at.get(int(q), -1) for q in parents], int)


def agreed_set(sets: list[tuple[tuple[int, ...], bool]], neighbours: dict[tuple[int, ...], int],
               at: dict[int, int]) -> int | None:
    """The position in ``sets`` of the set the neighbours agree on, or None.

    Parameters
    ----------
    sets : list of (tuple of int, bool)
        The candidate sets (:func:`candidate_sets`).
    neighbours : dict of tuple of int to int
        The sets (bone indices) the artists bound on the other meshes on the same slot bone of
        the same skeleton, each with how many meshes bound it.
    at : dict of int to int
        Each candidate bone's index among the candidates.

    Returns
    -------
    int or None
        The set at least :data:`AGREED_SHARE` of at least :data:`AGREED_MESHES` neighbours
        bound, when it is among ``sets`` (every bone of it a candidate that can be bound, at
        most ``MAX_AUTO_BONES``); else None.
    """
    total = sum(neighbours.values())
    if total < AGREED_MESHES:
        return None
    chosen, count = max(neighbours.items(), key=lambda item: item[1])
    if count < AGREED_SHARE * total or not all(b in at for b in chosen):
        return None
    key = tuple(sorted(at[b] for b in chosen))
    return next((k for k, (members, _) in enumerate(sets) if members == key), None)


def pick(score: np.ndarray, margin: float = SET_MARGIN) -> int:
    """The set taken, given each candidate set's score (S,), the per-bone choice's first
    (:func:`candidate_sets`): the best-scoring set when it scores more than ``margin`` above
    the first, else the first."""
    best = int(np.argmax(score))
    return best if score[best] - score[0] > margin else 0
