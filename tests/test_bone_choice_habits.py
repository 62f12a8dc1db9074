"""The project's habits for the ``learned`` bone choice: tallies, leaving out, the prior, the report."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from spinemesh.rig import habits as hb
from spinemesh.rig.document import WeightOptions, build_rig, weight_document
from spinemesh.rig.learned import (FEATURES, MODEL_FORMAT, TreeEnsemble, candidates, choose_learned, project_habits,
                                   weighted_meshes)

from test_bone_choice_learned import _mesh_of, _worm_mesh_doc

H = {f: i for i, f in enumerate(hb.HABIT_FEATURES)}


def _weighted_worms() -> dict:
    """The worm mesh in two slots on ``seg1`` (``worm``, ``worm2``), both weighted by our own
    ``--bones rule`` (seg1, seg2, seg3: the artist's bones here), and a third, unweighted copy."""
    doc = _worm_mesh_doc()
    mesh = doc["skins"][0]["attachments"]["worm"]["worm"]
    for slot in ("worm2", "fresh"):
        doc["slots"].append({"name": slot, "bone": "seg1", "attachment": slot})
        doc["skins"][0]["attachments"][slot] = {slot: copy.deepcopy(mesh)}
    weight_document(doc, "worm.json", WeightOptions(bones="rule", method="harmonic", only=["worm", "worm2"]))
    return doc


def test_a_weighted_mesh_tallies_its_candidates_by_kind():
    doc = _weighted_worms()
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    meshes = weighted_meshes(doc, rig)
    assert [(m["slot"], sorted(names[b] for b in m["artist"])) for m in meshes] == [
        ("worm", ["seg1", "seg2", "seg3"]), ("worm2", ["seg1", "seg2", "seg3"])]
    m = meshes[0]
    kinds = hb.candidate_kinds(m["features"], FEATURES)
    relation = {names[b]: hb.RELATIONS[r] for b, r in zip(m["bones"], kinds["relation"])}
    assert relation == {"root": "ancestor of the slot bone", "seg1": "slot bone", "seg2": "below the slot bone",
                        "seg3": "below the slot bone", "beside": "sibling of the slot bone"}
    t = hb.tally(m["features"], m["label"], len(m["artist"]), FEATURES)
    others = hb.ProjectHabits(t[None], [hb.keys_of("other", "other")]).others(hb.keys_of("x", "y"))
    f = hb.habit_features(m["features"], FEATURES, others, np.zeros(hb.TALLY_SIZE))
    got = {names[b]: dict(zip(hb.HABIT_FEATURES, row)) for b, row in zip(m["bones"], f)}
    # one mesh seen, a prior of zero rates: its one child of the slot bone over the art bound -> 1 / (1 + 5)
    assert got["seg2"]["habit_kind"] == pytest.approx(1 / (1 + hb.PSEUDO_COUNT))
    assert got["seg3"]["habit_relation"] == pytest.approx(2 / (2 + hb.PSEUDO_COUNT))   # 2 of 2 below bound
    assert got["seg1"]["habit_slot_bound"] == pytest.approx(1 / (1 + hb.PSEUDO_COUNT))
    assert got["root"]["habit_kind"] == 0 and got["beside"]["habit_relation"] == 0
    assert got["seg1"]["habit_bones"] == pytest.approx(3 / (1 + hb.PSEUDO_COUNT))
    assert got["seg1"]["habit_rule"] == pytest.approx(3 / (3 + hb.PSEUDO_COUNT))   # the rule took 3, all bound
    assert [row["habit_meshes"] for row in got.values()] == pytest.approx([np.log(2)] * len(got))
    # many meshes of the same habit outweigh the prior
    many = hb.habit_features(m["features"], FEATURES, 1000 * t, np.zeros(hb.TALLY_SIZE))
    assert many[m["bones"].index(names.index("seg2")), H["habit_kind"]] == pytest.approx(1, abs=0.01)


def test_the_judged_mesh_and_its_namesakes_are_left_out():
    rng = np.random.default_rng(0)
    t = rng.random((6, hb.TALLY_SIZE))
    pools = np.array(["a", "a", "a", "b", "b", "c"])
    keys = [hb.keys_of("arm", "arm"), hb.keys_of("arm", "arm-red"), hb.keys_of("leg", "leg"),
            hb.keys_of("x", "x"), hb.keys_of("y", "y"), hb.keys_of("z", "z")]
    strict = hb.others_of(t, pools, keys)
    assert np.allclose(strict[0], t[2]) and np.allclose(strict[2], t[0] + t[1]) and np.allclose(strict[3], t[4])
    assert np.allclose(strict[5], 0)                      # alone in its project
    loose = hb.others_of(t, pools)
    assert np.allclose(loose[0], t[1] + t[2])


def test_a_project_without_weighted_meshes_gets_the_prior():
    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    assert project_habits([(_worm_mesh_doc(), rig)]).others(hb.keys_of("worm", "worm")).tolist() == [0] * hb.TALLY_SIZE
    cand = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {})
    doc = _weighted_worms()
    wrig = build_rig(doc)
    base = hb.prior(np.stack([hb.tally(m["features"], m["label"], len(m["artist"]), FEATURES)
                              for m in weighted_meshes(doc, wrig)]))
    f = hb.habit_features(cand.features, FEATURES, np.zeros(hb.TALLY_SIZE), base)
    kinds = hb.candidate_kinds(cand.features, FEATURES)
    start = 0
    for g, (name, n) in enumerate(hb.GROUPINGS):
        rate = base[start + 1:start + 2 * n:2] / np.maximum(base[start:start + 2 * n:2], 1e-9)
        assert np.allclose(f[:, g], rate[kinds[name]])
        start += 2 * n
    assert np.allclose(f[:, H["habit_bones"]], 3) and np.allclose(f[:, H["habit_slot_bound"]], 1)
    assert np.allclose(f[:, H["habit_meshes"]], 0)


