"""The pose sampler (spinemesh.anim): curves, timelines and poses, then against the official runtime.

The first tests build small skeletons here and check values worked out by hand. The last
compares a representative share of real skeletons with the official runtime's dump (bone
world transforms and attachment world vertices); ``scripts/prove_poses.py`` proves every
animation of every example and corpus skeleton.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from spinemesh.anim import Sampler, animation_time, atlas_regions, sample_pose
from spinemesh.anim.curves import bezier_points_3, bezier_points_4, percent_3, read_keys, value_4
from spinemesh.anim.dump import dump, pose_errors
from spinemesh.anim.timelines import _draw_order
from spinemesh.atlas import read_atlas
from spinemesh.skeleton import load_skeleton
from spinemesh.skeleton_curves import CURVES_35, CURVES_38, curve_spelling

from conftest import EXAMPLES
from runtime_tool import pose_dump
from test_skeleton_binary_v43 import _corpus_json, runtime43  # noqa: F401  (fixture)


def _cubic(p0, p1, p2, p3, s):
    return (1 - s) ** 3 * p0 + 3 * (1 - s) ** 2 * s * p1 + 3 * (1 - s) * s * s * p2 + s ** 3 * p3


def test_bezier_samples_lie_on_the_curve():
    pts = bezier_points_4(0.0, 0.0, 0.3, 10.0, 0.6, 0.0, 1.0, 20.0)
    for i, (x, y) in enumerate(pts):
        s = (i + 1) / 10
        assert x == pytest.approx(_cubic(0, 0.3, 0.6, 1, s), abs=1e-5)
        assert y == pytest.approx(_cubic(0, 10, 0, 20, s), abs=1e-4)


def test_curve_values_3x_and_4x():
    # A symmetric ease in-out passes through the middle; an ease-in lags behind linear.
    assert percent_3(bezier_points_3(0.25, 0, 0.75, 1), 0.5) == pytest.approx(0.5, abs=1e-6)
    assert percent_3(bezier_points_3(0.5, 0, 1, 1), 0.3) < 0.3
    assert percent_3(bezier_points_3(0.5, 0, 1, 1), 0) == 0 and percent_3(bezier_points_3(0.5, 0, 1, 1), 1) == 1
    pts = bezier_points_4(1.0, 5.0, 1.25, 5.0, 1.75, 15.0, 2.0, 15.0)
    assert value_4(pts, 1.5, 1.0, 5.0, 2.0, 15.0) == pytest.approx(10.0, abs=1e-4)
    assert value_4(pts, 1.2, 1.0, 5.0, 2.0, 15.0) < 7.0


def test_a_curve_point_on_its_key_gives_nan_at_the_key_as_float_division_does():
    """A 4.x curve whose first sampled point rounds (float32) onto its key's time divides 0 by 0
    at that time: the runtimes' floats, and the numpy floats the sampler used, give NaN; the
    sampler's Python floats must too, not raise (which would lose the whole animation)."""
    import warnings

    keys = read_keys([{"time": 1000, "value": 0, "curve": [1000, 0, 999.963, 1]}, {"time": 1001, "value": 1}],
                     lambda f: [f.get("value", 0)], four=True)
    assert keys.bezier[0][0][0][0] == 1000.0          # the first point sits on the key
    with warnings.catch_warnings():
        warnings.simplefilter("error")                # and no numpy warning either
        assert math.isnan(keys.at(1000.0)[0]) and math.isnan(keys.percent(1000.0)[1])
        assert keys.at(1000.5)[0] == pytest.approx(0.8967514693)
    assert math.isnan(percent_3([[0.0, 0.5]] + [[1.0, 1.0]] * 8, 0.0))    # 3.x: 0 / 0 the same way


def test_keys_linear_stepped_bezier_and_ends():
    frames = [{"value": 10, "curve": "stepped"}, {"time": 1, "value": 20}, {"time": 2, "value": 40,
              "curve": [2.25, 40, 2.75, 80]}, {"time": 3, "value": 80}]
    keys = read_keys(frames, lambda f: [f.get("value", 0)], four=True)
    assert keys.at(-0.1) is None                      # before the first key: the setup value
    assert keys.at(0.9)[0] == 10                      # stepped
    assert keys.at(1.5)[0] == pytest.approx(30)       # linear
    assert keys.at(2.5)[0] == pytest.approx(60, abs=1e-3)
    assert keys.at(9)[0] == 80                        # after the last key: the last value
    # 3.x rotate keys turn the shorter way: 170 -> -170 passes 180, not 0.
    keys = read_keys([{"angle": 170}, {"time": 1, "angle": -170}], lambda f: [f.get("angle", 0)],
                     four=False, angle=True)
    assert keys.at(0.5)[0] % 360 == pytest.approx(180)


