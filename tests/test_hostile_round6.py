"""Hostile input, sixth round: what the last round of work added (``pose``'s stream, the preview's
animations sampled over ``--jobs``, 3.x curves read per version, 4.3 physics).

As in round five (tests/test_hostile_wave4.py), every skeleton and project is made here by our
own code; each case checks what docs/safety.md promises: no traceback, one line naming the file,
nothing non-finite written, one bad animation never stopping the others, bounded time, and no
process or temporary file left behind.
"""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from test_anim43 import physics_doc
from test_hostile import snapshot
from test_hostile_wave4 import within

from spinemesh.anim import Sampler
from spinemesh.anim.dump import dump


def _strict(obj) -> dict:
    return json.loads(json.dumps(obj, allow_nan=False))


# --- physics (4.2 and 4.3) driven past what a float holds -------------------------------------

def _as_42(doc: dict) -> dict:
    """A 4.3 physics document as 4.2 writes it (a ``physics`` list, no ``type``)."""
    doc = copy.deepcopy(doc)
    doc["skeleton"]["spine"] = "4.2.11"
    doc["physics"] = [{k: v for k, v in c.items() if k not in ("type", "scaleY")} for c in doc.pop("constraints")]
    return doc


def _diverging(version: str, where: str) -> dict:
    """Physics whose springs blow up to infinity within a few steps: values the document's check
    lets through (strength 1e9, mass 1e-9 on one bone, five times), or animated to 1e30."""
    doc = physics_doc()
    if where == "setup":
        doc["constraints"] += [{"type": "physics", "name": f"stiff{i}", "bone": "tail", "x": 1, "rotate": 1,
                                "strength": 1e9, "mass": 1e-9} for i in range(5)]
        doc["animations"]["h"] = copy.deepcopy(doc["animations"]["sway"])
    else:
        doc["animations"]["h"] = {"physics": {"tail": {where: [{"value": 1e30}]}},
                                  "bones": {"body": {"rotate": [{"value": 0}, {"time": 1, "value": 90}]}}}
    return doc if version == "4.3" else _as_42(doc)


@pytest.mark.parametrize("version, where", [("4.2", "strength"), ("4.2", "damping"), ("4.2", "mix"),
                                            ("4.3", "strength"), ("4.3", "damping"), ("4.3", "setup")])
def test_physics_whose_springs_diverge_flags_its_bones_instead_of_refusing_the_animation(version, where):
    """The runtimes draw such a bone nowhere (NaN); the sampler once raised a math domain error
    and refused the whole animation. Now the bone and those below it are flagged (null in the
    dump), every other bone posed."""
    sampler = Sampler(_diverging(version, where))
    with within(30):
        out = _strict(dump(sampler, "h", [0.05, 0.5, 1.5]))
    last = out["poses"][-1]
    assert "tail" in last["inexact"] and "tip" in last["inexact"]
    assert last["bones"]["chin"] is not None and "chin" not in last["inexact"]


# --- pose's stream on standard output -----------------------------------------------------

def _spinemesh(*args, cwd: Path, stdout, timeout: float = 60) -> subprocess.CompletedProcess:
    """``python -m spinemesh ARGS`` with its standard output given (a file opened here, a shell's
    redirection), its stderr read."""
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    return subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=env, stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=timeout, check=False)


