"""``upgrade --preview``: the pages that show what an upgrade changed.

Runs on the demo project drawn by our own code. The browser checks need Chromium: skipped
when it is absent, a failure in CI (``CI=true``), where the proof must run.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from spinemesh.demo import make_demo_project
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.preview import fill_rate, mesh_raster, skeleton_signature, twin_of, write_preview


@pytest.fixture(scope="module")
def page(tmp_path_factory) -> tuple[Path, object]:
    tmp = tmp_path_factory.mktemp("preview")
    demo = make_demo_project(tmp / "demo")
    result = upgrade_project(demo, tmp / "out", Options())
    return write_preview(result, demo, tmp / "out", tmp / "preview"), result


def test_fill_rate_of_a_square_sprite():
    rgba = np.zeros((10, 10, 4), np.uint8)
    rgba[3:7, 2:6, 3] = 255
    # a mesh exactly around the opaque 4x4 square, as two triangles
    uvs = np.array([[2, 3], [6, 3], [6, 7], [2, 7]], float) / 10
    rate = fill_rate(rgba, (0, 0, 10, 10), uvs, np.array([[0, 1, 2], [0, 2, 3]]))
    assert (rate.before, rate.after, rate.transparent_before, rate.transparent_after) == (100, 16, 84, 0)
    # only the stored box is drawn by the region, and the mesh never draws outside it
    rate = fill_rate(rgba, (2, 3, 6, 7), uvs, np.array([[0, 1, 2], [0, 2, 3]]))
    assert (rate.before, rate.after, rate.transparent_before, rate.transparent_after) == (16, 16, 0, 0)


def test_mesh_raster_counts_texel_centres():
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    assert mesh_raster(uvs, np.array([[0, 1, 2], [0, 2, 3]]), 7, 5).sum() == 35


def _numbers(text: str) -> list[int]:
    return [int(g.replace(",", "")) for g in text]


def test_index_links_one_light_page_per_skeleton_and_adds_up(page):
    path, result = page
    folder = path.parent
    index = path.read_text(encoding="utf-8")
    pages = sorted(folder.glob("s/*.html"))
    # demo.json and demo-binary.skel are one skeleton in two formats: one page, counted once
    assert len(result.written) == 2 and len(pages) == 1
    assert re.findall(r'href="(s/[^"]+\.html)"', index) == [p.relative_to(folder).as_posix() for p in pages]
    assert "the same skeleton in the other format, counted once" in index
    html = pages[0].read_text(encoding="utf-8")
    # nothing inlined: every image is a file beside the pages, loaded when scrolled to
    for text in (index, html):
        assert "data:" not in text and "http://" not in text and "https://" not in text
    imgs = re.findall(r"<img [^>]*>", html)
    assert imgs and all('loading="lazy"' in i for i in imgs)
    for src in re.findall(r'src="([^"]+)"', html):
        assert (pages[0].parent / src).resolve().is_file(), src
    assert max(p.stat().st_size for p in folder.rglob("*.html")) < 2_000_000
    meshed = {t.key for t in result.targets if t.status == "meshed" and t.skeleton == result.written[0]}
    assert html.count('class="card"') == len(meshed)
    # the headline leads with texels drawn, then the transparent ones among them
    m = re.search(r'class="big">Texels drawn: ([\d,]+) → ([\d,]+) .*?class="second">of them fully transparent: '
                  r"([\d,]+) → ([\d,]+)", index, re.S)
    before, after, clear_before, clear_after = _numbers(m.groups())
    # the demo's art is fully opaque or fully clear: every visible texel is still drawn
    assert before - clear_before == after - clear_after
    assert clear_after < clear_before / 2, "the demo's meshes leave out most of the transparent area"
    # one skeleton's totals are the project's (its twin is not added)
    assert f"{before:,} → {after:,}" in html


def test_twins_are_the_same_skeleton_in_the_other_format():
    doc = {"bones": [{"name": "root"}], "slots": [{"name": "a", "bone": "root", "attachment": "x"}],
           "skins": [{"name": "default", "attachments": {"a": {"x": {}}}}], "animations": {"walk": {}}}
    other = {**doc, "animations": {"run": {}}}
    sig = {"p/a.json": skeleton_signature(doc), "p/a.skel": skeleton_signature(doc),
           "p/b.json": skeleton_signature(doc), "q/a.skel": skeleton_signature(doc),
           "p/c.skel": skeleton_signature(other)}
    rels = list(sig)
    # same folder, same skeleton, one JSON and one binary: a twin; b.json has no binary partner left,
    # q/ is another folder, c.skel another skeleton
    assert twin_of(rels, sig) == {"p/a.skel": "p/a.json"}
    # formats by content when given (a binary skeleton named .json)
    assert twin_of(["p/a.json", "p/b.json"], sig, {"p/a.json": False, "p/b.json": True}) == {"p/b.json": "p/a.json"}


def test_player_draws_both_sides_in_headless_chromium(page, tmp_path):
    from browser import canvases, player_result, run

    path, _ = page
    skeleton = next(path.parent.glob("s/*.html"))
    got = player_result(skeleton.resolve().as_uri() + "#at=0,0", tmp_path)
    sides = canvases(got)
    assert sides[0].shape == sides[1].shape
    # the demo's blue body drawn on both sides, alike (the meshes draw what the regions drew)
    blue = [(np.abs(s[..., :3].astype(int) - (70, 110, 200)).sum(axis=2) < 60).sum() for s in sides]
    assert min(blue) > 2000 and abs(blue[0] - blue[1]) < 0.02 * blue[0]
    drawn = [(s[..., 3] > 128) for s in sides]
    assert (drawn[0] ^ drawn[1]).sum() < 0.02 * drawn[0].sum()
    # the index opens without a page error
    run(path.resolve().as_uri(), tmp_path, "--dump-dom")


@pytest.mark.parametrize("size", [(1280, 720), (1920, 1080)])
def test_the_player_opens_whole_in_the_window_above_the_texel_counts(page, tmp_path, size):
    """A laptop's window shows the player, both canvases with their captions, without scrolling:
    it comes right under the title, the texel counts after it."""
    from browser import player_result

    path, _ = page
    skeleton = next(path.parent.glob("s/*.html"))
    text = skeleton.read_text()
    assert text.index('class="player"') < text.index("Texels drawn")
    got = player_result(skeleton.resolve().as_uri() + "#at=0,0", tmp_path, f"--window-size={size[0]},{size[1]}")
    width, height = got["window"]  # the page's part of the window: less the browser's bars
    assert width == size[0] and 0.7 * size[1] < height <= size[1]
    top, bottom = got["figure"]
    assert top < 0.3 * height and bottom <= height, (got["figure"], height)
    assert bottom - top > 0.6 * height  # and not shrunk to a thumbnail to fit


def test_setup_pose_dresses_an_empty_default_skin():
    """A project whose default skin is empty (mix-and-match) is drawn with the skin that
    supplies most of the slots' setup attachments, then the default skin."""
    from spinemesh.upgrade.preview import pose_skins

    doc = {"slots": [{"name": "a", "bone": "root", "attachment": "x"}, {"name": "b", "bone": "root", "attachment": "y"}],
           "skins": [{"name": "default", "attachments": {}},
                     {"name": "one", "attachments": {"a": {"x": {}}}},
                     {"name": "both", "attachments": {"a": {"x": {}}, "b": {"y": {}}}}]}
    assert pose_skins(doc) == ["both", "default"]
    doc["skins"] = doc["skins"][:1]
    assert pose_skins(doc) == ["default"]


