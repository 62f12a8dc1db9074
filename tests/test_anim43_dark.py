"""Two-colour tint in 4.3: each drawn slot's light and dark colour, against the official spine-core 4.3.

4.3 keeps a slot's colours in its pose and clamps every colour a timeline sets to 0..1 (the
light colour of ``rgb``, ``alpha`` and ``rgb2`` keys too, which 4.0 to 4.2 assign as they are;
the dark colour of ``rgba2`` and ``rgb2``). A small 4.3 skeleton built here keys ``rgba2`` and
``rgb2`` with Bezier curves that overshoot 0..1 both ways, stepped and linear keys, a first key
after the start (the setup colours before it), a slot with a dark colour no animation keys, and
slots without one (light timelines only: spine-core 4.3 cannot apply a two-colour timeline to
such a slot, it fails). ``tests/runtime43/pose.mjs`` writes the colours spine-core draws each
attachment with; the sampler's must match at many times, from the ``.json`` and from the
``.skel`` our writer makes of it.
"""

from __future__ import annotations

import numpy as np
from test_anim43 import posed_by_both_43
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)

from spinemesh.anim import Sampler

#: Times sampled (seconds): before, on and between keys, past the end (the animation loops).
TIMES = tuple(round(0.07 * i, 2) for i in range(31)) + (0.3, 0.8, 1.0, 1.2, 1.5, 1.9)

#: Largest difference allowed of any colour channel (spine-core's are rounded to 1e-6).
GOAL = 1e-5


def _bezier(*channels: tuple[float, float]) -> list[float]:
    """A 4.x key's ``curve`` over [0.0, 0.8]: per channel its two control points' values
    (times at a third and two thirds), which may lie outside 0..1 (the curve overshoots)."""
    return [v for c1, c2 in channels for v in (0.8 / 3, c1, 1.6 / 3, c2)]


def dark_doc() -> dict:
    """A 4.3 skeleton whose slots key two-colour tints (see the module's docstring)."""
    slots = [
        # rgba2: Bezier over- and undershooting on light and dark channels, then stepped, then linear
        {"name": "glow", "bone": "root", "attachment": "box", "dark": "336699"},
        # rgb2 from 0.3 (the setup colours before), Bezier, stepped, linear; alpha keyed past 0..1
        {"name": "edge", "bone": "root", "attachment": "box", "color": "ffffffc0", "dark": "ff8000"},
        # the corpus's 4.3 case: black dark colours, here with a curve undershooting black
        {"name": "black", "bone": "root", "attachment": "box", "dark": "000000"},
        # a dark colour no animation keys (a mesh), and slots without any (light timelines only)
        {"name": "still", "bone": "root", "attachment": "tri", "dark": "405060"},
        {"name": "plain", "bone": "root", "attachment": "box", "color": "80808080"},
        {"name": "bare", "bone": "root", "attachment": "box"},
    ]
    box = {"box": {"x": 8, "width": 16, "height": 6}}
    tri = {"tri": {"type": "mesh", "uvs": [0, 1, 1, 1, 0.5, 0], "triangles": [0, 1, 2], "hull": 3,
                   "vertices": [-10, -5, 10, -5, 0, 12], "width": 20, "height": 17}}
    atts = {"glow": box, "edge": box, "black": box, "still": tri, "bare": box,
            "plain": {"box": {**box["box"], "color": "ff8040c0"}}}  # drawn light: slot x attachment
    slot_keys = {
        "glow": {"rgba2": [
            {"time": 0, "light": "f2f2f2f2", "dark": "336699",
             "curve": _bezier((1.7, 1.4), (-0.6, 0.2), (1.0, 1.0), (0.9, 1.5),
                              (1.8, 1.6), (-0.9, -0.2), (0.5, 0.3))},
            {"time": 0.8, "light": "80c0ff80", "dark": "cc9919", "curve": "stepped"},
            {"time": 1.2, "light": "fafafafa", "dark": "1a1a1a"},
            {"time": 1.9, "light": "40404040", "dark": "e6e6e6"}]},
        "edge": {"rgb2": [
            {"time": 0.3, "light": "808080", "dark": "804020",
             "curve": [0.53, -0.7, 0.77, 0.4, 0.53, 1.9, 0.77, 1.2, 0.53, 0.5, 0.77, 0.5,
                       0.53, 1.6, 0.77, 1.3, 0.53, -0.5, 0.77, 0.1, 0.53, 0.2, 0.77, 1.4]},
            {"time": 1.0, "light": "f01010", "dark": "10f010", "curve": "stepped"},
            {"time": 1.5, "light": "10f010", "dark": "0d0df2"}],
            "alpha": [{"time": 0, "value": 0.5, "curve": [0.3, 1.8, 0.6, 1.5]}, {"time": 0.9, "value": 0.9},
                      {"time": 1.4, "value": 0.2, "curve": [1.6, -0.6, 1.8, -0.3]}, {"time": 1.9, "value": 0.4}]},
        "black": {"rgba2": [
            {"time": 0, "light": "ffffffff", "dark": "000000",
             "curve": _bezier((1, 1), (1, 1), (1, 1), (1, 1), (-0.5, 0.05), (-0.2, -0.4), (0, 0))},
            {"time": 0.8, "light": "ffffffff", "dark": "000000", "curve": "stepped"},
            {"time": 1.6, "light": "ffffffff", "dark": "000000"}]},
        "plain": {"rgb": [{"time": 0.1, "color": "204080", "curve": [0.4, -0.4, 0.7, 1.7, 0.4, 1.9, 0.7, 0.9,
                                                                    0.4, 0.6, 0.7, -0.3]},
                          {"time": 1.0, "color": "e0c0a0"}]},
        "bare": {"rgba": [{"time": 0, "color": "f0f0f0f0", "curve": _bezier((1.5, 1.2), (-0.2, 0.1), (0.5, 0.5),
                                                                            (1.4, 1.1))},
                          {"time": 0.8, "color": "10203040"}]},
    }
    return {"skeleton": {"spine": "4.3.23"}, "bones": [{"name": "root"}], "slots": slots,
            "skins": [{"name": "default", "attachments": atts}],
            "animations": {"tint": {"slots": slot_keys}, "rest": {"slots": {"edge": {"rgb2": [
                {"time": 0.5, "light": "ffffff", "dark": "ffffff"}]}}}}}


