"""Poses at the edges where the runtimes of each version part: proved against their dumps.

Each case is a small rig of our own (``rig_project``'s worm) posed by the sampler and by the
official runtime of the skeleton's version (``../shared/tools/spine-runtime``), compared bone
by bone and vertex by vertex; where the runtime computes no number (NaN, null in its dump), our
dump holds null at the same places, and ``spinemesh pose`` says so in one line.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from rig_project import make_worm_project, worm_skeleton
from runtime_tool import pose_dump
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)

from spinemesh.anim import Sampler, atlas_regions
from spinemesh.anim.dump import dump
from spinemesh.atlas import read_atlas

VERSIONS = ["3.8.99", "4.0.64", "4.1.24", "4.2.22"]


def _worm(version: str) -> dict:
    """The worm in ``version``'s JSON (3.8 keys a rotation's ``angle``), with a ``target`` bone."""
    doc = worm_skeleton(version)
    if version.startswith("3."):
        for timelines in doc["animations"]["wiggle"]["bones"].values():
            for key in timelines["rotate"]:
                key["angle"] = key.pop("value")
    doc["bones"].append({"name": "target", "parent": "root", "x": 60, "y": 50})
    return doc


def _same_dumps(ours: dict, theirs: dict, tolerance: float = 0.01) -> None:
    """Every pose's bones and drawn vertices within ``tolerance``, null (no number) at the same places."""
    assert [p["label"] for p in ours["poses"]] == [p["label"] for p in theirs["poses"]]
    for a, b in zip(ours["poses"], theirs["poses"]):
        pairs = [(a["bones"][name], m, name) for name, m in b["bones"].items()]
        assert [s["slot"] for s in a["attachments"]] == [s["slot"] for s in b["attachments"]], a["label"]
        pairs += [(x["vertices"], y["vertices"], x["slot"]) for x, y in zip(a["attachments"], b["attachments"])]
        for mine, runtime, where in pairs:
            mine, runtime = np.array(mine, float), np.array(runtime, float)  # null -> NaN
            assert mine.shape == runtime.shape, (a["label"], where)
            assert (np.isnan(mine) == np.isnan(runtime)).all(), (a["label"], where, mine, runtime)
            known = ~np.isnan(runtime)
            assert np.abs(mine[known] - runtime[known]).max(initial=0) <= tolerance, (a["label"], where)


def _reach_under_a_flat_grandparent(version: str, scale: str) -> dict:
    """Two-bone IK on seg2 and seg3, whose grandparent seg1 is scaled to 0 along ``scale``."""
    doc = _worm(version)
    doc["bones"][1][scale] = 0
    doc["slots"][0]["bone"] = "seg3"
    doc["ik"] = [{"name": "reach", "bones": ["seg2", "seg3"], "target": "target"}]
    return doc


@pytest.mark.parametrize("scale", ["scaleX", "scaleY"])
@pytest.mark.parametrize("version", VERSIONS)
def test_two_bone_ik_under_a_grandparent_scaled_to_zero_poses_as_each_runtime(version, scale, spine_runtime,
                                                                               tmp_path):
    """3.8 and 4.0 divide by the grandparent's zero determinant: both IK bones and what they
    draw are NaN there (null in the dumps); 4.1 and 4.2 take the inverse as 0 and pose them."""
    path = make_worm_project(tmp_path / "in")
    doc = _reach_under_a_flat_grandparent(version, scale)
    path.write_text(json.dumps(doc))
    atlas = path.parent / "worm.atlas"
    theirs = pose_dump(spine_runtime, atlas, path, tmp_path / "d.json", "wiggle", "0,0.5")
    ours = dump(Sampler(doc, None, atlas_regions(read_atlas(atlas))), "wiggle", [0, 0.5])
    _same_dumps(ours, theirs)
    nan = any(None in p["bones"]["seg3"] for p in theirs["poses"])
    assert nan == (version[:3] in ("3.8", "4.0"))  # the case is the one each version parts on


def test_pose_says_in_one_line_which_bones_the_runtime_leaves_without_a_number(tmp_path):
    path = make_worm_project(tmp_path / "in")
    path.write_text(json.dumps(_reach_under_a_flat_grandparent("3.8.99", "scaleX")))
    out = tmp_path / "pose.json"
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", path, "-a", "wiggle", "--times", "0.5",
                        "--out", out], capture_output=True, text=True, check=False, env=dict(os.environ, COLUMNS="300"))
    assert r.returncode == 0, r.stderr
    said = [line for line in r.stderr.splitlines() if "not a number" in line]
    assert len(said) == 1 and "2 bones (seg2, seg3)" in said[0] and "setup, wiggle@0.5" in said[0], r.stderr
    text = out.read_text()
    assert "NaN" not in text and "Infinity" not in text
    pose = json.loads(text)["poses"][1]
    assert pose["bones"]["seg3"] == [None] * 6 and pose["bones"]["seg1"][0] == 0


