"""``spinemesh info`` and the CLI's error handling, run as a user would."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from spinemesh.files.atomic import atomic_write_bytes
from spinemesh.files.inside import resolve_inside
from spinemesh.errors import OutputError, UnsafePathError


def run(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env)


def test_info_on_a_project_folder(examples):
    r = run("info", str(examples / "4.2/dragon"))
    assert r.returncode == 0, r.stderr
    assert "Spine 4.2" in r.stdout and "dragon.atlas" in r.stdout
    assert "region" in r.stdout and "every attachment image was found" in r.stdout


def test_info_reports_missing_images(tmp_path, examples):
    proj = tmp_path / "p"
    proj.mkdir()
    (proj / "s.json").write_text('{"skeleton": {"spine": "4.2.1"}, "bones": [{"name": "root"}],'
                                 '"slots": [{"name": "a", "bone": "root"}],'
                                 '"skins": [{"name": "default", "attachments": {"a": {"ghost": {}}}}]}')
    r = run("info", str(proj / "s.json"))
    assert r.returncode == 0, r.stderr
    assert "1 attachment image(s) not found" in r.stdout and "'ghost'" in r.stdout


def test_bad_input_is_one_line_not_a_traceback(tmp_path):
    f = tmp_path / "bad.atlas"
    f.write_text("p.png\n\tsize: 4, 4\nr\n\tbounds: 0, x, 1, 1\n")
    atomic_write_bytes(tmp_path / "p.png", _png_4x4())
    (tmp_path / "s.json").write_text('{"skeleton": {"spine": "4.2.1"}, "bones": [')
    r = run("info", str(tmp_path))
    assert "Traceback" not in r.stdout + r.stderr
    assert "bad.atlas:3" in r.stderr and "s.json:1" in r.stderr
    assert r.returncode == 3, "an unreadable skeleton or atlas is not a success"
    r = run("info", str(tmp_path / "nope"))
    assert r.returncode == 2 and "Traceback" not in r.stderr and "no such file" in r.stderr


def _png_4x4() -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGBA", (4, 4)).save(buf, format="PNG")
    return buf.getvalue()


def test_help_has_an_example():
    r = run("info", "--help")
    assert r.returncode == 0 and "Example:" in r.stdout


def test_resolve_inside(tmp_path):
    assert resolve_inside(tmp_path, "a/b.png") == (tmp_path / "a/b.png").resolve()
    for bad in ("../x.png", "a/../../x.png", "/etc/passwd"):
        with pytest.raises(UnsafePathError):
            resolve_inside(tmp_path, bad)


def test_atomic_write_leaves_no_partial_file(tmp_path, monkeypatch):
    target = tmp_path / "out.bin"
    atomic_write_bytes(target, b"old")

    def crash(*args):
        raise OSError("simulated crash before the rename")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OutputError, match="simulated crash"):  # one line naming the file, not a traceback
        atomic_write_bytes(target, b"new")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_atomic_write_gives_ordinary_permissions(tmp_path):
    atomic_write_bytes(tmp_path / "f", b"x")
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "f").stat().st_mode & 0o777 == 0o666 & ~mask


@pytest.mark.parametrize("keep", [20, -30])  # inside its header; inside its image data
def test_info_names_a_page_cut_short(tmp_path, keep):
    """A page whose file is cut short is named once, as a problem: every attachment image was not found."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.effect_noise((64, 64), 40).convert("RGBA").save(buf, format="PNG")
    atomic_write_bytes(tmp_path / "p.png", buf.getvalue()[:keep])
    (tmp_path / "p.atlas").write_text("p.png\n\tsize: 64, 64\nr\n\tbounds: 0, 0, 4, 4\n")
    (tmp_path / "s.json").write_text('{"skeleton": {"spine": "4.2.1"}, "bones": [{"name": "root"}],'
                                     '"slots": [{"name": "a", "bone": "root"}],'
                                     '"skins": [{"name": "default", "attachments": {"a": {"r": {}}}}]}')
    r = run("info", str(tmp_path / "s.json"))
    assert "Traceback" not in r.stdout + r.stderr
    assert "every attachment image was found" not in r.stdout, r.stdout
    words = "cannot be read as an image" if keep == 20 else "is cut short at byte"
    assert r.returncode == 3, (r.stdout, r.stderr)
    # said once, where the run's problems are (stderr), counted in the skeleton's part
    assert words not in r.stdout and "1 page(s) cannot be read" in r.stdout, r.stdout
    said = [line for line in r.stderr.splitlines() if words in line]
    assert len(said) == 1 and said[0].startswith(f"problem: {tmp_path / 'p.png'}: page image 'p.png' "), r.stderr


def test_a_missing_source_is_one_line_in_every_command(tmp_path):
    """``convert`` says a missing or wrong source in one line naming it, as ``info`` and ``pose``
    do (not click's usage and three lines)."""
    (tmp_path / "folder").mkdir()
    for args in (["info", "nope.skel"], ["pose", "nope.skel"], ["convert", "nope.skel", "out.json"]):
        r = run(*[str(tmp_path / a) if a.startswith("nope") else a for a in args])
        assert r.returncode == 2 and r.stderr.strip() == f"error: {tmp_path / 'nope.skel'}: no such file or folder", \
            (args, r.stderr)
    r = run("convert", str(tmp_path / "folder"), str(tmp_path / "out.json"))
    assert r.returncode == 2 and r.stderr.strip() == f"error: {tmp_path / 'folder'}: skeleton is a folder", r.stderr
    assert not (tmp_path / "out.json").exists()
