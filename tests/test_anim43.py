"""4.3 constraints in the pose sampler, against the official spine-core 4.3 (tests/runtime43/pose.mjs).

Small 4.3 skeletons built here exercise each setting the sampler reproduces (physics stepped and
drawn between its steps; transform constraints' property mappings) and are played by both, at
many times of every animation, the harness's clock carried from pose to pose as
:func:`spinemesh.anim.dump.dump` carries it. No bone may be flagged, and every bone and vertex
must be within the proofs' goal (0.01 world units; in practice 1e-6, the harness's rounding).
"""

from __future__ import annotations

import json

import pytest

from spinemesh.anim import Sampler
from spinemesh.anim.dump import advance_clock, pose_errors
from spinemesh.skeleton import load_skeleton
from spinemesh.skeleton_binary import encode_skel

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


def transform_doc() -> dict:
    """A 4.3 skeleton whose transform constraints use every mapping form 4.3 has: world and local
    source, world and local target, every property onto itself and onto others, offsets (the
    constraint's, each source's and target's), scale, clamp (each way round), additive; sources a
    constraint changed before (their local values taken back from the world, in every inherit
    mode), animated mixes, an IK between them and stretching IKs scaling y uniformly or keeping
    the bone's area (one and two bones)."""
    bones = [{"name": "root"},
             {"name": "face", "parent": "root", "x": 20, "y": 50, "rotation": 15, "scaleX": 1.1, "length": 40},
             {"name": "eye", "parent": "face", "x": 30, "y": 5, "rotation": -10, "length": 10},
             {"name": "brow", "parent": "face", "x": 28, "y": 14, "length": 12, "shearY": 8},
             {"name": "lid", "parent": "eye", "x": 10, "length": 6, "inherit": "noScale"},
             {"name": "hat", "parent": "root", "x": -10, "y": 90, "rotation": 100, "length": 30,
              "inherit": "noRotationOrReflection"},
             {"name": "feather", "parent": "hat", "x": 30, "length": 20, "scaleY": 0.7},
             {"name": "tag", "parent": "root", "x": 40, "y": -10, "length": 15, "inherit": "onlyTranslation"},
             {"name": "torso", "parent": "root", "x": -5, "y": 8, "rotation": 5},
             {"name": "arm", "parent": "torso", "x": -20, "y": 30, "rotation": -60, "length": 25},
             {"name": "hand", "parent": "arm", "x": 25, "length": 12, "inherit": "noScaleOrReflection"},
             {"name": "aim", "parent": "root", "x": -50, "y": 10}]
    constraints = [
        # world -> world, every property onto itself, offsets, clamp on x
        {"type": "transform", "name": "w2w", "source": "face", "bones": ["eye"], "x": -5, "y": 3, "rotation": 12,
         "scaleX": 0.1, "shearY": 4, "clamp": True,
         "properties": {"rotate": {"to": {"rotate": {}}},
                        "x": {"offset": 2, "to": {"x": {"offset": 1, "max": 60, "scale": 0.5}}},
                        "y": {"to": {"y": {"max": 100}}}, "scaleX": {"to": {"scaleX": {}}},
                        "scaleY": {"to": {"scaleY": {"scale": 0.8}}}, "shearY": {"to": {"shearY": {}}}},
         "mixRotate": 0.6, "mixX": 0.5, "mixScaleX": 0.7, "mixShearY": 0.4},
        # crossed mappings, additive, world
        {"type": "transform", "name": "cross", "source": "face", "bones": ["brow", "tag"], "additive": True,
         "properties": {"rotate": {"offset": 10, "to": {"x": {"scale": 0.2}, "shearY": {"scale": 0.3}}},
                        "scaleX": {"to": {"rotate": {"scale": 20, "offset": -5}, "scaleY": {}}},
                        "y": {"to": {"scaleX": {"scale": 0.01}}}},
         "mixRotate": 0.5, "mixX": 0.8, "mixScaleX": 0.5, "mixScaleY": 0.3, "mixShearY": 0.9},
        # local source -> local target
        {"type": "transform", "name": "l2l", "source": "arm", "bones": ["hat"], "localSource": True,
         "localTarget": True, "rotation": 5, "x": 3,
         "properties": {"rotate": {"to": {"rotate": {}, "shearY": {"scale": 0.1}}},
                        "x": {"to": {"x": {"max": 50}, "y": {"scale": -1}}},
                        "scaleX": {"to": {"scaleX": {}, "scaleY": {}}}},
         "mixRotate": 0.7, "mixX": 0.3, "mixY": 0.9, "mixScaleX": 0.4, "mixShearY": 1},
        # local source reading a bone a world constraint changed; world target
        {"type": "transform", "name": "l2w", "source": "eye", "bones": ["feather"], "localSource": True,
         "properties": {"rotate": {"to": {"rotate": {}}}, "y": {"to": {"y": {"scale": 2}}},
                        "shearY": {"to": {"shearY": {}}},
                        "scaleY": {"to": {"scaleX": {}}}},
         "mixRotate": 0.5, "mixY": 0.5, "mixShearY": 0.5, "mixScaleX": 0.6},
        # world source -> local target, additive and clamped, on a bone a world constraint changed
        {"type": "transform", "name": "w2l", "source": "hand", "bones": ["lid", "eye"], "localTarget": True,
         "additive": True, "clamp": True,
         "properties": {"x": {"to": {"rotate": {"scale": 0.5, "max": 30, "offset": -30}}},
                        "rotate": {"to": {"scaleX": {"scale": 0.001, "max": 2}, "x": {"scale": 0.05, "max": 4}}},
                        "shearY": {"to": {"shearY": {"max": -20, "offset": 20}}}},
         "mixRotate": 1, "mixX": 0.5, "mixScaleX": 1, "mixShearY": 0.5},
        {"type": "ik", "name": "reach", "target": "aim", "bones": ["arm", "hand"]},
        # after IK: reads the IK'd hand in the world
        {"type": "transform", "name": "after", "source": "hand", "bones": ["tag"],
         "properties": {"rotate": {"to": {"rotate": {}}}, "x": {"to": {"x": {}}}}, "mixRotate": 0.3, "mixX": 0.2},
    ]
    anims = {
        "look": {
            "bones": {"face": {"rotate": [{"value": 0}, {"time": 0.5, "value": 40}, {"time": 1, "value": -30},
                                          {"time": 1.5, "value": 0}],
                               "translate": [{"x": 0}, {"time": 0.7, "x": 30, "y": -20}, {"time": 1.5}],
                               "scale": [{"x": 1}, {"time": 0.6, "x": 1.4, "y": 0.7}, {"time": 1.2, "x": 0.8}]},
                      "arm": {"rotate": [{"value": 0}, {"time": 0.8, "value": 120}],
                              "scale": [{"time": 0.3, "x": 1}, {"time": 0.9, "x": -1.2}]},
                      "aim": {"translate": [{"x": 0}, {"time": 1.0, "x": 40, "y": 30}]},
                      "eye": {"shear": [{"y": 0}, {"time": 1.0, "y": 20}]}},
            "transform": {"w2w": [{"mixRotate": 0.6, "mixX": 0.5, "mixScaleX": 0.7, "mixShearY": 0.4},
                                  {"time": 0.8, "mixRotate": 1, "mixX": 1, "mixY": 0.2, "mixScaleX": 0.1,
                                   "mixScaleY": 0.5, "mixShearY": 0}],
                          "l2l": [{"time": 0.4, "mixRotate": 0.2, "mixX": 0.5}, {"time": 1.1}]},
        },
    }
    slots = [{"name": n, "bone": n, "attachment": "box"} for n in ("eye", "brow", "lid", "feather", "tag", "hand")]
    skins = [{"name": "default", "attachments": {n: {"box": {"x": 5, "width": 10, "height": 4}} for n in
                                                  ("eye", "brow", "lid", "feather", "tag", "hand")}}]
    bones += [{"name": "neck", "parent": "root", "x": 5, "y": 5, "rotation": 70, "length": 20, "scaleY": 0.8},
              {"name": "nape", "parent": "root", "x": 60, "y": 60}]
    constraints.append({"type": "ik", "name": "stretchy", "target": "nape", "bones": ["neck"], "stretch": True,
                        "compress": True, "scaleY": "uniform"})
    bones += [{"name": "thigh", "parent": "torso", "x": 10, "y": -20, "rotation": -80, "length": 22},
              {"name": "shin", "parent": "thigh", "x": 22, "length": 20},
              {"name": "tail", "parent": "root", "x": -40, "y": -30, "rotation": 200, "length": 16},
              {"name": "fin", "parent": "root", "x": -45, "y": 20, "rotation": 30, "length": 60}]
    constraints += [{"type": "ik", "name": "leg", "target": "nape", "bones": ["thigh", "shin"], "stretch": True,
                     "scaleY": "volume"},
                    {"type": "ik", "name": "whip", "target": "aim", "bones": ["tail"], "compress": True,
                     "stretch": True, "scaleY": "volume"},
                    {"type": "ik", "name": "fold", "target": "aim", "bones": ["fin"], "compress": True,
                     "scaleY": "volume", "mix": 0.9}]
    anims["look"]["bones"]["nape"] = {"translate": [{"x": 0}, {"time": 1.0, "x": -70, "y": -55}]}
    return {"skeleton": {"spine": "4.3.23"}, "bones": bones, "slots": slots, "constraints": constraints,
            "skins": skins, "animations": anims}


