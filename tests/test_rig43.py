"""Spine 4.3 setup poses for binding: :func:`spinemesh.rig.constraints.solver.setup_pose` solves 4.3
constraints as the pose sampler does, against the official spine-core 4.3 (``tests/runtime43``).

``weights`` and ``upgrade --weights`` bind meshes in the setup pose that ``setup_pose`` computes,
and never on a bone it calls not exact. Its family (:func:`~spinemesh.rig.constraints.families.posing_family`)
is the sampler's, so a 4.3 skeleton's IK, transform, path and physics constraints are solved in
both: the bones equal the sampler's setup pose and spine-core 4.3's, every one exact, and the
meshes the constraints' bones carry are bound and drawn by spine-core where they were.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from spinemesh.anim import Sampler
from spinemesh.rig.constraints.solver import setup_pose
from spinemesh.skeleton import iter_attachments, load_skeleton

from runtime_tool import node
from test_anim43 import GOAL, path_doc, physics_doc, slider_doc, transform_doc
from test_skeleton_binary_v43 import PROJECTS43, _affine, _corpus_json, _node, runtime43  # noqa: F401  (fixture)

#: Largest distance, in world units, between a bound vertex and where the original drew it.
SETUP_TOLERANCE = 0.05


def _runtime_setup(runtime, path, out) -> dict:
    """Every bone's setup-pose world transform by spine-core 4.3, ``name -> (2, 3)`` (its dump
    written to ``out``, never beside the skeleton: the data's folders are not ours to write)."""
    r = node(runtime, "pose.mjs", "", path, out, "")
    assert r.returncode == 0, r.stderr[-2000:]
    setup = json.loads(out.read_text())["poses"][0]
    assert setup["label"] == "setup"
    return {n: np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]]) for n, m in setup["bones"].items()}


def _assert_setup_pose_solved(doc: dict, runtime=None, path=None, out=None) -> None:
    """``setup_pose``: every bone exact, equal to the sampler's setup pose (the same
    computation, to the bit) and, given the runtime, to spine-core 4.3's within the goal."""
    bones = setup_pose(doc)
    assert all(b.exact for b in bones), [(b.name, b.why) for b in bones if not b.exact]
    sampled = Sampler(doc).pose(None)
    assert not sampled.why
    np.testing.assert_array_equal(np.stack([b.world for b in bones]), sampled.world)
    if runtime is not None:
        theirs = _runtime_setup(runtime, path, out)
        worst = max(float(np.abs(theirs[b.name] - b.world).max()) for b in bones)
        assert worst <= GOAL, worst


FIXTURES = [physics_doc, transform_doc, path_doc]


@pytest.mark.parametrize("make", FIXTURES)
def test_43_setup_pose_is_the_samplers(make):
    """The fixtures' constraints move their bones in the setup pose; ``setup_pose`` solves them
    as the sampler does (no runtime needed)."""
    _assert_setup_pose_solved(make())


@pytest.mark.parametrize("make", FIXTURES)
def test_43_setup_pose_matches_spine_core_43(make, runtime43, tmp_path):  # noqa: F811
    path = tmp_path / "skeleton.json"
    doc = make()
    path.write_text(json.dumps(doc), encoding="utf-8")
    _assert_setup_pose_solved(doc, runtime43, path, tmp_path / "pose.json")


def test_43_setup_pose_constraints_move_bones():
    """The proof above is not passed by constraints that leave the setup pose as it is: without
    its constraints each fixture has bones elsewhere."""
    for make in FIXTURES:
        doc = make()
        bare = dict(doc, constraints=[c for c in doc["constraints"] if c["type"] == "physics"])
        posed = np.stack([b.world for b in setup_pose(doc)])
        unposed = np.stack([b.world for b in setup_pose(bare)])
        if make is physics_doc:  # physics reset leaves the setup pose as it is
            np.testing.assert_array_equal(posed, unposed)
        else:
            assert np.abs(posed - unposed).max() > 1, make.__name__


def test_43_sliders_are_flagged_in_the_setup_pose():
    """Sliders need an animation player (:mod:`spinemesh.anim`): ``setup_pose`` leaves the bones
    they move, and those below, not exact with the reason, never bound."""
    bones = {b.name: b for b in setup_pose(slider_doc())}
    for name in ("head", "arm", "hand"):
        assert not bones[name].exact and "slider" in bones[name].why, (name, bones[name].why)
    assert bones["knob"].exact and bones["dial"].exact


@pytest.mark.parametrize("name", PROJECTS43)
def test_43_corpus_setup_pose_matches_spine_core_43(name, runtime43, tmp_path):  # noqa: F811
    """The 4.3 corpus skeletons (IK and physics; ten transform constraints): every bone exact,
    the sampler's and spine-core 4.3's setup pose."""
    path = _corpus_json(name)
    doc = load_skeleton(path)
    moved = {b for c in doc["constraints"] if c["type"] != "physics" for b in c.get("bones", [])}
    assert moved
    _assert_setup_pose_solved(doc, runtime43, path, tmp_path / "pose.json")


def _constraint_bones(doc: dict) -> set[str]:
    """Bones an IK, transform or path constraint moves, and every bone below one."""
    moved = {b for c in doc["constraints"] if c["type"] != "physics" for b in c.get("bones", [])}
    parent = {b["name"]: b.get("parent") for b in doc["bones"]}
    out = set()
    for name in parent:
        n = name
        while n is not None and n not in moved:
            n = parent[n]
        if n is not None:
            out.add(name)
    return out


