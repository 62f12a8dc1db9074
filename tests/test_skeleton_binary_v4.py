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

import fnmatch
import json
import struct
from pathlib import Path

import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton_binary import read_skel, sniff_version, write_skel
from spinemesh.skeleton_binary.compare import diff_documents
from spinemesh.skeleton_binary.v4 import EXTRA

from conftest import EXAMPLES, skel_json_pairs

PAIRS = [p for v in ("4.0", "4.1", "4.2") for p in skel_json_pairs(v)]
IDS = [f"{s.parts[-3]}/{s.name}" for s, _ in PAIRS]


def _one_bone_ik(doc: dict, path: str) -> bool:
    i = int(path.split("/")[1])
    return len(doc["ik"][i]["bones"]) == 1


#: Differences that remain because the two exports hold different information:
#: (version, file, path pattern, condition on the .skel document, reason).
KNOWN = [
    ("4.2", "*", "bones/*/visible", None,
     "The binary's nonessential data keeps bones hidden in the editor (visible false); the "
     "4.2 editor's JSON export does not write bone visibility at all."),
    ("4.*", "spineboy-pro.skel", "ik/*/bendPositive", _one_bone_ik,
     "The binary keeps the bend direction of one-bone IK constraints, where it has no effect; "
     "the JSON leaves it out for them."),
    ("4.1", "hero-pro.skel", "skeleton/hash", None,
     "The two exports come from different editor sessions: the skins' bone sets are listed in "
     "another order, and the hash, computed over the data, differs with it."),
    ("4.1", "mix-and-match-pro.skel", "skeleton/hash", None, "As for hero-pro.skel."),
    ("4.2", "raptor-pro.skel", "animations/gun-holster/ik/spineboy-front-arm-ik/0/curve", None,
     "The JSON has a stepped curve between two keys of equal value (mix 0 to 0); the binary "
     "has a linear one: the same motion."),
]


def _known(version: str, name: str, doc: dict, path: str) -> bool:
    for v, f, pattern, condition, _reason in KNOWN:
        if fnmatch.fnmatchcase(version, v) and fnmatch.fnmatchcase(name, f) \
                and fnmatch.fnmatchcase(path, pattern) and (condition is None or condition(doc, path)):
            return True
    return False


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_round_trip_is_byte_identical(skel: Path, js: Path):
    data = skel.read_bytes()
    assert write_skel(read_skel(data, skel)) == data


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_document_equals_editor_json(skel: Path, js: Path):
    doc = read_skel(skel)
    editor = json.loads(js.read_text(encoding="utf-8-sig"))
    version = skel.parts[-3]
    diffs = diff_documents(doc, editor, ignore=[EXTRA], limit=100_000)
    unexplained = [d for d in diffs if not _known(version, skel.name, doc, d.path)]
    assert not unexplained, "\n".join(map(str, unexplained[:30]))
    # Entries tied to this very file must still be needed: the list does not rot.
    for v, f, pattern, _c, _r in KNOWN:
        if f == skel.name and fnmatch.fnmatchcase(version, v):
            assert any(fnmatch.fnmatchcase(d.path, pattern) for d in diffs), f"{pattern} no longer differs"


@pytest.mark.parametrize("skel,js", PAIRS, ids=IDS)
def test_json_document_writes_a_skel_that_reads_back(skel: Path, js: Path):
    editor = json.loads(js.read_text(encoding="utf-8-sig"))
    data = write_skel(editor)
    again = read_skel(data)
    assert EXTRA not in again or set(again[EXTRA]) <= {"strings", "refs", "timelines"}
    # Only float32 rounding separates the two.
    diffs = diff_documents(again, editor, abs_tol=1e-4, rel_tol=1e-6, ignore=[EXTRA])
    assert not diffs, "\n".join(map(str, diffs[:30]))
    # And that .skel is itself stable.
    assert write_skel(again) == data
    assert sniff_version(data) == editor["skeleton"]["spine"]


@pytest.mark.parametrize("skel,js", PAIRS[::7], ids=IDS[::7])
def test_document_survives_json_text(skel: Path, js: Path):
    """A document read from .skel, saved as JSON text with its binary-only data and loaded
    again, still writes the original bytes."""
    data = skel.read_bytes()
    text = json.dumps(read_skel(data))
    assert write_skel(json.loads(text)) == data


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
    data = spineboy42[:cut]
    with pytest.raises(SkelFormatError) as e:
        read_skel(data, "spineboy-pro.skel")
    assert e.value.offset is not None and 0 <= e.value.offset <= len(data)
    assert "expected" in e.value.message and e.value.path == "spineboy-pro.skel"


def test_trailing_bytes_are_an_error(spineboy42):
    with pytest.raises(SkelFormatError, match="end of file") as e:
        read_skel(spineboy42 + b"\0")
    assert e.value.offset == len(spineboy42)


def _with_version(data: bytes, version: str) -> bytes:
    n = data[8] - 1
    raw = version.encode()
    return data[:8] + bytes([len(raw) + 1]) + raw + data[9 + n:]


@pytest.mark.parametrize("version", ["4.3.39", "4.5.0", "5.0.1", "4.x"])
def test_unsupported_version(spineboy42, version):
    with pytest.raises(SkelFormatError, match="expected") as e:
        read_skel(_with_version(spineboy42, version))
    assert e.value.offset is not None


def test_writer_rejects_unknown_references(examples):
    doc = json.loads((examples / "4.2/spineboy/spineboy-pro.json").read_text(encoding="utf-8"))
    doc["slots"][0]["bone"] = "no-such-bone"
    with pytest.raises(SkelFormatError, match="no-such-bone"):
        write_skel(doc)
    doc = json.loads((examples / "4.2/spineboy/spineboy-pro.json").read_text(encoding="utf-8"))
    doc["skeleton"]["spine"] = "4.3.0"
    with pytest.raises(SkelFormatError, match="4.3.0"):
        write_skel(doc)


def test_writer_checks_mesh_triangle_count(examples):
    doc = json.loads((examples / "4.2/spineboy/spineboy-pro.json").read_text(encoding="utf-8"))
    mesh = doc["skins"][0]["attachments"]["eye"]["eye-indifferent"]
    mesh["triangles"] = mesh["triangles"][:-3]
    with pytest.raises(SkelFormatError, match="triangles"):
        write_skel(doc)


def test_strings_are_refs_with_duplicates_kept(examples):
    """The editor's string table can hold a string twice; the reader keeps which copy each
    reference used, so the bytes come back."""
    data = (examples / "4.2/tank/tank-pro.skel").read_bytes()
    doc = read_skel(data)
    table = doc[EXTRA]["strings"]
    assert len(table) > len(set(table))
    assert write_skel(doc) == data
    # Without the binary-only data the file is different but reads to the same document.
    plain = {k: v for k, v in doc.items() if k != EXTRA}
    other = write_skel(plain)
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
