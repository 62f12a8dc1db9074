"""The ``learned`` bone choice: candidate features, the shipped model, and ``--bones rule``."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from spinemesh.rig import document
from spinemesh.rig.binding import parse_vertices, setup_world
from spinemesh.rig.choice import choose_by_rule
from spinemesh.rig.document import build_rig, choose
from spinemesh.rig.habits import HABIT_FEATURES, TALLY_SIZE
from spinemesh.rig.learned import (CHAIN_REACH, FEATURES, MODEL_FORMAT, MODEL_PATH, REACH, TreeEnsemble, candidates,
                                   choose_learned, constrained_bones, shipped_model)
from spinemesh.skeleton import iter_attachments, load_skeleton

from rig_project import worm_skeleton

SHARED = Path(__file__).resolve().parents[2] / "shared"
COL = {f: i for i, f in enumerate(FEATURES)}


def _worm_mesh_doc() -> dict:
    """The worm (root -> seg1 -> seg2 -> seg3 along x, -120..120) as a strip mesh on seg1, plus a
    bone far from the art and a bone beside it."""
    doc = worm_skeleton()
    doc["bones"] += [{"name": "far", "parent": "root", "x": 1000, "length": 50},
                     {"name": "beside", "parent": "root", "x": -60, "y": 40, "length": 30}]
    xs = np.linspace(0, 240, 9)
    local = [(x, y) for x in xs for y in (-20.0, 20.0)]              # in seg1's space (origin x=-120)
    tris = []
    for i in range(8):
        a, b, c, d = 2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3
        tris += [a, c, b, b, c, d]
    uvs = [v for x, y in local for v in (x / 240, (y + 20) / 40)]
    doc["skins"][0]["attachments"]["worm"]["worm"] = {
        "type": "mesh", "uvs": uvs, "vertices": [v for p in local for v in p], "triangles": tris,
        "hull": 4, "width": 240, "height": 40}
    return doc


def _mesh_of(doc):
    rig = build_rig(doc)
    ref = next(r for r in iter_attachments(doc) if r.type == "mesh")
    mesh = parse_vertices(ref.attachment, len(rig.bones))
    world = setup_world(mesh, rig.worlds, rig.slot_bone[ref.slot])
    tris = np.asarray(ref.attachment["triangles"]).reshape(-1, 3)
    return rig, ref, mesh, world, tris


def test_candidate_features_describe_the_rig_and_the_art():
    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    names = [b.name for b in rig.bones]
    cand = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {})
    got = {names[i]: dict(zip(FEATURES, row)) for i, row in zip(cand.bones, cand.features)}
    assert set(got) == {"root", "seg1", "seg2", "seg3", "beside"}  # "far" is beyond reach
    assert got["seg1"]["is_slot_bone"] == 1 and got["seg1"]["share_over_art"] == pytest.approx(1)
    seg2, seg3 = got["seg2"], got["seg3"]
    assert seg2["is_descendant"] == 1 and seg2["tree_distance"] == 1 and seg2["depth_difference"] == 1
    assert seg3["tree_distance"] == 2 and seg3["depth_difference"] == 2 and seg3["child_count"] == 0
    assert seg2["children_on_art"] == 1 and seg2["parent_on_art"] == 1 and seg3["parent_on_art"] == 1
    assert seg2["length_per_diag"] == pytest.approx(80 / np.hypot(240, 40))
    assert seg2["rule_chose"] == 1 and seg3["rule_chose"] == 1 and got["beside"]["rule_chose"] == 0
    assert got["root"]["is_root"] == 1 and got["root"]["is_point"] == 1 and got["root"]["is_ancestor"] == 1
    beside = got["beside"]
    assert beside["is_sibling"] == 1 and beside["share_over_art"] == 0
    assert beside["distance_per_diag"] == pytest.approx(20 / np.hypot(240, 40), rel=1e-6)
    assert beside["share_near_art"] == 0   # 20 units off, beyond 5% of the diagonal (12.2)
    shares = [got[n]["nearest_vertex_share"] for n in got]
    assert sum(shares) == pytest.approx(1)
    assert {row[COL["candidate_count"]] for row in cand.features} == {5}
    assert {row[COL["rule_bone_count"]] for row in cand.features} == {3}


def test_the_candidates_take_the_rules_distances_for_the_bones_both_measure():
    """The rule's 65 samples to a segment hold the candidates' 33: taken from the rule, they are
    the distances measured afresh, to the bit, point bones (the root) and zero-length bones too,
    and the rule's lengths are those it measures itself."""
    from spinemesh.rig.choice import lengths_on_art, rule_near, rule_samples
    from spinemesh.rig.learned import reach_limits, sample_distances

    doc = _worm_mesh_doc()
    doc["bones"].append({"name": "pin", "parent": "seg1", "x": 30})  # a zero-length bone on the art
    rig, ref, mesh, world, tris = _mesh_of(doc)
    slot = rig.slot_bone["worm"]
    limit = reach_limits(rig.bones, slot, float(np.linalg.norm(np.ptp(world, axis=0))))
    measured = rule_samples(rig.bones, world, tris, rule_near(world))
    ids, point, _ = measured
    assert point.any() and (~point).sum() >= 3
    fresh = sample_distances(rig.bones, world, tris, limit)
    taken = sample_distances(rig.bones, world, tris, limit, known=measured)
    assert np.array_equal(fresh[0], taken[0]) and len(fresh[0]) > len(ids)  # "beside": measured here only
    assert fresh[1].tobytes() == taken[1].tobytes()
    assert lengths_on_art(rig.bones, world, tris, 0.0, measured=measured) == lengths_on_art(rig.bones, world, tris, 0.0)