def _colours_43(runtime, doc: dict, tmp_path, binary: bool) -> list[tuple[str, list[dict], list[dict]]]:
    """Each pose (setup first, then every animation at :data:`TIMES`; see
    :func:`test_anim43.posed_by_both_43`): its label, spine-core 4.3's attachments and ours
    (dump layout). ``binary``: both read the ``.skel`` our writer makes of ``doc``."""
    return [(theirs["label"], theirs["attachments"], mine.to_dump()["attachments"])
            for theirs, mine in posed_by_both_43(runtime, doc, tmp_path, TIMES, binary)]


def _compare(results) -> dict:
    """Every drawn slot's colours compared (fails on the first that differs); counts of what the
    comparison saw, so that a test can tell its fixture exercised what it claims to."""
    seen = {"compared": 0, "dark_moved": 0, "dark_clamped": 0, "light_clamped": 0}
    setup = {a["slot"]: a for a in results[0][1]}
    for label, theirs, ours in results:
        mine = {a["slot"]: a for a in ours}
        assert [a["slot"] for a in ours] == [a["slot"] for a in theirs], label
        for a in theirs:
            b = mine[a["slot"]]
            where = (label, a["slot"])
            assert ("dark" in b) == ("dark" in a), (where, b.get("dark"), a.get("dark"))
            assert np.abs(np.subtract(b["color"], a["color"])).max() <= GOAL, (where, b["color"], a["color"])
            seen["compared"] += 1
            # the keys of these slots lie inside 0..1 (their setup colours may not): 0 or 1 away
            # from the setup colour is reached by clamping an overshooting curve only
            seen["light_clamped"] += a["slot"] in ("glow", "edge", "plain", "bare") and any(
                c in (0.0, 1.0) for c in a["color"]) and a["color"] != setup[a["slot"]]["color"]
            if "dark" not in a:
                continue
            assert np.abs(np.subtract(b["dark"], a["dark"])).max() <= GOAL, (where, b["dark"], a["dark"])
            seen["dark_moved"] += a["dark"] != setup[a["slot"]]["dark"]
            seen["dark_clamped"] += a["slot"] in ("glow", "edge") and any(
                c in (0.0, 1.0) for c in a["dark"]) and a["dark"] != setup[a["slot"]]["dark"]
    return seen


def _assert_exercised(seen: dict) -> None:
    # 6 drawn slots in the setup pose and in each of 2 x len(TIMES) poses
    assert seen["compared"] == 6 * (1 + 2 * len(TIMES)), seen
    # keyed dark colours move away from the setup's, overshooting curves are clamped
    assert seen["dark_moved"] >= 20 and seen["dark_clamped"] >= 5 and seen["light_clamped"] >= 5, seen


def test_43_dark_colours_match_spine_core_43(runtime43, tmp_path):  # noqa: F811
    """Each drawn slot's light and dark colour as spine-core 4.3 draws it, from the ``.json``."""
    _assert_exercised(_compare(_colours_43(runtime43, dark_doc(), tmp_path, binary=False)))


def test_43_dark_colours_from_our_skel_match_spine_core_43(runtime43, tmp_path):  # noqa: F811
    """The same skeleton as the binary ``.skel`` our writer makes (read by ours and by spine-core
    4.3): the same colours (float32 curves)."""
    _assert_exercised(_compare(_colours_43(runtime43, dark_doc(), tmp_path, binary=True)))


def test_43_slot_without_a_dark_colour_keyed_two_colour_keeps_none():
    """A two-colour timeline on a slot without a dark colour (spine-core 4.3 fails applying it,
    so there is nothing to compare): the sampler sets its light colour and gives it no dark
    colour, as for 4.2 (tests/test_anim_dark.py)."""
    doc = dark_doc()
    doc["animations"]["tint"]["slots"]["bare"] = {"rgba2": [{"time": 0, "light": "ff000080", "dark": "00ff00"}]}
    drawn = {a["slot"]: a for a in Sampler(doc).pose("tint", 0.5).to_dump()["attachments"]}
    assert "dark" not in drawn["bare"] and np.allclose(drawn["bare"]["color"], [1, 0, 0, 128 / 255], atol=1e-4)
