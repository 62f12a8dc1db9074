"""Binary ``.skel`` of Spine 3.5, read and written by the 3.x declarations.

No official 3.5 binary is in ``../shared`` and none may be copied into this repository; no
official 3.5 runtime runs here either (the runtime harness starts at 3.8). So:

- the reading order is proven against the 3.5 runtime's (``SkeletonBinary`` of spine-libgdx,
  branch 3.5) by a file encoded here field by field, independently of the codec, in that
  order: every structure 3.5 has, each field a value of its own, so a field read in the wrong
  place or skipped reads back as another value or as an error;
- the game projects' 3.5 JSON skeletons (``../shared/spine-corpus``) are written as ``.skel``
  by our writer, read back, converted both ways and upgraded as a binary project;
- ``scripts/prove_skel35.py`` proves any folder of 3.5 binaries (the official examples, from
  the history of EsotericSoftware/spine-runtimes: 36 files, all byte-exact; see
  docs/guide/mesh.md).
"""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton import iter_attachments, load_skeleton
from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version
from spinemesh.skeleton_binary.compare import diff_documents
from spinemesh.skeleton_binary.enums import EXTRA

from conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))

from prove_skel35 import upgrades_differ  # noqa: E402


# -- a file encoded in the 3.5 runtime's reading order -------------------------------------

class Encoder:
    """The primitives of the format, written out by hand: varints (7 bits a byte, low first;
    signed ones zigzag), strings (byte length + 1, 0 for null), big-endian floats and ints."""

    def __init__(self):
        self.out = bytearray()

    def varint(self, n: int, signed: bool = False) -> "Encoder":
        n = ((n << 1) ^ (n >> 31)) & 0xFFFFFFFF if signed else n
        while n >= 0x80:
            self.out.append(n & 0x7F | 0x80)
            n >>= 7
        self.out.append(n)
        return self

    def string(self, s: str | None) -> "Encoder":
        if s is None:
            return self.varint(0)
        raw = s.encode()
        self.varint(len(raw) + 1)
        self.out += raw
        return self

    def floats(self, *xs: float) -> "Encoder":
        self.out += struct.pack(f">{len(xs)}f", *xs)
        return self

    def rgba(self, hex8: str) -> "Encoder":
        self.out += bytes.fromhex(hex8)
        return self

    def byte(self, *bs: int) -> "Encoder":
        self.out += struct.pack(f">{len(bs)}b", *bs)
        return self

    def shorts(self, *xs: int) -> "Encoder":
        self.varint(len(xs))
        self.out += struct.pack(f">{len(xs)}H", *xs)
        return self


