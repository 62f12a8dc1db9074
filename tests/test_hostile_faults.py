"""Hostile input and faults, fourth round: broken bone trees, memory that runs out, signals.

Same promises as :mod:`test_hostile` (whose helpers these cases use): exit status 0, 2 or 3,
one line naming the file, no traceback, inputs unchanged, nothing written outside the outputs.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from test_hostile import (MEMORY_LIMIT, TIME_LIMIT, _alive, _children, _demo_json, _json_only, _library_of_demos,
                          _limits, _write_json, check_run, demo, run_cli, snapshot)  # noqa: F401 (demo: fixture)

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
    "an IK constraint on no bone": (lambda d: {**d, "ik": [{"name": "k", "bones": ["arm", "nope"], "target": "head"}]},
                                    "ik[0].bones: 'k' names bone 'nope', which is not a bone"),
    "a path constraint on no slot": (lambda d: {**d, "path": [{"name": "p", "bones": ["arm"], "target": "nope"}]},
                                     "path[0].target: 'p' names slot 'nope', which is not a slot"),
    "a skin naming no bone": (lambda d: (d["skins"][0].update(bones=["nope"]), d)[1],
                              "skins[0].bones: 'default' names bone 'nope', which is not a bone"),
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
    assert f"warning: demo.json: skins[0].attachments.head.demo-head.{why}" in r.stderr, r.stderr
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


# --- signals --------------------------------------------------------------------------------------
#: Seconds a run may take to end after Ctrl-C or SIGTERM, whatever its workers do.
END_WITHIN = 10


def _signal_mid_run(tmp, args, started, sig, worker_fault=None, signal_after=0.3, group=False):
    """Run ``python -m spinemesh ARGS`` in ``tmp``; once ``started`` exists and workers run, do
    ``worker_fault(pids)`` to them, then send ``sig`` to the run (``group``: to its whole process
    group, workers included, as a terminal's Ctrl-C does). Returns the finished run, the seconds
    it took to end after the signal, and the workers still alive after it ended."""
    env = {**os.environ, "COLUMNS": "60", "NO_COLOR": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=tmp, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_limits(MEMORY_LIMIT, None), start_new_session=group)
    seen: set[int] = set()
    try:
        deadline = time.monotonic() + TIME_LIMIT
        while not (started.exists() and _children(proc.pid)):
            assert proc.poll() is None, "the run ended before its workers started"
            assert time.monotonic() < deadline, "the run never started its workers"
            time.sleep(0.02)
        time.sleep(signal_after)
        workers = _children(proc.pid)
        seen.update(workers)
        if worker_fault is not None:
            worker_fault(workers)
        if group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
        t0 = time.monotonic()
        try:
            stdout, stderr = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            stdout = stderr = ""
        took = time.monotonic() - t0
    finally:
        for pid in [proc.pid, *seen]:  # never leave this test's processes behind, whatever failed
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
                os.kill(pid, signal.SIGCONT)
        proc.wait()
    time.sleep(0.5)  # a worker told to end may take a moment after its parent
    alive = [p for p in seen if _alive(p)]
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr), took, alive


def _stop(pids):
    os.kill(pids[0], signal.SIGSTOP)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["Ctrl-C", "SIGTERM"])
@pytest.mark.parametrize("fault", ["a stopped worker", "workers at work", "to the whole group"])
def test_a_signal_ends_the_run_within_seconds(tmp_path, demo, sig, fault):
    """Ctrl-C or SIGTERM ends the run within seconds even while a worker is stopped (SIGSTOP,
    where a SIGTERM stays pending): it is killed after a bounded wait, no process stays, the
    run does not claim success, no traceback, no temporary file, inputs unchanged."""
    _library_of_demos(tmp_path, demo, 6)
    before = snapshot(tmp_path)
    r, took, alive = _signal_mid_run(tmp_path, ["upgrade", "L", "--out", "o", "--jobs", "2", "--density", "4"],
                                     tmp_path / "o" / ".spinemesh-output", sig,
                                     _stop if fault == "a stopped worker" else None,
                                     group=fault == "to the whole group")
    assert took < END_WITHIN, f"still running {took:.0f} s after {sig.name}"
    assert not alive, f"workers {alive} outlived the run"
    check_run(r, before, tmp_path, ["o"], codes=(128 + sig,))
    assert "KeyboardInterrupt" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr


_SIGNAL_IN_A_FINALIZER = """
import os, signal, sys, time
from spinemesh.processes import exit_on_terminate
from spinemesh.cluster import ProcessWorkers, _Mapping, shared_array
import numpy as np

exit_on_terminate()
SIG = signal.{sig}
unmap = _Mapping.__del__

def unmap_as_the_signal_comes(self):
    os.kill(os.getpid(), SIG)  # delivered at the finalizer's next instruction
    unmap(self)

_Mapping.__del__ = unmap_as_the_signal_comes
with ProcessWorkers(1) as workers:
    page = workers.submit(shared_array, np.ones((64, 64, 4), np.uint8)).result()  # a page handed back
    del page  # its mapping's finalizer runs here
    for _ in range(50):
        time.sleep(0.01)
    print("went on as if nothing came", flush=True)
"""


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_signal_during_a_page_handed_back_is_not_lost(tmp_path, sig):
    """A signal that comes while the shared mapping of a page handed back by a worker is
    unmapped (a finalizer, where Python drops exceptions as "Exception ignored") still ends the
    run: raised again at once, never a run that goes on to exit 0."""
    r = subprocess.run([sys.executable, "-c", _SIGNAL_IN_A_FINALIZER.format(sig=sig)], capture_output=True,
                       text=True, timeout=60, cwd=tmp_path)
    assert "Exception ignored" not in r.stderr and "went on" not in r.stdout, r.stdout + r.stderr
    if sig == "SIGTERM":
        assert r.returncode == 128 + signal.SIGTERM and "Traceback" not in r.stderr, r.stderr
    else:  # the command line ends a KeyboardInterrupt with status 130; here Python ends on it
        assert r.returncode == -signal.SIGINT and r.stderr.rstrip().endswith("KeyboardInterrupt"), r.stderr


# --- memory that runs out -------------------------------------------------------------------------
#: Address-space limits under which a 9000x9000 image cannot be decoded (tight) or meshed
#: (loose) while the interpreter, numpy and OpenCV still start and small images go on.
TIGHT_MEMORY = 900 * 1024**2
LOOSE_MEMORY = 1200 * 1024**2


def _big_sprite(path: Path, side: int = 9000) -> None:
    """A ``side`` x ``side`` RGBA sprite: a filled disc (small as a file, 324 MB decoded)."""
    import cv2
    import numpy as np

    rgba = np.zeros((side, side, 4), np.uint8)
    cv2.circle(rgba, (side // 2, side // 2), side * 4 // 9, (40, 80, 200, 255), -1)
    cv2.imwrite(str(path), rgba)


def _big_region_project(demo: Path) -> None:
    """The demo project with its head drawn from a page of its own, 9000x9000."""
    _json_only(demo)
    shutil.rmtree(demo / "images")
    _big_sprite(demo / "big.png")
    (demo / "big.atlas").write_text("big.png\n\tsize: 9000, 9000\n\tfilter: Linear, Linear\n"
                                    "demo-head\n\tbounds: 0, 0, 9000, 9000\n")
    atlas = demo / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("demo-head\n\tbounds: 105, 2, 81, 81\n\toffsets: 5, 4, 90, 90\n", ""))


@pytest.mark.parametrize("memory", [TIGHT_MEMORY, LOOSE_MEMORY], ids=["cannot decode", "cannot mesh"])
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_region_that_cannot_be_allocated_fails_alone(tmp_path, demo, memory, jobs):
    """``upgrade`` with a 9000x9000 region under a memory limit: that attachment stays a region,
    its line names it, the image's size and what it needs; the others are meshed (exit 3)."""
    _big_region_project(demo)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", jobs, "--report", "r.json", cwd=tmp_path, memory=memory,
                timeout=240)
    check_run(r, before, tmp_path, ["o", "r.json"], codes=(3,))
    line = next(x for x in (r.stdout + r.stderr).splitlines() if "not enough memory" in x)
    assert "demo-head" in line and "9000x9000 image" in line and "MB needed" in line, line
    rows = {row["name"]: row for row in json.loads((tmp_path / "r.json").read_text())["attachments"]}
    assert rows["demo-head"]["status"] == "failed"
    assert rows["demo-body"]["status"] == "meshed"