def test_candidates_reach_is_a_share_of_the_art_diagonal():
    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    names = [b.name for b in rig.bones]
    near = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {}, reach=0.05)
    # "beside" is 20 units off, 0.082 of the diagonal: out at 0.05, in at the default 0.25
    assert {names[i] for i in near.bones} == {"root", "seg1", "seg2", "seg3"}
    assert {row[COL["candidate_count"]] for row in near.features} == {4}


def test_candidates_reach_farther_along_the_slot_bones_chain_only():
    doc = _worm_mesh_doc()
    # 100 units past the art's end (0.41 of its diagonal): one below the slot bone, one beside the chain
    doc["bones"] += [{"name": "tail", "parent": "seg3", "x": 180, "length": 30},
                     {"name": "loose", "parent": "root", "x": 220, "length": 30}]
    rig, ref, mesh, world, tris = _mesh_of(doc)
    names = [b.name for b in rig.bones]
    slot = rig.slot_bone["worm"]
    within = candidates(rig.bones, slot, world, tris, set(), {}, chain_reach=REACH)
    assert {names[i] for i in within.bones} == {"root", "seg1", "seg2", "seg3", "beside"}
    assert CHAIN_REACH > 0.41
    along = candidates(rig.bones, slot, world, tris, set(), {})
    assert {names[i] for i in along.bones} == {"root", "seg1", "seg2", "seg3", "beside", "tail"}
    tail = dict(zip(FEATURES, along.features[along.bones.index(names.index("tail"))]))
    assert tail["is_descendant"] == 1 and tail["tree_distance"] == 3 and tail["share_over_art"] == 0
    assert tail["distance_per_diag"] == pytest.approx(100 / np.hypot(240, 40), rel=1e-6)


def test_constraint_roles_are_read_from_every_kind():
    doc = {"bones": [{"name": "a"}, {"name": "b"}, {"name": "c"}, {"name": "t"}],
           "ik": [{"name": "leg", "bones": ["b", "c"], "target": "t"}],
           "physics": [{"name": "hair", "bone": "a"}],
           "transform": [{"name": "bad", "bones": "not a list", "target": "t"}]}
    assert constrained_bones(doc) == {1: "ik", 2: "ik", 0: "physics"}


def _tree_model(feature: str, cut: float, threshold: float = 0.5) -> dict:
    """One split on ``feature``: log-odds -3 at or below ``cut``, +3 above."""
    return {"format": MODEL_FORMAT, "features": list(FEATURES), "base": 0.0, "threshold": threshold, "meta": {},
            "trees": [{"feature": [COL[feature], -1, -1], "threshold": [cut, 0, 0], "left": [1, 0, 0],
                       "right": [2, 0, 0], "value": [0, -3.0, 3.0]}]}


