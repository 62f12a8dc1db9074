"""A Spine 4.3 skeleton document, built here, that uses every field the 4.3 loaders read.

The 4.3 corpus projects use few of 4.3's features (IK, physics and transform constraints,
meshes, sequences, deform keys); this document adds the rest: every constraint type with
every option (sliders with and without a bone, transform properties, physics scaleY
modes), every attachment type (weighted and not, linked meshes from another slot, convex
and inverse clipping), every timeline type with stepped and bezier curves, draw order
folders, events with audio, skin constraints and animation colours.

Values are float32-exact or rounded like the editor's export, and alpha keys are
multiples of 1/255 (the binary stores an alpha key as a byte).
"""

from __future__ import annotations

import copy

_SQUARE_UVS = [0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5]
_SQUARE_TRIANGLES = [0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4]
_SQUARE = [-10, -10, 10, -10, 10, 10, -10, 10, 0, 0]
#: Five vertices bound to bones 1 and 2: [count, (bone, x, y, weight) * count] each.
_WEIGHTED = [2, 1, -10, -10, 0.5, 2, -5, -5, 0.5,
             1, 1, 10, -10, 1,
             2, 1, 10, 10, 0.25, 2, 5, 5, 0.75,
             1, 2, -10, 10, 1,
             2, 1, 0, 0, 0.5, 2, 0, 0, 0.5]
_BEZIER1 = [0.25, 0, 0.75, 1]


def _curve(n: int) -> list:
    """A bezier curve for ``n`` values."""
    return _BEZIER1 * n


def _skeleton() -> dict:
    return {"hash": "q2nqeR4aP0U", "spine": "4.3.23", "x": -50.5, "y": -20.25, "width": 120, "height": 140.5,
            "referenceScale": 50, "fps": 24, "images": "./images/", "audio": "./audio/"}


def _bones() -> list:
    return [
        {"name": "root"},
        {"name": "hip", "parent": "root", "length": 20.5, "rotation": 15.25, "x": 3.5, "y": -7.75,
         "scaleX": 1.5, "scaleY": 0.75, "shearX": 5, "shearY": -3, "color": "ff0000ff", "icon": "ik",
         "iconSize": 2, "iconRotation": 45},
        {"name": "arm", "parent": "hip", "length": 30, "rotation": -20, "x": 20.5, "inherit": "noScale"},
        {"name": "hand", "parent": "arm", "x": 30, "inherit": "onlyTranslation", "skin": True},
        {"name": "tail", "parent": "root", "length": 12, "inherit": "noRotationOrReflection"},
        {"name": "tail2", "parent": "tail", "length": 12, "x": 12, "inherit": "noScaleOrReflection"},
        {"name": "target", "parent": "root", "x": 40, "y": 10},
        {"name": "knob", "parent": "root", "x": -30},
    ]


def _slots() -> list:
    return [
        {"name": "body", "bone": "hip", "attachment": "body"},
        {"name": "skin", "bone": "hip", "color": "ffeeddcc", "dark": "102030", "attachment": "skin",
         "blend": "additive"},
        {"name": "arm", "bone": "arm", "attachment": "arm", "blend": "multiply"},
        {"name": "copy", "bone": "arm", "attachment": "copy", "blend": "screen"},
        {"name": "box", "bone": "root", "attachment": "box"},
        {"name": "rail", "bone": "root", "attachment": "rail"},
        {"name": "tip", "bone": "hand", "attachment": "tip"},
        {"name": "clip", "bone": "root", "attachment": "clip"},
        {"name": "hidden", "bone": "root", "visible": False},
    ]


def _constraints() -> list:
    return [
        {"type": "ik", "name": "reach", "target": "target", "bones": ["hip", "arm"], "mix": 0.5, "softness": 3.5,
         "bendPositive": False, "compress": True, "stretch": True, "scaleY": "uniform"},
        {"type": "ik", "name": "point", "skin": True, "target": "target", "bones": ["hand"], "mix": 0},
        {"type": "transform", "name": "follow", "source": "knob", "bones": ["tail", "tail2"],
         "localSource": True, "localTarget": True, "additive": True, "clamp": True,
         "rotation": 10, "x": 2.5, "y": -3, "scaleX": 0.25, "scaleY": -0.5, "shearY": 7,
         "properties": {
             "rotate": {"offset": 5, "to": {"rotate": {"offset": 1, "max": 90, "scale": 0.5},
                                            "x": {"max": 30, "scale": 2}}},
             "x": {"to": {"y": {"offset": -2, "max": 100}}},
             "scaleX": {"offset": 0.5, "to": {"scaleX": {"max": 2}, "scaleY": {"scale": -1}}},
             "shearY": {"to": {"shearY": {}}}},
         "mixRotate": 0.5, "mixX": 0.25, "mixScaleX": 0.75, "mixScaleY": 0.125},
        {"type": "transform", "name": "plain", "skin": True, "source": "knob", "bones": ["hand"],
         "properties": {"y": {"to": {"y": {}}}}},
        {"type": "path", "name": "along", "slot": "rail", "bones": ["tail"], "positionMode": "fixed",
         "spacingMode": "proportional", "rotateMode": "chainScale", "rotation": 12.5, "position": 5,
         "spacing": 2, "mixRotate": 0.5, "mixX": 0.375, "mixY": 0.25},
        {"type": "path", "name": "percent", "skin": True, "slot": "rail", "bones": ["tail2"],
         "spacingMode": "percent", "rotateMode": "chain", "mixX": 0.5},
        {"type": "physics", "name": "wobble", "bone": "tail", "x": 0.125, "y": 0.25, "rotate": 0.375,
         "scaleX": 0.5, "scaleY": "volume", "shearX": 0.625, "limit": 300, "fps": 30, "inertia": 0.75,
         "strength": 90, "damping": 0.5, "mass": 2, "wind": 1.5, "gravity": -2, "mix": 0.875,
         "inertiaGlobal": True, "strengthGlobal": True, "dampingGlobal": True, "massGlobal": True,
         "windGlobal": True, "gravityGlobal": True, "mixGlobal": True},
        {"type": "physics", "name": "sway", "skin": True, "bone": "tail2", "scaleY": "uniform"},
        {"type": "slider", "name": "timer", "loop": True, "additive": True, "time": 0.5, "mix": 0.25,
         "animation": "blink"},
        {"type": "slider", "name": "dial", "skin": True, "bone": "knob", "property": "x", "from": 10, "to": 0.25,
         "scale": 0.5, "max": 5, "local": True, "mix": 0, "animation": "walk"},
    ]