#: One 3.x key's curve spelled each way a document may spell it, with what 3.5-3.7 and 3.8 make of
#: it at a quarter of the way (the runtimes' ``readCurve``: 3.5-3.7 read a list only, "stepped"
#: only as stepped; 3.8 reads a number with c2..c4 beside it, any text as stepped).
_EASE_IN = {"curve": 0.9, "c2": 0, "c3": 1, "c4": 1}
_CURVES_3 = [
    ({"curve": [0.9, 0, 1, 1]}, "bezier", "linear"),
    (_EASE_IN, "linear", "bezier"),
    ({"curve": 0.9}, "linear", "bezier"),
    ({"curve": "stepped"}, "stepped", "stepped"),
    ({"curve": "linear"}, "linear", "stepped"),
    ({"curve": None}, "linear", "linear"),
    ({}, "linear", "linear"),
]


@pytest.mark.parametrize("curve, old, new", _CURVES_3)
def test_3x_curves_read_as_each_version_reads_them(curve, old, new):
    ease_in = percent_3(bezier_points_3(0.9, 0, 1, 1), 0.25)
    expected = {"linear": 2.5, "stepped": 0.0, "bezier": 10 * ease_in}
    for spelling, drawn in ((CURVES_35, old), (CURVES_38, new)):
        keys = read_keys([{"time": 0, "x": 0, **curve}, {"time": 1, "x": 10}], lambda f: [f.get("x", 0)],
                         four=False, spelling=spelling)
        assert keys.at(0.25)[0] == pytest.approx(expected[drawn], abs=1e-6), (spelling, curve)


def test_3x_curve_spelling_follows_the_version_through_the_sampler():
    assert [curve_spelling(v) for v in ("3.5.51", "3.6.53", "3.7.94", "3.8.99", "3.8", "")] == [
        CURVES_35, CURVES_35, CURVES_35, CURVES_38, CURVES_38, CURVES_38]

    def doc(version):
        return {"skeleton": {"spine": version}, "bones": [{"name": "root"}],
                "animations": {"move": {"bones": {"root": {"translate": [
                    {"time": 0, "x": 0, **_EASE_IN}, {"time": 1, "x": 10}]}}}}}

    # The same keys: 3.7 moves the bone linearly (its runtime passes a number over), 3.8 eases in.
    assert Sampler(doc("3.7.94")).pose("move", 0.25).bone("root")[0, 2] == pytest.approx(2.5, abs=1e-5)
    assert Sampler(doc("3.8.99")).pose("move", 0.25).bone("root")[0, 2] < 1.0


def test_draw_order_offsets():
    slots = {"a": 0, "b": 1, "c": 2, "d": 3}
    assert _draw_order([{"slot": "a", "offset": 2}], slots) == [1, 2, 0, 3]
    assert _draw_order([{"slot": "d", "offset": -3}], slots) == [3, 0, 1, 2]
    assert _draw_order(None, slots) is None


def test_animation_time_loops_in_fixed_steps():
    assert animation_time(0.5, 0.4) == pytest.approx(0.1)
    assert animation_time(0.3, 1.0) == pytest.approx(0.3)
    assert animation_time(0.3, 0.0) == 0.0
    assert animation_time(2.5, 1.0, loop=False) == pytest.approx(2.5)


