"""Spine 4.3: JSON and binary ``.skel``, proven against the official 4.3 runtime.

No 4.3 ``.skel`` exported by the editor is available, so the binary layout (learnt from
``@esotericsoftware/spine-core`` 4.3.13) is proven by the runtime itself: for every 4.3
JSON we have (the corpus projects, and :func:`skel43_features.features_document`, which
uses every field the 4.3 loaders read), our ``.skel`` loaded by the official
``SkeletonBinary`` gives the same skeleton data as the JSON loaded by the official
``SkeletonJson``, field by field up to float32 rounding, except for the differences in
:data:`LOADER_DIFFERENCES`, each a place where the two official loaders themselves differ.

The runtime is ``tests/runtime43`` (spine-core pinned by its lock file), installed with
``npm ci`` once per test run; ``upgrade`` of every 4.3 project, from ``.json`` and from
``.skel``, is loaded there too, and every mesh vertex must sit where its region drew.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton import load_skeleton
from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version
from spinemesh.skeleton_binary.compare import diff_documents
from spinemesh.skeleton_binary.enums import EXTRA

from conftest import CORPUS, unavailable
from skel43_features import features_document

HARNESS = Path(__file__).resolve().parent / "runtime43"
PROJECTS43 = ["tmd-ar15", "tmd-npcportrait"]


def _corpus_json(name: str) -> Path:
    folder = CORPUS / name
    if not folder.is_dir():
        unavailable(f"{folder} is absent: the 4.3 corpus projects are needed")
    return next(p for p in sorted(folder.glob("*.json")) if not p.name.endswith(".source.json"))


def _document(case: str) -> dict:
    if case == "features":
        return features_document()
    return json.loads(_corpus_json(case).read_text(encoding="utf-8-sig"))


CASES = ["features", *PROJECTS43]


# -- our own round trips ---------------------------------------------------------------------

@pytest.mark.parametrize("case", CASES)
def test_round_trips(case):
    """``read(write(doc)) == doc`` up to float32 rounding, and ``write(read(bytes)) == bytes``."""
    doc = _document(case)
    data = encode_skel(doc)
    assert sniff_version(data) == doc["skeleton"]["spine"]
    again = read_skel(data)
    assert EXTRA not in again, again.get(EXTRA)
    diffs = diff_documents(again, doc, abs_tol=1e-5, rel_tol=1e-6, ignore=[EXTRA])
    assert not diffs, "\n".join(map(str, diffs[:30]))
    assert encode_skel(again) == data
    # Through JSON text and back: still the same bytes.
    assert encode_skel(json.loads(json.dumps(again))) == data


def test_features_document_uses_every_4_3_structure():
    """The document the runtime proof relies on keeps covering what 4.3 added."""
    doc = features_document()
    assert {c["type"] for c in doc["constraints"]} == {"ik", "transform", "path", "physics", "slider"}
    kinds = {a.get("type", "region") for sk in doc["skins"] for sl in sk["attachments"].values()
             for a in sl.values()}
    assert kinds == {"region", "mesh", "linkedmesh", "boundingbox", "path", "point", "clipping"}
    walk = doc["animations"]["walk"]
    assert {"slots", "bones", "ik", "transform", "path", "physics", "slider", "attachments", "drawOrder",
            "drawOrderFolder", "events", "color"} <= set(walk)
    assert {k for t in walk["slots"].values() for k in t} == {"attachment", "rgba", "rgb", "alpha", "rgba2", "rgb2"}
    assert len({k for t in walk["bones"].values() for k in t}) == 11


def test_mesh_timeline_slots_follow_linked_meshes():
    """4.3 stores, with a mesh, the slots of linked meshes that play its timelines; the
    writer derives them, and a file that stores others keeps them."""
    doc = features_document()
    data = encode_skel(doc)
    again = read_skel(data)
    assert EXTRA not in again
    # The same document with the copy keeping its own timelines stores no slot.
    doc["skins"][1]["attachments"]["copy"]["copy"]["timelines"] = False
    other = encode_skel(doc)
    assert len(other) == len(data) - 1
    # Recorded slots that the runtime would not derive survive a round trip.
    odd = read_skel(data)
    odd[EXTRA] = {"timelineSlots": [["default", "skin", "skin", ["tip", "box"]]]}
    kept = read_skel(encode_skel(odd))
    assert kept[EXTRA] == {"timelineSlots": [["default", "skin", "skin", ["tip", "box"]]]}
    assert encode_skel(kept) == encode_skel(odd)


def test_writer_errors_name_the_problem():
    doc = features_document()
    doc["constraints"][0]["type"] = "spring"
    with pytest.raises(SkelFormatError, match="spring"):
        encode_skel(doc)
    doc = features_document()
    doc["skins"][1]["slider"] = ["no-such-slider"]
    with pytest.raises(SkelFormatError, match="no-such-slider"):
        encode_skel(doc)
    doc = features_document()
    doc["constraints"][-1]["animation"] = "no-such-animation"
    with pytest.raises(SkelFormatError, match="no-such-animation"):
        encode_skel(doc)


def test_truncations_and_constraint_type_errors():
    data = encode_skel(features_document())
    for cut in range(0, len(data), max(1, len(data) // 300)):
        with pytest.raises(SkelFormatError) as e:
            read_skel(data[:cut], "f.skel")
        assert e.value.offset is not None and e.value.offset <= cut and e.value.path == "f.skel"


# -- the official 4.3 runtime -------------------------------------------------------------------

@pytest.fixture(scope="session")
def runtime43(tmp_path_factory) -> Path:
    """``tests/runtime43`` with spine-core 4.3.13, ``npm ci``-installed once per test run."""
    if not shutil.which("node") or not shutil.which("npm"):
        unavailable("node and npm are needed to run the official Spine 4.3 runtime")
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # one install shared by every worker of this run
    dest = root / "runtime43"
    with open(root / "runtime43.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (dest / "node_modules").is_dir():
            shutil.rmtree(dest, ignore_errors=True)
            shutil.copytree(HARNESS, dest, ignore=shutil.ignore_patterns("node_modules"))
            r = subprocess.run(["npm", "ci", "--no-audit", "--no-fund"], cwd=dest, capture_output=True,
                               text=True, timeout=300)
            if r.returncode:
                shutil.rmtree(dest / "node_modules", ignore_errors=True)
                unavailable(f"npm ci of tests/runtime43 failed:\n{r.stderr[-3000:]}")
    return dest


def _node(runtime: Path, *args) -> None:
    r = subprocess.run(["node", *map(str, args)], cwd=runtime, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-3000:]


def _loaded(runtime: Path, skeleton: Path) -> dict:
    out = skeleton.with_name(skeleton.name + ".data.json")
    _node(runtime, "data.mjs", skeleton, out)
    return json.loads(out.read_text())


#: Where the official 4.3 loaders themselves disagree on one document: (path pattern,
#: condition on the JSON document or None, reason). Paths are those of ``data.mjs``'s dump.
LOADER_DIFFERENCES = [
    ("bones/*/visible", None,
     "SkeletonJson never reads a bone's visibility (it stays false); SkeletonBinary reads it."),
    ("bones/*/color/*", lambda doc, i: "color" not in doc["bones"][i],
     "Without a bone colour in the JSON, SkeletonJson leaves 0,0,0,0; the binary stores the default."),
    ("skins/*/color/*", None, "SkeletonJson does not read a skin's colour; SkeletonBinary does."),
    ("slots/*/setupPose/darkColor/a", None,
     "A dark colour has no alpha: SkeletonJson sets 1, SkeletonBinary's rgb888 leaves 0."),
    ("skeleton/fps", lambda doc, i: "fps" not in doc["skeleton"],
     "Without fps in the JSON, SkeletonJson leaves it undefined; the binary stores the editor's 30."),
]


def _index_in(path: str) -> int:
    parts = path.split("/")
    return int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else -1


def runtime_differences(a, b, doc: dict, path: str = "", rel_tol: float = 1e-5) -> list[str]:
    """Paths where two dumps of ``data.mjs`` differ, beyond float32 rounding and the named
    loader differences."""
    import fnmatch

    def named(p: str) -> bool:
        return any(fnmatch.fnmatchcase(p.lstrip("/"), pattern) and (cond is None or cond(doc, _index_in(p.lstrip("/"))))
                   for pattern, cond, _ in LOADER_DIFFERENCES)

    out: list[str] = []

    def walk(x, y, p):
        if named(p):
            return
        if isinstance(x, dict) and isinstance(y, dict):
            for k in sorted(set(x) | set(y)):
                if k not in x or k not in y:
                    if not named(f"{p}/{k}"):
                        out.append(f"{p}/{k}: only in one")
                    continue
                walk(x[k], y[k], f"{p}/{k}")
        elif isinstance(x, list) and isinstance(y, list):
            if len(x) != len(y):
                out.append(f"{p}: {len(x)} != {len(y)} items")
                return
            for i, (u, v) in enumerate(zip(x, y)):
                walk(u, v, f"{p}/{i}")
        elif isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool) \
                and not isinstance(y, bool):
            if abs(x - y) > rel_tol * max(1.0, abs(x), abs(y)):
                out.append(f"{p}: {x} != {y}")
        elif x != y:
            out.append(f"{p}: {x!r} != {y!r}")

    walk(a, b, path)
    return out


@pytest.mark.parametrize("case", CASES)
def test_official_runtime_loads_our_skel_like_the_json(case, runtime43, tmp_path):
    """Our .skel (written from the JSON) in SkeletonBinary = the JSON in SkeletonJson; and our
    JSON read back from that .skel loads like the .skel."""
    doc = _document(case)
    js, skel, back = tmp_path / "doc.json", tmp_path / "doc.skel", tmp_path / "back.json"
    js.write_text(json.dumps(doc), encoding="utf-8")
    skel.write_bytes(encode_skel(doc))
    back.write_text(json.dumps(read_skel(skel)), encoding="utf-8")
    from_json, from_skel, from_back = (_loaded(runtime43, p) for p in (js, skel, back))
    # Proof that the comparison sees the data: everything was loaded.
    assert len(from_skel["animations"]) == len(doc["animations"]) and from_skel["skins"]
    diffs = runtime_differences(from_json, from_skel, doc)
    assert not diffs, "\n".join(diffs[:40])
    # Every unconditional named difference is still needed (the list does not rot), and the
    # comparison sees a change of a hundredth anywhere.
    if case == "features":
        import fnmatch

        moved = json.loads(json.dumps(from_skel))
        moved["animations"][0]["timelines"][-1]["frames"][-1] += 0.01
        moved["constraints"][2]["setupPose"]["mixX"] += 0.01
        assert len(runtime_differences(from_json, moved, doc)) == 2

        raw = _raw_paths(from_json, from_skel)
        for pattern, condition, _reason in LOADER_DIFFERENCES:
            if condition is None:
                assert any(fnmatch.fnmatchcase(p, pattern) for p in raw), f"{pattern} no longer differs"
    # ... and our reading of the .skel is exact: its JSON loads like the .skel itself.
    diffs = runtime_differences(from_back, from_skel, read_skel(skel), rel_tol=1e-6)
    assert not diffs, "\n".join(diffs[:40])


def _raw_paths(a, b, p: str = "") -> list[str]:
    """Every path where two dumps differ at all (for checking the named differences)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [q for k in set(a) | set(b) for q in (_raw_paths(a.get(k), b.get(k), f"{p}/{k}".lstrip("/")))]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [q for i, (x, y) in enumerate(zip(a, b)) for q in _raw_paths(x, y, f"{p}/{i}")]
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return [p] if abs(a - b) > 1e-5 * max(1.0, abs(a), abs(b)) else []
    return [p] if a != b else []