def _one_error(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    return line


@pytest.fixture
def demo_project(tmp_path) -> Path:
    from spinemesh.demo import make_demo_project

    return make_demo_project(tmp_path / "p")


@pytest.mark.parametrize("target", ["p/demo.json", "p/demo.atlas", "p/new.json", "p/images/pose.json"])
def test_pose_never_streams_into_its_input_through_a_shell_redirection(tmp_path, demo_project, target):
    """``spinemesh pose hero.json >> hero.json`` once appended the poses to the skeleton itself
    (exit 0); standard output redirected to a file the run reads, or into its project, is now
    refused as such an --out is, before anything is written."""
    before = snapshot(demo_project)
    with open(tmp_path / target, "a", encoding="utf-8") as stdout:
        r = _spinemesh("pose", "p/demo.json", "-a", "wave", "--times", "0,0.5", "--atlas", "p/demo.atlas",
                       cwd=tmp_path, stdout=stdout)
    line = _one_error(r)
    assert "standard output" in line and str((tmp_path / target).resolve()) in line, line
    if target.endswith(("pose.json", "new.json")):
        assert (tmp_path / target).stat().st_size == 0  # made by the shell, nothing written in it
        (tmp_path / target).unlink()
    assert snapshot(demo_project) == before
    # beside the project the same redirection writes the whole document
    with open(tmp_path / "pose.json", "w", encoding="utf-8") as stdout:
        r = _spinemesh("pose", "p/demo.json", "-a", "wave", "--times", "0,0.5", cwd=tmp_path, stdout=stdout)
    assert r.returncode == 0, r.stderr
    assert len(json.loads((tmp_path / "pose.json").read_text())["poses"]) == 3



def test_pose_never_writes_onto_the_atlas_it_reads(tmp_path, demo_project):
    """``pose hero.json --atlas shared/hero.atlas --out shared/hero.atlas`` replaced the atlas,
    read from outside the project, by the poses (exit 0); it is refused as the skeleton is."""
    shared = tmp_path / "shared"
    shared.mkdir()
    (shared / "x.atlas").write_bytes((demo_project / "demo.atlas").read_bytes())
    before = snapshot(shared)
    r = _spinemesh("pose", "p/demo.json", "-a", "wave", "--atlas", "shared/x.atlas", "--out", "shared/x.atlas",
                   cwd=tmp_path, stdout=subprocess.PIPE)
    line = _one_error(r)
    assert "shared/x.atlas" in line and "input" in line, line
    assert snapshot(shared) == before


def test_pose_to_a_closed_or_full_standard_output_is_not_a_success(tmp_path, demo_project):
    """A closed standard output (``>&-``) once wrote nothing and exited 0; a full one (/dev/full)
    said only "No space left on device". Each now ends in one line naming standard output."""
    pose = [sys.executable, "-m", "spinemesh", "pose", "p/demo.json", "-a", "wave", "--times", "0,0.5"]
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    closed = subprocess.run(["sh", "-c", '"$@" >&-', "sh", *pose], cwd=tmp_path, env=env, stderr=subprocess.PIPE,
                            text=True, timeout=60, check=False)
    assert "standard output is closed" in _one_error(closed)
    if os.path.exists("/dev/full"):
        with open("/dev/full", "w") as full:
            r = _spinemesh(*pose[3:], cwd=tmp_path, stdout=full)
        assert "standard output: cannot write" in _one_error(r)


def test_pose_into_a_pipe_its_reader_closed_ends_quietly(tmp_path, demo_project):
    """``spinemesh pose ... | head -c 100``: the run ends at its next write after the reader is
    gone, with no traceback and a status that is not success (1, as the command line ends a
    closed pipe), within seconds although the whole document is about 8 MB."""
    times = ",".join(f"{i / 100:g}" for i in range(3000))
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    run = subprocess.Popen([sys.executable, "-m", "spinemesh", "pose", "p/demo.json", "-a", "wave", "--times", times],
                           cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert run.stdout.read(100).startswith(b'{"input"')
    run.stdout.close()
    stderr = run.stderr.read().decode()
    assert run.wait(60) == 1 and "Traceback" not in stderr and "Exception" not in stderr, stderr


def test_pose_to_a_disk_that_fills_mid_stream_leaves_no_file(tmp_path, demo_project):
    """The disk fills (here: a file size limit of 64 KiB) after some poses were streamed to
    --out: one line naming --out, no temporary file, and what --out held is kept."""
    from test_hostile import check_run, run_cli

    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "pose.json").write_text("what was there")
    times = ",".join(f"{i / 100:g}" for i in range(100))  # about 280 kB of JSON
    before = snapshot(tmp_path)
    r = run_cli("pose", "p/demo.json", "-a", "wave", "--times", times, "--out", "out/pose.json", cwd=tmp_path,
                file_size=64 * 1024)
    check_run(r, before, tmp_path, ["out"], codes=(2,))
    assert "out/pose.json" in _one_error(r) and (tmp_path / "out" / "pose.json").read_text() == "what was there"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["pose.json"]



def test_an_interruption_just_after_a_temporary_file_is_made_leaves_none(tmp_path, monkeypatch):
    """Ctrl-C (or the SIGTERM that becomes SystemExit) lands between two instructions: once it
    landed inside ``tempfile.mkstemp``, after the file was made and before its name came back,
    and the file stayed (the preview's data scripts, about one run in eight). The name is now
    held before the file is made: here the interruption comes just as ``open`` returns."""
    from spinemesh.files.atomic import atomic_write_files, atomic_write_text

    real = os.open

    def then_interrupted(path, flags, *args, **kwargs):
        fd = real(path, flags, *args, **kwargs)
        if flags & os.O_EXCL:
            os.close(fd)
            raise KeyboardInterrupt
        return fd

    (tmp_path / "kept.txt").write_text("what was there")
    monkeypatch.setattr(os, "open", then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_text(tmp_path / "kept.txt", "new")
    with pytest.raises(KeyboardInterrupt):
        atomic_write_files({tmp_path / "a.atlas": b"a", tmp_path / "a.png": b"p"})
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.txt"]
    assert (tmp_path / "kept.txt").read_text() == "what was there"


# --- the preview's animations sampled over --jobs ----------------------------------------------

def _library_of_animations(tmp_path: Path, extra: dict) -> Path:
    """The demo project, its skeleton given ``extra`` animations (its .skel twin removed)."""
    from spinemesh.demo import make_demo_project

    demo = make_demo_project(tmp_path / "lib" / "demo")
    doc = json.loads((demo / "demo.json").read_text())
    doc["animations"] |= extra
    (demo / "demo.json").write_text(json.dumps(doc))
    (demo / "demo-binary.skel").unlink()
    return demo


def _doomed_worker(task):
    """The preview's task, except that the worker sampling "doomed" is killed (SIGKILL): as the
    system's out-of-memory killer would kill it, on each of its tries."""
    import signal

    from spinemesh.upgrade import preview

    if "doomed" in task[-1]:
        os.kill(os.getpid(), signal.SIGKILL)
    return preview._sample_in_worker_unpatched(task)


def test_a_worker_killed_while_sampling_leaves_out_its_animations_only(tmp_path, monkeypatch):
    """A worker killed (twice: the task is run again once) while it samples one animation once
    left the whole player off the skeleton's page; now the page plays the other animations and
    says, in one line, which were left out and why. No worker outlives the preview."""
    import multiprocessing
    import re

    from spinemesh.upgrade import Options, preview, upgrade_library
    from spinemesh.upgrade.preview import write_preview

    turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 2, "value": 90}]}}}
    _library_of_animations(tmp_path, {"slow": turn, "doomed": copy.deepcopy(turn), "late": copy.deepcopy(turn)})
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(jobs=1))
    monkeypatch.setattr(preview, "CHUNK_SECONDS", 0.0)  # a task per animation
    monkeypatch.setattr(preview, "_sample_in_worker_unpatched", preview._sample_in_worker, raising=False)
    monkeypatch.setattr(preview, "_sample_in_worker", _doomed_worker)  # workers fork after this
    with within(120):
        index = write_preview(result, tmp_path / "lib", tmp_path / "out", tmp_path / "v", jobs=2)
    (page,) = index.parent.glob("s/*.html")
    model = next(index.parent.glob("data/*/model.js")).read_text(encoding="utf-8")
    assert re.findall(r'"name":"([^"]+)","dur"', model) == ["setup pose", "wave", "slow", "late"]
    lines = re.findall(r"<li>([^<]*)</li>", page.read_text(encoding="utf-8"))
    (line,) = [x for x in lines if "doomed" in x]
    assert "not shown" in line and "SIGKILL" in line and "2 times" in line, line
    assert not multiprocessing.active_children()


