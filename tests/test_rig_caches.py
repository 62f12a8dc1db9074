"""The bone choices' module-level caches never answer for other inputs than those they were
given: a list of bones changed in place, features changed in place, a second rig or project."""

from __future__ import annotations

import numpy as np

from spinemesh.rig import habits as hb
from spinemesh.rig.bones import Bone, bone_segments
from spinemesh.rig.learned import FEATURES

from test_bone_choice_habits import _weighted_worms


def _bone(index: int, x: float, length: float = 10.0) -> Bone:
    return Bone(index, f"b{index}", None, length, np.array([[1.0, 0.0, x], [0.0, 1.0, 0.0]]))


def _stacked(bones) -> np.ndarray:
    return np.stack([b.segment() for b in bones]).reshape(-1, 2, 2)


def test_the_stacked_segments_follow_a_list_of_bones_changed_in_place():
    """A bone replaced in the same list (same length), one added: its segments, not the last ones."""
    bones = [_bone(0, 0.0), _bone(1, 5.0)]
    np.testing.assert_array_equal(bone_segments(bones), _stacked(bones))
    bones[1] = _bone(1, 50.0, length=3.0)
    np.testing.assert_array_equal(bone_segments(bones), _stacked(bones))
    bones.append(_bone(2, 7.0))
    np.testing.assert_array_equal(bone_segments(bones), _stacked(bones))
    other = [_bone(0, -4.0)]                                 # a second rig's bones, then the first's again
    np.testing.assert_array_equal(bone_segments(other), _stacked(other))
    np.testing.assert_array_equal(bone_segments(bones), _stacked(bones))
    assert not bone_segments(bones).flags.writeable


def test_candidate_kinds_follow_features_changed_in_place():
    """The same array, its values changed: the kinds of the new values (the cache keys on bytes)."""
    doc = _weighted_worms()
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.learned import weighted_meshes

    features = np.array(weighted_meshes(doc, build_rig(doc))[0]["features"], float)
    first = {k: v.copy() for k, v in hb.candidate_kinds(features, FEATURES).items()}
    slot = FEATURES.index("is_slot_bone")
    moved = int(np.flatnonzero(features[:, slot] == 1)[0])
    features[moved, slot] = 0
    features[moved, FEATURES.index("is_sibling")] = 1
    second = hb.candidate_kinds(features, FEATURES)
    assert first["relation"][moved] == 0 and second["relation"][moved] == 3
    assert not second["kind"].flags.writeable
    features[moved, slot], features[moved, FEATURES.index("is_sibling")] = 1, 0
    np.testing.assert_array_equal(hb.candidate_kinds(features, FEATURES)["relation"], first["relation"])


def test_the_habits_index_answers_as_a_walk_over_every_mesh():
    """:meth:`ProjectHabits.others` and :meth:`ProjectHabits.neighbours` by index equal the walk."""
    t = np.arange(4 * hb.TALLY_SIZE, dtype=float).reshape(4, hb.TALLY_SIZE)
    keys = [hb.keys_of("a", "x"), hb.keys_of("b", "x"), hb.keys_of("c", "y"), hb.keys_of("d", "z")]
    bound = [("rig", "arm", frozenset({"arm", "hand"})), ("rig", "arm", frozenset({"arm"})),
             ("rig", "arm", frozenset({"arm", "hand"})), ("rig", "leg", frozenset({"leg"}))]
    habits = hb.ProjectHabits(t, keys, bound)
    for own in (hb.keys_of("a", "q"), hb.keys_of("q", "x"), hb.keys_of("q", "q")):
        keep = [not (k & own) for k in keys]
        np.testing.assert_array_equal(habits.others(own), t[keep].sum(axis=0))
        assert habits.neighbours(own, "rig", "arm") == hb.neighbour_counts(bound, keys, own, "rig", "arm")
    assert habits.neighbours(hb.keys_of("q", "q"), "rig", "arm") == {frozenset({"arm", "hand"}): 2,
                                                                      frozenset({"arm"}): 1}