def test_learned_choice_follows_its_model_and_explains_every_candidate():
    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    names = [b.name for b in rig.bones]
    model = TreeEnsemble.from_json(_tree_model("nearest_vertex_share", 0.2))
    choice = choose_learned(rig.bones, rig.slot_bone["worm"], world, tris, set(), {}, model)
    cand = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {})
    expected = {names[i] for i, row in zip(cand.bones, cand.features) if row[COL["nearest_vertex_share"]] > 0.2}
    assert {names[b] for b in choice.bones} == expected and expected  # the worm's chain
    assert set(choice.why) | set(choice.left_out) == set(cand.bones)
    assert all(w.startswith("learned: 0.95") for w in choice.why.values())
    assert all("below the threshold" in w for w in choice.left_out.values())
    # a model that takes nothing binds the slot's bone, even where another bone is likelier
    none = TreeEnsemble.from_json(_tree_model("is_descendant", 0.5, threshold=0.99))  # seg2, seg3 0.95, slot 0.05
    only = choose_learned(rig.bones, rig.slot_bone["worm"], world, tris, set(), {}, none)
    assert only.bones == [rig.slot_bone["worm"]] and "none reached the threshold" in only.why[only.bones[0]]
    assert only.why[only.bones[0]].startswith("learned: 0.05")


@pytest.mark.parametrize("damage", ["format", "features", "child", "nan", "length"])
def test_malformed_models_are_refused(damage):
    data = _tree_model("share_over_art", 0.5)
    tree = data["trees"][0]
    if damage == "format":
        data["format"] = "other/1"
    elif damage == "features":
        data["features"] = data["features"][:-1]
    elif damage == "child":
        tree["right"][0] = 7
    elif damage == "nan":
        tree["value"][2] = float("nan")
    else:
        tree["value"] = tree["value"][:2]
    with pytest.raises(ValueError):
        TreeEnsemble.from_json(data)


def test_shipped_model_loads_small_and_reproduces_its_training_predictions():
    assert MODEL_PATH.stat().st_size < 400_000
    model = shipped_model()
    # it reads the project's habits, with the prior a project without weighted meshes gets
    assert model.features == FEATURES + HABIT_FEATURES and model.reads_habits and 0 < model.threshold < 1
    assert model.trees and len(model.meta["habit_prior"]) == TALLY_SIZE and model.meta["habit_prior"][0] > 0
    check = model.meta["check"]
    # log-odds scikit-learn gave these rows when the model was fitted: the numpy evaluation agrees
    assert np.allclose(model.raw(np.asarray(check["x"])), check["raw"], atol=1e-6)
    assert len(set(np.round(check["raw"], 6))) > 1
    assert json.loads(MODEL_PATH.read_text())["format"] == MODEL_FORMAT


def test_bones_rule_is_todays_rule_on_the_worm():
    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    choice = choose(rig, ref, mesh, world, tris, "rule")
    names = {b: rig.bones[b].name for b in range(len(rig.bones))}
    assert {names[b]: w for b, w in choice.why.items()} == {
        "seg1": "slot bone", "seg2": "segment over the art (80.0 units)", "seg3": "segment over the art (80.0 units)"}
    assert {names[b] for b in choice.left_out} == {"root"}


def test_auto_is_the_choice_that_measured_better(monkeypatch):
    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    for mode in ("rule", "learned"):
        monkeypatch.setattr(document, "AUTO_BONES", mode)
        assert choose(rig, ref, mesh, world, tris, "auto") == choose(rig, ref, mesh, world, tris, mode)
    assert document.BONE_CHOICES == ("keep", "auto", "rule", "learned")


def test_cli_bone_choices_match_the_library():
    from spinemesh.cli.weights import BoneChoice

    assert tuple(c.value for c in BoneChoice) == document.BONE_CHOICES


@pytest.mark.skipif(not (SHARED / "spine-examples" / "4.2").is_dir(), reason="needs the Spine examples")
@pytest.mark.parametrize("project", ["raptor", "spineboy", "stretchyman"])
def test_bones_rule_gives_the_rules_choices_on_artist_meshes(project):
    path = next((SHARED / "spine-examples" / "4.2" / project).glob("*-pro.json"))
    doc = load_skeleton(path)
    rig = build_rig(doc)
    seen = 0
    for ref in iter_attachments(doc):
        if ref.type != "mesh" or ref.slot not in rig.slot_bone:
            continue
        mesh = parse_vertices(ref.attachment, len(rig.bones))
        world = setup_world(mesh, rig.worlds, rig.slot_bone[ref.slot])
        tris = np.asarray(ref.attachment["triangles"]).reshape(-1, 3)
        rule = choose(rig, ref, mesh, world, tris, "rule")
        assert rule == choose_by_rule(rig.bones, rig.slot_bone[ref.slot], world, tris,
                                   rig.skin_bones.get(ref.skin, set()))
        learned = choose(rig, ref, mesh, world, tris, "learned")
        assert learned.bones and all(rig.bones[b].exact for b in learned.bones)
        assert all(w.startswith(("learned:", "slot bone")) for w in learned.why.values())
        seen += 1
    assert seen


