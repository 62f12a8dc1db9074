"""Hostile input, tenth round: what a skeleton draws (attachment semantics ``upgrade`` must keep,
proven in the official runtime), the preview page's names, and the pose sampler's inputs.

As in the earlier rounds (tests/test_hostile*.py), every project is made here by our own code;
each case checks what docs/safety.md promises: never a wrong output written silently, one clear
line naming the file, never a traceback, inputs unchanged.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from test_hostile import check_run, json_demo, run_cli, snapshot
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)


def _edit(project: Path, change) -> dict:
    """``change(doc)`` applied to the demo's skeleton, written back; the document."""
    path = project / "demo.json"
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc, indent="\t"))
    return doc


def _att(doc: dict, slot: str) -> dict:
    """The default skin's one attachment of ``slot``."""
    return next(iter(doc["skins"][0]["attachments"][slot].values()))


def _types(path: Path) -> dict[str, str]:
    """``skin/slot/name`` -> attachment type of a written skeleton."""
    doc = json.loads(path.read_text())
    return {f"{skin['name']}/{slot}/{name}": a.get("type", "region")
            for skin in doc["skins"] for slot, atts in skin["attachments"].items() for name, a in atts.items()}


# --- attachment semantics the upgrade keeps, in the official runtime ------------------------------

def _geometry(doc):
    """Flips, a negative and a zero size, a turn past 360 degrees, on plain and turned regions."""
    _att(doc, "head")["scaleX"] = -1                 # mirrored
    _att(doc, "body")["scaleY"] = -1.5               # upside down and stretched
    _att(doc, "ring")["width"] = -100                # a negative width mirrors as scaleX -1 does
    _att(doc, "blobs")["rotation"] = 735             # 15 + 720
    _att(doc, "blobs")["scaleY"] = -1
    _att(doc, "arm")["scaleX"] = -0.9                # a region turned on its page, mirrored
    _att(doc, "arm")["height"] = -120


def _names_and_sizes(doc):
    """A ``path`` naming another region, one image at two sizes in two slots and in a second skin,
    a skin placeholder holding ``/`` and ``..``."""
    head = _att(doc, "head")
    head.update(path="demo-ring", width=100, height=100)
    doc["slots"].append({"name": "head2", "bone": "props", "attachment": "demo-head"})
    doc["skins"][0]["attachments"]["head2"] = {"demo-head": {"x": -60, "width": 40, "height": 150}}
    body = doc["skins"][0]["attachments"]["body"].pop("demo-body")
    doc["skins"][0]["attachments"]["body"]["../../x/demo-body"] = {**body, "path": "demo-body"}
    doc["slots"][1]["attachment"] = "../../x/demo-body"
    doc["skins"].append({"name": "big", "attachments": {"head2": {"demo-head": {"width": 160, "height": 60}}}})


def _colour_and_blend(doc):
    """A region of alpha 0, slots of every blend with dark colours, regions inside a clipping
    attachment's range."""
    _att(doc, "head")["color"] = "ffffff00"
    for slot, blend in zip(doc["slots"], ["additive", "multiply", "screen", "normal", "additive", "multiply"]):
        slot.update(blend=blend, dark="402010")
    doc["slots"].insert(1, {"name": "clip", "bone": "body", "attachment": "clip"})
    doc["skins"][0]["attachments"]["clip"] = {"clip": {"type": "clipping", "end": "head", "vertexCount": 3,
                                                       "vertices": [-40, -20, 60, 10, 0, 150]}}