# -- upgrade of the 4.3 projects, loaded by the official runtime ----------------------------------

MESHES: dict = {}  # one meshing per image for both the .json and the .skel project


def _project_as(name: str, kind: str, tmp_path: Path) -> Path:
    """The corpus project as it is (``json``) or with its skeleton as our ``.skel``."""
    source = _corpus_json(name).parent
    if kind == "json":
        return source
    folder = tmp_path / f"{name}-skel"
    folder.mkdir()
    for f in source.iterdir():
        if f == _corpus_json(name):
            (folder / f"{f.stem}.skel").write_bytes(encode_skel(json.loads(f.read_text(encoding="utf-8-sig"))))
        elif f.is_file():
            shutil.copy2(f, folder / f.name)
    return folder


def _affine(uvs: np.ndarray, world: np.ndarray) -> np.ndarray:
    """The map ``[u, v, 1] -> [x, y]`` through a region's four corners (a parallelogram)."""
    a = np.c_[uvs, np.ones(len(uvs))]
    m, *_ = np.linalg.lstsq(a, world, rcond=None)
    assert np.abs(a @ m - world).max() < 1e-3, "a region quad that is not affine in its UVs"
    return m


@pytest.mark.parametrize("kind", ["json", "skel"])
@pytest.mark.parametrize("name", PROJECTS43)
def test_upgraded_43_project_in_official_runtime(name, kind, runtime43, tmp_path):
    """Every region becomes a mesh that the 4.3 runtime loads, each vertex within 0.05 px of
    where the region drew the same texel, with UVs inside the region's."""
    from spinemesh.upgrade import Options, upgrade_project

    project = _project_as(name, kind, tmp_path)
    out = tmp_path / "out"
    result = upgrade_project(project, out, Options(), mesh_cache=MESHES)
    assert not result.errors, result.errors
    # Every region is meshed, or kept with its reason (a mesh would save too little).
    assert result.targets and all(t.status == "meshed" or (t.status == "kept" and t.reason) for t in result.targets), \
        [(t.name, t.status, t.reason) for t in result.targets if t.status != "meshed"]
    meshed = {(t.skin, t.slot, t.name) for t in result.targets if t.status == "meshed"}
    atlas = next(project.glob("*.atlas"))
    skeleton = _corpus_json(name) if kind == "json" else next(project.glob("*.skel"))
    before, after = tmp_path / "before.json", tmp_path / "after.json"
    _node(runtime43, "world.mjs", atlas, skeleton, before)
    _node(runtime43, "world.mjs", out / atlas.name, out / skeleton.name, after)
    before, after = json.loads(before.read_text()), json.loads(after.read_text())
    upgraded = [k for k, v in before.items() if v["type"] == "region" and after[k]["type"] == "mesh"]
    assert upgraded and len(upgraded) == len(meshed) == len({tuple(k.split("\t")) for k in upgraded} & meshed)
    worst = 0.0
    for key in upgraded:
        region, mesh = before[key], after[key]
        quad_uv = np.reshape(region["uvs"], (-1, 2))
        m = _affine(quad_uv, np.reshape(region["world"], (-1, 2)))
        uv = np.reshape(mesh["uvs"], (-1, 2))
        lo, hi = quad_uv.min(0) - 1e-6, quad_uv.max(0) + 1e-6
        assert ((uv >= lo) & (uv <= hi)).all(), f"{key}: UVs outside the region's"
        drawn = np.c_[uv, np.ones(len(uv))] @ m
        worst = max(worst, float(np.abs(drawn - np.reshape(mesh["world"], (-1, 2))).max()))
        assert worst < 0.05, f"{key}: a vertex {worst:.4f} px from where the region drew its texel"
    print(f"{name} from .{kind}: {len(upgraded)} regions meshed, worst vertex {worst:.2e} px from the region")
    # The other attachments are untouched.
    for key in set(before) - set(upgraded):
        assert before[key] == after[key], key


