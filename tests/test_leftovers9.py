"""Left-alone items of the fourth stop, each proven here: a killed run's temporary files removed by
the next run into its folder, ..."""

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


# --- a killed run's temporary files ---------------------------------------------------------------

def _plant_leftovers(folder: Path) -> tuple[list[str], list[str]]:
    """Temporary files a run killed outright (SIGKILL) leaves, named as the atomic writer names
    them, at the top and one folder down; and files of a user's that look like them but are not
    ours (another name, a symlink, a folder). Returns (ours, theirs) as POSIX paths."""
    from spinemesh.files.atomic import _temporary_name

    ours = [_temporary_name("hero.json", "0123abcd"), f"img/{_temporary_name('a.png', 'deadbeef')}"]
    theirs = ["notes.tmp", ".draft.tmp", ".hero.json.xyz.tmp", ".hero.json.0123ABCD.tmp", "img/keep.png"]
    for rel in ours + theirs:
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(b"half a file")
    (folder / "elsewhere.txt").write_bytes(b"a user's")
    os.symlink("elsewhere.txt", folder / _temporary_name("link.json", "cafebabe"))
    (folder / _temporary_name("dir.json", "feedf00d")).mkdir()
    theirs += ["elsewhere.txt", _temporary_name("link.json", "cafebabe")]
    return ours, theirs


def test_a_folder_written_again_loses_a_killed_runs_temporary_files(tmp_path):
    """A run killed outright leaves its ``.NAME.xxxxxxxx.tmp`` files; the next run that ends in the
    folder (rewriting_folder: ``upgrade --images``, ``weights --preview``, ``mesh DIR``) removes
    them, and only them: a user's file of another name, a symlink and a folder are kept."""
    from spinemesh.files.atomic import atomic_write_bytes
    from spinemesh.written_folder import mark_written_folder, rewriting_folder

    folder = tmp_path / "pictures"
    mark_written_folder(folder)
    ours, theirs = _plant_leftovers(folder)
    with rewriting_folder(folder):
        atomic_write_bytes(folder / "hero.json", b"{}")
    for rel in ours:
        assert not (folder / rel).exists(), rel
    for rel in theirs:
        assert os.path.lexists(folder / rel), rel
    assert (folder / ".dir.json.feedf00d.tmp").is_dir()


def test_a_run_that_does_not_end_keeps_them_and_the_next_removes_them(tmp_path):
    """A run that fails removes nothing, as for the earlier run's files; the next that ends does."""
    from spinemesh.files.atomic import atomic_write_bytes
    from spinemesh.written_folder import mark_written_folder, rewriting_folder

    folder = tmp_path / "pictures"
    mark_written_folder(folder)
    ours, _ = _plant_leftovers(folder)
    with pytest.raises(RuntimeError), rewriting_folder(folder):
        atomic_write_bytes(folder / "hero.json", b"{}")
        raise RuntimeError
    assert all((folder / rel).exists() for rel in ours)
    with rewriting_folder(folder):
        atomic_write_bytes(folder / "hero.json", b"{}")
    assert not any((folder / rel).exists() for rel in ours)


def test_a_temporary_file_written_meanwhile_is_kept(tmp_path):
    """A temporary file whose bytes changed while the run lasted (another run still writing it) is
    not the one found at the start: kept."""
    from spinemesh.files.atomic import _temporary_name, atomic_write_bytes
    from spinemesh.written_folder import mark_written_folder, rewriting_folder

    folder = tmp_path / "pictures"
    mark_written_folder(folder)
    live = folder / _temporary_name("b.png", "01234567")
    live.write_bytes(b"begun")
    with rewriting_folder(folder):
        atomic_write_bytes(folder / "hero.json", b"{}")
        live.write_bytes(b"begun, and more")
    assert live.read_bytes() == b"begun, and more"


def test_a_preview_written_again_loses_a_killed_runs_temporary_files(tmp_path):
    """The preview writer (PreviewFolder, every ``--preview``) removes them too once it ends."""
    from spinemesh.player.files import PreviewFolder
    from spinemesh.written_folder import mark_written_folder

    folder = tmp_path / "preview"
    mark_written_folder(folder)
    ours, theirs = _plant_leftovers(folder)
    pages = PreviewFolder(folder)
    pages.write_text("index.html", "<title>spinemesh preview</title>")
    pages.finish()
    assert not any((folder / rel).exists() for rel in ours)
    assert all(os.path.lexists(folder / rel) for rel in theirs)