def _habit_model() -> dict:
    """One split on the share of such bones the project bound: log-odds -3 at or below 0.2, +3 above."""
    names = FEATURES + hb.HABIT_FEATURES
    k = names.index("habit_kind")
    return {"format": MODEL_FORMAT, "features": list(names), "base": 0.0, "threshold": 0.5,
            "meta": {"habit_prior": [0.0] * hb.TALLY_SIZE},
            "trees": [{"feature": [k, -1, -1], "threshold": [0.2, 0, 0], "left": [1, 0, 0],
                       "right": [2, 0, 0], "value": [0, -3.0, 3.0]}]}


def test_the_habits_steer_the_choice_and_the_report_says_so():
    model = TreeEnsemble.from_json(_habit_model())
    assert model.reads_habits
    doc = _weighted_worms()
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    habits = project_habits([(doc, rig)])
    ref = next(r for r in weighted_meshes(doc, rig) if r["slot"] == "worm")
    fresh = doc["skins"][0]["attachments"]["fresh"]["fresh"]
    world = np.asarray(fresh["vertices"], float).reshape(-1, 2) + [-120, 0]
    tris = np.asarray(fresh["triangles"]).reshape(-1, 3)
    slot = rig.slot_bone["fresh"]
    without = choose_learned(rig.bones, slot, world, tris, set(), {}, model)
    assert [names[b] for b in without.bones] == ["seg1"]          # the prior: nothing likely, the slot bone
    with_them = choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits.others(hb.keys_of("fresh", "fresh")))
    assert sorted(names[b] for b in with_them.bones) == ["seg1", "seg2", "seg3"]
    assert "the project's habits: its artists bound 2 of 2 such bones (child of the slot bone, over the art) in 2 " \
        "weighted meshes" \
        in with_them.why[names.index("seg2")]
    assert "0.05 likely without the project's habits" in with_them.why[names.index("seg2")]
    # the mesh's own binding and its namesakes' are no habit of the project: worm sees worm2 only
    assert hb.meshes_in(habits.others(hb.keys_of(ref["slot"], ref["name"]))) == 1
    # a model with habits refuses to load without its prior
    data = _habit_model()
    del data["meta"]["habit_prior"]
    with pytest.raises(ValueError):
        TreeEnsemble.from_json(data)


