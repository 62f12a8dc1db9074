"""Binary ``.skel`` of Spine 3.6, 3.7 and 3.8 against the editor's own exports.

Every ``.skel`` in ``../shared/spine-examples/3.x`` has a ``.json`` twin exported from the
same project state. For each pair:

- reading the ``.skel`` and writing it back gives the same bytes;
- the document read from the ``.skel`` equals the JSON, up to the editor's rounding and
  left-out defaults, except for the differences listed in :data:`KNOWN`, each one a place
  where the two exports really hold different information;
- the JSON document written as ``.skel`` reads back to the same document.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version
from spinemesh.skeleton_binary.compare import diff_documents
from spinemesh.skeleton_binary.enums import EXTRA

from binary_pairs import (check_document_equals_editor_json, check_json_writes_a_skel_that_reads_back,
                          check_round_trip, check_survives_json_text, check_trailing_bytes_refused,
                          check_truncation_says_where_and_what, editor_json, no_motion)
from conftest import EXAMPLES, skel_json_pairs
from runtime_tool import max_difference, pose_dump

PAIRS = [p for v in ("3.6", "3.7", "3.8") for p in skel_json_pairs(v)]
IDS = [f"{s.parts[-3]}/{s.name}" for s, _ in PAIRS]

#: Differences that remain because the two exports hold different information:
#: (version, file, path pattern, condition on the .skel document, reason).
KNOWN = [
    ("3.*", "*", "animations/*/curve", no_motion,
     "Between two keys of equal values the JSON has a stepped curve where the binary has a "
     "linear one: the same motion, written two ways."),
    ("3.*", "powerup-*.skel", "animations/bounce/bones/star[689]/*/1/curve", None,
     "The JSON steps these stars' bones from their second key to their third, different values; "
     "the binary moves them linearly. Between those keys the star's colour keys hold alpha 0: "
     "the difference is never seen."),
    ("3.8", "*", "skeleton/hash", None,
     "The 3.8 editor wrote another hash into the binary than into the JSON for 16 of the 21 "
     "files, though all else matches: the hash names an export, not the data "
     "(all 3.6 and 3.7 pairs share theirs)."),
    ("3.8", "hero-pro.skel", "skins", None,
     "The JSON has two skins with bones and constraints but no attachments (weapon/morningstar, "
     "weapon/sword); the 3.8.76 binary has no skin but the default one: it leaves such skins out."),
    ("3.6", "raptor-pro.skel", "animations/gun-holster/ik/front-arm-goal/[01]/curve", None,
     "The exports disagree on this IK timeline's curves: the JSON steps from its first key "
     "(mix 0 to 0) and goes linearly from the second (0 to 0.996); the binary goes linearly "
     "from the first and steps from the second, a different motion between 0.47 s and 0.67 s."),
]


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_round_trip_is_byte_identical(skel: Path, js: Path):
    check_round_trip(skel)


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_document_equals_editor_json(skel: Path, js: Path):
    check_document_equals_editor_json(skel, js, KNOWN)


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_json_document_writes_a_skel_that_reads_back(skel: Path, js: Path):
    # A 3.x string table in first-use order is derivable: nothing binary-only is left.
    check_json_writes_a_skel_that_reads_back(js)


@pytest.mark.parametrize("skel,js", PAIRS[::6], ids=IDS[::6])
def test_document_survives_json_text(skel: Path, js: Path):
    check_survives_json_text(skel)


NONESSENTIAL = {"color", "edges", "width", "height", "images", "audio", "fps"}


@pytest.mark.parametrize("skel,js", PAIRS[::5], ids=IDS[::5])
def test_files_without_nonessential_data(skel: Path, js: Path):
    """The writer leaves nonessential data out when the document says the binary had none;
    such a file reads back to the document without it, and round-trips byte for byte."""
    doc = read_skel(skel)
    doc.setdefault(EXTRA, {})["nonessential"] = False
    data = encode_skel(doc)
    assert len(data) < skel.stat().st_size
    again = read_skel(data)
    assert again[EXTRA]["nonessential"] is False
    assert encode_skel(again) == data
    diffs = diff_documents(again, doc, abs_tol=0, rel_tol=0, ignore=[EXTRA])
    # What differs is nonessential data only (region and slot colours are essential).
    assert diffs and all(d.path.split("/")[-1] in NONESSENTIAL for d in diffs), diffs[:5]
    assert not any(d.path.startswith("slots/") for d in diffs)


def test_json_layout_per_version(examples):
    d36 = read_skel(examples / "3.6/stretchyman/stretchyman-pro.skel")
    d38 = read_skel(examples / "3.8/stretchyman/stretchyman-pro.skel")
    # Skins: a name-keyed object before 3.8, a list of {name, attachments} in 3.8.
    assert isinstance(d36["skins"], dict) and "default" in d36["skins"]
    assert isinstance(d38["skins"], list) and d38["skins"][0]["name"] == "default"
    # Path constraint timelines: "paths" before 3.8, "path" in 3.8.
    assert any("paths" in a for a in read_skel(examples / "3.7/tank/tank-pro.skel")["animations"].values())
    assert any("path" in a for a in d38["animations"].values())
    # A bezier curve: a list of 4 before 3.8, "curve" plus c2, c3, c4 in 3.8.
    curves36 = [f["curve"] for f in _all_keys(d36) if isinstance(f.get("curve"), list)]
    curves38 = [f for f in _all_keys(d38) if isinstance(f.get("curve"), float)]
    assert curves36 and all(len(c) == 4 for c in curves36)
    assert curves38 and any("c3" in f or "c4" in f for f in curves38)
    # 3.6 and 3.7 keys hold their time and all bone values, as the editor writes them.
    rotate36 = d36["animations"]["sneak"]["bones"]
    assert all("time" in f and "angle" in f for tl in rotate36.values() for f in tl.get("rotate", []))
    # Nonessential data is kept: mesh hull, edges, size; bone colours.
    meshes = [a for atts in d38["skins"][0]["attachments"].values() for a in atts.values() if a.get("type") == "mesh"]
    assert meshes and all(m["hull"] > 2 and m["edges"] and m["width"] > 0 for m in meshes)
    assert any("color" in b for b in d36["bones"])


def _all_keys(doc: dict):
    """Every key of every curve timeline of a document."""
    for anim in doc["animations"].values():
        for group in ("slots", "bones", "paths", "path"):
            for timelines in anim.get(group, {}).values():
                for frames in timelines.values():
                    yield from frames
        for group in ("ik", "transform"):
            for frames in anim.get(group, {}).values():
                yield from frames


def test_string_table_kept_in_editor_order(examples):
    """The 3.8 editor does not number strings in first-use order; the reader keeps its
    table, so the bytes come back, and a document without it still writes a valid file."""
    data = (examples / "3.8/coin/coin-pro.skel").read_bytes()
    doc = read_skel(data)
    table = doc[EXTRA]["strings"]
    assert len(table) == len(set(table)) and "refs" not in doc[EXTRA]
    plain = {k: v for k, v in doc.items() if k != EXTRA}
    other = encode_skel(plain)
    assert other != data and len(other) == len(data)
    assert not diff_documents(read_skel(other), plain, abs_tol=0, rel_tol=0)


def test_string_table_with_duplicates_keeps_each_reference(examples):
    """The table may hold a string many times (tank: 272 entries, 26 strings); which copy
    each reference uses is kept, and only then."""
    data = (examples / "3.8/tank/tank-pro.skel").read_bytes()
    doc = read_skel(data)
    table = doc[EXTRA]["strings"]
    assert len(table) == 272 and len(set(table)) == 26 and doc[EXTRA]["refs"]
    assert encode_skel(doc) == data
    plain = {k: v for k, v in doc.items() if k != EXTRA}
    other = encode_skel(plain)
    assert len(other) < len(data)
    assert not diff_documents(read_skel(other), plain, abs_tol=0, rel_tol=0)


def test_events_and_audio(examples):
    """Event definitions and keys, with 3.7+ audio and keys' values left out when they
    equal their event's (as in the JSON)."""
    doc = read_skel(examples / "3.8/spineboy/spineboy-pro.skel")
    assert "footstep" in doc["events"]
    keys = [f for a in doc["animations"].values() for f in a.get("events", [])]
    assert keys and all(f["name"] in doc["events"] for f in keys)
    assert doc["skeleton"]["audio"] == "" and doc["skeleton"]["images"] == "./images/"
    assert "audio" not in read_skel(examples / "3.6/spineboy/spineboy-pro.skel")["skeleton"]


