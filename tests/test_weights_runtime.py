"""Proof with the official Spine runtime: weighting keeps the setup pose exactly.

For every example project of 3.8, 4.0, 4.1 and 4.2, from ``.json`` and ``.skel``, every mesh
attachment is (re)weighted with ``--replace --bones auto``; the runtime's dump of the setup
pose must draw each weighted mesh's vertices within 0.05 px of where the original project
draws them. The bone world transforms computed by :mod:`spinemesh.rig.bones` must equal the
runtime's for every bone they call exact (bones only some skins activate are not posed by
the runtime in the default skin, and are not compared).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from spinemesh.project import find_project, image_source_for
from spinemesh.rig.bones import skeleton_bones
from spinemesh.rig.document import WeightOptions
from spinemesh.rig.run import weight_project
from spinemesh.skeleton import load_skeleton

from conftest import example_projects
from runtime_tool import node

CASES = [s for v in ("3.8", "4.0", "4.1", "4.2") for p in example_projects(v)
         for s in sorted(p.iterdir()) if s.suffix in (".json", ".skel")]

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


@pytest.mark.parametrize("skeleton", CASES, ids=lambda p: f"{p.parent.parent.name}/{p.name}")
def test_weighted_meshes_draw_where_the_originals_did(skeleton, spine_runtime, tmp_path):
    atlas = atlas_for(skeleton)
    if atlas is None:
        pytest.skip(f"{skeleton.parent.name} ships no atlas: the runtime cannot load it")
    out = tmp_path / "out"
    result = weight_project(skeleton, out, WeightOptions(bones="auto", replace=True))
    assert not result.errors, result.errors
    failed = [(o.slot, o.name, o.reason) for o in result.outcomes if o.status == "failed"]
    assert not failed, failed
    weighted = {(o.skin, o.slot, o.name) for o in result.outcomes if o.status == "weighted"}

    a = setup_dump(spine_runtime, atlas, skeleton, tmp_path / "a.json")
    b = setup_dump(spine_runtime, out / atlas.relative_to(skeleton.parent), out / skeleton.name,
                   tmp_path / "b.json")

    bones = skeleton_bones(load_skeleton(skeleton))
    for bone in bones:
        if bone.exact and not any(x.skin_required for x in _ancestors(bones, bone.index)):
            m = np.array(a["bones"][bone.name])
            runtime = np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]])
            assert np.abs(runtime - bone.world).max() < 1e-3, (bone.name, runtime, bone.world)

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
    meshes_drawn = sum(d["type"] == "mesh" for d in a["attachments"])
    if weighted and meshes_drawn:
        assert checked > 0, "no weighted mesh is drawn in the default skin's setup pose"
