"""Proof with the official Spine runtime: weighting keeps the setup pose exactly.

For every example project of 3.8, 4.0, 4.1 and 4.2, from ``.json`` and ``.skel``, every mesh
attachment is (re)weighted with ``--replace --bones auto``; the runtime's dump of the setup
pose must draw each weighted mesh's vertices within 0.05 px of where the original project
draws them. The bone world transforms computed by :mod:`spinemesh.rig.bones` (IK and transform
constraints applied, :mod:`spinemesh.rig.constraints`) must equal the runtime's for every bone
they call exact (bones only some skins activate are not posed by the runtime in the default
skin, and are not compared), on those examples and on every corpus skeleton of 3.8-4.2 in whose
setup pose an IK, transform or path constraint moves a bone.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from spinemesh.errors import SpineMeshError
from spinemesh.project import find_project, image_source_for
from spinemesh.rig.bones import skeleton_bones
from spinemesh.rig.constraints.solver import solved_constraints
from spinemesh.rig.document import WeightOptions
from spinemesh.rig.run import weight_project
from spinemesh.rig.binding import parse_vertices, setup_world
from spinemesh.skeleton import iter_attachments, load_skeleton

from conftest import CORPUS, example_projects
from runtime_tool import node

#: Example projects the runtime cannot load, with the reason (checked below, so the list cannot rot).
NO_ATLAS = {"spinosaurus": "ships skeletons (and, in 4.2, images) but no atlas"}

ALL_SKELETONS = [s for v in ("3.8", "4.0", "4.1", "4.2") for p in example_projects(v)
                 for s in sorted(p.iterdir()) if s.suffix in (".json", ".skel")]
CASES = [s for s in ALL_SKELETONS if s.parent.name not in NO_ATLAS]

#: Largest distance, in world units (pixels at scale 1), between a weighted vertex and the same
#: vertex of the original mesh in the setup pose.
SETUP_TOLERANCE = 0.05


def atlas_for(skeleton: Path) -> Path | None:
    """The atlas a game would load with this skeleton (the one its images come from)."""
    project = find_project(skeleton.parent)
    source = image_source_for(load_skeleton(skeleton), skeleton, project)
    return source.atlases[0].path if source is not None and hasattr(source, "atlases") else None


def setup_dump(tool: Path, atlas: Path, skeleton: Path, out: Path) -> dict:
    r = node(tool, "dump.mjs", atlas, skeleton, "--out", out)
    assert r.returncode == 0, f"dump of {skeleton} failed: {r.stderr[-2000:]}"
    return json.loads(out.read_text())["poses"][0]


def _ancestors(bones, b):
    while b is not None:
        yield bones[b]
        b = bones[b].parent


#: Why a bone may be left not exact (the first bone of a chain; those below say "below"):
#: a 3.8 path constraint in a chain mode, a constraint only some skins activate, a zero scale,
#: or a constraint that reads such a bone.
LEFT_OUT = ("3.8 chain paths", "only some skins", "zero scale", "which reads")


def assert_exact_bones_match(bones, pose: dict) -> int:
    """Every bone called exact (and posed by the runtime without a skin) equals the runtime's
    world transform within 1e-3; every bone left out says why. Returns how many were compared."""
    compared = 0
    for bone in bones:
        if bone.exact and not any(x.skin_required for x in _ancestors(bones, bone.index)):
            m = np.array(pose["bones"][bone.name])
            runtime = np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]])
            assert np.abs(runtime - bone.world).max() < 1e-3, (bone.name, runtime, bone.world)
            compared += 1
        elif not bone.exact and not bone.why.startswith("below"):
            assert any(w in bone.why for w in LEFT_OUT), (bone.name, bone.why)
    return compared


def constrained_corpus_skeletons() -> dict[str, list[Path]]:
    """Corpus skeletons of 3.8-4.2 (one per JSON/binary pair) in whose setup pose an IK,
    transform or path constraint moves a bone, by project; empty when the corpus is absent."""
    out: dict[str, list[Path]] = {}
    projects = sorted(p for p in CORPUS.iterdir() if p.is_dir()) if CORPUS.is_dir() else []
    for project in projects:
        files = sorted(project.rglob("*.json")) + sorted(project.rglob("*.skel"))
        twins = {f.with_suffix("") for f in files if f.suffix == ".json"}
        for f in files:
            if f.suffix == ".skel" and f.with_suffix("") in twins:
                continue
            try:
                doc = load_skeleton(f)
            except SpineMeshError:  # not a skeleton (an atlas or a package file in JSON)
                continue
            if isinstance(doc, dict) and solved_constraints(doc):
                out.setdefault(project.name, []).append(f)
    return out


CORPUS_CASES = constrained_corpus_skeletons()


def test_projects_left_out_ship_no_atlas(examples):
    left_out = [s for s in ALL_SKELETONS if s.parent.name in NO_ATLAS]
    assert left_out and all(atlas_for(s) is None for s in left_out)


@pytest.mark.parametrize("skeleton", CASES, ids=lambda p: f"{p.parent.parent.name}/{p.name}")
def test_weighted_meshes_draw_where_the_originals_did(skeleton, spine_runtime, tmp_path):
    atlas = atlas_for(skeleton)
    assert atlas is not None, f"{skeleton}: no atlas (add the project to NO_ATLAS with the reason)"
    out = tmp_path / "out"
    # Harmonic weights: the binding is exact whatever the weights are (test_rig covers each method).
    result = weight_project(skeleton, out, WeightOptions(bones="auto", replace=True, method="harmonic"))
    assert not result.errors, result.errors
    failed = [(o.slot, o.name, o.reason) for o in result.outcomes if o.status == "failed"]
    assert not failed, failed
    weighted = {(o.skin, o.slot, o.name) for o in result.outcomes if o.status == "weighted"}

    a = setup_dump(spine_runtime, atlas, skeleton, tmp_path / "a.json")
    b = setup_dump(spine_runtime, out / atlas.relative_to(skeleton.parent), out / skeleton.name,
                   tmp_path / "b.json")

    bones = skeleton_bones(load_skeleton(skeleton))
    assert_exact_bones_match(bones, a)

    ours = {(d["slot"], d["attachment"]): d for d in b["attachments"]}
    checked, worst = 0, 0.0
    for d in a["attachments"]:
        if d["type"] != "mesh" or not any(k[1:] == (d["slot"], d["attachment"]) for k in weighted):
            continue
        e = ours[(d["slot"], d["attachment"])]
        va = np.asarray(d["vertices"], float).reshape(-1, 2)
        vb = np.asarray(e["vertices"], float).reshape(-1, 2)
        assert va.shape == vb.shape
        err = float(np.linalg.norm(va - vb, axis=1).max())
        worst = max(worst, err)
        assert err <= SETUP_TOLERANCE, (d["slot"], d["attachment"], err)
        checked += 1
    # Every weighted mesh, drawn or not (other skins, attachments not shown in the setup pose):
    # placed with the runtime's own bone transforms, as the runtime places mesh vertices.
    worlds = []
    for bone in bones:
        m = a["bones"][bone.name]
        worlds.append(np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]]))
    active = [not any(x.skin_required for x in _ancestors(bones, b.index)) for b in bones]
    before = {(r.skin, r.slot, r.name): r.attachment for r in iter_attachments(load_skeleton(skeleton))}
    slot_bone = {s["name"]: [b.name for b in bones].index(s["bone"]) for s in load_skeleton(skeleton)["slots"]}
    placed = 0
    for ref in iter_attachments(load_skeleton(out / skeleton.name)):
        key = (ref.skin, ref.slot, ref.name)
        if key not in weighted:
            continue
        old, new = parse_vertices(before[key], len(bones)), parse_vertices(ref.attachment, len(bones))
        used = (old.bones() if old.weighted else [slot_bone[ref.slot]]) + new.bones()
        if not all(active[b] for b in used):
            continue  # the runtime does not pose bones of other skins in the default skin
        err = np.linalg.norm(setup_world(old, worlds, slot_bone[ref.slot])
                             - setup_world(new, worlds, slot_bone[ref.slot]), axis=1).max()
        assert err <= SETUP_TOLERANCE, (key, err)
        placed += 1
    if weighted:
        assert checked + placed > 0


@pytest.mark.parametrize("project", sorted(CORPUS_CASES))
def test_constraints_pose_bones_as_the_runtime_does_on_the_corpus(project, spine_runtime, tmp_path):
    """One setup-pose dump per skeleton: the bones IK, transform and path constraints move are
    exact (unless they read a bone that is not) and equal to the runtime's, as every other exact
    bone (the skeletons are those for which :func:`solved_constraints` names a constraint)."""
    for skeleton in CORPUS_CASES[project]:
        atlas = atlas_for(skeleton)
        assert atlas is not None, f"{skeleton}: no atlas"
        bones = skeleton_bones(load_skeleton(skeleton))
        # Compared, and no bone left out for a constraint that is solved (LEFT_OUT).
        assert assert_exact_bones_match(bones, setup_dump(spine_runtime, atlas, skeleton, tmp_path / "a.json"))


UPGRADE_CASES = ["worm", "demo", "raptor-pro.json"]


@pytest.mark.parametrize("case", UPGRADE_CASES)
def test_upgrade_with_weights_keeps_the_setup_pose_and_bends(case, spine_runtime, tmp_path):
    """``upgrade --weights auto``: the runtime's setup pose matches the original regions
    (``compare.mjs``: every mesh vertex in its region's quad within 0.05, UVs matching, no
    visible texel uncovered), and on the worm the animation bends the mesh (no vertex follows
    one bone rigidly everywhere)."""
    from spinemesh.upgrade import Options, upgrade_project

    from rig_project import make_worm_project
    from runtime_tool import compare_dumps

    if case == "worm":
        skeleton = make_worm_project(tmp_path / "worm")
    elif case == "demo":
        skeleton = Path(__file__).resolve().parents[1] / "examples" / "demo" / "demo.json"
    else:
        found = [p for p in example_projects("4.2") if (p / case).is_file()]
        if not found:
            pytest.skip("4.2 raptor example absent")
        skeleton = found[0] / case
    atlas = atlas_for(skeleton)
    results = {}
    for weights in ("none", "auto"):
        out = tmp_path / weights
        result = upgrade_project(skeleton, out, Options(weights=weights))
        assert not result.errors and not [t for t in result.targets if t.status == "failed"]
        results[weights] = result
    weighted = [t for t in results["auto"].targets if t.weights and t.weights["status"] == "weighted"]
    assert weighted, [t.weights for t in results["auto"].targets]
    rel = atlas.relative_to(skeleton.parent)
    a = tmp_path / "a.json"
    setup_dump(spine_runtime, atlas, skeleton, a)
    b = tmp_path / "b.json"
    setup_dump(spine_runtime, tmp_path / "auto" / rel, tmp_path / "auto" / skeleton.name, b)
    ok, text = compare_dumps(spine_runtime, a, b)
    assert ok, text
    if case == "worm":
        def frame(which: str) -> np.ndarray:
            path = tmp_path / f"{which}-wiggle.json"
            r = node(spine_runtime, "dump.mjs", tmp_path / which / rel, tmp_path / which / skeleton.name,
                     "--out", path, "--poses", "wiggle@0.5")
            assert r.returncode == 0, r.stderr[-2000:]
            return np.asarray(json.loads(path.read_text())["poses"][1]["attachments"][0]["vertices"]).reshape(-1, 2)

        # the unweighted mesh follows seg1 only (not animated); the weighted one curls with seg2 and seg3
        assert np.ptp(frame("auto")[:, 1]) > np.ptp(frame("none")[:, 1]) + 40