def test_default_skin_anywhere_in_json(examples):
    """The binary holds the default skin first; a JSON object may list it anywhere."""
    doc = editor_json(examples / "3.6/goblins/goblins-pro.json")
    doc["skins"] = {k: doc["skins"][k] for k in ("goblin", "default", "goblingirl")}
    again = read_skel(encode_skel(doc))
    assert list(again["skins"]) == ["default", "goblin", "goblingirl"]
    assert not diff_documents(again, doc, abs_tol=1e-4, rel_tol=1e-6)


def test_examples_present_or_skipped():
    # Guard against a silently empty parametrisation when the data is present.
    if EXAMPLES.is_dir():
        assert len(PAIRS) == 60


# -- errors ---------------------------------------------------------------------------

@pytest.fixture(scope="module", params=["3.6", "3.7", "3.8"])
def spineboy3(examples, request) -> bytes:
    return (examples / request.param / "spineboy/spineboy-pro.skel").read_bytes()


@pytest.mark.parametrize("cut", [0, 3, 20, 40, 100, 1000, 20000, -1])
def test_truncated_file_names_offset_and_expectation(spineboy3, cut):
    check_truncation_says_where_and_what(spineboy3[:cut])


def test_every_truncation_is_a_format_error(examples):
    """No prefix of a real file escapes as another exception (a small file, every cut)."""
    data = (examples / "3.8/vine/vine-pro.skel").read_bytes()
    for cut in range(0, len(data), max(1, len(data) // 400)):
        with pytest.raises(SkelFormatError):
            read_skel(data[:cut])


def test_corrupted_bytes_are_format_errors(spineboy3):
    """Flipped bytes either still read (a different number) or raise the one error type."""
    import random

    rng = random.Random(3)
    for _ in range(150):
        data = bytearray(spineboy3)
        for _ in range(3):
            data[rng.randrange(len(data))] = rng.randrange(256)
        try:
            read_skel(bytes(data))
        except SkelFormatError as e:
            assert e.offset is not None and "expected" in e.message


def test_trailing_bytes_are_an_error(spineboy3):
    check_trailing_bytes_refused(spineboy3)


def _with_version(data: bytes, version: str) -> bytes:
    # 3.x header: the hash as a string (one length byte here), then the version string.
    n = data[0]
    v = data[n]
    raw = version.encode()
    return data[:n] + bytes([len(raw) + 1]) + raw + data[n + v:]


@pytest.mark.parametrize("version", ["3.4.02", "3.3.07", "3.9.0", "3.x"])
def test_unsupported_version(spineboy3, version):
    with pytest.raises(SkelFormatError, match="expected") as e:
        read_skel(_with_version(spineboy3, version))
    assert e.value.offset is not None


def test_writer_rejects_broken_documents(examples):
    def editor() -> dict:
        return editor_json(examples / "3.7/spineboy/spineboy-pro.json")

    doc = editor()
    doc["slots"][0]["bone"] = "no-such-bone"
    with pytest.raises(SkelFormatError, match="no-such-bone"):
        encode_skel(doc)
    doc = editor()
    doc["skeleton"]["spine"] = "3.4.0"
    with pytest.raises(SkelFormatError, match="3.4.0"):
        encode_skel(doc)
    doc = editor()
    doc["bones"][1]["x"] = "left"
    with pytest.raises(SkelFormatError, match="x"):
        encode_skel(doc)
    doc = editor()
    mesh = next(a for atts in doc["skins"]["default"].values() for a in atts.values() if a.get("type") == "mesh")
    mesh["uvs"] = mesh["uvs"][:-2]
    with pytest.raises(SkelFormatError):
        encode_skel(doc)


def test_writer_refuses_a_weighted_vertex_on_a_bone_past_the_last(examples):
    """The 3.x writer checks a weighted vertex's bone as the reader does (the one writer of
    weighted vertices, shared with 4.x): a file naming bone 999 of 60 is never written."""
    doc = editor_json(examples / "3.7/spineboy/spineboy-pro.json")
    mesh = next(a for atts in doc["skins"]["default"].values() for a in atts.values()
                if a.get("type") == "mesh" and len(a["vertices"]) != len(a["uvs"]))
    mesh["vertices"][1] = 999  # the first vertex's first bone
    with pytest.raises(SkelFormatError, match=f"bone index below {len(doc['bones'])} in weighted vertices, got 999"):
        encode_skel(doc)


# -- real game exports ---------------------------------------------------------------------

#: The 3.x versions the binary codec reads and writes; other 3.x exports in the corpus (none
#: at present) are skipped by this rule, and counted.
READ_3X = ("3.5", "3.6", "3.7", "3.8")


def _read_by_rule(version: str) -> bool:
    """Whether the codec reads ``version``; editor downgrades ("3.8-from-4.0.64") count as 3.8."""
    m = re.match(r"(\d+\.\d+)", version)
    return bool(m) and m.group(1) in READ_3X


def _corpus_binaries(root: Path) -> tuple[list[Path], list[Path]]:
    """The corpus' 3.x binaries: (read by the codec, skipped by :data:`READ_3X`)."""
    from spinemesh.skeleton import is_binary_skeleton

    read, skipped = [], []
    for p in sorted(root.rglob("*")):
        name = p.name.lower()
        if p.is_file() and name.endswith((".skel", ".bytes", ".json")) and not name.endswith(".source.json"):
            if is_binary_skeleton(p) and (version := sniff_version(p.read_bytes())).startswith("3."):
                (read if _read_by_rule(version) else skipped).append(p)
    return read, skipped


def test_corpus_binaries_round_trip(corpus):
    """The game projects' 3.x binaries, with or without nonessential data, read, write back
    byte for byte, and survive a trip through JSON text."""
    files, skipped = _corpus_binaries(corpus)
    assert len(files) >= 2
    print(f"{len(files)} corpus 3.x binaries read, {len(skipped)} skipped (version not in {READ_3X})")
    for path in files:
        data = path.read_bytes()
        doc = read_skel(data, path)
        assert encode_skel(doc) == data, path
        again = read_skel(encode_skel(json.loads(json.dumps(doc))))
        assert not diff_documents(again, doc, abs_tol=0, rel_tol=0), path


def _corpus_json(root: Path) -> tuple[list[tuple[Path, dict]], list[Path]]:
    """The corpus' 3.x JSON skeletons: (read by the codec, skipped by :data:`READ_3X`)."""
    from spinemesh.skeleton import is_binary_skeleton

    out, skipped = [], []
    for p in sorted(root.rglob("*.json")):
        if is_binary_skeleton(p):
            continue
        try:
            doc = json.loads(p.read_text(encoding="utf-8-sig"))
        except (ValueError, UnicodeDecodeError):
            continue
        version = str(doc.get("skeleton", {}).get("spine", "")) if isinstance(doc, dict) else ""
        if version.startswith("3."):
            if _read_by_rule(version):
                out.append((p, doc))
            else:
                skipped.append(p)
    return out, skipped


def test_corpus_json_writes_skel_that_reads_back(corpus):
    """Every 3.5-3.8 JSON of the game projects, editor downgrades such as ``3.8-from-4.0.64``
    included, writes a .skel that reads back to the same document."""
    docs, skipped = _corpus_json(corpus)
    assert len(docs) >= 40
    print(f"{len(docs)} corpus 3.x JSON skeletons written as .skel, {len(skipped)} skipped "
          f"(version not in {READ_3X}): {[p.parent.name for p in skipped]}")
    for path, doc in docs:
        again = read_skel(encode_skel(doc, path))
        diffs = diff_documents(again, doc, abs_tol=1e-4, rel_tol=1e-6)
        assert not diffs, (path, diffs[:5])

# -- the official runtime loads what we write (3.8: the runtime tool has no 3.6/3.7) ------

TIMES = "0,0.3,0.7"


@pytest.mark.parametrize("project,name,anim", [
    ("spineboy", "spineboy-pro", "run"), ("tank", "tank-pro", "drive"), ("raptor", "raptor-pro", "walk"),
    ("stretchyman", "stretchyman-pro", "sneak"), ("mix-and-match", "mix-and-match-pro", "dance"),
])
def test_runtime_poses_match(spine_runtime, examples, tmp_path, project, name, anim):
    """What we write loads in a 3.8 runtime and poses like the editor's export: our .skel
    from the editor's JSON like that JSON, our JSON from the editor's .skel exactly like
    that .skel."""
    folder = examples / "3.8" / project
    atlas = folder / f"{project}.atlas"
    ours_skel = tmp_path / f"{name}.skel"
    ours_skel.write_bytes(encode_skel(editor_json(folder / f"{name}.json")))
    ours_json = tmp_path / f"{name}.json"
    ours_json.write_text(json.dumps(read_skel(folder / f"{name}.skel")), encoding="utf-8")
    a = pose_dump(spine_runtime, atlas, folder / f"{name}.json", tmp_path / "a.json", anim, TIMES)
    b = pose_dump(spine_runtime, atlas, ours_skel, tmp_path / "b.json", anim, TIMES)
    assert max_difference(a, b) < 0.01  # float32 rounding of the JSON's decimals
    c = pose_dump(spine_runtime, atlas, folder / f"{name}.skel", tmp_path / "c.json", anim, TIMES)
    d = pose_dump(spine_runtime, atlas, ours_json, tmp_path / "d.json", anim, TIMES)
    assert max_difference(c, d) == 0.0


@pytest.mark.parametrize("version, curve, drawn", [
    ("3.7.94", {"curve": 0.9, "c2": 0, "c3": 1, "c4": 1}, "linear"),  # 3.7's readers pass a number over
    ("3.7.94", {"curve": "linear"}, "linear"),
    ("3.6.53", {"curve": [0.9, 0, 1, 1]}, "bezier"),
    ("3.8.99", {"curve": "linear"}, "stepped"),                      # 3.8's readers step on any text
    ("3.8.99", {"curve": [0.9, 0, 1, 1]}, "linear"),                 # 3.8's readers refuse a list
    ("3.8.99", {"curve": 0.9}, "bezier"),
])
def test_a_json_curve_is_written_as_its_versions_runtime_draws_it(version, curve, drawn):
    """A made 3.x document written as ``.skel``: each key's curve is the one the version's runtime
    draws reading the JSON, so the binary poses as the JSON does (the sampler reads both alike)."""
    from spinemesh.anim import Sampler

    skins = [{"name": "default", "attachments": {}}] if version.startswith("3.8") else {"default": {}}
    doc = {"skeleton": {"spine": version, "hash": "made"}, "bones": [{"name": "root"}], "slots": [], "skins": skins,
           "animations": {"move": {"bones": {"root": {"translate": [{"time": 0, "x": 0, **curve},
                                                                    {"time": 1, "x": 10}]}}}}}
    back = read_skel(encode_skel(doc))
    key = back["animations"]["move"]["bones"]["root"]["translate"][0]
    got = ("linear" if "curve" not in key else "stepped" if key["curve"] == "stepped" else "bezier")
    assert got == drawn, key
    x = [Sampler(d).pose("move", 0.25).bone("root")[0, 2] for d in (doc, back)]
    assert x[0] == pytest.approx(x[1], abs=1e-5), x