def test_a_character_whose_default_skin_holds_none_of_it_is_played_in_its_own_skin():
    """A character whose attachments are all in named skins (the setup pose's in none: its
    animations put them on) and whose default skin holds one effect: the largest skin is
    offered, and sampled, first. The default skin came first, and over the poses' budget the
    animations were sampled in it alone: a 3.5 game character played 141 animations drawing
    nothing, on both sides."""
    from spinemesh.player.frames import plan_sampling, sampled_skins
    from spinemesh.upgrade.preview import pose_skins

    quad = {"width": 10, "height": 10}
    doc = {"skeleton": {"spine": "3.8.99"}, "bones": [{"name": "root"}],
           "slots": [{"name": "body", "bone": "root", "attachment": "gone"}, {"name": "fx", "bone": "root"}],
           "skins": [{"name": "default", "attachments": {"fx": {"flash": quad}}},
                     {"name": "small", "attachments": {"body": {"torso": quad, "arms": quad}}},
                     {"name": "hero", "attachments": {"body": {"torso": quad, "legs": quad, "arms": quad}}}],
           "animations": {"walk": {"slots": {"body": {"attachment": [{"name": "torso"}]}}}}}
    assert pose_skins(doc) == ["default"]  # no skin dresses the setup pose: the runtimes' default
    assert sampled_skins(doc) == ["hero", "small", "default"]
    _, sampling, _ = plan_sampling(doc, doc)
    assert sampling.skins[0][0] == "hero"
    # a default skin that dresses the setup pose still comes first, before larger skins
    doc["skins"][0]["attachments"]["body"] = {"gone": quad}
    assert sampled_skins(doc) == ["default", "hero", "small"]


