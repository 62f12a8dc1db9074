"""The ``learned`` bone choice: a small tree ensemble fitted to how artists bind their meshes.

Every bone near a mesh's art is a *candidate* (within ``REACH`` of the art's bounding-box
diagonal, plus the slot's bone). Each candidate is described by what the rig and the art show
in the setup pose (:data:`FEATURES`): how much of its segment lies over the art and how far it
is from it, its length against the art's size, where it sits in the bone tree relative to the
slot's bone, which neighbours in the tree are on the art, its constraint roles, and whether the
``rule`` choice (:func:`.choice.choose_by_rule`) takes it. A gradient-boosted tree ensemble, fitted
on the artist-weighted meshes of the Spine examples and a corpus of game projects
(:mod:`spinemesh.train.bone_choice`), gives the probability that an artist binds the bone. A second,
set-level ensemble (:mod:`.bone_sets`) then weighs a few whole sets built from those
probabilities and the likeliest set to be the artist's exact one is chosen (a model without
that stage chooses the bones at or above its threshold). A model may also read the project's
habits (:mod:`.habits`): how its artists bound such bones in its other weighted meshes, the
shapes of their whole sets, and the sets they bound on the other meshes on the same slot bone
or its mirror image (:func:`neighbour_sets`), which the set stage also weighs.

The model ships as JSON (``spinemesh/models/bone_choice.json``: each tree's split features,
thresholds, children and leaf values, the set stage's under ``sets``) and is evaluated with
numpy: no pickle, no training library at run time.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..skeleton import iter_attachments
from . import bone_sets
from .binding import mesh_triangles, parse_vertices, setup_world
from .bones import bone_segments
from .choice import MAX_AUTO_BONES, NEAR, ArtDistance, Choice, choose_by_rule, rule_near, rule_samples
from .constraints.families import constraints_of
from .habits import (HABIT_FEATURES, TALLY_SIZE, ProjectHabits, habit_features, keys_of, meshes_in, mirror_counts,
                     pattern_shares, rig_key, tally)
from .habits import reason as habit_reason

#: Bones whose segment comes within this share of the art's bounding-box diagonal are
#: candidates. Measured on the training meshes: 0.25 holds all but a few percent of the
#: artists' bones (the rest lie farther out: handles on effects, whole-body bones).
REACH = 0.25

#: Bones along the slot bone's chain (its ancestors and the bones below it) are candidates
#: within this share of the art's diagonal (at most ``REACH``: none beyond it). Nearly two
#: thirds of the artists' bones beyond ``REACH`` lie along that chain, most below the slot bone.
#: Measured project-held-out with the project's habits (the same folds), against ``REACH``: the
#: artist's bones among the candidates on 90.0% of the meshes instead of 83.4%, exact bone sets
#: 42.0% -> 43.3% (examples 30.4% -> 33.0%, corpus 44.3% -> 45.4%; 0.5 and 0.75 of the
#: diagonal: 42.0% and 42.2%), and in the offline replay of all 1,632 meshes the median ratio
#: to the rigid baseline 1.236 -> 1.158. Without the habits it had measured no better (29.9%
#: against 29.8%).
CHAIN_REACH = 1.0

#: Sample points along each segment for its distances to the art (the rule samples 65; the
#: features need less: a share of a bone over the art to 1/32).
SEGMENT_SAMPLES = 33

#: Feature names, in the order of the columns the model reads.
FEATURES = (
    "is_slot_bone", "is_root", "is_point", "is_control", "is_constrained", "not_exact", "skin_inactive",
    "share_over_art", "over_art_per_diag", "share_near_art", "distance_per_diag", "length_per_diag",
    "is_ancestor", "is_descendant", "is_sibling", "tree_distance", "depth_difference",
    "children_on_art", "parent_on_art", "child_count", "rank_over_art", "rule_chose",
    "origin_on_art", "tip_on_art", "nearest_vertex_share", "length_vs_slot_bone",
    "log_art_diag", "slot_bone_on_art", "bones_on_art", "rule_bone_count", "candidate_count",
)

#: The model shipped in the package.
MODEL_PATH = Path(__file__).resolve().parents[1] / "models" / "bone_choice.json"

#: Format tag of the model file.
MODEL_FORMAT = "spinemesh-bone-choice/1"


@dataclass
class Candidates:
    """The candidate bones of one mesh and their features.

    Attributes
    ----------
    bones : list of int
        Candidate bone indices, ascending.
    features : ndarray, shape (C, len(FEATURES))
    rule : Choice
        The ``rule`` choice for the same mesh (one of the features).
    over : dict of int to float
        Each candidate's length over the art (world units; absent when it misses the art).
    """

    bones: list[int]
    features: np.ndarray
    rule: Choice
    over: dict[int, float]


def constrained_bones(doc: dict) -> dict[int, str]:
    """Bones that IK, transform, path or physics constraints move, with the first constraint's kind."""
    names = [b.get("name") for b in doc.get("bones", []) or [] if isinstance(b, dict)]
    index = {str(n): i for i, n in enumerate(names)}
    out: dict[int, str] = {}
    for kind in ("ik", "transform", "path", "physics"):
        for c in constraints_of(doc, kind):
            moved = c.get("bones") if kind != "physics" else [c.get("bone")]
            for name in moved if isinstance(moved, list) else []:
                if isinstance(name, str) and name in index:
                    out.setdefault(index[name], kind)
    return out


