"""The preview player draws a slot's dark colour (two-colour tint) as the runtimes' shader does.

spine-webgl's two-colour fragment shader, straight alpha: ``rgb = dark + texel.rgb * (light -
dark)``, ``alpha = texel.a * light.a``. A project made here (three flat patches of colour, one
half transparent, on one region) keys the slot's light and dark colours over time; the player's
canvases, read back from headless Chromium at two times, must match the formula within 2/255 on
both sides (1.1/255 at most when written; without the dark colour drawn, 178/255 off). The
browser check needs Chromium: skipped when it is absent, a failure in CI (``CI=true``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from spinemesh.demo import pack_atlas
from spinemesh.files.atomic import atomic_write_png, atomic_write_text
from spinemesh.player.frames import tint_number
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.preview import write_preview

#: The three patches, left to right, each 20 x 20 texels (RGBA 0..255).
PATCHES = [(200, 120, 40, 255), (40, 200, 160, 255), (240, 240, 240, 128)]
#: The animation's two keys, at 0 and 1 s: (light RGBA, dark RGB), linear between.
KEYS = [("ffc080ff", "000000"), ("80ffffff", "ff2040")]
#: The world frame the player draws (x, y, width, height, pixels per unit): the patches' centres
#: at (-20, 0), (0, 0), (20, 0) fall on canvas pixels (80, 80), (160, 80), (240, 80).
VIEW = (-40, -20, 80, 40, 4)


def _hex(text: str) -> np.ndarray:
    return np.array([int(text[i:i + 2], 16) / 255 for i in range(0, len(text), 2)])


def make_tinted_project(folder: Path) -> Path:
    """A 4.2 project: one region of three flat patches, its slot's light and dark colours keyed."""
    image = np.zeros((20, 60, 4), np.uint8)
    for i, rgba in enumerate(PATCHES):
        image[:, 20 * i:20 * (i + 1)] = rgba
    atlas, page = pack_atlas({"patches": image}, "tint.png")
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write_text(folder / "tint.atlas", atlas)
    atomic_write_png(folder / "tint.png", page)
    doc = {
        "skeleton": {"hash": "dGludA", "spine": "4.2.40", "x": -30, "y": -10, "width": 60, "height": 20},
        "bones": [{"name": "root"}],
        "slots": [{"name": "patch", "bone": "root", "attachment": "patches", "dark": "000000"}],
        "skins": [{"name": "default", "attachments": {"patch": {"patches": {"width": 60, "height": 20}}}}],
        "animations": {"glow": {"slots": {"patch": {"rgba2": [
            {"time": t, "light": light, "dark": dark} for t, (light, dark) in enumerate(KEYS)]}}}},
    }
    atomic_write_text(folder / "tint.json", json.dumps(doc))
    return folder


def expected(t: float) -> np.ndarray:
    """(3, 4) RGBA 0..255 of each patch at ``t`` s: the shader's formula on the keyed colours."""
    light = _hex(KEYS[0][0]) + (_hex(KEYS[1][0]) - _hex(KEYS[0][0])) * t
    dark = _hex(KEYS[0][1]) + (_hex(KEYS[1][1]) - _hex(KEYS[0][1])) * t
    out = []
    for rgba in PATCHES:
        texel = np.array(rgba, float) / 255
        out.append(np.append(dark + texel[:3] * (light[:3] - dark), texel[3] * light[3]) * 255)
    return np.array(out)


def test_the_player_draws_the_dark_colour_as_the_two_colour_shader(tmp_path):
    from browser import canvases, player_result

    project = make_tinted_project(tmp_path / "in")
    result = upgrade_project(project, tmp_path / "out", Options())
    index = write_preview(result, project, tmp_path / "out", tmp_path / "preview")
    data = (index.parent / "data" / "tint" / "1.0.js").read_text(encoding="utf-8")
    assert str(tint_number(_hex(KEYS[0][0])[:3], _hex(KEYS[0][1]))) in data  # frame 0: a black dark colour
    url = (index.parent / "s" / "tint.html").resolve().as_uri()
    view = ",".join(map(str, VIEW))
    for t in (0.5, 0.9):  # frames 15 and 27 at 30 a second
        want = expected(t)
        for side, rgba in zip(("original", "upgraded"), canvases(player_result(url + f"#at=1,{t},{view}",
                                                                                  tmp_path / f"t{t}"))):
            assert rgba.shape[:2] == (160, 320), rgba.shape
            for k, x in enumerate((80, 160, 240)):
                got = np.median(rgba[76:85, x - 4:x + 5].reshape(-1, 4).astype(float), axis=0)
                assert np.abs(got - want[k]).max() <= 2, (t, side, k, got, want[k].round(1))