def test_a_packed_project_without_meshes_still_shows_its_pages(tmp_path):
    demo = make_demo_project(tmp_path / "demo")
    result = upgrade_project(demo, tmp_path / "out", Options(pack=True, min_saving=1.0))
    assert not result.counts().get("meshed") and result.atlases[0].status == "packed"
    index = write_preview(result, demo, tmp_path / "out", tmp_path / "preview")
    text = index.read_text(encoding="utf-8")
    assert "No attachment meshed; 1 atlas packed anew: page texels" in text
    before, after = text.split("<h4>before</h4>")[1].split("<h4>after</h4>")
    for part in (before, after):
        srcs = re.findall(r'<img class="checker" loading="lazy" src="([^"]+)"', part)
        assert len(srcs) == 1 and (index.parent / srcs[0]).is_file()
    assert re.search(r"demo\.png: 512 x 256 = 131,072 texels.*demo\.png: \d+ x \d+ = 65,536 texels", text, re.S)


def test_a_library_gets_one_index(tmp_path):
    import shutil

    from spinemesh.upgrade import upgrade_library

    demo = make_demo_project(tmp_path / "demo")
    for name in ("a", "b"):
        shutil.copytree(demo, tmp_path / "lib" / name)
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(jobs=1))
    index = write_preview(result, tmp_path / "lib", tmp_path / "out", tmp_path / "preview")
    text = index.read_text(encoding="utf-8")
    links = re.findall(r'href="(s/[^"]+\.html)"', text)
    assert len(links) == 2 and all((index.parent / link).is_file() for link in links)  # a/ and b/, twins once each
    assert "a/demo" in text and "b/demo" in text
    for link in links:  # each page draws its project's images
        page = (index.parent / link).read_text(encoding="utf-8")
        assert page.count('class="card"') == 5


def test_player_plays_every_animation_on_one_time_line(page, tmp_path):
    """The demo's "wave" (the player's animation 1, after the setup pose) plays: the page's
    clock advances, and both canvases change as it does."""
    from browser import player_result

    path, _ = page
    skeleton = next(path.parent.glob("s/*.html"))
    model = next(path.parent.glob("data/*/model.js")).read_text(encoding="utf-8")
    assert re.findall(r'"name":"([^"]+)","dur"', model) == ["setup pose", "wave"]
    got = player_result(skeleton.resolve().as_uri() + "#play=1&test=2", tmp_path, budget_ms=8000)
    assert got["anim"] == "wave"
    times = [s["t"] for s in got["samples"]]
    # Headless Chromium runs on virtual time and makes animation frames as it can: how far the
    # clock gets in the test's seconds depends on the machine's load (0.27 s to 1 s measured),
    # so the test asks that it moved on through several frames, not how far.
    assert len(set(times)) >= 5 and max(times) >= 5 / 60
    for side in ("before", "after"):
        assert len({s[side] for s in got["samples"]}) >= 5, f"the {side} canvas does not change as it plays"



@pytest.mark.parametrize("bad, anim", [
    ("play=%E0%A4%A", "setup pose"),           # a %-escape cut short: decodeURIComponent throws on it
    ("%E0%A4%A&skin=%ZZ&play=1", "wave"),       # the bad parts left out, the good one kept
    ("play=99&skin=-2", "setup pose"),          # choices the page does not have
    ("at=x,-1,0,0,a,-5,0", "setup pose"),       # a still frame of nothing readable: the first, at 0 s
])
def test_a_malformed_address_opens_the_player_on_its_first_animation(page, tmp_path, bad, anim):
    """An address typed, cut short or pasted by hand: what the player cannot read in its #hash is
    left out, with no page error, and the player opens on its first animation (or the one the
    readable part names) and plays."""
    from browser import player_result

    path, _ = page
    url = next(path.parent.glob("s/*.html")).resolve().as_uri() + "#" + bad
    if "at=" in bad:  # a still frame: both canvases written, the setup pose at 0 s
        got = player_result(url, tmp_path)
        assert (got["t"], got["frame"]) == (0, 0) and got["before"].startswith("data:image/png")
        return
    got = player_result(url + "&test=1", tmp_path, budget_ms=4000)
    assert got["anim"] == anim
    times = [s["t"] for s in got["samples"]]
    assert len(got["samples"]) >= 3 and all(t == t for t in times)  # sampled, every time a number
    if anim == "wave":
        assert len(set(times)) >= 3, "the player does not play"


