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


# --- an editor's downgraded export ("4.1-from-4.2.33") is read as the runtimes read it ------------

def test_major_minor_is_the_leading_numbers():
    from spinemesh.skeleton_binary import sniff_version, write_skel
    from spinemesh.skeleton_version import major_minor

    assert [major_minor(v) for v in ("4.1-from-4.2.33", "3.8-from-4.0.64", "4.3.39-beta", "4.10.2", "x4.2", None)] \
        == [(4, 1), (3, 8), (4, 3), (4, 10), None, None]
    doc = {"skeleton": {"spine": "4.1-from-4.2.33"}, "bones": [{"name": "root"}]}
    assert sniff_version(write_skel(doc)) == "4.1-from-4.2.33"  # written in 4.1's layout, its version kept


def test_a_downgraded_export_converts_and_poses_in_the_official_runtime(corpus, spine_runtime, tmp_path):
    """cm-character is a 4.2 project exported for 4.1 (``"spine": "4.1-from-4.2.33"``): ``convert``
    writes it as a 4.1 ``.skel`` and back, and the official 4.1 runtime poses both as the original."""
    from runtime_tool import max_difference, pose_dump

    folder = corpus / "cm-character"
    atlas, original = folder / "character.atlas", folder / "character.json"
    if not original.is_file():
        pytest.skip(f"{original} is absent")
    skel, back = tmp_path / "character.skel", tmp_path / "character.json"
    for source, target in ((original, skel), (skel, back)):
        r = run("convert", str(source), str(target))
        assert r.returncode == 0 and "Spine 4.1-from-4.2.33" in r.stdout, r.stderr
    a = pose_dump(spine_runtime, atlas, original, tmp_path / "a.json", "idle")
    assert a["skeleton"]["runtime"].startswith("spine-core-41@4.1."), a["skeleton"]  # the official 4.1 runtime
    b = pose_dump(spine_runtime, atlas, skel, tmp_path / "b.json", "idle")
    assert max_difference(a, b) < 0.01  # float32 rounding of the JSON's decimals
    c = pose_dump(spine_runtime, atlas, back, tmp_path / "c.json", "idle")
    assert max_difference(a, c) < 0.01  # and back as JSON (float32 values as their shortest decimals)