def _doc() -> dict:
    """A 4.2 skeleton: an arm that turns 90 degrees in 1 s, a region that switches at 0.5 s and
    turns red, a mesh deformed and one weighted between root and arm, a draw order swap."""
    return {
        "skeleton": {"spine": "4.2.00"},
        "bones": [{"name": "root"}, {"name": "arm", "parent": "root", "x": 5, "length": 10}],
        "slots": [{"name": "s", "bone": "arm", "attachment": "a"}, {"name": "m", "bone": "root", "attachment": "mesh"},
                  {"name": "w", "bone": "root", "attachment": "weighted"}],
        "skins": [{"name": "default", "attachments": {
            "s": {"a": {"width": 10, "height": 4}, "b": {"x": 1, "width": 2, "height": 2}},
            "m": {"mesh": {"type": "mesh", "uvs": [0, 0, 1, 0, 1, 1], "triangles": [0, 1, 2],
                           "vertices": [0, 0, 10, 0, 10, 10], "hull": 3}},
            "w": {"weighted": {"type": "mesh", "uvs": [0, 0, 1, 0, 1, 1], "triangles": [0, 1, 2], "hull": 3,
                               "vertices": [1, 0, 0, 0, 1, 2, 0, 5, 0, 0.5, 1, 0, 0, 0.5, 1, 1, 5, 0, 1]}}}}],
        "animations": {"turn": {
            "bones": {"arm": {"rotate": [{"value": 0}, {"time": 1, "value": 90}]}},
            "slots": {"s": {"attachment": [{"time": 0.5, "name": "b"}], "rgba": [{"color": "ff0000ff"}]}},
            "attachments": {"default": {"m": {"mesh": {
                "deform": [{}, {"time": 1, "offset": 4, "vertices": [0, 10]}]}}}},
            "drawOrder": [{"time": 0.75, "offsets": [{"slot": "s", "offset": 2}]}],
        }},
    }


def test_sampled_pose_follows_the_timelines():
    sampler = Sampler(_doc())
    pose = sampler.pose("turn", 0.25)
    r = math.radians(22.5)
    assert np.allclose(pose.bone("arm"), [[math.cos(r), -math.sin(r), 5], [math.sin(r), math.cos(r), 0]])
    s, m, w = pose.slots
    assert (s.attachment, m.attachment) == ("a", "mesh")
    assert np.allclose(s.color, [1, 0, 0, 1])
    # Region corners: bottom-left, top-left, top-right, bottom-right of a 10 x 4 quad on the arm.
    local = np.array([[-5, -2], [-5, 2], [5, 2], [5, -2]])
    assert np.allclose(s.vertices, local @ pose.bone("arm")[:, :2].T + [5, 0], atol=1e-5)
    assert np.allclose(m.vertices, [[0, 0], [10, 0], [10, 12.5]])    # a quarter of the deform (+10 in y)
    # Weighted: vertex 0 on root at (0, 0); vertex 1 half (5, 0) on root, half (0, 0) on the arm;
    # Vertex 2 at (5, 0) on the arm.
    assert np.allclose(w.vertices[:2], [[0, 0], [5, 0]], atol=1e-6)
    assert np.allclose(w.vertices[2], [5 + 5 * math.cos(r), 5 * math.sin(r)], atol=1e-5)
    pose = sampler.pose("turn", 0.8)
    assert [d.slot for d in pose.slots] == ["m", "w", "s"]             # draw order key at 0.75
    assert pose.slots[-1].attachment == "b"
    assert np.allclose(pose.world[:, :, 2], [[0, 0], [5, 0]])
    setup = sampler.pose(None)
    assert [d.attachment for d in setup.slots] == ["a", "mesh", "weighted"]
    assert np.allclose(setup.slots[1].vertices, [[0, 0], [10, 0], [10, 10]])
    with pytest.raises(KeyError):
        sample_pose(_doc(), "missing", 0.1)


def test_dump_layout():
    out = dump(Sampler(_doc()), "turn", [0.25, 1.0])
    assert [p["label"] for p in out["poses"]] == ["setup", "turn@0.25", "turn@1"]
    pose = out["poses"][1]
    assert set(pose["bones"]) == {"root", "arm"} and len(pose["bones"]["arm"]) == 6
    assert pose["attachments"][0]["type"] == "region" and len(pose["attachments"][0]["vertices"]) == 8
    assert pose_errors(pose, pose)["vertex"] == 0
    json.dumps(out, allow_nan=False)