#: How close a frame of our player comes to the official runtime's render of the same time
#: (render.mjs, spine-core 4.2, CanvasKit), premultiplied RGBA: at most this share of pixels
#: off by more than 32/255. Measured, original and upgraded alike: the demo's "wave" at 0.5 s
#: 0.058% (worst pixel 80/255), spineboy-pro's "run" at 0.5 s 0.105% (worst 65/255): edges
#: of the art, anti-aliased differently by a 2D canvas; no visible pixel lost.
RENDER_TOLERANCE = 0.005


def test_a_frame_of_the_player_matches_the_official_runtime(page, spine_runtime, tmp_path):
    from browser import against_the_runtime

    path, result = page
    demo, out = path.parent.parent / "demo", path.parent.parent / "out"
    rel = "demo.json"
    diffs = against_the_runtime(spine_runtime, tmp_path, path.parent, next(path.parent.glob("s/*.html")).name, 1, "wave",
                                 (demo / "demo.atlas", demo / rel), (out / "demo.atlas", out / rel))
    for d in diffs:
        assert d["off_share"] <= RENDER_TOLERANCE, d
        assert d["visible"] > 10_000


@pytest.fixture(scope="module")
def spineboy(examples, tmp_path_factory) -> tuple[Path, Path, Path, list[str]]:
    """spineboy-pro (4.2) upgraded and previewed: (project, upgraded output, preview index,
    the player's animation names)."""
    import shutil

    tmp = tmp_path_factory.mktemp("spineboy")
    project = tmp / "spineboy"
    project.mkdir()
    for name in ("spineboy-pro.json", "spineboy.atlas", "spineboy.png"):
        shutil.copy(examples / "4.2" / "spineboy" / name, project)
    result = upgrade_project(project, tmp / "out", Options(jobs=1))
    index = write_preview(result, project, tmp / "out", tmp / "preview")
    model = (index.parent / "data" / "spineboy-pro" / "model.js").read_text(encoding="utf-8")
    return project, tmp / "out", index, re.findall(r'"name":"([^"]+)","dur"', model)


def _against_the_runtime(spine_runtime, tmp_path, spineboy, anim: str, time: float = 0.5, frame=None) -> list[dict]:
    from browser import against_the_runtime

    project, out, index, names = spineboy
    return against_the_runtime(spine_runtime, tmp_path, index.parent, "spineboy-pro.html", names.index(anim), anim,
                               (project / "spineboy.atlas", project / "spineboy-pro.json"),
                               (out / "spineboy.atlas", out / "spineboy-pro.json"), time, frame)


def test_spineboy_runs_in_the_player_as_in_the_official_runtime(spineboy, spine_runtime, tmp_path):
    names = spineboy[3]
    assert names[0] == "setup pose" and len(names) == 12  # and every animation of spineboy-pro
    for d in _against_the_runtime(spine_runtime, tmp_path, spineboy, "run"):
        assert d["off_share"] <= RENDER_TOLERANCE and d["lost"] < 0.001 * d["visible"], d


#: spineboy-pro's "portal" at this time: he steps out of the portal, about 60% of his art's
#: area still outside the polygon of the clipping attachment (whose slot clips every slot up to
#: head-bb's) and so hidden.
PORTAL_TIME = 1.2