def test_a_skeleton_changed_during_the_preview_is_not_mixed_into_its_page(tmp_path, monkeypatch):
    """The preview plans a page from the skeletons it read, then worker processes read them
    again to sample the animations: a file changed in between (an artist saving over it) once
    made the page play the new version's animations over the old one's setup pose, silently.
    Now every animation shown is the one the page was planned from (byte for byte what one
    process writes), and those a worker could not read as planned are listed, naming the file."""
    import re

    from spinemesh.upgrade import Options, preview, upgrade_library
    from spinemesh.upgrade.preview import write_preview

    demo = _library_of_animations(tmp_path, {"slow": {"bones": {"arm": {"rotate": [
        {"value": 0}, {"time": 2, "value": 90}]}}}})
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(jobs=1))
    write_preview(result, tmp_path / "lib", tmp_path / "out", tmp_path / "v1", jobs=1)
    read_pairs = preview._read_pairs

    def read_then_edit(skeletons):
        got = read_pairs(skeletons)
        doc = json.loads((demo / "demo.json").read_text())
        doc["animations"]["slow"]["bones"]["arm"]["rotate"][1]["value"] = -90
        (demo / "demo.json").write_text(json.dumps(doc))
        return got

    monkeypatch.setattr(preview, "_read_pairs", read_then_edit)
    with within(120):
        index = write_preview(result, tmp_path / "lib", tmp_path / "out", tmp_path / "v2", jobs=2)
    data1, data2 = (sorted(p.relative_to(v / "data") for p in (v / "data").rglob("*.js") if p.name != "model.js")
                    for v in (tmp_path / "v1", tmp_path / "v2"))
    assert len(data1) == 3  # the setup pose, "wave" and "slow"
    for rel in data2:  # whatever is shown is the version the page was planned from
        assert (tmp_path / "v2" / "data" / rel).read_bytes() == (tmp_path / "v1" / "data" / rel).read_bytes(), rel
    (page,) = index.parent.glob("s/*.html")
    lines = [x for x in re.findall(r"<li>([^<]*)</li>", page.read_text(encoding="utf-8")) if "changed on disk" in x]
    # the page names the file from the library's name (the same bytes from any folder)
    assert len(data2) < 3 and lines and all("lib/demo/demo.json" in x for x in lines), lines