def _attachments() -> dict:
    return {
        "body": {"body": {"x": 1.5, "y": -2.25, "scaleX": 0.5, "scaleY": 2, "rotation": 30, "width": 64,
                          "height": 32},
                 "body-seq": {"path": "frames/body", "color": "80ff80c0", "width": 16, "height": 16,
                              "sequence": {"count": 3, "start": 2, "digits": 2, "setup": 1}}},
        "skin": {"skin": {"type": "mesh", "uvs": _SQUARE_UVS, "triangles": _SQUARE_TRIANGLES,
                          "vertices": _WEIGHTED, "hull": 4, "edges": [0, 2, 2, 4, 4, 6, 6, 0],
                          "width": 20, "height": 20}},
        "arm": {"arm": {"type": "mesh", "path": "limbs/arm", "color": "ffffff80", "uvs": _SQUARE_UVS,
                        "triangles": _SQUARE_TRIANGLES, "vertices": _SQUARE, "hull": 4,
                        "sequence": {"count": 2}, "edges": [0, 2, 2, 4], "width": 20, "height": 20}},
        "box": {"box": {"type": "boundingbox", "vertexCount": 5, "vertices": _WEIGHTED, "color": "00ff00ff"}},
        "rail": {"rail": {"type": "path", "closed": True, "constantSpeed": False, "lengths": [50, 100],
                          "vertexCount": 6, "vertices": [0, 0, 10, 5, 20, 10, 30, 5, 40, 0, 50, -5],
                          "color": "ff8800ff"}},
        "tip": {"tip": {"type": "point", "x": 3, "y": 4, "rotation": 90, "color": "ffff00ff"}},
        "clip": {"clip": {"type": "clipping", "end": "tip", "convex": True, "inverse": True, "vertexCount": 4,
                          "vertices": [-20, -20, 20, -20, 20, 20, -20, 20], "color": "ff0000ff"}},
    }


def _skins() -> list:
    return [
        {"name": "default", "attachments": _attachments()},
        {"name": "alt", "color": "11223344", "bones": ["hand"],
         "ik": ["point"], "transform": ["plain"], "path": ["percent"], "physics": ["sway"], "slider": ["dial"],
         "attachments": {
             # A linked mesh in another slot sharing the default skin's arm mesh timelines ...
             "copy": {"copy": {"type": "linkedmesh", "path": "limbs/arm", "source": "arm", "slot": "arm",
                               "width": 20, "height": 20}},
             # ... and one in the same slot that keeps its own.
             "arm": {"arm-alt": {"type": "linkedmesh", "name": "arm2", "source": "arm",
                                 "timelines": False, "color": "ff00ffff",
                                 "sequence": {"count": 2}, "width": 20, "height": 20}}}},
    ]


def _events() -> dict:
    return {"step": {"int": 3, "float": 1.5, "string": "left"},
            "boom": {"audio": "boom.ogg", "volume": 0.75, "balance": -0.5}}