@pytest.mark.parametrize("pack", [False, True], ids=["upgrade", "pack"])
@pytest.mark.parametrize("change", [_geometry, _names_and_sizes, _colour_and_blend], ids=lambda f: f.__name__[1:])
def test_upgraded_regions_draw_as_the_originals_in_the_runtime(tmp_path, spine_runtime, change, pack):
    """Passed as it was: every region of each case becomes a mesh that the official 4.2 runtime
    draws as the region, in the setup pose and the animation (a pixel on a quad's edge may fall
    either way: a few pixels of the 300,000 at most). The runtime ignores dark colours, so those
    are proven by the document only: the slots are written as they were."""
    from runtime_tool import render, render_difference

    project = json_demo(tmp_path)
    doc = _edit(project, change)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", *(["--pack"] if pack else []),
                cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(0,))
    written = tmp_path / "o" / "demo.json"
    assert set(_types(written).values()) <= {"mesh", "clipping"}, _types(written)
    assert json.loads(written.read_text())["slots"] == doc["slots"]
    a = render(spine_runtime, project / "demo.atlas", project / "demo.json", "wave", "0,0.3", tmp_path / "a")
    b = render(spine_runtime, tmp_path / "o" / "demo.atlas", written, "wave", "0,0.3", tmp_path / "b",
               frame_from=tmp_path / "a.frame.json")
    assert len(a) == len(b) == 3
    for pa, pb in zip(a, b):
        d = render_difference(pa, pb)
        assert d["lost"] + d["added"] <= 8 and d["off"] <= 8, (pb.name, d)


@pytest.mark.parametrize("frame2,meshed", [("\tbounds: 183, 145, 64, 64\n\toffsets: 8, 8, 80, 80\n", False),
                                           ("\tbounds: 183, 145, 48, 48\n\toffsets: 0, 0, 48, 48\n", True)],
                         ids=["larger, trimmed otherwise", "smaller, untrimmed"])
def test_a_sequence_frame_of_another_original_size_draws_alike(tmp_path, spine_runtime, frame2, meshed):
    """Passed as it was: a sequence whose second frame has another original size than the others
    (larger with its art placed inside, or smaller): kept a region where the frames are trimmed
    otherwise (unless --repack), else meshed; either way the runtime draws every frame as the
    original, with and without --pack."""
    from runtime_tool import render, render_difference

    project = json_demo(tmp_path)
    atlas = project / "demo.atlas"
    text = atlas.read_text()
    assert "demo-spark/frame2\n\tbounds: 183, 145, 64, 64\n" in text
    atlas.write_text(text.replace("demo-spark/frame2\n\tbounds: 183, 145, 64, 64\n", "demo-spark/frame2\n" + frame2))
    before = snapshot(tmp_path)
    for out, pack in (("o", []), ("k", ["--pack"])):
        r = run_cli("upgrade", "p", "--out", out, "--jobs", "1", "--min-saving", "0", *pack, cwd=tmp_path)
        check_run(r, before, tmp_path, ["o/", "k/", "r/"], codes=(0,))
        written = tmp_path / out / "demo.json"
        assert (_types(written)["default/spark/spark"] == "mesh") is meshed
        (tmp_path / "r").mkdir(exist_ok=True)
        a = render(spine_runtime, atlas, project / "demo.json", "wave", "0.05,0.15,0.25", tmp_path / "r" / "a")
        b = render(spine_runtime, tmp_path / out / "demo.atlas", written, "wave", "0.05,0.15,0.25",
                   tmp_path / "r" / f"b-{out}", frame_from=tmp_path / "r" / "a.frame.json")
        assert len(a) == len(b) == 4
        for pa, pb in zip(a, b):
            d = render_difference(pa, pb)
            assert d["lost"] + d["added"] <= 8 and d["off"] <= 8, (pb.name, d)


