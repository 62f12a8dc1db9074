"""The motion guard of the bone choice: bones that would carry the art away from its slot's bone."""

from __future__ import annotations

import numpy as np

from spinemesh.rig.choice import Choice
from spinemesh.rig.document import build_rig
from spinemesh.anim.bone_worlds import sampled_bone_worlds
from spinemesh.rig.drift import DRIFT_LIMIT, drifts, guarded

from rig_project import worm_skeleton


def _worm_with_flap() -> dict:
    """The worm (root -> seg1 -> seg2 -> seg3 along x, -120..120; ``wiggle`` bends seg2 and seg3 by
    35 and 40 degrees, a forearm's bend) plus ``flap``, a bone lying over the art that ``wiggle``
    turns over and throws 300 units up: a paper-fold leaf or another part's bone."""
    doc = worm_skeleton()
    doc["bones"].append({"name": "flap", "parent": "root", "x": -40, "length": 80})
    doc["animations"]["wiggle"]["bones"]["flap"] = {
        "rotate": [{"value": 0}, {"time": 0.5, "value": 180}, {"time": 1, "value": 0}],
        "translate": [{"x": 0, "y": 0}, {"time": 0.5, "x": 0, "y": 300}, {"time": 1, "x": 0, "y": 0}]}
    return doc


ART = np.array([[x, y] for x in np.linspace(-120, 120, 7) for y in (-30.0, 30.0)])  # the worm's region


def _drift_of(doc) -> dict[str, float]:
    rig = build_rig(doc, sampled_bone_worlds)
    names = [b.name for b in rig.bones]
    frames = sampled_bone_worlds(doc)
    assert frames.shape == (3, len(names), 2, 3)                   # one animation, three frames
    got = drifts(ART, np.stack(rig.worlds), frames, names.index("seg1"), range(len(names)))
    return {names[i]: d for i, d in got.items()}


def test_a_bone_that_turns_the_art_over_drifts_far_a_bending_one_stays_near():
    drift = _drift_of(_worm_with_flap())
    assert drift["seg1"] == 0.0 and drift["root"] < 1e-9           # the slot's bone; neither moves in wiggle
    assert 0.1 < drift["seg2"] < drift["seg3"] < DRIFT_LIMIT        # the forearm and the hand bend the art
    assert drift["flap"] > 1.5 * DRIFT_LIMIT                        # turned over and thrown away


def test_the_guard_leaves_the_flipping_bone_out_and_keeps_the_forearm():
    doc = _worm_with_flap()
    rig = build_rig(doc, sampled_bone_worlds)
    idx = {b.name: b.index for b in rig.bones}
    drift = {idx[n]: d for n, d in _drift_of(doc).items()}
    chosen = Choice([idx["seg1"], idx["seg2"], idx["flap"]], {i: "chosen" for i in (1, 2, 4)}, {})
    out = guarded(chosen, drift, idx["seg1"], DRIFT_LIMIT)
    assert out.bones == [idx["seg1"], idx["seg2"]]
    assert "carry the art" in out.left_out[idx["flap"]] and idx["seg2"] in out.why
    # every chosen bone would carry it away: the slot's bone, where the region was drawn
    alone = guarded(Choice([idx["flap"]], {idx["flap"]: "chosen"}, {}), drift, idx["seg1"], DRIFT_LIMIT)
    assert alone.bones == [idx["seg1"]] and idx["flap"] in alone.left_out
    # without animations nothing is measured, and nothing left out
    still = worm_skeleton()
    still["animations"] = {}
    assert sampled_bone_worlds(still).shape[0] == 0
    assert drifts(ART, np.stack(rig.worlds), np.zeros((0, len(rig.bones), 2, 3)), 1, [4]) == {4: 0.0}


def test_the_auto_choice_is_guarded_where_the_slot_bone_carries_the_art():
    import pickle

    from spinemesh.rig.drift import Motion, guard

    doc = _worm_with_flap()
    rig = build_rig(doc, sampled_bone_worlds)
    idx = {b.name: b.index for b in rig.bones}
    tris = np.array([[2 * i + a for a in t] for i in range(6) for t in ((0, 2, 1), (1, 2, 3))])  # strips of ART
    chosen = Choice([idx["seg1"], idx["seg2"], idx["seg3"], idx["flap"]], {}, {})
    assert guard(chosen, rig.bones, idx["seg1"], ART, tris, rig.motion).bones == [idx[n] for n in ("seg1", "seg2", "seg3")]
    # a slot on the root (or far from the art) does not say where the art goes: nothing is left out
    assert guard(chosen, rig.bones, idx["root"], ART, tris, rig.motion).bones == chosen.bones
    far = _with_a_bone_far(doc)
    rig_far = build_rig(far, sampled_bone_worlds)
    assert guard(chosen, rig_far.bones, len(rig_far.bones) - 1, ART, tris, rig_far.motion).bones == chosen.bones
    # one bone chosen: no animation is sampled
    fresh = Motion(doc, sampled_bone_worlds)
    assert guard(Choice([idx["seg1"]], {}, {}), rig.bones, idx["seg1"], ART, tris, fresh).bones == [idx["seg1"]]
    assert fresh._frames is None
    # sent to another process, the motion carries the sampled frames, not the document
    sent = pickle.loads(pickle.dumps(Motion(doc, sampled_bone_worlds)))
    assert sent._doc is None and np.array_equal(sent.frames, rig.motion.frames)
    # without a sampler handed down (the Python API's default) there is nothing to guard by
    assert guard(chosen, rig.bones, idx["seg1"], ART, tris, build_rig(doc).motion).bones == chosen.bones


def _with_a_bone_far(doc: dict) -> dict:
    """``doc`` with a bone 1000 units from the art, last in the skeleton."""
    import copy

    out = copy.deepcopy(doc)
    out["bones"].append({"name": "elsewhere", "parent": "root", "x": 1000, "length": 40})
    return out


def test_upgrade_leaves_out_a_bone_that_would_throw_the_art_away(tmp_path):
    """``upgrade --weights auto`` guards its choice, on the workers too: a worm whose last bone
    turns over and flies 300 units up in its animation (a slash effect beside a kicking shoe's
    bone) keeps its art on the bones that bend it."""
    import json

    from rig_project import make_worm_project

    from spinemesh.upgrade import Options, upgrade_project

    doc = worm_skeleton()
    doc["animations"]["wiggle"]["bones"]["seg3"] = {
        "rotate": [{"value": 0}, {"time": 0.5, "value": 180}, {"time": 1, "value": 0}],
        "translate": [{"x": 0, "y": 0}, {"time": 0.5, "x": 0, "y": 300}, {"time": 1, "x": 0, "y": 0}]}
    path = make_worm_project(tmp_path / "in")
    path.write_text(json.dumps(doc))
    for jobs in (1, 2):  # weighted in this process, then on worker processes
        out = tmp_path / f"out{jobs}"
        (target,) = upgrade_project(tmp_path / "in", out, Options(weights="auto", jobs=jobs)).targets
        assert target.status == "meshed" and sorted(target.weights["bones"]) == ["seg1", "seg2"]
        assert "would carry the art" in target.weights["left_out"]["seg3"]
        mesh = json.loads((out / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]
        assert mesh["type"] == "mesh" and len(mesh["vertices"]) > 2 * len(mesh["uvs"])  # weighted