def test_a_data_set_image_that_cannot_be_allocated_fails_alone(tmp_path, demo):
    """``dataset`` of the project with a 9000x9000 region under a memory limit: that image is
    listed with its size and what it needs; the project's other images are stored."""
    _big_region_project(demo)
    before = snapshot(tmp_path)
    r = run_cli("dataset", "p", "--out", "ds", "--jobs", "1", cwd=tmp_path, memory=LOOSE_MEMORY, timeout=240)
    check_run(r, before, tmp_path, ["ds"], codes=(0, 3))
    text = r.stdout + r.stderr
    assert "image 'demo-head': 9000x9000 image: not enough memory" in text, text
    rows = (tmp_path / "ds" / "index.jsonl").read_text().splitlines()
    assert {json.loads(row)["name"] for row in rows} >= {"demo-body", "demo-arm"}


def test_mesh_and_segment_of_an_image_that_cannot_be_allocated(tmp_path, demo):
    """``mesh DIR``: the big image is skipped with its line, the others are written (exit 3);
    ``mesh`` and ``segment`` of that image alone: one line naming it (exit 2)."""
    art = tmp_path / "art"
    shutil.copytree(demo / "images", art)
    _big_sprite(art / "big.png")
    before = snapshot(tmp_path)
    r = run_cli("mesh", "art", "--out", "meshes", cwd=tmp_path, memory=TIGHT_MEMORY, timeout=240)
    check_run(r, before, tmp_path, ["meshes"], codes=(3,))
    assert "big.png: 9000x9000 image: not enough memory" in r.stderr, r.stderr
    assert (tmp_path / "meshes" / "demo-head.json").is_file()
    for args in (["mesh", "art/big.png", "--out", "big.mesh.json"], ["segment", "art/big.png", "--out", "big.png"]):
        r = run_cli(*args, cwd=tmp_path, memory=TIGHT_MEMORY, timeout=240)
        check_run(r, before, tmp_path, ["meshes"], codes=(2,))
        assert r.stderr.startswith("error: art/big.png: 9000x9000 image: not enough memory to "), r.stderr