def test_a_region_a_linked_mesh_names_as_its_parent_stays_a_region(tmp_path):
    """A linked mesh whose parent is a region attachment: no runtime loads the skeleton (spine-ts
    and libGDX stop at it, spine-c and spine-cpp read the region as a mesh) and ``pose`` draws
    nothing there. ``upgrade`` meshed the region, so the linked mesh then loaded and drew its own
    image over the new mesh (exit 0): a picture the original never showed. Now the region stays
    a region with one line naming the linked mesh, exit 3; the rest is meshed."""
    project = json_demo(tmp_path)

    def linked(doc):
        doc["skins"].append({"name": "alt", "attachments": {"head": {"demo-head": {
            "type": "linkedmesh", "parent": "demo-head", "skin": "default", "path": "demo-ring",
            "width": 100, "height": 100}}}})

    _edit(project, linked)
    before = snapshot(tmp_path)
    for args, out in ((["--out", "o"], "o"), (["--out", "k", "--pack"], "k")):
        r = run_cli("upgrade", "p", *args, "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
        check_run(r, before, tmp_path, ["o/", "k/"], codes=(3,))
        lines = [x for x in r.stderr.splitlines() if "linked mesh" in x]
        assert len(lines) == 1 and "attachment 'demo-head'" in lines[0] and "'demo-head' of skin 'alt'" in lines[0], \
            r.stderr
        types = _types(tmp_path / out / "demo.json")
        assert types.pop("default/head/demo-head") == "region" and types.pop("alt/head/demo-head") == "linkedmesh"
        assert set(types.values()) == {"mesh"}, types


@pytest.mark.parametrize("version", ["4.2.40", "3.8.99"])
def test_a_region_an_animation_deforms_stays_a_region(tmp_path, spine_runtime, version):
    """A deform timeline keyed on a region attachment (4.1+ under ``attachments``, earlier under
    ``deform``): no runtime loads it (spine-ts stops on the region's missing vertices, libGDX on its
    type) and ``pose`` deforms nothing. ``upgrade`` meshed the region, so the skeleton then loaded
    and the animation moved the new mesh's vertices (exit 0). Now the region stays a region with
    one line naming the animation, exit 3; the rest is meshed."""
    from runtime_tool import node

    deform = [{"time": 0}, {"time": 0.5, "vertices": [5] * 8}, {"time": 1}]
    keyed = ({"attachments": {"default": {"head": {"demo-head": {"deform": deform}}}}} if version >= "4.1"
             else {"deform": {"default": {"head": {"demo-head": deform}}}})
    project = _pose_project(tmp_path, version, {"wave": keyed})
    r = node(spine_runtime, "dump.mjs", project / "demo.atlas", project / "demo.json", "--anim", "wave", "--times",
             "0.5", "--out", tmp_path / "d.json")
    assert r.returncode != 0  # the official runtime does not load the original
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert ("slot 'head' attachment 'demo-head': animation 'wave' keys a deform of it: no runtime loads that"
            in r.stderr), r.stderr
    types = _types(tmp_path / "o" / "demo.json")
    assert types.pop("default/head/demo-head") == "region" and set(types.values()) == {"mesh"}, types


def test_a_43_region_a_linked_mesh_of_another_slot_takes_as_its_source_stays_a_region(tmp_path):
    """4.3 names the source mesh ``source`` and, in another slot, that ``slot``: a region so named
    stays a region too, with its one line."""
    project = json_demo(tmp_path)

    def linked(doc):
        doc["skeleton"]["spine"] = "4.3.00"
        doc["slots"].append({"name": "ghost", "bone": "props", "attachment": "copy"})
        doc["skins"][0]["attachments"]["ghost"] = {"copy": {
            "type": "linkedmesh", "source": "demo-head", "slot": "head", "path": "demo-ring", "width": 100, "height": 100}}

    _edit(project, linked)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert "slot 'head' attachment 'demo-head': linked mesh 'copy' of skin 'default' names it" in r.stderr, r.stderr
    types = _types(tmp_path / "o" / "demo.json")
    assert types.pop("default/head/demo-head") == "region" and types.pop("default/ghost/copy") == "linkedmesh"
    assert set(types.values()) == {"mesh"}, types


# --- the preview page ------------------------------------------------------------------------------

def test_skins_and_animations_named_like_javascript_internals_play_in_the_preview(tmp_path):
    """A skin named ``__proto__`` (the page's script wrote each animation's data files in an
    object keyed by skin name, where that key sets no property) opened the player on "could not
    load [object Object]" with nothing drawn, whichever animation was chosen. Skins named
    ``constructor`` or ``toString``, an animation named ``__proto__``, one of 10,000 characters
    behind a right-to-left override, and bones and slots named with script play too."""
    from browser import player_result, run
    from test_hostile_wave4 import PAYLOADS

    project = json_demo(tmp_path)
    long_name = "\u202e" + "x" * 10_000

    def names(doc):
        atts = doc["skins"][0]["attachments"]
        for name in ("__proto__", "constructor", "toString"):
            doc["skins"].append({"name": name, "attachments": copy.deepcopy(atts)})
        wave = doc["animations"]["wave"]
        doc["animations"].update({"__proto__": copy.deepcopy(wave), long_name: copy.deepcopy(wave)})
        doc["bones"][2]["name"] = PAYLOADS[0]      # the head's bone, keyed by the wave
        for slot in doc["slots"]:
            if slot["bone"] == "head":
                slot["bone"] = PAYLOADS[0]
        wave["bones"][PAYLOADS[0]] = wave["bones"].pop("head")
        doc["slots"][4]["name"] = PAYLOADS[1]      # the blobs' slot
        atts[PAYLOADS[1]] = atts.pop("blobs")

    _edit(project, names)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--preview", "v", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/", "v/"], codes=(0,))
    page = (tmp_path / "v" / "s" / "demo.html").resolve().as_uri()
    model = next((tmp_path / "v" / "data").glob("*/model.js")).read_text(encoding="utf-8")
    skins = json.loads(model[model.index('"skins":') + 8:model.index('],"anims"') + 1])
    assert sorted(skins) == sorted(["__proto__", "constructor", "toString", "default"])
    for skin in range(len(skins)):
        for anim, name in ((1, "wave"), (2, "__proto__"), (3, long_name)):
            got = player_result(page + f"#skin={skin}&play={anim}&test=1", tmp_path / "chromium", budget_ms=4000)
            assert got["anim"] == name
            assert len({s["after"] for s in got["samples"]}) > 1, (skin, name)  # drawn, and moving
    dom = run(page, tmp_path / "chromium", "--dump-dom").stdout
    assert "PWNED" not in dom and "could not load" not in dom


