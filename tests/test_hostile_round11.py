"""Hostile input, eleventh round: what binds meshes to bones (``weights``, ``upgrade --weights
auto``) and the readers of weighted meshes.

Every project is made here by our own code (the worm of :mod:`rig_project`, its region made a
9 x 3 grid mesh); each case checks what docs/safety.md promises: a weighted mesh is drawn where
the mesh was in the setup pose (by our own reading and, where Node is there, by the official
runtime), or it is left as it was with one line; never a traceback; inputs unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rig_project import HEIGHT, WIDTH, make_worm_project, worm_skeleton
from test_hostile import check_run, run_cli, snapshot
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)


def worm_mesh(nx: int = 9, ny: int = 3) -> dict:
    """The worm's region as an unweighted grid mesh of ``nx`` by ``ny`` vertices, drawn where the
    region drew (on ``seg1``, 0..240 along it)."""
    uvs, vertices, triangles = [], [], []
    for j in range(ny):
        for i in range(nx):
            u, v = i / (nx - 1), j / (ny - 1)
            uvs += [u, v]
            vertices += [u * WIDTH, HEIGHT / 2 - v * HEIGHT]
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i
            triangles += [a, a + 1, a + nx, a + 1, a + nx + 1, a + nx]
    return {"type": "mesh", "uvs": uvs, "triangles": triangles, "vertices": vertices,
            "hull": 2 * (nx + ny) - 4, "width": WIDTH, "height": HEIGHT}


def _bone(doc: dict, name: str) -> dict:
    return next(b for b in doc["bones"] if b["name"] == name)


def _worm_mesh_project(tmp: Path, change=None) -> dict:
    """The worm project in ``tmp/p`` with its region a grid mesh, ``change(doc)`` applied; the document."""
    make_worm_project(tmp / "p")
    doc = worm_skeleton()
    doc["skins"][0]["attachments"]["worm"]["worm"] = worm_mesh()
    if change is not None:
        change(doc)
    (tmp / "p" / "worm.json").write_text(json.dumps(doc, indent=1))
    return doc


def _setup_vertices(path: Path) -> dict[str, np.ndarray]:
    """``skin/slot/name`` -> world vertices (N, 2) of every mesh of a skeleton in its setup pose,
    as our own reading draws them (:func:`spinemesh.rig.binding.setup_world`)."""
    from spinemesh.rig.binding import parse_vertices, setup_world
    from spinemesh.rig.document import build_rig
    from spinemesh.skeleton import iter_attachments, load_skeleton

    doc = load_skeleton(path)
    rig = build_rig(doc)
    return {f"{ref.skin}/{ref.slot}/{ref.name}": setup_world(parse_vertices(ref.attachment, len(rig.bones)),
                                                              rig.worlds, rig.slot_bone[ref.slot])
            for ref in iter_attachments(doc) if ref.type == "mesh"}


def _runtime_vertices(tool: Path, project: Path, skeleton: str = "worm.json") -> dict[str, np.ndarray]:
    """``slot/attachment`` -> world vertices (N, 2) the official runtime draws in the setup pose."""
    from runtime_tool import dump

    out = project.parent / f"{project.name}.dump.json"
    dump(tool, project / "worm.atlas", project / skeleton, None, "0", out)
    pose = json.loads(out.read_text())["poses"][0]
    return {f"{a['slot']}/{a['attachment']}": np.array(a["vertices"], float).reshape(-1, 2)
            for a in pose["attachments"] if a.get("vertices")}


def _weights(tmp: Path, *extra, codes=(0, 3)):
    before = snapshot(tmp)
    r = run_cli("weights", "p", "--out", "o", *extra, cwd=tmp)
    check_run(r, before, tmp, ["o", "r.json"], codes=codes)
    return r


# --- bones whose world transform is extreme in the setup pose --------------------------------------

def _slot_bone_scaled(scale: float):
    """``seg1`` (the slot's bone) scaled by ``scale``, the mesh's vertices divided by it: the
    worm is drawn where it was, its vertices' numbers as small (or large) as the scale is large."""
    def change(doc):
        _bone(doc, "seg1").update(scaleX=scale, scaleY=scale)
        mesh = doc["skins"][0]["attachments"]["worm"]["worm"]
        mesh["vertices"] = [v / scale for v in mesh["vertices"]]
    return change


@pytest.mark.parametrize("scale", [1e6, 1e8])
def test_a_mesh_on_a_bone_scaled_a_million_times_is_bound_where_it_is(tmp_path, scale):
    """Positions in a bone's space were rounded to 1e-4 whatever the bone's scale: on a bone
    scaled by 1e6 the worm's 240 units are 2.4e-4 in its space, and its weighted vertices were
    written 0.0001 and 0.0002, drawn up to 50 units from the art (exit 0). Now the rounding
    keeps what the scale needs, and every binding is proved before it is written."""
    _worm_mesh_project(tmp_path, _slot_bone_scaled(scale))
    _weights(tmp_path, codes=(0,))
    before, after = _setup_vertices(tmp_path / "p" / "worm.json"), _setup_vertices(tmp_path / "o" / "worm.json")
    mesh = json.loads((tmp_path / "o" / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]
    assert len(mesh["vertices"]) > len(mesh["uvs"])  # weighted
    assert np.abs(after["default/worm/worm"] - before["default/worm/worm"]).max() < 1e-3


def test_a_binding_a_runtime_of_32_bit_floats_draws_elsewhere_is_refused():
    """A bone whose axes are all but parallel holds a vertex at millions of units in its space:
    read as 32-bit floats (the binary format; the C, C++, C# and libGDX runtimes' JSON readers)
    it is drawn centimetres off. The binding says so and writes nothing."""
    from spinemesh.errors import SpineMeshError
    from spinemesh.rig.binding import bind

    worlds = [np.array([[1.0, 1.0, 0.0], [0.0, 1e-6, 0.0]])]
    with pytest.raises(SpineMeshError, match=r"would be drawn 0\.0125 units from where it is in the setup pose"):
        bind(np.array([[0.3, 0.7]]), np.ones((1, 1)), [0], worlds)
    assert bind(np.array([[0.3, 0.0]]), np.ones((1, 1)), [0], worlds) == [1, 0, 0.3, 0.0, 1.0]


def _drawn_alike(tool: Path, tmp: Path, skeleton: str) -> None:
    """The official runtime draws ``tmp/o``'s worm in the setup pose where it draws ``tmp/p``'s."""
    from runtime_tool import compare_dumps, dump

    for side in ("p", "o"):
        dump(tool, tmp / side / "worm.atlas", tmp / side / skeleton, None, "0", tmp / f"{side}.dump.json")
    ok, text = compare_dumps(tool, tmp / "p.dump.json", tmp / "o.dump.json")
    assert ok, text


def test_a_skel_bound_to_a_bone_of_all_but_parallel_axes_is_drawn_where_the_region_was(tmp_path, spine_runtime):
    """``seg2`` sheared -89.9999 degrees: its axes all but one line, a vertex near it lies at
    millions of units in its space, and the binary format stores 32-bit floats: ``upgrade
    --weights auto`` of the ``.skel`` wrote a binding the runtime drew 0.75 texels off the art
    (exit 0). The proof now reads the numbers as 32-bit floats and keeps the mesh unweighted."""
    make_worm_project(tmp_path / "p")
    doc = worm_skeleton()
    _bone(doc, "seg2")["shearY"] = -89.9999
    (tmp_path / "worm.json").write_text(json.dumps(doc))
    assert run_cli("convert", "worm.json", "p/worm.skel", cwd=tmp_path).returncode == 0
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--weights", "auto", "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o"], codes=(0,))
    assert "from where it is in the setup pose" in r.stdout + r.stderr, r.stdout + r.stderr
    _drawn_alike(spine_runtime, tmp_path, "worm.skel")


@pytest.mark.parametrize("bone", [{"scaleX": 1e9, "scaleY": 1e9}, {"length": 1e9}], ids=["scaled 1e9", "1e9 long"])
def test_upgrade_weights_a_region_crossed_by_a_bone_a_billion_units_long_in_seconds(tmp_path, spine_runtime, bone):
    """The rig-aware vertices of ``upgrade --weights auto`` stepped along every bone segment
    point by point, the points off the art dropped after: ``seg2`` a billion units long was
    stepped through for hours, its memory growing (the run never ended). Only the steps over the
    art's box are taken now; the worm is weighted and drawn where the region was."""
    make_worm_project(tmp_path / "p")
    doc = worm_skeleton()
    _bone(doc, "seg2").update(bone)
    (tmp_path / "p" / "worm.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--weights", "auto", "--min-saving", "0", cwd=tmp_path, timeout=60)
    check_run(r, before, tmp_path, ["o"], codes=(0,))
    assert "1 of 1 new meshes weighted" in r.stdout + r.stderr, r.stdout + r.stderr
    _drawn_alike(spine_runtime, tmp_path, "worm.json")


def _set(bone: str, **fields):
    return lambda doc: _bone(doc, bone).update(fields)


def _modes(mode: str, key: str = "inherit", version: str | None = None):
    """``seg2`` and ``seg3`` of inherit ``mode`` under a mirrored, sheared, turned ``seg1``."""
    def change(doc):
        if version:
            doc["skeleton"]["spine"] = version
        _bone(doc, "seg1").update(scaleX=-2, scaleY=0.5, rotation=30)
        _bone(doc, "seg2").update({key: mode, "rotation": 20, "shearX": 10})
        _bone(doc, "seg3").update({key: mode})
    return change


#: Bones of the worm at the extremes of their setup pose: the mesh is weighted (True) drawn where
#: it was, or stays as it was (False) with the line's words.
EXTREME_BONES = {
    "slot bone scaleX 0": (_set("seg1", scaleX=0), "setup position depends on bone 'seg1', zero scale"),
    "parent of the slot bone scaleX 0": (_set("root", scaleX=0), "setup position depends on bone 'seg1', zero scale"),
    "slot bone scale 1e-30": (_set("seg1", scaleX=1e-30), "setup position depends on bone 'seg1', zero scale"),
    "candidate bone scaleY 0": (_set("seg2", scaleY=0), True),
    "candidate bone scale 1e-30": (_set("seg2", scaleX=1e-30, scaleY=1e-30), True),
    "candidate bone shearX 90": (_set("seg2", shearX=90), True),
    "candidate bone shearY -90 (axes one line)": (_set("seg2", shearY=-90), True),
    "candidate bone shearY -89.9999": (_set("seg2", shearY=-89.9999), True),
    "slot bone shearY 89.99": (_set("seg1", shearY=89.99), True),
    "slot bone scaled 1e6": (_slot_bone_scaled(1e6), True),
    **{f"{mode} under a mirrored parent": (_modes(mode), True) for mode in
       ("noScale", "noRotationOrReflection", "onlyTranslation", "noScaleOrReflection")},
    **{f"3.8 transform {mode}": (_modes(mode, "transform", "3.8.99"), True) for mode in
       ("noRotationOrReflection", "noScaleOrReflection")},
    # constraints in the setup pose over the bones the worm may be bound to
    "IK of mix 0.5 on seg2 and seg3": (lambda doc: (
        doc["bones"].append({"name": "target", "parent": "root", "x": 60, "y": 80}),
        doc.update(ik=[{"name": "ik", "bones": ["seg2", "seg3"], "target": "target", "mix": 0.5}])), True),
    "transform constraint with offsets on seg3": (lambda doc: (
        doc["bones"].append({"name": "target", "parent": "root", "x": 60, "y": 80, "rotation": 20, "scaleX": 1.5}),
        doc.update(transform=[{"name": "tc", "bones": ["seg3"], "target": "target", "rotation": 30, "x": 10,
                               "shearY": 5, "mixRotate": 0.7, "mixX": 0.5, "mixScaleX": 0.3, "mixShearY": 1}])), True),
    "4.2 physics on seg2 (the setup pose is before physics)": (lambda doc: doc.update(physics=[{
        "name": "ph", "bone": "seg2", "rotate": 1, "x": 1, "inertia": 0.5, "strength": 100, "damping": 0.9, "mass": 1,
        "gravity": 500, "wind": 300}]), True),
}


@pytest.mark.parametrize("case", sorted(EXTREME_BONES))
def test_bones_at_the_extremes_bind_where_the_runtime_draws_the_mesh(tmp_path, spine_runtime, case):
    """Zero and tiny scales, shears that lay the axes on one line, every inherit mode (3.8's
    ``transform`` spelling too) under a mirrored parent: the weighted mesh is drawn by the
    official runtime where the unweighted one was, or it is left as it was with its reason."""
    change, expected = EXTREME_BONES[case]
    _worm_mesh_project(tmp_path, change)
    r = _weights(tmp_path)
    mesh = json.loads((tmp_path / "o" / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]
    if expected is True:
        assert r.returncode == 0 and len(mesh["vertices"]) > len(mesh["uvs"]), r.stdout + r.stderr
    else:
        assert mesh["vertices"] == worm_mesh()["vertices"] or mesh["vertices"] == json.loads(
            (tmp_path / "p" / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]["vertices"]
        assert expected in r.stdout + r.stderr, r.stdout + r.stderr
    before, after = (_runtime_vertices(spine_runtime, tmp_path / d) for d in ("p", "o"))
    assert np.abs(after["worm/worm"] - before["worm/worm"]).max() < 1e-3



AT_43 = {
    "slot bone scaled 1e6": _slot_bone_scaled(1e6),
    "noScale under a mirrored parent": _modes("noScale"),
    "noRotationOrReflection under a mirrored parent": _modes("noRotationOrReflection"),
    "IK of mix 0.5": lambda doc: (doc["bones"].append({"name": "target", "parent": "root", "x": 60, "y": 80}),
                                  doc.update(constraints=[{"type": "ik", "name": "ik", "bones": ["seg2", "seg3"],
                                                           "target": "target", "mix": 0.5}])),
}


@pytest.mark.parametrize("case", sorted(AT_43))
def test_43_bones_at_the_extremes_bind_where_spine_core_43_draws_the_mesh(tmp_path, runtime43, case):  # noqa: F811
    """The same for 4.3 (its own transforms, :mod:`spinemesh.rig.transform43`), in spine-core 4.3."""
    def change(doc):
        doc["skeleton"]["spine"] = "4.3.00"
        AT_43[case](doc)
    _worm_mesh_project(tmp_path, change)
    _weights(tmp_path, codes=(0,))
    mesh = json.loads((tmp_path / "o" / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]
    assert len(mesh["vertices"]) > len(mesh["uvs"])  # weighted
    before, after = _world43(runtime43, tmp_path / "p"), _world43(runtime43, tmp_path / "o")
    assert np.abs(after["default\tworm\tworm"] - before["default\tworm\tworm"]).max() < 1e-3

# --- meshes `weights` is given ---------------------------------------------------------------------

def _ghost(bone: str, **linked):
    """4.3: a slot ``ghost`` on ``bone`` whose linked mesh takes the worm's mesh (slot ``worm``) as its source."""
    def change(doc):
        doc["skeleton"]["spine"] = "4.3.00"
        doc["slots"].append({"name": "ghost", "bone": bone, "attachment": "copy"})
        doc["skins"][0]["attachments"]["ghost"] = {"copy": {
            "type": "linkedmesh", "source": "worm", "slot": "worm", "path": "worm", "width": WIDTH, "height": HEIGHT,
            **linked}}
    return change


def _world43(runtime: Path, project: Path) -> dict[str, np.ndarray]:
    """``skin\\tslot\\tname`` -> world vertices spine-core 4.3 draws in the setup pose (tests/runtime43)."""
    from runtime_tool import node

    out = project.parent / f"{project.name}.world.json"
    r = node(runtime, "world.mjs", project / "worm.atlas", project / "worm.json", out)
    assert r.returncode == 0, r.stderr[-2000:]
    return {k: np.array(v["world"], float) for k, v in json.loads(out.read_text()).items()}


def test_a_43_source_mesh_whose_linked_mesh_sits_on_another_bone_stays_unweighted(tmp_path, runtime43):  # noqa: F811
    """4.3 lets a linked mesh in one slot take its source from another (``"slot"``): unweighted,
    it draws the source's vertices in its own slot's bone; bound, in the source's bones. The
    source was weighted and the ghost on ``seg3`` jumped 160 units onto the worm (exit 0). Now
    the source is left as it was with the reason; on the same bone it is weighted."""
    _worm_mesh_project(tmp_path, _ghost("seg3"))
    r = _weights(tmp_path, codes=(0,))
    assert "a linked mesh of slot 'ghost' draws its vertices on that slot's bone" in r.stdout, r.stdout
    assert (tmp_path / "o" / "worm.json").read_bytes() == (tmp_path / "p" / "worm.json").read_bytes()
    before, after = _world43(runtime43, tmp_path / "p"), _world43(runtime43, tmp_path / "o")
    assert np.abs(after["default\tghost\tcopy"] - before["default\tghost\tcopy"]).max() < 1e-3

    same = tmp_path / "same"
    _worm_mesh_project(same, _ghost("seg1"))
    _weights(same, codes=(0,))
    mesh = json.loads((same / "o" / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]
    assert len(mesh["vertices"]) > len(mesh["uvs"])  # weighted
    before, after = _world43(runtime43, same / "p"), _world43(runtime43, same / "o")
    for key in before:
        assert np.abs(after[key] - before[key]).max() < 1e-3, key


def test_a_deform_keyed_on_a_43_linked_mesh_of_another_slot_keeps_its_source(tmp_path):
    """A linked mesh that plays its own deform keys (``"timelines": false``) holds them laid out
    as its source's vertices: weighting the source changes what they mean. The keys were looked
    for under the linked mesh's slot, not the source's (4.3's ``"slot"``), and the source was
    weighted; now it is left as it was with the animation's name."""
    def change(doc):
        _ghost("seg1", timelines=False)(doc)
        doc["animations"]["wiggle"]["attachments"] = {"default": {"ghost": {"copy": {"deform": [
            {"time": 0}, {"time": 0.5, "vertices": [5.0] * len(worm_mesh()["vertices"])}]}}}}
    _worm_mesh_project(tmp_path, change)
    r = _weights(tmp_path, codes=(0,))
    assert "keyed by a deform timeline" in r.stdout, r.stdout
    assert (tmp_path / "o" / "worm.json").read_bytes() == (tmp_path / "p" / "worm.json").read_bytes()



def _bound_bones(mesh: dict) -> set[int]:
    """The bone indices a weighted ``vertices`` list names."""
    v, i, out = mesh["vertices"], 0, set()
    while i < len(v):
        out |= {v[i + 1 + 4 * j] for j in range(int(v[i]))}
        i += 1 + 4 * int(v[i])
    return out


def test_a_bone_below_a_bone_of_another_skin_is_not_bound_to(tmp_path, spine_runtime):
    """``seg2`` is a skin bone (``"skin": true``) of no skin: the runtimes never pose it, and
    ``seg3`` below it (no skin bone itself: the editor makes every bone below a skin bone one)
    is posed from its never-updated transform. The learned choice left ``seg2`` out but bound
    the worm to ``seg3``, which the runtime drew 120 units off (exit 0). In a skin that lists
    ``seg2`` (``red``, drawn with that skin) ``seg3`` was bound at the place the setup pose,
    taken without a skin, gives it, 40 units from the runtime's. Now such a bone is left out with
    that reason; ``seg2`` itself is bound in ``red``."""
    from runtime_tool import dump

    _worm_mesh_project(tmp_path, lambda doc: _bone(doc, "seg2").update(skin=True))
    _weights(tmp_path, "--report", "r.json", codes=(0,))
    (row,) = json.loads((tmp_path / "r.json").read_text())["attachments"]
    assert row["status"] == "weighted" and set(row["bones"]) == {"seg1"}, row
    assert row["left_out"]["seg3"] == "below bone 'seg2', which only some skins activate", row
    before, after = (_runtime_vertices(spine_runtime, tmp_path / d) for d in ("p", "o"))
    assert np.abs(after["worm/worm"] - before["worm/worm"]).max() < 1e-3

    red = tmp_path / "red"

    def in_red(doc):
        _bone(doc, "seg2")["skin"] = True
        mesh = doc["skins"][0]["attachments"].pop("worm")
        doc["skins"].append({"name": "red", "bones": ["seg2"], "attachments": {"worm": mesh}})
    _worm_mesh_project(red, in_red)
    _weights(red, codes=(0,))
    mesh = json.loads((red / "o" / "worm.json").read_text())["skins"][1]["attachments"]["worm"]["worm"]
    assert 2 in _bound_bones(mesh) and 3 not in _bound_bones(mesh), mesh["vertices"][:40]
    for side in ("p", "o"):
        dump(spine_runtime, red / side / "worm.atlas", red / side / "worm.json", None, "0", red / f"{side}.json",
             skin="red")
    drawn = [json.loads((red / f"{side}.json").read_text())["poses"][0]["attachments"][0]["vertices"]
             for side in ("p", "o")]
    assert np.abs(np.subtract(*drawn)).max() < 1e-3


def test_a_default_skin_mesh_on_a_skin_bone_is_bound_to_the_bones_every_skin_drawing_it_poses(tmp_path, spine_runtime):
    """The default skin's attachments are drawn under every skin; on a skin bone, under those that
    activate it. The worm on skin bones ``seg1`` to ``seg3`` (``blue`` activates ``seg1`` and
    ``seg2``, ``red`` all three) was bound to the root alone, every skin bone left out: exact in
    the setup pose, it stayed behind whenever its slot's bone moved (exit 0). Now it is bound to
    the bones both skins activate and drawn, with either skin, where it was; ``seg3`` is left out."""
    from runtime_tool import dump

    def skins(doc):
        for name in ("seg1", "seg2", "seg3"):
            _bone(doc, name)["skin"] = True
        doc["skins"] += [{"name": "red", "bones": ["seg3"], "attachments": {}},
                         {"name": "blue", "bones": ["seg1", "seg2"], "attachments": {}}]
    _worm_mesh_project(tmp_path, skins)
    _weights(tmp_path, "--report", "r.json", codes=(0,))
    (row,) = json.loads((tmp_path / "r.json").read_text())["attachments"]
    assert row["status"] == "weighted" and set(row["bones"]) <= {"seg1", "seg2"} and "seg2" in row["bones"], row
    assert row["left_out"]["seg3"] == "only active in other skins", row
    for skin in ("red", "blue"):
        for side in ("p", "o"):
            dump(spine_runtime, tmp_path / side / "worm.atlas", tmp_path / side / "worm.json", None, "0",
                 tmp_path / f"{side}.{skin}.json", skin=skin)
        drawn = [json.loads((tmp_path / f"{side}.{skin}.json").read_text())["poses"][0]["attachments"][0]["vertices"]
                 for side in ("p", "o")]
        assert np.abs(np.subtract(*drawn)).max() < 1e-3, skin


def _artist_weights(entry):
    """The worm's vertices weighted by ``entry(i, x, y)`` (x, y in ``seg1``'s space; ``seg2`` is 80 further)."""
    def change(doc):
        mesh = doc["skins"][0]["attachments"]["worm"]["worm"]
        v = mesh["vertices"]
        mesh["vertices"] = [n for i in range(len(v) // 2) for n in entry(i, v[2 * i], v[2 * i + 1])]
    return change


ODD_WEIGHTS = {
    "weights summing to 2": _artist_weights(lambda i, x, y: [2, 1, x, y, 1.0, 2, x - 80, y, 1.0]),
    "a vertex of 0 bones": _artist_weights(lambda i, x, y: [0] if i == 4 else [1, 1, x, y, 1.0]),
    "a negative weight": _artist_weights(lambda i, x, y: [2, 1, x, y, 1.5, 2, x - 80, y, -0.5]),
}


@pytest.mark.parametrize("case", sorted(ODD_WEIGHTS))
def test_artist_weights_the_runtime_draws_as_it_reads_them_are_rebound_where_it_drew(tmp_path, spine_runtime, case):
    """``weights --replace`` of weights no editor writes (a sum of 2, a vertex of no bone, drawn
    at the origin, a negative weight): the new binding is drawn where the runtime drew the old."""
    _worm_mesh_project(tmp_path, ODD_WEIGHTS[case])
    _weights(tmp_path, "--replace", codes=(0,))
    mesh = json.loads((tmp_path / "o" / "worm.json").read_text())["skins"][0]["attachments"]["worm"]["worm"]
    assert mesh["vertices"] != json.loads((tmp_path / "p" / "worm.json").read_text())["skins"][0][
        "attachments"]["worm"]["worm"]["vertices"]  # bound again
    before, after = (_runtime_vertices(spine_runtime, tmp_path / d) for d in ("p", "o"))
    assert np.abs(after["worm/worm"] - before["worm/worm"]).max() < 1e-3

# --- the readers of weighted meshes ----------------------------------------------------------------

def _weighted_worm() -> list:
    """The grid worm's 27 vertices each bound to ``seg1`` alone (index 1), weight 1."""
    mesh = worm_mesh()["vertices"]
    return [n for i in range(0, len(mesh), 2) for n in (1, 1, mesh[i], mesh[i + 1], 1)]


BROKEN_COUNTS = {
    "a negative bone count": ([-1] + _weighted_worm()[1:], "vertex 0 gives -1 as its number of bones"),
    "a bone count of 1e9": ([1e9] + _weighted_worm()[1:], "vertex 0 gives 1000000000.0 as its number of bones"),
    "a list that runs past its end": (_weighted_worm()[:-3], "the weighted list ends inside vertex 26 of 27"),
}


@pytest.mark.parametrize("case", sorted(BROKEN_COUNTS))
def test_readers_of_a_weighted_mesh_of_broken_counts_say_it_in_one_line(tmp_path, case):
    """``pose`` draws the rest and warns naming the attachment; ``diff``, with nothing else to
    compare, says which attachment it passed over and why (it said ``(1 skipped)``, no more);
    ``dataset`` counts it among its skipped images (a skeleton whose only art it was said
    nothing: it needed no image, and the count was never reached)."""
    vertices, why = BROKEN_COUNTS[case]
    _worm_mesh_project(tmp_path, lambda doc: doc["skins"][0]["attachments"]["worm"]["worm"].update(vertices=vertices))
    before = snapshot(tmp_path)
    r = run_cli("pose", "p/worm.json", "--out", "pose.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json"], codes=(3,))
    assert f"p/worm.json: skins[0].attachments.worm.worm.vertices: {why}" in r.stderr, r.stderr
    r = run_cli("diff", "p", "--out", "d", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json", "d"], codes=(2,))
    (line,) = [line for line in r.stderr.splitlines() if line.startswith("error:")]
    assert "p/worm.json slot 'worm' attachment 'worm': " in line and why in line, r.stderr
    r = run_cli("dataset", "p", "--out", "ds", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json", "d", "ds"], codes=(0,))
    (row,) = [json.loads(line) for line in (tmp_path / "ds" / "projects.jsonl").read_text().splitlines()]
    assert row["skipped"] == {"attachment of unusable fields": 1}, row