# --- 3.x curves of every JSON type ---------------------------------------------------------------

#: What a 3.x key's ``curve`` (or 3.8's ``c2``..``c4``) may hold in a hand-edited file: every JSON
#: type, lists of every length and depth, numbers past a float32 and integers of 400 digits.
BIG = int("1" + "0" * 400)
CURVE_VALUES = [True, False, None, {}, {"a": 1}, [], [1], [[1, 2], [3, 4], [5], 6], [1, 2, 3],
                [0.1, 0.2, 0.3, 0.4, 0.5], ["a", "b", "c", "d"], [True] * 4, [None] * 4, [BIG] * 4,
                [1e308, -1e308, 1e308, -1e308], [{}, [], "x", None], BIG, -BIG, 1e308, 1e39, -1, 0,
                "stepped", "linear", "bezier", "", "\u2028"]


def _doc3(version: str, value, field: str = "curve") -> dict:
    """A 3.x skeleton whose first key of a rotate, a translate and a colour timeline has
    ``field`` = ``value`` (3.8's ``c2``..``c4`` beside a curve of 0.3)."""
    first = {"time": 0, "curve": value} if field == "curve" else {"time": 0, "curve": 0.3, field: value}
    skins = {"default": {"s": {"a": {"width": 10, "height": 4}}}}
    return {"skeleton": {"spine": version},
            "bones": [{"name": "root"}, {"name": "arm", "parent": "root", "x": 5, "length": 10}],
            "slots": [{"name": "s", "bone": "arm", "attachment": "a"}],
            "skins": [{"name": "default", "attachments": skins["default"]}] if version.startswith("3.8") else skins,
            "animations": {"a": {
                "bones": {"arm": {"rotate": [{**first, "angle": 0}, {"time": 1, "angle": 90}],
                                  "translate": [{**first, "x": 0, "y": 0}, {"time": 1, "x": 5, "y": 5}]}},
                "slots": {"s": {"color": [{**first, "color": "ffffffff"}, {"time": 1, "color": "00000000"}]}}}}}


@pytest.mark.parametrize("version, field", [("3.5.51", "curve"), ("3.6.53", "curve"), ("3.7.94", "curve"),
                                            ("3.8.99", "curve"), ("3.8.99", "c2"), ("3.8.99", "c3"),
                                            ("3.8.99", "c4")])
def test_3x_curves_of_every_json_type_pose_play_and_convert(tmp_path, version, field):
    """Each read as its version's runtime reads it (a curve it cannot draw as a Bezier is
    linear): the pose is finite, the player shows the animation, and the binary writer writes
    it or refuses it in one short line saying what the key holds."""
    from spinemesh.player.frames import animations
    from spinemesh.skeleton import load_skeleton
    from spinemesh.skeleton_binary import SkelFormatError, encode_skel, read_skel

    refused = 0
    with within(60):
        for value in CURVE_VALUES:
            path = tmp_path / "x.json"
            path.write_text(json.dumps(_doc3(version, value, field)))
            doc = load_skeleton(path)
            out = _strict(dump(Sampler(doc), "a", [0, 0.3, 0.7]))
            assert all(p["bones"]["arm"] is not None for p in out["poses"]), value
            problems: list[str] = []
            assert [a.name for a in animations(doc, doc, problems=problems)] == ["setup pose", "a"], problems
            try:
                _strict(read_skel(encode_skel(doc)))
            except SkelFormatError as e:
                refused += 1
                assert len(str(e)) < 300 and "\n" not in str(e), str(e)
    assert refused < len(CURVE_VALUES)


def test_convert_names_what_a_3x_bezier_holds_in_one_short_line(tmp_path):
    """A Bezier of 400-digit integers once printed them whole (a line of 1,700 characters), a
    handle of 1e39 a Python OverflowError, and a bad 3.8 ``c3`` the ``curve`` beside it."""
    cases = {"big.json": _doc3("3.7.94", [BIG] * 4), "wide.json": _doc3("3.6.53", [1e39, 0, 0, 1]),
             "c3.json": _doc3("3.8.99", {"a": 1}, "c3")}
    words = {"big.json": "an integer of 401 digits", "wide.json": "the number 1e+39", "c3.json": "an object"}
    for name, doc in cases.items():
        (tmp_path / name).write_text(json.dumps(doc))
        r = _spinemesh("convert", name, name.replace(".json", ".skel"), cwd=tmp_path, stdout=subprocess.PIPE)
        line = _one_error(r)
        assert line.startswith(f"error: {name}:") and words[name] in line and len(line) < 300, line
        assert not (tmp_path / name.replace(".json", ".skel")).exists()