def test_cli_weights_with_learned_bones_reports_why(tmp_path):
    from typer.testing import CliRunner

    from spinemesh.cli import app

    doc = _worm_mesh_doc()
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "worm.json").write_text(json.dumps(doc))
    before = copy.deepcopy(doc)
    r = CliRunner().invoke(app, ["weights", str(tmp_path / "p" / "worm.json"), "--out", str(tmp_path / "w"),
                                 "--bones", "learned", "--method", "harmonic", "--report", str(tmp_path / "r.json")])
    assert r.exit_code == 0, r.output
    row = json.loads((tmp_path / "r.json").read_text())["attachments"][0]
    assert row["status"] == "weighted" and row["bones"]
    assert all(w.startswith("learned:") for w in row["bones"].values())
    assert json.loads((tmp_path / "p" / "worm.json").read_text()) == before


def _toy_dataset() -> dict:
    """Two meshes of three candidates: mesh 0 (artist: bones 0, 1), mesh 1 (artist: bone 3)."""
    X = np.zeros((6, len(FEATURES)))
    X[[0, 3], COL["is_slot_bone"]] = 1
    return {"X": X, "y": np.array([1, 1, 0, 1, 0, 0], bool), "mesh": np.array([0, 0, 0, 1, 1, 1]),
            "group": np.array(["corpus/a", "corpus/b"]), "missed": np.array([0, 0]),
            "artist_count": np.array([2, 1])}


def test_held_out_judgement_counts_exact_sets_and_falls_back_to_the_slot_bone():
    from spinemesh.train import bone_choice as tc

    data = _toy_dataset()
    chosen = tc.choose_rows(data, np.array([0.9, 0.6, 0.2, 0.1, 0.3, 0.4]), 0.5)
    assert chosen.tolist() == [True, True, False, True, False, False]   # mesh 1: none likely -> slot bone
    s = tc.judge(data, chosen)
    assert s["exact"] == 1.0 and s["bones_p95"] == pytest.approx(1.95) and s["too_many"] == 0
    s = tc.judge(data, np.array([True, False, False, True, True, False]))
    assert s["exact"] == 0.0 and s["too_many"] == 0.5 and s["too_few"] == 0.5


def test_folds_hold_out_whole_repositories(tmp_path):
    """Projects of one repository (a game's characters: one rig, one artist) share a fold; the
    examples are all one repository; each fold model names the repositories it held out."""
    pytest.importorskip("sklearn")
    from spinemesh.train import bone_choice as tc

    for name, repo in (("a1", "studio/game"), ("a2", "studio/game"), ("b", "other/b")):
        (tmp_path / name).mkdir()
        (tmp_path / name / ".source.json").write_text(json.dumps({"repo": repo}))
    (tmp_path / "bare").mkdir()
    assert tc.repository_of("corpus/a2", tmp_path) == "studio/game"
    assert tc.repository_of("examples/spineboy", tmp_path) == tc.EXAMPLES_REPOSITORY
    assert tc.repository_of("corpus/bare", tmp_path) == "corpus/bare"
    groups = ["corpus/a1", "corpus/a2", "corpus/b", "corpus/bare", "examples/x", "examples/y"] * 3
    data = tc.with_folds({"group": np.array(groups)}, tmp_path, folds=3)
    fold_of = {}
    for g, r, k in zip(data["group"], data["repository"], data["fold"]):
        assert fold_of.setdefault(r, k) == k, f"{r} in two folds"
    assert set(fold_of.values()) == {0, 1, 2}
    models = {k: TreeEnsemble(FEATURES, 0.0, [], 0.5, {"held_out": sorted(r for r, f in fold_of.items() if f == k)})
              for k in range(3)}
    assert tc.model_for(models, "studio/game") is models[fold_of["studio/game"]]
    assert tc.model_for(models, "never/seen") is models[0]