def test_weights_reads_the_projects_habits_before_weighting(tmp_path):
    from spinemesh.rig.run import weight_project, write_report

    doc = _weighted_worms()
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "worm.json").write_text(json.dumps(doc))
    result = weight_project(tmp_path / "p" / "worm.json", tmp_path / "w",
                            WeightOptions(bones="learned", method="harmonic", only=["fresh"]))
    write_report(result, tmp_path / "r.json")
    rows = {r["slot"]: r for r in json.loads((tmp_path / "r.json").read_text())["attachments"]}
    assert rows["fresh"]["status"] == "weighted" and rows["fresh"]["bones"]
    assert all(w.startswith("learned:") for w in rows["fresh"]["bones"].values())


def test_a_weighted_mesh_tallies_the_shape_of_its_whole_set():
    doc = _weighted_worms()
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    m = weighted_meshes(doc, rig)[0]
    whole = np.flatnonzero(m["label"])
    shown = dict(zip(hb.SET_PATTERNS, hb.set_patterns(whole, m["features"], FEATURES)))
    assert shown["three bones"] == 1 and shown["one bone"] == shown["two bones"] == 0
    assert shown["a bone below the slot bone"] == 1 and shown["an ancestor of the slot bone"] == 0
    assert shown["the rule's set"] == 1 and shown["the slot bone alone"] == 0    # weighted by the rule
    slot = [m["bones"].index(names.index("seg1"))]
    alone = dict(zip(hb.SET_PATTERNS, hb.set_patterns(slot, m["features"], FEATURES)))
    assert alone["the slot bone alone"] == alone["one bone"] == 1 and alone["a bone below the slot bone"] == 0
    t = hb.tally(m["features"], m["label"], len(m["artist"]), FEATURES)
    shares = hb.pattern_shares(t, np.zeros(hb.TALLY_SIZE))
    # one set seen, a prior of zero rates: each pattern it shows 1 / (1 + 5), the others 0
    assert shares == pytest.approx(np.where(list(shown.values()), 1 / (1 + hb.PSEUDO_COUNT), 0))
    # an artist's bone beyond the candidates: the set's shape is not known, nothing tallied
    beyond = hb.tally(m["features"], m["label"], len(m["artist"]) + 1, FEATURES)
    assert hb.pattern_shares(beyond, np.zeros(hb.TALLY_SIZE)).tolist() == [0] * len(hb.SET_PATTERNS)


def test_the_sets_bound_on_the_same_slot_bone_are_neighbours():
    from spinemesh.rig.learned import neighbour_sets

    doc = _weighted_worms()
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    habits = project_habits([(doc, rig)])
    key = hb.rig_key(names)
    assert habits.neighbours(hb.keys_of("fresh", "fresh"), key, "seg1") == {frozenset({"seg1", "seg2", "seg3"}): 2}
    assert habits.neighbours(hb.keys_of("worm", "worm"), key, "seg1") == {frozenset({"seg1", "seg2", "seg3"}): 1}
    assert habits.neighbours(hb.keys_of("fresh", "fresh"), key, "seg2") == {}          # another slot bone
    assert habits.neighbours(hb.keys_of("fresh", "fresh"), hb.rig_key(names[:-1]), "seg1") == {}  # another rig
    got = neighbour_sets(habits, rig.bones, names.index("seg1"), hb.keys_of("fresh", "fresh"))
    assert got == {tuple(sorted(names.index(n) for n in ("seg1", "seg2", "seg3"))): 2}
    assert neighbour_sets(None, rig.bones, names.index("seg1"), set()) == {}