def test_mesh_of_a_folder_run_again_removes_a_killed_runs_temporary_files(tmp_path):
    """``mesh DIR --out OUT``: OUT written again after a killed run holds no temporary file of it."""
    from spinemesh.files.atomic import _temporary_name

    art = tmp_path / "art"
    art.mkdir()
    rgba = np.zeros((48, 48, 4), np.uint8)
    rgba[8:40, 8:40] = 255
    Image.fromarray(rgba).save(art / "hero.png")
    assert run("mesh", str(art), "--out", "out", cwd=tmp_path).returncode == 0
    left = tmp_path / "out" / _temporary_name("hero.json", "89abcdef")
    left.write_bytes(b"{\"half")
    r = run("mesh", str(art), "--out", "out", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert not left.exists() and (tmp_path / "out" / "hero.json").is_file()


# --- an upgrade whose --report cannot be written ---------------------------------------------------

def test_an_upgrade_whose_report_cannot_be_written_says_what_it_wrote(tmp_path):
    """The skeletons are written before the report: a report that cannot be written (its folder a
    file here; a full disk) ends the run done in part (exit 3), after the table of the skeletons
    written and the preview, with one error line naming the report and saying the skeletons were
    written; it ended with exit 2 (refused, nothing written) and no word of them."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "demo", with_images_folder=False)
    (tmp_path / "taken").write_text("a file, not a folder")
    r = run("upgrade", "demo", "--out", "out", "--report", "taken/report.json", "--preview", "look", cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "taken" in errors[0] and "--report not written" in errors[0] and "2 skeletons listed" in errors[0], errors
    assert "demo.json" in r.stdout and "demo-binary.skel" in r.stdout and "preview:" in r.stdout, r.stdout
    assert (tmp_path / "out" / "demo.json").is_file() and (tmp_path / "look" / "index.html").is_file()
    assert not (tmp_path / "taken").is_dir()


@pytest.mark.parametrize("command, written, table", [
    ("pack", "the 1 atlas listed above", "demo.atlas"),
    ("weights", "2 skeletons", "spinemesh weights"),
])
def test_pack_and_weights_whose_report_cannot_be_written_say_what_they_wrote(tmp_path, command, written, table):
    """``pack`` and ``weights`` the same way (one function, output.run_report_error): exit 3 after
    their table, the report's error line last, naming what was written."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "demo", with_images_folder=False)
    (tmp_path / "taken").write_text("a file, not a folder")
    r = run(command, "demo", "--out", "out", "--report", "taken/report.json", cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in r.stderr, r.stderr
    assert errors[0].endswith(f"--report not written (written in out: {written})"), errors
    assert table in r.stdout and (tmp_path / "out" / "demo.json").is_file(), r.stdout


def test_an_upgrade_that_wrote_nothing_and_no_report_is_refused(tmp_path):
    """With nothing written (--only matching nothing) the report's error is the run's one line, exit 2."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "demo", with_images_folder=False)
    (tmp_path / "taken").write_text("a file, not a folder")
    r = run("upgrade", "demo", "--out", "out", "--only", "no-such-*", "--report", "taken/report.json", cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "taken" in errors[0] and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


# --- an animation's key written twice ---------------------------------------------------------------

TWICE = '"slots": {"spark": {"attachment": [{"name": "spark"}], "attachment": [{"time": 0.5, "name": null}]}}, '


def _demo_with_a_timeline_twice(folder: Path) -> Path:
    """The demo project, its ``wave`` animation keying the spark slot's attachment in two
    ``"attachment"`` timelines, as an exporter left them in a game's skeleton of the corpus."""
    from spinemesh.demo import make_demo_project

    make_demo_project(folder, with_images_folder=False)
    text = (folder / "demo.json").read_text()
    assert text.count('"wave": {') == 1
    (folder / "demo.json").write_text(text.replace('"wave": {', '"wave": {' + TWICE))
    (folder / "demo-binary.skel").unlink()
    return folder


def test_the_lines_name_each_animation_and_its_key_written_twice():
    """One line per animation, naming it and the key's path in it; keys that differ but for case
    (both kept, by spine-ts as by spinemesh) and a document without any are not said."""
    from spinemesh.skeleton import parse_skeleton_json
    from spinemesh.skeleton_check import MAX_KEYED_TWICE_LINES, animations_keyed_twice

    lines = animations_keyed_twice(parse_skeleton_json('{"animations": {"wave": {' + TWICE + '"bones": {}}}}'))
    assert len(lines) == 1 and lines[0].startswith("animation 'wave': slots.spark.attachment written twice;"), lines
    assert "spine-ts the last only" in lines[0]
    assert not animations_keyed_twice(parse_skeleton_json('{"animations": {"a": {"slots": {"s": {"rgba": [], '
                                                          '"RGBA": []}}}, "A": {}}}'))
    assert not animations_keyed_twice(parse_skeleton_json('{"animations": {"wave": {"slots": {}}}}'))
    named_twice = animations_keyed_twice(parse_skeleton_json('{"animations": {"wave": {}, "wave": {}}}'))
    assert named_twice and named_twice[0].startswith("animation 'wave': named twice;"), named_twice
    many = "{" + ", ".join(f'"a{i}": {{{TWICE[:-2]}}}' for i in range(30)) + "}"
    lines = animations_keyed_twice(parse_skeleton_json('{"animations": ' + many + "}"))
    assert len(lines) == MAX_KEYED_TWICE_LINES + 1 and lines[-1].startswith("and 20 more animations"), lines[-1]


@pytest.mark.parametrize("target", ["demo.skel", "demo-again.json"])
def test_convert_says_an_animation_key_written_twice(tmp_path, target):
    """``convert`` keeps the last timeline only (as spine-ts reads it; spine-c, spine-cpp and libGDX
    apply both): it says so, a warning naming the file and the animation, and writes (exit 0); it
    was silent."""
    project = _demo_with_a_timeline_twice(tmp_path / "demo")
    r = run("convert", str(project / "demo.json"), str(tmp_path / target))
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 1 and "demo.json" in warnings[0] and "animation 'wave'" in warnings[0], r.stderr
    assert "slots.spark.attachment written twice" in warnings[0] and (tmp_path / target).is_file()
    r = run("convert", str(tmp_path / target), str(tmp_path / "back.json"))
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr  # written once: nothing more to say


def test_upgrade_says_an_animation_key_written_twice(tmp_path):
    """``upgrade`` writes the skeleton back with the last timeline: a warning line and the report's."""
    import json

    project = _demo_with_a_timeline_twice(tmp_path / "demo")
    r = run("upgrade", str(project), "--out", str(tmp_path / "out"), "--report", str(tmp_path / "report.json"))
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if "written twice" in line]
    assert len(warnings) == 1 and warnings[0].startswith("warning: demo.json: animation 'wave'"), r.stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert any("animation 'wave'" in w for w in report["warnings"]), report["warnings"]


def test_the_corpus_skeleton_of_a_timeline_written_twice_is_said_so(tmp_path, corpus):
    """The corpus's redgvin-character keys a slot's attachment twice in eight animations: each said."""
    source = corpus / "redgvin-character" / "character.json"
    r = run("convert", str(source), str(tmp_path / "character.skel"))
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 8 and all("character.json: animation 'portal_" in w for w in warnings), r.stderr


def test_weights_says_an_animation_key_written_twice(tmp_path):
    """``weights`` writes the skeleton back too: the same warning line, and in its report."""
    import json

    from spinemesh.upgrade import Options, upgrade_project

    project = _demo_with_a_timeline_twice(tmp_path / "demo")
    upgrade_project(project, tmp_path / "meshed", Options(min_saving=None, jobs=1))
    r = run("weights", "meshed", "--out", "w", "--report", "r.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if "written twice" in line]
    assert len(warnings) == 1 and warnings[0].startswith("warning: demo.json: animation 'wave'"), r.stderr
    assert any("animation 'wave'" in w for w in json.loads((tmp_path / "r.json").read_text())["warnings"])
