"""Bones, weights, binding and rig-aware topology on data made by our own code (no ../shared)."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

from spinemesh.rig.binding import bind, parse_vertices, rounded_weights, setup_world
from spinemesh.rig.bones import skeleton_bones
from spinemesh.rig.document import UNWEIGHTED_BONE, Outcome, WeightOptions, build_rig, weight_document
from spinemesh.rig.topology import add_rig_vertices
from spinemesh.rig.transform import world_transform
from spinemesh.rig.weights import bounded_biharmonic, geodesic_weights, refine, segment_distances, solve_weights, sparsify
from spinemesh.skeleton import iter_attachments

from rig_project import make_worm_project, worm_skeleton


def _rot(deg, sx=1.0, sy=1.0):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c * sx, -s * sy], [s * sx, c * sy]])


def test_normal_bones_compose_parent_and_local():
    parent = np.array([[0.0, -2.0, 10.0], [2.0, 0.0, 5.0]])  # turned 90 degrees, scaled 2
    m = world_transform({"x": 3, "y": 1, "rotation": 30, "scaleX": 1.5, "scaleY": 0.5}, parent)
    assert np.allclose(m[:, :2], parent[:, :2] @ _rot(30, 1.5, 0.5))
    assert np.allclose(m[:, 2], parent[:, :2] @ [3, 1] + parent[:, 2])


@pytest.mark.parametrize("mode", ["onlyTranslation", "noRotationOrReflection", "noScale", "noScaleOrReflection"])
def test_inherit_modes_drop_what_they_say(mode):
    parent = np.c_[_rot(40, 2.0, 2.0), [7.0, -3.0]]
    for key in ("inherit", "transform"):  # 4.2 and 3.x-4.1 spellings
        m = world_transform({"rotation": 10, key: mode}, parent)
        assert np.allclose(m[:, 2], [7, -3])
        if mode == "onlyTranslation":
            assert np.allclose(m[:, :2], _rot(10))
        elif mode == "noRotationOrReflection":
            assert np.allclose(m[:, :2], _rot(10, 2, 2))  # scale kept, rotation not
        else:
            assert np.allclose(m[:, :2], _rot(50))  # rotation kept, scale not


def _posed(doc):
    return {b.name: b for b in skeleton_bones(doc)}


def _tip(bone):
    return bone.world[:, 2] + bone.world[:, 0] * bone.length


def _worm_with(version="4.2.22", **extra_bones):
    """The worm plus a ``target`` bone at (x, y) under the root."""
    doc = worm_skeleton(version)
    x, y = extra_bones.get("target", (60, 50))
    doc["bones"].append({"name": "target", "parent": "root", "x": x, "y": y})
    return doc


@pytest.mark.parametrize("version", ["3.8.99", "4.0.64", "4.1.24", "4.2.22"])
def test_one_bone_ik_aims_the_bone_at_its_target(version):
    doc = _worm_with(version)
    doc["ik"] = [{"name": "aim", "bones": ["seg3"], "target": "target"}]
    bones = _posed(doc)
    seg3, target = bones["seg3"], bones["target"]
    assert seg3.exact and bones["seg2"].exact
    to_target = target.world[:, 2] - seg3.world[:, 2]
    x_axis = seg3.world[:, 0]
    assert abs(x_axis[0] * to_target[1] - x_axis[1] * to_target[0]) < 1e-6 and x_axis @ to_target > 0
    assert np.allclose(np.linalg.norm(x_axis), 1)  # no stretch asked: the length is kept
    doc["ik"][0].update(compress=True)  # target nearer than the bone's length: the bone shrinks to it
    assert np.allclose(_tip(_posed(doc)["seg3"]), target.world[:, 2])
    doc["bones"][-1]["y"] = 150
    doc["ik"][0].update(compress=False, stretch=True)  # out of reach: the bone stretches to it
    assert np.allclose(_tip(_posed(doc)["seg3"]), [60, 150])
    doc["bones"][-1]["y"] = 50
    doc["ik"][0].update(stretch=False, mix=0.5)  # half way between the setup and the aimed rotation
    angle = math.degrees(math.atan2(*_posed(doc)["seg3"].world[::-1, 0]))
    assert np.isclose(angle, math.degrees(math.atan2(to_target[1], to_target[0])) / 2)


@pytest.mark.parametrize("bend", [True, False])
def test_two_bone_ik_reaches_the_target_on_the_bend_side(bend):
    doc = _worm_with(target=(0, 60))  # seg2 starts at x = -40: the target is within 160 of it
    doc["ik"] = [{"name": "leg", "bones": ["seg2", "seg3"], "target": "target", "bendPositive": bend}]
    bones = _posed(doc)
    assert bones["seg2"].exact and bones["seg3"].exact
    # The runtimes' pi (3.1415927) leaves the tip about 1e-6 off, as in the runtime itself.
    assert np.allclose(_tip(bones["seg3"]), bones["target"].world[:, 2], atol=1e-5)
    knee, hip, foot = bones["seg3"].world[:, 2], bones["seg2"].world[:, 2], _tip(bones["seg3"])
    (fx, fy), (kx, ky) = foot - hip, knee - hip
    side = fx * ky - fy * kx
    assert (side < 0) if bend else (side > 0)  # bendPositive bends towards positive angles


def test_transform_constraint_copies_the_target_rotation_in_update_order():
    doc = _worm_with()
    doc["bones"].append({"name": "follower", "parent": "root", "y": -100, "length": 20})
    doc["ik"] = [{"name": "aim", "order": 0, "bones": ["seg3"], "target": "target"}]
    doc["transform"] = [{"name": "copy", "order": 1, "bones": ["follower"], "target": "seg3",
                         "mixX": 0, "mixScaleX": 0, "mixShearY": 0, "rotation": 10}]
    bones = _posed(doc)
    def angle(b):
        return math.degrees(math.atan2(b.world[1, 0], b.world[0, 0]))
    assert bones["follower"].exact and np.isclose(angle(bones["follower"]), angle(bones["seg3"]) + 10)
    # ordered before the IK, the copy reads seg3 before it is aimed (as the runtime's update cache does)
    doc["transform"][0]["order"], doc["ik"][0]["order"] = 0, 1
    bones = _posed(doc)
    assert np.isclose(angle(bones["follower"]), 10) and not np.isclose(angle(bones["seg3"]), 0)


def test_a_posed_bones_world_array_follows_its_six_numbers():
    """The update keeps each bone's world transform as six floats and makes the array when it is
    read: read, posed again and read again, it is the new pose's, as computed from scratch (the
    array read before keeps the old pose); it cannot be written in place, which its numbers would
    not follow; assigned, the numbers follow it. Every step of a preview's poses relies on this."""
    from spinemesh.rig.constraints.solver import build_rig, update_world
    from spinemesh.rig.transform import world_from_local

    doc = _worm_with()
    doc["ik"] = [{"name": "aim", "bones": ["seg3"], "target": "target"}]  # a constraint writes one too
    rig = build_rig(doc)
    update_world(rig)
    before = [b.world for b in rig.bones]
    assert all(not w.flags.writeable for w in before)
    with pytest.raises(ValueError):
        before[1][0, 2] = 5.0
    rig.bones[0].local = (0.0, 0.0, 30.0, 1.0, 1.0, 0.0, 0.0)  # the root turned: every bone moves
    update_world(rig)
    for b, old in zip(rig.bones, before):
        assert np.array_equal(b.world, np.array(b.m).reshape(2, 3)) and not np.array_equal(b.world, old)
        if b.name != "seg3":  # the IK turns seg3 from its setup values
            parent = None if b.parent is None else b.parent.world
            assert np.array_equal(b.world, world_from_local(b.local, b.inherit, parent)), b.name
    again = [b.world.copy() for b in rig.bones]
    update_world(rig)  # the same pose again: the same numbers
    assert all(np.array_equal(b.world, w) for b, w in zip(rig.bones, again))
    seg1 = rig.bones[1]
    seg1.world = np.array([[0.0, -1.0, 7.0], [1.0, 0.0, -2.0]])
    assert seg1.m == (0.0, -1.0, 7.0, 1.0, 0.0, -2.0) and all(type(v) is float for v in seg1.m)
    assert seg1.finite()
    seg1.world = np.full((2, 3), np.nan)
    assert not seg1.finite() and np.isnan(seg1.world).all()