def test_known_sets_are_weighed_only_when_every_bone_can_be_bound():
    from spinemesh.rig import bone_sets

    p = np.array([0.9, 0.3, 0.2, 0.15, 0.1, 0.05])
    allowed = np.array([True] * 5 + [False])
    ancestors, parents_at = bone_sets.mesh_inputs(np.arange(6), np.arange(-1, 5))
    rule = np.zeros(6, bool)
    plain = [s for s, _ in bone_sets.candidate_sets(p, allowed, 0, ancestors, parents_at, 0.5, rule, 0)]
    known = {(0, 2, 4): 3, (0, 5): 1}
    sets = [s for s, _ in bone_sets.candidate_sets(p, allowed, 0, ancestors, parents_at, 0.5, rule, 0, known=known)]
    assert (0, 2, 4) not in plain and (0, 2, 4) in sets and (0, 5) not in sets
    f = bone_sets.habit_set_features(sets, np.zeros((6, len(FEATURES))), FEATURES,
                                     np.full(len(hb.SET_PATTERNS), 0.5), known)
    row = dict(zip(bone_sets.SET_HABIT_FEATURES, f[sets.index((0, 2, 4))]))
    assert row["neighbour_sets"] == 4 and row["neighbour_share"] == 0.75 and row["neighbour_most"] == 1
    assert dict(zip(bone_sets.SET_HABIT_FEATURES, f[sets.index((0,))]))["neighbour_share"] == 0


def _set_habit_model() -> dict:
    """A per-bone model finding no bone likely (the slot bone alone), with a set stage that takes
    the set most bound on the same slot bone: log-odds +3 when ``neighbour_share`` is over 0.5."""
    from spinemesh.rig import bone_sets

    data = _habit_model()
    data["trees"] = [{"feature": [-1], "threshold": [0], "left": [0], "right": [0], "value": [-3.0]}]
    names = bone_sets.SET_FEATURES + bone_sets.SET_HABIT_FEATURES
    k = names.index("neighbour_share")
    data["sets"] = {"format": bone_sets.SET_MODEL_FORMAT, "features": list(names), "base": 0.0, "threshold": 0.1,
                    "meta": {}, "trees": [{"feature": [k, -1, -1], "threshold": [0.5, 0, 0], "left": [1, 0, 0],
                                           "right": [2, 0, 0], "value": [0, -3.0, 3.0]}]}
    return data


def test_the_set_stage_binds_the_set_the_artists_bound_on_the_same_slot_bone():
    from spinemesh.rig.learned import neighbour_sets

    model = TreeEnsemble.from_json(_set_habit_model())
    doc = _weighted_worms()
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    habits = project_habits([(doc, rig)])
    fresh = doc["skins"][0]["attachments"]["fresh"]["fresh"]
    world = np.asarray(fresh["vertices"], float).reshape(-1, 2) + [-120, 0]
    tris = np.asarray(fresh["triangles"]).reshape(-1, 3)
    slot = rig.slot_bone["fresh"]
    keys = hb.keys_of("fresh", "fresh")
    alone = choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits.others(keys))
    assert [names[b] for b in alone.bones] == ["seg1"]
    near = neighbour_sets(habits, rig.bones, slot, keys)
    # the made per-bone model finds seg2 and seg3 unlikely: the set stage alone is tested here
    chosen = choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits.others(keys), near,
                            least_likely=0.0)
    assert sorted(names[b] for b in chosen.bones) == ["seg1", "seg2", "seg3"]
    assert ("the artists bound this set on 2 of the project's 2 other weighted meshes on the same slot bone or its "
            "mirror image") in chosen.why[names.index("seg2")]
    assert "not in the chosen set" in chosen.left_out[names.index("beside")]
    # a set stage reading the habits inside a model without their prior is refused
    data = _set_habit_model()
    data["features"] = list(FEATURES)
    data["trees"] = [{"feature": [-1], "threshold": [0], "left": [0], "right": [0], "value": [-3.0]}]
    with pytest.raises(ValueError):
        TreeEnsemble.from_json(data)


