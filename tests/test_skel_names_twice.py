"""A ``.skel`` whose indexed lists name one item twice (hostile round ten).

A ``.skel`` refers to slots, constraints, events, skins and animations by their place in their
list; the document the binary reader makes (the JSON's layout) by name. With two slots of one
name, a timeline aimed at the later one was read, posed and written back (``convert``,
``upgrade``) aimed at the first: a changed animation, exit 0. Each such file is now refused in
one line naming the file and the name, and nothing is written from it.

Each case is a ``.skel`` made by our own writer with two items of distinct names and a timeline
(or skin entry) aimed at the later, whose name is then made the earlier's in the file's bytes:
the index the official runtime plays stays the later one.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from test_hostile import check_run, run_cli, snapshot

#: The two names: the later is written as ``LATER``, then made ``NAME`` in the bytes (an inline
#: string and a string-table entry are both a varint of length + 1, then the UTF-8 bytes).
NAME, LATER = "dup", "duQ"


def _patched(data: bytes) -> bytes:
    old, new = bytes([len(LATER) + 1]) + LATER.encode(), bytes([len(NAME) + 1]) + NAME.encode()
    assert data.count(old) >= 1
    return data.replace(old, new)


def _doc_4x(version: str) -> dict:
    """The demo's skeleton as its ``.skel`` reads, of ``version``."""
    import tempfile

    from spinemesh.demo import make_demo_project
    from spinemesh.skeleton_binary import read_skel

    with tempfile.TemporaryDirectory() as tmp:
        doc = read_skel(make_demo_project(Path(tmp) / "p") / "demo-binary.skel")
    doc.pop("_skel", None)
    doc["skeleton"]["spine"] = version
    return doc


def _doc_3x(version: str) -> dict:
    """A small 3.x skeleton: two bones, a slot holding a mesh, the default skin."""
    mesh = {"type": "mesh", "uvs": [0, 0, 1, 0, 1, 1], "triangles": [0, 1, 2], "vertices": [0, 0, 10, 0, 10, 10],
            "hull": 3, "width": 10, "height": 10}
    doc = {"skeleton": {"hash": "h", "spine": version, "width": 10, "height": 10},
           "bones": [{"name": "root"}, {"name": "arm", "parent": "root"}, {"name": "head", "parent": "root"}],
           "slots": [{"name": "s", "bone": "arm", "attachment": "m"}],
           "skins": [{"name": "default", "attachments": {"s": {"m": mesh}}}],
           "animations": {"a": {"bones": {"arm": {"rotate": [{"time": 0, "angle": 10}]}}}}}
    if not version.startswith("3.8"):
        doc["skins"] = {sk["name"]: sk["attachments"] for sk in doc["skins"]}
    return doc


def _twice(doc: dict, kind: str) -> tuple[str, int]:
    """Two items of ``kind`` named ``NAME`` and ``LATER``, and a timeline (or skin entry) aimed at
    the later; the list as the JSON names it and the later's place there."""
    v4 = not doc["skeleton"]["spine"].startswith("3.")
    anim = doc["animations"].setdefault("t", {})
    key0 = {} if v4 else {"time": 0}
    if kind == "slots":
        doc["slots"] += [{"name": n, "bone": "arm"} for n in (NAME, LATER)]
        anim["slots"] = {LATER: {"rgba" if v4 else "color": [{**key0, "color": "ff000080"}]}}
        return "slots", len(doc["slots"]) - 1
    if kind in ("ik", "transform", "path", "physics"):
        body = {"ik": {"bones": ["arm"], "target": "head"}, "transform": {"bones": ["arm"], "target": "head"},
                "path": {"bones": ["arm"], "target": doc["slots"][0]["name"]}, "physics": {"bone": "arm"}}[kind]
        key = {"ik": {"mix": 0.5}, "transform": {"mixRotate": 0.5} if v4 else {"rotateMix": 0.5},
               "path": {"position": [{**key0, "value" if v4 else "position": 5}]},
               "physics": {"inertia": [{"value": 0.5}]}}[kind]
        doc.setdefault(kind, []).extend({"name": n, **copy.deepcopy(body)} for n in (NAME, LATER))
        anim[kind] = {LATER: [{**key0, **key}] if kind in ("ik", "transform") else key}
        return kind, len(doc[kind]) - 1
    if kind == "constraints":  # 4.3: one list of every type
        doc["constraints"] = [{"type": "ik", "name": n, "bones": ["arm"], "target": "head"} for n in (NAME, LATER)]
        anim["ik"] = {LATER: [{"mix": 0.5}]}
        return "constraints", 1
    if kind == "events":
        doc["events"] = {NAME: {"int": 1}, LATER: {"int": 2}}
        anim["events"] = [{**key0, "name": LATER}]
        return "events", 1
    if kind == "skins":
        if v4:  # a sequence timeline: skin, slot and attachment
            spark = doc["skins"][0]["attachments"]["spark"]
            doc["skins"] += [{"name": n, "attachments": {"spark": copy.deepcopy(spark)}} for n in (NAME, LATER)]
            anim["attachments"] = {LATER: {"spark": {"spark": {"sequence": [{"mode": "loop"}]}}}}
            return "skins", len(doc["skins"]) - 1
        default = doc["skins"]["default"] if isinstance(doc["skins"], dict) else doc["skins"][0]["attachments"]
        deform = {LATER: {"s": {"m": [{"time": 0, "vertices": [1, 1]}]}}}
        if isinstance(doc["skins"], dict):
            doc["skins"] |= {n: copy.deepcopy(default) for n in (NAME, LATER)}
        else:
            doc["skins"] += [{"name": n, "attachments": copy.deepcopy(default)} for n in (NAME, LATER)]
        anim["deform"] = deform
        return "skins", 2
    raise AssertionError(kind)