def path_doc() -> dict:
    """A 4.3 skeleton whose path constraints (4.3 names the path's slot ``slot``) use each rotate
    mode (tangent, chain, chain scale), spacing mode (length, spacing animated below the bones'
    lengths, which 4.3 stops at 0; percent; proportional) and position mode, open, closed and
    weighted paths, constant speed and stored lengths, an offset rotation, animated positions,
    spacing and mixes, a deformed path and a path attachment changed by an animation."""
    bones = [{"name": "root"},
             {"name": "rail", "parent": "root", "x": -80, "y": 20, "rotation": 10},
             {"name": "loop", "parent": "root", "x": 60, "y": 80, "scaleX": 1.2},
             {"name": "ctl", "parent": "root", "x": 0, "y": 150}]
    for name in ("a", "b", "c"):
        parent = "root"
        for i in range(4):
            bones.append({"name": f"{name}{i}", "parent": parent, "length": 18 + 3 * i, "x": 20 if i else 0,
                          "rotation": 5 * i})
            parent = f"{name}{i}"
    open_path = {"type": "path", "lengths": [180, 360], "vertexCount": 6,
                 "vertices": [-20, -30, 0, 0, 40, 30, 90, 40, 130, 0, 170, -30]}
    closed_path = {"type": "path", "closed": True, "lengths": [60, 120, 180, 240], "vertexCount": 12,
                   "vertices": [-10, -30, 0, -30, 10, -30, 30, -10, 30, 0, 30, 10, 10, 30, 0, 30, -10, 30,
                                -30, 10, -30, 0, -30, -10]}
    stored = dict(open_path, constantSpeed=False)
    weighted = {"type": "path", "lengths": [150, 300], "vertexCount": 6,
                "vertices": [1, 0, -20, -30, 1, 1, 3, 0, 0, 1, 2, 3, 40, 30, 0.5, 0, 20, 10, 0.5, 1, 3, 90, 40, 1,
                             1, 3, 40, 0, 1, 2, 3, 80, -30, 0.7, 1, 0, 0, 0.3]}
    slots = [{"name": "track", "bone": "rail", "attachment": "p"}, {"name": "ring", "bone": "loop", "attachment": "p"},
             {"name": "cable", "bone": "root", "attachment": "p"}]
    for name in ("a", "b", "c"):
        slots += [{"name": f"{name}{i}", "bone": f"{name}{i}", "attachment": "box"} for i in range(4)]
    atts = {"track": {"p": open_path, "q": stored}, "ring": {"p": closed_path}, "cable": {"p": weighted}}
    for name in ("a", "b", "c"):
        for i in range(4):
            atts[f"{name}{i}"] = {"box": {"x": 6, "width": 12, "height": 4}}
    constraints = [
        {"type": "path", "name": "ride", "slot": "track", "bones": ["a0", "a1", "a2", "a3"], "position": 0.1,
         "spacing": 5, "rotation": 15, "mixX": 0.9},
        {"type": "path", "name": "spin", "slot": "ring", "bones": ["b0", "b1", "b2", "b3"], "positionMode": "fixed",
         "position": 30, "spacingMode": "percent", "spacing": 0.12, "rotateMode": "chainScale", "mixRotate": 0.8},
        {"type": "path", "name": "hang", "slot": "cable", "bones": ["c0", "c1", "c2", "c3"],
         "spacingMode": "proportional", "spacing": 0.9, "rotateMode": "chain", "mixY": 0.7},
    ]
    anims = {"go": {
        "bones": {"rail": {"rotate": [{"value": 0}, {"time": 1, "value": 30}]},
                  "loop": {"rotate": [{"value": 0}, {"time": 1.5, "value": 270}]},
                  "ctl": {"translate": [{"x": 0}, {"time": 0.8, "x": 40, "y": -60}]}},
        "path": {"ride": {"position": [{"value": 0.1}, {"time": 1, "value": 0.8}],
                          "spacing": [{"value": 5}, {"time": 0.6, "value": -40}]},
                 "spin": {"position": [{"value": 30}, {"time": 1.5, "value": 330}],
                          "mix": [{"mixRotate": 0.8}, {"time": 1, "mixRotate": 0.3, "mixX": 0.6}]}},
        "slots": {"track": {"attachment": [{"time": 1.2, "name": "q"}]}},
        "attachments": {"default": {"ring": {"p": {"deform": [{}, {"time": 0.7, "offset": 4,
                                                                   "vertices": [10, 5, 15, 5]},
                                                             {"time": 1.4}]}}}},
    }}
    return {"skeleton": {"spine": "4.3.23"}, "bones": bones, "slots": slots, "constraints": constraints,
            "skins": [{"name": "default", "attachments": atts}], "animations": anims}


