"""Hostile input, fifth round: the surfaces of wave 4 (``pose`` and its sampler, the preview
player, ``pack``'s page formats and extremes, Spine 3.5 binaries).

Every project is made here by our own code (small skeletons written as JSON, the demo project
drawn by ``spinemesh.demo``); nothing is copied from real data. What each case checks is what
docs/safety.md promises: no traceback, one line naming the file, nothing non-finite written,
one bad animation never stopping the others, time and memory bounded whatever a file says.
"""

from __future__ import annotations

import copy
import json
import math
import signal
from contextlib import contextmanager

import numpy as np
import pytest
from test_anim import _doc
from test_hostile import check_run, run_cli, snapshot

from spinemesh.anim import Sampler
from spinemesh.anim.dump import dump
from spinemesh.anim.timelines import _draw_order
from spinemesh.skeleton import load_skeleton
from spinemesh.skeleton_binary import SkelFormatError, encode_skel, read_skel


@contextmanager
def within(seconds: int):
    """Fail (instead of hanging) when the block takes longer than ``seconds``."""
    def expire(*_):
        raise TimeoutError(f"took longer than {seconds} s")
    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


# --- pose and the sampler -------------------------------------------------------------------

#: An integer JSON parses (under Python's 4300 digits) that no float holds.
BIG = int("1" + "0" * 400)

#: Animations a document may hold that no runtime would play sensibly: each must pose (or be
#: refused alone, in one line), write nothing non-finite and change no other animation.
HOSTILE_ANIMATIONS = {
    "a key at 1e30 s": {"bones": {"arm": {"rotate": [{"time": 1e30, "value": 5}]}}},
    "a key at 1e300 s (beyond float32)": {"bones": {"arm": {"rotate": [{"time": 1e300, "value": 5}]}}},
    "an event at 1e300 s": {"events": [{"time": 1e300, "name": "x"}]},
    "negative times": {"bones": {"arm": {"rotate": [{"time": -5, "value": 5}, {"time": -1, "value": 50}]}}},
    "a value of 1e300": {"bones": {"arm": {"rotate": [{"time": 0, "value": 1e300}]}}},
    "a translation of 1e38": {"bones": {"arm": {"translate": [{"time": 0, "x": 1e38, "y": 1e38}]}}},
    "bezier handles of 1e30": {"bones": {"arm": {"rotate": [
        {"time": 0, "value": 0, "curve": [1e30, -1e30, -1e30, 1e30]}, {"time": 1, "value": 90}]}}},
    "a bezier over no time": {"bones": {"arm": {"rotate": [
        {"time": 0.5, "value": 0, "curve": [0.5, 1, 0.5, 2]}, {"time": 0.5, "value": 90}]}}},
    "a 3.8 curve in a 4.2 file": {"bones": {"arm": {"rotate": [
        {"time": 0, "value": 0, "curve": 0.25, "c2": 9, "c3": 0.5}, {"time": 1, "value": 90}]}}},
    "keys out of order": {"bones": {"arm": {"rotate": [
        {"time": 1, "value": 0}, {"time": 0.2, "value": 90}, {"time": 0.5, "value": 9}]}}},
    "zero duration": {"bones": {"arm": {"rotate": [{"time": 0, "value": 30}]}}},
    "empty": {},
    "timelines of what does not exist": {
        "bones": {"nobone": {"rotate": [{"time": 1}]}}, "slots": {"noslot": {"rgba": [{"time": 1}]}},
        "ik": {"noik": [{"time": 1, "mix": 0}]}, "transform": {"no": [{"time": 1}]},
        "path": {"no": {"mix": [{"time": 1}]}}, "physics": {"nop": {"reset": [{"time": 1}]}},
        "attachments": {"noskin": {"s": {"a": {"deform": [{"time": 1, "vertices": [1, 2]}]}}}}},
    "a deform of 500 numbers on 3 vertices, offset a billion": {"attachments": {"default": {"m": {"mesh": {
        "deform": [{"time": 0, "vertices": [1] * 500, "offset": 3}, {"time": 1, "offset": 10**9, "vertices": [1]}]}}}}},
    "a weighted deform cut short, negative offset": {"attachments": {"default": {"w": {"weighted": {
        "deform": [{"time": 0, "vertices": [1e30] * 100}, {"time": 1, "offset": -5, "vertices": [3]}]}}}}},
    "a deform of a region": {"attachments": {"default": {"s": {"a": {"deform": [{"time": 0, "vertices": [1, 2, 3]}]}}}}},
    "draw order offsets of a billion": {"drawOrder": [{"time": 0.1, "offsets": [
        {"slot": "s", "offset": 1e9}, {"slot": "s", "offset": -3}, {"slot": "m", "offset": 1.5}]}]},
    "draw order offsets out of slot order": {"drawOrder": [{"time": 0, "offsets": [
        {"slot": "w", "offset": -2}, {"slot": "m", "offset": -1}]}]},
    "draw order offsets onto one place": {"drawOrder": [{"time": 0, "offsets": [
        {"slot": "m", "offset": 1}, {"slot": "w", "offset": 0}]}]},
    "attachment keys at one time": {"slots": {"s": {"attachment": [
        {"time": 0.5, "name": "b"}, {"time": 0.5, "name": None}, {"time": 0.2, "name": "zz"}]}}},
    "colour curves of a billion": {"slots": {"s": {"rgba": [
        {"time": 0, "color": "ffffff", "curve": [0, 1e9, 1, -1e9] * 4}, {"time": 1, "color": "00000000"}],
        "alpha": [{"time": 0, "value": 1e20}]}}},
    "IK mix 1e30, softness -1e30": {"ik": {"x": [{"time": 0, "mix": 1e30, "softness": -1e30}]}},
    "an unknown inherit mode": {"bones": {"arm": {"inherit": [{"time": 0, "inherit": "bogus"}, {"time": "x"}]}}},
    "a sequence index of 1e20, delay 1e-30": {"attachments": {"default": {"s": {"a": {"sequence": [
        {"time": 0, "mode": "loop", "delay": 1e-30, "index": 1e20}]}}}}},
    # integers of 400 digits: Python's JSON reads them, no float holds them
    "a key time of 400 digits": {"bones": {"arm": {"rotate": [{"time": BIG, "value": 5}]}}},
    "a value of 400 digits": {"bones": {"arm": {"rotate": [{"time": 0, "value": BIG}]}}},
    "a curve handle of 400 digits": {"bones": {"arm": {"rotate": [
        {"time": 0, "value": 0, "curve": [BIG, 1, 1, 1]}, {"time": 1, "value": 90}]}}},
    "deform vertices of 400 digits": {"attachments": {"default": {"m": {"mesh": {
        "deform": [{"time": 0, "vertices": [BIG]}]}}}}},
    "a deform offset of 400 digits": {"attachments": {"default": {"m": {"mesh": {
        "deform": [{"time": 0, "offset": BIG, "vertices": [1]}]}}}}},
    "a draw order offset of 400 digits": {"drawOrder": [{"time": 0, "offsets": [{"slot": "s", "offset": BIG}]}]},
    "a sequence delay of 400 digits": {"attachments": {"default": {"s": {"a": {"sequence": [
        {"time": 0, "mode": "loop", "delay": BIG, "index": BIG}]}}}}},
}