# --- the pose sampler's inputs, against the official runtime --------------------------------------

#: Times sampled: before, on and between the keys, and past the end (the animation loops).
POSE_TIMES = "0,0.1,0.2,0.25,0.4,0.5,0.6,0.75,0.9,1,1.3,1.6"


def _pose_project(tmp: Path, version: str, animations: dict) -> Path:
    """The demo skeleton as ``version`` (without its 4.1+ sequence before 4.1), with ``animations``."""
    project = json_demo(tmp)

    def change(doc):
        doc["skeleton"]["spine"] = version
        doc["animations"] = animations
        if version < "4.1":
            doc["slots"] = [s for s in doc["slots"] if s["name"] != "spark"]
            del doc["skins"][0]["attachments"]["spark"]

    _edit(project, change)
    return project


def _poses_match_the_runtime(tmp: Path, runtime: Path, project: Path, animation: str, times: str = POSE_TIMES):
    """``pose`` of ``animation`` at ``times`` (through the command) against the official runtime's dump."""
    from runtime_tool import pose_dump

    from spinemesh.anim.dump import pose_errors

    before = snapshot(tmp)
    r = run_cli("pose", "p/demo.json", "-a", animation, "--times", times, "--out", f"{animation}.json", cwd=tmp)
    check_run(r, before, tmp, [f"{animation}.json"], codes=(0,))
    ours = json.loads((tmp / f"{animation}.json").read_text())
    (tmp / "runtime").mkdir(exist_ok=True)
    theirs = pose_dump(runtime, project / "demo.atlas", project / "demo.json", tmp / "runtime" / f"{animation}.json",
                       animation, times)
    assert len(ours["poses"]) == len(theirs["poses"])
    # a value the runtime could not compute (NaN, dumped as null) would compare as no difference
    for pose in theirs["poses"]:
        numbers = [v for m in pose["bones"].values() for v in m] + [v for a in pose["attachments"] for v in a["vertices"]]
        assert None not in numbers, ("the runtime posed something as not a number", pose["label"])
    for a, b in zip(ours["poses"], theirs["poses"]):
        e = pose_errors(a, b)
        assert not e["problems"] and e["bone"] <= 0.01 and e["vertex"] <= 0.01, (animation, a["label"], e)


