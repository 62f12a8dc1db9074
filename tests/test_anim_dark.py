"""Two-colour tint ("tint black"): each drawn slot's dark colour, sampled as the official runtime holds it.

The harness's dump does not write the dark colour, so ``tests/dark_colors.mjs`` reads
``Slot.darkColor`` from the runtime the harness loads (the same project, played the same way),
at the times our sampler is asked for. Skeletons of the examples and of the corpus that key dark
colours (``rgba2``/``rgb2``, 3.8's ``twoColor``; Bezier, stepped and linear keys) in 3.8 to 4.2.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from runtime_tool import node

from spinemesh.anim import Sampler, atlas_regions
from spinemesh.anim.dump import dump
from spinemesh.atlas import read_atlas
from spinemesh.skeleton import load_skeleton

#: (data set, skeleton, atlas): skeletons whose animations key dark colours.
CASES = [
    ("examples", "3.8/tank/tank-pro.json", "tank.atlas"),         # twoColor, linear and stepped
    ("examples", "4.0/tank/tank-pro.json", "tank.atlas"),
    ("examples", "4.1/tank/tank-pro.skel", "tank.atlas"),         # the binary reader's rgba2
    ("examples", "4.2/tank/tank-pro.json", "tank.atlas"),
    ("corpus", "cm-character/character.json", "character.atlas"),   # 4.1, Bezier curves on the dark part
    ("corpus", "nf-symbols/wild.json", "wild.atlas"),                # 4.2
    ("corpus", "wg-symbols/low_payout_2.json", "low_payout_2.atlas"),  # 4.1
]

#: Times sampled in each animation, as shares of its duration (between keys, not on them).
SHARES = (0.0, 0.13, 0.29, 0.41, 0.57, 0.73, 0.91)


def _keys_dark(anim: dict) -> bool:
    return any(k in ("twoColor", "rgba2", "rgb2") for tls in (anim.get("slots") or {}).values() for k in tls)


def runtime_darks(tool, atlas, skeleton, anim: str, times: list[float]) -> list[dict]:
    """Per pose (setup first), slot name -> its dark colour in the runtime, or None."""
    r = node(tool, Path(__file__).resolve().parent / "dark_colors.mjs", tool, atlas, skeleton, anim,
             ",".join(repr(t) for t in times))
    assert r.returncode == 0, r.stderr[-2000:]
    return [p["dark"] for p in json.loads(r.stdout)["poses"]]


@pytest.mark.parametrize("where, rel, atlas_name", CASES, ids=[c[1] for c in CASES])
def test_dark_colours_are_sampled_as_the_official_runtime_holds_them(where, rel, atlas_name, request,
                                                                     spine_runtime):
    root = request.getfixturevalue(where)
    skeleton = root / rel
    atlas = skeleton.parent / atlas_name
    if not skeleton.is_file():
        pytest.skip(f"{rel} is not in this data set")
    doc = load_skeleton(skeleton)
    keyed = [n for n, a in (doc.get("animations") or {}).items() if _keys_dark(a)]
    if skeleton.suffix == ".skel":  # the binary's animations: keyed where the JSON beside it keys them
        twin = json.loads(skeleton.with_suffix(".json").read_text(encoding="utf-8"))
        keyed = [n for n, a in twin["animations"].items() if _keys_dark(a)]
    assert keyed
    sampler = Sampler(doc, None, atlas_regions(read_atlas(atlas)))
    compared = moved = 0
    for anim in keyed[:3]:
        duration = sampler.duration(anim)
        times = sorted({round(s * duration, 4) for s in SHARES})
        theirs = runtime_darks(spine_runtime, atlas, skeleton, anim, times)
        ours = dump(sampler, anim, times)["poses"]
        assert len(ours) == len(theirs)
        setup = theirs[0]
        for pose, dark in zip(ours, theirs):
            for a in pose["attachments"]:
                want = dark[a["slot"]]
                assert ("dark" in a) == (want is not None), (anim, pose["label"], a["slot"], a.get("dark"), want)
                if want is None:
                    continue
                assert np.allclose(a["dark"], want, atol=2e-3), (anim, pose["label"], a["slot"], a["dark"], want)
                compared += 1
                moved += not np.allclose(want, setup[a["slot"]], atol=2e-3)
    assert compared and moved, (compared, moved)  # dark colours drawn, some keyed away from the setup pose's


def test_a_slot_without_a_dark_colour_has_none_and_its_pose_has_no_dark_field():
    """Only slots whose data has a dark colour carry one (a keyed two-colour timeline on a slot
    without one has nothing to set, as in the runtimes); the others' dump is as before."""
    doc = {
        "skeleton": {"spine": "4.2.22"},
        "bones": [{"name": "root"}],
        "slots": [{"name": "plain", "bone": "root", "attachment": "r"},
                  {"name": "tinted", "bone": "root", "attachment": "r", "dark": "102030"}],
        "skins": [{"name": "default", "attachments": {
            "plain": {"r": {"width": 10, "height": 10}}, "tinted": {"r": {"width": 10, "height": 10}}}}],
        "animations": {"a": {"slots": {
            "plain": {"rgba2": [{"time": 0, "light": "ffffffff", "dark": "ff0000"}]},
            "tinted": {"rgb2": [{"time": 0, "light": "ffffff", "dark": "000000"},
                                {"time": 1, "light": "ffffff", "dark": "ff8000"}]}}}},
    }
    sampler = Sampler(doc)
    setup = {d.slot: d for d in sampler.pose(None).slots}
    assert setup["plain"].dark is None
    assert np.allclose(setup["tinted"].dark, [0x10 / 255, 0x20 / 255, 0x30 / 255])
    half = {d.slot: d for d in sampler.pose("a", 0.5).slots}
    assert half["plain"].dark is None
    assert np.allclose(half["tinted"].dark, [0.5, 0.25098, 0], atol=1e-4)  # linear: halfway to ff8000
    dumped = {a["slot"]: a for a in sampler.pose("a", 0.5).to_dump()["attachments"]}
    assert "dark" not in dumped["plain"] and list(dumped["tinted"]).index("dark") == list(dumped["tinted"]).index("color") + 1


