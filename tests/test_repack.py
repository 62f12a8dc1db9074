"""``upgrade --repack``: sequences whose frames were trimmed differently get one mesh.

The project is drawn by our own code (:mod:`spinemesh.demo`): the demo sprites packed with
every frame of the spark sequence trimmed to its own art (frames of growing size, one of
them rotated), so no single rectangle is stored for all three.
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np
import pytest

from spinemesh.atlas import read_atlas
from spinemesh.demo import demo_images, demo_skeleton, pack_atlas
from spinemesh.files.atomic import atomic_write_png, atomic_write_text
from spinemesh.images.decode import load_rgba
from spinemesh.images.sources import AtlasImages
from spinemesh.metrics import uncovered_pixels
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.repack import shelf_pack

SPARK = [f"demo-spark/frame{i}" for i in (1, 2, 3)]



def _digest(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_shelf_pack_places_every_rectangle_apart_and_on_its_page():
    rng = np.random.default_rng(1)
    sizes = [tuple(int(v) for v in rng.integers(1, 300, 2)) for _ in range(60)]
    places, pages = shelf_pack(sizes, padding=2, max_side=1024)
    assert len(places) == len(sizes) and len(pages) > 1
    for page, (pw, ph) in enumerate(pages):
        used = np.zeros((ph, pw), np.int32)
        for (p, x, y), (w, h) in zip(places, sizes):
            if p == page:
                assert x >= 2 and y >= 2 and x + w + 2 <= pw and y + h + 2 <= ph <= 1024
                used[y - 1:y + h + 1, x - 1:x + w + 1] += 1  # with a texel of padding each side
        assert used.max() <= 1


def test_sequence_trimmed_differently_is_kept_without_repack(trimmed_project, tmp_path):
    result = upgrade_project(trimmed_project, tmp_path / "out", Options(repack=False))
    spark = [t for t in result.targets if t.name == "spark"]
    assert spark and spark[0].status == "kept" and "--repack" in spark[0].reason


def test_repack_stores_frames_whole_and_the_mesh_covers_every_frame(trimmed_project, tmp_path):
    before = _digest(trimmed_project)
    out = tmp_path / "out"
    result = upgrade_project(trimmed_project, out, Options(repack=True))
    assert not result.errors and not result.partial
    assert [t.status for t in result.targets if t.name == "spark"] == ["meshed"]
    assert _digest(trimmed_project) == before  # the input is never changed

    atlas = read_atlas(out / "demo.atlas")
    new_pages = [p.name for p in atlas.pages if p.name != "demo.png"]
    assert new_pages == ["demo-untrimmed-1.png"]
    source = AtlasImages([atlas], root=out)
    originals = demo_images()
    doc = json.loads((out / "demo.json").read_text())
    mesh = doc["skins"][0]["attachments"]["spark"]["spark"]
    uv = np.asarray(mesh["uvs"], float).reshape(-1, 2)
    triangles = np.asarray(mesh["triangles"], int).reshape(-1, 3)
    for name in SPARK:
        region = atlas.find(name)
        g = region.geometry()
        assert atlas.pages[region.page].name == "demo-untrimmed-1.png"
        assert (g.width, g.height, g.offset_x, g.offset_y, g.degrees) == (64, 64, 0, 0, 0)
        frame = source.get(name)
        assert frame.content == (0, 0, 64, 64)
        assert np.array_equal(frame.rgba, originals[name])  # texels copied exactly
        # Every texel the frame draws lies inside the one mesh, and the mesh stays in the image.
        drawn = originals[name][..., 3] > 0
        assert drawn.any() and not uncovered_pixels(uv * 64, triangles, drawn).any()
    assert uv.min() >= 0 and uv.max() <= 1
    # Other regions are stored exactly where they were.
    original = read_atlas(trimmed_project / "demo.atlas")
    for region in original.regions:
        if region.name not in SPARK:
            assert atlas.find(region.name).entries == region.entries
    assert np.array_equal(load_rgba(out / "demo.png"), load_rgba(trimmed_project / "demo.png"))


def test_repacked_project_renders_like_the_original(trimmed_project, tmp_path):
    """The official runtime draws the re-packed upgrade as it draws the original (Node needed).

    One difference is inherent: a trimmed frame's quad ends at its stored rectangle, cutting
    off the bilinear fringe (half a texel) of the art on that border; the one mesh of the
    sequence reaches further (other frames have art there) and draws that fringe. So pixels
    may be added, but only within one pixel of the original quad's edges; none is lost, and
    at most 0.1% of pixels differ.
    """
    import re

    from test_corpus_runtime import _prove_corpus
    from runtime_tool import install, render_difference

    tool = install(tmp_path / "tool")
    if tool is None:
        if os.environ.get("CI"):
            pytest.fail("CI: Node/npm or ../shared/tools/spine-runtime is unavailable, the proof cannot run")
        pytest.skip("Node/npm or ../shared/tools/spine-runtime unavailable")
    prove = _prove_corpus()
    rows = prove.prove_project(tool, trimmed_project, tmp_path / "work", options=Options(repack=True))
    assert len(rows) == 1 and rows[0].dump_ok and rows[0].meshed + rows[0].kept == rows[0].regions == 6
    work = tmp_path / "work" / "render" / "demo.json"
    frame = json.loads((work / "a0.frame.json").read_text())
    poses = {re.sub(r"[^\w@.+-]", "~", p["label"]): p["attachments"]
             for p in json.loads((work / "a0.dump.json").read_text())["poses"]}
    fringe = 0
    for a in sorted(work.glob("a0.*.png")):
        d = render_difference(a, work / ("b" + a.name[1:]), where=100_000)
        assert d["lost"] == 0 and d["off_share"] <= 1e-3, d
        distance = prove.edge_distances(d["added_where"], poses[a.name[3:-4]], frame["frame"], frame["ppu"])
        assert (distance <= 1.0).all(), distance.max()
        fringe += d["added"]
    assert rows[0].renders == 3


def test_cover_resample_covers_every_texel_in_relative_coordinates():
    from spinemesh.attachment_geometry import cover_resample

    rng = np.random.default_rng(0)
    for _ in range(100):
        h, w = (int(v) for v in rng.integers(1, 30, 2))
        big_h, big_w = h + int(rng.integers(0, 30)), w + int(rng.integers(0, 30))
        mask = rng.random((h, w)) < 0.05
        cells = cover_resample(mask, big_w, big_h)
        for y, x in zip(*np.nonzero(mask)):
            rows = slice(y * big_h // h, -(-(y + 1) * big_h // h))
            cols = slice(x * big_w // w, -(-(x + 1) * big_w // w))
            assert cells[rows, cols].all()
        assert np.array_equal(cover_resample(mask, w, h), mask)


@pytest.mark.parametrize("repack", [False, True])
def test_sequence_frames_of_different_sizes_share_one_mesh(tmp_path, repack):
    """Frames drawn at 64, 96 and 48 px share one mesh in coordinates relative to each frame."""
    import cv2

    images = demo_images()
    for name, size in zip(SPARK, (64, 96, 48)):
        images[name] = cv2.resize(images[name], (size, size), interpolation=cv2.INTER_LINEAR)
    keep = () if repack else ("demo-spark/",)
    text, page = pack_atlas(images, "demo.png", rotate={"demo-spark/frame2"}, keep_whitespace=keep)
    folder = tmp_path / "project"
    atomic_write_text(folder / "demo.atlas", text)
    atomic_write_png(folder / "demo.png", page)
    atomic_write_text(folder / "demo.json", json.dumps(demo_skeleton(images), indent=1))
    result = upgrade_project(folder, tmp_path / "out", Options(repack=repack))
    assert not result.partial
    assert [t.status for t in result.targets if t.name == "spark"] == ["meshed"]
    mesh = json.loads((tmp_path / "out" / "demo.json").read_text())["skins"][0]["attachments"]["spark"]["spark"]
    uv = np.asarray(mesh["uvs"], float).reshape(-1, 2)
    triangles = np.asarray(mesh["triangles"], int).reshape(-1, 3)
    for name in SPARK:
        drawn = images[name][..., 3] > 0
        h, w = drawn.shape
        assert not uncovered_pixels(uv * (w, h), triangles, drawn).any()


def test_cover_resample_to_its_own_size_is_the_mask():
    from spinemesh.attachment_geometry import cover_resample

    mask = np.random.default_rng(4).random((7, 11)) < 0.3
    same = cover_resample(mask, 11, 7)
    assert np.array_equal(same, mask) and same is not mask
    # one column wider: every texel still covered, by the general path
    wider = cover_resample(mask, 12, 7)
    assert wider.shape == (7, 12) and wider[:, :11][mask].all()