def test_pages_decoded_ahead_stay_within_their_budget(tmp_path):
    """The pages a prefetch has submitted and not handed over never hold more texels than its
    budget (sizes from the headers); a page larger than the budget alone is never decoded ahead,
    and the page store counts the pages ahead against its own budget."""
    from concurrent.futures import Future

    import numpy as np
    from PIL import Image

    from spinemesh.images.decode import load_rgba
    from spinemesh.images.pages import PagePrefetch, PageStore

    paths = []
    for i, side in enumerate([100, 100, 100, 200, 100]):  # 40,000 bytes of texels, one of 160,000
        paths.append(tmp_path / f"p{i}.png")
        Image.fromarray(np.full((side, side, 4), i, np.uint8)).save(paths[-1])
    submitted, most = [], [0]

    def submit(path):
        future = Future()
        future.set_result(load_rgba(path))
        submitted.append(path)
        return future

    prefetch = PagePrefetch(submit, window=10, max_bytes=100_000)
    store = PageStore(max_bytes=120_000)
    store.prefetch = prefetch
    store.decode_ahead(paths)
    for path in paths:
        most[0] = max(most[0], prefetch.bytes_ahead)
        assert prefetch.bytes_ahead <= 100_000
        assert sum(p.nbytes for p in store._pages.values()) + prefetch.bytes_ahead <= 120_000 + 160_000
        assert store.page(path)[0, 0, 0] == paths.index(path)
    assert most[0] == 80_000  # two pages ahead at once, not five
    assert paths[3] not in submitted  # larger than the budget: decoded by the store itself
    assert prefetch.bytes_ahead == 0


# --- data sets ------------------------------------------------------------------------------------