def _dark_slot_doc(version: str, dark: str) -> dict:
    """One slot with the dark colour ``dark`` on a skeleton of ``version`` (3.8 also keys it)."""
    doc = {"skeleton": {"spine": version}, "bones": [{"name": "root"}],
           "slots": [{"name": "s", "bone": "root", "attachment": "r", "dark": dark}],
           "skins": [{"name": "default", "attachments": {"s": {"r": {"width": 10, "height": 10}}}}]}
    if version.startswith("3"):
        doc["skins"] = {"default": doc["skins"][0]["attachments"]}
        doc["animations"] = {"a": {"slots": {"s": {"twoColor": [{"time": 0, "light": "ffffffff", "dark": dark}]}}}}
    return doc


@pytest.mark.parametrize("version", ["3.8.99", "4.2.22"])
def test_a_dark_colour_of_eight_digits_is_written_where_the_runtimes_read_its_rgb(version):
    """The runtimes read a binary dark colour's low 24 bits as rgb (-1: none) and a JSON's
    ``rrggbbaa`` as its first six digits. Our 3.x writer stored ``"12345680"`` as 0x12345680
    (rgb 345680, another colour, silently) and read a high byte back in front
    (``"80123456"``, posed as 801234); both versions wrote ``"ffffffff"`` as -1, a slot with no
    dark colour. Now each is written with its rgb where the runtimes read it, and poses alike
    from the .json and from the .skel."""
    from spinemesh.skeleton_binary import encode_skel, read_skel

    six, eight = encode_skel(_dark_slot_doc(version, "123456")), encode_skel(_dark_slot_doc(version, "12345680"))
    assert eight.replace(b"\x80\x12\x34\x56", b"\x00\x12\x34\x56") == six  # the high byte alone differs
    back = read_skel(eight)
    assert back["slots"][0]["dark"] == "12345680"
    rgb = [0x12 / 255, 0x34 / 255, 0x56 / 255]
    for doc in (_dark_slot_doc(version, "12345680"), back):
        sampler = Sampler(doc)
        assert np.allclose(sampler.pose(None).slots[0].dark, rgb)
        if version.startswith("3"):
            assert np.allclose(sampler.pose("a", 0.5).slots[0].dark, rgb)
    white = read_skel(encode_skel(_dark_slot_doc(version, "ffffffff")))
    assert white["slots"][0].get("dark", "")[:6] == "ffffff"
    assert np.allclose(Sampler(white).pose(None).slots[0].dark, [1, 1, 1])


@pytest.mark.parametrize("version", ["3.8.99", "4.2.22"])
def test_colours_not_of_eight_digits_pose_alike_from_the_json_and_our_skel(version):
    """The runtimes (and our sampler) read a JSON colour's alpha only from exactly eight digits
    (1 otherwise); our writer padded seven digits with an ``f`` (``"ff80401"``: alpha 0x1f)
    and cut longer ones to eight (``"ff804000ab"``: alpha 0), a .skel drawn almost or wholly
    transparent where the .json draws opaque, silently. Slots, attachments and keys now pose
    alike from both; fewer than six digits (no colour a runtime reads) are refused."""
    from spinemesh.errors import SkelFormatError
    from spinemesh.skeleton_binary import encode_skel, read_skel

    box = {"width": 10, "height": 10, "color": "ff80401"}
    slots = [{"name": "s", "bone": "root", "attachment": "r", "color": "ff804000ab", "dark": "102030"},
             {"name": "t", "bone": "root", "attachment": "r"}]
    if version.startswith("3"):
        keys = {"s": {"twoColor": [{"time": 0, "light": "ff80401", "dark": "000000"}]},
                "t": {"color": [{"time": 0, "color": "20406080ab"}]}}
        skins = {"default": {"s": {"r": box}, "t": {"r": box}}}
    else:
        keys = {"s": {"rgba2": [{"time": 0, "light": "ff80401", "dark": "000000"}]},
                "t": {"rgba": [{"time": 0, "color": "20406080ab"}]}}
        skins = [{"name": "default", "attachments": {"s": {"r": box}, "t": {"r": box}}}]
    doc = {"skeleton": {"spine": version}, "bones": [{"name": "root"}], "slots": slots, "skins": skins,
           "animations": {"a": {"slots": keys}}}
    back = read_skel(encode_skel(doc))
    for animation in (None, "a"):
        want, got = (Sampler(d).pose(animation, 0.5).slots for d in (doc, back))
        assert [list(s.color) for s in got] == [list(s.color) for s in want]
        assert all(s.color[3] == 1 for s in got)
    doc["slots"][1]["color"] = "ff80"
    with pytest.raises(SkelFormatError, match="six or eight digits"):
        encode_skel(doc)