@pytest.mark.parametrize("version", ["4.2.40", "4.1.20", "4.0.60", "3.8.99"])
def test_keys_out_of_time_order_pose_as_the_runtimes_find_them(tmp_path, spine_runtime, version):
    """Keys whose times do not ascend (the editor never writes them; a tool or a hand can): numpy's
    bisection found another key than the runtimes do, so ``pose`` and the preview showed a pose
    no runtime shows (a bone 6 degrees off, the slots in another draw order, a 3.8 bone 60 units
    away), exit 0. The runtimes disagree among themselves here: 4.x scans for the first later key
    past the time, 3.8 bisects; each version is now posed as its own runtime poses it, rotate,
    translate with a stepped key, attachment and draw order timelines alike."""
    angle = "angle" if version.startswith("3") else "value"
    keyed = {
        "bones": {
            "arm": {"rotate": [{angle: 5}, {"time": 0.7, angle: 40}, {"time": 0.2, angle: -30},
                               {"time": 0.9, angle: 60}, {"time": 0.4, angle: 10}, {"time": 1.0, angle: 0}]},
            "head": {"rotate": [{"time": 0.5, angle: 40}, {angle: 0}, {"time": 1, angle: 10}]},
            "body": {"translate": [{"x": 5}, {"time": 0.7, "x": 40}, {"time": 0.2, "x": -30, "curve": "stepped"},
                                   {"time": 0.9, "x": 60}, {"time": 0.4, "y": 10}, {"time": 1.0}]},
        },
        "slots": {"head": {"attachment": [{"name": None}, {"time": 0.6, "name": "demo-head"},
                                          {"time": 0.3, "name": None}, {"time": 0.8, "name": "demo-head"}]}},
        "drawOrder": [{"offsets": [{"slot": "arm", "offset": 3}]}, {"time": 0.7},
                      {"time": 0.2, "offsets": [{"slot": "head", "offset": -2}]}, {"time": 0.9}],
    }
    project = _pose_project(tmp_path, version, {"t": keyed})
    _poses_match_the_runtime(tmp_path, spine_runtime, project, "t")


def test_the_search_of_keys_out_of_order_is_each_runtimes():
    """The two searches worked by hand: 4.x takes the key before the first later one past the
    time, 3.x bisects (which here lands elsewhere); ascending keys give the last at or before."""
    import numpy as np

    from spinemesh.anim.curves import key_times, search

    times = np.array([0.0, 0.7, 0.2, 0.9, 0.4, 1.0])
    four, three = key_times(times, True), key_times(times, False)
    assert [search(four, t) for t in (-1, 0.1, 0.3, 0.5, 0.8, 0.95, 1.2)] == [-1, 0, 0, 0, 2, 4, 5]
    assert [search(three, t) for t in (-1, 0.1, 0.3, 0.5, 0.8, 0.95, 1.2)] == [-1, 0, 2, 2, 2, 4, 5]
    ascending = np.array([0.0, 0.5, 0.5, 1.0])
    assert key_times(ascending, True) is ascending
    assert [search(ascending, t) for t in (-0.5, 0.25, 0.5, 0.75, 1, 2)] == [-1, 0, 2, 2, 3, 3]


