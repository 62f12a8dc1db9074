"""Small leftovers of the sixth stop, each proven here: an ``OPENCV_*`` environment variable
OpenCV cannot parse is refused in one line before OpenCV is imported, ..."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from test_hostile import run_cli

from spinemesh.opencv_environment import opencv_variable_problem

# --- OpenCV's own environment variables ----------------------------------------------------------

BAD_OPENCV_SETTINGS = [("OPENCV_FOR_THREADS_NUM", "-1"), ("OPENCV_BUFFER_AREA_ALWAYS_SAFE", "x"),
                       ("OPENCV_IO_MAX_IMAGE_PIXELS", "abc"), ("OPENCV_TRACE_MAX_CHILDREN", "")]


@pytest.mark.parametrize("name,value", BAD_OPENCV_SETTINGS, ids=[n for n, _ in BAD_OPENCV_SETTINGS])
def test_an_opencv_variable_opencv_cannot_parse_is_one_line(tmp_path, monkeypatch, name, value):
    """Each ended every command: a ``cv2.error: stoull`` traceback, or the process aborted (exit
    134) at OpenCV's import, naming nothing. Now one line naming the variable, exit 2."""
    monkeypatch.setenv(name, value)
    r = run_cli("mesh", tmp_path / "none.png", cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr)
    line = r.stderr.strip()
    assert "\n" not in line and "Traceback" not in line, line
    assert line.startswith(f"error: environment variable {name}={value!r}: OpenCV reads it as "), line


def test_an_opencv_variable_opencv_parses_is_taken(tmp_path, monkeypatch):
    """Values OpenCV takes go on to the command (its own error here: the image is missing)."""
    monkeypatch.setenv("OPENCV_FOR_THREADS_NUM", "2")
    monkeypatch.setenv("OPENCV_IO_MAX_IMAGE_PIXELS", "64MB")
    monkeypatch.setenv("OPENCV_TRACE", "false")
    monkeypatch.setenv("OPENCV_LOG_LEVEL", "anything")  # text: OpenCV parses it leniently
    r = run_cli("mesh", tmp_path / "none.png", cwd=tmp_path)
    assert r.returncode == 2 and "environment variable" not in r.stderr and "none.png" in r.stderr, r.stderr


# Values for two variables OpenCV parses at import, with what it does with them: the check's rules
# are OpenCV's own (a value it takes is never refused, one it aborts on always is).
IMPORT_TIME = [("OPENCV_BUFFER_AREA_ALWAYS_SAFE", v) for v in ("1", "TRUE", "False", "on", "2", " 1", "")] + \
              [("OPENCV_TRACE_MAX_CHILDREN", v) for v in ("05", "5mb", "5Kb", "5K", "5GB", "+5", "0x10",
                                                          str(2**64 - 1), str(2**64))]


def test_the_rules_are_opencvs_own():
    for name, value in IMPORT_TIME:
        r = subprocess.run([sys.executable, "-c", "import cv2"], env={**os.environ, name: value},
                           capture_output=True, timeout=60, check=False)
        refused = opencv_variable_problem(name, value) is not None
        assert refused == (r.returncode != 0), (name, value, r.returncode)


# --- a closed standard output ---------------------------------------------------------------------

def _closed_stdout(*args, cwd) -> subprocess.CompletedProcess:
    """``spinemesh ARGS >&-``."""
    return subprocess.run(["sh", "-c", 'exec "$@" >&-', "sh", sys.executable, "-m", "spinemesh", *map(str, args)],
                          cwd=cwd, env={**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}, stderr=subprocess.PIPE,
                          text=True, timeout=120, check=False)


def _dot(path):
    import cv2
    import numpy as np

    art = np.zeros((64, 64, 4), np.uint8)
    cv2.circle(art, (32, 32), 20, (255, 255, 255, 255), -1)
    cv2.imwrite(str(path), art)


def test_info_to_a_closed_standard_output_is_refused(tmp_path):
    """``info``'s table is all it makes: ``info P >&-`` wrote nothing and exited 0; now refused
    before any work, in one line naming standard output (exit 2), as ``pose`` is."""
    (tmp_path / "p").mkdir()
    _dot(tmp_path / "p" / "dot.png")
    r = _closed_stdout("info", "p", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr, (r.returncode, r.stderr)
    assert r.stderr.strip() == "error: standard output is closed: the table would go nowhere; give it a file (> FILE)"


def test_a_command_making_files_says_its_table_is_not_written(tmp_path):
    """A command whose files are what it makes runs whole (a daemon closes standard output), and
    says once that its table is not written; it said nothing (exit 0 either way)."""
    _dot(tmp_path / "dot.png")
    r = _closed_stdout("mesh", "dot.png", "-o", "out", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("warning: standard output is closed: this command's table is not written") == 1, r.stderr
    assert (tmp_path / "out").is_file() and (tmp_path / "out").stat().st_size > 0


# --- diff's bar on a standard error that is no terminal ------------------------------------------

def test_diff_refusing_prints_only_its_error_line(tmp_path):
    """On a pipe, ``diff`` printed its bar's last state before the error line; now the line alone,
    as the other commands (their bars are transient)."""
    (tmp_path / "empty").mkdir()
    r = run_cli("diff", "empty", "-o", "report", cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("error: empty: no Spine skeleton found") and r.stderr.count("\n") == 1, r.stderr


# --- pack's totals: a page two atlases share ----------------------------------------------------

def test_pack_totals_count_a_page_two_kept_atlases_share_once(meshed, tmp_path):
    """``b.atlas`` names ``demo.png`` as ``demo.atlas`` does: both are kept, each row counts the
    page (each is right), and the total counted it twice (2 pages, its texels and bytes twice).
    The total counts each page file once, and its note says so."""
    import json
    import shutil

    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    (project / "b.atlas").write_text((project / "demo.atlas").read_text())
    env = {**os.environ, "COLUMNS": "250", "NO_COLOR": "1"}
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pack", "p", "--out", "o", "--report", "r.json", "-j", "1"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    rows = report["atlases"]
    assert [row["status"] for row in rows] == ["kept", "kept"] and all(row["pages_before"] == 1 for row in rows)
    page = project / "demo.png"
    atlases = sum((project / name).stat().st_size for name in ("b.atlas", "demo.atlas"))
    totals = report["totals"]
    assert totals["pages_before"] == totals["pages_after"] == 1, totals
    assert totals["bytes_before"] == totals["bytes_after"] == page.stat().st_size + atlases, totals
    assert totals["texels_before"] == rows[0]["texels_before"] and totals["shared_pages"] == 1, totals
    assert "page_files" not in rows[0]
    total = next(line for line in r.stdout.splitlines() if line.startswith("│ total"))
    assert "1 -> 1" in total and "1 page file named by several atlases counted once" in total, total
