"""Small leftovers of the fourth stop, each proven here: a project named ``.`` from inside it
reported as from elsewhere, ..."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200", PYTHONPATH=os.pathsep.join(
        [str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


# --- a project named from inside it ----------------------------------------------------------------

def _demo_without_page(folder: Path, bad_skeleton: bool = False) -> Path:
    """The demo project with its atlas page gone (the atlas's error names the project's file), or
    with a skeleton that cannot be read beside its own."""
    from spinemesh.demo import make_demo_project

    project = folder / "proj"
    make_demo_project(project)
    if bad_skeleton:
        (project / "broken.json").write_text('{"skeleton": {"spine": "4.2.0"}, "bones": [')
    else:
        (project / "demo.png").unlink()
    return project


def _without_seconds(value):
    if isinstance(value, dict):
        return {k: _without_seconds(v) for k, v in value.items() if "seconds" not in k}
    if isinstance(value, list):
        return [_without_seconds(v) for v in value]
    return value


def test_project_named_dot_reports_as_from_elsewhere(tmp_path):
    import json

    outside = _demo_without_page(tmp_path / "a")
    inside = _demo_without_page(tmp_path / "b")
    first = run("upgrade", "proj", "--out", "out", "--report", "r.json", "--preview", "p", cwd=outside.parent)
    second = run("upgrade", ".", "--out", "../out", "--report", "../r.json", "--preview", "../p", cwd=inside)
    assert first.returncode == second.returncode == 3, (first.stderr, second.stderr)
    one = json.loads((outside.parent / "r.json").read_text())
    two = json.loads((inside.parent / "r.json").read_text())
    assert any("proj/demo.atlas" in e for e in one["errors"]), one["errors"]
    assert _without_seconds(one) == _without_seconds(two)
    assert (outside.parent / "p/index.html").read_bytes() == (inside.parent / "p/index.html").read_bytes()
    # a skeleton named from inside too, and the console still names a file to open
    third = run("upgrade", "demo.json", "--out", "../out3", "--report", "../r3.json", cwd=inside)
    three = json.loads((inside.parent / "r3.json").read_text())
    assert any("proj/demo.atlas" in e for e in three["errors"]), three["errors"]
    assert str(inside.resolve() / "demo.atlas") in third.stderr + third.stdout


def test_pack_project_named_dot_reports_as_from_elsewhere(tmp_path):
    import json

    outside = _demo_without_page(tmp_path / "a", bad_skeleton=True)
    inside = _demo_without_page(tmp_path / "b", bad_skeleton=True)
    first = run("pack", "proj", "--out", "out", "--report", "r.json", cwd=outside.parent)
    second = run("pack", ".", "--out", "../out", "--report", "../r.json", cwd=inside)
    assert first.returncode == second.returncode, (first.stderr, second.stderr)
    one = json.loads((outside.parent / "r.json").read_text())
    two = json.loads((inside.parent / "r.json").read_text())
    assert "proj/broken.json" in json.dumps(one), one
    assert _without_seconds(one) == _without_seconds(two)