# --- 4.3 physics with hostile numbers through pose and the preview -----------------------------

#: One constraint per hostile setting, each on a bone of its own (the root's included).
HOSTILE_PHYSICS = {
    "root": {"x": 1, "y": 1, "rotate": 1, "scaleX": 1, "shearX": 1, "gravity": 1e9},
    "fps0": {"rotate": 1, "fps": 0}, "fpsneg": {"x": 1, "fps": -5}, "fps1e9": {"rotate": 1, "fps": 1e9},
    "fpstiny": {"y": 1, "fps": 1e-300},
    "inertia": {"x": 1, "inertia": 1e9, "limit": 1e9}, "massless": {"rotate": 1, "scaleX": 1, "mass": 0},
    "stiff": {"x": 1, "rotate": 1, "strength": 1e9, "mass": 1e-9}, "nolimit": {"x": 1, "y": 1, "limit": 0},
    "windy": {"scaleX": 1, "scaleY": "volume", "wind": -1e9, "damping": 0},
    "negative": {"rotate": 1, "damping": -1e9, "strength": -1e9, "mix": -1},
}


def _hostile_physics_doc() -> dict:
    bones = [{"name": "root"}] + [{"name": n, "parent": "root", "x": 10 * i, "length": 20, "rotation": 15 * i}
                                  for i, n in enumerate(HOSTILE_PHYSICS) if n != "root"]
    bones += [{"name": f"{n}-tip", "parent": n, "x": 20, "length": 10} for n in HOSTILE_PHYSICS]
    slots = [{"name": f"{n}-tip", "bone": f"{n}-tip", "attachment": "box"} for n in HOSTILE_PHYSICS]
    return {"skeleton": {"spine": "4.3.23"}, "bones": bones, "slots": slots,
            "constraints": [{"type": "physics", "name": n, "bone": n, **c} for n, c in HOSTILE_PHYSICS.items()],
            "skins": [{"name": "default", "attachments": {s["name"]: {"box": {"width": 8, "height": 4}} for s in slots}}],
            "animations": {"move": {
                "bones": {"root": {"translate": [{"x": 0}, {"time": 0.5, "x": 300, "y": -200}, {"time": 1, "x": 0}],
                                   "rotate": [{"value": 0}, {"time": 1, "value": 720}]}},
                "physics": {"": {"gravity": [{"value": 0}, {"time": 0.5, "value": 1e30}],
                                 "reset": [{"time": 0.7}]}}}}}


def test_43_physics_with_hostile_numbers_poses_within_seconds(tmp_path):
    """fps of 0, -5, 1e9 and 1e-300, inertia and gravity of 1e9, mass 0, limit 0, springs that
    diverge, physics on the root: ``pose`` ends in seconds, writes nothing non-finite, and
    flags the bones it cannot place (the springs that diverge; a constraint stepping more than
    1,000 times a second) instead of writing NaN."""
    project = tmp_path / "p"
    project.mkdir()
    (project / "phys.json").write_text(json.dumps(_hostile_physics_doc()))
    before = snapshot(tmp_path)
    r = _spinemesh("pose", "p/phys.json", "-a", "move", "--times", "0,0.1,0.5,0.75,1.5,3", "--out", "pose.json",
                   cwd=tmp_path, stdout=subprocess.PIPE, timeout=60)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert {k: v for k, v in snapshot(tmp_path).items() if k != "pose.json"} == before
    poses = _strict(json.loads((tmp_path / "pose.json").read_text()))["poses"]
    for pose in poses:  # a bone not placed is flagged, never written as a number that is not one
        assert {b for b, world in pose["bones"].items() if world is None} <= set(pose["inexact"])
    assert all("fps1e9" in pose["inexact"] for pose in poses[1:])
    assert any({"stiff", "stiff-tip"} <= set(pose["inexact"]) for pose in poses)
    assert all(pose["bones"]["massless-tip"] is not None and "massless" not in pose["inexact"] for pose in poses)


def test_43_physics_with_hostile_numbers_plays_in_the_preview_over_jobs(tmp_path):
    """The same skeleton upgraded with ``--preview --jobs 2``: the player shows the animation
    (its physics stepped in a worker), no traceback, within the time limit."""
    from PIL import Image
    from test_hostile import check_run, run_cli

    project = tmp_path / "p"
    (project / "images").mkdir(parents=True)
    (project / "phys.json").write_text(json.dumps(_hostile_physics_doc()))
    disc = Image.new("RGBA", (8, 4))
    disc.paste((200, 80, 40, 255), (2, 1, 6, 3))
    disc.save(project / "images" / "box.png")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--preview", "v", "--jobs", "2", cwd=tmp_path, timeout=120)
    check_run(r, before, tmp_path, ["o", "v"], codes=(0,))
    model = next((tmp_path / "v" / "data").glob("*/model.js")).read_text(encoding="utf-8")
    assert '"name":"move"' in model



