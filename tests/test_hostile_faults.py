"""Hostile input and faults, fourth round: broken bone trees, memory that runs out, signals.

Same promises as :mod:`test_hostile` (whose helpers these cases use): exit status 0, 2 or 3,
one line naming the file, no traceback, inputs unchanged, nothing written outside the outputs.
"""

from __future__ import annotations

import json

import pytest

from test_hostile import _demo_json, _json_only, _write_json, check_run, demo, run_cli, snapshot  # noqa: F401 (demo: fixture)

# --- the bone tree ------------------------------------------------------------------------------
# demo.json's bones: root, body (root), head (body), arm (body), props (root); slots on them.


def _bones(change):
    def mutate(doc):
        change(doc["bones"])
        return doc
    return mutate


def _swap(bones, i, j):
    bones[i], bones[j] = bones[j], bones[i]


#: case: (change of the document, the line every command gives)
BONE_TREES = {
    "a bone its own parent": (_bones(lambda b: b[2].update(parent="head")),
                              "bones[2].parent: bone 'head' is its own parent"),
    "two bones each other's parent": (_bones(lambda b: (b[2].update(parent="arm"), b[3].update(parent="head"))),
                                      "bones[2].parent: the parents of bones 'head' -> 'arm' -> 'head' run in a cycle"),
    "the root in a cycle": (_bones(lambda b: b[0].update(parent="props")),
                            "bones[0].parent: the parents of bones 'root' -> 'props' -> 'root' run in a cycle"),
    "a parent listed after its child": (_bones(lambda b: _swap(b, 1, 2)),
                                        "bones[1].parent: parent 'body' of bone 'head' is listed after it"),
    "one name for two bones": (_bones(lambda b: b.append({"name": "body", "parent": "head"})),
                               "bones[5].name: 'body' names two bones (bones[1] and bones[5])"),
    "a parent that is no bone": (_bones(lambda b: b[2].update(parent="nope")),
                                 "bones[2].parent: bone 'head' names parent 'nope', which is not a bone"),
    "a slot on no bone": (lambda d: (d["slots"][0].update(bone="nope"), d)[1],
                          "slots[0].bone: slot 'arm' is on bone 'nope', which is not a bone"),
}

#: The commands that read a bone tree, with their outputs.
TREE_COMMANDS = {
    "upgrade --weights auto": (["upgrade", "p", "--out", "o", "--weights", "auto"], ["o"]),
    "weights": (["weights", "p", "--out", "o"], ["o"]),
    "convert to .skel": (["convert", "p/demo.json", "o.skel"], ["o.skel"]),
}


def _broken_tree(demo, case):
    _json_only(demo)
    _write_json(demo / "demo.json", BONE_TREES[case][0](_demo_json(demo)))


@pytest.mark.parametrize("command", sorted(TREE_COMMANDS))
@pytest.mark.parametrize("case", sorted(BONE_TREES))
def test_a_broken_bone_tree_is_refused_with_one_line(tmp_path, demo, case, command):
    """Every command refuses the skeleton with the same line, naming the skeleton (never the
    target of ``convert``, which is not written); none weights meshes to bones in a cycle."""
    _broken_tree(demo, case)
    args, outputs = TREE_COMMANDS[command]
    before = snapshot(tmp_path)
    r = run_cli(*args, cwd=tmp_path)
    check_run(r, before, tmp_path, outputs, codes=(2, 3))
    line = next((x for x in r.stderr.splitlines() if BONE_TREES[case][1] in x), None)
    assert line is not None, r.stdout + r.stderr
    assert "demo.json: " + BONE_TREES[case][1] in line and "o.skel" not in line, line
    assert not (tmp_path / "o.skel").exists() and not (tmp_path / "o" / "demo.json").exists()


def _weighted_head(vertices):
    def mutate(doc):
        doc["skins"][0]["attachments"]["head"]["demo-head"] = {
            "type": "mesh", "uvs": [0, 0, 1, 0, 0, 1], "triangles": [0, 1, 2], "hull": 3,
            "width": 90, "height": 90, "vertices": vertices}
        return doc
    return mutate