#: skeleton (under the examples) -> what it covers. A few skeletons, two times each: the
#: whole set is proved by scripts/prove_poses.py.
CASES = {
    "4.2/spineboy/spineboy-pro.skel": "4.2 binary, IK with softness, 4.x bezier curves, clipping",
    "3.8/spineboy/spineboy-pro.json": "3.8 curves (split c1..c4), deform of weighted meshes, draw order",
    "4.1/stretchyman/stretchyman-pro.json": "IK stretch, transform constraints",
    "4.0/tank/tank-pro.json": "path constraint, region sequences of treads",
    "4.1/vine/vine-pro.json": "path constraint on a weighted path",
    "4.2/cloud-pot/cloud-pot.json": "4.2 physics stepped frame by frame (under a parent with physics), reset keys",
}


@pytest.mark.parametrize("skeleton", sorted(CASES))
def test_poses_match_the_official_runtime(skeleton, examples, spine_runtime, tmp_path):
    path = EXAMPLES / skeleton
    atlas = path.parent / f"{path.parent.name}.atlas"    # the examples' straight-alpha atlas
    doc = load_skeleton(path)
    sampler = Sampler(doc, None, atlas_regions(read_atlas(atlas)))
    for animation in list(doc["animations"])[:2]:
        theirs = pose_dump(spine_runtime, atlas, path, tmp_path / "d.json", animation, "0.3,1.1")
        ours = dump(sampler, animation, [0.3, 1.1])
        for a, b in zip(ours["poses"], theirs["poses"]):
            assert a["label"] == b["label"]
            e = pose_errors(a, b)
            assert not e["problems"], (animation, a["label"], e["problems"])
            assert e["bone"] <= 0.01 and e["vertex"] <= 0.01, (animation, a["label"], e)


@pytest.mark.parametrize("version", ["4.0.64", "4.1.24", "4.2.22"])
def test_a_bone_under_a_parent_scaled_to_zero_poses_as_in_the_official_runtime(version, spine_runtime, tmp_path):
    """Where the runtime divides by a parent's zero determinant and goes on, the pose is its
    pose, exact (the preview said "Not as a game shows it" of a slot symbol that was)."""
    from rig_project import make_worm_project
    from test_rig import flattened_under_a_world_constraint

    path = make_worm_project(tmp_path / "in")
    doc = flattened_under_a_world_constraint(version)
    path.write_text(json.dumps(doc))
    atlas = path.parent / "worm.atlas"
    theirs = pose_dump(spine_runtime, atlas, path, tmp_path / "d.json", "wiggle", "0,0.5")
    sampler = Sampler(doc, None, atlas_regions(read_atlas(atlas)))
    ours = dump(sampler, "wiggle", [0, 0.5])
    for a, b in zip(ours["poses"], theirs["poses"]):
        e = pose_errors(a, b)
        assert not e["problems"] and e["bone"] <= 0.01 and e["vertex"] <= 0.01, (a["label"], e)
    assert all(sampler.pose("wiggle", t).exact.all() for t in (0, 0.5))


def _cli(*args):
    import os
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "spinemesh", "pose", *map(str, args)], capture_output=True,
                          text=True, env=dict(os.environ, COLUMNS="200"))


def test_pose_command_writes_the_dump_layout(tmp_path):
    project = tmp_path / "project"
    project.mkdir()
    (project / "arm.json").write_text(json.dumps(_doc()))
    out = tmp_path / "pose.json"
    r = _cli(project / "arm.json", "--animation", "turn", "--times", "0.25,0.8", "--out", out)
    assert r.returncode == 0, r.stderr
    written = json.loads(out.read_text())
    assert [p["label"] for p in written["poses"]] == ["setup", "turn@0.25", "turn@0.8"]
    assert written["poses"][1] == json.loads(json.dumps(dump(Sampler(_doc()), "turn", [0.25])["poses"][1]))
    assert written["poses"][2]["attachments"][-1]["attachment"] == "b"
    # Bad input: one line naming the file, no traceback; nothing written inside the project.
    for args, words in (((project / "arm.json", "-a", "walk"), "no animation 'walk'"),
                        ((project / "arm.json", "--skin", "red"), "no skin 'red'"),
                        ((project / "arm.json", "--out", project / "p.json"), "inside the input"),
                        ((project / "arm.json", "-a", "turn", "--times", "1e9"), "game-loop steps")):
        r = _cli(*args)
        assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert len([line for line in r.stderr.splitlines() if words in line]) == 1
    assert sorted(p.name for p in project.iterdir()) == ["arm.json"]