def test_round_five_hostile_animations_sampled_over_workers_write_the_same_files(tmp_path, monkeypatch):
    """Round five's hostile animations (keys at 1e300 s, 400-digit values, deforms of the wrong
    size, draw orders out of slot order, ...), one task each over two workers: each is shown or
    left out as one process shows it, the same files to the byte."""
    from test_hostile_wave4 import _hostile_doc

    from spinemesh.upgrade import Options, preview, upgrade_library
    from spinemesh.upgrade.preview import write_preview

    project = tmp_path / "lib" / "arm"
    project.mkdir(parents=True)
    (project / "arm.json").write_text(json.dumps(_hostile_doc()))
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(jobs=1))
    monkeypatch.setattr(preview, "CHUNK_SECONDS", 0.0)
    with within(120):
        for jobs in (1, 2):
            write_preview(result, tmp_path / "lib", tmp_path / "out", tmp_path / f"v{jobs}", jobs=jobs)
    files = [sorted(p.relative_to(v) for p in v.rglob("*") if p.is_file()) for v in (tmp_path / "v1", tmp_path / "v2")]
    assert files[0] == files[1] and len([p for p in files[0] if p.parts[0] == "data"]) > 30
    for rel in files[0]:
        assert (tmp_path / "v1" / rel).read_bytes() == (tmp_path / "v2" / rel).read_bytes(), rel



def test_a_disk_that_fills_during_the_preview_ends_the_run(tmp_path):
    """A player's data script the disk refused (here: a file size limit of 40 KiB) was reported on
    the page as "the player could not pose this skeleton", and the run exited 0. It ends the run
    now, in one line naming the file (exit 2), no temporary file left."""
    from test_hostile import check_run, run_cli

    turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 20, "value": 900}]}}}
    _library_of_animations(tmp_path, {"long": turn})
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "lib/demo", "--out", "o", "--preview", "v", "--jobs", "2", cwd=tmp_path,
                file_size=40 * 1024, timeout=120)
    check_run(r, before, tmp_path, ["o", "v"], codes=(2,))
    line = _one_error(r)
    assert "v/data/" in line and "cannot write" in line, line


# --- Ctrl-C and SIGTERM while the preview's workers sample ---------------------------------------

def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (Linux: read from /proc)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    found, todo = set(), [pid]
    while todo:
        here = todo.pop()
        kids = {p for p, parent in parents.items() if parent == here}
        todo += list(kids - found)
        found |= kids
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from /proc")
@pytest.mark.parametrize("sig, code", [("SIGTERM", 143), ("SIGINT", 130)])
def test_a_signal_while_the_preview_samples_over_jobs_leaves_nothing_behind(tmp_path, sig, code):
    """The run ends within seconds with 128 + the signal, no traceback, no worker left running
    and no temporary file, the preview's files written so far each whole."""
    import signal

    turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 20, "value": 900}]}}}
    demo = _library_of_animations(tmp_path, {f"a{i}": turn for i in range(30)})
    for i in range(3):
        (demo / f"demo{i}.json").write_text((demo / "demo.json").read_text())
    before = snapshot(tmp_path / "lib")
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    run = subprocess.Popen([sys.executable, "-m", "spinemesh", "upgrade", "lib/demo", "--out", "o", "--preview", "v",
                            "--jobs", "2"], cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 90
    while not (tmp_path / "v" / "data").exists() and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = _descendants(run.pid)
    assert run.poll() is None and workers, "the preview ended before the signal: give it more to sample"
    run.send_signal(getattr(signal, sig))
    out, err = run.communicate(timeout=30)
    assert run.returncode == code and b"Traceback" not in out + err, err.decode()[-2000:]
    time.sleep(0.5)
    assert not [p for p in workers if Path(f"/proc/{p}").exists()
                and "Z" not in Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1][:3]]
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".tmp")]
    assert snapshot(tmp_path / "lib") == before
    for script in (tmp_path / "v").rglob("*.js"):
        assert script.read_text(encoding="utf-8").rstrip().endswith(";"), script


# --- 4.3 constraints in loops and at extremes ------------------------------------------------------

def _set_all(key, value):
    def change(doc):
        for c in doc["constraints"]:
            c[key] = value
    return change


def _append(*constraints):
    def change(doc):
        doc["constraints"] += copy.deepcopy(list(constraints))
    return change


