"""``spinemesh mesh`` on real sprites: files written, format, folder mode."""

from __future__ import annotations

import json

import numpy as np
from PIL import Image
from typer.testing import CliRunner

from conftest import EXAMPLES
from spinemesh.cli import app
from spinemesh.images.decode import load_rgba
from spinemesh.mesher import Mesh
from spinemesh.metrics import coverage, opaque_mask

runner = CliRunner()


def test_mesh_one_image_writes_json_preview_and_steps(examples, tmp_path):
    png = EXAMPLES / "4.2" / "spineboy" / "images" / "torso.png"
    out, prev, steps = tmp_path / "torso.json", tmp_path / "torso.png", tmp_path / "steps.png"
    r = runner.invoke(app, ["mesh", str(png), "--out", str(out), "--preview", str(prev), "--steps", str(steps)])
    assert r.exit_code == 0, r.output
    doc = json.loads(out.read_text())
    img = load_rgba(png)
    assert (doc["width"], doc["height"]) == (img.shape[1], img.shape[0])
    for key in ("vertices", "triangles", "hull", "edges"):
        assert key in doc
    mesh = Mesh.from_json(doc)
    assert coverage(mesh.vertices, mesh.triangles, opaque_mask(img)) == 1.0
    assert Image.open(prev).size[0] > 0
    w, h = Image.open(steps).size
    assert w > h  # 3 x 2 panels
    # the same command twice writes the same bytes
    first = out.read_bytes()
    runner.invoke(app, ["mesh", str(png), "--out", str(out)])
    assert out.read_bytes() == first


def test_mesh_folder_with_options(examples, tmp_path):
    folder = EXAMPLES / "4.2" / "goblins" / "images"
    out = tmp_path / "meshes"
    r = runner.invoke(app, ["mesh", str(folder), "--out", str(out), "--preset", "default", "--max-vertices", "20"])
    assert r.exit_code == 0, r.output
    written = sorted(out.rglob("*.json"))
    sources = sorted(p for p in folder.rglob("*.png"))
    assert len(written) == len(sources)
    counts = [len(json.loads(p.read_text())["vertices"]) for p in written]
    assert max(counts) <= 20 and np.median(counts) >= 4


def test_mesh_bad_preset_and_empty_image(tmp_path):
    empty = tmp_path / "empty.png"
    Image.fromarray(np.zeros((8, 8, 4), np.uint8)).save(empty)
    r = runner.invoke(app, ["mesh", str(empty), "--out", str(tmp_path / "e.json")])
    assert r.exit_code != 0
    assert "no opaque pixel" in str(r.exception) + r.output
    r = runner.invoke(app, ["mesh", str(empty), "--preset", "nope"])
    assert r.exit_code != 0
