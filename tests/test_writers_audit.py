"""Every writer audited: each file a command or library call writes is written atomically,
never over a user's files in a folder spinemesh did not write, never with NaN or Infinity.

Each test here failed on the code before its fix.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


def _user_folder(path: Path, *names: str) -> dict[str, bytes]:
    """A folder of a user's files, some named as spinemesh would name its own; returns its contents."""
    path.mkdir(parents=True)
    for name in names:
        (path / name).parent.mkdir(parents=True, exist_ok=True)
        (path / name).write_bytes(b"mine: " + name.encode())
    return _contents(path)


def _contents(path: Path) -> dict[str, bytes]:
    return {p.relative_to(path).as_posix(): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def _one_error(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    return line


def _sprite(path: Path, radius: int = 20) -> Path:
    yy, xx = np.mgrid[:64, :64]
    rgba = np.zeros((64, 64, 4), np.uint8)
    rgba[(yy - 32) ** 2 + (xx - 32) ** 2 < radius ** 2] = (200, 80, 40, 255)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(rgba).save(path)
    return path


# --- mesh DIR: its --out, --preview and --steps folders -------------------------------------------

@pytest.mark.parametrize("option,name", [("--out", "hero.json"), ("--preview", "hero.png"), ("--steps", "hero.png")])
def test_mesh_of_a_folder_never_writes_over_a_users_folder(tmp_path, option, name):
    """``mesh DIR --out/--preview/--steps FOLDER`` wrote ``hero.json``/``hero.png`` into any folder,
    replacing a user's files of those names (exit 0). A folder of someone else's files is refused
    in one line before any work; the folders it writes are its own, written into again."""
    art = tmp_path / "art"
    _sprite(art / "hero.png")
    mine = tmp_path / "mine"
    before = _user_folder(mine, name, "notes.txt")
    line = _one_error(run("mesh", str(art), option, str(mine), cwd=tmp_path))
    assert f"{mine}: {option} folder is not empty and holds no spinemesh" in line, line
    assert _contents(mine) == before
    for _ in range(2):  # its own folders, written into again
        r = run("mesh", str(art), "--out", "meshes", "--preview", "previews", "--steps", "steps", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "meshes" / "hero.json").is_file() and (tmp_path / "steps" / "hero.png").is_file()


# --- dataset --out ----------------------------------------------------------------------------------

def test_a_data_set_is_never_built_in_a_folder_of_a_users_files(tmp_path):
    """``dataset --out FOLDER`` (and ``build_dataset``) appended its rows to a user's
    ``index.jsonl`` (cutting its last line when it had no newline), emptied their ``.lock`` and
    wrote ``meta.json`` and ``shards/`` beside them (exit 0). A folder of someone else's files is
    refused in one line before anything is written; a data set is resumed as before, also one an
    earlier spinemesh wrote without marking its folder."""
    from spinemesh.dataset import build_dataset
    from spinemesh.demo import make_demo_project
    from spinemesh.errors import OutputError

    make_demo_project(tmp_path / "corpus" / "demo", with_images_folder=False)
    mine = tmp_path / "mine"
    before = _user_folder(mine, "index.jsonl", "projects.jsonl", ".lock")
    line = _one_error(run("dataset", "corpus", "--out", "mine", cwd=tmp_path))
    assert "mine: data set folder is not empty and holds no spinemesh data set" in line, line
    assert _contents(mine) == before
    with pytest.raises(OutputError, match="data set folder is not empty"):
        build_dataset([tmp_path / "corpus"], mine)
    assert _contents(mine) == before
    ds = tmp_path / "ds"
    first = build_dataset([tmp_path / "corpus"], ds)
    assert first.samples > 0
    (ds / ".spinemesh-written").unlink()  # a data set built before folders were marked
    again = build_dataset([tmp_path / "corpus"], ds)
    assert again.samples == 0 and again.projects_done_before == 1


# --- dataset-stats --plots ----------------------------------------------------------------------------

def test_dataset_stats_never_draws_over_a_users_folder(tmp_path):
    """``dataset-stats DS --plots FOLDER`` wrote its four PNGs into any folder, replacing a user's
    ``image_sizes.png`` (exit 0), and through a symlink. Such a folder is refused in one line before
    any work; the folder it drew into is its own, drawn into again, and so is the default DS/stats."""
    pytest.importorskip("matplotlib")
    from spinemesh.dataset import build_dataset
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "corpus" / "demo", with_images_folder=False)
    build_dataset([tmp_path / "corpus"], tmp_path / "ds")
    mine = tmp_path / "mine"
    before = _user_folder(mine, "image_sizes.png", "notes.txt")
    line = _one_error(run("dataset-stats", "ds", "--plots", "mine", cwd=tmp_path))
    assert "mine: --plots folder is not empty and holds no spinemesh plots" in line, line
    assert _contents(mine) == before
    (tmp_path / "link").symlink_to(mine)
    assert "symlink" in _one_error(run("dataset-stats", "ds", "--plots", "link", cwd=tmp_path))
    assert _contents(mine) == before
    for _ in range(2):
        for plots in (["--plots", "plots"], []):
            r = run("dataset-stats", "ds", *plots, cwd=tmp_path)
            assert r.returncode == 0, r.stderr
    assert (tmp_path / "plots" / "image_sizes.png").is_file() and (tmp_path / "ds" / "stats" / "type_share.png").is_file()