def slider_doc() -> dict:
    """A 4.3 skeleton with sliders: one whose time and mix an animation keys, one driven by a
    bone's world x (looping, additive, mixed), one by a bone's local rotation; their animations
    rotate, translate, scale and shear bones, both axes and one."""
    bones = [{"name": "root"},
             {"name": "knob", "parent": "root", "x": -60, "y": 40},
             {"name": "dial", "parent": "root", "x": 60, "y": 40, "rotation": 20},
             {"name": "body", "parent": "root", "y": 10, "length": 40, "rotation": 90},
             {"name": "head", "parent": "body", "x": 40, "length": 20},
             {"name": "arm", "parent": "body", "x": 25, "y": 5, "length": 25, "rotation": -100, "scaleX": 1.1},
             {"name": "hand", "parent": "arm", "x": 25, "length": 10}]
    anims = {
        "nod": {"bones": {"head": {"rotate": [{"value": 0}, {"time": 1, "value": 40}, {"time": 2, "value": -20}],
                                   "translate": [{"time": 0.5, "x": 0}, {"time": 1.5, "x": 5, "y": -3}]},
                          "arm": {"scale": [{"x": 1, "y": 1}, {"time": 2, "x": 1.5, "y": 0.6}],
                                  "shear": [{"time": 0.2, "y": 0}, {"time": 1.8, "y": 25}]}}},
        "wave": {"bones": {"hand": {"rotate": [{"value": -30}, {"time": 0.5, "value": 30}, {"time": 1, "value": -30}],
                                    "scalex": [{"value": 1}, {"time": 1, "value": 0.5}]},
                           "arm": {"translatey": [{"value": 0}, {"time": 1, "value": 8}]}}},
        "play": {"bones": {"knob": {"translate": [{"x": 0}, {"time": 1, "x": 50}, {"time": 2, "x": -20}]},
                           "dial": {"rotate": [{"value": 0}, {"time": 2, "value": 200}]},
                           "body": {"rotate": [{"value": 0}, {"time": 1.5, "value": 15}]}},
                 "slider": {"timed": {"time": [{"value": 0}, {"time": 2, "value": 2}],
                                      "mix": [{"value": 1}, {"time": 1, "value": 0.4}]}}},
    }
    constraints = [
        {"type": "slider", "name": "timed", "animation": "nod", "time": 0.5},
        {"type": "slider", "name": "by_x", "animation": "wave", "bone": "knob", "property": "x", "from": -60,
         "to": 0.1, "scale": 0.02, "loop": True, "mix": 0.8, "additive": True},
        {"type": "slider", "name": "by_turn", "animation": "nod", "bone": "dial", "property": "rotate", "local": True,
         "scale": 0.01, "mix": 0.5},
    ]
    slots = [{"name": n, "bone": n, "attachment": "box"} for n in ("head", "arm", "hand")]
    skins = [{"name": "default", "attachments": {n: {"box": {"x": 5, "width": 10, "height": 4}} for n in
                                                  ("head", "arm", "hand")}}]
    return {"skeleton": {"spine": "4.3.23"}, "bones": bones, "slots": slots, "constraints": constraints,
            "skins": skins, "animations": anims}