def _chain(bones, i: int, known: dict[int, list[int]] | None = None) -> list[int]:
    """``i`` and its ancestors up to the root, nearest first (``known``: chains already walked,
    reused and added to)."""
    known = {} if known is None else known
    out = []
    j = i
    while j is not None and j not in known:
        out.append(j)
        j = bones[j].parent
    out += known[j] if j is not None else []
    known[i] = out
    return out


def boxes_meet(lo: np.ndarray, hi: np.ndarray, art_lo: np.ndarray, art_hi: np.ndarray, reach) -> np.ndarray:
    """Whether each box (``lo``, ``hi``: (B, 2) corners) meets the art's box (``art_lo``,
    ``art_hi``: (2,)) grown by ``reach`` (world units: one for every box, or (B,))."""
    grow = np.broadcast_to(np.asarray(reach, float), (len(lo),))[:, None]
    return ~((hi < art_lo - grow).any(axis=1) | (lo > art_hi + grow).any(axis=1))


def slot_chain_bones(bones, slot_bone: int) -> list[int]:
    """The slot bone's chain: the bone, its ancestors up to the root and every bone below it."""
    below, todo = [], list(bones[slot_bone].children)
    while todo:
        i = todo.pop()
        below.append(i)
        todo += bones[i].children
    return _chain(bones, slot_bone) + below


def reach_limits(bones, slot_bone: int, diag: float, reach: float = REACH,
                 chain_reach: float = CHAIN_REACH) -> np.ndarray:
    """How far from the art (world units) each bone may lie and be a candidate (shape (len(bones),)):
    ``reach`` of the art's diagonal ``diag``, ``chain_reach`` along the slot bone's chain
    (:func:`slot_chain_bones`) when it is larger."""
    out = np.full(len(bones), reach * diag)
    if chain_reach > reach:
        out[slot_chain_bones(bones, slot_bone)] = chain_reach * diag
    return out