def test_pose_command_reads_binary_skeletons(examples, tmp_path):
    """The command on a .skel writes what the sampler gives for it with the atlas beside it
    (the sampler itself is proved on .skel files against the runtime above)."""
    skel = EXAMPLES / "4.2/spineboy/spineboy-pro.skel"
    r = _cli(skel, "-a", "run", "--times", "0.4", "--out", tmp_path / "p.json")
    assert r.returncode == 0, r.stderr
    written = json.loads((tmp_path / "p.json").read_text())["poses"][1]
    sampler = Sampler(load_skeleton(skel), None, atlas_regions(read_atlas(skel.parent / "spineboy.atlas")))
    expected = json.loads(json.dumps(dump(sampler, "run", [0.4])["poses"][1]))
    assert written == expected


def test_physics_is_stepped_and_play_follows_one_game_loop():
    doc = {"skeleton": {"spine": "4.2.00"}, "bones": [{"name": "root"}, {"name": "drop", "parent": "root"}],
           "slots": [], "physics": [{"name": "p", "bone": "drop", "y": 1, "strength": 0, "gravity": 70}],
           "animations": {"idle": {"bones": {"root": {"rotate": [{"time": 2, "value": 0}]}}}}}
    sampler = Sampler(doc)
    ys = [sampler.pose("idle", t).bone("drop")[1, 2] for t in (0.0, 0.25, 0.5)]
    assert ys[0] == 0 and 0 > ys[1] > ys[2]                 # gravity pulls it down, faster and faster
    assert sampler.pose("idle", 0.5).exact.all()
    unsimulated = sampler.pose("idle", 0.5, physics=False)
    assert unsimulated.bone("drop")[1, 2] == 0 and not unsimulated.exact[1]
    times = [0.0, 0.25, 0.5]
    played = [p.bone("drop")[1, 2] for p in sampler.play("idle", times)]
    assert np.allclose(played, ys, atol=1e-6)
    with pytest.raises(ValueError):
        list(sampler.play("idle", [0.5, 0.25]))


def test_malformed_timelines_are_passed_over():
    """Groups and keys of the wrong shape (a document not checked by the loader) pose as if absent."""
    doc = _doc()
    doc["animations"]["bad"] = {
        "bones": 3, "slots": {"s": {"rgba": [{"color": "zz"}, "x"], "attachment": [{"time": "a", "name": 5}]}},
        "ik": "x", "transform": {"t": [{"mixRotate": "a", "curve": [1, "b"]}]}, "drawOrder": [{"offsets": [{"slot": 3}]}],
        "attachments": {"default": {"m": {"mesh": {"deform": [{"offset": -7, "vertices": ["a", 1]}]}}}},
    }
    pose = Sampler(doc).pose("bad", 0.5)
    assert [d.slot for d in pose.slots] == ["m", "w"]     # "5": an attachment the skin lacks, none drawn
    json.dumps(pose.to_dump(), allow_nan=False)


@pytest.mark.parametrize("name", ["tmd-ar15", "tmd-npcportrait"])
def test_43_poses_match_spine_core_43(name, runtime43, tmp_path):  # noqa: F811
    """4.3 through the official spine-core 4.3 (tests/runtime43/pose.mjs): every animation, every
    bone within the goal, IK, physics (tmd-ar15; stepped as 4.3 steps it, the harness's clock
    carried from pose to pose) and transform constraints (tmd-npcportrait) included, none
    flagged, and the attachments they draw with their light and dark colours."""
    from spinemesh.anim.dump import advance_clock
    from runtime_tool import node

    skeleton = _corpus_json(name)
    atlas = skeleton.with_suffix(".atlas")
    doc = load_skeleton(skeleton)
    poses = ",".join(f"{a}@{t}" for a in doc["animations"] for t in (0.3, 1.1))
    r = node(runtime43, "pose.mjs", atlas, skeleton, tmp_path / "d.json", poses)
    assert r.returncode == 0, r.stderr[-2000:]
    theirs = json.loads((tmp_path / "d.json").read_text())["poses"]
    sampler = Sampler(doc, None, atlas_regions(read_atlas(atlas)))
    assert bool(sampler.physics) == (name == "tmd-ar15")   # 4.3 physics is stepped
    clock = 0.0
    for pose in theirs:
        mine = sampler.pose(pose["anim"], pose["time"], clock=clock)
        if pose["anim"] is not None:
            clock = advance_clock(clock, pose["time"])
        assert not mine.why and all(d["exact"] for d in mine.to_dump()["attachments"]), (pose["label"], mine.why)
        e = pose_errors(mine.to_dump(), pose)
        assert not e["problems"] and e["bone"] <= 0.01 and e["vertex"] <= 0.01, (pose["label"], e)
        drawn = {d["slot"]: d for d in mine.to_dump()["attachments"]}
        for a in pose["attachments"]:  # the colours drawn: light, and dark where the slot has one
            d = drawn[a["slot"]]
            assert ("dark" in d) == ("dark" in a), (pose["label"], a["slot"])
            assert np.allclose(d["color"], a["color"], atol=1e-5), (pose["label"], a["slot"], d["color"], a["color"])
            assert np.allclose(d.get("dark", 0), a.get("dark", 0), atol=1e-5), (pose["label"], a["slot"])