def test_convert_43_both_ways(tmp_path):
    """``spinemesh convert`` from 4.3 JSON to .skel and back gives the same document."""
    import sys

    doc = features_document()
    src = tmp_path / "f.json"
    src.write_text(json.dumps(doc), encoding="utf-8")
    env = dict(os.environ, COLUMNS="200")
    for a, b in ((src, tmp_path / "f.skel"), (tmp_path / "f.skel", tmp_path / "g.json")):
        r = subprocess.run([sys.executable, "-m", "spinemesh", "convert", str(a), str(b)], capture_output=True,
                           text=True, env=env)
        assert r.returncode == 0, r.stderr
        assert "4.3.23" in r.stdout
    back = load_skeleton(tmp_path / "g.json")
    assert not diff_documents(back, doc, abs_tol=1e-5, rel_tol=1e-6)
    assert read_skel(tmp_path / "f.skel") == read_skel(encode_skel(doc))


# -- 4.3 JSON: lossless, and walked like every other version ----------------------------------

@pytest.mark.parametrize("case", PROJECTS43)
def test_json_43_is_lossless_and_walked(case, tmp_path):
    from spinemesh.skeleton import dumps_skeleton, image_paths, iter_attachments

    path = _corpus_json(case)
    doc = load_skeleton(path)
    copy = tmp_path / path.name
    copy.write_text(dumps_skeleton(doc), encoding="utf-8")
    assert load_skeleton(copy) == doc == json.loads(path.read_text(encoding="utf-8-sig"))
    refs = list(iter_attachments(doc))
    expected = sum(len(atts) for sk in doc["skins"] for atts in sk.get("attachments", {}).values())
    assert refs and len(refs) == expected
    # Sequences (AR15's effect mesh has 8 frames) name every frame's image.
    assert any(len(image_paths(r)) > 1 for r in refs) == (case == "tmd-ar15")