def posed_by_both_43(runtime, doc: dict, tmp_path, times, binary: bool = False) -> list[tuple[dict, object]]:
    """Every animation of ``doc`` at ``times`` (the setup pose first) by spine-core 4.3 and by the
    sampler, one skeleton each, its clock carried from pose to pose as the harness plays them:
    per pose, the harness's entry and our :class:`~spinemesh.anim.Pose`. ``binary``: both read
    the ``.skel`` our writer makes of ``doc``."""
    if binary:
        path = tmp_path / "skeleton.skel"
        path.write_bytes(encode_skel(doc))
        doc = load_skeleton(path)
    else:
        path = tmp_path / "skeleton.json"
        path.write_text(json.dumps(doc), encoding="utf-8")
    poses = ",".join(f"{a}@{t}" for a in doc["animations"] for t in times)
    r = node(runtime, "pose.mjs", "", path, tmp_path / "d.json", poses)
    assert r.returncode == 0, r.stderr[-2000:]
    sampler, clock, out = Sampler(doc), 0.0, []
    for theirs in json.loads((tmp_path / "d.json").read_text())["poses"]:
        out.append((theirs, sampler.pose(theirs["anim"], theirs["time"], clock=clock)))
        if theirs["anim"] is not None:
            clock = advance_clock(clock, theirs["time"])
    return out


