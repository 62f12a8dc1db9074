"""A two-bone IK whose chain hangs directly on the root, against the official runtimes.

The runtimes' two-bone IK works in the space of the first bone's parent (3.8 to 4.3 alike), so a
chain under the root (no grandparent) is solved as any other. No skeleton of the examples or the
corpus has such a chain: the fixture is made here, and posed by the 3.8-4.2 runtime tool
(``tests/runtime_tool.py``) and spine-core 4.3 (``tests/runtime43``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from spinemesh.anim import Sampler
from spinemesh.rig.bones import skeleton_bones

from rig_project import make_worm_project
from runtime_tool import node
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)

#: The proofs' goal, in world units (the runtimes' float32 and the dumps' rounding are far below).
GOAL = 0.01

#: An atlas of the worm's page in the layout every runtime reads (3.8's port reads no ``bounds``).
ATLAS = ("\nworm.png\nsize: 256,64\nformat: RGBA8888\nfilter: Linear,Linear\nrepeat: none\nworm\n"
         "  rotate: false\n  xy: 2, 2\n  size: 240, 60\n  orig: 240, 60\n  offset: 0, 0\n  index: -1\n")


def root_chain(version: str) -> dict:
    """A skeleton whose root is moved, turned and scaled, with two two-bone IKs directly under it:
    ``leg`` (bend negative, softness, stretch, mix 0.8) and ``arm`` (non-uniform root scale reached
    through a one-bone IK's target)."""
    four_three = version.startswith("4.3")
    bones = [{"name": "root", "x": 12, "y": -7, "rotation": 20, "scaleX": 1.3, "scaleY": 1.3},
             {"name": "thigh", "parent": "root", "x": 10, "y": 40, "rotation": -70, "length": 50},
             {"name": "shin", "parent": "thigh", "x": 50, "rotation": 20, "length": 45},
             {"name": "foot", "parent": "root", "x": 70, "y": -20},
             {"name": "upper", "parent": "root", "x": -30, "y": 60, "rotation": 150, "length": 30, "scaleY": 0.6},
             {"name": "fore", "parent": "upper", "x": 30, "rotation": -30, "length": 28},
             {"name": "hand", "parent": "root", "x": -50, "y": 20}]
    ik = [{"name": "leg", "bones": ["thigh", "shin"], "target": "foot", "bendPositive": False, "softness": 6,
           "stretch": True, "mix": 0.8},
          {"name": "arm", "order": 1, "bones": ["upper", "fore"], "target": "hand"}]
    slots = [{"name": "worm", "bone": "shin", "attachment": "worm"}]
    skins = [{"name": "default", "attachments": {"worm": {"worm": {"x": 20, "width": 240, "height": 60,
                                                                   "scaleX": 0.2, "scaleY": 0.2}}}}]
    doc = {"skeleton": {"spine": version}, "bones": bones, "slots": slots, "skins": skins, "animations": {}}
    if four_three:
        doc["constraints"] = [dict(c, type="ik") for c in ik]
        for c in doc["constraints"]:
            c.pop("order", None)
    else:
        doc["ik"] = ik
    return doc


def _assert_like(bones, theirs: dict) -> float:
    worst = 0.0
    for bone in bones:
        assert bone.exact, (bone.name, bone.why)
        m = theirs[bone.name]
        worst = max(worst, float(np.abs(np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]]) - bone.world).max()))
    assert worst <= GOAL, worst
    return worst


@pytest.mark.parametrize("version", ["3.8.99", "4.0.64", "4.1.24", "4.2.22"])
def test_two_bone_ik_under_the_root_matches_the_runtime(version, spine_runtime, tmp_path):
    make_worm_project(tmp_path)
    (tmp_path / "worm.atlas").write_text(ATLAS)
    path = tmp_path / "chain.json"
    doc = root_chain(version)
    path.write_text(json.dumps(doc))
    r = node(spine_runtime, "dump.mjs", tmp_path / "worm.atlas", path, "--out", tmp_path / "d.json")
    assert r.returncode == 0, r.stderr[-2000:]
    _assert_like(skeleton_bones(doc), json.loads((tmp_path / "d.json").read_text())["poses"][0]["bones"])


def test_two_bone_ik_under_the_root_matches_spine_core_43(runtime43, tmp_path):  # noqa: F811
    path = tmp_path / "chain.json"
    doc = root_chain("4.3.23")
    path.write_text(json.dumps(doc))
    r = node(runtime43, "pose.mjs", "", path, tmp_path / "d.json", "")
    assert r.returncode == 0, r.stderr[-2000:]
    theirs = json.loads((tmp_path / "d.json").read_text())["poses"][0]["bones"]
    _assert_like(skeleton_bones(doc), theirs)
    np.testing.assert_array_equal(np.stack([b.world for b in skeleton_bones(doc)]), Sampler(doc).pose(None).world)


@pytest.mark.parametrize("version", ["3.8.99", "4.2.22", "4.3.23"])
def test_two_bone_ik_under_the_root_moves_its_bones(version):
    """The IKs do something: without them the chains' bones are elsewhere."""
    doc = root_chain(version)
    bare = {k: v for k, v in doc.items() if k not in ("ik", "constraints")}
    posed = {b.name: b.world for b in skeleton_bones(doc)}
    unposed = {b.name: b.world for b in skeleton_bones(bare)}
    for name in ("thigh", "shin", "upper", "fore"):
        assert np.abs(posed[name] - unposed[name]).max() > 0.1, name