@pytest.mark.parametrize("version", ["4.2.40", "4.0.60"])
def test_odd_keys_pose_as_in_the_runtime(tmp_path, spine_runtime, version):
    """Passed as it was: two keys at one time, keys before 0, Bezier handles far outside their
    keys' span in time, a stepped last key, curve lists longer than their values need (8 numbers
    on a timeline of one value, 16 on one of two), an animation of events only, one of no duration
    and one of 1e9 seconds: ``pose`` gives the runtime's pose at every time."""
    odd = {
        "bones": {
            "arm": {"rotate": [{"value": 0}, {"time": 0.5, "value": 40}, {"time": 0.5, "value": -40},
                               {"time": 1, "value": 0, "curve": "stepped"}]},
            "head": {"rotate": [{"time": -0.5, "value": 20, "curve": [-0.5, 0, 2, 40]}, {"time": 0.5, "value": 40},
                                {"time": 1, "value": 0}]},
            "body": {"translate": [{"x": 0, "y": 0, "curve": [0.1, 0, 0.4, 10, 0.2, 5, 0.3, 15]},
                                   {"time": 0.5, "x": 30, "y": 20}, {"time": 1}]},
            "props": {"rotate": [{"value": 0, "curve": 0}, {"time": 0.3, "value": 20, "curve": None},
                                 {"time": 0.6, "value": 40, "curve": [0.6, 0, 0.7, 40, 0.1, 0, 0.4, 3]},
                                 {"time": 0.9, "value": -10}],
                      "scale": [{"x": 1, "curve": [0.4, 80, 0.1, -30, 0.2, 1, 0.3, 2, 9, 9, 9, 9, 9, 9, 9, 9]},
                                {"time": 0.5, "x": 2, "y": 0.5}]},
        },
    }
    project = _pose_project(tmp_path, version, {
        "odd": odd, "events": {"events": [{"time": 0.5, "name": "e"}]},
        "still": {"bones": {"arm": {"rotate": [{"value": 30}, {"value": 50}]}}},
        "long": {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 1e9, "value": 40}]}}}})
    _edit(project, lambda doc: doc.update(events={"e": {}}))
    for animation in ("odd", "events", "still", "long"):
        _poses_match_the_runtime(tmp_path, spine_runtime, project, animation)


def test_38_curve_handles_outside_0_to_1_pose_as_in_the_runtime(tmp_path, spine_runtime):
    """Passed as it was: 3.8 Bezier handles outside 0..1 in time and value (``curve``, ``c2`` to
    ``c4`` of -0.5 to 3), on a rotate and on a translate followed by a stepped key, pose as the 3.8
    runtime poses them."""
    keyed = {"bones": {
        "arm": {"rotate": [{"angle": 0, "curve": -0.5, "c2": 2, "c3": 1.5, "c4": -1},
                           {"time": 0.5, "angle": 40, "curve": 1.5, "c2": 0.2, "c3": -0.4, "c4": 0.9},
                           {"time": 1, "angle": 0}]},
        "body": {"translate": [{"x": 0, "curve": 0.5, "c2": 3, "c3": 0.5}, {"time": 0.5, "x": 40, "curve": "stepped"},
                               {"time": 1, "x": 10}]}}}
    project = _pose_project(tmp_path, "3.8.99", {"t": keyed})
    _poses_match_the_runtime(tmp_path, spine_runtime, project, "t")


@pytest.mark.parametrize("curve,values", [([0.25, 0, 0.75], 1), ([], 1), (True, 1), ("linear", 1),
                                          (["0.1", 0, 0.4, 10], 1), ([0.1, 0, 0.4, 10], 2)],
                         ids=["3 numbers", "empty", "true", "text", "a number as text", "4 for 2 values"])
