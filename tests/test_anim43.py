"""4.3 constraints in the pose sampler, against the official spine-core 4.3 (tests/runtime43/pose.mjs).

Small 4.3 skeletons built here exercise each setting the sampler reproduces (physics stepped and
drawn between its steps; transform constraints' property mappings) and are played by both, at
many times of every animation, the harness's clock carried from pose to pose as
:func:`spinemesh.anim.dump.dump` carries it. No bone may be flagged, and every bone and vertex
must be within the proofs' goal (0.01 world units; in practice 1e-6, the harness's rounding).
"""

from __future__ import annotations

import json

from spinemesh.anim import Sampler
from spinemesh.anim.dump import advance_clock, pose_errors

from runtime_tool import node
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)

GOAL = 0.01
TIMES = (0.05, 0.1, 0.37, 0.55, 0.8, 1.19, 1.53, 2.4, 3.3)


def _boxes(*bones: str) -> tuple[list, list]:
    """A slot with a small region on each of ``bones`` (their vertices are compared too)."""
    slots = [{"name": n, "bone": n, "attachment": "box"} for n in bones]
    skins = [{"name": "default", "attachments": {n: {"box": {"x": 8, "width": 16, "height": 6}} for n in bones}}]
    return slots, skins


def physics_doc() -> dict:
    """A 4.3 skeleton whose physics constraints use every setting 4.3 steps: x, y, rotate, shearX,
    scaleX with each scaleY mode, inertia, strength, damping, mass, wind, gravity, limit, fps
    (coarser and finer than the frames), mix; animated values, global timelines and resets."""
    bones = [{"name": "root"},
             {"name": "body", "parent": "root", "y": 40, "rotation": 80, "length": 60},
             {"name": "tail", "parent": "body", "x": 60, "length": 40, "rotation": -30},
             {"name": "tip", "parent": "tail", "x": 40, "length": 30},
             {"name": "ear", "parent": "body", "x": 30, "y": 10, "length": 25, "rotation": 40},
             {"name": "lobe", "parent": "ear", "x": 25, "length": 15, "scaleX": 1.2},
             {"name": "cheek", "parent": "body", "x": 10, "y": -12, "length": 20, "rotation": -70},
             {"name": "chin", "parent": "root", "x": -30, "y": 10, "length": 18, "shearY": 12}]
    constraints = [
        {"type": "physics", "name": "tail", "bone": "tail", "x": 1, "y": 0.6, "rotate": 0.8, "inertia": 0.7,
         "strength": 140, "damping": 0.7, "mass": 1.6, "wind": 2, "gravity": -3, "windGlobal": True},
        {"type": "physics", "name": "tip", "bone": "tip", "rotate": 1, "shearX": 0.5, "scaleX": 0.4,
         "scaleY": "uniform", "fps": 30, "limit": 800, "gravityGlobal": True, "gravity": 4},
        {"type": "physics", "name": "ear", "bone": "ear", "scaleX": 1, "scaleY": "volume", "strength": 60, "mix": 0.8},
        {"type": "physics", "name": "lobe", "bone": "lobe", "shearX": 1, "x": 0.5, "mass": 0.5, "fps": 120},
        {"type": "physics", "name": "cheek", "bone": "cheek", "y": 1, "rotate": 0.3, "scaleX": 0.6, "fps": 45,
         "inertia": 1, "damping": 0.9},
        {"type": "physics", "name": "chin", "bone": "chin", "rotate": 0.5, "x": 0.3},
    ]
    sway = {
        "bones": {"root": {"translate": [{"x": 0}, {"time": 0.3, "x": 60, "y": 10,
                                                    "curve": [0.4, 60, 0.5, 80, 0.4, 10, 0.5, 0]},
                                         {"time": 0.7, "x": -40, "y": 30}, {"time": 1.2, "x": 0}]},
                  "body": {"rotate": [{"value": 0}, {"time": 0.5, "value": 35}, {"time": 1.0, "value": -20},
                                      {"time": 1.2, "value": 0}],
                           "scale": [{"time": 0.2, "x": 1}, {"time": 0.6, "x": 1.3, "y": 0.8}, {"time": 1.1}]},
                  "chin": {"rotate": [{"value": 0}, {"time": 0.4, "value": 90}, {"time": 0.9, "value": -45}]}},
        "physics": {"tail": {"mix": [{"value": 1}, {"time": 0.6, "value": 0.4}, {"time": 1.0}],
                             "strength": [{"value": 140}, {"time": 0.8, "value": 60}]},
                    "": {"wind": [{"time": 0.2, "value": 0}, {"time": 0.9, "value": 6}],
                         "gravity": [{"value": 4}, {"time": 1.0, "value": -2}]},
                    "ear": {"reset": [{"time": 0.55}]},
                    "cheek": {"damping": [{"value": 0.9}, {"time": 0.7, "value": 0.5}],
                              "mass": [{"value": 1}, {"time": 0.9, "value": 3}],
                              "inertia": [{"time": 0.3, "value": 0.3}]}},
    }
    still = {"bones": {"tail": {"rotate": [{"value": 0}, {"time": 2, "value": 10}]}},
             "physics": {"": {"reset": [{"time": 0.4}]}}}
    slots, skins = _boxes("tail", "tip", "ear", "lobe")
    return {"skeleton": {"spine": "4.3.23"}, "bones": bones, "slots": slots, "constraints": constraints,
            "skins": skins, "animations": {"sway": sway, "still": still}}


