"""``weights --preview`` pictures say which colour is which bone: a legend under the panels and a
caption beside each picture naming every bone in full (spinemesh.rig.preview)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from spinemesh.rig.preview import LEGEND_COLUMNS, LEGEND_ROW, LEGEND_ROWS, bone_colour, drawable, legend

DEMO = Path(__file__).resolve().parents[1] / "examples" / "demo"


def _swatch(strip: np.ndarray, k: int) -> tuple[int, int, int]:
    """The colour at the middle of the ``k``-th entry's swatch."""
    column = strip.shape[1] // LEGEND_COLUMNS
    x, y = (k % LEGEND_COLUMNS) * column + 6, (k // LEGEND_COLUMNS) * LEGEND_ROW + 4
    return tuple(int(c) for c in strip[y + 8, x + 6])


def test_each_bone_has_its_colour_in_the_legend_and_many_bones_stay_within_its_rows():
    names = ["root", "spine_01_" + "x" * 200, "頭", "neck"] + [f"bone{i}" for i in range(40)]
    strip = legend(names, 768)
    assert strip.shape == (LEGEND_ROWS * LEGEND_ROW + 8, 768, 3)  # 44 bones: bounded, the rest in the caption
    shown = LEGEND_COLUMNS * LEGEND_ROWS - 1
    assert [_swatch(strip, k) for k in range(shown)] == [bone_colour(k) for k in range(shown)]
    # the entry after the last shown is words (how many more), no swatch
    column = 768 // LEGEND_COLUMNS
    k = shown
    x, y = (k % LEGEND_COLUMNS) * column + 6, (k // LEGEND_COLUMNS) * LEGEND_ROW + 4
    assert (strip[y + 2:y + 15, x + 1:x + 12] == 255).mean() > 0.5
    small = legend(["a", "b"], 768)
    assert small.shape[0] == LEGEND_ROW + 8 and _swatch(small, 1) == bone_colour(1)
    # no colour repeats (from the 11th bone on they did)
    assert _swatch(legend([f"b{i}" for i in range(12)], 768), 10) == bone_colour(10) != bone_colour(0)
    assert drawable("spine_01") and not drawable("頭") and not drawable("tab\tname")


def _renamed(doc: dict, old: str, new: str) -> None:
    """Bone ``old`` of the demo skeleton renamed ``new`` everywhere the demo names a bone."""
    for bone in doc["bones"]:
        bone["name"] = new if bone["name"] == old else bone["name"]
        if bone.get("parent") == old:
            bone["parent"] = new
    for slot in doc["slots"]:
        slot["bone"] = new if slot["bone"] == old else slot["bone"]
    for animation in doc.get("animations", {}).values():
        bones = animation.get("bones", {})
        if old in bones:
            bones[new] = bones.pop(old)


def test_each_picture_has_a_caption_naming_its_bones_in_full_and_a_legend(tmp_path):
    from spinemesh.images.decode import load_rgba
    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project
    from spinemesh.upgrade import Options, upgrade_project

    upgrade_project(DEMO / "demo.json", tmp_path / "up", Options(min_saving=0))
    skeleton = tmp_path / "up" / "demo.json"
    doc = json.loads(skeleton.read_text(encoding="utf-8"))
    _renamed(doc, "head", "頭の骨")  # the font cannot draw it: the caption names it
    skeleton.write_text(json.dumps(doc, ensure_ascii=False), encoding="utf-8")
    result = weight_project(tmp_path / "up", tmp_path / "w", WeightOptions(bones="auto"), preview=tmp_path / "prev")
    assert result.errors == []
    pictures = sorted((tmp_path / "prev").glob("*.png"))
    assert pictures
    bones = {b["name"] for b in doc["bones"]}
    named = set()
    for picture in pictures:
        said = json.loads(picture.with_suffix(".json").read_text(encoding="utf-8"))
        assert said["picture"] == picture.name and said["bones"], said
        for k, bone in enumerate(said["bones"]):
            assert bone["number"] == k + 1 and bone["name"] in bones
            assert bone["colour"] == "#{:02x}{:02x}{:02x}".format(*bone_colour(k))
            named.add(bone["name"])
        image = load_rgba(picture)
        strip = image[-(LEGEND_ROW + 8):, :, :3]  # one row: the demo's meshes have a few bones
        assert [_swatch(strip, k) for k in range(len(said["bones"]))] == \
            [bone_colour(k) for k in range(len(said["bones"]))]
    assert "頭の骨" in named, named


def test_attachments_of_one_file_name_each_keep_their_picture(tmp_path):
    """``arm?`` and ``arm!`` are both ``arm_`` as a file name (and ``Arm`` is ``arm`` on a macOS
    or Windows disk): the second picture and caption replaced the first without a word. Each
    weighted attachment now has its own picture, named apart (``files.names.name_apart``)."""
    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project
    from spinemesh.upgrade import Options, upgrade_project

    upgrade_project(DEMO / "demo.json", tmp_path / "up", Options(min_saving=0))
    skeleton = tmp_path / "up" / "demo.json"
    doc = json.loads(skeleton.read_text(encoding="utf-8"))
    skin = doc["skins"][0]["attachments"]
    slot, attachments = next((s, a) for s, a in skin.items() if any(v.get("type") == "mesh" for v in a.values()))
    name, mesh = next((n, v) for n, v in attachments.items() if v.get("type") == "mesh")
    for twin in (f"{name}?", f"{name}!", name.upper()):
        attachments[twin] = {**mesh, "path": mesh.get("path", name)}
    skeleton.write_text(json.dumps(doc), encoding="utf-8")
    result = weight_project(tmp_path / "up", tmp_path / "w", WeightOptions(bones="auto"), preview=tmp_path / "prev")
    assert result.errors == []
    weighted = {(o.slot, o.name) for o in result.outcomes if o.status == "weighted"}
    assert {(slot, name), (slot, f"{name}?"), (slot, f"{name}!"), (slot, name.upper())} <= weighted
    captions = [json.loads(p.read_text(encoding="utf-8")) for p in (tmp_path / "prev").glob("*.json")]
    assert sorted((c["slot"], c["attachment"]) for c in captions) == sorted(weighted)
    assert len({p.name.casefold() for p in (tmp_path / "prev").glob("*.png")}) == len(weighted)