def _walk() -> dict:
    return {
        "color": "ff0000ff",
        "slots": {
            "body": {"attachment": [{"name": "body-seq"}, {"time": 0.5, "name": "body"}, {"time": 1}],
                     "rgba": [{"color": "ff0000ff", "curve": _curve(4)}, {"time": 0.5, "color": "00ff0080",
                                                                          "curve": "stepped"},
                              {"time": 1, "color": "0000ffff"}],
                     "alpha": [{"value": 0.2, "curve": _curve(1)}, {"time": 1, "value": 1}]},
            "skin": {"rgb": [{"color": "ff0000", "curve": _curve(3)}, {"time": 1, "color": "00ffff"}],
                     "rgba2": [{"light": "ff000080", "dark": "00ff00", "curve": _curve(7)},
                               {"time": 1, "light": "ffffffff", "dark": "000000"}]},
            "arm": {"rgb2": [{"light": "ff0000", "dark": "0000ff", "curve": "stepped"},
                             {"time": 1, "light": "00ff00", "dark": "ff00ff"}]},
        },
        "bones": {
            "hip": {"rotate": [{"value": 10, "curve": _curve(1)}, {"time": 0.5, "value": -10, "curve": "stepped"},
                               {"time": 1}],
                    "translate": [{"x": 1, "y": 2, "curve": _curve(2)}, {"time": 1, "x": -1}],
                    "translatex": [{"value": 3}, {"time": 1, "value": 4}],
                    "translatey": [{"value": -3, "curve": "stepped"}, {"time": 1}],
                    "scale": [{"x": 2, "curve": _curve(2)}, {"time": 1, "y": 0.5}],
                    "scalex": [{"value": 1.5}, {"time": 1}],
                    "scaley": [{"value": 0.5}, {"time": 1}],
                    "shear": [{"x": 5, "y": -5}, {"time": 1}],
                    "shearx": [{"value": 3, "curve": _curve(1)}, {"time": 1}],
                    "sheary": [{"value": -3}, {"time": 1}],
                    "inherit": [{"inherit": "noScale"}, {"time": 0.5}, {"time": 1, "inherit": "onlyTranslation"}]},
        },
        "ik": {"reach": [{"mix": 0.5, "softness": 2, "bendPositive": False, "compress": True, "curve": _curve(2)},
                         {"time": 0.5, "mix": 0, "stretch": True, "curve": "stepped"},
                         {"time": 1, "softness": 1.5}]},
        "transform": {"follow": [{"mixRotate": 0.5, "mixX": 0.25, "mixScaleX": 0.75, "curve": _curve(6)},
                                 {"time": 1, "mixY": 0.125, "mixScaleY": 0.5, "mixShearY": 0}]},
        "path": {"along": {"position": [{"value": 2, "curve": _curve(1)}, {"time": 1, "value": 8}],
                           "spacing": [{"value": 1}, {"time": 1, "value": 3}],
                           "mix": [{"mixRotate": 0.5, "mixX": 0.25, "curve": _curve(3)}, {"time": 1, "mixY": 0}]}},
        "physics": {"wobble": {"inertia": [{"value": 0.5}, {"time": 1, "value": 0.75}],
                               "strength": [{"value": 80, "curve": _curve(1)}, {"time": 1, "value": 90}],
                               "damping": [{"value": 0.25}], "mass": [{"value": 3}], "wind": [{"value": 2}],
                               "gravity": [{"value": -1}], "mix": [{"value": 0.5}, {"time": 1}],
                               "reset": [{"time": 0.5}, {"time": 0.75}]},
                    "": {"wind": [{"value": 1}, {"time": 1, "value": -1}], "reset": [{}]}},
        "slider": {"timer": {"time": [{"value": 0.25, "curve": _curve(1)}, {"time": 1}],
                             "mix": [{"value": 0.5}, {"time": 1, "value": 0.75}]},
                   "dial": {"mix": [{}, {"time": 1, "value": 0}]}},
        "attachments": {
            "default": {
                "skin": {"skin": {"deform": [{"curve": _curve(1)},
                                             {"time": 0.5, "offset": 2, "vertices": [1, 2, 3.5, -4],
                                              "curve": "stepped"},
                                             {"time": 1, "vertices": [0.5, 0.5]}]}},
                "arm": {"arm": {"deform": [{"vertices": [1, 1, -1, -1]}, {"time": 1}],
                                "sequence": [{"mode": "loop", "delay": 0.25}, {"time": 0.5, "mode": "pingpong",
                                                                                "index": 1},
                                             {"time": 0.75, "mode": "onceReverse", "delay": 0.125}]}},
                "body": {"body-seq": {"sequence": [{"mode": "once", "index": 2}]}},
            },
        },
        "drawOrder": [{"offsets": [{"slot": "box", "offset": -3}, {"slot": "tip", "offset": 1}]},
                      {"time": 0.5}, {"time": 1, "offsets": [{"slot": "body", "offset": 2}]}],
        "drawOrderFolder": [{"slots": ["box", "rail", "tip"],
                             "keys": [{"offsets": [{"slot": "tip", "offset": -2}]}, {"time": 1}]}],
        "events": [{"name": "step"}, {"time": 0.5, "name": "step", "int": 4, "float": 2.5, "string": "right"},
                   {"time": 1, "name": "boom", "volume": 0.5, "balance": 0.25}],
    }


def features_document() -> dict:
    """The document; a fresh copy on every call (tests may change it)."""
    return copy.deepcopy({
        "skeleton": _skeleton(), "bones": _bones(), "slots": _slots(), "constraints": _constraints(),
        "skins": _skins(), "events": _events(),
        "animations": {"walk": _walk(), "blink": {"slots": {"tip": {"alpha": [{"value": 0.4}]}}}},
    })