def test_fitted_trees_export_to_the_shipped_format():
    pytest.importorskip("sklearn")
    from spinemesh.train import bone_choice as tc

    rng = np.random.default_rng(0)
    X = rng.random((600, len(FEATURES)))
    y = (X[:, COL["share_over_art"]] + 0.2 * rng.random(600)) > 0.6
    model = tc.fit(X, y)            # raises when the exported trees disagree with scikit-learn
    again = TreeEnsemble.from_json(json.loads(json.dumps(model.to_json())))
    assert np.array_equal(again.raw(X), model.raw(X))
    assert ((again.probability(X) >= 0.5) == y).mean() > 0.9


def test_the_set_model_learns_only_from_meshes_whose_artists_set_is_weighed(monkeypatch):
    from spinemesh.rig import bone_sets
    from spinemesh.train import bone_choice as tc

    data = {"group": np.array(["corpus/a", "corpus/a", "corpus/b"]), "missed": np.array([0, 0, 1])}
    # mesh 0: its artist's set among its three sets; mesh 1: every bone a candidate, its set not
    # weighed; mesh 2: a bone beyond the candidates
    sets = {"Z": np.arange(8 * len(bone_sets.SET_FEATURES), dtype=float).reshape(8, -1),
            "mesh": np.array([0, 0, 0, 1, 1, 2, 2, 2]),
            "exact": np.array([False, True, False, False, False, False, False, False])}
    seen = {}
    monkeypatch.setattr(tc, "fit_ranker", lambda Z, y, q, w, *a, **k: seen.update(Z=Z, y=y, q=q, w=w))
    tc.fit_sets(data, sets)
    assert seen["Z"].tolist() == sets["Z"][:3].tolist() and seen["y"].tolist() == [False, True, False]
    assert seen["q"].tolist() == [0, 0, 0] and np.allclose(seen["w"], 1.0)


def test_a_learning_curve_learns_from_the_projects_drawn_only():
    from spinemesh.train import bone_choice as tc

    # three meshes of project a (one row each), one of project b over two rows
    data = {"group": np.array(["corpus/a", "corpus/a", "corpus/a", "corpus/b"]), "mesh": np.array([0, 1, 2, 3, 3])}
    every = tc.mesh_weights(data, 0.5)
    assert every[:3] == pytest.approx(every[3:].sum() / 3 ** 0.5 * np.ones(3))   # a project of M meshes weighs M^0.5
    drawn = {**data, "learn_from": np.array([False, False, False, True])}
    assert tc.mesh_weights(drawn, 0.5)[:3].tolist() == [0, 0, 0] and tc.project_weights(drawn)[3] == 1.0
    groups = np.array([f"corpus/p{i}" for i in range(200)])
    half, quarter = tc.drawn_projects(groups, 0.5), tc.drawn_projects(groups, 0.25)
    assert 80 < half.sum() < 120 and (quarter <= half).all() and tc.drawn_projects(groups, 1.0).all()


def test_the_set_ranker_is_exported_as_trees_that_rank_as_lightgbm_does():
    from spinemesh.rig import bone_sets
    from spinemesh.train import bone_choice as tc

    rng = np.random.default_rng(1)
    queries = np.repeat(np.arange(300), 6)
    Z = rng.random((len(queries), len(bone_sets.SET_FEATURES)))
    # the artist's set of each query: the one with the largest first column
    first = np.zeros(len(queries), bool)
    first[np.arange(300) * 6 + Z[:, 0].reshape(300, 6).argmax(axis=1)] = True
    model = tc.fit_ranker(Z, first, queries, features=bone_sets.SET_FEATURES)   # raises when the trees disagree
    again = TreeEnsemble.from_json(json.loads(json.dumps(model.to_json(bone_sets.SET_MODEL_FORMAT))),
                                   bone_sets.SET_FEATURES, bone_sets.SET_MODEL_FORMAT)
    score = again.raw(Z).reshape(300, 6)
    assert np.array_equal(score, model.raw(Z).reshape(300, 6))
    assert (score.argmax(axis=1) == Z[:, 0].reshape(300, 6).argmax(axis=1)).mean() > 0.9