def test_clipping_attachments_clip_in_the_player_as_in_the_runtime(spineboy, spine_runtime, tmp_path):
    """Measured (headless Chromium against spine-core 4.2, 1 px a unit, 259,000 pixels
    visible): 0.017% and 0.016% of the frame's pixels off by more than 32/255, original and
    upgraded, none lost, 20 and 22 added on the art's edges; drawn unclipped (as the player
    drew it before), 7.0% off: this test fails."""
    from spinemesh.anim import Sampler, atlas_regions
    from spinemesh.atlas import read_atlas
    from spinemesh.skeleton import load_skeleton

    project = spineboy[0]
    pose = Sampler(load_skeleton(project / "spineboy-pro.json"), None,
                   atlas_regions(read_atlas(project / "spineboy.atlas"))).pose("portal", PORTAL_TIME)
    clipped = [s for s in pose.slots if s.clip is not None]
    assert len(clipped) > 10
    art = np.concatenate([s.vertices for s in pose.slots])  # clipped or not: the frame holds all of it
    (x0, y0), (x1, y1) = art.min(axis=0) - 20, art.max(axis=0) + 20
    for d in _against_the_runtime(spine_runtime, tmp_path, spineboy, "portal", PORTAL_TIME, (x0, y0, x1 - x0, y1 - y0)):
        assert d["visible"] > 10_000, d
        assert d["off_share"] <= RENDER_TOLERANCE and d["lost"] < 0.001 * d["visible"], d
        assert d["added"] < 0.001 * d["visible"], d


def test_the_player_offers_the_skins_and_draws_the_one_chosen(tmp_path):
    """A skin that dresses the body slot in the ring's image: offered first (it dresses the setup
    pose, which the default skin leaves without a body), then the default skin; each drawn when
    chosen (the page's #skin=), on both sides."""
    import json

    from browser import canvases, player_result

    demo = make_demo_project(tmp_path / "demo")
    (demo / "demo-binary.skel").unlink()
    doc = json.loads((demo / "demo.json").read_text(encoding="utf-8"))
    ring = dict(doc["skins"][0]["attachments"]["ring"]["demo-ring"], x=0.0, y=0.0, path="demo-ring")
    doc["skins"].append({"name": "ringed", "attachments": {"body": {"demo-body": ring}}})
    del doc["skins"][0]["attachments"]["body"]  # the body is drawn by the skin chosen only
    (demo / "demo.json").write_text(json.dumps(doc), encoding="utf-8")
    result = upgrade_project(demo, tmp_path / "out", Options())
    index = write_preview(result, demo, tmp_path / "out", tmp_path / "preview")
    model = (index.parent / "data" / "demo" / "model.js").read_text(encoding="utf-8")
    assert '"skins":["ringed","default"]' in model
    url = (index.parent / "s" / "demo.html").resolve().as_uri()
    ringed = canvases(player_result(url + "#at=0,0&skin=0", tmp_path / "a"))
    plain = canvases(player_result(url + "#at=0,0&skin=1", tmp_path / "b"))
    red = lambda rgba: int((np.abs(rgba[..., :3].astype(int) - (200, 60, 60)).sum(axis=2) < 80).sum())  # noqa: E731
    for side in (0, 1):
        assert red(ringed[side]) > 1.5 * red(plain[side]), "the chosen skin's ring is not drawn"


def test_frames_fall_on_the_players_clock_within_the_budget():
    from spinemesh.player.frames import FPS, MAX_FRAMES, MAX_VALUES, frame_rate, frame_times

    # a 1 s animation at 30 frames a second: frame i is the pose at i / 30 s, the last before 1 s
    rate = frame_rate(1.0, 100)
    assert rate == FPS and np.allclose(frame_times(1.0, rate), np.arange(30) / 30)
    assert len(frame_times(0.0, rate)) == 1  # a still pose
    # a long animation keeps at most MAX_FRAMES frames, a heavy one at most MAX_VALUES coordinates
    assert len(frame_times(60.0, frame_rate(60.0, 100))) <= MAX_FRAMES
    heavy = frame_rate(10.0, 20_000)
    assert len(frame_times(10.0, heavy)) * 2 * 20_000 <= MAX_VALUES