def _spun(version: str, turns: float) -> dict:
    """seg2 set up at ``turns`` degrees; seg3 keyed 0, ``turns``, ``-turns`` (3.x reaches each key
    the shorter way round, then takes its value as written: the angle jumps there)."""
    doc = _worm(version)
    key = "angle" if version.startswith("3.") else "value"
    doc["bones"][2]["rotation"] = turns
    doc["slots"][0]["bone"] = "seg3"
    doc["animations"]["wiggle"]["bones"]["seg3"]["rotate"] = [
        {key: 0}, {"time": 0.5, key: turns}, {"time": 1, key: -turns}]
    return doc


SPUN_TIMES = [0.25, 0.5, 0.75, 0.9, 1.6]


@pytest.mark.parametrize("turns", [1e6, 1e8, 1e12])
@pytest.mark.parametrize("version", VERSIONS)
def test_rotations_of_a_million_to_a_trillion_degrees_pose_as_each_runtime(version, turns, spine_runtime,
                                                                            tmp_path):
    """The runtimes turn degrees into radians with their pi of 3.1415927, 9.3e-8 radians a turn
    from the true one, so an angle and the same angle a million turns on are drawn 5 degrees
    apart: the angle itself must be the runtime's, not one equal to it modulo 360. 4.x sets it
    to setup + keyed value (as the sampler does); 3.8 carries it from frame to frame, each step
    adding the keyed angle's difference brought within half a turn (its whole-number part cut
    to 32 bits as JavaScript's ``| 0`` cuts it), which the sampler replays. Within 1e-4."""
    path = make_worm_project(tmp_path / "in")
    doc = _spun(version, turns)
    path.write_text(json.dumps(doc))
    atlas = path.parent / "worm.atlas"
    theirs = pose_dump(spine_runtime, atlas, path, tmp_path / "d.json", "wiggle", ",".join(map(str, SPUN_TIMES)))
    ours = dump(Sampler(doc, None, atlas_regions(read_atlas(atlas))), "wiggle", SPUN_TIMES)
    _same_dumps(ours, theirs, tolerance=1e-4)


@pytest.mark.parametrize("turns", [1e6, 1e8, 1e12])
def test_rotations_of_a_million_to_a_trillion_degrees_pose_as_spine_core_43(turns, runtime43, tmp_path):  # noqa: F811
    from runtime_tool import node

    path = make_worm_project(tmp_path / "in")
    doc = _spun("4.3.23", turns)
    path.write_text(json.dumps(doc))
    r = node(runtime43, "pose.mjs", path.parent / "worm.atlas", path, tmp_path / "d.json",
             ",".join(f"wiggle@{t}" for t in SPUN_TIMES))
    assert r.returncode == 0, r.stderr[-2000:]
    theirs = json.loads((tmp_path / "d.json").read_text())
    sampler = Sampler(doc, None, atlas_regions(read_atlas(path.parent / "worm.atlas")))
    ours = {"poses": [{"label": p["label"], **sampler.pose("wiggle", p["time"]).to_dump()}
                      for p in theirs["poses"]]}
    assert len(ours["poses"]) == 1 + len(SPUN_TIMES)  # the setup pose first
    _same_dumps(ours, theirs, tolerance=1e-4)


def test_a_3x_angle_is_replayed_only_where_its_keys_jump_a_half_turn():
    """3.7 and 3.8 only (3.5, 3.6 and 4.x set the angle from the setup pose each frame)."""
    calm = Sampler(_worm("3.8.99")).animation("wiggle")[0]
    spun = Sampler(_spun("3.8.99", 1e6)).animation("wiggle")[0]
    assert not any(tl.carried for tl in calm.bones)
    assert [tl.carried for tl in spun.bones] == [False, True]
    for version in ("3.6.53", "4.2.22"):
        assert not any(tl.carried for tl in Sampler(_spun(version, 1e6)).animation("wiggle")[0].bones)


def _railed(version: str, rotate: str, spacing_mode: str, spacing: float, offset: float = 0) -> dict:
    """seg2 and seg3 (under seg1, scaled 1.3 along x, so their world lengths are not their setup
    lengths) laid along a curved three-segment path on a turned bone, by a path constraint in
    ``rotate`` mode, mixes 0.9 (rotate) and 0.8 (translate), the worm drawn on seg3; in
    ``version``'s JSON (3.8: ``rotateMix``/``translateMix`` and ``angle`` keys)."""
    doc = _worm(version)
    doc["bones"][1]["scaleX"] = 1.3
    doc["bones"].append({"name": "rail", "parent": "root", "rotation": 10})
    doc["slots"][0]["bone"] = "seg3"
    doc["slots"].append({"name": "rail", "bone": "rail", "attachment": "rail"})
    doc["skins"][0]["attachments"]["rail"] = {"rail": {
        "type": "path", "vertexCount": 9, "lengths": [200, 420, 700],
        "vertices": [-250, -40, -150, 0, -60, 120, 40, 160, 150, 60, 220, -60, 300, 0, 380, 80, 420, 200]}}
    mixes = {"rotateMix": 0.9, "translateMix": 0.8} if version.startswith("3.") else {"mixRotate": 0.9, "mixX": 0.8}
    doc["path"] = [{"name": "rail", "bones": ["seg2", "seg3"], "target": "rail", "positionMode": "fixed",
                    "position": 30, "spacingMode": spacing_mode, "spacing": spacing, "rotateMode": rotate,
                    "rotation": offset, **mixes}]
    return doc