def _against_43(runtime, doc: dict, tmp_path, times=TIMES) -> list[dict]:
    """Every animation of ``doc`` at ``times`` by spine-core 4.3 and by the sampler (one skeleton,
    its clock carried from pose to pose, as the harness plays them): the errors of each pose,
    with the bones the sampler flags."""
    path = tmp_path / "skeleton.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    poses = ",".join(f"{a}@{t}" for a in doc["animations"] for t in times)
    r = node(runtime, "pose.mjs", "", path, tmp_path / "d.json", poses)
    assert r.returncode == 0, r.stderr[-2000:]
    sampler, clock, out = Sampler(doc), 0.0, []
    for theirs in json.loads((tmp_path / "d.json").read_text())["poses"]:
        mine = sampler.pose(theirs["anim"], theirs["time"], clock=clock)
        if theirs["anim"] is not None:
            clock = advance_clock(clock, theirs["time"])
        e = pose_errors(mine.to_dump(), theirs, set(mine.why))
        out.append({"label": theirs["label"], "flagged": dict(mine.why), **e})
    return out


def _assert_exact(results: list[dict]) -> None:
    for e in results:
        assert not e["flagged"], (e["label"], e["flagged"])
        assert not e["problems"] and e["bone"] <= GOAL and e["vertex"] <= GOAL, e


def test_43_physics_matches_spine_core_43(runtime43, tmp_path):  # noqa: F811
    """4.3 physics stepped as spine-core 4.3 steps it (the bone drawn between steps, its 4.3
    defaults, scaleY modes, animated and global values, resets): no bone flagged, all exact."""
    results = _against_43(runtime43, physics_doc(), tmp_path)
    _assert_exact(results)
    assert max(e["bone"] for e in results) < 1e-4   # the harness rounds to 1e-6


def test_43_physics_moves_its_bones():
    """The fixture's physics does something: its bones lag behind a pose without physics."""
    sampler = Sampler(physics_doc())
    stepped, still = sampler.pose("sway", 0.37), sampler.pose("sway", 0.37, physics=False)
    for bone in ("tail", "tip", "ear", "lobe", "cheek", "chin"):
        assert abs(stepped.bone(bone) - still.bone(bone)).max() > 0.01, bone
    assert set(still.why) >= {"tail", "tip", "ear", "lobe", "cheek", "chin"}