def test_a_mix_and_match_character_is_played_dressed_in_its_skins_combined(tmp_path, monkeypatch):
    """A character whose default skin is empty and whose setup pose two skins dress (a body, its
    clothes): the player offers them combined first, and draws every frame of the animation
    as the same character kept in one skin, on both sides; one skin alone draws a part."""
    import json

    from browser import canvases, player_result

    pages = {}
    for name, split in (("whole", False), ("parts", True)):
        demo = make_demo_project(tmp_path / name)
        (demo / "demo-binary.skel").unlink()
        if split:
            doc = json.loads((demo / "demo.json").read_text(encoding="utf-8"))
            atts = doc["skins"][0]["attachments"]
            body = {k: atts.pop(k) for k in ("arm", "body", "head")}
            doc["skins"] += [{"name": "body", "attachments": body}, {"name": "clothes", "attachments": dict(atts)}]
            atts.clear()
            keyed = doc["animations"]["wave"]["attachments"]  # the spark's sequence, keyed by its skin
            keyed["clothes"] = keyed.pop("default")
            (demo / "demo.json").write_text(json.dumps(doc), encoding="utf-8")
        result = upgrade_project(demo, tmp_path / f"{name}-out", Options())
        index = write_preview(result, demo, tmp_path / f"{name}-out", tmp_path / f"{name}-preview")
        pages[name] = (index.parent / "s" / "demo.html").resolve().as_uri()
        model = (index.parent / "data" / "demo" / "model.js").read_text(encoding="utf-8")
        if split:
            assert '"skins":["body + clothes","body","clothes"' in model or '"skins":["clothes + body"' in model
        if not split:  # one world frame for every picture: the whole character's bounds
            data = (index.parent / "data" / "demo" / "1.0.js").read_text(encoding="utf-8")
            x0, y0, x1, y1 = json.loads(re.search(r'"box":(\[[^]]*\])', data).group(1))
            view = f"{x0},{y0},{x1 - x0},{y1 - y0},{400 / max(x1 - x0, y1 - y0)}"
    for t in (0.0, 0.5):
        whole = canvases(player_result(pages["whole"] + f"#at=1,{t},{view}", tmp_path / f"w{t}"))
        parts = canvases(player_result(pages["parts"] + f"#at=1,{t},{view}&skin=0", tmp_path / f"p{t}"))
        part = canvases(player_result(pages["parts"] + f"#at=1,{t},{view}&skin=1", tmp_path / f"q{t}"))
        for side in (0, 1):
            assert whole[side].shape == parts[side].shape
            drawn = whole[side][..., 3] > 128
            assert drawn.sum() > 2000
            assert ((parts[side][..., 3] > 128) ^ drawn).sum() < 0.01 * drawn.sum(), (t, side)
            assert (part[side][..., 3] > 128).sum() < 0.9 * drawn.sum(), (t, side)
    # over the poses' budget the animations are sampled in the first skin alone: the page says
    # which skin it draws instead of the one chosen, and why, in words a user knows
    from browser import run

    from spinemesh.player import frames

    monkeypatch.setattr(frames, "MAX_POSES", 40)
    index = write_preview(result, demo, tmp_path / "parts-out", tmp_path / "budget-preview")
    dom = run((index.parent / "s" / "demo.html").resolve().as_uri() + "#at=1,0.5&skin=1", tmp_path / "budget",
              "--dump-dom").stdout
    status = re.search(r'<div class="status">([^<]*)</div>', dom).group(1)
    assert status.startswith(tuple(f"Drawn in the skin {skins}: to keep the preview small"
                                   for skins in ("body + clothes", "clothes + body"))), status
    assert "budget" not in status


def test_a_bent_mesh_is_drawn_without_seams_between_its_triangles(tmp_path):
    """A mesh that bends is drawn triangle by triangle, each clipped with anti-aliased edges: the
    light lattice of half-covered pixels along every shared edge (5% of the worm's inside when
    the triangles were grown by 0.4 pixel from their centroids) must not show a user a torn mesh."""
    from browser import canvases, player_result
    from rig_project import make_worm_project
    from scipy import ndimage

    make_worm_project(tmp_path / "in")
    result = upgrade_project(tmp_path / "in", tmp_path / "out", Options(weights="auto"))
    index = write_preview(result, tmp_path / "in", tmp_path / "out", tmp_path / "preview")
    url = (index.parent / "s" / "worm.html").resolve().as_uri()
    for t in (0.25, 0.5):  # the worm bent by its wiggle
        before, after = canvases(player_result(url + f"#at=1,{t}", tmp_path / f"c{t}"))
        inside = [ndimage.binary_erosion(side[..., 3] > 128, iterations=2) for side in (before, after)]
        assert abs(int(inside[1].sum()) - int(inside[0].sum())) < 0.15 * inside[0].sum()  # nothing cut away
        seams = (after[..., 3] < 250) & inside[1]
        assert seams.sum() < 0.001 * inside[1].sum(), (t, int(seams.sum()))