@pytest.mark.parametrize("version, fps", [("4.2.00", 1e9), ("4.3.23", 1e9)])
def test_the_setup_pose_is_exact_where_physics_is_not_stepped(version, fps):
    """Physics reset moves no bone in the runtimes, so the setup pose of a constraint not
    stepped here (finer than MAX_PHYSICS_FPS) is exact; an animation's pose flags its bones."""
    doc = {"skeleton": {"spine": version}, "bones": [{"name": "root"}, {"name": "hair", "parent": "root", "y": 5}],
           "slots": [{"name": "s", "bone": "hair", "attachment": "a"}],
           "skins": [{"name": "default", "attachments": {"s": {"a": {"width": 4, "height": 4}}}}],
           "animations": {"idle": {"bones": {"root": {"rotate": [{"time": 1, "value": 30}]}}}}}
    if version.startswith("4.3"):
        doc["constraints"] = [{"type": "physics", "name": "p", "bone": "hair", "x": 1, "fps": fps}]
    else:
        doc["physics"] = [{"name": "p", "bone": "hair", "x": 1, "fps": fps}]
    sampler = Sampler(doc)
    assert not sampler.physics and sampler.physics_bones                   # active, not stepped
    setup = sampler.pose(None)
    assert setup.exact.all() and not setup.why and all(d.exact for d in setup.slots)
    moved = sampler.pose("idle", 0.5)
    assert "hair" in moved.why and not moved.slots[0].exact


def test_skins_combined_draw_each_ones_attachments_and_pose_their_bones():
    """A tuple of skins is a combined skin, as a game dresses a mix-and-match character: each
    slot's attachment from the first skin that has it, then the default skin; the bones and
    constraints of every skin active."""
    doc = {"skeleton": {"spine": "4.2.22"},
           "bones": [{"name": "root"}, {"name": "hip", "parent": "root", "x": 5, "skin": True},
                     {"name": "brim", "parent": "root", "y": 7, "skin": True}],
           "slots": [{"name": "body", "bone": "hip", "attachment": "b"}, {"name": "hat", "bone": "brim", "attachment": "h"}],
           "skins": [{"name": "default", "attachments": {}},
                     {"name": "naked", "bones": ["hip"], "attachments": {"body": {"b": {"width": 4, "height": 2}}}},
                     {"name": "cap", "bones": ["brim"], "attachments": {"hat": {"h": {"width": 6, "height": 2}},
                                                                      "body": {"b": {"width": 8, "height": 2}}}}]}
    alone = Sampler(doc, "naked").pose(None)
    assert [d.slot for d in alone.slots] == ["body"] and not alone.active[2]
    both = Sampler(doc, ("naked", "cap")).pose(None)
    assert [(d.slot, d.skin) for d in both.slots] == [("body", "naked"), ("hat", "cap")]
    assert both.active.all() and np.allclose(both.bone("brim")[:, 2], [0, 7], atol=1e-5)
    assert np.ptp(np.asarray(both.slots[0].vertices)[:, 0]) == pytest.approx(4)   # the first skin's body
    assert Sampler(doc, ("cap", "naked")).pose(None).slots[0].skin == "cap"


