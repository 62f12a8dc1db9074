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
                           capture_output=True, timeout=60)
        refused = opencv_variable_problem(name, value) is not None
        assert refused == (r.returncode != 0), (name, value, r.returncode)