@pytest.mark.parametrize(("name", "least"), [("tmd-ar15", 1), ("tmd-npcportrait", 10)])
def test_43_weights_bind_constrained_bones_and_draw_as_before(name, least, runtime43, tmp_path):  # noqa: F811
    """``spinemesh weights --replace`` on the 4.3 corpus: meshes on the bones IK and transform
    constraints move are weighted (none was while 4.3 constraints were not solved: 1 and 14
    meshes were left as they were), and spine-core 4.3 draws every mesh of the output where it
    drew the original's, in the setup pose."""
    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project

    path = _corpus_json(name)
    out = tmp_path / "out"
    result = weight_project(path.parent, out, WeightOptions(bones="auto", replace=True, method="harmonic"))
    assert not result.errors, result.errors
    doc = load_skeleton(path)
    constrained = _constraint_bones(doc)
    skipped = [(o.slot, o.reason) for o in result.outcomes if o.status != "weighted"]
    assert all("deform" in why for _, why in skipped), skipped
    on_constrained = [o for o in result.outcomes if o.status == "weighted" and set(o.bones) & constrained]
    assert len(on_constrained) >= least, len(on_constrained)
    atlas = next(path.parent.glob("*.atlas"))
    before, after = tmp_path / "before.json", tmp_path / "after.json"
    _node(runtime43, "world.mjs", atlas, path, before)
    _node(runtime43, "world.mjs", out / atlas.name, out / path.name, after)
    before, after = json.loads(before.read_text()), json.loads(after.read_text())
    weighted = {f"{o.skin}\t{o.slot}\t{o.name}" for o in result.outcomes if o.status == "weighted"}
    assert weighted <= set(before)
    worst = 0.0
    for key in weighted:
        a, b = np.reshape(before[key]["world"], (-1, 2)), np.reshape(after[key]["world"], (-1, 2))
        worst = max(worst, float(np.linalg.norm(a - b, axis=1).max()))
    assert worst <= SETUP_TOLERANCE, worst
    print(f"{len(weighted)} meshes weighted, {len(on_constrained)} on constrained bones, worst {worst:.2e}")


def test_43_upgrade_weights_draws_as_the_regions(runtime43, tmp_path):  # noqa: F811
    """``upgrade --weights auto`` on tmd-npcportrait: every region becomes a weighted mesh that
    spine-core 4.3 draws where the region drew each texel, in the setup pose its transform
    constraints pose (no region hangs below a bone they move: the weights proof above binds those)."""
    from spinemesh.upgrade import Options, upgrade_project

    path = _corpus_json("tmd-npcportrait")
    out = tmp_path / "out"
    result = upgrade_project(path.parent, out, Options(weights="auto"), mesh_cache={})
    assert not result.errors, result.errors
    weighted = {(t.skin, t.slot, t.name): t.weights for t in result.targets
                if t.weights and t.weights["status"] == "weighted"}
    assert weighted and len(weighted) == len(result.targets)
    atlas = next(path.parent.glob("*.atlas"))
    before, after = tmp_path / "before.json", tmp_path / "after.json"
    _node(runtime43, "world.mjs", atlas, path, before)
    _node(runtime43, "world.mjs", out / atlas.name, out / path.name, after)
    before, after = json.loads(before.read_text()), json.loads(after.read_text())
    worst = 0.0
    for skin, slot, name in weighted:
        key = f"{skin}\t{slot}\t{name}"
        region, mesh = before[key], after[key]
        assert region["type"] == "region" and mesh["type"] == "mesh", key
        m = _affine(np.reshape(region["uvs"], (-1, 2)), np.reshape(region["world"], (-1, 2)))
        uv = np.reshape(mesh["uvs"], (-1, 2))
        drawn = np.c_[uv, np.ones(len(uv))] @ m
        worst = max(worst, float(np.abs(drawn - np.reshape(mesh["world"], (-1, 2))).max()))
    assert worst < SETUP_TOLERANCE, worst
    weighted_refs = [r for r in iter_attachments(load_skeleton(out / path.name))
                     if (r.skin, r.slot, r.name) in weighted]
    assert all(len(r.attachment["vertices"]) > len(r.attachment["uvs"]) for r in weighted_refs)


def test_43_hostile_constraints_in_the_setup_pose(tmp_path):
    """The 4.3 constraints of the hostile rounds (loops, extremes, wrong types) through the setup
    pose ``weights`` binds in: in a second, every bone it calls exact finite and where the sampler
    poses it (the sampler plays sliders too: the bones they move are not exact here)."""
    import time

    from test_hostile_round6 import HOSTILE_43

    for case, (kind, change) in HOSTILE_43.items():
        doc = slider_doc() if kind == "slider" else transform_doc()
        change(doc)
        (tmp_path / "x.json").write_text(json.dumps(doc))
        doc = load_skeleton(tmp_path / "x.json")
        start = time.perf_counter()
        bones = setup_pose(doc)
        assert time.perf_counter() - start < 1, case
        sampled = Sampler(doc).pose(None)
        exact = [b for b in bones if b.exact]
        assert exact, case
        for b in exact:
            assert np.isfinite(b.world).all(), (case, b.name)
            np.testing.assert_array_equal(b.world, sampled.world[b.index], err_msg=f"{case}: {b.name}")