def flattened_under_a_world_constraint(version: str) -> dict:
    """The worm drawn on seg3, seg1 scaled to 0 across (its determinant 0: seg2 under it is a
    line) and seg2 turned, moved and sheared out of that line by a world transform constraint
    to ``target``: the runtimes divide by seg1's zero determinant and go on."""
    doc = _worm_with(version)
    doc["bones"][1]["scaleY"] = 0
    doc["bones"][2]["rotation"] = 30
    doc["slots"][0]["bone"] = "seg3"
    doc["transform"] = [{"name": "lift", "bones": ["seg2"], "target": "target", "rotation": 20, "shearY": 40}]
    return doc


@pytest.mark.parametrize("version", ["4.0.64", "4.1.24", "4.2.22"])
def test_a_bone_under_a_parent_scaled_to_zero_is_exact_where_a_constraint_moves_it(version):
    bones = _posed(flattened_under_a_world_constraint(version))
    (a, b, x), (c, d, y) = bones["seg2"].world
    assert abs(a * d - b * c) > 0.1 and np.allclose((x, y), bones["target"].world[:, 2])  # out of the line
    assert bones["seg2"].exact and bones["seg3"].exact, (bones["seg2"].why, bones["seg3"].why)


def _with_rail(doc, **path):
    """A straight path slot ``rail`` on the root, from (-100, 100) to (200, 100), and a path
    constraint on seg2 and seg3 along it."""
    doc["slots"].append({"name": "rail", "bone": "root", "attachment": "rail"})
    doc["skins"][0]["attachments"]["rail"] = {"rail": {
        "type": "path", "vertexCount": 6, "lengths": [300, 600],
        "vertices": [-200, 100, -100, 100, 0, 100, 100, 100, 200, 100, 300, 100]}}
    doc["path"] = [{"name": "rail", "bones": ["seg2", "seg3"], "target": "rail", **path}]
    return doc


