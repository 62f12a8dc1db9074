"""The one marker mechanism of every folder spinemesh writes again (spinemesh.written_folder), where
it fell short: an older spinemesh's output marker emptied OUT whole, a studio's files placed there
since too; a run killed before its folder was marked, or mid-write into a folder not yet marked,
left temporary files that no later run removed (or a folder a later run refused)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from spinemesh.output import OLDER_OUTPUT_MARKER, OUTPUT_MARKER, output_folder

REPO = Path(__file__).resolve().parents[1]


def _listing(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() or p.is_symlink())


def _killed_mid_write(folder: Path, name: str, before: str = "") -> None:
    """Run ``before`` (Python, ``out`` the folder), then start the atomic write of ``folder/name`` and
    be killed in it (``os._exit``: no clean-up runs, as under SIGKILL)."""
    code = ("import os, sys\nfrom pathlib import Path\nfrom spinemesh.files.atomic import atomic_write_stream\n"
            "out = Path(sys.argv[1])\n" + before +
            "def killed(f):\n    f.write(b'half')\n    f.flush()\n    os._exit(9)\n"
            "atomic_write_stream(out / sys.argv[2], killed)\n")
    r = subprocess.run([sys.executable, "-c", code, str(folder), name], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(REPO)), check=False)
    assert r.returncode == 9, r.stderr


def _temporaries(folder: Path) -> list[str]:
    from spinemesh.files.atomic import is_temporary_name

    return [rel for rel in _listing(folder) if is_temporary_name(rel.rpartition("/")[2])]


def test_an_older_marker_keeps_a_studios_hidden_and_meta_files(tmp_path):
    """An older spinemesh's one-line marker lists nothing: --overwrite removed every file, Unity's
    .meta files (the ids every reference to an asset uses) and a .gitignore put beside the run's
    since with them. Now only the files an upgrade writes go; hidden files and .meta stay."""
    out = tmp_path / "out"
    (out / "sub").mkdir(parents=True)
    (out / OUTPUT_MARKER).write_text(OLDER_OUTPUT_MARKER + "\n")
    for name in ("hero.json", "hero.atlas", "hero.png", "sub/arm.png"):
        (out / name).write_text("the older run's")
    for name in ("hero.png.meta", "sub.meta", "sub/arm.png.meta", ".gitignore", ".git/config"):
        (out / name).parent.mkdir(exist_ok=True)
        (out / name).write_text("the studio's")
    with output_folder(out, True):
        (out / "hero.json").write_text("this run")
    assert _listing(out) == [".git/config", ".gitignore", OUTPUT_MARKER, "hero.json", "hero.png.meta", "sub.meta",
                             "sub/arm.png.meta"]
    assert (out / "hero.png.meta").read_text() == "the studio's"


def test_an_output_folder_killed_while_being_marked_is_written_again(tmp_path):
    """Killed between making OUT and its marker's rename: OUT holds only the marker's temporary
    file. It was refused as a user's folder for ever; it is empty, and the leftover goes."""
    out = tmp_path / "out"
    _killed_mid_write(out, OUTPUT_MARKER, "out.mkdir()\n")
    assert len(_temporaries(out)) == 1
    with output_folder(out, False):
        (out / "hero.json").write_text("this run")
    assert _listing(out) == [OUTPUT_MARKER, "hero.json"]


def test_overwrite_removes_a_temporary_file_no_marker_lists(tmp_path):
    """A run's marker lists the files it wrote; a write killed after it ended (its --report's, or
    another process's into the folder) left a temporary file that no marker lists: kept for ever."""
    out = tmp_path / "out"
    with output_folder(out, False):
        (out / "sub").mkdir()
        (out / "sub" / "hero.png").write_bytes(b"page")
    _killed_mid_write(out, "report.json")
    _killed_mid_write(out, "sub/hero.png")
    assert len(_temporaries(out)) == 2
    (out / "mine.txt").write_text("a user's")
    with output_folder(out, True):
        pass
    assert _listing(out) == [OUTPUT_MARKER, "mine.txt"]


@pytest.mark.parametrize("first", [".spinemesh-written", "img/1234.png"])
def test_a_preview_killed_before_its_marker_is_written_again(tmp_path, first):
    """A preview killed writing its marker, or its first picture into a folder not yet marked, left
    only a temporary file: the next preview refused the folder as a user's. It writes it, and the
    leftover goes once it ends."""
    from spinemesh.player.files import PreviewFolder

    folder = tmp_path / "preview"
    _killed_mid_write(folder, first, "(out / 'img').mkdir(parents=True)\n")
    files = PreviewFolder(folder)
    files.write_text("index.html", "<title>spinemesh preview</title>")
    files.finish()
    assert _listing(folder) == [".spinemesh-written", "index.html"]


def test_a_folder_of_pictures_killed_before_its_marker_is_written_again(tmp_path):
    """The same for a folder written through rewriting_folder (``--images``, ``mesh DIR``): checked,
    written, the leftover removed; also by a run that ends writing nothing there."""
    from spinemesh.written_folder import check_written_folder, mark_written_folder, rewriting_folder

    folder = tmp_path / "pictures"
    _killed_mid_write(folder, ".spinemesh-written", "out.mkdir()\n")
    check_written_folder(folder, "--images folder", "images")
    with rewriting_folder(folder):
        mark_written_folder(folder)
    assert _listing(folder) == [".spinemesh-written"]


def test_a_users_folder_is_still_refused_beside_a_temporary_file(tmp_path):
    """Temporary files do not make a folder ours: a user's file beside one is refused as before, and
    neither file is removed; a temporary name that is a symlink or a folder is no leftover."""
    from spinemesh.errors import OutputError, SpineMeshError
    from spinemesh.written_folder import check_written_folder, holds_files

    folder = tmp_path / "mine"
    _killed_mid_write(folder, "a.png", "out.mkdir()\n")
    assert not holds_files(folder)
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="holds no spinemesh preview"):
        check_written_folder(folder)
    with pytest.raises(SpineMeshError, match="not written by spinemesh"), output_folder(folder, True):
        pass
    assert len(_temporaries(folder)) == 1 and (folder / "notes.txt").exists()
    other = tmp_path / "other"
    other.mkdir()
    (other / ".b.png.0123abcd.tmp").symlink_to(folder / "notes.txt")
    assert holds_files(other)
    (other / ".b.png.0123abcd.tmp").unlink()
    (other / ".c.png.0123abcd.tmp").mkdir()
    (other / ".c.png.0123abcd.tmp" / "x").write_text("mine")
    assert holds_files(other)