TIMES = [0.0, 0.3, 0.5, 1.0, 2.7]


def _hostile_doc(version: str = "4.2.00") -> dict:
    doc = _doc()
    doc["skeleton"]["spine"] = version
    doc["ik"] = [{"name": "x", "bones": ["arm"], "target": "root"}]
    doc["events"] = {"x": {}}
    doc["animations"].update(copy.deepcopy(HOSTILE_ANIMATIONS))
    return doc


def _strict(obj) -> dict:
    return json.loads(json.dumps(obj, allow_nan=False))


def test_every_hostile_animation_poses_finite_and_leaves_the_others_alone():
    alone = _hostile_doc()
    alone["animations"] = {"turn": alone["animations"]["turn"]}
    clean = _strict(dump(Sampler(alone), "turn", TIMES))
    sampler = Sampler(_hostile_doc())
    with within(60):
        for name in HOSTILE_ANIMATIONS:
            out = _strict(dump(sampler, name, TIMES))      # allow_nan=False: nothing non-finite
            assert [p["label"] for p in out["poses"]][1:] == [f"{name}@{t:g}" for t in TIMES]
            durations = {a["name"]: a["duration"] for a in out["skeleton"]["animations"]}
            assert all(d is None or abs(d) < 1e39 for d in durations.values())
        turn = _strict(dump(sampler, "turn", TIMES))
    assert turn["poses"] == clean["poses"]


def test_draw_order_keys_the_runtimes_cannot_read_still_draw_every_slot_once():
    slots = {"a": 0, "b": 1, "c": 2, "d": 3}
    for offsets in ([{"slot": "d", "offset": -3}, {"slot": "b", "offset": 1}],   # out of slot order
                    [{"slot": "b", "offset": 1}, {"slot": "c", "offset": 0}],    # onto one place
                    [{"slot": "a", "offset": 10**9}, {"slot": "a", "offset": -1}],
                    [{"slot": "a", "offset": 3}, {"slot": "b", "offset": 2}, {"slot": "c", "offset": -2}]):
        assert sorted(_draw_order(offsets, slots)) == [0, 1, 2, 3], offsets
    # what the runtimes read is unchanged: d to the front, the others in the gaps
    assert _draw_order([{"slot": "d", "offset": -3}], slots) == [3, 0, 1, 2]


@pytest.mark.parametrize("version", ["4.2.00", "3.8.99"])
def test_hostile_animations_of_binary_skeletons_pose_finite(version):
    """The same animations written as a .skel by our writer (where the format holds them: a
    float32 file cannot hold 400 digits, a 3.8 file no 4.x timeline) and read back."""
    doc = _hostile_doc(version)
    if version.startswith("3"):
        doc["skins"] = {"default": doc["skins"][0]["attachments"]}
        del doc["animations"]["turn"]["attachments"]
    written = 0
    for name, anim in HOSTILE_ANIMATIONS.items():
        one = {**doc, "animations": {name: anim}}
        try:
            data = encode_skel(one)
        except SkelFormatError:
            continue  # refused in one line: nothing to pose
        written += 1
        with within(30):
            _strict(dump(Sampler(read_skel(data)), name, TIMES))
    assert written >= 15


def _pose_cli(tmp_path, skeleton, *args, out="pose.json"):
    before = snapshot(tmp_path)
    r = run_cli("pose", skeleton, *args, "--out", out, cwd=tmp_path)
    check_run(r, before, tmp_path, [out])
    return r


def _posed(tmp_path, doc: dict, animation: str, times: str) -> list:
    """The poses ``spinemesh pose`` writes of ``animation`` of ``doc`` (a project ``p`` in
    ``tmp_path``) at ``times``; the command must succeed."""
    project = tmp_path / "p"
    project.mkdir()
    (project / "x.json").write_text(json.dumps(doc))
    r = _pose_cli(tmp_path, "p/x.json", "-a", animation, "--times", times)
    assert r.returncode == 0, r.stderr
    return json.loads((tmp_path / "pose.json").read_text())["poses"]


def test_pose_command_on_a_skeleton_full_of_hostile_animations(tmp_path):
    """One line or a finite pose, never a traceback; the good animation poses as it would alone."""
    project = tmp_path / "p"
    project.mkdir()
    (project / "arm.json").write_text(json.dumps(_hostile_doc()))
    for i, name in enumerate(("a key time of 400 digits", "draw order offsets out of slot order",
                              "an event at 1e300 s")):
        r = _pose_cli(tmp_path, "p/arm.json", "-a", name, "--times", "0,0.3,1", out=f"{i}.json")
        assert r.returncode == 0, r.stderr
    r = _pose_cli(tmp_path, "p/arm.json", "-a", "turn", "--times", "0.25,0.8")
    assert r.returncode == 0, r.stderr
    written = json.loads((tmp_path / "pose.json").read_text())
    alone = _hostile_doc()
    alone["animations"] = {"turn": alone["animations"]["turn"]}
    assert written["poses"] == _strict(dump(Sampler(alone), "turn", [0.25, 0.8]))["poses"]


