"""Binary ``.skel`` of Spine 4.0, 4.1 and 4.2 against the editor's own exports.

Every ``.skel`` in ``../shared/spine-examples/4.x`` has a ``.json`` twin exported from the
same project state. For each pair:

- reading the ``.skel`` and writing it back gives the same bytes;
- the document read from the ``.skel`` equals the JSON, up to the editor's rounding and
  left-out defaults, except for the differences listed in :data:`KNOWN`, each one a place
  where the two exports really hold different information;
- the JSON document written as ``.skel`` reads back to the same document.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version
from spinemesh.skeleton_binary.compare import diff_documents
from spinemesh.skeleton_binary.enums import EXTRA

from binary_pairs import (check_document_equals_editor_json, check_json_writes_a_skel_that_reads_back,
                          check_round_trip, check_survives_json_text, check_trailing_bytes_refused,
                          check_truncation_says_where_and_what)
from conftest import EXAMPLES, skel_json_pairs
from runtime_tool import max_difference, pose_dump

PAIRS = [p for v in ("4.0", "4.1", "4.2") for p in skel_json_pairs(v)]
IDS = [f"{s.parts[-3]}/{s.name}" for s, _ in PAIRS]


def _one_bone_ik(doc: dict, path: str) -> bool:
    i = int(path.split("/")[1])
    return len(doc["ik"][i]["bones"]) == 1


#: Differences that remain because the two exports hold different information:
#: (version, file, path pattern, condition on the .skel document, reason).
KNOWN = [
    ("4.2", "*", "bones/*/visible", None,
     "The binary's nonessential data keeps bones hidden in the editor (visible false, 102 "
     "bones); none of the 26 JSON exports of 4.2.22 writes bone visibility."),
    ("4.*", "spineboy-pro.skel", "ik/*/bendPositive", _one_bone_ik,
     "The binary keeps the bend direction of one-bone IK constraints, where it has no effect; "
     "the JSON leaves it out for them."),
    ("4.1", "hero-pro.skel", "skeleton/hash", None,
     "The two exports were not written from the same editor state: their skins list the same "
     "bone sets in different orders (compared as sets here), and their hashes differ."),
    ("4.1", "mix-and-match-pro.skel", "skeleton/hash", None, "As for hero-pro.skel."),
    ("4.2", "raptor-pro.skel", "animations/gun-holster/ik/spineboy-front-arm-ik/0/curve", None,
     "The JSON has a stepped curve between two keys of equal value (mix 0 to 0); the binary "
     "has a linear one: the same motion."),
]


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_round_trip_is_byte_identical(skel: Path, js: Path):
    check_round_trip(skel)


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_document_equals_editor_json(skel: Path, js: Path):
    check_document_equals_editor_json(skel, js, KNOWN)


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_json_document_writes_a_skel_that_reads_back(skel: Path, js: Path):
    check_json_writes_a_skel_that_reads_back(js, binary_only=frozenset({"strings", "refs", "timelines"}))


@pytest.mark.parametrize("skel,js", PAIRS[::7], ids=IDS[::7])
def test_document_survives_json_text(skel: Path, js: Path):
    check_survives_json_text(skel)


def test_json_layout_per_version(examples):
    d40 = read_skel(examples / "4.0/spineboy/spineboy-pro.skel")
    d41 = read_skel(examples / "4.1/spineboy/spineboy-pro.skel")
    d42 = read_skel(examples / "4.2/spineboy/spineboy-pro.skel")
    # 4.0 keeps deform timelines apart; 4.1 puts them under "attachments".
    assert any("deform" in a for a in d40["animations"].values())
    assert not any("attachments" in a for a in d40["animations"].values())
    assert any("attachments" in a for a in d41["animations"].values())
    # 4.2 names a bone's inheritance "inherit", earlier versions "transform".
    assert any("inherit" in b for b in read_skel(examples / "4.2/stretchyman/stretchyman-pro.skel")["bones"])
    assert any("transform" in b for b in read_skel(examples / "4.1/stretchyman/stretchyman-pro.skel")["bones"])
    assert d42["skeleton"]["spine"].startswith("4.2") and d42["skeleton"]["hash"] == "dr3Kr/vMgPA"
    # Nonessential data is kept: mesh hull, edges, size; bone colours.
    mesh = d42["skins"][0]["attachments"]["eye"]["eye-indifferent"]
    assert mesh["type"] == "mesh" and mesh["hull"] == 4 and mesh["edges"] and mesh["width"] == 93


def test_physics_and_sequences_read(examples):
    circus = read_skel(examples / "4.2/celestial-circus/celestial-circus-pro.skel")
    assert len(circus["physics"]) > 10 and all("bone" in p for p in circus["physics"])
    dragon = read_skel(examples / "4.2/dragon/dragon-ess.skel")
    seqs = [f for a in dragon["animations"].values() for sk in a.get("attachments", {}).values()
            for sl in sk.values() for h in sl.values() for f in h.get("sequence", [])]
    assert seqs and {f.get("mode", "hold") for f in seqs} >= {"loop"}


# -- errors ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def spineboy42(examples) -> bytes:
    return (examples / "4.2/spineboy/spineboy-pro.skel").read_bytes()


@pytest.mark.parametrize("cut", [0, 5, 8, 20, 100, 1000, 20000, -1])
def test_truncated_file_names_offset_and_expectation(spineboy42, cut):
    check_truncation_says_where_and_what(spineboy42[:cut])


def test_trailing_bytes_are_an_error(spineboy42):
    check_trailing_bytes_refused(spineboy42)


def _with_version(data: bytes, version: str) -> bytes:
    n = data[8] - 1
    raw = version.encode()
    return data[:8] + bytes([len(raw) + 1]) + raw + data[9 + n:]


@pytest.mark.parametrize("version", ["4.4.0", "4.5.0", "5.0.1", "4.x"])
def test_unsupported_version(spineboy42, version):
    with pytest.raises(SkelFormatError, match="expected") as e:
        read_skel(_with_version(spineboy42, version))
    assert e.value.offset is not None


def test_writer_rejects_unknown_references(examples):
    doc = json.loads((examples / "4.2/spineboy/spineboy-pro.json").read_text(encoding="utf-8"))
    doc["slots"][0]["bone"] = "no-such-bone"
    with pytest.raises(SkelFormatError, match="no-such-bone"):
        encode_skel(doc)
    doc = json.loads((examples / "4.2/spineboy/spineboy-pro.json").read_text(encoding="utf-8"))
    doc["skeleton"]["spine"] = "4.4.0"
    with pytest.raises(SkelFormatError, match="4.4.0"):
        encode_skel(doc)


def test_writer_checks_mesh_triangle_count(examples):
    doc = json.loads((examples / "4.2/spineboy/spineboy-pro.json").read_text(encoding="utf-8"))
    mesh = doc["skins"][0]["attachments"]["eye"]["eye-indifferent"]
    mesh["triangles"] = mesh["triangles"][:-3]
    with pytest.raises(SkelFormatError, match="triangles"):
        encode_skel(doc)


def test_strings_are_refs_with_duplicates_kept(examples):
    """The editor's string table can hold a string twice; the reader keeps which copy each
    reference used, so the bytes come back."""
    data = (examples / "4.2/tank/tank-pro.skel").read_bytes()
    doc = read_skel(data)
    table = doc[EXTRA]["strings"]
    assert len(table) > len(set(table))
    assert encode_skel(doc) == data
    # Without the binary-only data the file is different but reads to the same document.
    plain = {k: v for k, v in doc.items() if k != EXTRA}
    other = encode_skel(plain)
    assert other != data
    assert not diff_documents(read_skel(other), plain, abs_tol=0, rel_tol=0, ignore=[EXTRA])


def test_float32_values_are_exact(spineboy42):
    doc = read_skel(spineboy42)
    x = doc["skeleton"]["x"]
    assert struct.unpack(">f", struct.pack(">f", x))[0] == x


def test_examples_present_or_skipped():
    # Guard against a silently empty parametrisation when the data is present.
    if EXAMPLES.is_dir():
        assert len(PAIRS) == 69


# -- spinemesh convert ------------------------------------------------------------------

def _cli(*args: str):
    import os
    import subprocess
    import sys

    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", "convert", *args],
                          capture_output=True, text=True, env=env)


def test_convert_skel_to_json_and_back(examples, tmp_path):
    src = examples / "4.1/goblins/goblins-pro.skel"
    out_json, out_skel = tmp_path / "g.json", tmp_path / "g.skel"
    r = _cli(str(src), str(out_json))
    assert r.returncode == 0, r.stderr
    doc = json.loads(out_json.read_text(encoding="utf-8"))
    assert EXTRA not in doc and doc["skeleton"]["spine"] == "4.1.17"
    # Shortest float32 decimals, not float64 expansions.
    assert all(len(repr(v)) <= 16 for v in doc["skeleton"].values() if isinstance(v, float))
    editor = json.loads(src.with_suffix(".json").read_text(encoding="utf-8"))
    assert not diff_documents(doc, editor)
    r = _cli(str(out_json), str(out_skel))
    assert r.returncode == 0, r.stderr
    # Every float32 comes back exactly: the same document as the original .skel gives.
    assert not diff_documents(read_skel(out_skel), read_skel(src), abs_tol=0, rel_tol=0, ignore=[EXTRA])


def test_convert_keeps_bytes_with_binary_info(examples, tmp_path):
    src = examples / "4.2/mix-and-match/mix-and-match-pro.skel"
    r = _cli(str(src), str(tmp_path / "m.json"), "--keep-binary-info")
    assert r.returncode == 0, r.stderr
    r = _cli(str(tmp_path / "m.json"), str(tmp_path / "m.skel"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "m.skel").read_bytes() == src.read_bytes()


@pytest.mark.parametrize("name", ["4.2/raptor/raptor-pro.skel", "3.6/hero/hero-pro.skel"])
def test_convert_keeps_negative_zeros(examples, tmp_path, name):
    """A .skel may hold -0.0 (these two do, and the editor's JSON never writes one): convert
    writes it so, and the JSON (with the string table kept) converts back to the same bytes."""
    src = examples / name
    assert _cli(str(src), str(tmp_path / "a.json"), "--keep-binary-info").returncode == 0
    assert "-0.0" in (tmp_path / "a.json").read_text(encoding="utf-8")
    assert _cli(str(tmp_path / "a.json"), str(tmp_path / "a.skel")).returncode == 0
    assert (tmp_path / "a.skel").read_bytes() == src.read_bytes()


def test_convert_editor_json_to_skel(examples, tmp_path):
    src = examples / "4.0/raptor/raptor-pro.json"
    r = _cli(str(src), str(tmp_path / "r.skel"))
    assert r.returncode == 0, r.stderr
    assert not diff_documents(read_skel(tmp_path / "r.skel"), json.loads(src.read_text(encoding="utf-8")),
                              abs_tol=1e-4, rel_tol=1e-6)


def test_convert_errors_are_one_line(examples, tmp_path):
    bad = tmp_path / "bad.skel"
    bad.write_bytes((examples / "4.2/owl/owl-pro.skel").read_bytes()[:300])
    r = _cli(str(bad), str(tmp_path / "x.json"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "bad.skel" in r.stderr and "byte" in r.stderr and "expected" in r.stderr
    assert not (tmp_path / "x.json").exists()
    r = _cli(str(examples / "4.2/owl/owl-pro.skel"), str(tmp_path / "x.txt"))
    assert r.returncode == 2 and ".json" in r.stderr


# -- the official runtime loads what we write ---------------------------------------------

@pytest.mark.parametrize("version,project,name,anim", [
    ("4.0", "tank", "tank-pro", "drive"), ("4.1", "mix-and-match", "mix-and-match-pro", "walk"),
    ("4.2", "celestial-circus", "celestial-circus-pro", "swing"), ("4.2", "spineboy", "spineboy-pro", "run"),
])
def test_official_runtime_poses_match(spine_runtime, examples, tmp_path, version, project, name, anim):
    """What we write loads in the official runtime and poses like the editor's export:
    our .skel from the editor's JSON like that JSON, our JSON from the editor's .skel like
    that .skel (exactly: no value changes on the way)."""
    folder = examples / version / project
    atlas = folder / f"{project}.atlas"
    ours_skel = tmp_path / f"{name}.skel"
    ours_skel.write_bytes(encode_skel(json.loads((folder / f"{name}.json").read_text(encoding="utf-8"))))
    ours_json = tmp_path / f"{name}.json"
    ours_json.write_text(json.dumps(read_skel(folder / f"{name}.skel")), encoding="utf-8")
    a = pose_dump(spine_runtime, atlas, folder / f"{name}.json", tmp_path / "a.json", anim)
    b = pose_dump(spine_runtime, atlas, ours_skel, tmp_path / "b.json", anim)
    assert max_difference(a, b) < 0.01  # float32 rounding of the JSON's decimals
    c = pose_dump(spine_runtime, atlas, folder / f"{name}.skel", tmp_path / "c.json", anim)
    d = pose_dump(spine_runtime, atlas, ours_json, tmp_path / "d.json", anim)
    assert max_difference(c, d) == 0.0


# -- real game exports ---------------------------------------------------------------------

def _corpus_binaries(root: Path) -> list[Path]:
    from spinemesh.skeleton import is_binary_skeleton

    out = []
    for p in sorted(root.rglob("*")):
        name = p.name.lower()
        if p.is_file() and name.endswith((".skel", ".skel.bytes", ".json")) and not name.endswith(".source.json"):
            if is_binary_skeleton(p) and sniff_version(p.read_bytes()).startswith("4."):
                out.append(p)
    return out


def test_corpus_binaries_round_trip(corpus):
    """The game projects' 4.x binaries (some named .json or .skel.bytes, as Unity ships
    them) read, write back byte for byte, and survive a trip through JSON."""
    files = _corpus_binaries(corpus)
    assert len(files) >= 5
    for path in files:
        data = path.read_bytes()
        doc = read_skel(data, path)
        assert encode_skel(doc) == data, path
        plain = {k: v for k, v in doc.items() if k != EXTRA}
        again = read_skel(encode_skel(json.loads(json.dumps(plain))))
        assert not diff_documents(again, plain, abs_tol=0, rel_tol=0, ignore=[EXTRA]), path


# -- the comparison helper itself -----------------------------------------------------------

def test_compare_rounding_and_defaults():
    a = {"bones": [{"name": "b", "x": 10.004, "scaleX": 1.0, "length": 2000.9}],
         "transform": [{"name": "t", "mixX": 0.5, "mixY": 0.5}],
         "skins": [{"name": "s", "bones": ["b", "c"]}]}
    b = {"bones": [{"name": "b", "x": 10, "length": 2001.9}],          # rel 5e-4 on length
         "transform": [{"name": "t", "mixX": 0.5}],                     # mixY defaults to mixX
         "skins": [{"name": "s", "bones": ["c", "b"]}]}                 # a skin's bones are a set
    assert diff_documents(a, b) == []
    b["bones"][0]["x"] = 10.02
    b["transform"][0]["mixY"] = 0.4
    assert {d.path for d in diff_documents(a, b)} == {"bones/0/x", "transform/0/mixY"}
    assert [d.path for d in diff_documents(a, b, ignore=["bones/*/x"])] == ["transform/0/mixY"]


def test_compare_keyframe_defaults():
    anim = {"attachments": {"default": {"s": {"a": {
        "deform": [{"offset": 2, "vertices": [1.0, 0.004]}],
        "sequence": [{"delay": 0.1}, {"time": 1}]}}}},
        "events": [{"name": "e", "int": 3}]}
    left = {"events": {"e": {"int": 3}}, "animations": {"x": anim}}
    right = json.loads(json.dumps(left))
    frame = right["animations"]["x"]["attachments"]["default"]["s"]["a"]
    frame["deform"][0] = {"vertices": [0, 0, 1.0]}   # same offsets, spelt differently
    frame["sequence"][1]["delay"] = 0.1              # the previous key's delay is the default
    del right["animations"]["x"]["events"][0]["int"]  # an event key's int defaults to its event's
    assert diff_documents(left, right) == []


NONESSENTIAL = {"color", "icon", "visible", "edges", "width", "height", "images", "audio", "fps"}


@pytest.mark.parametrize("skel,js", PAIRS[::5], ids=IDS[::5])
def test_without_nonessential_data(skel: Path, js: Path):
    """All examples carry nonessential data; a file without it (the editor's export option)
    drops exactly that data, and round-trips."""
    editor = json.loads(js.read_text(encoding="utf-8"))
    editor[EXTRA] = {"nonessential": False}
    data = encode_skel(editor)
    doc = read_skel(data)
    assert doc[EXTRA] == {"nonessential": False}
    assert encode_skel(doc) == data
    diffs = diff_documents(doc, editor, abs_tol=1e-4, rel_tol=1e-6, ignore=[EXTRA])
    assert diffs and all(d.path.rsplit("/", 1)[-1] in NONESSENTIAL for d in diffs), diffs[:10]
    # Region sizes are essential: every region keeps its width and height.
    regions = [a for sk in doc["skins"] for sl in sk.get("attachments", {}).values() for a in sl.values()
               if a.get("type", "region") == "region"]
    assert regions and all("width" in a and "height" in a for a in regions)


@pytest.mark.parametrize("given", ["gen-h1-1784752710547", "dGludA", "not base64!", 12345])
def test_writer_refuses_a_hash_a_skel_cannot_hold(given):
    """A 4.x .skel holds the editor's 8-byte hash; other tools write other strings there
    (`gen-h1-...`), which were refused as "Incorrect padding". The line says what to do."""
    doc = {"skeleton": {"hash": given, "spine": "4.2.40"}, "bones": [{"name": "root"}]}
    with pytest.raises(SkelFormatError, match=r"hash of 8 bytes in base64.*remove the hash"):
        encode_skel(doc)
    doc["skeleton"]["hash"] = "itfFESDjM+Q"
    assert read_skel(encode_skel(doc))["skeleton"]["hash"] == "itfFESDjM+Q"
    del doc["skeleton"]["hash"]
    assert read_skel(encode_skel(doc))["bones"] == [{"name": "root"}]