CASES = [("4.2.40", k) for k in ("slots", "ik", "transform", "path", "physics", "events", "skins")] + \
        [("4.3.39", k) for k in ("slots", "constraints", "events")] + \
        [("4.0.64", "skins"), ("4.1.24", "transform")] + \
        [(v, k) for v in ("3.8.99", "3.7.94", "3.5.51") for k in ("slots", "ik", "path", "events", "skins")]


def _skel(tmp: Path, version: str, kind: str) -> tuple[Path, str, int]:
    """``p/x.skel`` of ``version`` with two items of ``kind`` named alike; the list and the place
    of the item the file's timeline is aimed at."""
    from spinemesh.skeleton_binary import encode_skel

    doc = _doc_3x(version) if version.startswith("3.") else _doc_4x(version)
    key, later = _twice(doc, kind)
    (tmp / "p").mkdir(parents=True, exist_ok=True)
    path = tmp / "p" / "x.skel"
    path.write_bytes(_patched(encode_skel(doc)))
    return path, key, later


def _aimed_at(doc: dict, key: str) -> int | None:
    """The place of the item ``key`` the runtime finds for the name a converted document's
    timeline names (the first of that name, ``findSlot``), or ``None`` when the document no
    longer holds the timeline."""
    items = doc.get(key)
    names = list(items) if isinstance(items, dict) else [x.get("name") for x in items or []]
    return names.index(NAME) if NAME in names else None


@pytest.mark.parametrize("version,kind", CASES, ids=[f"{v}-{k}" for v, k in CASES])
def test_a_skel_naming_one_item_twice_is_refused(tmp_path, version, kind):
    """``convert`` wrote the JSON with the timeline aimed at the first item of the name (what
    every runtime then plays), exit 0; now one line names the file and the name, exit 2,
    nothing written."""
    _, key, later = _skel(tmp_path, version, kind)
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/x.skel", "x.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["x.json"], codes=(0, 2))
    out = tmp_path / "x.json"
    if out.exists():  # what was written must play as the file does: aimed at the later item
        assert _aimed_at(json.loads(out.read_text()), key) == later, f"{kind}: aimed at the first"
    assert r.returncode == 2 and not out.exists(), r.stderr
    line = r.stderr.strip()
    assert "\n" not in line and line.startswith("error: p/x.skel (byte ") and f"found {NAME!r} naming two ({key}[" in line \
        and f"and {key}[{later}])" in line, line


def test_upgrade_keeps_a_skel_naming_a_slot_twice_as_it_is(tmp_path):
    """``upgrade`` (and ``weights``, which write the skeleton back alike) wrote the ``.skel`` back
    with the slot's colour keys on the first slot of the name, exit 0; now the skeleton is not
    upgraded and the file is copied as it is, with the one line."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo.json").unlink()
    path = _skel(tmp_path, "4.2.40", "slots")[0]
    path.replace(project / "demo-binary.skel")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(0, 2, 3))
    written = tmp_path / "o" / "demo-binary.skel"
    assert r.returncode != 0 and f"slots named once each, found {NAME!r} naming two" in r.stderr, r.stderr
    assert not written.exists() or written.read_bytes() == (project / "demo-binary.skel").read_bytes()