def test_rows_walked_together_score_as_walked_apart():
    """The learned choice scores its candidates with and without the project's habits in one walk
    of the trees (for the report's notes): each row's probability is the same to the bit as when
    its rows are scored alone."""
    from spinemesh.rig.learned import shipped_model

    model = shipped_model()
    rng = np.random.default_rng(5)
    for ensemble, score in ((model, model.probability), (model.sets, model.sets.raw if model.sets else None)):
        if ensemble is None:
            continue
        for rows in (1, 2, 7, 40):
            a = rng.normal(size=(rows, len(ensemble.features))) * rng.choice([0.1, 1, 10], size=len(ensemble.features))
            b = np.where(rng.random(a.shape) < 0.5, a, a + rng.normal(size=a.shape))
            assert score(np.vstack([a, b])).tobytes() == np.concatenate([score(a), score(b)]).tobytes()


def test_bones_the_model_finds_unlikely_are_left_out_of_the_set_taken(monkeypatch):
    """The set stage may take a bone the per-bone model finds under LEAST_LIKELY (the project's
    other meshes bound it): with the project's habits ``weights`` leaves it out, binding the
    slot's bone where nothing is left; without them, and for the upgrade's unweighted art, the
    set is kept."""
    import spinemesh.rig.learned as learned

    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    names = [b.name for b in rig.bones]
    slot = rig.slot_bone["worm"]
    model = TreeEnsemble.from_json(_tree_model("is_descendant", 0.5))   # seg2, seg3: 0.95; the others 0.05
    model.sets = object()                                               # a set stage, whose pick is given below
    cand = candidates(rig.bones, slot, world, tris, set(), {})
    at = {names[i]: k for k, i in enumerate(cand.bones)}
    assert learned.LEAST_LIKELY == 0.05 and {"seg2", "beside"} <= set(at)
    picked = {}
    monkeypatch.setattr(learned, "_by_sets", lambda *a, **k: (picked["set"], "the chosen set (given)"))

    habits = np.ones(TALLY_SIZE)                                        # the project's other weighted meshes
    picked["set"] = [at["seg2"], at["beside"]]
    choice = choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits)
    assert [names[b] for b in choice.bones] == ["seg2"]
    assert "under 0.05" in choice.left_out[names.index("beside")]
    assert choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits, explain=False).bones == choice.bones
    for kept in (choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits, least_likely=0.0),
                 choose_learned(rig.bones, slot, world, tris, set(), {}, model),               # no habits
                 choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits, unweighted=True)):
        assert {names[b] for b in kept.bones} == {"seg2", "beside"}

    picked["set"] = [at["beside"]]                                      # nothing likely left: the slot's bone
    alone = choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits)
    assert alone.bones == [slot] and "every other bone taken was under 0.05" in alone.why[slot]


def _raw_one_at_a_time(model: TreeEnsemble, x: np.ndarray) -> np.ndarray:
    """The ensemble's definition: each row down each tree alone, the leaves added tree by tree."""
    out = np.full(len(x), model.base)
    for tree in model.trees:
        leaves = []
        for row in x:
            n = 0
            while tree["feature"][n] >= 0:
                n = tree["left"][n] if row[tree["feature"][n]] <= tree["threshold"][n] else tree["right"][n]
            leaves.append(tree["value"][n])
        out += np.array(leaves)
    return out


def test_the_trees_walk_gives_each_rows_log_odds_to_the_bit():
    model = shipped_model()
    rng = np.random.default_rng(3)
    # a tree that is one leaf, a missing value (goes right) and infinities among the rows
    stump = {"feature": np.array([-1]), "threshold": np.array([0.0]), "left": np.array([0]),
             "right": np.array([0]), "value": np.array([0.25])}
    for ensemble in (model, model.sets, TreeEnsemble(model.features, -0.5, model.trees[:3] + [stump], 0.5, {})):
        x = rng.normal(size=(300, len(ensemble.features))) * 2
        x[rng.random(x.shape) < 0.05] = np.nan
        x[rng.random(x.shape) < 0.02] = np.inf
        x[rng.random(x.shape) < 0.02] = -np.inf
        assert ensemble.raw(x).tobytes() == _raw_one_at_a_time(ensemble, x).tobytes()
        assert ensemble.raw(x[:1]).tobytes() == _raw_one_at_a_time(ensemble, x[:1]).tobytes()
        assert ensemble.raw(x[:0]).shape == (0,)
    assert TreeEnsemble(model.features, 0.5, [], 0.5, {}).raw(np.zeros((2, len(model.features)))).tolist() == [0.5, 0.5]