def _regions_widened(doc: dict) -> dict:
    """``doc`` with every region attachment 1.5 times as wide: attachments changed, bones not."""
    import copy

    out = copy.deepcopy(doc)
    for skin in out["skins"]:
        for attachments in skin["attachments"].values():
            for att in attachments.values():
                if att.get("type", "region") == "region":
                    att["width"] = 1.5 * att.get("width", 32)
    return out


def _meshes_moved(doc: dict) -> dict:
    """``doc`` with every mesh moved one unit to the right (a weighted one: each influence's x):
    attachments changed, bones not."""
    import copy

    out = copy.deepcopy(doc)
    for skin in out["skins"]:
        for attachments in skin["attachments"].values():
            for att in attachments.values():
                if att.get("type") != "mesh":
                    continue
                v = att["vertices"]
                if len(v) == len(att["uvs"]):
                    att["vertices"] = [x + 1 if i % 2 == 0 else x for i, x in enumerate(v)]
                    continue
                i = 0
                while i < len(v):  # per vertex: its bone count, then bone, x, y, weight per bone
                    for k in range(int(v[i])):
                        v[i + 2 + 4 * k] += 1
                    i += 1 + 4 * int(v[i])
    return out


@pytest.mark.parametrize("changed", [_regions_widened, _meshes_moved])
@pytest.mark.parametrize("skeleton", ["4.2/cloud-pot/cloud-pot.json", "4.2/tank/tank-pro.json"])
def test_a_pair_played_together_poses_as_each_played_alone(skeleton, changed, examples):
    """play_pair steps the bones (physics, a path constraint) once for a skeleton and its twin
    whose attachments differ (regions or meshes), and places the attachments the twin keeps as
    they are once: each side's poses are exactly those it gives played alone, bit for bit."""
    from spinemesh.anim import same_motion

    doc = load_skeleton(EXAMPLES / skeleton)
    twin = changed(doc)
    assert same_motion(doc, twin)
    name = next(iter(doc["animations"]))
    times = [0.0, 0.3, 1.1]
    alone = [list(Sampler(d).play(name, times)) for d in (doc, twin)]
    together = list(Sampler(doc).play_pair(Sampler(twin), name, times))
    assert len(together) == len(times)
    for (p, q), a, b in zip(together, *alone):
        for got, want in ((p, a), (q, b)):
            assert np.array_equal(got.world, want.world) and np.array_equal(got.exact, want.exact)
            assert got.why == want.why and got.time == want.time
            assert [(s.slot, s.key, s.exact) for s in got.slots] == [(s.slot, s.key, s.exact) for s in want.slots]
            assert all(s.vertices.tobytes() == t.vertices.tobytes() and np.array_equal(s.color, t.color)
                       for s, t in zip(got.slots, want.slots))
    # the twin's own attachments are drawn, not the original's
    assert any(not np.array_equal(s.vertices, t.vertices) for s, t in zip(together[1][0].slots, together[1][1].slots))


def test_skeletons_move_alike_only_with_the_same_bones_constraints_and_paths(examples):
    from spinemesh.anim import same_motion

    tank = load_skeleton(EXAMPLES / "4.2/tank/tank-pro.json")
    assert same_motion(tank, _regions_widened(tank))
    moved = json.loads(json.dumps(tank))
    moved["bones"][1]["x"] = moved["bones"][1].get("x", 0) + 1
    assert not same_motion(tank, moved)
    target = tank["path"][0]["target"]
    bent = json.loads(json.dumps(tank))
    for skin in bent["skins"]:
        for att in (skin["attachments"].get(target) or {}).values():
            att["vertices"][0] += 1          # the path the constraint follows
    assert not same_motion(tank, bent)
    retimed = json.loads(json.dumps(tank))
    anim = next(iter(retimed["animations"].values()))
    retimed["animations"]["extra"] = {**anim, "bones": {}}
    assert not same_motion(tank, retimed)


def _swinging_tread(doc: dict) -> dict:
    """The tank with a physics bone hung on a tread its path constraint moves: the physics
    carries the path's motion from step to step (sorted last: a constraint's order is its place)."""
    bone = {"name": "swing", "parent": doc["path"][0]["bones"][0], "length": 40, "x": 20}
    physics = {"name": "swing", "bone": "swing", "x": 1, "y": 1, "rotate": 1, "inertia": 0.5, "strength": 60,
               "damping": 0.8, "mass": 1, "order": 9}
    return {**doc, "bones": [*doc["bones"], bone], "physics": [physics]}


