"""Nothing drawn that the original did not draw, nothing lost: on a project drawn by our own code.

The demo sprites (:mod:`spinemesh.demo`) are packed trimmed, one of them rotated, on a
premultiplied page, with a glow added in an additive slot, scaled up: its outer ring fainter
than alpha 8 and, inside, premultiplied light (alpha 0, colour > 0), which adds to whatever lies
below it. The same glow is drawn again in a normal slot, where texels of at most 2/255 may be
left out of the mesh (``images.FAINT_TEXEL``). Two regions touch on the page with no padding
between them.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from spinemesh.atlas import parse_atlas
from spinemesh.demo import demo_images, demo_skeleton, pack_atlas
from spinemesh.files.atomic import atomic_write_png, atomic_write_text
from spinemesh.images.regions import bleeding_in
from spinemesh.images.texels import FAINT_TEXEL, premultiply, shown_texels
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.attachment_geometry import float32_exact, region_positions


def _glow(size: int = 64) -> np.ndarray:
    """Premultiplied RGBA glow: alpha 1..6 outside radius 12, light (alpha 0, colour > 0) inside it."""
    yy, xx = np.mgrid[:size, :size]
    r = np.hypot(xx - size / 2 + 0.5, yy - size / 2 + 0.5)
    out = np.zeros((size, size, 4), np.uint8)
    faint = (r >= 12) & (r < 30)
    out[faint, 3] = np.clip(6 - (r[faint] - 12) / 3.5, 1, 6).astype(np.uint8)
    out[faint, :3] = out[faint, 3:4]
    light = r < 12
    out[light, :3] = (200, 180, 255)
    return out


@pytest.fixture()
def glow_project(tmp_path):
    images = {k: premultiply(v) for k, v in demo_images().items() if not k.startswith("demo-spark")}
    images["demo-glow"] = _glow()
    text, page = pack_atlas(images, "demo.png", rotate={"demo-arm", "demo-glow"})
    text = text.replace("\tfilter: Linear, Linear\n", "\tfilter: Linear, Linear\n\tpma: true\n", 1)
    doc = demo_skeleton(demo_images())
    doc["slots"] = [s for s in doc["slots"] if s["name"] != "spark"]
    doc["slots"].append({"name": "glow", "bone": "body", "attachment": "demo-glow", "blend": "additive"})
    skin = doc["skins"][0]["attachments"]
    del skin["spark"]
    skin["glow"] = {"demo-glow": {"y": 30, "scaleX": 2.5, "scaleY": 2.5, "width": 64, "height": 64}}
    doc["slots"].append({"name": "glow-normal", "bone": "body", "attachment": "demo-glow"})
    skin["glow-normal"] = {"demo-glow": {"x": 60, "y": -20, "scaleX": 2.5, "scaleY": 2.5, "width": 64, "height": 64}}
    del doc["animations"]["wave"]["attachments"]
    folder = tmp_path / "project"
    atomic_write_text(folder / "demo.atlas", text)
    atomic_write_png(folder / "demo.png", page)
    atomic_write_text(folder / "demo.json", json.dumps(doc, indent=1))
    return folder


def test_border_texels_next_to_a_neighbour_without_padding_count_as_drawn():
    page = np.zeros((4, 8, 4), np.uint8)
    page[:, 4:, 3] = 255  # region b, right of region a with no padding
    atlas = parse_atlas("p.png\nsize: 8, 4\na\n  xy: 0, 0\n  size: 4, 4\nb\n  xy: 4, 0\n  size: 4, 4\n")
    bleed = bleeding_in(page, atlas.find("a"))
    assert bleed[:, 3].all() and not bleed[:, :3].any()


def test_vertices_on_the_stored_edge_are_the_quads_own_float32_coordinates():
    region = {"x": 12.3, "y": -7.1, "width": 90, "height": 70, "scaleX": 1.3, "scaleY": 0.7}
    box = (5, 4, 85, 60)  # stored part of a 90 x 70 image
    corners = np.array([[5, 4], [85, 4], [85, 60], [5, 60], [40, 4], [85, 33]], float)
    ours = [[float32_exact(v) for v in p] for p in region_positions(region, corners, 90, 70, box)]
    # The runtimes: corner = -w/2*sx + offset*regionScale (+ stored size*regionScale), plus x, y.
    rsx, rsy = 90 / 90 * 1.3, 70 / 70 * 0.7
    left = -90 / 2 * 1.3 + 5 * rsx
    bottom = -70 / 2 * 0.7 + (70 - 60) * rsy
    right, top = left + 80 * rsx, bottom + 56 * rsy
    # What a runtime stores (float32) is the same number: the written decimal reads back as it.
    ours = np.float32(ours)
    assert ours[0].tolist() == np.float32([left + 12.3, top - 7.1]).tolist()
    assert ours[2].tolist() == np.float32([right + 12.3, bottom - 7.1]).tolist()
    assert ours[4][1] == ours[0][1] and ours[5][0] == ours[1][0]  # on an edge: its exact coordinate


def test_faint_art_and_premultiplied_light_are_inside_the_mesh(glow_project, tmp_path):
    result = upgrade_project(glow_project, tmp_path / "out", Options(min_saving=None))
    assert not result.partial and all(t.status == "meshed" for t in result.targets)
    mesh = json.loads((tmp_path / "out" / "demo.json").read_text())["skins"][0]["attachments"]["glow"]["demo-glow"]
    from spinemesh.metrics import uncovered_pixels

    uv = np.asarray(mesh["uvs"], float).reshape(-1, 2)
    triangles = np.asarray(mesh["triangles"], int).reshape(-1, 3)
    glow = _glow()
    drawn = glow.max(axis=-1) > 0
    assert not uncovered_pixels(uv * 64, triangles, drawn).any()


def test_glow_project_renders_like_the_original(glow_project, tmp_path):
    """Official runtime: within 2/255 on 99.9% of pixels; a pixel drawn by one side only is a
    rasterisation tie on a quad edge (scripts/prove_corpus.py, TIE_PX), never art added or lost."""
    from test_corpus_runtime import _prove_corpus
    from runtime_tool import install

    tool = install(tmp_path / "tool")
    if tool is None:
        if os.environ.get("CI"):
            pytest.fail("CI: Node/npm or ../shared/tools/spine-runtime is unavailable, the proof cannot run")
        pytest.skip("Node/npm or ../shared/tools/spine-runtime unavailable")
    rows = _prove_corpus().prove_project(tool, glow_project, tmp_path / "work", options=Options(min_saving=None))
    assert [r.status for r in rows] == ["pass"], [(r.cause, r.details) for r in rows]
    assert rows[0].meshed == rows[0].regions == 7 and rows[0].renders == 3


def test_a_texel_shown_texels_leaves_out_moves_no_pixel_by_more_than_faint_in_normal_blending():
    """The bound behind leaving faint texels out of meshes in normal slots: drawing a texel
    ``shown_texels`` leaves out changes no channel of any pixel by more than FAINT_TEXEL/255,
    for premultiplied and straight pages, over any destination, at any slot tint <= 1."""
    rng = np.random.default_rng(7)
    n = 200_000
    texels = rng.integers(0, 256, (n, 4)).astype(np.uint8)
    texels[: n // 2] = rng.integers(0, 2 * FAINT_TEXEL, (n // 2, 4))  # many near the threshold
    dest = rng.random((n, 4))
    tint = rng.random((n, 4))
    for pma in (True, False):
        left_out = ~shown_texels(texels.reshape(n, 1, 4), pma).ravel()
        t = texels[left_out].astype(float) / 255 * tint[left_out]
        c = t[:, :3] if pma else t[:, :3] * t[:, 3:4]  # premultiplied colour
        a = t[:, 3:4]
        src = np.concatenate([c, a], axis=1)
        over = src + (1 - a) * dest[left_out]  # normal blending, premultiplied
        assert left_out.sum() > 1000
        assert np.abs(over - dest[left_out]).max() <= FAINT_TEXEL / 255 + 1e-12
    # a texel just above it is shown; on a premultiplied page colour counts as well as alpha
    assert shown_texels(np.array([[[0, 0, 0, FAINT_TEXEL + 1]]], np.uint8), False).all()
    assert shown_texels(np.array([[[FAINT_TEXEL + 1, 0, 0, 0]]], np.uint8), True).all()
    assert not shown_texels(np.array([[[FAINT_TEXEL + 1, 0, 0, 0]]], np.uint8), False).any()


def test_faint_texels_are_left_out_in_normal_slots_only(glow_project, tmp_path):
    result = upgrade_project(glow_project, tmp_path / "out", Options(min_saving=None))
    assert all(t.status == "meshed" for t in result.targets)
    skin = json.loads((tmp_path / "out" / "demo.json").read_text())["skins"][0]["attachments"]
    from spinemesh.metrics import mesh_area, uncovered_pixels

    glow = _glow()
    meshes = {}
    for slot in ("glow", "glow-normal"):
        mesh = skin[slot]["demo-glow"]
        uv = np.asarray(mesh["uvs"], float).reshape(-1, 2) * 64
        triangles = np.asarray(mesh["triangles"], int).reshape(-1, 3)
        meshes[slot] = (uv, triangles)
    shown = shown_texels(glow, True)
    assert shown.any() and not shown.all()
    # additive: every drawn texel; normal: every texel above FAINT_TEXEL, and a smaller mesh
    assert not uncovered_pixels(*meshes["glow"], glow.max(axis=-1) > 0).any()
    assert not uncovered_pixels(*meshes["glow-normal"], shown).any()
    assert mesh_area(*meshes["glow-normal"]) < mesh_area(*meshes["glow"])


def test_the_hull_keeps_half_a_texel_around_every_drawn_texel_after_its_inset():
    """``upgrade`` grows the art by one texel and moves the hull half a texel back in
    (``hull_inset``): every point bilinear sampling takes a drawn texel's colour at (within
    half a texel of its square, inside the stored rectangle) must stay inside the hull."""
    import shapely

    from spinemesh.mesher import mesh_image, resolve_params
    from spinemesh.upgrade.meshing import SAMPLING_INSET, sampling_margin

    rng = np.random.default_rng(3)
    masks = []
    for _ in range(12):
        h, w = rng.integers(20, 90, 2)
        noise = rng.random((h // 4 + 2, w // 4 + 2))
        import cv2

        smooth = cv2.resize(noise, (int(w), int(h)), interpolation=cv2.INTER_CUBIC)
        masks.append(smooth > np.quantile(smooth, rng.uniform(0.4, 0.8)))  # blobs, often on the border
    masks.append(_glow()[2:62, 2:62].max(axis=-1) > 0)  # a disc touching its trimmed border
    params = resolve_params("default", hull_inset=SAMPLING_INSET)
    inset_somewhere = False
    for art in masks:
        if not art.any():
            continue
        rgba = np.zeros(art.shape + (4,), np.uint8)
        rgba[art, 3] = 255
        grown = sampling_margin(art)
        mesh = mesh_image(rgba, params, mask=grown)
        plain = mesh_image(rgba, resolve_params("default"), mask=grown)
        hull = shapely.Polygon(np.asarray(mesh.vertices)[: mesh.hull]).buffer(1e-9)
        crop = shapely.box(0, 0, art.shape[1], art.shape[0])
        reach = [shapely.box(x - 0.5, y - 0.5, x + 1.5, y + 1.5).intersection(crop) for y, x in np.argwhere(art)]
        assert all(hull.contains(r) for r in reach)
        inset_somewhere |= hull.area < shapely.Polygon(np.asarray(plain.vertices)[: plain.hull]).area - 1
    assert inset_somewhere


def test_bleeding_border_is_the_dilation_of_the_whole_frame():
    """bleeding_border reads only the frame's strips: the same texels as dilating the whole
    rectangle with its frame (rotated, offset and page-edge regions, straight and premultiplied)."""
    import cv2

    from spinemesh.atlas import parse_atlas
    from spinemesh.foreground import texels_as_words
    from spinemesh.images.regions import bleeding_border

    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(400):
        ph, pw = (int(v) for v in rng.integers(3, 30, 2))
        page = np.zeros((ph, pw, 4), np.uint8)
        page[..., 3] = (rng.random((ph, pw)) < 0.3) * rng.integers(1, 256, (ph, pw))
        page[..., 0] = (rng.random((ph, pw)) < 0.2) * 7  # premultiplied light: colour without alpha
        w, h = int(rng.integers(1, pw + 1)), int(rng.integers(1, ph + 1))
        rotate = bool(rng.random() < 0.3)
        sw, sh = (h, w) if rotate else (w, h)
        if sw > pw or sh > ph:
            continue
        x, y = int(rng.integers(0, pw - sw + 1)), int(rng.integers(0, ph - sh + 1))
        region = parse_atlas(f"p.png\nsize: {pw}, {ph}\na\n  rotate: {str(rotate).lower()}\n  xy: {x}, {y}\n"
                             f"  size: {w}, {h}\n  orig: {w + 2}, {h + 1}\n  offset: 1, 0\n").find("a")
        for pma in (False, True):
            ring = np.zeros((sh + 2, sw + 2), np.uint8)
            y0, x0 = y - 1, x - 1
            near = page[max(0, y0):y + sh + 1, max(0, x0):x + sw + 1]
            ring[max(0, y0) - y0:max(0, y0) - y0 + near.shape[0], max(0, x0) - x0:max(0, x0) - x0 + near.shape[1]] = \
                texels_as_words(near) != 0 if pma else near[..., 3] > 0
            ring[1:-1, 1:-1] = 0
            expected = cv2.dilate(ring, np.ones((3, 3), np.uint8))[1:-1, 1:-1].astype(bool)
            assert np.array_equal(bleeding_border(page, region, pma), expected)
            checked += expected.any()
    assert checked > 100


def test_float32_exact_of_an_array_is_that_of_each_value():
    """float32_exact_all gives, value by value, the float of np.format_float_positional(unique=True)
    of the float32: small, large, negative zero and overflowing values included."""
    from spinemesh.attachment_geometry import float32_exact_all

    rng = np.random.default_rng(5)
    values = np.concatenate([rng.normal(0, 1, 20000) * 10.0 ** rng.integers(-40, 39, 20000),
                             rng.uniform(-2000, 2000, 20000), np.round(rng.uniform(-2000, 2000, 5000), 2),
                             [0.0, -0.0, 1e-45, -1e-45, 3.4e38, 1e39, 0.1, 1 / 3, 1e7, 1e16]]).reshape(-1, 5)
    with np.errstate(over="ignore"):
        expected = [float(np.format_float_positional(np.float32(v), unique=True, trim="-")) for v in values.ravel()]
        got = float32_exact_all(values)
    assert len(got) == values.size
    assert all(a == b and np.copysign(1, a) == np.copysign(1, b) for a, b in zip(got, expected))
    assert float32_exact(0.1) == 0.1 and float32_exact(1 / 3) == 0.33333334
