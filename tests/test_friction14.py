"""Friction a new user met on the eighth stop, each proven here: a folder with no skeleton is told
so in one line that every command shares, ..."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from test_hostile import run_cli

from spinemesh.project import no_skeleton_said

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
