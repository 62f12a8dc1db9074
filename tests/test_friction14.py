"""Friction a new user met on the eighth stop, each proven here: a folder with no skeleton is told
so in one line that every command shares, ..."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from test_hostile import run_cli

from spinemesh.project import no_skeleton_said
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