def test_motion_sampling_of_an_animation_hours_long_is_bounded():
    """``weights``' motion guard samples every animation at thirds of its length: a key at
    1e30 s once summed 6e31 game-loop steps."""
    from spinemesh.anim.bone_worlds import sampled_bone_worlds

    doc = _doc()
    doc["events"] = {"x": {}}
    doc["animations"]["far"] = {"events": [{"time": 1e30, "name": "x"}],
                                "bones": {"arm": {"rotate": [{"time": 0, "value": 0}, {"time": 1e30, "value": 9}]}}}
    with within(20):
        frames = sampled_bone_worlds(doc)
    assert frames.shape == (6, 2, 2, 3) and np.isfinite(frames).all()


def _physics_doc() -> dict:
    doc = _doc()
    doc["bones"].append({"name": "drop", "parent": "arm"})
    doc["physics"] = [{"name": "p", "bone": "drop", "y": 1, "strength": 0, "gravity": 70}]
    doc["events"] = {"x": {}}
    doc["animations"]["far"] = {"events": [{"time": 1e6, "name": "x"}]}
    return doc


def test_the_player_leaves_out_an_animation_whose_physics_would_replay_for_hours():
    from spinemesh.player.frames import animations

    problems: list[str] = []
    with within(60):
        shown = animations(_physics_doc(), _physics_doc(), problems=problems)
    assert [a.name for a in shown] == ["setup pose", "turn"]
    assert len(problems) == 1 and "'far'" in problems[0] and "game-loop steps" in problems[0]


def test_upgrade_preview_of_a_skeleton_with_an_event_at_1e30_s_ends(tmp_path):
    """It once sampled 1e30 s of game loop, step by step, for the player (a hang)."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p")
    doc = json.loads((project / "demo.json").read_text())
    doc.setdefault("events", {})["x"] = {}
    doc["animations"]["far"] = {"events": [{"time": 1e30, "name": "x"}]}
    (project / "demo.json").write_text(json.dumps(doc))
    (project / "demo-binary.skel").unlink()
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--preview", "v", cwd=tmp_path, timeout=90)
    check_run(r, before, tmp_path, ["o", "v"], codes=(0,))
    assert (tmp_path / "v" / "index.html").is_file()
    assert load_skeleton(tmp_path / "o" / "demo.json")["animations"]["far"]["events"][0]["time"] == 1e30


# --- the preview pages and the player -------------------------------------------------------

#: Names that run code wherever a page pastes them unescaped (HTML text, an attribute, an inline
#: script, a JavaScript string): each, if it ran, would set the page's title to ``PWNED``, a
#: word none of them holds whole.
PAYLOADS = [
    "</script><script>document.title='PW'+'NED'</script>",
    "<img src=q onerror=\"document.title='PW'+'NED'\">",
    "'\"><svg onload=document.title='PW'+'NED'>",
    "');document.title='PW'+'NED';//\u2028\u2029",
]


def _hostile_names_project(folder):
    """The demo project with its skeleton, atlas, animations, a skin and an event named by
    :data:`PAYLOADS`."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(folder)
    (project / "demo-binary.skel").unlink()
    doc = json.loads((project / "demo.json").read_text())
    wave = doc["animations"].pop("wave")
    doc["events"] = {PAYLOADS[1]: {"string": PAYLOADS[0]}}
    for name in PAYLOADS:
        doc["animations"][name] = {**copy.deepcopy(wave), "events": [{"time": 0.1, "name": PAYLOADS[1]}]}
    doc["skins"].append({"name": PAYLOADS[2], "attachments": copy.deepcopy(doc["skins"][0]["attachments"])})
    (project / "demo.json").unlink()
    (project / f"{PAYLOADS[1][:40]}.json").write_text(json.dumps(doc))
    return project


def test_names_holding_html_and_script_run_nothing_in_the_preview(tmp_path):
    from browser import player_result, run

    project = _hostile_names_project(tmp_path / "p")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--preview", "v", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "v"], codes=(0,))
    pages = [tmp_path / "v" / "index.html", *sorted((tmp_path / "v" / "s").glob("*.html"))]
    assert len(pages) == 2
    for page in pages:
        dom = run(page.resolve().as_uri(), tmp_path / "chromium", "--dump-dom").stdout
        assert "PWNED" not in dom and "<title>" in dom
    # the player offers every name as it is, and plays the one chosen
    got = player_result(pages[1].resolve().as_uri() + "#play=2&test=1", tmp_path / "chromium", budget_ms=6000)
    assert got["anim"] == PAYLOADS[1]
    for path in (tmp_path / "v").rglob("*"):
        if path.is_file() and path.suffix in (".html", ".js"):
            assert "PWNED" not in path.read_text(encoding="utf-8")
    assert project.is_dir()