def test_a_4x_curve_no_runtime_plays_is_said(tmp_path, spine_runtime, curve, values):
    """A 4.x key's ``curve`` that is neither absent, ``"stepped"`` nor a list of 4 numbers per
    value: spine-ts poses the timeline's values as not a number (the bone, and what it draws, is
    nowhere: the official runtime's dump holds null; a number written as text it reads as the
    number), spine-c and spine-cpp read past the list or read text as 0 and libGDX refuses the file. ``pose`` posed it linear without a word (exit 0): a pose no game
    shows. Now it says so, one line naming the animation, the timeline and the key, exit 3; the
    runtimes disagree, so the linear pose stays."""
    key = ({"x": 0, "y": 0} if values == 2 else {"value": 0}) | {"curve": curve}
    last = {"time": 0.5, "x": 30, "y": 20} if values == 2 else {"time": 0.5, "value": 40}
    project = _pose_project(tmp_path, "4.2.40", {"t": {"bones": {"arm": {
        "translate" if values == 2 else "rotate": [key, last]}}}})
    before = snapshot(tmp_path)
    r = run_cli("pose", "p/demo.json", "-a", "t", "--times", "0.2", "--out", "pose.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json"], codes=(3,))
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 2 and lines[1] == "pose.json: 2 poses", r.stderr
    assert lines[0].startswith("warning: p/demo.json: animation 't': bones.arm.") and "key at 0 s" in lines[0]
    assert f"need{'' if values > 1 else 's'} a list of {4 * values} numbers" in lines[0], lines[0]
    from runtime_tool import pose_dump

    theirs = pose_dump(spine_runtime, project / "demo.atlas", project / "demo.json", tmp_path / "d.json", "t", "0.2")
    # where the runtimes disagree: spine-ts's NaN (a number written as text it reads as the number)
    assert (None in theirs["poses"][-1]["bones"]["arm"]) is (curve != ["0.1", 0, 0.4, 10])
    ours = json.loads((tmp_path / "pose.json").read_text())["poses"][-1]["bones"]["arm"]
    assert None not in ours


def test_the_preview_says_a_4x_curve_the_runtimes_play_apart(tmp_path):
    """The player shows such a curve linear, as ``pose`` does; its skeleton's page says so in the
    same words (it showed it without a word)."""
    import html

    project = _pose_project(tmp_path, "4.2.40", {"t": {"bones": {"arm": {"rotate": [
        {"value": 0, "curve": [0.25, 0, 0.75]}, {"time": 0.5, "value": 40}]}}}})
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--preview", "v", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/", "v/"], codes=(0,))
    page = html.unescape((tmp_path / "v" / "s" / "demo.html").read_text(encoding="utf-8"))
    assert ("<li>animation 't': bones.arm.rotate: the curve of the key at 0 s is [0.25, 0, 0.75], where its 1 value "
            "needs a list of 4 numbers; the runtimes play it apart or not at all") in page
    assert project.is_dir()


def test_a_43_linked_mesh_whose_source_sits_in_another_slot_is_posed(tmp_path, runtime43):  # noqa: F811
    """4.3 lets a linked mesh take its source mesh from another slot (``"slot"``), whose deform
    keys then drive it too (spine-core adds its slot to the source's timeline slots). The sampler
    looked for the source in the linked mesh's own slot, found none and drew nothing there:
    ``pose`` and the preview left the attachment out, exit 0. Now it is posed as spine-core 4.3
    poses it, deformed with its source."""
    import numpy as np
    from runtime_tool import node

    from spinemesh.anim.dump import pose_errors

    project = json_demo(tmp_path)
    _edit(project, lambda doc: doc["skeleton"].update(spine="4.3.00"))
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    assert r.returncode == 0, r.stderr

    def linked(doc):
        head = doc["skins"][0]["attachments"]["head"]["demo-head"]
        assert head["type"] == "mesh"
        doc["slots"].append({"name": "ghost", "bone": "props", "attachment": "copy"})
        doc["skins"][0]["attachments"]["ghost"] = {"copy": {
            "type": "linkedmesh", "source": "demo-head", "slot": "head", "path": "demo-ring", "width": 100, "height": 100}}
        deform = [{"time": 0}, {"time": 0.5, "vertices": [5.0] * len(head["vertices"])}, {"time": 1}]
        doc["animations"]["wave"]["attachments"]["default"]["head"] = {"demo-head": {"deform": deform}}

    _edit(tmp_path / "o", linked)
    before = snapshot(tmp_path)
    r = run_cli("pose", "o/demo.json", "-a", "wave", "--times", "0.3,0.5", "--out", "pose.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json"], codes=(0,))
    ours = json.loads((tmp_path / "pose.json").read_text())["poses"]
    r = node(runtime43, "pose.mjs", tmp_path / "o" / "demo.atlas", tmp_path / "o" / "demo.json", tmp_path / "d.json",
             "wave@0.3,wave@0.5")
    assert r.returncode == 0, r.stderr[-2000:]
    theirs = json.loads((tmp_path / "d.json").read_text())["poses"]
    assert len(ours) == len(theirs) == 3
    for a, b in zip(ours, theirs):
        assert [x["slot"] for x in a["attachments"]][-1] == "ghost"
        e = pose_errors(a, b)
        assert not e["problems"] and e["bone"] <= 0.01 and e["vertex"] <= 0.01, (a["label"], e)
    ghost = [np.array(p["attachments"][-1]["vertices"]) for p in ours]
    assert abs(ghost[2] - ghost[0]).max() > 4  # the source's deform moves it