def _against_43(runtime, doc: dict, tmp_path, times=TIMES, binary: bool = False) -> list[dict]:
    """:func:`posed_by_both_43`'s poses compared: the errors of each, with the bones the sampler flags."""
    return [{"label": theirs["label"], "flagged": dict(mine.why), **pose_errors(mine.to_dump(), theirs, set(mine.why))}
            for theirs, mine in posed_by_both_43(runtime, doc, tmp_path, times, binary)]


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


def test_43_transform_constraints_match_spine_core_43(runtime43, tmp_path):  # noqa: F811
    """4.3 transform constraints (every mapping form) solved as spine-core 4.3 solves them, in
    4.3's update order, with IK between them: no bone flagged, all exact."""
    results = _against_43(runtime43, transform_doc(), tmp_path)
    _assert_exact(results)
    assert max(e["bone"] for e in results) < 1e-4


def _moved_by_each_constraint(doc: dict, animation: str, kind: str) -> list[tuple[str, list[bool]]]:
    """``(name, moved)`` for each constraint of type ``kind`` in ``doc``: per bone it constrains,
    whether ``animation`` at 0.37 s poses it otherwise (by over 0.01) without that constraint
    and its timeline (none is a no-op that a proof passes by)."""
    posed = Sampler(doc).pose(animation, 0.37)
    out = []
    for c in doc["constraints"]:
        if c["type"] != kind:
            continue
        alone = json.loads(json.dumps(doc))
        alone["constraints"] = [x for x in alone["constraints"] if x["name"] != c["name"]]
        alone["animations"][animation][kind].pop(c["name"], None)
        without = Sampler(alone).pose(animation, 0.37)
        out.append((c["name"], [abs(posed.bone(b) - without.bone(b)).max() > 0.01 for b in c["bones"]]))
    assert out, f"no {kind} constraint in the fixture"
    return out