def _slider_keys_itself(doc):
    doc["constraints"][0]["animation"] = "play"  # "play" keys the slider "timed" itself
    doc["animations"]["nod"]["slider"] = {"by_turn": {"time": [{"value": 0}, {"time": 1, "value": 1e300}]}}
    doc["constraints"][2]["animation"] = "play"


def _slider_driven_by_what_it_moves(doc):
    doc["constraints"][1]["bone"] = "hand"  # "wave" turns the hand that drives it


def _transform_onto_its_source(doc):
    doc["constraints"][0]["bones"] = ["face"]


def _mappings_of_wrong_types(doc):
    doc["constraints"][0]["properties"] = {"bogus": {"to": {"rotate": {}}}, "x": [1], "y": "z",
                                           "rotate": {"to": {"bogus": {}, "x": [], "y": None,
                                                             "scaleX": {"scale": 1e300, "offset": BIG}}}}


HOSTILE_43 = {
    "a slider playing the animation that keys it": ("slider", _slider_keys_itself),
    "a slider driven by a bone its animation moves": ("slider", _slider_driven_by_what_it_moves),
    "sliders of scale, time and range 1e300": ("slider", lambda d: [_set_all(k, 1e300)(d) for k in
                                                                   ("scale", "time", "from", "to", "mix")]),
    "sliders of 400-digit numbers and text": ("slider", lambda d: [_set_all(k, v)(d) for k, v in
                                                                   (("scale", BIG), ("time", "x"), ("to", None))]),
    "a slider of no animation": ("slider", lambda d: d["constraints"][0].update(animation="nope")),
    "physics on the bones sliders move and read": ("slider", _append(
        {"type": "physics", "name": "p", "bone": "hand", "rotate": 1, "x": 1},
        {"type": "physics", "name": "q", "bone": "knob", "x": 1, "strength": 1e9, "mass": 1e-9})),
    "a transform onto its own source": ("transform", _transform_onto_its_source),
    "two transforms in a loop": ("transform", _append({"type": "transform", "name": "back", "source": "eye",
                                                       "bones": ["face"], "mixRotate": 1,
                                                       "properties": {"rotate": {"to": {"rotate": {}}}}})),
    "an IK whose target is its own bone": ("transform", _append({"type": "ik", "name": "me", "target": "arm",
                                                                 "bones": ["arm"]})),
    "mappings of wrong types and 1e300": ("transform", _mappings_of_wrong_types),
}


@pytest.mark.parametrize("case", list(HOSTILE_43))
def test_43_constraints_in_loops_and_at_extremes_pose_finite(tmp_path, case):
    """Through the document's check and the sampler: every animation poses, finite, in seconds."""
    from test_anim43 import slider_doc, transform_doc

    from spinemesh.skeleton import load_skeleton

    kind, change = HOSTILE_43[case]
    doc = slider_doc() if kind == "slider" else transform_doc()
    change(doc)
    (tmp_path / "x.json").write_text(json.dumps(doc))
    sampler = Sampler(load_skeleton(tmp_path / "x.json"))
    with within(30):
        for name in doc["animations"]:
            _strict(dump(sampler, name, [0.05, 0.5, 1.5, 3.3]))


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from /proc")
def test_a_worker_killed_once_while_the_preview_samples_changes_nothing(tmp_path):
    """``kill -9`` of one of the preview's workers (the run's other processes untouched): its
    task is run again in a fresh worker, the run exits 0 and writes the same files."""
    import signal

    turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 20, "value": 900}]}}}
    _library_of_animations(tmp_path, {f"a{i}": turn for i in range(30)})
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    args = [sys.executable, "-m", "spinemesh", "upgrade", "lib/demo", "--jobs", "2"]
    whole = subprocess.run(args + ["--out", "o1", "--preview", "v1"], cwd=tmp_path, env=env, capture_output=True,
                           timeout=120, check=False)
    assert whole.returncode == 0, whole.stderr.decode()[-2000:]
    run = subprocess.Popen(args + ["--out", "o2", "--preview", "v2"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE)
    deadline = time.monotonic() + 90
    while not (tmp_path / "v2" / "data").exists() and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    workers = sorted(_descendants(run.pid))
    assert run.poll() is None and workers, "the preview ended before a worker could be killed"
    os.kill(workers[0], signal.SIGKILL)
    out, err = run.communicate(timeout=120)
    assert run.returncode == 0 and b"Traceback" not in out + err, err.decode()[-2000:]
    files = [sorted(p.relative_to(v) for p in v.rglob("*") if p.is_file()) for v in (tmp_path / "v1", tmp_path / "v2")]
    assert files[0] == files[1]
    for rel in files[0]:
        if rel.name not in ("index.html", ".spinemesh-written"):  # which names its output folder (the marker its digest)
            assert (tmp_path / "v1" / rel).read_bytes() == (tmp_path / "v2" / rel).read_bytes(), rel


def test_an_atlas_of_many_regions_is_not_sent_with_every_task(tmp_path, monkeypatch):
    """An atlas of 20,000 regions the skeleton never draws (99,000 made ``upgrade --preview
    --jobs 2`` take 8.8 s where one process took 2.0 s): each task of the preview's workers was
    sent every atlas whole. A task now carries the geometry of the regions the skeleton's
    attachments can draw, and the files are the same as one process writes."""
    import pickle

    from spinemesh.cluster import ProcessWorkers
    from spinemesh.upgrade import Options, preview, upgrade_library
    from spinemesh.upgrade.preview import write_preview

    turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 2, "value": 90}]}}}
    demo = _library_of_animations(tmp_path, {f"a{i}": turn for i in range(4)})
    atlas = (demo / "demo.atlas").read_text()
    (demo / "demo.atlas").write_text(atlas.rstrip("\n") + "\n" + "".join(f"x{i}\n\tbounds: 0, 0, 1, 1\n"
                                                                          for i in range(20_000)))
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(jobs=1))
    monkeypatch.setattr(preview, "CHUNK_SECONDS", 0.0)
    sent: list[int] = []
    submit = ProcessWorkers.submit

    def measured(self, fn, arg, first=False):
        sent.append(len(pickle.dumps(arg)))
        return submit(self, fn, arg, first)

    monkeypatch.setattr(ProcessWorkers, "submit", measured)
    with within(120):
        for jobs in (1, 2):
            write_preview(result, tmp_path / "lib", tmp_path / "out", tmp_path / f"v{jobs}", jobs=jobs)
    assert len(sent) >= 2 and max(sent) < 20_000, sent  # 1.9 MB each when the atlases were sent
    files = [sorted(p.relative_to(v) for p in v.rglob("*") if p.is_file()) for v in (tmp_path / "v1", tmp_path / "v2")]
    assert files[0] == files[1]
    for rel in files[0]:
        assert (tmp_path / "v1" / rel).read_bytes() == (tmp_path / "v2" / rel).read_bytes(), rel