@pytest.mark.parametrize("version", ["3.8.99", "4.1.24", "4.2.22"])
@pytest.mark.parametrize("constant_speed", [True, False])
def test_path_constraint_lays_bones_along_the_path(constant_speed, version):
    doc = _with_rail(worm_skeleton(version), positionMode="fixed", position=50)
    doc["skins"][0]["attachments"]["rail"]["rail"]["constantSpeed"] = constant_speed
    bones = _posed(doc)
    assert bones["seg2"].exact and bones["seg3"].exact
    # "length" spacing: each bone starts where the previous one's length ends, turned along the path
    assert np.allclose(bones["seg2"].world[:, 2], [-50, 100], atol=1e-6)
    assert np.allclose(bones["seg3"].world[:, 2], [30, 100], atol=1e-6)
    assert np.allclose(bones["seg3"].world[:, :2], np.eye(2), atol=1e-6)


def test_constraints_not_reproduced_leave_bones_and_children_not_exact():
    doc = _with_rail(worm_skeleton("3.8.99"), rotateMode="chain")  # 3.8 chain paths are not bound to
    bones = _posed(doc)
    assert bones["seg1"].exact and not bones["seg2"].exact and not bones["seg3"].exact
    assert "path constraint 'rail'" in bones["seg2"].why
    doc = _worm_with()  # a constraint only some skins activate: the setup pose depends on the skin
    doc["ik"] = [{"name": "aim", "bones": ["seg3"], "target": "target", "skin": True}]
    assert "only some skins" in _posed(doc)["seg3"].why
    doc = _with_rail(_worm_with("3.8.99"), rotateMode="chain")  # an IK reading a bone not exact is not exact
    doc["path"][0]["bones"] = ["target"]
    doc["ik"] = [{"name": "aim", "order": 1, "bones": ["seg3"], "target": "target"}]
    bones = _posed(doc)
    assert not bones["target"].exact and not bones["seg3"].exact and bones["seg2"].exact
    assert "which reads 'target'" in bones["seg3"].why
    doc = _worm_with("3.7.94")  # versions whose runtime is not reproduced: as before
    doc["ik"] = [{"name": "aim", "bones": ["seg3"], "target": "target"}]
    assert "3.8-4.3" in _posed(doc)["seg3"].why
    doc["ik"][0]["mix"] = 0  # a constraint with mix 0 moves nothing
    doc["transform"] = [{"name": "t", "bones": ["seg3"], "target": "seg1", "rotateMix": 0, "translateMix": 0,
                         "scaleMix": 0, "shearMix": 0}]
    assert all(b.exact for b in skeleton_bones(doc))
    doc["transform"][0]["scaleMix"] = 1
    assert not _posed(doc)["seg3"].exact


def test_spine_43_constraints_list_is_read():
    doc = worm_skeleton("4.3.23")
    doc["constraints"] = [{"type": "ik", "name": "reach", "bones": ["seg3"], "target": "seg1"},
                          {"type": "physics", "name": "wobble", "bone": "seg2"}]
    bones = {b.name: b for b in skeleton_bones(doc)}
    # solved as the sampler solves 4.3 (the IK aims seg3 back at seg1); physics leaves the setup pose as it is
    assert bones["seg3"].exact and bones["seg2"].exact
    x_axis, to_target = bones["seg3"].world[:, 0], bones["seg1"].world[:, 2] - bones["seg3"].world[:, 2]
    assert abs(x_axis[0] * to_target[1] - x_axis[1] * to_target[0]) < 1e-4 and x_axis @ to_target > 0
    assert "ik constraint 'reach'" in bones["seg1"].target_of
    doc["constraints"].append({"type": "slider", "name": "s", "animation": "wiggle", "bone": "seg1",
                               "property": "unknown"})  # one constraint not solved: none is
    bones = {b.name: b for b in skeleton_bones(doc)}
    assert not bones["seg3"].exact and "4.3 constraints are solved where" in bones["seg3"].why


def test_refine_shares_edge_points_and_keeps_vertices_first():
    v = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    t = np.array([[0, 1, 2], [0, 2, 3]])
    p, f = refine(v, t, 3)
    assert np.array_equal(p[:4], v)
    assert len(f) == 2 * 9
    assert len(p) == 16  # a 4x4 grid of points: the diagonal's points are shared
    assert len(np.unique(np.round(p, 9), axis=0)) == len(p)
    # a degenerate triangle along the diagonal adds faces but no point: its points are the diagonal's
    p2, f2 = refine(v, np.r_[t, [[0, 2, 2]]], 3)
    assert np.array_equal(p2, p) and np.array_equal(f2[:18], f) and len(f2) == 27
    assert set(f2[18:].ravel()) <= set(f[:9].ravel()) & set(f[9:].ravel())


def _strip(n=9, length=300.0, width=40.0):
    xs = np.linspace(0, length, n)
    v = np.r_[np.c_[xs, np.zeros(n)], np.c_[xs[::-1], np.full(n, width)]]
    tris = []
    for i in range(n - 1):
        a, b, c, d = i, i + 1, 2 * n - 2 - i, 2 * n - 1 - i
        tris += [(a, b, c), (a, c, d)]
    return v, np.array(tris)