@pytest.mark.parametrize("skeleton", ["4.2/cloud-pot/cloud-pot.json", "4.2/tank/tank-pro.json"])
def test_steps_between_drawn_frames_pose_the_bones_as_drawn_steps_do(skeleton, examples):
    """play steps the bones only (no colours, draw order, attachments but a path's) between the
    times it draws: its poses are exactly those of a play that draws every step."""
    doc = load_skeleton(EXAMPLES / skeleton)
    if "tank" in skeleton:
        doc = _swinging_tread(doc)
    name = next(iter(doc["animations"]))
    every = [i / 60 for i in range(90)]
    drawn = list(Sampler(doc).play(name, every))[::7]
    sparse = list(Sampler(doc).play(name, every[::7]))
    assert len(sparse) == len(drawn) == 13
    for a, b in zip(sparse, drawn):
        assert np.array_equal(a.world, b.world) and np.array_equal(a.exact, b.exact) and a.why == b.why
        assert all(np.array_equal(s.vertices, t.vertices) for s, t in zip(a.slots, b.slots))
    assert not np.array_equal(sparse[1].world, sparse[5].world)  # the bones move


@pytest.mark.parametrize("skeleton", ["3.8/tank/tank-pro.json", "4.2/coin/coin-pro.json", "4.2/owl/owl-pro.json"])
def test_one_sampler_asked_out_of_order_poses_as_a_fresh_one_each_time(skeleton, examples):
    """A sampler keeps what it found (each timeline's span between two keys, the constraints'
    values read once per data, the attachments found, setup values shared until a timeline sets
    them): asked times backwards, repeated, across animations and the setup pose between them,
    every pose (bones, vertices, light and dark colours) is the one a fresh sampler gives."""
    import random

    doc = load_skeleton(EXAMPLES / skeleton)
    names = list(doc["animations"])[:3]
    asks = [(a, t) for a in names for t in (0.9, 0.1, 0.37, 0.37, 2.5, 0.0)] + [(None, 0.0)]
    random.Random(7).shuffle(asks)
    asks.append((None, 0.0))  # the setup pose after every animation has been played
    sampler = Sampler(doc)
    for animation, time in asks:
        got = sampler.pose(animation, time, physics=False).to_dump()
        assert got == Sampler(doc).pose(animation, time, physics=False).to_dump(), (animation, time)


@pytest.mark.parametrize("skeleton", ["4.2/cloud-pot/cloud-pot.json", "4.2/tank/tank-pro.json"])
def test_poses_with_physics_asked_out_of_order_are_a_fresh_samplers_to_the_bit(skeleton, examples):
    """With physics stepped (each pose replays the game loop from 0; ``play`` steps one loop), a
    sampler asked times backwards, repeated, across animations and the setup pose between them
    poses every bone and vertex to the last bit as a fresh sampler does: nothing a step leaves on
    the rig's bones (their world transforms' numbers and the arrays read from them) carries over."""
    import random

    doc = load_skeleton(EXAMPLES / skeleton)
    if "tank" in skeleton:
        doc = _swinging_tread(doc)
    names = list(doc["animations"])[:2]
    asks = [(a, t) for a in names for t in (0.9, 0.1, 0.37, 0.37, 1.6, 0.0)] + [(None, 0.0)]
    random.Random(11).shuffle(asks)
    asks.append((None, 0.0))

    def same(a, b) -> bool:
        return (np.array_equal(a.world, b.world) and np.array_equal(a.exact, b.exact) and a.why == b.why
                and len(a.slots) == len(b.slots)
                and all(s.vertices.tobytes() == t.vertices.tobytes() for s, t in zip(a.slots, b.slots)))

    sampler = Sampler(doc)
    assert sampler.physics
    for animation, time in asks:
        assert same(sampler.pose(animation, time), Sampler(doc).pose(animation, time)), (animation, time)
    times = [0.0, 0.1, 0.37, 0.9]
    for name in names + names[::-1]:  # one game loop each, after poses of the other animation
        fresh = list(Sampler(doc).play(name, times))
        assert all(same(a, b) for a, b in zip(sampler.play(name, times), fresh)), name