def encode_35(nonessential: bool) -> bytes:
    """A 3.5 file with every structure of the format, in the runtime's reading order."""
    e = Encoder()
    ne = nonessential
    # Header: hash, version, size, nonessential flag, (fps, images path).
    e.string("fixture35").string("3.5.51").floats(64, 128).byte(1 if ne else 0)
    if ne:
        e.floats(24).string("./images/")
    # Bones: name, parent (not for the root), rotation, x, y, scale, shear, length, transform mode, (colour).
    e.varint(3)
    e.string("root").floats(0, 0, 0, 1, 1, 0, 0, 0).varint(0)
    if ne:
        e.rgba("9b9b9bff")
    e.string("hip").varint(0).floats(90, 1.5, -2.5, 0.5, 2, 3, -4, 40).varint(3)
    if ne:
        e.rgba("ff0000ff")
    e.string("target").varint(1).floats(0, 10, 0, 1, 1, 0, 0, 0).varint(1)
    if ne:
        e.rgba("9b9b9bff")
    # Slots: name, bone, colour, setup attachment, blend (no dark colour before 3.6).
    e.varint(2)
    e.string("body").varint(1).rgba("ff800080").string("body").varint(1)
    e.string("rail").varint(0).rgba("ffffffff").string(None).varint(0)
    # IK: name, order, bones, target, mix, bend direction.
    e.varint(1).string("reach").varint(0).varint(1).varint(1).varint(2).floats(0.5).byte(-1)
    # Transform: name, order, bones, target, offsets, mixes (no local/relative before 3.6).
    e.varint(1).string("follow").varint(1).varint(1).varint(2).varint(1)
    e.floats(5, 6, 7, 0.25, 0.75, 8, 0.5, 0.25, 0.125, 0)
    # Path: name, order, bones, target slot, position/spacing/rotate modes, values, mixes.
    e.varint(1).string("ride").varint(2).varint(1).varint(2).varint(1).varint(0).varint(2).varint(2)
    e.floats(15, 0.5, 2, 0.75, 0.5)
    # Default skin: per slot, per key, an attachment (name or null, type byte, fields).
    e.varint(2)
    e.varint(0).varint(3)
    e.string("body").string(None).byte(0).string("art/body").floats(30, 1, 2, 1.5, 0.5, 20, 10).rgba("ffffffff")
    e.string("hitbox").string("box").byte(1).varint(3).byte(0).floats(0, 0, 1, 0, 0, 1)
    if ne:
        e.rgba("60f000ff")
    e.string("shape").string(None).byte(2).string(None).rgba("ffffffff").varint(3)
    e.floats(0, 0, 1, 0, 0, 1).shorts(0, 1, 2).byte(1)
    e.varint(2).varint(1).floats(1, 2, 0.5).varint(2).floats(3, 4, 0.5)
    e.varint(1).varint(1).floats(5, 6, 1)
    e.varint(1).varint(2).floats(7, 8, 1)
    e.varint(3)
    if ne:
        e.shorts(0, 2, 2, 4, 4, 0).floats(16, 8)
    e.varint(1).varint(1)
    e.string("rail").string(None).byte(4).byte(1).byte(0).varint(6).byte(0)
    e.floats(*range(12)).floats(100, 200)
    if ne:
        e.rgba("00ff00ff")
    # Named skins: name, then as the default skin.
    e.varint(1).string("alt").varint(1).varint(0).varint(1)
    e.string("body").string(None).byte(3).string("art/body-alt").rgba("ffffffff").string(None).string("shape").byte(0)
    if ne:
        e.floats(16, 8)
    # Events: name, int (zigzag), float, string.
    e.varint(1).string("hit").varint(-3, signed=True).floats(0.5).string("boom")
    # One animation: slot, bone, IK, transform, path, deform, draw order and event timelines.
    e.varint(1).string("walk")
    e.varint(1).varint(0).varint(2)
    e.byte(1).varint(2).floats(0).rgba("ff000080").byte(1).floats(1).rgba("ffffffff")   # colour, stepped
    e.byte(0).varint(2).floats(0).string("shape").floats(0.5).string(None)             # attachment
    e.varint(1).varint(1).varint(4)
    e.byte(0).varint(2).floats(0, 10).byte(2).floats(0.25, 0, 0.75, 1).floats(1, -20)   # rotate, bezier
    e.byte(1).varint(1).floats(0, 1, 2)                                                 # translate
    e.byte(2).varint(1).floats(0, 1.5, 0.5)                                             # scale
    e.byte(3).varint(1).floats(0.25, 0, 5)                                              # shear
    e.varint(1).varint(0).varint(2).floats(0, 0.25).byte(1).byte(0).floats(1, 1).byte(-1)  # IK
    e.varint(1).varint(0).varint(1).floats(0, 0.5, 0.25, 0.125, 0)                      # transform
    e.varint(1).varint(0).varint(3)
    e.byte(0).varint(1).floats(0, 0.25)                                                 # position
    e.byte(1).varint(1).floats(0, 3)                                                    # spacing
    e.byte(2).varint(1).floats(0, 0.5, 0.75)                                            # mix
    e.varint(1).varint(0).varint(1).varint(0).varint(1).string("shape").varint(2)       # deform
    e.floats(0).varint(2).varint(1).floats(0.5, -0.5).byte(1).floats(1).varint(0)
    e.varint(1).floats(0.5).varint(1).varint(0).varint(1)                               # draw order
    e.varint(2)                                                                         # events
    e.floats(0.25).varint(0).varint(-3, signed=True).floats(1.5).byte(0)
    e.floats(0.75).varint(0).varint(7, signed=True).floats(0.5).byte(1).string("bang")
    return bytes(e.out)