def test_more_tints_than_the_players_cache_holds_are_drawn(tmp_path):
    """320 slots over each other, each drawing the patches in a colour of its own (the first 310 a
    light colour alone, the last 10 a dark colour too): the page's tint cache (300 images) is
    emptied while the frame is drawn, before any two-colour tint exists and after; no page
    error, and the slot on top is drawn as the shader draws it."""
    from browser import canvases, player_result

    project = make_tinted_project(tmp_path / "in")
    doc = json.loads((project / "tint.json").read_text(encoding="utf-8"))
    slot, att = doc["slots"][0], doc["skins"][0]["attachments"]["patch"]
    doc["slots"], doc["skins"][0]["attachments"] = [], {}
    colours = []
    for i in range(320):
        light, dark = f"{i % 256:02x}{64 * (i // 256):02x}80ff", f"{(3 * i) % 256:02x}2040"  # 320 colours
        entry = {**slot, "name": f"s{i}", "color": light}
        if i >= 310:
            entry["dark"] = dark
        else:
            del entry["dark"]
        doc["slots"].append(entry)
        doc["skins"][0]["attachments"][f"s{i}"] = att
        colours.append((light, dark if i >= 310 else None))
    doc["animations"] = {}
    (project / "tint.json").write_text(json.dumps(doc), encoding="utf-8")
    result = upgrade_project(project, tmp_path / "out", Options())
    index = write_preview(result, project, tmp_path / "out", tmp_path / "preview")
    url = (index.parent / "s" / "tint.html").resolve().as_uri() + "#at=0,0," + ",".join(map(str, VIEW))
    light, dark = (_hex(c) for c in colours[-1])
    for rgba in canvases(player_result(url, tmp_path / "page")):
        for k, x in enumerate((80, 160)):  # the opaque patches: the slot on top alone shows
            want = (dark + np.array(PATCHES[k][:3]) / 255 * (light[:3] - dark)) * 255
            got = np.median(rgba[76:85, x - 4:x + 5, :3].reshape(-1, 3).astype(float), axis=0)
            assert np.abs(got - want).max() <= 2, (k, got, want.round(1))


def test_a_light_colour_alone_keeps_half_transparent_texels_exact(tmp_path):
    """A slot with a light colour and no dark colour: the half-transparent patch is its texel times
    the light colour, alpha kept (compositing a multiply under the image's alpha drew it up to
    8/255 towards the light colour)."""
    from browser import canvases, player_result

    project = make_tinted_project(tmp_path / "in")
    doc = json.loads((project / "tint.json").read_text(encoding="utf-8"))
    del doc["slots"][0]["dark"]
    doc["slots"][0]["color"], doc["animations"] = KEYS[0][0], {}
    (project / "tint.json").write_text(json.dumps(doc), encoding="utf-8")
    result = upgrade_project(project, tmp_path / "out", Options())
    index = write_preview(result, project, tmp_path / "out", tmp_path / "preview")
    url = (index.parent / "s" / "tint.html").resolve().as_uri() + "#at=0,0," + ",".join(map(str, VIEW))
    light = _hex(KEYS[0][0])
    for rgba in canvases(player_result(url, tmp_path / "page")):
        for k, x in enumerate((80, 160, 240)):
            texel = np.array(PATCHES[k], float) / 255
            want = np.append(texel[:3] * light[:3], texel[3]) * 255
            got = np.median(rgba[76:85, x - 4:x + 5].reshape(-1, 4).astype(float), axis=0)
            assert np.abs(got - want).max() <= 2, (k, got, want.round(1))


def test_colours_overshooting_by_a_bezier_are_clamped_only_as_drawn(tmp_path):
    """4.0 to 4.2 keep a Bezier curve's overshoot of 0..1 in the light and dark colours an ``rgb2``
    timeline sets and in the alpha an ``alpha`` timeline sets, and their shader clamps only the
    colour it draws, ``dark + texel * (light - dark)`` and ``texel alpha * alpha``. Here the light
    colour and the alpha rise past 1 and the dark colour falls below 0 half way: the player draws
    the formula on those values (clamping them first drew 40/255 off, the half-transparent patch's
    alpha 70/255)."""
    from browser import canvases, player_result

    from spinemesh.anim import Sampler

    project = make_tinted_project(tmp_path / "in")
    doc = json.loads((project / "tint.json").read_text(encoding="utf-8"))
    up, down = [0.8, 0.9, 1.1], [-1.0, -0.8, -1.2]  # each channel's control points past its value
    curve = [c for lift in up + down for c in (0.25, 0.5 + lift, 0.75, 0.5 + lift)]
    doc["animations"] = {"glow": {"slots": {"patch": {"rgb2": [
        {"time": 0, "light": "808080", "dark": "808080", "curve": curve},
        {"time": 1, "light": "808080", "dark": "808080"}], "alpha": [
        {"time": 0, "value": 0.8, "curve": [0.25, 1.8, 0.75, 1.8]}, {"time": 1, "value": 0.8}]}}}}
    (project / "tint.json").write_text(json.dumps(doc), encoding="utf-8")
    slot = Sampler(doc).pose("glow", 0.5).slots[0]
    light, dark = np.asarray(slot.color, float), np.asarray(slot.dark, float)
    assert (light > 1.05).all() and (dark < -0.05).all(), (light, dark)  # the sampler keeps the overshoot
    result = upgrade_project(project, tmp_path / "out", Options())
    index = write_preview(result, project, tmp_path / "out", tmp_path / "preview")
    url = (index.parent / "s" / "tint.html").resolve().as_uri() + "#at=1,0.5," + ",".join(map(str, VIEW))
    clamped_off = 0.0
    for rgba in canvases(player_result(url, tmp_path / "page")):
        for k, x in enumerate((80, 160, 240)):
            texel = np.array(PATCHES[k], float) / 255
            want = np.clip(np.append(dark + texel[:3] * (light[:3] - dark), texel[3] * light[3]), 0, 1) * 255
            got = np.median(rgba[76:85, x - 4:x + 5].reshape(-1, 4).astype(float), axis=0)
            assert np.abs(got - want).max() <= 2, (k, got, want.round(1))
            lit, dim = np.clip(light, 0, 1), np.clip(dark, 0, 1)
            first = np.append(dim + texel[:3] * (lit[:3] - dim), texel[3] * lit[3])
            clamped_off = max(clamped_off, np.abs(first * 255 - want).max())
    assert clamped_off > 10, clamped_off  # clamping the colours first draws visibly otherwise
