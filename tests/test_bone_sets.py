"""The set-level stage of the ``learned`` bone choice: candidate sets, their features, the choice."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from spinemesh.rig import bone_sets as bs
from spinemesh.rig.learned import FEATURES, MODEL_FORMAT, TreeEnsemble, candidates, choose_learned

from test_bone_choice_learned import COL, _mesh_of, _tree_model, _worm_mesh_doc

SCOL = {f: i for i, f in enumerate(bs.SET_FEATURES)}


def _chain():
    """Candidates 0 (root) -> 1 (slot) -> 2 -> 3 and 4 under the root, as bone indices 0, 1, 2, 3, 5."""
    bones, parents = np.array([0, 1, 2, 3, 5]), np.array([-1, 0, 1, 2, 0])
    return (*bs.mesh_inputs(bones, parents),)


def test_tree_relations_follow_candidate_parents():
    ancestors, parents_at = _chain()
    assert ancestors == [set(), {0}, {0, 1}, {0, 1, 2}, {0}]
    assert parents_at.tolist() == [-1, 0, 1, 2, 0]
    # a parent outside the candidates ends the walk
    anc, at = bs.mesh_inputs(np.array([4, 7]), np.array([2, 4]))
    assert anc == [set(), {0}] and at.tolist() == [-1, 0]


@pytest.mark.parametrize("seed", range(40))
def test_likeliest_sets_come_in_order_of_independent_likelihood(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 8))
    p, allowed = rng.random(n), rng.random(n) > 0.2
    got = bs.likeliest_sets(p, allowed, 12, most=4)
    q, ok = np.clip(p, bs.EPS, 1 - bs.EPS), np.flatnonzero(allowed)

    def loglik(s):
        return sum(np.log(q[k]) if k in s else np.log1p(-q[k]) for k in ok)

    every = sorted((s for r in range(1, min(4, len(ok)) + 1) for s in itertools.combinations(ok.tolist(), r)),
                   key=lambda s: -loglik(s))
    assert len(got) == len(set(got)) == min(12, len(every))
    assert np.allclose([loglik(s) for s in got], [loglik(s) for s in every[:len(got)]])


def test_candidate_sets_hold_the_per_bone_choice_first_and_the_chain_with_its_gap_filled():
    ancestors, parents_at = _chain()
    p = np.array([0.05, 0.9, 0.3, 0.6, 0.4])
    allowed = np.array([False, True, True, True, True])
    rule = np.array([False, True, True, False, False])
    sets = bs.candidate_sets(p, allowed, 1, ancestors, parents_at, 0.5, rule, likely=0)
    members = [m for m, _ in sets]
    assert members[0] == (1, 3)                          # the bones at or over 0.5
    assert (1, 2, 3) in members                          # seg2 fills the gap between 1 and 3
    assert (1, 2) in members                             # the rule's set
    assert all(0 not in m for m in members)              # never a bone that cannot be bound
    assert len(set(members)) == len(members)
    assert dict(sets)[(1,)] and dict(sets)[(1, 3)] and not dict(sets)[(1, 2)]  # likeliest-k prefixes
    assert bs.candidate_sets(p, np.zeros(5, bool), None, ancestors, parents_at, 0.5, rule) == []


def test_set_features_describe_size_likelihood_and_shape():
    ancestors, parents_at = _chain()
    p = np.array([0.05, 0.9, 0.3, 0.6, 0.4])
    allowed = np.array([False, True, True, True, True])
    features = np.zeros((5, len(FEATURES)))
    features[:, COL["nearest_vertex_share"]] = [0.1, 0.4, 0.2, 0.2, 0.1]
    sets = [((1, 3), True), ((1, 2, 3), False)]
    z = bs.set_features(sets, p, allowed, features, FEATURES, 1, ancestors, parents_at, 0.5)
    assert z.shape == (2, len(bs.SET_FEATURES))
    gap, filled = (dict(zip(bs.SET_FEATURES, row)) for row in z)
    assert gap["size"] == 2 and gap["likely_count"] == 2 and gap["components"] == 2 and gap["gaps"] == 1
    assert filled["components"] == 1 and filled["gaps"] == 0 and filled["edges"] == 2
    assert gap["likelihood_gap"] == pytest.approx(0) and filled["likelihood_gap"] > 0
    expected = np.log(0.9) + np.log(0.6) + np.log(0.7) + np.log(0.6)
    assert gap["log_likelihood"] == pytest.approx(expected)
    assert gap["min_in"] == pytest.approx(0.6) and gap["max_out"] == pytest.approx(0.4)
    assert filled["nearest_share_in"] == pytest.approx(0.8) and gap["slot_in"] == 1
    assert gap["is_threshold_choice"] == 1 and filled["is_threshold_choice"] == 0


def _set_model(feature: str, cut: float) -> dict:
    """A set model of one split on ``feature``: score -3 at or below ``cut``, +3 above."""
    return {"format": bs.SET_MODEL_FORMAT, "features": list(bs.SET_FEATURES), "base": 0.0, "threshold": 0.1,
            "meta": {}, "trees": [{"feature": [SCOL[feature], -1, -1], "threshold": [cut, 0, 0], "left": [1, 0, 0],
                                   "right": [2, 0, 0], "value": [0, -3.0, 3.0]}]}


def test_the_set_stage_takes_its_likeliest_set_and_says_why_for_every_candidate():
    rig, _, _, world, tris = _mesh_of(_worm_mesh_doc())
    names = [b.name for b in rig.bones]
    data = _tree_model("nearest_vertex_share", 0.2)          # seg1..seg3 0.95, the others 0.05
    data["sets"] = _set_model("size", 2.5)                   # any set of 3 bones or more
    model = TreeEnsemble.from_json(data)
    choice = choose_learned(rig.bones, rig.slot_bone["worm"], world, tris, set(), {}, model)
    cand = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {})
    assert {names[b] for b in choice.bones} == {"seg1", "seg2", "seg3"}   # the first set of 3+: the per-bone one
    assert set(choice.why) | set(choice.left_out) == set(cand.bones)
    assert all("; in the chosen set (the bones at or over 0.50, score 3.00: no other of " in w
               and " sets scored more than 0.10 higher)" in w for w in choice.why.values())
    assert all("; not in the chosen set" in w for b, w in choice.left_out.items() if rig.bones[b].exact)
    # a set model preferring single bones overrides the per-bone threshold
    data["sets"] = _set_model("size", 1.5)
    data["sets"]["trees"][0]["value"] = [0, 3.0, -3.0]
    one = choose_learned(rig.bones, rig.slot_bone["worm"], world, tris, set(), {}, TreeEnsemble.from_json(data))
    assert len(one.bones) == 1 and one.why[one.bones[0]].startswith("learned: 0.95")
    assert " in the chosen set (ranked first of " in one.why[one.bones[0]]
    assert "sets weighed, score 3.00 against -3.00 for the bones at or over 0.50)" in one.why[one.bones[0]]


def test_models_round_trip_with_their_set_stage_and_refuse_a_wrong_one():
    data = _tree_model("share_over_art", 0.5)
    data["sets"] = _set_model("size", 2.5)
    model = TreeEnsemble.from_json(data)
    assert model.sets is not None and model.sets.features == bs.SET_FEATURES
    again = model.to_json()
    assert again["format"] == MODEL_FORMAT and again["sets"]["format"] == bs.SET_MODEL_FORMAT
    assert TreeEnsemble.from_json(again).sets.to_json(bs.SET_MODEL_FORMAT) == again["sets"]
    data["sets"]["features"] = list(FEATURES)
    with pytest.raises(ValueError):
        TreeEnsemble.from_json(data)
    data["sets"] = _set_model("size", 2.5)
    data["sets"]["trees"][0]["right"] = [0, 0, 0]          # a child pointing back: a loop
    with pytest.raises(ValueError):
        TreeEnsemble.from_json(data)


def test_a_set_replaces_the_per_bone_choice_only_when_clearly_likelier():
    assert bs.pick(np.array([0.30, 0.38, 0.10]), margin=0.1) == 0
    assert bs.pick(np.array([0.30, 0.45, 0.10]), margin=0.1) == 1
    assert bs.pick(np.array([0.30, 0.30]), margin=0.0) == 0


def test_the_set_the_neighbours_agree_on_is_found_among_the_sets():
    sets = [((0,), False), ((0, 1), True), ((0, 1, 2), False)]
    at = {10: 0, 11: 1, 12: 2}                       # bone index -> candidate index
    assert bs.agreed_set(sets, {(10, 11): 3}, at) == 1
    assert bs.agreed_set(sets, {(10, 11): 2}, at) is None                # too few meshes to agree
    assert bs.agreed_set(sets, {(10, 11): 7, (10,): 3}, at) == 1         # 70% of them
    assert bs.agreed_set(sets, {(10, 11): 6, (10,): 3}, at) is None      # 67%
    assert bs.agreed_set(sets, {(10, 13): 4}, at) is None                # a bone that is not a candidate
    assert bs.agreed_set(sets, {(11, 12): 4}, at) is None                # not among the sets weighed
    assert bs.agreed_set(sets, {}, at) is None
