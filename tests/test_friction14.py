"""Friction a new user met on the eighth stop, each proven here: a folder with no skeleton is told
so in one line that every command shares; a report lists a few bones left out per mesh and counts
the others; ``convert`` of a 4.1/4.2 ``.skel`` writes no ``"name": null`` the editor leaves out; a
library run says the files in no project it does not copy; a ``dataset`` re-run says only that
nothing is new."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from conftest import skel_json_pairs
from test_hostile import run_cli, snapshot

from spinemesh.cli.convert_files import convert_files
from spinemesh.project import no_skeleton_said
from spinemesh.skeleton import load_skeleton
from spinemesh.skeleton_binary.enums import EXTRA
from spinemesh.rig.document import LEFT_OUT_LISTED, UNWEIGHTED_BONE
from spinemesh.upgrade.report import Target

REPO_SOURCES = Path(__file__).resolve().parents[1] / "spinemesh"

# --- a folder with no skeleton: one line for every command ---------------------------------------

EMPTY_FOLDER_RUNS = [("upgrade", "--out", "o"), ("weights", "--out", "w"), ("info",), ("diff", "--out", "d")]


@pytest.mark.parametrize("command", EMPTY_FOLDER_RUNS, ids=[c[0] for c in EMPTY_FOLDER_RUNS])
def test_a_folder_with_no_skeleton_is_told_in_the_same_words(tmp_path, command):
    """``upgrade`` and ``weights`` said ``no Spine skeleton found in empty (...)``, ``info`` its own
    ``no Spine skeleton (.json with a "skeleton" object, or .skel) found in empty``, ``diff``
    ``empty: no Spine skeleton found (...)``: now each the one line, naming the folder first."""
    (tmp_path / "empty").mkdir()
    r = run_cli(command[0], "empty", *command[1:], cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert r.stderr.splitlines()[-1] == f"error: empty: {no_skeleton_said()}", r.stderr


def test_a_library_with_no_skeleton_is_told_in_the_same_words(tmp_path):
    """``dataset`` (which searches every depth) says the same line, with its depth and its hint."""
    (tmp_path / "empty").mkdir()
    r = run_cli("dataset", "empty", "--out", "ds", cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert r.stderr.strip() == f"error: empty: {no_skeleton_said(at_any_depth=True)}", r.stderr
    assert no_skeleton_said(at_any_depth=True).startswith("no Spine skeleton found at any depth (")


def test_the_no_skeleton_line_is_written_once_in_the_sources():
    """Its words were written out in five modules (and drifted apart); one function says them."""
    written = [p.relative_to(REPO_SOURCES).as_posix() for p in sorted(REPO_SOURCES.rglob("*.py"))
               if re.search(r"no Spine skeleton( \(| found)", p.read_text(encoding="utf-8"))]
    assert written == ["project.py"], written


# --- the bones left out, in a report: those worth saying, and a count ----------------------------

def test_a_weights_report_lists_a_few_bones_left_out_and_counts_the_others(corpus, tmp_path):
    """Each mesh's ``left_out`` listed every bone the learned choice weighed: 756 per mesh on
    bmyq-bigwin, a report of 4.3 MB for 49 meshes. Now at most :data:`LEFT_OUT_LISTED`, the
    likeliest first, and ``left_out_more`` counts the rest (88 KB)."""
    r = run_cli("weights", corpus / "bmyq-bigwin", "--out", "w", "--report", "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "r.json").stat().st_size < 200_000
    rows = json.loads((tmp_path / "r.json").read_text())["attachments"]
    assert len(rows) == 49 and all(len(row["left_out"]) == LEFT_OUT_LISTED for row in rows)
    assert all(row["left_out_more"] > 700 for row in rows), {row["left_out_more"] for row in rows}
    for row in rows:
        likely = [float(why.split(",")[0].removeprefix("learned: ")) for why in row["left_out"].values()]
        assert likely == sorted(likely, reverse=True), row["left_out"]


def test_an_upgrade_report_lists_the_bones_left_out_for_a_reason_of_their_own_first():
    """``upgrade --weights auto --report`` rows give the same: the bones left out for a reason of
    their own (another skin's, no vertex weighted to it) first, then the likeliest, then a count."""
    unlikely = {f"far{i}": f"learned: 0.{20 - i:02d}, below the threshold 0.50; elsewhere in the tree" for i in range(20)}
    target = Target("hero.json", "default", "arm", "arm", ["arm.png"], status="meshed",
                    weights={"status": "weighted", "reason": "", "bones": {"arm": "slot bone"},
                             "left_out": {**unlikely, "cape": "only active in other skins", "hand": UNWEIGHTED_BONE},
                             "added_vertices": 0})
    weights = target.row()["weights"]
    assert list(weights["left_out"]) == ["cape", "hand", *[f"far{i}" for i in range(LEFT_OUT_LISTED - 2)]]
    assert weights["left_out_more"] == 22 - LEFT_OUT_LISTED
    assert len(target.weights["left_out"]) == 22  # the run's own record is whole


# --- convert of a 4.1/4.2 .skel: the editor's JSON, no "name": null --------------------------------

NULL_NAME = re.compile(r'"name":\s*null')


@pytest.mark.parametrize("version", ["4.1", "4.2"])
def test_convert_of_a_4_1_or_4_2_skel_writes_no_null_attachment_name(examples, tmp_path, version):
    """Attachment keys with no attachment came out as ``"name": null``, which the 4.1/4.2 editors
    leave out (3.8/4.0 write it): 78 on celestial-circus. Now as the editor's JSON beside each
    ``.skel``, and the ``.skel`` written back from that JSON reads the same."""
    pairs = skel_json_pairs(version)
    assert len(pairs) >= 10
    for skel, editor_json in pairs:
        assert not NULL_NAME.search(editor_json.read_text(encoding="utf-8")), editor_json
        converted = tmp_path / f"{skel.stem}.json"
        convert_files(skel, converted)
        assert not NULL_NAME.search(converted.read_text(encoding="utf-8")), skel
        back = tmp_path / f"{skel.stem}.skel"
        convert_files(converted, back)
        assert _without_binary_info(load_skeleton(back)) == _without_binary_info(load_skeleton(skel)), skel


def _without_binary_info(doc: dict) -> dict:
    """A document read from a ``.skel`` without its string table's order (not in the JSON)."""
    return {k: v for k, v in doc.items() if k != EXTRA}


def test_convert_of_a_4_0_skel_keeps_its_null_attachment_names(examples, tmp_path):
    """The 4.0 editor writes the null: so does ``convert``, as many as in its JSON."""
    skel = examples / "4.0" / "spineboy" / "spineboy-pro.skel"
    convert_files(skel, tmp_path / "s.json")
    assert (len(NULL_NAME.findall((tmp_path / "s.json").read_text(encoding="utf-8"))) ==
            len(NULL_NAME.findall(skel.with_suffix(".json").read_text(encoding="utf-8"))) > 0)


# --- a library's files in no project: said once ------------------------------------------------------

def _library_with_notes(examples, root):
    """A library of one 4.2 example project, with a note beside it and a folder of documents."""
    shutil.copytree(examples / "4.2" / "coin", root / "lib" / "coin")
    (root / "lib" / "NOTES.txt").write_text("meshes for the slot game\n")
    (root / "lib" / "docs").mkdir()
    (root / "lib" / "docs" / "brief.md").write_text("# brief\n")
    return root / "lib"


@pytest.mark.parametrize("command", [("upgrade", "--dry-run"), ("pack",)], ids=["upgrade", "pack"])
def test_a_library_run_says_the_files_it_does_not_copy(examples, tmp_path, command):
    """``NOTES.txt`` beside the projects was left out of OUT without a word; now one line, with
    how many files lie in no project and the first one."""
    _library_with_notes(examples, tmp_path)
    before = snapshot(tmp_path / "lib")
    r = run_cli(command[0], "lib", "--out", "out", *command[1:], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("not copied: 2 files in no project (NOTES.txt and 1 more)") == 1, r.stdout
    assert snapshot(tmp_path / "lib") == before
    if command[0] == "pack":
        assert not (tmp_path / "out" / "NOTES.txt").exists()


def test_a_single_project_run_says_nothing_of_files_outside(examples, tmp_path):
    """One project is copied whole: no such line."""
    shutil.copytree(examples / "4.2" / "coin", tmp_path / "coin")
    r = run_cli("upgrade", "coin", "--out", "out", "--dry-run", cwd=tmp_path)
    assert r.returncode == 0 and "not copied" not in r.stdout, (r.stdout, r.stderr)


# --- dataset re-run: only its "nothing new" line -----------------------------------------------------

def test_a_dataset_rerun_says_only_that_nothing_is_new(examples, tmp_path):
    """A re-run printed ``0 new samples from 0 projects in 0.0 s (0 samples/s)`` before its
    ``nothing new`` line; now that line alone (the first run still gives its counts)."""
    shutil.copytree(examples / "4.2" / "coin", tmp_path / "coin")
    r = run_cli("dataset", "coin", "--out", "ds", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "new samples from 1 projects" in r.stdout and "nothing new" not in r.stdout, r.stdout
    r = run_cli("dataset", "coin", "--out", "ds", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "new samples from" not in r.stdout and "samples/s" not in r.stdout, r.stdout
    assert r.stdout.startswith("nothing new: the data set already holds "), r.stdout