def test_the_set_the_meshes_on_the_same_slot_bone_agree_on_is_taken_whatever_the_set_model_scores():
    from spinemesh.rig import bone_sets
    from spinemesh.rig.learned import neighbour_sets

    data = _set_habit_model()
    data["sets"]["trees"][0]["value"] = [0, 3.0, -3.0]      # the set model now finds the neighbours' set unlikely
    model = TreeEnsemble.from_json(data)
    doc = _worm_mesh_doc()
    mesh = doc["skins"][0]["attachments"]["worm"]["worm"]
    for slot in ("worm2", "worm3", "fresh"):
        doc["slots"].append({"name": slot, "bone": "seg1", "attachment": slot})
        doc["skins"][0]["attachments"][slot] = {slot: copy.deepcopy(mesh)}
    fresh = doc["skins"][0]["attachments"]["fresh"]["fresh"]
    world = np.asarray(fresh["vertices"], float).reshape(-1, 2) + [-120, 0]
    tris = np.asarray(fresh["triangles"]).reshape(-1, 3)
    keys = hb.keys_of("fresh", "fresh")
    chosen = {}
    for weighted in (["worm", "worm2"], ["worm", "worm2", "worm3"]):
        weight_document(doc, "worm.json", WeightOptions(bones="rule", method="harmonic", only=weighted, replace=True))
        rig = build_rig(doc)
        habits = project_habits([(doc, rig)])
        slot = rig.slot_bone["fresh"]
        near = neighbour_sets(habits, rig.bones, slot, keys)
        assert sum(near.values()) == len(weighted)
        chosen[len(weighted)] = choose_learned(rig.bones, slot, world, tris, set(), {}, model, habits.others(keys),
                                               near, least_likely=0.0)  # the set stage alone
    names = [b.name for b in rig.bones]
    assert bone_sets.AGREED_MESHES == 3
    assert [names[b] for b in chosen[2].bones] == ["seg1"]          # two meshes do not make an agreement
    assert sorted(names[b] for b in chosen[3].bones) == ["seg1", "seg2", "seg3"]
    assert "in the set taken as agreed: the artists bound it on 3 of the project's 3 other weighted meshes on " \
           "the same slot bone or its mirror image" in chosen[3].why[names.index("seg2")]


def test_mirror_images_differ_only_in_their_side_markers_and_sets_move_across_by_tree_place():
    names = ["root", "body", "arm_L", "forearm_L", "hand_L", "arm_R", "forearm_R", "Left ear", "right ear", "l-leg2",
             "r-leg2", "armLower"]
    parents = [-1, 0, 1, 2, 3, 1, 5, 1, 1, 1, 1, 1]
    assert hb.mirror_bones(names, names.index("arm_L")) == [names.index("arm_R")]
    assert hb.mirror_bones(names, names.index("Left ear")) == [names.index("right ear")]
    assert hb.mirror_bones(names, names.index("r-leg2")) == [names.index("l-leg2")]
    assert hb.mirror_bones(names, names.index("body")) == [] and hb.mirror_bones(names, names.index("armLower")) == []
    at = {n: i for i, n in enumerate(names)}
    # the slot bone, the bone below it and the body they share move across
    moved = hb.mirror_set(parents, at["arm_L"], at["arm_R"], [at["arm_L"], at["forearm_L"], at["body"]])
    assert moved == tuple(sorted((at["arm_R"], at["forearm_R"], at["body"])))
    # the right arm has no hand: a set with the hand has no counterpart
    assert hb.mirror_set(parents, at["arm_L"], at["arm_R"], [at["arm_L"], at["hand_L"]]) is None
    got = hb.mirror_counts(parents, names, at["arm_R"], lambda bone: {(at["arm_L"], at["forearm_L"]): 2}
                           if bone == at["arm_L"] else {})
    assert got == {(at["arm_R"], at["forearm_R"]): 2}