def segment_samples(bones, world: np.ndarray, reach, samples: int = SEGMENT_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """Evenly spaced points along every bone segment that may come within ``reach`` of the art.

    ``reach``: world units, one for every bone or each bone's own (ndarray, shape (len(bones),):
    :func:`reach_limits`).

    Returns
    -------
    ids : ndarray of int, shape (B,)
        The bones whose segment's bounding box, grown by ``reach``, meets the art's (``world``, (N, 2)).
    points : ndarray, shape (B * samples, 2)
        Bone after bone, from its origin to its tip.
    """
    segs = bone_segments(bones)
    ids = np.flatnonzero(boxes_meet(segs.min(axis=1), segs.max(axis=1), world.min(axis=0), world.max(axis=0), reach))
    t = np.linspace(0, 1, samples)[None, :, None]
    a, b = segs[ids, :1], segs[ids, 1:]
    return ids, (a + t * (b - a)).reshape(-1, 2)


def sample_distances(bones, world: np.ndarray, triangles: np.ndarray, reach, samples: int = SEGMENT_SAMPLES,
                     known: tuple | None = None, art: ArtDistance | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distances to the art of the :func:`segment_samples` of the bones that may come within ``reach``
    (``art``: the :class:`.choice.ArtDistance` of ``world`` and ``triangles``, when the caller has it).

    ``known``: the rule's distances (:func:`.choice.rule_samples`), whose every other sample
    (65 to a segment, these 33: the same points) is taken for the bones it measured, not
    measured again; a point bone's row there is its origin's distance, as here.

    Returns
    -------
    ids : ndarray of int, shape (B,)
    distance : ndarray, shape (B, samples)
        World units, 0 on the art; the first column is the bone's origin, the last its tip.
    """
    ids, points = segment_samples(bones, world, reach, samples)
    rows = np.ones(len(ids), bool)
    out = np.empty((len(ids), samples))
    if known is not None:
        known_ids, _, distance = known
        step = (distance.shape[1] - 1) // (samples - 1)
        if step * (samples - 1) == distance.shape[1] - 1 and len(known_ids):
            at = np.searchsorted(known_ids, ids).clip(0, len(known_ids) - 1)
            rows = known_ids[at] != ids
            out[~rows] = distance[at[~rows], ::step]
    points = points.reshape(len(ids), samples, 2)[rows].reshape(-1, 2)
    art = art if art is not None else ArtDistance(world, triangles)
    out[rows] = art(points).reshape(-1, samples)
    return ids, out


def _on_art(bones, ids: np.ndarray, distance: np.ndarray, near: float) -> dict[int, float]:
    """Each bone's length within ``near`` of the art (as :func:`.choice.lengths_on_art`: a point
    bone on the art has 0; a bone missing it is absent)."""
    close = distance <= near
    # each row's share at once (sums of ones: exact, whatever the order), then Python numbers
    first, some, share = close[:, 0].tolist(), close.any(axis=1).tolist(), close.mean(axis=1).tolist()
    out = {}
    for k, i in enumerate(np.asarray(ids).tolist()):
        if bones[i].length == 0:
            if first[k]:
                out[i] = 0.0
        elif some[k]:
            out[i] = bones[i].span() * share[k]
    return out


def _nearest_shares(bones, ids: list[int], world: np.ndarray) -> np.ndarray:
    """Share of the art's vertices whose nearest candidate segment is each candidate's."""
    from .weights import segment_distances

    d = segment_distances(world, np.stack([bones[i].segment() for i in ids]))  # (N, C)
    return np.bincount(d.argmin(axis=1), minlength=len(ids)) / max(len(world), 1)


def candidates(bones, slot_bone: int, world: np.ndarray, triangles: np.ndarray, skin_bones: set[int],
               constrained: dict[int, str] | None = None, reach: float = REACH,
               chain_reach: float = CHAIN_REACH) -> Candidates:
    """The candidate bones of one mesh and their features (:data:`FEATURES`).

    Parameters
    ----------
    bones : list of Bone
        The skeleton's bones (:func:`.bones.skeleton_bones`).
    slot_bone : int
        The bone of the mesh's slot.
    world : ndarray, shape (N, 2)
        The mesh's vertices in the setup pose, world units.
    triangles : ndarray, shape (T, 3)
    skin_bones : set of int
        Bones the mesh's skin activates.
    constrained : dict of int to str, optional
        Bones constraints move (:func:`constrained_bones`).
    reach : float
        Bones within this share of the art's diagonal are candidates (default :data:`REACH`;
        the shipped model was fitted with it).
    chain_reach : float
        Bones along the slot bone's chain (ancestors and descendants) are candidates within
        this share (default :data:`CHAIN_REACH`; at most ``reach`` adds none).
    """
    constrained = constrained or {}
    diag = max(float(np.linalg.norm(np.ptp(world, axis=0))), 1e-9)
    limit = reach_limits(bones, slot_bone, diag, reach, chain_reach)
    # the rule's distances (65 samples to a segment) give these (33) for the bones both measure
    art = ArtDistance(world, triangles)                                 # prepared once for both
    measured = rule_samples(bones, world, triangles, rule_near(world), art=art)
    sampled, dist = sample_distances(bones, world, triangles, limit, known=measured, art=art)
    over = _on_art(bones, sampled, dist, 0.0)
    near = _on_art(bones, sampled, dist, NEAR * diag)
    closest = dict(zip(sampled.tolist(), dist.min(axis=1).tolist()))
    ends = dict(zip(sampled.tolist(), (dist[:, [0, -1]] <= 0).tolist()))
    slot_chain = _chain(bones, slot_bone)
    ids = sorted({i for i, d in closest.items() if d <= limit[i]} | {slot_bone})
    rule = choose_by_rule(bones, slot_bone, world, triangles, skin_bones, measured)
    nearest = _nearest_shares(bones, ids, world)

    slot_depth = len(slot_chain) - 1
    on_art = [i for i in over if bones[i].parent is not None]
    ranked = sorted(on_art, key=lambda i: -over[i])
    rank = {i: r for r, i in enumerate(ranked)}
    slot_length = bones[slot_bone].span()
    rows = []
    known = {slot_bone: slot_chain}
    slot_place = {j: n for n, j in enumerate(slot_chain)}
    for k, i in enumerate(ids):
        b = bones[i]
        chain = _chain(bones, i, known)
        up = next(n for n, j in enumerate(chain) if j in slot_place)
        down = slot_place[chain[up]]
        length = b.span()
        rows.append([
            i == slot_bone, b.parent is None, b.length == 0, bool(b.target_of), i in constrained, not b.exact,
            b.skin_required and i not in skin_bones,
            (over.get(i, 0.0) / length if length > 0 else float(i in over)),
            over.get(i, 0.0) / diag,
            (near.get(i, 0.0) / length if length > 0 else float(i in near)),
            closest.get(i, reach * diag) / diag, min(length / diag, 10.0),
            i != slot_bone and i in slot_place, i != slot_bone and slot_bone in chain,
            i != slot_bone and b.parent is not None and b.parent == bones[slot_bone].parent,
            up + down, (len(chain) - 1) - slot_depth,
            sum(c in over for c in b.children), b.parent in over if b.parent is not None else False,
            len(b.children), min(rank.get(i, 20), 20), i in rule.bones,
            *ends.get(i, (False, False)), nearest[k],
            math.log((length + 1.0) / (slot_length + 1.0)),
            math.log(diag), slot_bone in over, len(on_art), len(rule.bones), len(ids),
        ])
    features = np.asarray(rows, float).reshape(len(ids), len(FEATURES))
    return Candidates(ids, features, rule, over)


def weighted_meshes(doc: dict, rig, reach: float = REACH, chain_reach: float = CHAIN_REACH) -> list[dict]:
    """Every artist-weighted mesh of a skeleton document with its candidates and the artist's bones.

    Meshes whose artist's bones include one with a setup transform not reproduced, or whose
    triangles or setup vertices are unusable, are passed over. ``rig``: the document's
    (:func:`.document.build_rig`); ``reach``, ``chain_reach``: as :func:`candidates`.

    Returns
    -------
    list of dict
        Each: ``skin``, ``slot``, ``name``, ``bones`` (candidate bone indices), ``parents``
        (each candidate's parent bone, -1 for the root), ``features`` (C, len(FEATURES)),
        ``label`` (C,) bool (the artist bound it), ``rule`` (the rule's bones), ``artist``
        (the artist's bones).
    """
    out = []
    # one mesh in several skins is the same art on the same bones: its candidates measured once
    measured: dict[tuple, Candidates] = {}
    for ref in iter_attachments(doc):
        att = ref.attachment
        if ref.type != "mesh" or ref.slot not in rig.slot_bone:
            continue
        try:
            mesh = parse_vertices(att, len(rig.bones))
            if not mesh.weighted:
                continue
            tris = mesh_triangles(att, mesh.count)
        except SpineMeshError:
            continue
        artist = mesh.bones()
        if not artist or any(not rig.bones[b].exact for b in artist):
            continue
        slot_bone = rig.slot_bone[ref.slot]
        world = setup_world(mesh, rig.worlds, slot_bone)
        if not np.isfinite(world).all() or np.ptp(world, axis=0).max() <= 0:
            continue
        skin_bones = rig.posed_skin_bones(ref.skin, slot_bone)
        key = (slot_bone, world.shape, world.tobytes(), tris.shape, tris.tobytes(), frozenset(skin_bones))
        if key not in measured:
            measured[key] = candidates(rig.bones, slot_bone, world, tris, skin_bones, rig.constrained,
                                       reach=reach, chain_reach=chain_reach)
        cand = measured[key]
        parents = [-1 if rig.bones[b].parent is None else rig.bones[b].parent for b in cand.bones]
        out.append(dict(skin=ref.skin, slot=ref.slot, name=ref.name, bones=list(cand.bones),
                        features=cand.features.copy(),
                        label=np.array([b in artist for b in cand.bones]), rule=list(cand.rule.bones), artist=artist,
                        parents=parents))
    return out


def document_habits(doc: dict, rig) -> tuple[list[np.ndarray], list[set[str]], list[tuple]]:
    """What :func:`project_habits` reads of one skeleton ``doc`` (its ``rig``): the tally, the
    names and the bound set of each of its artist-weighted meshes, in document order.

    A function of the document's artist-weighted meshes alone, so it runs anywhere (a worker,
    :func:`document_habits_job`) and the project's habits are these put together
    (:func:`habits_of`).
    """
    tallies, keys, bound = [], [], []
    names = [b.name for b in rig.bones]
    for m in weighted_meshes(doc, rig):
        tallies.append(tally(m["features"], m["label"], len(m["artist"]), FEATURES))
        keys.append(keys_of(m["slot"], m["name"]))
        whole = set(m["artist"]) <= set(m["bones"])
        bound.append((rig_key(names), names[rig.slot_bone[m["slot"]]],
                      frozenset(names[b] for b in m["artist"]) if whole else frozenset()))
    return tallies, keys, bound


def document_habits_job(job: tuple) -> tuple[list[np.ndarray], list[set[str]], list[tuple]]:
    """:func:`document_habits` of ``job``, a ``(doc, rig)`` pair, on a worker process."""
    return document_habits(*job)


def habits_of(parts) -> ProjectHabits:
    """The project's habits from the :func:`document_habits` of each of its skeletons, in order."""
    tallies, keys, bound = [], [], []
    for t, k, b in parts:
        tallies += t
        keys += k
        bound += b
    return ProjectHabits(np.asarray(tallies, float).reshape(-1, TALLY_SIZE), keys, bound)


def project_habits(documents) -> ProjectHabits:
    """The habits (:mod:`.habits`) of the artist-weighted meshes of a project's skeletons.

    ``documents``: ``(doc, rig)`` pairs, read before any of them is weighted (the habits are
    the artists', not ours).
    """
    return habits_of(document_habits(doc, rig) for doc, rig in documents)


def share_project_habits(documents) -> None:
    """Give the rig of each ``(doc, rig)`` pair of a project the :func:`project_habits` of all
    of them, read before any of its meshes is weighted."""
    habits = project_habits(documents)
    for _, rig in documents:
        rig.habits = habits


def neighbour_sets(habits: ProjectHabits | None, bones, slot_bone: int, keys: set[str]) -> dict[tuple[int, ...], int]:
    """The bone sets (indices into ``bones``, sorted) the project's artists bound on the other
    meshes on the slot bone ``slot_bone`` of a skeleton with these ``bones``, or on its mirror
    image (:func:`.habits.mirror_counts`, the sets moved across), each with how many meshes
    bound it (:meth:`.habits.ProjectHabits.neighbours`; the meshes sharing a name with ``keys``
    left out). Empty without habits."""
    if habits is None:
        return {}
    names = [b.name for b in bones]
    index = {n: i for i, n in enumerate(names)}
    rig = rig_key(names)

    def bound_on(bone: int) -> dict[tuple[int, ...], int]:
        found = habits.neighbours(keys, rig, names[bone])
        return {tuple(sorted(index[n] for n in chosen)): count for chosen, count in found.items()
                if all(n in index for n in chosen)}

    parents = [-1 if b.parent is None else b.parent for b in bones]
    return dict(Counter(bound_on(slot_bone)) + mirror_counts(parents, names, slot_bone, bound_on))


def _tree_from_json(t: dict, features: int) -> dict[str, np.ndarray]:
    """One tree's arrays from its JSON form, checked (children ahead of their node and inside
    the tree, features read exist, finite leaves); raises ValueError when malformed."""
    tree = {"feature": np.asarray(t["feature"], np.int64), "threshold": np.asarray(t["threshold"], float),
            "left": np.asarray(t["left"], np.int64), "right": np.asarray(t["right"], np.int64),
            "value": np.asarray(t["value"], float)}
    n = len(tree["feature"])
    if any(len(a) != n for a in tree.values()) or not np.isfinite(tree["value"]).all():
        raise ValueError("a tree of the model is malformed")
    inner = tree["feature"] >= 0
    ahead = np.flatnonzero(inner)
    if (tree["feature"][inner] >= features).any() or (tree["left"][inner] <= ahead).any() \
            or (tree["right"][inner] <= ahead).any() or (tree["right"][inner] >= n).any() \
            or (tree["left"][inner] >= n).any():
        raise ValueError("a tree of the model is malformed")
    return tree


@dataclass
class TreeEnsemble:
    """A tree ensemble: a base value plus the sum of regression trees' leaves (:meth:`raw`). The
    per-bone model is a binary classifier (:meth:`probability`, the sigmoid of it); the set
    model ranks (its ``raw`` the score).

    Each tree is arrays over its nodes: ``feature`` (column read; -1 at a leaf), ``threshold``
    (go left when the value is at most it), ``left``/``right`` (child nodes), ``value`` (the
    leaf's contribution, learning rate included). ``threshold``: the probability at which a
    bone is chosen (in a set model: the margin of :func:`.bone_sets.pick`, in score). ``sets``: the
    set-level stage (:mod:`.bone_sets`, reading :data:`.bone_sets.SET_FEATURES`), absent in
    models without it.
    """

    features: tuple[str, ...]
    base: float
    trees: list[dict[str, np.ndarray]]
    threshold: float
    meta: dict
    sets: TreeEnsemble | None = None

    @classmethod
    def from_json(cls, data: dict, features: tuple[str, ...] = FEATURES, form: str = MODEL_FORMAT) -> TreeEnsemble:
        """A model from its JSON form (:meth:`to_json`); raises ValueError when it is not one.

        ``features`` and ``form``: the feature names and format tag it must have (the
        per-bone model's by default).
        """
        from .bone_sets import SET_FEATURES, SET_HABIT_FEATURES, SET_MODEL_FORMAT

        if data.get("format") != form:
            raise ValueError(f"not a bone-choice model (format {data.get('format')!r}, expected {form!r})")
        names = tuple(data["features"])
        more = {FEATURES: HABIT_FEATURES, SET_FEATURES: SET_HABIT_FEATURES}.get(features, ())
        if names not in (features, features + more):
            raise ValueError("the model reads other features than this version computes")
        if features == FEATURES and len(names) > len(features) \
                and len(data.get("meta", {}).get("habit_prior", ())) != TALLY_SIZE:
            raise ValueError("the model reads the project's habits but holds no prior for them")
        trees = [_tree_from_json(t, len(names)) for t in data["trees"]]
        sets = data.get("sets")
        sets = cls.from_json(sets, SET_FEATURES, SET_MODEL_FORMAT) if sets is not None else None
        if sets is not None and len(sets.features) > len(SET_FEATURES) and len(names) == len(features):
            raise ValueError("the model's set stage reads the project's habits but the model holds no prior for them")
        return cls(names, float(data["base"]), trees, float(data["threshold"]), dict(data.get("meta", {})), sets)

    def to_json(self, form: str = MODEL_FORMAT) -> dict:
        """The JSON form :meth:`from_json` reads (``form``: its format tag)."""
        from .bone_sets import SET_MODEL_FORMAT

        out = {"format": form, "features": list(self.features), "base": self.base, "threshold": self.threshold,
               "meta": self.meta, "trees": [{k: v.tolist() for k, v in t.items()} for t in self.trees]}
        if self.sets is not None:
            out["sets"] = self.sets.to_json(SET_MODEL_FORMAT)
        return out

    @property
    def reads_habits(self) -> bool:
        """Whether the model reads :data:`.habits.HABIT_FEATURES` after :data:`FEATURES`."""
        return len(self.features) > len(FEATURES) and self.features[len(FEATURES)] == HABIT_FEATURES[0]

    def with_habits(self, features: np.ndarray, others: np.ndarray | None) -> np.ndarray:
        """``features`` (C, len(FEATURES)) with the habit columns appended when the model reads
        them (:func:`.habits.habit_features`, from ``others``, the tally of the project's other
        weighted meshes; None or zeros: the prior alone)."""
        if not self.reads_habits:
            return features
        base = np.asarray(self.meta["habit_prior"], float)
        others = np.zeros(TALLY_SIZE) if others is None else np.asarray(others, float)
        return np.hstack([features, habit_features(features, FEATURES, others, base)])

    @cached_property
    def stacked(self) -> dict[str, np.ndarray]:
        """All trees' nodes in flat arrays, tree after tree, for :meth:`raw`'s walk: one walk
        serves every (tree, row) pair.

        A node ``n`` of the flat numbering is read at the steps ``2n`` and ``2n + 1``:
        ``feature`` and ``threshold`` (twice each), ``child`` (``2n``: the right child's step,
        ``2n + 1``: the left's), so that a step plus whether the value is at most the
        threshold is the next step, one look-up instead of two and a choice. A leaf leads to
        itself (feature 0, threshold infinite) and is marked in ``leaf``; ``value`` is by node,
        ``first`` each tree's root's step.
        """
        sizes = [len(t["feature"]) for t in self.trees]
        first = np.cumsum([0] + sizes, dtype=np.int64)[:-1]
        feature = np.concatenate([t["feature"] for t in self.trees]) if self.trees else np.zeros(0, np.int64)
        leaf = feature < 0
        node = np.arange(len(feature))
        offset = np.repeat(first, sizes)

        def child(key):
            return np.where(leaf, node, np.concatenate([t[key] for t in self.trees]) + offset) if self.trees else node

        threshold = np.concatenate([t["threshold"] for t in self.trees]) if self.trees else np.zeros(0)
        steps = np.empty(2 * len(feature), np.int64)
        steps[0::2], steps[1::2] = 2 * child("right"), 2 * child("left")
        return {"feature": np.repeat(np.where(leaf, 0, feature), 2),
                "threshold": np.repeat(np.where(leaf, np.inf, threshold), 2),
                "child": steps, "leaf": np.repeat(leaf, 2), "first": 2 * first,
                "value": np.concatenate([t["value"] for t in self.trees]) if self.trees else np.zeros(0)}

    def raw(self, x: np.ndarray) -> np.ndarray:
        """The ensemble's log-odds for each row of ``x`` (R, F).

        Every (tree, row) pair walks down a level at a time, only those not yet at a leaf (the
        120 per-bone trees on 741 candidates: 6.9 ms, against 20.8 ms for all pairs of a level
        through two-dimensional indexing); a step is the next node's look-up by
        :attr:`stacked`'s ``child`` (the 1,352 calls of a run of 45 skeletons: 0.54 -> 0.38 s
        against a step's two look-ups and choice). The base and the trees' leaves are added
        in one accumulation down the trees, tree by tree as the training library adds them.
        """
        x = np.asarray(x, float)
        s = self.stacked
        rows, width = x.shape
        trees = len(s["first"])
        done = np.repeat(s["first"], rows)                   # the (tree, row) pairs, tree after tree
        column = np.tile(np.arange(rows) * width, trees)
        cells = x.ravel()
        walking, at = np.arange(len(done)), done
        # children come after their node (checked on reading): every walk ends
        while len(walking):
            at = s["child"][at + (cells[column + s["feature"][at]] <= s["threshold"][at])]
            done[walking] = at
            inner = ~s["leaf"][at]
            walking, at, column = walking[inner], at[inner], column[inner]
        # an accumulation adds in order, one term after the other (a reduction may add in pairs,
        # as it does over one row): the same doubles as adding each tree's leaves in turn
        terms = np.empty((trees + 1, rows))
        terms[0] = self.base
        terms[1:] = s["value"][done >> 1].reshape(trees, rows)
        return np.add.accumulate(terms, axis=0)[-1]

    def probability(self, x: np.ndarray) -> np.ndarray:
        """Probability (R,) that an artist binds each candidate."""
        return 1.0 / (1.0 + np.exp(-self.raw(x)))


_SHIPPED: list[TreeEnsemble] = []


def shipped_model() -> TreeEnsemble:
    """The model :func:`choose_learned` uses by default: the package's (read once), unless
    :func:`use_model` replaced it."""
    if not _SHIPPED:
        _SHIPPED.append(TreeEnsemble.from_json(json.loads(MODEL_PATH.read_text())))
    return _SHIPPED[0]


def use_model(model: TreeEnsemble | None) -> None:
    """Make ``model`` the default of :func:`choose_learned` (None: the package's again).

    For judging models fitted without some projects on those projects (the benchmarks).
    """
    _SHIPPED.clear()
    if model is not None:
        _SHIPPED.append(model)


def _describe(bones, i: int, slot_bone: int, over: dict[int, float], known: dict[int, list[int]] | None = None) -> str:
    """Where a candidate sits: its tree relation to the slot's bone and its length over the art
    (``known``: as :func:`_chain`'s)."""
    if i == slot_bone:
        where = "slot bone"
    elif bones[i].parent == slot_bone:
        where = "child of the slot bone"
    elif i in _chain(bones, slot_bone, known):
        where = "ancestor of the slot bone"
    elif slot_bone in _chain(bones, i, known):
        where = "below the slot bone"
    else:
        where = "elsewhere in the tree"
    on = f"{over[i]:.1f} units over the art" if i in over else "beside the art"
    return f"{where}, {on}"


def _by_threshold(p: np.ndarray, order: list[int], slot: int | None, threshold: float) -> list[int]:
    """The per-bone choice: candidates at or above ``threshold`` (at most ``MAX_AUTO_BONES``, the
    likeliest first), else the slot's bone (``slot``: its index among the candidates), else the
    likeliest one. ``order``: the allowed candidates, likeliest first."""
    take = [k for k in order if p[k] >= threshold][:MAX_AUTO_BONES]
    if not take and order:
        # None likely: the slot's bone, as the mesh follows now (the likeliest other bone, a
        # child beside the art say, can move it far away: measured 123 px off on one corpus mesh)
        take = [slot] if slot is not None else order[:1]
    return take


def _by_sets(bones, cand: Candidates, p: np.ndarray, allowed: np.ndarray, slot: int | None,
             model: TreeEnsemble, habits: np.ndarray | None = None,
             neighbours: dict[tuple[int, ...], int] | None = None) -> tuple[list[int], str]:
    """The set-level choice (:mod:`.bone_sets`): the candidate set the set model ranks first as
    the artist's exact set, when it scores above the per-bone choice's set by the margin
    (:func:`.bone_sets.pick`, the set model's ``threshold`` the margin); with a note on the
    choice for the report. A set model reading the project's habits gets their pattern shares
    (from ``habits``, the others' tally) and the ``neighbours``' sets (bone indices), which it
    also weighs; the set the neighbours agree on (:func:`.bone_sets.agreed_set`) is taken
    whatever the set model scores."""
    parents = np.array([-1 if bones[i].parent is None else bones[i].parent for i in cand.bones], int)
    ancestors, parents_at = bone_sets.mesh_inputs(np.asarray(cand.bones), parents)
    rule = cand.features[:, FEATURES.index("rule_chose")] == 1
    known, mesh_habits, at = {}, None, {b: k for k, b in enumerate(cand.bones)}
    reads_habits = len(model.sets.features) > len(bone_sets.SET_FEATURES)
    if reads_habits:
        known = {tuple(sorted(at[b] for b in chosen)): n for chosen, n in (neighbours or {}).items()
                 if all(b in at for b in chosen)}
        others = np.zeros(TALLY_SIZE) if habits is None else np.asarray(habits, float)
        mesh_habits = (pattern_shares(others, np.asarray(model.meta["habit_prior"], float)), known)
    sets = bone_sets.candidate_sets(p, allowed, slot, ancestors, parents_at, model.threshold, rule, known=known)
    if not sets:
        return [], ""
    agreed = bone_sets.agreed_set(sets, neighbours or {}, at) if reads_habits else None
    if agreed is not None:
        total = sum(neighbours.values())
        return list(sets[agreed][0]), (f"the set taken as agreed: the artists bound it on {known[sets[agreed][0]]} "
                                       f"of the project's {total} other weighted meshes on the same slot bone or "
                                       f"its mirror image")
    score = model.sets.raw(bone_sets.set_features(sets, p, allowed, cand.features, FEATURES, slot,
                                                  ancestors, parents_at, model.threshold, mesh_habits))
    best = bone_sets.pick(score, model.sets.threshold)
    how = (f"ranked first of {len(sets)} sets weighed, score {score[best]:.2f} against {score[0]:.2f} for the "
           f"bones at or over {model.threshold:.2f}" if best else
           f"the bones at or over {model.threshold:.2f}, score {score[0]:.2f}: no other of {len(sets)} sets "
           f"scored more than {model.sets.threshold:.2f} higher")
    count = known.get(sets[best][0], 0)
    if count:
        how += (f"; the artists bound this set on {count} of the project's {sum(known.values())} other "
                f"weighted meshes on the same slot bone or its mirror image")
    return list(sets[best][0]), f"the chosen set ({how})"


def choose_learned(bones, slot_bone: int, world: np.ndarray, triangles: np.ndarray, skin_bones: set[int],
                   constrained: dict[int, str] | None = None, model: TreeEnsemble | None = None,
                   habits: np.ndarray | None = None, neighbours: dict[tuple[int, ...], int] | None = None,
                   unweighted: bool = False, explain: bool = True, least_likely: float | None = None) -> Choice:
    """The ``learned`` choice (module docstring) for a mesh with setup world vertices ``world`` (N, 2).

    Bones nothing can be bound to (setup transform not exact, only active in other skins) are
    never chosen. With a set-level stage (``model.sets``) the candidate set it scores likeliest
    to be the artist's is taken. Without one, the bones at or above the model's threshold; when
    none reaches it, the slot's bone (the most likely candidate when the slot's bone cannot be
    bound); at most ``MAX_AUTO_BONES``, the most likely first.

    ``habits``: the tally (:data:`.habits.TALLY_SIZE`) of the other artist-weighted meshes of
    the project (:meth:`.habits.ProjectHabits.others`), for a model that reads the project's
    habits (None: the prior, as for a project without weighted meshes). A bone whose
    probability they move by :data:`HABIT_MATTERS` or more says so in its reason.
    ``neighbours``: the bone sets the project's artists bound on its other meshes on the same
    slot bone (:func:`neighbour_sets`), for a set stage reading the habits.

    ``unweighted``: the art is not one an artist chose to weight (``upgrade --weights auto``
    binds regions): bound to more than one bone only when a bone besides the slot's reaches the
    per-bone threshold, else to the slot's bone alone. Both models were fitted on meshes that
    artists weighted, 95% of them to several bones, and the set stage learned that: on the
    attachments artists left rigid it takes several bones three times in four, the per-bone
    choice one time in four (measured project-held-out: ``docs/guide/bones.md``, *While upgrading*).

    ``explain=False``: the same bones, without the reasons (``why`` and ``left_out`` empty), for
    a caller that only counts them (:meth:`.upgraded_meshes.BendingRegions.bends`): the habits' notes
    evaluate the model a second time.

    ``least_likely``: with the project's habits, bones the per-bone model finds less likely than
    this are left out of the bones taken, the slot's bone bound where none is left (default
    :data:`LEAST_LIKELY`; 0: none left out). Not for ``unweighted`` art: it takes more than one
    bone only where one is likely.
    """
    least_likely = LEAST_LIKELY if least_likely is None else least_likely
    model = model or shipped_model()
    cand = candidates(bones, slot_bone, world, triangles, skin_bones, constrained)
    p, alone = _probabilities(model, cand.features, habits, explain)
    left_out: dict[int, str] = {}
    allowed = np.zeros(len(cand.bones), bool)
    for k, i in enumerate(cand.bones):
        b = bones[i]
        if not b.exact:
            left_out[i] = b.why
        elif b.skin_required and i not in skin_bones:
            left_out[i] = "only active in other skins"
        else:
            allowed[k] = True
    order = sorted(np.flatnonzero(allowed).tolist(), key=lambda k: -p[k])
    slot = next((k for k in order if cand.bones[k] == slot_bone), None)
    if unweighted and slot is not None and not any(p[k] >= model.threshold for k in order if k != slot):
        take, note = [slot], ""  # the per-bone choice: no bone but the slot's is likely
    elif model.sets is not None:
        take, note = _by_sets(bones, cand, p, allowed, slot, model, habits, neighbours)
    else:
        take, note = [], ""
    taken = take or _by_threshold(p, order, slot, model.threshold)
    # a bone the per-bone model finds this unlikely lies beside the art, where the set stage took
    # it from the project's other meshes: it carried the art off where the slot's bone did not
    # (without the habits, leaving such bones out measured a little worse)
    from_habits = habits is not None and bool(np.any(habits)) and not unweighted
    taken, unlikely = _without_unlikely(taken, p, slot, least_likely) if from_habits else (taken, [])
    if not explain:  # the bones _explain gives reasons for: those taken (all of them allowed)
        chosen = sorted(cand.bones[k] for k in taken)
        return Choice(chosen or ([slot_bone] if bones[slot_bone].exact else []), {}, {})
    notes = _habit_notes(cand, p, habits, alone)
    why = _explain(bones, cand, p, order, taken, slot_bone, model.threshold, note if take else "", left_out, notes)
    for k in unlikely:
        left_out[cand.bones[k]] = (f"learned: {p[k]:.2f} likely an artist's bone, under {least_likely:g}: "
                                   f"left out of {note or 'the bones taken'}")
    if unlikely and taken == [slot]:
        why[slot_bone] = f"slot bone (every other bone taken was under {least_likely:g} likely)"
    if not why and bones[slot_bone].exact:
        why[slot_bone] = "slot bone (no candidate can be bound)"
    return Choice(sorted(why), why, left_out)


def _probabilities(model: TreeEnsemble, features: np.ndarray, habits: np.ndarray | None,
                   explain: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Each candidate's probability (C,) with the project's ``habits``, and, when ``explain`` and
    the habits move them, without (for the notes, :func:`_habit_notes`; else None)."""
    x = model.with_habits(features, habits)
    if not (explain and _habits_move(model, habits)):
        return model.probability(x), None
    # one walk of the trees for both (each row's is its own: the same numbers as two walks)
    both = model.probability(np.vstack([x, model.with_habits(features, None)]))
    return both[:len(x)], both[len(x):]


def _without_unlikely(taken: list[int], p: np.ndarray, slot: int | None,
                      least_likely: float) -> tuple[list[int], list[int]]:
    """``taken`` (candidate indices) without those but the slot's bone (``slot``) whose probability
    ``p`` is under ``least_likely``, the slot's bone where none is left; and those left out. As it
    was where all would be left out and the slot's bone is not a candidate."""
    unlikely = [k for k in taken if k != slot and p[k] < least_likely]
    if unlikely and (len(unlikely) < len(taken) or slot is not None):
        return [k for k in taken if k not in unlikely] or [slot], unlikely
    return taken, []


#: A bone the per-bone model finds less likely than this is left out of the bones taken (the set
#: stage takes such bones where the project's other meshes bound them: a slot symbol's bones
#: beside the art); the slot's bone is bound where none is left. Chosen on repository folds of
#: the offline replay among 0.02, 0.05, 0.1 and 0.2: every fold picked 0.05
#: (``docs/guide/bones.md``, *Bones the model finds unlikely*).
LEAST_LIKELY = 0.05


#: A bone's reason mentions the project's habits when they move its probability this much.
HABIT_MATTERS = 0.1


def _habits_move(model: TreeEnsemble, habits: np.ndarray | None) -> bool:
    """Whether the project's ``habits`` may move the ``model``'s probabilities (it reads them,
    and they hold some mesh)."""
    return model.reads_habits and habits is not None and meshes_in(habits) != 0


def _habit_notes(cand: Candidates, p: np.ndarray, habits: np.ndarray | None,
                 alone: np.ndarray | None) -> dict[int, str]:
    """For the candidates (indices into ``cand.bones``) whose probability ``p`` the project's
    habits moved by :data:`HABIT_MATTERS` or more from the prior's (``alone``: without the
    habits, None where they move nothing, :func:`_probabilities`), a note for the report."""
    if alone is None:
        return {}
    return {k: f"{habit_reason(cand.features, FEATURES, habits, k)} "
               f"({alone[k]:.2f} likely without the project's habits)"
            for k in np.flatnonzero(np.abs(p - alone) >= HABIT_MATTERS).tolist()}


#: The words of a bone left out only because the model finds it unlikely, the reason of most
#: bones left out (:func:`.document.left_out_reported` lists the others first).
BELOW_THRESHOLD = "below the threshold"


def _explain(bones, cand: Candidates, p: np.ndarray, order: list[int], take: list[int], slot_bone: int,
             threshold: float, chosen_set: str, left_out: dict[int, str],
             notes: dict[int, str] | None = None) -> dict[int, str]:
    """Why each allowed candidate was taken (returned) or left out (added to ``left_out``).

    ``chosen_set``: the set stage's note on the set taken (empty: the per-bone choice);
    ``notes``: the project's habits' notes (:func:`_habit_notes`), by candidate.
    """
    why: dict[int, str] = {}
    known: dict[int, list[int]] = {}
    for k in order:
        i = cand.bones[k]
        text = _describe(bones, i, slot_bone, cand.over, known)
        if notes and k in notes:
            text = f"{text}; {notes[k]}"
        alone = f"learned: {p[k]:.2f} likely an artist's bone"
        if chosen_set:
            if k in take:
                why[i] = f"{alone}; in {chosen_set}; {text}"
            else:
                left_out[i] = f"{alone}; not in {chosen_set}; {text}"
        elif k in take:
            top = " (none reached the threshold)" if p[k] < threshold else ""
            why[i] = f"{alone}, threshold {threshold:.2f}{top}; {text}"
        elif p[k] >= threshold:
            left_out[i] = f"learned: {p[k]:.2f}, but more than {MAX_AUTO_BONES} bones qualify; {text}"
        else:
            left_out[i] = f"learned: {p[k]:.2f}, {BELOW_THRESHOLD} {threshold:.2f}; {text}"
    return why