RAILS = [(rotate, mode, spacing, offset) for rotate in ("chain", "chainScale", "tangent")
         for mode, spacing in (("length", 5), ("fixed", 70), ("percent", 0.2)) for offset in (0, 25)]


@pytest.mark.parametrize("rotate, mode, spacing, offset", RAILS)
def test_38_path_constraints_pose_as_the_official_38_runtime(rotate, mode, spacing, offset, spine_runtime,
                                                              tmp_path):
    """3.8 path constraints in every rotate and spacing mode, the bones laid in chain modes
    included, as the official 3.8 runtime lays them (spine-ts and libGDX 3.8: a fixed spacing
    scaled by the bone's world length, a percent one not).

    The harness's 3.8 runtime is a port (pixi-spine) whose path constraint differs from the
    official 3.8 one in two places: it never turns a bone in a chain mode towards the next
    point (its ``atan2`` is left out, so chain bones point along the world's x axis), and it
    spaces bones as runtimes before 3.7 did (a fixed spacing not scaled, a percent spacing in
    chain scale scaled). So it is not the proof here. Official 4.0 lays bones longer than the
    epsilon exactly as official 3.8 does (the spacing, the chain turn and tip, chain scale; only
    the names of the mixes differ), so the same rig written as 4.0 and posed by the official 4.0
    runtime is: equal to 1e-6, bones and vertices. Against the port, the bones it poses otherwise
    differ as said, and only those."""
    path = make_worm_project(tmp_path / "in")
    atlas = path.parent / "worm.atlas"
    path.write_text(json.dumps(_railed("4.0.64", rotate, mode, spacing, offset)))
    official = pose_dump(spine_runtime, atlas, path, tmp_path / "official.json", "wiggle", "0.3,0.7")
    doc = _railed("3.8.99", rotate, mode, spacing, offset)
    path.write_text(json.dumps(doc))
    port = pose_dump(spine_runtime, atlas, path, tmp_path / "port.json", "wiggle", "0.3,0.7")
    sampler = Sampler(doc, None, atlas_regions(read_atlas(atlas)))
    ours = dump(sampler, "wiggle", [0.3, 0.7])
    assert not any(p["inexact"] for p in ours["poses"])
    _same_dumps(ours, official, tolerance=2e-6)
    port_parts = rotate != "tangent" or (mode == "fixed")  # the chain turn; the spacing under a scale
    apart = max(np.abs(np.array(a["attachments"][0]["vertices"]) - b["attachments"][0]["vertices"]).max()
                for a, b in zip(ours["poses"], port["poses"]))  # the worm, drawn on seg3
    assert (apart > 10) == port_parts and (port_parts or apart < 1e-5), apart
    for a, b in zip(ours["poses"], port["poses"]):
        for name in ("root", "seg1", "rail", "target"):
            assert np.allclose(a["bones"][name], b["bones"][name], atol=1e-6)


@pytest.mark.parametrize("inherit", ["normal", "noRotationOrReflection"])
@pytest.mark.parametrize("extra", [{}, {"compress": True}, {"stretch": True}], ids=["plain", "compress", "stretch"])
@pytest.mark.parametrize("version", VERSIONS)
def test_one_bone_ik_under_a_parent_scaled_to_zero_poses_as_each_runtime(version, extra, inherit, spine_runtime,
                                                                          tmp_path):
    """seg3 aimed by one-bone IK, its parent seg2 scaled to 0 along x: 3.8 and 4.0 divide by the
    parent's zero determinant (NaN there, nothing drawn), 4.1 and 4.2 take the target as at the bone."""
    path = make_worm_project(tmp_path / "in")
    doc = _worm(version)
    doc["bones"][2]["scaleX"] = 0
    doc["bones"][3]["inherit" if version.startswith("4.2") else "transform"] = inherit
    doc["slots"][0]["bone"] = "seg3"
    doc["ik"] = [{"name": "aim", "bones": ["seg3"], "target": "target", **extra}]
    path.write_text(json.dumps(doc))
    atlas = path.parent / "worm.atlas"
    theirs = pose_dump(spine_runtime, atlas, path, tmp_path / "d.json", "wiggle", "0,0.5")
    _same_dumps(dump(Sampler(doc, None, atlas_regions(read_atlas(atlas))), "wiggle", [0, 0.5]), theirs)
    assert any(None in p["bones"]["seg3"] for p in theirs["poses"]) == (version[:3] in ("3.8", "4.0"))