@pytest.mark.parametrize("method", ["bbw", "bbw-libigl", "harmonic", "biharmonic", "geodesic"])
def test_weights_follow_the_bones(method):
    v, t = _strip()
    segs = np.array([[[0, 20], [150, 20]], [[150, 20], [300, 20]]], float)
    w = solve_weights(v, t, segs, method)
    assert w.shape == (len(v), 2) and (w >= 0).all() and np.allclose(w.sum(1), 1)
    left, right = v[:, 0] < 60, v[:, 0] > 240
    assert (w[left, 0] > 0.8).all() and (w[right, 1] > 0.8).all()
    # mirror symmetry of the strip and the bones
    order = np.lexsort((v[:, 1], v[:, 0]))
    mirror = np.lexsort((v[:, 1], 300 - v[:, 0]))
    # The triangulation is not symmetric; geodesic weights read it most (path lengths along edges
    # depend on the triangles' diagonals, and their falloff sharpens that at the joint).
    assert np.allclose(w[order, 0], w[mirror, 1], atol=0.3 if method == "geodesic" else 0.1)


def _strip_problem(bones=3):
    """A refined strip with handles along ``bones`` equal segments of its mid-line."""
    v, t = _strip()
    p, f = refine(v, t, 4)
    b = np.flatnonzero(np.isclose(p[:, 1], 20.0))
    bc = np.eye(bones)[np.minimum((p[b, 0] / (300.0 / bones)).astype(int), bones - 1)]
    return p, f, b, bc


@pytest.mark.parametrize("bones", [2, 3])
def test_bounded_biharmonic_matches_libigl(bones):
    import igl

    p, f, b, bc = _strip_problem(bones)
    w = bounded_biharmonic(p, f, b, bc)
    ref = igl.bbw(p, f, b, bc, partition_unity=False, max_iter=200)
    assert np.abs(w - ref).max() < 1e-4
    assert np.array_equal(w[b], bc) and w.min() > -1e-7 and w.max() < 1 + 1e-7
    assert np.allclose(w.sum(1), 1, atol=1e-4)  # handles one-hot, Q 1 = 0: the optimum is a partition


def test_one_bone_with_handles_weighs_1_everywhere_as_the_qp_optimum():
    import igl

    p, f, b, bc = _strip_problem(2)
    one = np.c_[np.ones(len(b)), np.zeros(len(b))]  # every handle on the first bone, none on the second
    w = bounded_biharmonic(p, f, b, one)
    assert (w[:, 0] == 1.0).all() and (w[:, 1] == 0.0).all()
    ref = igl.bbw(p, f, b, one, partition_unity=False, max_iter=200)  # the QP solved, not skipped
    assert np.abs(ref[:, 0] - 1.0).max() < 1e-6


def _c_shape(cell=20.0):
    """A ``]``-shaped grid mesh: two bars (y 0-40 and 60-100, x 0-200) joined only at their right
    end (x 160-200); the gap between them (y 40-60, x < 160) is not art."""
    xs, ys = np.arange(0, 201, cell), np.arange(0, 101, cell)
    at = {(x, y): i for i, (x, y) in enumerate((x, y) for y in ys for x in xs)}
    v = np.array(list(at), float)
    tris = []
    for x in xs[:-1]:
        for y in ys[:-1]:
            if 40 <= y < 60 and x < 160:
                continue
            a, b, c, d = at[x, y], at[x + cell, y], at[x + cell, y + cell], at[x, y + cell]
            tris += [(a, b, c), (a, c, d)]
    return v, np.array(tris), at


def test_geodesic_weights_follow_the_art_not_the_straight_line():
    v, t, at = _c_shape()
    # bone 0 along the top bar's left end, bone 1 down the joining end
    segs = np.array([[[0, 80], [40, 80]], [[180, 0], [180, 100]]], float)
    w = solve_weights(v, t, segs, "geodesic")
    assert w.shape == (len(v), 2) and (w >= 0).all() and (w <= 1).all() and np.allclose(w.sum(1), 1)
    for x in (0, 20, 40):  # on bone 0's segment: its handles
        assert w[at[x, 80], 0] == 1.0
    for y in (0, 20, 40, 60, 80, 100):  # on bone 1's segment
        assert w[at[180, y], 1] == 1.0
    # Both 60 from bone 0 in a straight line: across the gap (under the bone) and along the bar.
    across, along = at[20, 20], at[100, 80]
    straight = segment_distances(v[[across, along]], segs)
    assert np.allclose(straight[:, 0], 60.0) and straight[0, 1] > straight[1, 1]
    # Falling off with straight-line distance, the point across the gap would weigh more on bone 0
    # (it lies farther from bone 1); along the art the path around the gap is long, so it weighs less.
    inverse = straight ** -2.0 / (straight ** -2.0).sum(axis=1, keepdims=True)
    assert inverse[0, 0] > inverse[1, 0]
    assert w[across, 0] < 0.5 * w[along, 0] and w[across, 1] > 0.75
    # and the weight on a bone falls as the path to it grows, along the top bar
    top = w[[at[x, 80] for x in range(40, 181, 20)], 0]
    assert (np.diff(top) < 0).all()