def test_the_player_fills_the_window_at_laptop_and_desktop_sizes(page, tmp_path):
    """At 1280x720 and 1920x1080 the two canvases stand side by side within the window's width,
    each at most 80% of its height and ending above its bottom edge, and a larger window shows the
    skeleton larger (it was 400 pixels at any size: a thumbnail on a desktop screen)."""
    from browser import run

    path, _ = page
    url = next(path.parent.glob("s/*.html")).resolve().as_uri() + "#at=1,0.5"
    sizes = {}
    for w, h in ((1280, 720), (1920, 1080)):
        dom = run(url, tmp_path / f"{w}", "--dump-dom", f"--window-size={w},{h}").stdout
        canvases = [(int(a), int(b)) for a, b in re.findall(r'<canvas width="(\d+)" height="(\d+)"', dom)]
        assert len(canvases) == 2 and canvases[0] == canvases[1], canvases
        cw, ch = canvases[0]
        assert 2 * cw + 16 + 48 <= w and ch <= 0.8 * h + 20, (w, h, canvases)
        sizes[w] = max(cw, ch)
    assert sizes[1920] > 1.3 * sizes[1280] and sizes[1280] > 380  # the window less its bars and the title


def test_the_preview_over_jobs_writes_the_same_files(tmp_path, monkeypatch):
    """``upgrade --preview --jobs 2``: the players' animations sampled by worker processes, one
    animation a task, every file the same as one process writes."""
    import shutil

    from spinemesh.upgrade import preview, upgrade_library

    demo = make_demo_project(tmp_path / "demo")
    doc = json.loads((demo / "demo.json").read_text())
    wave = doc["animations"]["wave"]
    doc["animations"] |= {"slow": {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 3, "value": 90}]}}},
                          "still": {}, "wave2": wave}
    (demo / "demo.json").write_text(json.dumps(doc))
    (demo / "demo-binary.skel").unlink()  # no longer its twin
    for name in ("a", "b", "c"):
        shutil.copytree(demo, tmp_path / "lib" / name)
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(jobs=1))
    monkeypatch.setattr(preview, "CHUNK_SECONDS", 0.0)  # a task per animation: runs of several in flight
    assert preview._chunks({"a": 1.0, "b": 3.0, "c": 0.0}, 8) == [["a"], ["b"], ["c"]]
    folders, told = {}, {}
    for jobs in (1, 2):
        folders[jobs], told[jobs] = tmp_path / f"preview{jobs}", []
        write_preview(result, tmp_path / "lib", tmp_path / "out", folders[jobs], jobs=jobs,
                      on_progress=lambda done, total, jobs=jobs: told[jobs].append((done, total)))
    for calls in told.values():  # the bar: 3 skeletons and their 4 animations each, done in order
        assert calls[0] == (0, 15) and calls[-1] == (15, 15) and [d for d, _ in calls] == sorted(d for d, _ in calls)
    files = {jobs: sorted(p.relative_to(f) for p in f.rglob("*") if p.is_file()) for jobs, f in folders.items()}
    assert files[1] == files[2] and len([p for p in files[1] if p.parts[0] == "data"]) == 3 * (1 + 5)
    for rel in files[1]:
        assert (folders[1] / rel).read_bytes() == (folders[2] / rel).read_bytes(), rel


def test_an_animation_encoded_apart_is_written_as_if_encoded_in_the_page(tmp_path):
    """A worker encodes each animation against tables of its own (:func:`encode_animation`); the
    page renumbers them (:meth:`SideTable.absorb`) to what encoding all of them against the
    page's tables gives: the same indices, rows and image indices, in the same order."""
    from spinemesh.player.frames import SideTable, animations, bounds, encode_animation, encode_frames

    doc = json.loads((make_demo_project(tmp_path / "demo") / "demo.json").read_text())
    shown = animations(doc, doc)
    assert len(shown) == 2 and len(shown[1].by_skin["default"][0]) > 10
    images: list[str] = []

    def image_index(path):
        if path not in images:
            images.append(path)
        return images.index(path)

    direct, renumbered = SideTable(image_index), SideTable(image_index)
    for anim in shown[::-1] + shown:  # the setup pose's attachments seen in a second order too
        poses = anim.by_skin["default"][0]
        box = bounds(poses + anim.by_skin["default"][1])
        pad = 0.02 * max(box[2] - box[0], box[3] - box[1])
        box = (box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad)
        want = encode_frames(poses, direct, box)
        got = renumbered.absorb(encode_animation(anim).by_skin["default"][2][0])
        assert got == want
    assert renumbered.rows == direct.rows and renumbered.keys == direct.keys and len(direct.rows) >= 5
