"""Left-alone items of earlier stops, each proven here: refusals said as errors, ..."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from spinemesh.demo import make_demo_project


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


# --- an exit 2 is an error -----------------------------------------------------------------------

@pytest.mark.parametrize("command", [
    ["upgrade", "demo", "--out", "out", "--only", "no-such-*"],
    ["upgrade", "demo", "--out", "out", "--exclude", "*"],
    ["upgrade", "empty", "--out", "out"],
    ["weights", "empty", "--out", "out"],
    ["info", "empty"],
], ids=["upgrade-only-nothing", "upgrade-exclude-all", "upgrade-no-skeleton", "weights-no-skeleton", "info-no-skeleton"])
def test_nothing_to_work_on_is_refused_as_one_error_line(tmp_path, command):
    """A run refused with exit 2 says ``error:`` in one line, as every other refusal does, not ``warning:``."""
    make_demo_project(tmp_path / "demo", with_images_folder=False)
    (tmp_path / "empty").mkdir()
    r = run(*command, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "warning" not in r.stderr and "Traceback" not in r.stderr, r.stderr