def test_dataset_resumed_over_broken_metadata_says_so(tmp_path, demo):
    """A data set whose ``meta.json`` was cut short, or whose project list holds a broken row in
    its middle, is refused with one line naming the file (exit 2), never a JSONDecodeError."""
    _json_only(demo)
    r = run_cli("dataset", "p", "--out", "ds", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    meta = tmp_path / "ds" / "meta.json"
    whole = meta.read_bytes()
    meta.write_bytes(whole[:40])
    before = snapshot(tmp_path)
    r = run_cli("dataset", "p", "--out", "ds", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["ds"], codes=(2,))
    assert r.stderr.startswith("error: ds/meta.json: unreadable data set metadata"), r.stderr
    meta.write_bytes(whole)
    rows = tmp_path / "ds" / "projects.jsonl"
    rows.write_bytes(b'{"project": "x", "err\n' + rows.read_bytes())
    before = snapshot(tmp_path)
    r = run_cli("dataset", "p", "--out", "ds", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["ds"], codes=(2,))
    assert r.stderr.startswith("error: ds/projects.jsonl:1: unreadable row"), r.stderr


def test_dataset_of_an_empty_folder_is_nothing_to_do(tmp_path):
    (tmp_path / "empty").mkdir()
    before = snapshot(tmp_path)
    r = run_cli("dataset", "empty", "--out", "ds", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert r.stderr.startswith("error: empty: no Spine skeleton found"), r.stderr
    assert not (tmp_path / "ds").exists()


# --- tried as a new user --------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["upgrade", "pack"])
def test_a_missing_project_is_said_missing_whatever_the_outputs(tmp_path, command):
    """The getting-started command from the wrong folder: the project is missing, and that is
    what the one line says (not that a relative --preview lies inside ``.``)."""
    r = run_cli(command, "demo", "--out", "m1", "--preview", "m1-preview", cwd=tmp_path)
    check_run(r, {}, tmp_path, [], codes=(2,))
    assert r.stderr == "error: demo: no such file or folder\n", r.stderr


def test_error_lines_start_the_output(tmp_path, demo):
    """No blank line before an error: a progress display drew nothing on a pipe, so it leaves nothing."""
    r = run_cli("upgrade", "p", "--out", "p/inside", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("error: "), repr(r.stderr[:80])
    r = run_cli("upgrade", "nothing-here", "--out", "o", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("error: "), repr(r.stderr[:80])


@pytest.mark.parametrize("triangles", [[0, 1, 2, 0], [0, 1, 2.5], [0, 1, 3]], ids=["not whole", "not an index", "past"])
def test_an_artist_weighted_mesh_with_broken_triangles_is_passed_over(tmp_path, demo, triangles):
    """The habits ``--weights auto`` reads (on the workers with --jobs 2) pass over a weighted mesh
    whose triangles are not whole triangles of its vertices; ``weights --replace`` fails it alone."""
    _json_only(demo)
    doc = _weighted_head(WEIGHTED)(_demo_json(demo))
    doc["skins"][0]["attachments"]["head"]["demo-head"]["triangles"] = triangles
    _write_json(demo / "demo.json", doc)
    before = snapshot(tmp_path)
    outputs = []
    for jobs in (1, 2):
        r = run_cli("upgrade", "p", "--out", f"u{jobs}", "--weights", "auto", "--jobs", jobs, cwd=tmp_path)
        check_run(r, before, tmp_path, [f"u{j}" for j in range(1, jobs + 1)], codes=(0,))
        out = json.loads((tmp_path / f"u{jobs}" / "demo.json").read_text())
        assert out["skins"][0]["attachments"]["head"]["demo-head"]["triangles"] == triangles  # left as it was
        outputs.append(out)
    assert outputs[0] == outputs[1]
    r = run_cli("weights", "p", "--out", "w", "--replace", cwd=tmp_path)
    check_run(r, before, tmp_path, ["u1", "u2", "w"], codes=(3,))
    assert "attachment 'demo-head'" in r.stdout + r.stderr and "triangles do not index the vertices" in r.stdout + r.stderr


def _die_on_a_fill(arg):
    """A packing worker that dies (as an out-of-memory kill would) on every fill it is given."""
    os._exit(9)


def test_an_atlas_whose_fills_kill_their_workers_is_kept_as_it_was(tmp_path, meshed, monkeypatch):
    """``pack --jobs 2`` of one atlas runs its fills on the workers: where they die on every try,
    the atlas is copied as it was with the reason, and nothing packed is written."""
    from spinemesh.cluster import ProcessWorkers
    from spinemesh.pack import parallel
    from spinemesh.pack.report import PackResult
    from spinemesh.pack.run import PackOptions, pack_project_into
    from spinemesh.project import find_project

    monkeypatch.setattr(parallel, "fill_task", _die_on_a_fill)
    result = PackResult()
    with ProcessWorkers(2) as workers:
        pack_project_into(find_project(meshed), tmp_path / "o", PackOptions(jobs=2), result, workers=workers)
    (row,) = result.atlases
    assert row.status == "failed" and "exited with status 9" in row.reason, row.reason
    for name in ("demo.atlas", "demo.png", "demo.json"):
        assert (tmp_path / "o" / name).read_bytes() == (meshed / name).read_bytes(), name


_REAL_MESH_ONE: dict = {}


def _die_on_bending_tasks(task):
    """A meshing worker that dies (as an out-of-memory kill would) on every bending task."""
    from spinemesh.upgrade.plan import BENDS_KEY

    if task.key.startswith(BENDS_KEY):
        os._exit(9)
    return _REAL_MESH_ONE["mesh_one"](task)


def test_a_region_whose_bending_task_kills_its_worker_stays_as_it_was(tmp_path, monkeypatch):
    """``upgrade --weights auto --jobs 2``: the bending task sent as the plain mesh arrived dies on
    every try; that region fails alone with the reason and is written as the region it was."""
    from test_upgrade_weights import attachments, make_bar_project

    from spinemesh.cluster import ProcessWorkers
    from spinemesh.upgrade import Options, meshing, upgrade_project

    project = make_bar_project(tmp_path / "p")
    monkeypatch.setitem(_REAL_MESH_ONE, "mesh_one", meshing.mesh_one)
    monkeypatch.setattr(meshing, "mesh_one", _die_on_bending_tasks)
    with ProcessWorkers(2) as workers:
        result = upgrade_project(project, tmp_path / "o", Options(weights="auto", jobs=2), workers=workers)
    rows = {t.slot: t for t in result.targets}
    assert rows["bar"].status == "failed" and "exited with status 9" in rows["bar"].reason, rows["bar"]
    assert rows["flag"].status == "kept" and result.written == ["bar.json"]
    assert attachments(tmp_path / "o" / "bar.json") == attachments(project)


def _no_memory_for_a_fill(arg):
    """A packing fill that cannot have the memory it asks for, on a worker or here."""
    raise MemoryError


@pytest.mark.parametrize("jobs", [1, 2])
def test_an_atlas_whose_fills_run_out_of_memory_fails_alone(tmp_path, meshed, monkeypatch, jobs):
    """Memory refused to a fill (``pack`` with ``--jobs 2``: on a worker) fails that atlas with one
    line, its files copied as they were, and the run goes on: never a traceback."""
    from spinemesh.cluster import ProcessWorkers
    from spinemesh.pack import atlas_pack, parallel
    from spinemesh.pack.report import PackResult
    from spinemesh.pack.run import NO_MEMORY, PackOptions, pack_project_into
    from spinemesh.project import find_project

    monkeypatch.setattr(parallel, "fill_task", _no_memory_for_a_fill)
    monkeypatch.setattr(atlas_pack, "run_fill", lambda *a: _no_memory_for_a_fill(a))
    result = PackResult()
    with ProcessWorkers(jobs) as workers:
        pack_project_into(find_project(meshed), tmp_path / "o", PackOptions(jobs=jobs), result, workers=workers)
    (row,) = result.atlases
    assert row.status == "failed" and row.reason == NO_MEMORY, row.reason
    for name in ("demo.atlas", "demo.png", "demo.json"):
        assert (tmp_path / "o" / name).read_bytes() == (meshed / name).read_bytes(), name


def test_habits_whose_worker_had_no_memory_for_them_are_read_here(tmp_path):
    """A skeleton's habits job that fails for memory on its worker (the job or its answer too large to
    hand over) is read in this process, as one whose worker was lost: the same habits."""
    from concurrent.futures import Future
    from types import SimpleNamespace

    import numpy as np

    from spinemesh.cluster import Workers
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.learned import project_habits
    from spinemesh.upgrade.bending import gather_habits, start_habits

    class NoMemoryWorkers(Workers):
        def submit(self, fn, arg, first=False):
            future = Future()
            future.set_exception(MemoryError())
            return future

    doc = _weighted_head(WEIGHTED)(json.loads((Path(__file__).parents[1] / "examples" / "demo" / "demo.json").read_text()))
    expected = project_habits([(doc, build_rig(doc))])
    assert len(expected.keys) == 1  # the weighted head
    skeletons = [SimpleNamespace(doc=doc, rig=build_rig(doc))]
    plan = SimpleNamespace(habits=start_habits(skeletons, NoMemoryWorkers()), skeletons=skeletons)
    gather_habits(plan)
    assert np.array_equal(plan.habits.tallies, expected.tallies) and plan.habits.keys == expected.keys