def test_geodesic_weights_on_the_refinement_directly():
    v, t, at = _c_shape()
    fixed = {at[0, 80]: 0, at[20, 80]: 0, at[180, 0]: 2}  # bone 1 has no handle
    w = geodesic_weights(v, t, fixed, 3)
    assert (w[:, 1] == 0).all() and np.allclose(w.sum(1), 1) and (w >= 0).all() and (w <= 1).all()
    assert w[at[0, 80], 0] == 1.0 and w[at[180, 0], 2] == 1.0
    # the exponent sharpens: a point nearer bone 2 leans more on it with a larger falloff
    p = at[140, 0]
    assert geodesic_weights(v, t, fixed, 3, falloff=8.0)[p, 2] > geodesic_weights(v, t, fixed, 3, falloff=2.0)[p, 2] > 0.5
    # a point in no face weighs nothing (the caller binds it to its nearest bone)
    v2 = np.vstack([v, [[500.0, 500.0]]])
    assert (geodesic_weights(v2, t, fixed, 3)[-1] == 0).all()


def test_bone_without_handle_gets_zero_and_a_failed_solve_falls_back_to_harmonic(monkeypatch):
    from spinemesh.rig import weights as rig_weights

    p, f, b, bc = _strip_problem(2)
    w = bounded_biharmonic(p, f, b, np.c_[bc[:, :1], np.zeros(len(b)), bc[:, 1:]])
    assert (w[:, 1] == 0).all() and np.allclose(w[:, [0, 2]], bounded_biharmonic(p, f, b, bc))
    v, t = _strip()
    segs = np.array([[[0, 20], [150, 20]], [[150, 20], [300, 20]]], float)
    monkeypatch.setattr(rig_weights, "bounded_biharmonic", lambda *a: None)
    assert np.allclose(solve_weights(v, t, segs, "bbw"), solve_weights(v, t, segs, "harmonic"))