# --- the player's address ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def still_page(tmp_path_factory) -> tuple[str, dict]:
    """The demo's preview page (its address) and the still frame it draws at 0.25 s of "wave",
    fitted to the page."""
    from browser import player_result

    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import Options, upgrade_project
    from spinemesh.upgrade.preview import write_preview

    tmp = tmp_path_factory.mktemp("still")
    project = make_demo_project(tmp / "p")
    result = upgrade_project(project, tmp / "o", Options(jobs=1))
    index = write_preview(result, project, tmp / "o", tmp / "v")
    page = next(index.parent.glob("s/*.html")).resolve().as_uri()
    return page, player_result(f"{page}#at=1,0.25", tmp / "chromium")


@pytest.mark.parametrize("view", ["0,0,9000,100,1", "0,0,2500,2500,2", "0,0,100,100,1e9"])
def test_an_address_asking_for_a_huge_still_frame_is_left_out(tmp_path, still_page, view):
    """``#at=A,T,x,y,w,h,ppu`` sized the canvases at w*ppu by h*ppu pixels whatever they were: a
    link asking 16,000 x 16,000 made the page take 30 s and 5 GB (headless Chromium). A frame
    over 8,192 pixels a side or 4,096 x 4,096 in all is left out: the page fits the pose, as
    without it, and still draws the time asked."""
    import base64
    import io

    from browser import player_result
    from PIL import Image

    page, fitted = still_page
    got = player_result(f"{page}#at=1,0.25,{view}", tmp_path / "chromium")
    sizes = [Image.open(io.BytesIO(base64.b64decode(got[k].split(",", 1)[1]))).size for k in ("before", "after")]
    assert got["t"] == 0.25 and all(max(size) <= 1000 for size in sizes), sizes
    assert got["before"] == fitted["before"] and got["after"] == fitted["after"]


@pytest.mark.parametrize("command", ["upgrade", "pack", "dataset"])
def test_a_jobs_count_beyond_the_bound_is_refused_before_anything_starts(tmp_path, command):
    """``--jobs 100000`` would start a process per task (thousands): refused in the option's own
    line, nothing written."""
    from test_hostile import run_cli

    from spinemesh.demo import make_demo_project
    from spinemesh.limits import MAX_JOBS

    project = make_demo_project(tmp_path / "p")
    before = snapshot(project)
    r = run_cli(command, project, "--out", tmp_path / "out", "--jobs", MAX_JOBS + 1, cwd=tmp_path)
    assert r.returncode == 2 and "--jobs" in r.stderr and f"1<=x<={MAX_JOBS}" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "out").exists() and snapshot(project) == before
