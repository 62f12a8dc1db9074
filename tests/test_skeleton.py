"""Skeleton JSON: lossless round trips and the attachment walker, all versions."""

from __future__ import annotations

import json

import pytest

from spinemesh.errors import SkeletonError
from spinemesh.skeleton import (
    AttachmentRef, dumps_skeleton, image_paths, iter_attachments, load_skeleton, save_skeleton,
    sequence_paths, spine_version,
)

from conftest import EXAMPLES

JSONS = sorted(EXAMPLES.glob("*/*/*.json"))


def _plain_count(doc) -> int:
    skins = doc.get("skins", {})
    if isinstance(skins, dict):
        return sum(len(atts) for slots in skins.values() for atts in slots.values())
    return sum(len(atts) for skin in skins for atts in skin.get("attachments", {}).values())


@pytest.mark.parametrize("path", JSONS, ids=lambda p: f"{p.parts[-3]}/{p.parts[-2]}/{p.name}")
def test_json_round_trip_is_lossless(path, tmp_path):
    doc = load_skeleton(path)
    out = tmp_path / path.name
    save_skeleton(doc, out)
    again = json.loads(out.read_text(encoding="utf-8"))
    assert again == json.loads(path.read_text(encoding="utf-8-sig"))
    # Key order is kept at every level.
    assert dumps_skeleton(again) == dumps_skeleton(doc)
    assert list(again) == list(doc)


@pytest.mark.parametrize("path", JSONS, ids=lambda p: f"{p.parts[-3]}/{p.parts[-2]}/{p.name}")
def test_walker_finds_every_attachment(path):
    doc = load_skeleton(path)
    refs = list(iter_attachments(doc))
    assert len(refs) == _plain_count(doc) > 0
    assert spine_version(doc).startswith(path.parts[-3])


def test_both_skin_layouts(examples):
    old = load_skeleton(examples / "3.7/spineboy/spineboy-ess.json")
    new = load_skeleton(examples / "3.8/spineboy/spineboy-ess.json")
    assert isinstance(old["skins"], dict) and isinstance(new["skins"], list)
    key = lambda r: (r.skin, r.slot, r.name)  # noqa: E731
    assert {key(r) for r in iter_attachments(old)} == {key(r) for r in iter_attachments(new)}


def test_image_path_resolution():
    ref = AttachmentRef("default", "s", "key", {})
    assert image_paths(ref) == ["key"]
    assert image_paths(ref._replace(attachment={"name": "n"})) == ["n"]
    assert image_paths(ref._replace(attachment={"name": "n", "path": "p"})) == ["p"]
    assert image_paths(ref._replace(attachment={"type": "boundingbox"})) == []
    seq = {"type": "mesh", "path": "fx/f", "sequence": {"count": 3, "start": 8, "digits": 2}}
    assert image_paths(ref._replace(attachment=seq)) == ["fx/f08", "fx/f09", "fx/f10"]
    assert sequence_paths("a", {"count": 2}) == ["a1", "a2"]


def test_real_sequences_resolve_to_atlas_regions(examples):
    from spinemesh.atlas import read_atlas

    doc = load_skeleton(examples / "4.2/dragon/dragon-ess.json")
    atlas = read_atlas(examples / "4.2/dragon/dragon.atlas")
    frames = [p for r in iter_attachments(doc) if "sequence" in r.attachment for p in image_paths(r)]
    assert frames and all(atlas.find(p) for p in frames)


@pytest.mark.parametrize("text, line", [
    ('{"skeleton": {"spine": "4.2.1"}, "bones": [\n{"name": "root"},\n', 3),
    ('{"bones": [1, 2,, 3]}', 1),
])
def test_malformed_json_names_file_and_line(tmp_path, text, line):
    f = tmp_path / "broken.json"
    f.write_text(text)
    with pytest.raises(SkeletonError) as e:
        load_skeleton(f)
    assert "broken.json" in str(e.value) and e.value.line == line


def test_truncated_real_skeleton(tmp_path, examples):
    data = (examples / "4.2/spineboy/spineboy-pro.json").read_bytes()
    f = tmp_path / "spineboy-pro.json"
    f.write_bytes(data[: len(data) // 2])
    with pytest.raises(SkeletonError) as e:
        load_skeleton(f)
    assert e.value.line and "spineboy-pro.json" in str(e.value)


def test_corpus_skeleton_json_round_trips(corpus):
    files = [p for p in corpus.rglob("*.json") if not p.name.endswith(".source.json")]
    checked = 0
    for p in files:
        if not p.read_bytes().lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"{"):
            continue  # binary skeletons under a .json name
        doc = load_skeleton(p)
        assert json.loads(dumps_skeleton(doc)) == doc
        checked += 1
    assert checked > 100


@pytest.mark.parametrize("number", ["1e999", "-1E+999", "1e0999", "2.5e+308", "-9" + "9" * 400 + ".5",
                                    "1" + "0" * 250 + "e99"])
def test_numbers_beyond_float_range_are_refused(number):
    """Floats parse without a per-number hook where no number can overflow (_may_overflow):
    every overflowing shape is still found and refused, as NaN and Infinity are."""
    from spinemesh.skeleton import _may_overflow, parse_skeleton_json

    text = '{"bones": [{"name": "root", "x": %s}]}' % number
    assert _may_overflow(text)
    with pytest.raises(SkeletonError, match="beyond the range"):
        parse_skeleton_json(text, "s.json")


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_nan_and_infinity_are_refused(constant):
    from spinemesh.skeleton import _may_overflow, parse_skeleton_json

    text = '{"bones": [{"name": "root", "x": %s}]}' % constant
    assert not _may_overflow(text)  # refused by the parse itself, hook or not
    with pytest.raises(SkeletonError, match="not a number JSON allows"):
        parse_skeleton_json(text, "s.json")


def test_numbers_within_range_parse_the_same_either_way():
    """The largest and smallest floats, underflow to 0, exponents of two digits and hex colours
    parse to the values the checking parse gives; a colour like 10e323ff only costs the check."""
    from spinemesh.skeleton import _finite_float, _may_overflow, _refuse_constant, parse_skeleton_json

    text = ('{"bones": [{"name": "root", "x": 1.7976931348623157e308, "y": -4.9e-324, "rotation": 1e-999,'
            ' "scaleX": 12345678901234567890.5e99, "length": -1E+99, "shearX": 0.1, "shearY": -0}],'
            ' "slots": [{"name": "a", "color": "abe323ff"}]}')
    assert not _may_overflow(text.replace("1.7976931348623157e308", "1").replace("1e-999", "1"))
    assert _may_overflow('{"color": "10e323ff"}')
    checked = json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float)
    assert json.dumps(parse_skeleton_json(text, "s.json")) == json.dumps(checked)
    plain = text.replace("1.7976931348623157e308", "1.5e30").replace("1e-999", "2e-9")
    assert not _may_overflow(plain)
    assert json.dumps(parse_skeleton_json(plain, "s.json")) == json.dumps(json.loads(plain))