#: Three vertices bound to bones 2 and 3 of five; then the same list broken.
WEIGHTED = [1, 2, 0, 0, 1, 1, 2, 10, 0, 1, 2, 2, 0, 10, 0.5, 3, 0, 10, 0.5]
BROKEN_WEIGHTS = {
    "cut after a vertex": (WEIGHTED[:10], "vertices: the weighted list ends after 2 of 3 vertices"),
    "cut inside a vertex": (WEIGHTED[:-3], "vertices: the weighted list ends inside vertex 2 of 3"),
    "a bone index beyond the bones": (WEIGHTED[:15] + [30] + WEIGHTED[16:],
                                      "vertices: vertex 2 is bound to bone index 30, the skeleton has 5 bones"),
    "a bone count beyond the bones": ([9] + WEIGHTED[1:], "vertices: vertex 0 gives 9 as its number of bones"),
}


@pytest.mark.parametrize("case", sorted(BROKEN_WEIGHTS))
def test_broken_weighted_vertices_fail_their_mesh_alone(tmp_path, demo, case):
    """``weights`` leaves the mesh as it was with the reason, weights the others; ``upgrade
    --weights auto`` upgrades the rest; ``convert`` blames the skeleton, not its target."""
    _json_only(demo)
    _write_json(demo / "demo.json", _weighted_head(BROKEN_WEIGHTS[case][0])(_demo_json(demo)))
    why = BROKEN_WEIGHTS[case][1]
    before = snapshot(tmp_path)
    r = run_cli("weights", "p", "--out", "o", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o"], codes=(3,))
    assert "attachment 'demo-head'" in r.stdout + r.stderr and why in r.stdout + r.stderr
    r = run_cli("upgrade", "p", "--out", "u", "--weights", "auto", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "u"])
    assert json.loads((tmp_path / "u" / "demo.json").read_text())["skins"][0]["attachments"]["head"][
        "demo-head"]["vertices"] == BROKEN_WEIGHTS[case][0]  # left as it was
    r = run_cli("convert", "p/demo.json", "c.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "u"], codes=(2,))
    assert "p/demo.json: " in r.stderr and "c.skel" not in r.stderr, r.stderr


def test_the_bone_tree_check_reads_every_real_skeleton(examples):
    """No official example is refused by the tree check nor has a mesh its weights walk refuses."""
    from spinemesh.skeleton import checked_attachments, load_skeleton

    count = 0
    for path in sorted(examples.rglob("*")):
        if path.suffix in (".json", ".skel"):
            doc = load_skeleton(path)
            assert not [p for _, p in checked_attachments(doc) if "vertices" in p], path
            count += 1
    assert count > 20


def test_the_tree_check_is_one_rule_for_json_and_binary(tmp_path):
    """A document read from a ``.skel`` is checked by the same function: one cut weighted list
    gives the same reason whichever format the skeleton came in."""
    from spinemesh.skeleton_check import bone_tree_problem, vertices_problem

    doc = {"bones": [{"name": "a", "parent": "b"}, {"name": "b", "parent": "a"}], "slots": []}
    assert bone_tree_problem(doc) == "bones[0].parent: the parents of bones 'a' -> 'b' -> 'a' run in a cycle"
    doc = {"bones": [{"name": "a"}, {"name": "b", "parent": "c"}, {"name": "c", "parent": "d"},
                     {"name": "d", "parent": "c"}], "slots": []}
    assert "'c' -> 'd' -> 'c' run in a cycle" in bone_tree_problem(doc)  # b leads into a cycle it is not in
    assert vertices_problem([0, 0, 1, 1], 2, 0) == ""  # unweighted
    assert vertices_problem([1, 0, 0, 0, 1], 2, 1) == "the weighted list ends after 1 of 2 vertices"
    assert vertices_problem([1, 0, 0, 0, 1, 0, 7, 8], 2, 1) == "2 numbers follow the 2 weighted vertices"
