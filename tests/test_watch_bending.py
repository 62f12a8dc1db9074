"""scripts/watch_bending.py: how far an upgrade's meshes move from where their regions drew the art."""

from __future__ import annotations

import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))


def test_a_bending_worm_moves_by_its_bend_and_a_thrown_bone_by_the_art(tmp_path):
    """The worm upgraded with ``--weights auto``: in the setup pose its mesh lies on the region's
    quad (0); its wiggle bends it by a share of its size; a bone that turns over and flies away,
    bound by hand, moves it as far as the art is large."""
    from rig_project import make_worm_project
    from watch_bending import watch

    from spinemesh.anim import Sampler
    from spinemesh.upgrade import Options, upgrade_project

    make_worm_project(tmp_path / "in")
    upgrade_project(tmp_path / "in", tmp_path / "out", Options(weights="auto"))
    rows = watch(tmp_path / "in", tmp_path / "out", 0.25)
    setup = [r for r in rows if r[4] is None]
    bent = max(r[1] for r in rows if r[4] == "wiggle")
    assert setup and max(r[0] for r in setup) < 0.01
    assert 0.05 < bent < 0.75
    # every vertex of the mesh rigid on a bone thrown 300 units up: as far as that
    out = tmp_path / "out" / "worm.json"
    doc = json.loads(out.read_text())
    doc["bones"].append({"name": "thrown", "parent": "root", "x": 0})
    doc["animations"]["wiggle"]["bones"]["thrown"] = {
        "translate": [{"x": 0, "y": 0}, {"time": 0.5, "x": 0, "y": 300}, {"time": 1, "x": 0, "y": 0}]}
    mesh = doc["skins"][0]["attachments"]["worm"]["worm"]
    world = Sampler(doc).pose(None).slots[0].vertices  # bound to "thrown" (at the origin) where they are
    assert len(world) == len(mesh["uvs"]) // 2
    thrown = len(doc["bones"]) - 1
    mesh["vertices"] = [v for x, y in world for v in (1, thrown, float(x), float(y), 1.0)]
    out.write_text(json.dumps(doc))
    far = max(r[0] for r in watch(tmp_path / "in", tmp_path / "out", 0.5) if r[4] == "wiggle" and r[5] == 0.5)
    assert abs(far - 300) < 5