def test_sparsify_bounds_counts_and_sums():
    w = np.array([[0.5, 0.2, 0.15, 0.1, 0.045, 0.005], [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
    s = sparsify(w, max_bones=4, min_weight=0.01)
    assert ((s > 0).sum(1) <= 4).all() and np.allclose(s.sum(1), 1) and (s[s > 0] >= 0.01).all()
    assert s[0, 5] == 0 and s[0, 4] == 0 and s[1, 2] == 1


def test_rounded_weights_sum_to_exactly_one():
    for row in np.random.default_rng(1).dirichlet(np.ones(4), 200):
        assert sum(rounded_weights(row)) == pytest.approx(1.0, abs=1e-12)


def test_binding_keeps_setup_positions():
    rng = np.random.default_rng(2)
    worlds = [np.c_[_rot(a, s, s), rng.uniform(-100, 100, 2)] for a, s in ((0, 1), (37, 2), (-120, 0.5))]
    world = rng.uniform(-200, 200, (30, 2))
    w = sparsify(rng.dirichlet(np.ones(3), 30))
    verts = bind(world, w, [0, 1, 2], worlds)
    mesh = parse_vertices({"uvs": [0.0] * 60, "vertices": verts}, 3)
    assert mesh.weighted and mesh.count == 30
    assert np.abs(setup_world(mesh, worlds, 0) - world).max() < 1e-3


@pytest.mark.parametrize("scale", [1.0, 1.00000001, 1.4, 3.0, 1e3, 1e6])
def test_binding_rounds_positions_to_what_the_bone_scale_needs(scale):
    """Rounding moves no bound vertex more than 1e-4 world units, and bones of ordinary scale
    (1, or 1.00000001 as a .skel's 32-bit floats give it, turned by any angle) keep 4 decimals:
    a turned bone's norm of 1.0000000000000002 wrote 5 for every weighted mesh of most rigs."""
    rng = np.random.default_rng(3)
    for angle in range(0, 360, 7):
        worlds = [np.c_[_rot(angle, scale, scale), rng.uniform(-100, 100, 2)]]
        world = worlds[0][:, 2] + rng.uniform(-200, 200, (20, 2)) * scale
        verts = bind(world, np.ones((20, 1)), [0], worlds)
        mesh = parse_vertices({"uvs": [0.0] * 40, "vertices": verts}, 1)
        assert np.abs(setup_world(mesh, worlds, 0) - world).max() <= 1e-4 + 1e-9 * scale
        if scale < 1.41:
            positions = [verts[i + 2 + j] for i in range(0, len(verts), 5) for j in (0, 1)]
            assert all(round(x, 4) == x for x in positions), angle


def test_binding_refuses_a_vertex_without_a_bone():
    from spinemesh.errors import SpineMeshError

    worlds = [np.c_[np.eye(2), [0.0, 0.0]], np.c_[np.eye(2), [5.0, 0.0]]]
    with pytest.raises(SpineMeshError, match="vertex 1 has no positive bone weight"):
        bind(np.zeros((2, 2)), np.array([[1.0, 0.0], [np.nan, np.nan]]), [0, 1], worlds)


def test_worm_is_weighted_to_its_chain_and_keeps_its_setup_pose():
    doc = worm_skeleton()
    att = doc["skins"][0]["attachments"]["worm"]["worm"]
    # the region as a 2 x 9 strip mesh in seg1's space (origin at the worm's left end)
    v, t = _strip(9, 240, 60)
    att.update({"type": "mesh", "uvs": (v / (240, 60)).ravel().tolist(),
                "vertices": (v - (0, 30)).ravel().tolist(), "triangles": t.ravel().tolist(), "hull": len(v)})
    before = setup_world(parse_vertices(att, 4), build_rig(doc).worlds, 1)
    out = weight_document(doc, "worm.json", WeightOptions(bones="auto"))
    assert [o.status for o in out] == ["weighted"]
    assert set(out[0].bones) == {"seg1", "seg2", "seg3"}
    assert "root" in out[0].left_out
    mesh = parse_vertices(att, 4)
    assert mesh.weighted and set(mesh.bones()) == {1, 2, 3}
    assert all(len(inf) <= 4 and abs(sum(e[3] for e in inf) - 1) < 1e-9 for inf in mesh.influences)
    assert np.abs(setup_world(mesh, build_rig(doc).worlds, 1) - before).max() < 1e-3
    # a second run leaves weighted meshes alone unless asked to replace them
    again = weight_document(doc, "worm.json", WeightOptions(bones="auto"))
    assert again[0].status == "skipped" and "--replace" in again[0].reason
    # keep: an unweighted mesh stays on its slot's bone only
    doc2 = copy.deepcopy(worm_skeleton())
    doc2["skins"][0]["attachments"]["worm"]["worm"] = copy.deepcopy(att)
    doc2["skins"][0]["attachments"]["worm"]["worm"]["vertices"] = (v - (0, 30)).ravel().tolist()
    keep = weight_document(doc2, "w", WeightOptions(bones="keep"))
    assert list(keep[0].bones) == ["seg1"]


def test_an_outcome_names_the_bones_chosen_whether_written_or_left_at_zero():
    out = Outcome("s.json", "default", "slot", "a", bones={"arm": "slot bone"},
                  left_out={"hand": UNWEIGHTED_BONE, "root": "root bone: moves the whole skeleton"})
    assert out.chosen() == {"arm", "hand"}


def test_deform_keys_and_inexact_bones_leave_meshes_as_they_are():
    doc = worm_skeleton()
    att = doc["skins"][0]["attachments"]["worm"]["worm"]
    v, t = _strip(3, 240, 60)
    att.update({"type": "mesh", "uvs": (v / (240, 60)).ravel().tolist(), "vertices": v.ravel().tolist(),
                "triangles": t.ravel().tolist(), "hull": len(v)})
    keyed = copy.deepcopy(doc)
    keyed["animations"]["wiggle"]["attachments"] = {"default": {"worm": {"worm": {"deform": [{"time": 0}]}}}}
    original = copy.deepcopy(att)
    out = weight_document(keyed, "w", WeightOptions())
    assert out[0].status == "skipped" and "deform timeline" in out[0].reason
    assert keyed["skins"][0]["attachments"]["worm"]["worm"] == original
    constrained = _with_rail(copy.deepcopy(doc), rotateMode="chain")  # a 3.8 chain path is not bound to
    constrained["skeleton"]["spine"] = "3.8.99"
    constrained["path"][0]["bones"] = ["seg1"]
    out = weight_document(constrained, "w", WeightOptions())
    assert out[0].status == "skipped" and "path constraint" in out[0].reason
    constrained = copy.deepcopy(doc)  # an IK's is: the mesh is weighted
    constrained["ik"] = [{"name": "ik", "bones": ["seg1"], "target": "root"}]
    out = weight_document(constrained, "w", WeightOptions())
    assert out[0].status == "weighted", out[0].reason


def test_rig_vertices_fold_the_mesh_at_joints_within_budget():
    v, t = _strip(3, 240, 60)  # a coarse strip: nothing at the joints
    att = {"type": "mesh", "uvs": (v / (240, 60)).ravel().tolist(), "vertices": (v - (0, 30)).ravel().tolist(),
           "triangles": t.ravel().tolist(), "hull": len(v), "edges": [], "width": 240, "height": 60}
    segs = np.array([[[0, 0], [80, 0]], [[80, 0], [160, 0]], [[160, 0], [240, 0]]], float)
    added = add_rig_vertices(att, segs, [None, 0, 1])
    n = len(att["uvs"]) // 2
    assert added > 0 and n == len(v) + added
    assert len(att["triangles"]) // 3 == 2 * n - len(v) - 2  # one fully triangulated hull
    local = np.asarray(att["vertices"]).reshape(-1, 2)
    uv = np.asarray(att["uvs"]).reshape(-1, 2)
    assert np.allclose(local, uv * (240, 60) - (0, 30), atol=1e-3)  # positions and UVs agree
    assert any(np.allclose(p, [80, 0], atol=1e-3) for p in local)  # a vertex on the joint
    across = [p for p in local[len(v):] if abs(p[0] - 80) < 1e-3 and abs(p[1]) > 1]
    assert across, "a row of vertices across the joint"
    budget = copy.deepcopy(att)
    assert add_rig_vertices(budget, segs, [None, 0, 1], max_vertices=n) == 0  # budget spent


def test_weighted_mesh_survives_the_binary_writer(tmp_path):
    from spinemesh.skeleton_binary import encode_skel, read_skel

    doc = worm_skeleton()
    att = doc["skins"][0]["attachments"]["worm"]["worm"]
    v, t = _strip(5, 240, 60)
    att.update({"type": "mesh", "uvs": (v / (240, 60)).ravel().tolist(), "vertices": v.ravel().tolist(),
                "triangles": t.ravel().tolist(), "hull": len(v)})
    weight_document(doc, "w", WeightOptions(bones="auto"))
    path = tmp_path / "worm.skel"
    path.write_bytes(encode_skel(doc, path))
    back = read_skel(path)
    a = parse_vertices(next(r for r in iter_attachments(back) if r.name == "worm").attachment, 4)
    b = parse_vertices(att, 4)
    assert a.count == b.count and [len(i) for i in a.influences] == [len(i) for i in b.influences]
    worlds = build_rig(doc).worlds
    assert np.abs(setup_world(a, worlds, 1) - setup_world(b, worlds, 1)).max() < 1e-3


def test_cli_weights_a_project_without_touching_it(tmp_path):
    from typer.testing import CliRunner

    from spinemesh.cli import app

    project = make_worm_project(tmp_path / "p").parent
    upgraded = tmp_path / "up"
    before = {p.name: p.read_bytes() for p in project.iterdir()}
    r = CliRunner().invoke(app, ["upgrade", str(project), "--out", str(upgraded), "--weights", "none"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["weights", str(upgraded), "--out", str(tmp_path / "w"), "--report",
                                 str(tmp_path / "r.json"), "--preview", str(tmp_path / "prev"), "--method",
                                 "harmonic"])
    assert r.exit_code == 0, r.output
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["counts"] == {"weighted": 1}
    assert set(report["attachments"][0]["bones"]) == {"seg1", "seg2", "seg3"}
    assert len(list((tmp_path / "prev").glob("*.png"))) == 1
    assert {p.name: p.read_bytes() for p in project.iterdir()} == before
    r = CliRunner().invoke(app, ["weights", str(upgraded), "--out", str(upgraded / "inside")])
    assert r.exit_code != 0
    (tmp_path / "empty").mkdir()
    r = CliRunner().invoke(app, ["weights", str(tmp_path / "empty"), "--out", str(tmp_path / "e-out")])
    assert r.exit_code == 2 and "no Spine skeleton found" in r.output


def test_cli_weights_geodesic(tmp_path):
    from typer.testing import CliRunner

    from spinemesh.cli import app

    project = make_worm_project(tmp_path / "p").parent
    upgraded = tmp_path / "up"
    assert CliRunner().invoke(app, ["upgrade", str(project), "--out", str(upgraded), "--weights", "none"]).exit_code == 0
    r = CliRunner().invoke(app, ["weights", str(upgraded), "--out", str(tmp_path / "w"), "--report",
                                 str(tmp_path / "r.json"), "--method", "geodesic"])
    assert r.exit_code == 0, r.output
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["counts"] == {"weighted": 1}
    assert set(report["attachments"][0]["bones"]) == {"seg1", "seg2", "seg3"}

@pytest.mark.parametrize("version", ["3.8.99", "4.1.24", "4.2.22"])
def test_malformed_or_degenerate_constraints_never_raise(version):
    """Constraints that name missing bones, chains the runtimes cannot solve, zero scales and
    unreadable paths: every bone still gets a transform, exact ones finite, the rest say why."""
    broken = [
        {"ik": [{"name": "a", "bones": "seg2", "target": "target"}]},
        {"ik": [{"name": "a", "bones": ["nope"], "target": "target"}]},
        {"ik": [{"name": "a", "bones": ["seg2"], "target": "nope", "order": "x"}]},
        {"ik": [{"name": "a", "bones": ["root"], "target": "target"}]},
        {"ik": [{"name": "a", "bones": ["seg1", "seg2", "seg3"], "target": "target"}]},
        {"ik": [{"name": "a", "bones": ["seg1", "seg3"], "target": "target", "softness": 5, "stretch": True}]},
        {"transform": [{"name": "t", "bones": ["seg3"], "target": "target", "local": True, "scaleX": -1}]},
        {"path": [{"name": "p", "bones": ["seg2"], "target": "nope"}]},
    ]
    for extra in broken:
        doc = _worm_with(version)
        doc.update(extra)
        _check_finite_or_explained(doc)
    doc = _worm_with(version)  # zero scale under the constrained bones
    doc["bones"][1]["scaleX"] = 0
    doc["bones"][1]["scaleY"] = 0
    doc["ik"] = [{"name": "a", "bones": ["seg2", "seg3"], "target": "target", "stretch": True}]
    doc["transform"] = [{"name": "t", "bones": ["seg3"], "target": "seg1"}]
    _check_finite_or_explained(doc)
    doc = _with_rail(_worm_with(version))  # a path whose vertices do not parse, then an empty one
    doc["skins"][0]["attachments"]["rail"]["rail"]["vertices"] = [3, "x", 1, 2]
    _check_finite_or_explained(doc)
    doc["skins"][0]["attachments"]["rail"]["rail"].update(vertices=[0, 0] * 6, constantSpeed=True)
    _check_finite_or_explained(doc)


def _check_finite_or_explained(doc):
    bones = skeleton_bones(doc)
    assert len(bones) == len(doc["bones"])
    for b in bones:
        assert (b.exact and np.isfinite(b.world).all()) or (not b.exact and b.why), (b.name, b.why, b.world)


def test_weights_preview_draws_a_sequence_mesh_from_its_setup_frame(tmp_path):
    """A mesh drawing a sequence (the demo's spark) is previewed from its setup frame, not
    looked up under the sequence's base name (which no atlas region has)."""
    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project
    from spinemesh.upgrade import Options, upgrade_project

    demo = Path(__file__).resolve().parents[1] / "examples" / "demo"
    upgrade_project(demo / "demo.json", tmp_path / "up", Options(min_saving=0))
    doc = json.loads((tmp_path / "up" / "demo.json").read_text())
    spark = [r for r in iter_attachments(doc) if r.attachment.get("sequence")]
    assert spark and all(r.type == "mesh" for r in spark)
    result = weight_project(tmp_path / "up", tmp_path / "w", WeightOptions(bones="auto"),
                            preview=tmp_path / "prev")
    assert result.errors == []
    names = sorted(p.name for p in (tmp_path / "prev").glob("*.png"))
    assert any("spark" in n for n in names), names


def test_a_row_across_a_joint_stops_where_every_step_tested_says_the_art_ends(monkeypatch):
    """The steps from a joint towards the outline are tested a few at a time and stop at the first
    outside: the rows are those of testing every step at once, whatever the art's width."""
    from spinemesh.rig import topology

    loop = np.array([[0.0, 0.0], [300.0, 0.0], [300.0, 40.0], [150.0, 90.0], [0.0, 40.0]])
    rows = {}
    for at_once in (topology.STEPS_AT_ONCE, 10_000):
        monkeypatch.setattr(topology, "STEPS_AT_ONCE", at_once)
        rows[at_once] = [np.asarray(topology._row(loop, np.array([x, 20.0]), np.array([0.0, s]), 12.0, 4.0))
                         for x in (5.0, 100.0, 150.0, 290.0) for s in (1.0, -1.0)]
    few, every = rows.values()
    assert all(a.tobytes() == b.tobytes() for a, b in zip(few, every))
    assert max(len(r) for r in few) >= 5 and min(len(r) for r in few) >= 1  # 70 units up at the peak, 20 down


def test_box_qps_answer_is_the_optimum_with_bounds_active():
    """PIQP's answer meets the box QP's optimality conditions on a made mesh whose bounds bind."""
    from spinemesh.rig.weights import biharmonic_qp, solve_box_qps

    p, f, b, bc = _strip_problem(3)
    free = np.setdiff1d(np.arange(len(p)), b)
    q, fixed = biharmonic_qp(p, f, free, b)
    c = np.asarray(fixed @ bc)
    x = solve_box_qps(q, c)
    assert x.shape == c.shape and x.min() >= 0.0 and x.max() <= 1.0
    g = q @ x + c  # the gradient: 0 where free, >= 0 at 0, <= 0 at 1
    scale = np.abs(c).max()
    low, high = x < 1e-6, x > 1 - 1e-6
    assert low.any()  # the unconstrained minimiser leaves [0, 1]: the bounds are active
    assert (g[low] > -1e-3 * scale).all() and (g[high] < 1e-3 * scale).all()
    assert np.abs(g[~low & ~high]).max() < 1e-4 * scale
    from scipy.sparse.linalg import spsolve
    assert spsolve(q, -c).min() < -1e-3


def test_one_bone_with_handles_builds_no_operator(monkeypatch):
    from spinemesh.rig import weights as rig_weights

    p, f, b, bc = _strip_problem(2)
    monkeypatch.setattr(rig_weights, "biharmonic_qp", lambda *a: pytest.fail("operator built"))
    w = rig_weights.bounded_biharmonic(p, f, b, np.c_[np.ones(len(b)), np.zeros(len(b))])
    assert (w[:, 0] == 1.0).all() and (w[:, 1] == 0.0).all()


def test_a_skin_bone_no_skin_activates_is_said_active_in_no_skin():
    """A skin bone (``"skin": true``) that no skin lists, nor a bone below it, is posed by no
    skin: it was said "only active in other skins" (gm-21483 has 97 attachments on such bones,
    which its runtimes never draw). One some skin activates is still said so, and the bones below
    either are named by it."""
    doc = worm_skeleton()
    for bone in doc["bones"]:
        bone["skin"] = bone["name"] in ("seg2", "seg3")
    rig = build_rig(doc)
    seg1, seg2, seg3 = (rig.bones[i].index for i in (1, 2, 3))
    assert rig.unposed("default", seg1) == {seg2: "active in no skin", seg3: "active in no skin"}
    doc["skins"].append({"name": "red", "bones": ["seg2"], "attachments": {}})
    for bone in doc["bones"]:
        bone["skin"] = bone["name"] == "seg2"
    rig = build_rig(doc)
    assert rig.unposed("default", seg1) == {seg2: "only active in other skins",
                                            seg3: "below bone 'seg2', which only some skins activate"}
    assert rig.unposed("red", seg1) == {seg3: "below bone 'seg2', which only some skins activate"}