def document_35(nonessential: bool) -> dict:
    """What :func:`encode_35` holds, as the 3.5 editor's JSON export lays it out."""
    ne = nonessential
    doc = {
        "skeleton": {"hash": "fixture35", "spine": "3.5.51", "width": 64.0, "height": 128.0,
                     **({"fps": 24.0, "images": "./images/"} if ne else {})},
        "bones": [
            {"name": "root"},
            {"name": "hip", "parent": "root", "length": 40.0, "rotation": 90.0, "x": 1.5, "y": -2.5,
             "scaleX": 0.5, "scaleY": 2.0, "shearX": 3.0, "shearY": -4.0, "transform": "noScale",
             **({"color": "ff0000ff"} if ne else {})},
            {"name": "target", "parent": "hip", "x": 10.0, "transform": "onlyTranslation"},
        ],
        "slots": [{"name": "body", "bone": "hip", "color": "ff800080", "attachment": "body", "blend": "additive"},
                  {"name": "rail", "bone": "root"}],
        "ik": [{"name": "reach", "order": 0, "bones": ["hip"], "target": "target", "mix": 0.5,
                "bendPositive": False}],
        "transform": [{"name": "follow", "order": 1, "bones": ["target"], "target": "hip", "rotation": 5.0,
                       "x": 6.0, "y": 7.0, "scaleX": 0.25, "scaleY": 0.75, "shearY": 8.0, "rotateMix": 0.5,
                       "translateMix": 0.25, "scaleMix": 0.125, "shearMix": 0.0}],
        "path": [{"name": "ride", "order": 2, "bones": ["target"], "target": "rail", "positionMode": "fixed",
                  "spacingMode": "percent", "rotateMode": "chainScale", "rotation": 15.0, "position": 0.5,
                  "spacing": 2.0, "rotateMix": 0.75, "translateMix": 0.5}],
        "skins": {
            "default": {
                "body": {
                    "body": {"path": "art/body", "rotation": 30.0, "x": 1.0, "y": 2.0, "scaleX": 1.5,
                             "scaleY": 0.5, "width": 20.0, "height": 10.0},
                    "hitbox": {"name": "box", "type": "boundingbox", "vertexCount": 3,
                               "vertices": [0.0, 0.0, 1.0, 0.0, 0.0, 1.0]},
                    "shape": {"type": "mesh", "uvs": [0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "triangles": [0, 1, 2],
                              "vertices": [2, 1, 1.0, 2.0, 0.5, 2, 3.0, 4.0, 0.5, 1, 1, 5.0, 6.0, 1.0,
                                           1, 2, 7.0, 8.0, 1.0],
                              "hull": 3, **({"edges": [0, 2, 2, 4, 4, 0], "width": 16.0, "height": 8.0}
                                            if ne else {})},
                },
                "rail": {"rail": {"type": "path", "closed": True, "constantSpeed": False, "vertexCount": 6,
                                  "vertices": [float(i) for i in range(12)], "lengths": [100.0, 200.0],
                                  **({"color": "00ff00ff"} if ne else {})}},
            },
            "alt": {"body": {"body": {"type": "linkedmesh", "path": "art/body-alt", "parent": "shape",
                                      "deform": False, **({"width": 16.0, "height": 8.0} if ne else {})}}},
        },
        "events": {"hit": {"int": -3, "float": 0.5, "string": "boom"}},
        "animations": {"walk": {
            "slots": {"body": {
                "color": [{"time": 0.0, "color": "ff000080", "curve": "stepped"}, {"time": 1.0, "color": "ffffffff"}],
                "attachment": [{"time": 0.0, "name": "shape"}, {"time": 0.5, "name": None}]}},
            "bones": {"hip": {
                "rotate": [{"time": 0.0, "angle": 10.0, "curve": [0.25, 0.0, 0.75, 1.0]},
                           {"time": 1.0, "angle": -20.0}],
                "translate": [{"time": 0.0, "x": 1.0, "y": 2.0}],
                "scale": [{"time": 0.0, "x": 1.5, "y": 0.5}],
                "shear": [{"time": 0.25, "x": 0.0, "y": 5.0}]}},
            "ik": {"reach": [{"time": 0.0, "mix": 0.25}, {"time": 1.0, "bendPositive": False}]},
            "transform": {"follow": [{"time": 0.0, "rotateMix": 0.5, "translateMix": 0.25, "scaleMix": 0.125,
                                      "shearMix": 0.0}]},
            "paths": {"ride": {"position": [{"time": 0.0, "position": 0.25}],
                               "spacing": [{"time": 0.0, "spacing": 3.0}],
                               "mix": [{"time": 0.0, "rotateMix": 0.5, "translateMix": 0.75}]}},
            "deform": {"default": {"body": {"shape": [
                {"time": 0.0, "offset": 1, "vertices": [0.5, -0.5], "curve": "stepped"}, {"time": 1.0}]}}},
            "drawOrder": [{"time": 0.5, "offsets": [{"slot": "body", "offset": 1}]}],
            "events": [{"time": 0.25, "name": "hit", "float": 1.5},
                       {"time": 0.75, "name": "hit", "int": 7, "string": "bang"}],  # float: the event's
        }},
    }
    if not ne:
        doc[EXTRA] = {"nonessential": False}
    return doc


@pytest.mark.parametrize("nonessential", [True, False])
def test_reading_order_is_the_runtimes(nonessential):
    """Our reader gives exactly the document the hand-encoded file holds, and our writer
    gives back exactly its bytes."""
    data, doc = encode_35(nonessential), document_35(nonessential)
    assert read_skel(data) == doc
    assert encode_skel(doc) == data
    assert sniff_version(data) == "3.5.51"


def test_the_layout_is_the_versions():
    """The same bytes under a 3.6 header do not read as the same document: 3.6 reads a dark
    colour after each slot's colour, and the rest shifts."""
    data = encode_35(True)
    as36 = data.replace(b"\x073.5.51", b"\x073.6.53", 1)
    try:
        doc = read_skel(as36)
    except SkelFormatError:
        return
    assert doc != document_35(True)


def test_a_document_loaded_from_json_text_writes_the_same_bytes():
    doc = json.loads(json.dumps(document_35(True)))
    assert encode_skel(doc) == encode_35(True)


@pytest.mark.parametrize("kind,fields", [
    ("point", {"x": 1, "y": 2}),
    ("clipping", {"end": "rail", "vertexCount": 3, "vertices": [0, 0, 1, 0, 0, 1]}),
])
def test_attachments_3_5_cannot_hold_are_refused(kind, fields):
    doc = document_35(True)
    doc["skins"]["default"]["body"]["extra"] = {"type": kind, **fields}
    with pytest.raises(SkelFormatError, match=f"3.5.51.*got '{kind}'"):
        encode_skel(doc)


def test_two_colour_timelines_are_refused():
    doc = document_35(True)
    doc["animations"]["walk"]["slots"]["body"]["twoColor"] = [{"time": 0, "light": "ffffffff", "dark": "000000"}]
    with pytest.raises(SkelFormatError, match="twoColor"):
        encode_skel(doc)


def test_attachment_types_of_later_versions_are_errors():
    """Type byte 5 (3.6's point) in a 3.5 file is corrupt data, named with its offset."""
    data = encode_35(True)
    at = data.index(b"\x07hitbox\x04box") + len(b"\x07hitbox\x04box")
    assert data[at] == 1
    bad = data[:at] + b"\x05" + data[at + 1:]
    with pytest.raises(SkelFormatError, match="attachment type below 5, found 5") as e:
        read_skel(bad)
    assert e.value.offset == at


@pytest.mark.parametrize("version", ["3.4.02", "3.3.07", "2.1.27"])
def test_older_versions_are_one_clear_error(version, tmp_path):
    """3.4 and older have another layout: refused by the reader, and by ``convert`` in one
    line naming the file and the versions it reads."""
    data = encode_35(True).replace(b"\x073.5.51", bytes([len(version) + 1]) + version.encode(), 1)
    with pytest.raises(SkelFormatError, match=f"expected Spine 3.5.*, found version '{version}'"):
        read_skel(data)
    old = tmp_path / "old.skel"
    old.write_bytes(data)
    r = _cli("convert", str(old), str(tmp_path / "old.json"))
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert "old.skel" in r.stderr and version in r.stderr and "3.5" in r.stderr
    assert not (tmp_path / "old.json").exists()


def _cli(*args: str) -> subprocess.CompletedProcess:
    import os

    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env)