def test_43_transform_constraints_move_their_bones():
    """Each constraint of the fixture moves its bones (none is a no-op the proof passes by)."""
    for c, moved in _moved_by_each_constraint(transform_doc(), "look", "transform"):
        assert any(moved), c


def test_43_path_constraints_match_spine_core_43(runtime43, tmp_path):  # noqa: F811
    """4.3 path constraints solved as spine-core 4.3 solves them: no bone flagged, all exact."""
    results = _against_43(runtime43, path_doc(), tmp_path)
    _assert_exact(results)
    assert max(e["bone"] for e in results) < 1e-4


def test_43_path_constraints_move_their_bones():
    for c, moved in _moved_by_each_constraint(path_doc(), "go", "path"):
        assert all(moved), c


def test_43_sliders_match_spine_core_43(runtime43, tmp_path):  # noqa: F811
    """4.3 sliders played as spine-core 4.3 plays them (their animation over the bones' current
    values, at a keyed time or one a bone's property drives): no bone flagged, all exact."""
    results = _against_43(runtime43, slider_doc(), tmp_path)
    _assert_exact(results)
    assert max(e["bone"] for e in results) < 1e-4


def test_43_sliders_move_their_bones():
    doc = slider_doc()
    for c in doc["constraints"]:
        alone = json.loads(json.dumps(doc))
        alone["constraints"] = [x for x in alone["constraints"] if x["name"] != c["name"]]
        posed, without = Sampler(doc).pose("play", 0.8), Sampler(alone).pose("play", 0.8)
        assert any(abs(posed.bone(b) - without.bone(b)).max() > 0.01 for b in ("head", "arm", "hand")), c["name"]


@pytest.mark.parametrize("make", [physics_doc, transform_doc, path_doc, slider_doc])
def test_43_fixtures_as_skel_match_spine_core_43(make, runtime43, tmp_path):  # noqa: F811
    """The same four skeletons as binary ``.skel`` (our writer; read by ours and by spine-core
    4.3): the constraints' settings read from the binary pose alike (float32 values)."""
    results = _against_43(runtime43, make(), tmp_path, TIMES[::2], binary=True)
    _assert_exact(results)


def test_43_what_is_not_solved_is_flagged():
    """A property the runtime does not know, and a slider whose animation changes more than
    bones, are not solved: the bones they move (and those below them) are flagged, never passed
    as exact."""
    doc = transform_doc()
    doc["constraints"][0]["properties"]["shearX"] = {"to": {"x": {}}}
    pose = Sampler(doc).pose("look", 0.37)
    assert "unknown property 'shearX'" in pose.why["eye"] and "lid" in pose.why
    # A slider whose animation changes more than bones: no constraint of the skeleton is solved.
    doc = slider_doc()
    doc["animations"]["wave"]["slots"] = {"hand": {"alpha": [{"value": 0.5}]}}
    pose = Sampler(doc).pose("play", 0.8)
    assert {"head", "arm", "hand"} <= set(pose.why)