def test_walker_helpers_follow_4_3_layout():
    """4.3 moved constraints into one typed list and names a linked mesh's mesh 'source'."""
    from spinemesh.skeleton import iter_attachments, iter_constraints, linked_source

    doc = features_document()
    assert [c["name"] for c in iter_constraints(doc, "ik")] == ["reach", "point"]
    assert [c["name"] for c in iter_constraints(doc, "slider")] == ["timer", "dial"]
    linked = {r.name: linked_source(r) for r in iter_attachments(doc) if r.type == "linkedmesh"}
    assert linked == {"copy": ("default", "arm", "arm"), "arm-alt": ("default", "arm", "arm")}
    old = {"ik": [{"name": "a"}], "skins": [{"name": "default", "attachments": {"s": {"l": {
        "type": "linkedmesh", "parent": "m"}}}}]}
    assert [c["name"] for c in iter_constraints(old, "ik")] == ["a"]
    assert [linked_source(r) for r in iter_attachments(old)] == [("default", "s", "m")]


def test_compare_knows_4_3_defaults():
    """diff_documents treats a 4.3 value spelled out at its default like one left out."""
    doc = features_document()
    read_back = read_skel(encode_skel(doc))
    c = {x["name"]: x for x in doc["constraints"]}
    c["sway"].update(inertia=0.5, damping=0.85, strength=100, mix=1)
    c["plain"].update(mixY=0, mixX=0, mixRotate=0, localSource=False)  # no bone receives x: mixes 0
    c["timer"].update(scale=1, local=False)
    walk = doc["animations"]["walk"]
    walk["slider"]["dial"]["mix"][0]["value"] = 1
    walk["physics"]["wobble"]["mix"][1]["value"] = 1
    walk["transform"]["follow"][0]["mixScaleY"] = 1
    assert not diff_documents(read_back, doc, abs_tol=1e-5, rel_tol=1e-6, ignore=[EXTRA])
    c["plain"]["mixY"] = 0.5
    assert [d.path for d in diff_documents(read_back, doc, abs_tol=1e-5, rel_tol=1e-6)] == ["constraints/3/mixY"]