# -- the game projects' 3.5 skeletons, written as binaries by our writer ---------------------------

def _corpus_35(corpus: Path) -> list[Path]:
    """The corpus' Spine 3.5 JSON skeletons, by the manifest's version column."""
    rows = [line.split("\t") for line in (corpus / "MANIFEST.tsv").read_text(encoding="utf-8").splitlines()[1:]]
    out = []
    for row in rows:
        if len(row) > 3 and row[3].startswith("3.5"):
            out += sorted(p for p in (corpus / row[0]).rglob("*.json") if not p.name.startswith("."))
    return out


@pytest.fixture(scope="module")
def corpus35(corpus) -> list[Path]:
    files = _corpus_35(corpus)
    assert len(files) >= 4, files
    return files


def test_corpus_35_json_writes_skel_that_reads_back(corpus35):
    """Each 3.5 JSON of the game projects, meshes and linked meshes, weights, deform keys and
    all, writes a .skel that reads back to it and writes the same bytes again, with and
    without nonessential data."""
    kinds = set()
    for path in corpus35:
        doc = json.loads(path.read_text(encoding="utf-8-sig"))
        assert doc["skeleton"]["spine"].startswith("3.5")
        data = encode_skel(doc, path)
        again = read_skel(data, path)
        assert not diff_documents(again, doc, abs_tol=1e-4, rel_tol=1e-6), path
        assert encode_skel(again) == data
        assert encode_skel(json.loads(json.dumps(again))) == data
        again[EXTRA] = {"nonessential": False}
        lean = encode_skel(again)
        assert len(lean) < len(data) and encode_skel(read_skel(lean)) == lean
        kinds |= {a.type for a in iter_attachments(doc)}
    assert {"region", "mesh"} <= kinds


