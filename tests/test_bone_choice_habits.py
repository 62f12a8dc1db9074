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
