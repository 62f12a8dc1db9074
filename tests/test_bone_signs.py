"""What bone names and animations say to the learned bone choice (``spinemesh.rig.signs``)."""

from __future__ import annotations

import numpy as np
import pytest

from spinemesh.rig.learned import FEATURES, art_name_tokens, candidates
from spinemesh.rig.signs import name_overlap, name_tokens, rig_signs, side_conflict

from test_bone_choice_learned import _mesh_of, _worm_mesh_doc

COL = {f: i for i, f in enumerate(FEATURES)}


@pytest.mark.parametrize("name, tokens", [
    ("images/armL_upper2", {"images", "arm", "l", "upper", "2"}),
    ("R_Arm", {"r", "arm"}), ("HEAD", {"head"}), ("hairFront", {"hair", "front"}),
    ("eye-left", {"eye", "l"}), ("手臂-左2", {"手臂", "左", "2"}), ("", set()),
])
def test_names_are_cut_into_tokens_whatever_the_style_or_script(name, tokens):
    assert name_tokens(name) == tokens


def test_name_overlap_ignores_sides_and_digits_and_sides_can_conflict():
    art = name_tokens("arm_L") | name_tokens("images/arm_L_2")
    assert name_overlap(name_tokens("armL"), art) == 1.0
    assert name_overlap(name_tokens("upperArm_R"), art) == 0.5
    assert name_overlap(name_tokens("L"), art) == 0.0
    assert side_conflict(name_tokens("arm_R"), art) and not side_conflict(name_tokens("arm_L"), art)
    assert not side_conflict(name_tokens("arm"), art)


def test_motion_is_read_from_every_timeline_form():
    doc = {"animations": {
        "a": {"bones": {"x": {"rotate": [{"angle": -10}, {"time": 1, "angle": 30}],
                              "translate": [{"x": 0, "y": 0}, {"time": 1, "x": 30, "y": 40}]}}},
        "b": {"bones": {"x": {"scalex": [{"value": 1}, {"time": 1, "value": 2.5}]},
                        "y": {"rotate": [{"value": "bad"}, {"time": 1, "value": float("nan")}]},
                        "gone": {"rotate": [{"value": 90}]}}},
    }}
    signs = rig_signs(doc, ["x", "y", "z"])
    assert signs.motion[0].tolist() == pytest.approx([40, 50, 1.5, 1.0])
    assert signs.motion[1].tolist() == [0, 0, 0, 0.5]       # keyed, values unreadable: no motion
    assert signs.motion[2].tolist() == [0, 0, 0, 0]
    assert rig_signs({"animations": "nonsense"}, ["x"]).motion.tolist() == [[0, 0, 0, 0]]


def test_candidates_carry_names_and_motion():
    doc = _worm_mesh_doc()
    rig, ref, mesh, world, tris = _mesh_of(doc)
    names = [b.name for b in rig.bones]
    art = art_name_tokens(ref)
    assert art == {"worm"}
    cand = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {}, rig.signs, name_tokens("root worm"))
    got = {names[i]: dict(zip(FEATURES, row)) for i, row in zip(cand.bones, cand.features)}
    diag = np.hypot(240, 40)
    assert got["seg2"]["motion_rotate"] == pytest.approx(35 / 360) and got["seg3"]["keyed_share"] == 1
    assert got["seg1"]["motion_rotate"] == 0 and got["seg1"]["slot_keyed_share"] == 0
    assert got["root"]["name_overlap"] == 1 and got["root"]["name_best"] == 1 and got["seg3"]["name_best"] == 0
    assert got["seg3"]["name_overlap"] == 0 and got["seg3"]["slot_name_overlap"] == 0   # "seg" is not "worm"
    assert {r["moving_candidates"] for r in got.values()} == {2}
    assert got["seg2"]["motion_translate_per_diag"] == 0 and diag > 0
    # without signs the columns read as for unnamed bones no animation moves
    bare = candidates(rig.bones, rig.slot_bone["worm"], world, tris, set(), {})
    assert not bare.features[:, COL["name_overlap"]:].any()
    assert np.array_equal(bare.features[:, :COL["name_overlap"]], cand.features[:, :COL["name_overlap"]])