def test_atlas_names_holding_html_run_nothing_in_the_pack_preview(tmp_path):
    from browser import run

    _hostile_names_project(tmp_path / "p")
    r = run_cli("upgrade", "p", "--out", "m", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for f in ("demo.atlas", "demo.png"):
        (tmp_path / "m" / f).rename(tmp_path / "m" / f.replace("demo", PAYLOADS[2][:20]))
    atlas = tmp_path / "m" / f"{PAYLOADS[2][:20]}.atlas"
    atlas.write_text(atlas.read_text().replace("demo.png", f"{PAYLOADS[2][:20]}.png"))
    before = snapshot(tmp_path)
    r = run_cli("pack", "m", "--out", "k", "--preview", "kv", cwd=tmp_path)
    check_run(r, before, tmp_path, ["k", "kv"], codes=(0,))
    dom = run((tmp_path / "kv" / "index.html").resolve().as_uri(), tmp_path / "chromium", "--dump-dom").stdout
    assert "PWNED" not in dom and "spinemesh pack" in dom


def test_a_skeleton_of_thousands_of_animations_gets_a_light_preview(tmp_path):
    """A skeleton file can list millions of empty animations (20,000 took 18 s and 81 MB of
    preview in 20,003 files): the player shows the first MAX_ANIMATIONS and says so."""
    from spinemesh.demo import make_demo_project
    from spinemesh.player.frames import MAX_ANIMATIONS

    project = make_demo_project(tmp_path / "p")
    (project / "demo-binary.skel").unlink()
    doc = json.loads((project / "demo.json").read_text())
    doc["animations"].update({f"a{i}": {} for i in range(MAX_ANIMATIONS + 500)})
    (project / "demo.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--preview", "v", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "v"], codes=(0,))
    scripts = list((tmp_path / "v" / "data").rglob("*.js"))
    assert len(scripts) == MAX_ANIMATIONS + 2                  # the setup pose, the first 1,000 animations, model.js
    page = next((tmp_path / "v" / "s").glob("*.html")).read_text(encoding="utf-8")
    assert "501 animations not shown: the player shows the first 1,000" in page
    assert sum(p.stat().st_size for p in scripts) < 8 * 1024**2


# --- pack: are pages ever written lossy, or with other texels? -----------------------------------

def _pillow_rgba(path):
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGBA"))