def test_slots_named_twice_pose_as_the_runtimes_find_them(tmp_path, spine_runtime):
    """Two slots of one name (no editor writes them; a merge of two skeletons can; two bones of
    one name are refused): the runtimes find the first by its name (``findSlot``) for a
    timeline and for a skin's attachments, so the later slot draws nothing. The sampler took the
    last, so ``pose`` and the preview drew the head twice, tinted the later one and keyed its
    colour there (exit 0). Now each name finds the first, as in the official runtime."""
    def twice(doc):
        doc["slots"].insert(3, {"name": "head", "bone": "props", "attachment": "demo-head", "color": "ff000080"})

    wave = {"slots": {"head": {"rgba": [{"color": "ffffffff"}, {"time": 1, "color": "00ff00ff"}]}}}
    project = _pose_project(tmp_path, "4.2.40", {"t": wave})
    _edit(project, twice)
    _poses_match_the_runtime(tmp_path, spine_runtime, project, "t", "0,0.3,0.6")


def test_skins_named_twice_pose_as_the_runtimes_find_them(tmp_path, spine_runtime):
    """Two skins of one name in a 3.8+ skin list: the runtimes find the first by name
    (``findSkin``) and take the last named ``default`` as the default skin (their JSON readers set
    it at each). ``pose --skin red`` and the preview drew the later ``red`` (the head 80 units
    off, exit 0); the default skin was already right. Now both are found as the runtime finds them."""
    from runtime_tool import dump

    from spinemesh.anim.dump import pose_errors

    project = json_demo(tmp_path)

    def twice(doc):
        head = doc["skins"][0]["attachments"]["head"].pop("demo-head")
        for x in (40, -40):
            doc["skins"].append({"name": "red", "attachments": {"head": {"demo-head": {**head, "x": x}}}})
        later = copy.deepcopy(doc["skins"][0])
        later["attachments"]["arm"]["demo-arm"]["x"] = 30
        doc["skins"].append(later)

    _edit(project, twice)
    before = snapshot(tmp_path)
    r = run_cli("pose", "p/demo.json", "-a", "wave", "--times", "0,0.3", "--skin", "red", "--out", "pose.json",
                cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json"], codes=(0,))
    ours = json.loads((tmp_path / "pose.json").read_text())["poses"]
    dump(spine_runtime, project / "demo.atlas", project / "demo.json", "wave", "0,0.3", tmp_path / "d.json", skin="red")
    theirs = json.loads((tmp_path / "d.json").read_text())["poses"]
    assert len(ours) == len(theirs) == 3
    for a, b in zip(ours, theirs):
        e = pose_errors(a, b)
        assert not e["problems"] and e["bone"] <= 0.01 and e["vertex"] <= 0.01, (a["label"], e)