def test_the_sets_bound_on_the_mirror_image_of_the_slot_bone_are_neighbours():
    from spinemesh.rig.learned import neighbour_sets

    doc = _weighted_worms()
    side = {f"seg{k}": f"seg{k}_l" for k in (1, 2, 3)}
    for bone in doc["bones"]:
        bone["name"] = side.get(bone["name"], bone["name"])
        if "parent" in bone:
            bone["parent"] = side.get(bone["parent"], bone["parent"])
    for slot in doc["slots"]:
        slot["bone"] = side.get(slot["bone"], slot["bone"])
    doc["animations"]["wiggle"]["bones"] = {side[b]: v for b, v in doc["animations"]["wiggle"]["bones"].items()}
    # the other side, appended (the weighted vertices' bone indices stay)
    doc["bones"] += [{"name": "seg1_r", "parent": "root", "length": 80, "x": -120, "y": 200},
                     {"name": "seg2_r", "parent": "seg1_r", "length": 80, "x": 80},
                     {"name": "seg3_r", "parent": "seg2_r", "length": 80, "x": 80}]
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    habits = project_habits([(doc, rig)])
    keys = hb.keys_of("fresh", "fresh")
    right = tuple(sorted(names.index(n) for n in ("seg1_r", "seg2_r", "seg3_r")))
    assert neighbour_sets(habits, rig.bones, names.index("seg1_r"), keys) == {right: 2}
    left = tuple(sorted(names.index(n) for n in ("seg1_l", "seg2_l", "seg3_l")))
    assert neighbour_sets(habits, rig.bones, names.index("seg1_l"), keys) == {left: 2}
    assert neighbour_sets(habits, rig.bones, names.index("seg2_r"), keys) == {}   # no mesh on seg2_l


def test_upgrade_reads_the_projects_habits_for_every_skeleton(tmp_path):
    """``upgrade --weights auto`` gives each skeleton's rig the habits of the weighted meshes of
    all of the project's skeletons, as ``spinemesh weights`` does: read from the documents as
    planned, before anything is tested for bending or weighted (:func:`.bending.gather_habits`)."""
    from spinemesh.project import find_project
    from spinemesh.upgrade import Options
    from spinemesh.upgrade.bending import gather_habits
    from spinemesh.upgrade.plan import plan_project
    from spinemesh.upgrade.report import Result

    from test_upgrade_weights import make_bar_project

    make_bar_project(tmp_path / "p")
    (tmp_path / "p" / "worm.json").write_text(json.dumps(_weighted_worms()))
    plans = {w: plan_project(find_project(tmp_path / "p"), Options(weights=w), Result()) for w in ("auto", "none")}
    gather_habits(plans["auto"])
    rigs = {sk.rel: sk.rig for sk in plans["auto"].skeletons}
    assert sorted(rigs) == ["bar.json", "worm.json"]
    assert rigs["bar.json"].habits is rigs["worm.json"].habits
    assert len(rigs["bar.json"].habits.tallies) == 2  # the two weighted worms, read for the bar too
    assert all(sk.rig is None for sk in plans["none"].skeletons)


def test_the_same_weighted_art_on_the_same_bones_is_measured_once(monkeypatch):
    """weighted_meshes measures the candidates of one art on one slot bone once (``worm`` and
    ``worm2`` are the same mesh on ``seg1``): every mesh's entry is what measuring it alone gives,
    and its own (changing one changes no other)."""
    from spinemesh.rig import learned
    from spinemesh.rig.binding import parse_vertices, setup_world

    doc = _weighted_worms()
    rig = build_rig(doc)
    measured = []
    monkeypatch.setattr(learned, "candidates", lambda *a, f=learned.candidates, **k: measured.append(1) or f(*a, **k))
    meshes = weighted_meshes(doc, rig)
    assert len(meshes) == 2 and len(measured) == 1
    for m in meshes:
        att = doc["skins"][0]["attachments"][m["slot"]][m["slot"]]
        world = setup_world(parse_vertices(att, len(rig.bones)), rig.worlds, rig.slot_bone[m["slot"]])
        alone = candidates(rig.bones, rig.slot_bone[m["slot"]], world, np.asarray(att["triangles"]).reshape(-1, 3),
                           rig.skin_bones.get("default", set()), rig.constrained)
        assert m["bones"] == alone.bones and m["rule"] == alone.rule.bones
        assert m["features"].tobytes() == alone.features.tobytes()
    meshes[0]["features"][:] = -1
    meshes[0]["bones"].append(-1)
    assert (meshes[1]["features"] != -1).any() and -1 not in meshes[1]["bones"]