def _upright(page: np.ndarray, g) -> np.ndarray:
    """A region's texels upright at its original size, cut by hand from the atlas's numbers
    (not by spinemesh.images, which the packer uses)."""
    crop = page[g.y:g.y + g.page_height, g.x:g.x + g.page_width]
    if g.degrees:
        crop = np.rot90(crop, -(g.degrees // 90))
    out = np.zeros((g.original_height, g.original_width, 4), np.uint8)
    top = g.original_height - g.offset_y - g.height
    out[top:top + g.height, g.offset_x:g.offset_x + g.width] = crop
    return out


def _drawn_masks(skeleton, regions) -> dict:
    """Per region drawn by meshes, the texels (upright, original size) whose centres lie at least
    a texel inside one of its meshes' triangles: what drawing it samples, for sure."""
    import cv2

    from spinemesh.skeleton import iter_skins

    out = {}
    for _, slots in iter_skins(load_skeleton(skeleton)):
        for atts in slots.values():
            for key, a in atts.items():
                if a.get("type") != "mesh":
                    continue
                path = a.get("path") or key
                names = [r.name for r in regions if r.name == path or (
                    a.get("sequence") and r.name.startswith(path) and r.name[len(path):].isdigit())]
                uv = np.asarray(a["uvs"], float).reshape(-1, 2)
                for name in names:
                    g = next(r for r in regions if r.name == name).geometry()
                    mask = out.setdefault(name, np.zeros((g.original_height, g.original_width), np.uint8))
                    pts = np.round(uv * (g.original_width, g.original_height) * 16).astype(np.int32)
                    for tri in np.asarray(a["triangles"]).reshape(-1, 3):
                        cv2.fillPoly(mask, [pts[tri]], 1, shift=4)
    return {k: cv2.erode(m, np.ones((3, 3), np.uint8)).astype(bool) for k, m in out.items()}


def _same_texels_drawn(project, out) -> int:
    """Compare every region of the atlas written in ``out`` with ``project``'s, by Pillow's
    decoding of both pages: inside its meshes for a region meshes draw, its whole rectangle
    for any other. Returns the texels compared."""
    from spinemesh.atlas import read_atlas

    before, after = read_atlas(project / "demo.atlas"), read_atlas(out / "demo.atlas")
    pages_before = [_pillow_rgba(project / p.name) for p in before.pages]
    pages_after = [_pillow_rgba(out / p.name) for p in after.pages]
    masks = _drawn_masks(project / "demo.json", before.regions)
    assert [r.name for r in after.regions] == [r.name for r in before.regions]
    compared = 0
    for r, was in zip(after.regions, before.regions):
        o = _upright(pages_after[r.page], r.geometry())
        s = _upright(pages_before[was.page], was.geometry())
        assert o.shape == s.shape, r.name
        inside = masks.get(r.name, np.ones(s.shape[:2], bool))
        if inside.shape != s.shape[:2]:  # a name twice, of two sizes: the whole rectangle
            inside = np.ones(s.shape[:2], bool)
        differ = (o != s).any(axis=2) & inside
        assert not differ.any(), f"{r.name}: {int(differ.sum())} texels drawn differ"
        compared += int(inside.sum())
    return compared


def _page_as(meshed, dest, how):
    """A copy of the meshed demo whose page is stored ``how``; returns the project."""
    import shutil

    import cv2
    from PIL import Image

    shutil.copytree(meshed, dest, ignore=shutil.ignore_patterns(".*"))
    page = dest / "demo.png"
    im = Image.open(page).convert("RGBA")
    name = {"webp lossless": "demo.webp", "webp lossy": "demo.webp", "jpeg": "demo.jpg"}.get(how, "demo.png")
    if how == "16-bit":
        wide = np.asarray(im).astype(np.uint16) * 257
        noise = np.random.default_rng(1).integers(0, 200, wide.shape).astype(np.uint16)
        wide = np.where(wide[..., 3:4] > 0, np.minimum(wide + noise, 65535), wide).astype(np.uint16)
        cv2.imwrite(str(page), cv2.cvtColor(wide, cv2.COLOR_RGBA2BGRA))
    elif how == "palette with tRNS":
        im.quantize(64, method=Image.Quantize.FASTOCTREE).save(page)
    elif how == "grey and alpha":
        im.convert("LA").save(page)
    elif how == "RGB":
        im.convert("RGB").save(page)
    elif how.startswith("webp"):
        im.save(dest / name, "WEBP", **({"lossless": True} if how == "webp lossless" else {"quality": 80}))
    elif how == "jpeg":
        im.convert("RGB").save(dest / name, "JPEG", quality=90)
    if name != "demo.png":
        page.unlink()
        (dest / "demo.atlas").write_text((dest / "demo.atlas").read_text().replace("demo.png", name))
    return dest, name


#: How each page format must come out of ``pack --larger-files``: packed with the very texels drawn
#: (a lossy WebP page written losslessly: the texels it decodes to), or kept byte for byte (16 bits a
#: channel once came out packed at 8, its low bits gone, exit 0).
PAGE_FORMATS = {"8-bit RGBA": "packed", "palette with tRNS": "packed", "grey and alpha": "packed",
                "RGB": "packed", "webp lossless": "packed", "16-bit": "kept", "webp lossy": "packed", "jpeg": "kept"}


@pytest.mark.parametrize("how", sorted(PAGE_FORMATS))
def test_packed_pages_draw_the_original_texels_in_every_page_format(meshed, tmp_path, how):
    from spinemesh.pack.run import PackOptions, pack_project

    project, name = _page_as(meshed, tmp_path / "p", how)
    result = pack_project(project, tmp_path / "out", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == PAGE_FORMATS[how], row.reason
    if row.status == "kept":
        assert (tmp_path / "out" / name).read_bytes() == (project / name).read_bytes(), row.reason
        assert (tmp_path / "out" / "demo.atlas").read_bytes() == (project / "demo.atlas").read_bytes()
    assert _same_texels_drawn(project, tmp_path / "out") > 20_000


_HEAD = "demo-head\n\tbounds: 105, 2, 81, 81\n\toffsets: 5, 4, 90, 90\n"

#: Atlases a hand or an old exporter writes: (what the atlas becomes, packed or kept).
ATLAS_CASES = {
    "a region name on two pages": (lambda a: a + "\ndemo2.png\n\tsize: 512, 256\n\tfilter: Linear, Linear\n" + _HEAD,
                                   "packed"),
    "one name twice with index fields": (lambda a: a.replace(_HEAD, _HEAD + "\tindex: 0\n" + _HEAD + "\tindex: 1\n"),
                                         "packed"),
    "an index field": (lambda a: a.replace("demo-body\n", "demo-body\n\tindex: 7\n"), "packed"),
    "rotate: 270": (lambda a: a.replace("demo-ring\n", "demo-ring\n\trotate: 270\n"), "packed"),
    "rotate: 180": (lambda a: a.replace("demo-ring\n", "demo-ring\n\trotate: 180\n"), "packed"),
    "rotated, odd sides": (lambda a: a.replace("demo-blobs\n", "demo-blobs\n\trotate: true\n"), "packed"),
    "a region past its page's edge": (lambda a: a.replace("bounds: 105, 2, 81, 81", "bounds: 500, 2, 81, 81"), "kept"),
    "a region at x = -5": (lambda a: a.replace("bounds: 105, 2, 81, 81", "bounds: -5, 2, 81, 81"), "kept"),
    "a region of no size": (lambda a: a.replace("bounds: 105, 2, 81, 81", "bounds: 105, 2, 0, 0"), "kept"),
    "an original size of 16000": (lambda a: a.replace("offsets: 5, 4, 90, 90", "offsets: 5, 4, 16000, 16000"), "kept"),
}


@pytest.mark.parametrize("case", sorted(ATLAS_CASES))
def test_hand_made_atlases_pack_to_the_same_texels_or_are_kept(meshed, tmp_path, case):
    import shutil

    change, expected = ATLAS_CASES[case]
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    shutil.copy(project / "demo.png", project / "demo2.png")
    atlas = project / "demo.atlas"
    text = atlas.read_text()
    assert _HEAD in text
    atlas.write_text(change(text))
    before = snapshot(tmp_path)
    r = run_cli("pack", "p", "--out", "o", "--report", "r.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "r.json"])
    (row,) = json.loads((tmp_path / "r.json").read_text())["atlases"]
    assert row["status"] == expected, row["reason"]
    if expected == "packed":
        assert _same_texels_drawn(project, tmp_path / "o") > 20_000
    else:   # kept: the atlas as it was, its page perhaps re-encoded, to the very texels
        assert (tmp_path / "o" / "demo.atlas").read_bytes() == atlas.read_bytes()
        np.testing.assert_array_equal(_pillow_rgba(tmp_path / "o" / "demo.png"), _pillow_rgba(project / "demo.png"))


# --- Spine 3.5 binaries ---------------------------------------------------------------------

def _read_or_refuse(data: bytes, name: str = "x.skel"):
    """The document, or None where the reader refused it with a SkelFormatError naming an
    offset inside the data; anything else fails the test."""
    try:
        with within(10):
            return read_skel(data, name)
    except SkelFormatError as e:
        assert e.offset is not None and 0 <= e.offset <= len(data), e
        assert e.path == name
        return None


def _round_trips(doc: dict) -> None:
    """What was read is written and read back as the same document (the bytes may differ only
    where the file was not the writer's own)."""
    try:
        data = encode_skel(doc)
    except SkelFormatError:
        return  # a document the reader let through but no 3.5 file can hold: refused in one line
    assert json.dumps(read_skel(data)) == json.dumps(doc)  # as text: a NaN read equals the NaN written


def test_every_cut_of_a_35_binary_is_refused_at_its_end():
    from test_skeleton_binary_v35 import encode_35

    data = encode_35(True)
    for cut in range(len(data)):
        with pytest.raises(SkelFormatError) as e:
            read_skel(data[:cut], "cut.skel")
        assert e.value.offset is not None and e.value.offset <= cut


def test_huge_counts_and_string_lengths_anywhere_in_a_35_binary():
    """The largest varint (2^32 - 1), and 2^22 + 1 (one over the count limit), spliced over
    every byte in turn: a count or a string length of billions is refused without allocating
    it; whatever still reads writes back to the same document."""
    from test_skeleton_binary_v35 import encode_35

    data = encode_35(True)
    read = 0
    for big in (b"\xff\xff\xff\xff\x0f", b"\x81\x80\x80\x02"):
        for at in range(len(data)):
            doc = _read_or_refuse(data[:at] + big + data[at + 1:])
            if doc is not None:
                read += 1
                _round_trips(doc)
    assert read < len(data)   # most are refused


def test_random_damage_to_a_35_binary_reads_or_is_refused():
    import random

    from test_skel_fuzz import mutate
    from test_skeleton_binary_v35 import encode_35

    rng = random.Random("spinemesh-hostile-3.5")
    seeds = [encode_35(True), encode_35(False)]
    refused = 0
    for _ in range(600):
        _, bad = mutate(rng.choice(seeds), rng)
        doc = _read_or_refuse(bad)
        if doc is None:
            refused += 1
        else:
            _round_trips(doc)
    assert refused > 150


@pytest.mark.parametrize("version", ["3.6.53", "3.7.94", "3.8.99", "4.0.64", "4.1.24", "4.2.43", "3.5.99", "35"])
def test_a_35_binary_claiming_another_version(version, tmp_path):
    """Read by that version's layout: refused with an offset, or a document that converts in
    one line or writes back as the same document; ``convert`` never ends in a traceback."""
    from test_skeleton_binary_v35 import encode_35

    data = encode_35(True).replace(b"\x073.5.51", bytes([len(version) + 1]) + version.encode(), 1)
    doc = _read_or_refuse(data)
    if doc is not None:
        _round_trips(doc)
    (tmp_path / "x.skel").write_bytes(data)
    before = snapshot(tmp_path)
    r = run_cli("convert", "x.skel", "x.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["x.json"])
    assert (r.returncode == 0) == (doc is not None), r.stderr
    if r.returncode == 2:
        assert "x.skel" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_pose_bounds_what_a_long_times_list_costs(tmp_path):
    """10,000 times are allowed, but with physics each replays the game loop from 0 (10,000
    times of 1,666 s once meant 14 hours of a tiny skeleton), and the JSON written (a stream) is
    capped: both are refused up front, in one line; what is within the limits poses as the
    sampler does."""
    project = tmp_path / "p"
    project.mkdir()
    (project / "phys.json").write_text(json.dumps(_physics_doc()))
    many = _doc()
    # 6,000 regions: about 1.9 MB of JSON a pose, 19 GB for 10,000 times
    many["slots"] += [{"name": f"s{i}", "bone": "arm", "attachment": "a"} for i in range(6000)]
    many["skins"][0]["attachments"].update({f"s{i}": {"a": {"width": 10, "height": 4}} for i in range(6000)})
    (project / "many.json").write_text(json.dumps(many))
    long_list = ",".join(f"{i / 100:g}" for i in range(10_000))
    for skeleton, times, words in (("p/phys.json", ",".join(f"{1666 - i}" for i in range(10)), "game-loop steps"),
                                   ("p/many.json", long_list, "MiB of JSON")):
        before = snapshot(tmp_path)
        with within(60):
            r = run_cli("pose", skeleton, "-a", "turn", "--times", times, "--out", "o.json", cwd=tmp_path)
        check_run(r, before, tmp_path, [], codes=(2,))
        (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
        assert words in line and skeleton in line, r.stderr
    r = _pose_cli(tmp_path, "p/phys.json", "-a", "turn", "--times", "0.25,0.5")
    assert r.returncode == 0, r.stderr
    written = json.loads((tmp_path / "pose.json").read_text())
    assert written["poses"] == _strict(dump(Sampler(_physics_doc()), "turn", [0.25, 0.5]))["poses"]


def _constrained_doc() -> dict:
    doc = _doc()
    doc["bones"] += [{"name": "b1", "parent": "root", "length": 0}, {"name": "b2", "parent": "b1", "length": 0},
                     {"name": "tgt", "parent": "root"}, {"name": "phys", "parent": "b2"}]
    doc["slots"].append({"name": "path", "bone": "root", "attachment": "p"})
    doc["skins"][0]["attachments"]["path"] = {"p": {"type": "path", "closed": False, "constantSpeed": True,
                                                     "lengths": [0, 0], "vertexCount": 6, "vertices": [0] * 12}}
    return doc


#: Constraints at the extremes the document's check lets through (numbers up to 1e9 in size).
CONSTRAINT_CASES = {
    "IK of bones of no length, the target on them": {"ik": [{"name": "i", "bones": ["b1", "b2"], "target": "tgt",
                                                             "stretch": True, "compress": True, "uniform": True}]},
    "IK mix and softness 1e9": {"ik": [{"name": "i", "bones": ["b1", "b2"], "target": "tgt", "mix": 1e9,
                                        "softness": 1e9, "stretch": True}]},
    "IK mix -1e9": {"ik": [{"name": "i", "bones": ["b1"], "target": "tgt", "mix": -1e9}]},
    "transform mixes and offsets of 1e9": {"transform": [{
        "name": "t", "bones": ["b1"], "target": "tgt", "mixRotate": 1e9, "mixX": -1e9, "mixScaleX": 1e9,
        "mixShearY": 1e9, "rotation": 1e9, "scaleX": 1e9, "x": 1e9}]},
    "local relative transform, scale -1e9": {"transform": [{
        "name": "t", "bones": ["b1"], "target": "tgt", "local": True, "relative": True, "mixRotate": 1e9,
        "mixScaleX": 1e9, "scaleX": -1e9}]},
    "path of no length, percent spacing 1e9": {"path": [{
        "name": "pa", "bones": ["b1", "b2"], "target": "path", "spacingMode": "percent", "rotateMode": "chainScale",
        "position": 1e9, "spacing": 1e9, "mixRotate": 1e9}]},
    "proportional path at -1e9": {"path": [{"name": "pa", "bones": ["b1", "b2"], "target": "path",
                                            "spacingMode": "proportional", "rotateMode": "chain",
                                            "positionMode": "percent", "position": -1e9}]},
    "physics of zeros": {"physics": [{"name": "ph", "bone": "phys", "x": 1, "y": 1, "rotate": 1, "scaleX": 1,
                                      "shearX": 1, "mass": 0, "strength": 0, "damping": 0, "inertia": 0,
                                      "limit": 0, "fps": 0}]},
    # an fps of 1e9 made each 1/60 s frame 16 million steps: a pose never ended
    "physics of 1e9, fps 1e9": {"physics": [{"name": "ph", "bone": "phys", "x": 1, "y": 1, "rotate": 1,
                                             "scaleX": 1, "shearX": 1, "mass": 1e9, "strength": 1e9,
                                             "damping": 1e9, "inertia": 1e9, "limit": 1e9, "gravity": 1e9,
                                             "wind": -1e9, "mix": 1e9, "fps": 1e9}]},
    "physics fps 1e-9, mass 1e-9": {"physics": [{"name": "ph", "bone": "phys", "x": 1, "fps": 1e-9, "mass": 1e-9}]},
}


@pytest.mark.parametrize("case", sorted(CONSTRAINT_CASES))
def test_constraints_at_the_extremes_pose_finite_in_bounded_time(case):
    from spinemesh.skeleton_check import check_document

    doc = _constrained_doc()
    doc.update(copy.deepcopy(CONSTRAINT_CASES[case]))
    check_document(doc, "x.json")   # what the loader lets through
    with within(20):
        out = _strict(dump(Sampler(doc), "turn", [0.0, 0.3, 1.0, 2.5]))
    if "fps 1e9" in case:
        assert "phys" in out["poses"][-1]["inexact"]   # not stepped: said, not silently wrong


def test_the_player_writes_a_skeleton_scaled_to_1e308(tmp_path):
    """Bones scaled by 1e38 each (float32 keys hold it), eight deep: the vertices, finite, lie at
    about ±1e308, so the box around them once spanned infinity and the player's script could not
    be written (a traceback from ``upgrade --preview``)."""
    from spinemesh.player.files import PreviewFolder
    from spinemesh.player.frames import animations
    from spinemesh.player.page import write_player

    doc = {"skeleton": {"spine": "4.2.00"},
           "bones": [{"name": "b0"}] + [{"name": f"b{i}", "parent": f"b{i - 1}"} for i in range(1, 9)],
           "slots": [{"name": "s", "bone": "b8", "attachment": "a"}],
           "skins": [{"name": "default", "attachments": {"s": {"a": {"width": 20000, "height": 10}}}}],
           "animations": {"blow": {"bones": {f"b{i}": {"scale": [{"x": 1e38, "y": 1}]} for i in range(1, 9)}}}}
    problems: list[str] = []
    shown = animations(doc, doc, problems=problems)
    xs = np.concatenate([d.world[:, 0] for d in shown[1].by_skin["default"][0][0]])
    assert np.isfinite(xs).all() and float(xs.max()) - float(xs.min()) == math.inf  # a span beyond float range
    html = write_player(PreviewFolder(tmp_path), "blow", "s/blow.html", shown, lambda path: None)
    assert "player-blow" in html and not problems
    _scripts_are_strict_json(tmp_path)


def test_the_player_shows_every_hostile_animation_and_extreme_constraint(tmp_path):
    """What ``pose`` survives, the player survives too: every animation and constraint case above
    sampled for the page and written, nothing that is not a number in its scripts. The one case
    no runtime plays as written (a 3.8 curve in a 4.2 file) is said on the page, as ``pose`` says it."""
    from spinemesh.player.files import PreviewFolder
    from spinemesh.player.frames import animations
    from spinemesh.player.page import write_player

    docs = [_hostile_doc()]
    for extra in CONSTRAINT_CASES.values():
        docs.append(_constrained_doc())
        docs[-1].update(copy.deepcopy(extra))
    with within(60):
        for i, doc in enumerate(docs):
            problems: list[str] = []
            shown = animations(doc, doc, problems=problems)
            assert len(shown) == 1 + len(doc["animations"])
            said = ["a 3.8 curve in a 4.2 file"] if "a 3.8 curve in a 4.2 file" in doc["animations"] else []
            assert [line.split("'")[1] for line in problems] == said, problems
            write_player(PreviewFolder(tmp_path / str(i)), "x", "s/x.html", shown, lambda path: None)
    _scripts_are_strict_json(tmp_path)


def _scripts_are_strict_json(folder) -> None:
    """Every data script of a player (``SM.model(id, {...});``, ``SM.frames(key, {...});``)
    passes a JSON object that a strict parser reads: no NaN, no Infinity."""
    import re

    scripts = [p for p in folder.rglob("*.js") if p.name != "player.js"]
    assert scripts
    for script in scripts:
        found = re.fullmatch(r'SM\.(?:model|frames)\(("(?:[^"\\]|\\.)*"),(.*)\);\s*', script.read_text(), re.DOTALL)
        assert found, script
        json.loads(found.group(2), parse_constant=lambda name, where=script: pytest.fail(f"{where} holds {name}"))


@pytest.mark.parametrize("args,code", [
    (("--max-page", "0"), 2), (("--max-page", "-5"), 2), (("--max-page", "99999"), 2), (("--max-page", "abc"), 2),
    (("--pages", "7"), 2), (("--padding", "-1"), 2), (("--jobs", "0"), 2),
    (("--max-page", "16"), 0), (("--pages", "power-of-two", "--max-page", "17"), 0),
    (("--pages", "multiple-of-4", "--max-page", "16384"), 0), (("--padding", "64", "--max-page", "64"), 0),
])
def test_pack_option_extremes(meshed, tmp_path, args, code):
    """Values out of range are refused before anything is written; a page too small for a
    region keeps the atlas; what is packed draws the original texels."""
    import shutil

    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    before = snapshot(tmp_path)
    r = run_cli("pack", "p", "--out", "o", *args, cwd=tmp_path)
    check_run(r, before, tmp_path, ["o"], codes=(code,))
    if code == 2:
        assert not (tmp_path / "o").exists()
    else:
        _same_texels_drawn(project, tmp_path / "o")


def test_a_deform_of_many_empty_keys_on_a_large_mesh_costs_what_it_draws(tmp_path):
    """100,000 empty deform keys (``{}``, 1.5 MB of JSON) on a mesh of 2,500 vertices: every
    key's vertices were made up front, 4 GB (over this run's 3 GB limit); now each key is made
    when a pose needs it."""
    n = 2500
    doc = _doc()
    doc["skins"][0]["attachments"]["m"]["mesh"] = {"type": "mesh", "uvs": [0.5] * (2 * n), "triangles": [0, 1, 2],
                                                   "vertices": [float(i % 97) for i in range(2 * n)], "hull": 3}
    doc["animations"]["fat"] = {"attachments": {"default": {"m": {"mesh": {"deform": [
        {"time": 0, "offset": 2, "vertices": [7, 7]}] + [{"time": i * 1e-3} for i in range(1, 100_001)]}}}}}
    poses = _posed(tmp_path, doc, "fat", "0,50")
    first, later = (next(a for a in p["attachments"] if a["slot"] == "m") for p in poses[1:])
    assert first["vertices"][:4] == [0, 1, 9, 10]   # the first key: 7 added to the second vertex's x, y
    assert later["vertices"][:4] == [0, 1, 2, 3]


def test_a_draw_order_of_many_keys_on_many_slots_costs_what_it_draws(tmp_path):
    """300,000 draw order keys of ``"offsets": []`` (5 MB of JSON) on 500 slots: every key's
    order was made up front, 150 million slot indices (3.6 GB, over this run's 3 GB limit)."""
    doc = _doc()
    doc["slots"] += [{"name": f"z{i}", "bone": "root"} for i in range(500)]
    doc["animations"]["busy"] = {"drawOrder": [{"time": 0, "offsets": [{"slot": "s", "offset": 2}]}] + [
        {"time": i * 1e-4, "offsets": []} for i in range(1, 300_000)]}
    poses = _posed(tmp_path, doc, "busy", "0,20")
    assert [a["slot"] for a in poses[1]["attachments"]] == ["m", "w", "s"]   # the first key: s moved after w
    assert [a["slot"] for a in poses[2]["attachments"]] == ["s", "m", "w"]


def test_the_game_loop_sum_is_the_loops_own_rounding():
    """The track time and the clock are summed at C speed (10,000 times of 1,666 s took 67 s of
    Python additions, now 28 s in all) with the very rounding of one addition after another."""
    import random

    from spinemesh.anim.pose import summed
    from spinemesh.limits import MAX_POSE_STEPS

    rng = random.Random(7)
    for _ in range(500):
        start, step, count = rng.choice([0.0, rng.random() * 100]), rng.random() / rng.choice([1, 7, 60]), \
            rng.randrange(0, 3000)
        looped = start
        for _ in range(count):
            looped += step
        assert summed(start, step, count) == looped
    with within(5):
        assert summed(0.0, 1 / 60, 6 * 10**31) == pytest.approx(1e30)   # beyond the limit: the product
    assert summed(1.0, 0.5, MAX_POSE_STEPS + 1) == 1.0 + 0.5 * (MAX_POSE_STEPS + 1)


@pytest.mark.parametrize("wide", [False, True])
def test_repack_never_writes_frames_of_a_16_bit_page_at_8_bits(tmp_path, wide):
    """``upgrade --repack`` stores differently trimmed sequence frames whole on a new page,
    written at 8 bits a channel: frames of a 16-bit page once lost their low bits there (exit
    0); such a sequence now stays a region, with the reason."""
    import cv2

    from spinemesh.demo import demo_images, make_demo_project, pack_atlas

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    text, page = pack_atlas(demo_images(), "demo.png", rotate={"demo-arm"})   # the spark's frames trimmed
    (project / "demo.atlas").write_text(text)
    if wide:
        deep = page.astype(np.uint16) * 257
        noise = np.random.default_rng(3).integers(0, 200, deep.shape).astype(np.uint16)
        deep = np.where(deep[..., 3:4] > 0, np.minimum(deep + noise, 65535), deep).astype(np.uint16)
        cv2.imwrite(str(project / "demo.png"), cv2.cvtColor(deep, cv2.COLOR_RGBA2BGRA))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--repack", "--min-saving", "0", "--report", "r.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "r.json"], codes=(0,))
    new_pages = sorted(p.name for p in (tmp_path / "o").glob("*untrimmed*"))
    report = (tmp_path / "r.json").read_text()
    if wide:
        assert not new_pages and "'demo.png' has 16 bits a channel" in report
        assert (tmp_path / "o" / "demo.atlas").read_text() == text
    else:
        assert new_pages == ["demo-untrimmed-1.png"]


@pytest.mark.parametrize("args", [
    ("pose", "p/demo.json", "-a", "wave", "--out", "F"), ("upgrade", "p", "--out", "o", "--report", "F"),
    ("pack", "p", "--out", "o", "--report", "F"), ("convert", "p/demo.json", "F"),
    ("mesh", "p/images/demo-head.png", "--out", "F"), ("weights", "p", "--out", "o", "--report", "F"),
])
def test_an_output_that_is_a_fifo_or_device_is_refused_not_replaced(tmp_path, args):
    """Outputs are written whole and renamed into place: ``pose --out /dev/null`` run as root
    replaced /dev/null itself with a regular file. A FIFO stands for the device here."""
    import os
    import stat

    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p")
    os.mkfifo(tmp_path / "F")
    before = snapshot(tmp_path)
    r = run_cli(*args, cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "F: " in r.stderr and "a FIFO, not a regular file" in r.stderr, r.stderr
    assert stat.S_ISFIFO(os.lstat(tmp_path / "F").st_mode)