def test_convert_35_both_ways(corpus35, tmp_path):
    """``spinemesh convert``: the editor's 3.5 JSON to .skel, that .skel to JSON, and that
    JSON back to the very same .skel."""
    src = max(corpus35, key=lambda p: p.stat().st_size)
    first, text, second = tmp_path / "a.skel", tmp_path / "a.json", tmp_path / "b.skel"
    for a, b in ((src, first), (first, text), (text, second)):
        r = _cli("convert", str(a), str(b))
        assert r.returncode == 0, r.stderr
        assert "Spine 3.5" in r.stdout
    assert first.read_bytes() == encode_skel(json.loads(src.read_text(encoding="utf-8-sig")))
    assert second.read_bytes() == first.read_bytes()
    assert json.loads(text.read_text(encoding="utf-8"))["skeleton"]["spine"].startswith("3.5")


def _project_with_binaries(corpus: Path, project: str, into: Path) -> Path:
    """A copy of a corpus 3.5 project in ``into``, each JSON with its .skel (our writer's) beside it."""
    folder = into / project
    shutil.copytree(corpus / project, folder, ignore=shutil.ignore_patterns(".*"))
    for js in folder.rglob("*.json"):
        js.with_suffix(".skel").write_bytes(encode_skel(json.loads(js.read_text(encoding="utf-8-sig")), js))
    return folder


#: The corpus' 3.5 projects with region attachments (sws-mainchar has meshes only: its binary
#: is proven by the tests above).
PROJECTS_35 = ["l387-lemur", "sws-crawler", "jg-roles"]


@pytest.mark.parametrize("project", PROJECTS_35)
def test_upgrade_of_a_35_binary_project(corpus, corpus35, tmp_path, project):
    """``spinemesh upgrade`` on a folder of 3.5 binaries beside their JSON: exit 0 (nothing
    failed), regions meshed, each upgraded .skel read back byte for byte and equal to the
    upgrade of its JSON (the same meshes, each placed where its region was; see
    ``scripts/prove_skel35.py``); a skeleton without regions comes through as it is."""
    folder = _project_with_binaries(corpus, project, tmp_path)
    out = tmp_path / "out"
    r = _cli("upgrade", str(folder), "--out", str(out))
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    regions = meshed = 0
    for skel in sorted(folder.rglob("*.skel")):
        rel = skel.relative_to(folder)
        data = (out / rel).read_bytes()
        doc = read_skel(data, out / rel)
        assert encode_skel(doc) == data and sniff_version(data) == sniff_version(skel.read_bytes())
        source = read_skel(skel)
        before = [a.type for a in iter_attachments(source)]
        after = [a.type for a in iter_attachments(doc)]
        regions += before.count("region")
        meshed += after.count("mesh") - before.count("mesh")
        if "region" not in before:
            assert data == skel.read_bytes()
        js = rel.with_suffix(".json")
        differ = upgrades_differ(source, doc, load_skeleton(folder / js), load_skeleton(out / js),
                                 sniff_version(data), skel.name)
        assert not differ, differ[:10]
    assert regions and meshed > 0
