"""Left-alone items of earlier stops, each proven here: refusals said as errors, ..."""

from __future__ import annotations

import os
import re
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
    """A run refused with exit 2 says ``error:`` in one line, as every other refusal does, not
    ``warning:``, and writes nothing (``--only``/``--exclude`` matching nothing wrote OUT, copies)."""
    make_demo_project(tmp_path / "demo", with_images_folder=False)
    (tmp_path / "empty").mkdir()
    r = run(*command, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "warning" not in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()
    assert not re.search(r"\b(mesh|write) [0-9.]+ s", r.stdout), r.stdout  # no timing of phases that never ran


def test_a_selection_of_nothing_writes_nothing_from_the_library(tmp_path):
    """``upgrade_project`` whose ``only``/``exclude`` leave no region writes nothing, not even OUT,
    and says why in each row; one that selects something writes as before."""
    from spinemesh.upgrade import Options, upgrade_project
    from spinemesh.upgrade.report import selection_left_nothing

    project = make_demo_project(tmp_path / "demo", with_images_folder=False)
    for options in (Options(only=["no-such-*"]), Options(exclude=["*"]), Options(only=["demo-*"], exclude=["*"])):
        result = upgrade_project(project, tmp_path / "out", options)
        assert selection_left_nothing(result) and not result.written and not (tmp_path / "out").exists()
        assert {t.reason for t in result.targets} <= {"not matched by --only", "matched by --exclude"}
    result = upgrade_project(project, tmp_path / "out", Options(only=["demo-head"]))
    assert not selection_left_nothing(result) and result.written and (tmp_path / "out" / "demo.json").is_file()


# --- an editor's downgraded export ("4.1-from-4.2.33") is read as the runtimes read it ------------

def test_major_minor_is_the_leading_numbers():
    from spinemesh.skeleton_binary import encode_skel, sniff_version
    from spinemesh.skeleton_version import major_minor

    assert [major_minor(v) for v in ("4.1-from-4.2.33", "3.8-from-4.0.64", "4.3.39-beta", "4.10.2", "x4.2", None)] \
        == [(4, 1), (3, 8), (4, 3), (4, 10), None, None]
    doc = {"skeleton": {"spine": "4.1-from-4.2.33"}, "bones": [{"name": "root"}]}
    assert sniff_version(encode_skel(doc)) == "4.1-from-4.2.33"  # written in 4.1's layout, its version kept


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


# --- the library refuses a folder of a user's files, as the commands do ---------------------------

def _user_folder(path: Path) -> Path:
    path.mkdir()
    (path / "index.html").write_text("<title>my own page</title>")  # a name our previews write too
    (path / "demo.png").write_bytes(b"mine")                      # and one our images folder would
    return path


def _unchanged(path: Path) -> bool:
    return (sorted(p.name for p in path.iterdir()) == ["demo.png", "index.html"]
            and (path / "index.html").read_text() == "<title>my own page</title>"
            and (path / "demo.png").read_bytes() == b"mine")


def test_library_calls_never_write_over_a_users_folder(tmp_path):
    """``upgrade_project``/``upgrade_library`` with ``images_out``, ``weight_project`` with
    ``preview``, and the upgrade and pack preview writers refuse, before writing anything, a
    folder that holds files but none spinemesh wrote; a folder they wrote is written into again."""
    from spinemesh.errors import OutputError
    from spinemesh.pack import preview as pack_preview
    from spinemesh.pack.run import pack_project
    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project
    from spinemesh.upgrade import Options, upgrade_library, upgrade_project
    from spinemesh.upgrade import preview as upgrade_preview

    project = make_demo_project(tmp_path / "lib" / "demo", with_images_folder=False)
    mine = _user_folder(tmp_path / "mine")
    calls = {
        "upgrade_project": lambda: upgrade_project(project, tmp_path / "o1", Options(images_out=mine)),
        "upgrade_library": lambda: upgrade_library(tmp_path / "lib", tmp_path / "o2", Options(images_out=mine)),
        "weight_project": lambda: weight_project(project, tmp_path / "o3", WeightOptions(bones="auto"), preview=mine),
    }
    for name, call in calls.items():
        with pytest.raises(OutputError, match="not empty and holds no spinemesh"):
            call()
        assert _unchanged(mine), name
    assert not any((tmp_path / o).exists() for o in ("o1", "o2", "o3"))  # refused before any work
    result = upgrade_project(project, tmp_path / "up")
    with pytest.raises(OutputError, match="preview folder is not empty"):
        upgrade_preview.write_preview(result, project, tmp_path / "up", mine)
    packed = pack_project(project, tmp_path / "packed", keep_previews=True)
    with pytest.raises(OutputError, match="preview folder is not empty"):
        pack_preview.write_preview(packed, mine)
    assert _unchanged(mine)
    # folders spinemesh wrote are its own: written into again
    page = pack_preview.write_preview(packed, tmp_path / "pv")
    assert pack_preview.write_preview(packed, tmp_path / "pv") == page
    upgrade_project(project, tmp_path / "o4", Options(images_out=tmp_path / "pictures"))
    upgrade_project(project, tmp_path / "o5", Options(images_out=tmp_path / "pictures"))


def test_every_downgraded_export_of_the_corpus_converts_both_ways(corpus, tmp_path):
    """Every corpus skeleton whose version says it was exported for an older one (``3.8-from-4.0.64``,
    ``3.8-from-4.0-from-4.1.19``, ``4.1-from-4.2.43``) is written as a ``.skel`` of that older
    version, keeping its version text, and read back to the same binary."""
    import json

    from spinemesh.skeleton import load_skeleton
    from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version

    found = [p for p in sorted(corpus.rglob("*.json")) if not p.name.startswith(".")
             and re.search(r'"spine"\s*:\s*"[0-9.]+-from-', p.read_text("utf-8", errors="replace")[:400])]
    assert len(found) >= 10, found
    for path in found:
        doc = load_skeleton(path)
        data = encode_skel(doc, path)
        assert sniff_version(data) == doc["skeleton"]["spine"], path
        again = read_skel(data, path)
        assert encode_skel(json.loads(json.dumps(again))) == data, path


def test_a_diff_report_never_replaces_a_users_files(tmp_path, meshed):
    """``diff --out`` (and ``write_report`` from the library) wrote ``index.html``, ``report.md``,
    ``report.json`` and ``assets/`` into any folder, replacing a user's files of those names. A
    folder of someone else's files is refused before any work, in one line; its own is written again."""
    from spinemesh.diff.report import write_report
    from spinemesh.diff.run import run_diff
    from spinemesh.errors import OutputError

    mine = _user_folder(tmp_path / "mine")
    r = run("diff", str(meshed), "--out", str(mine), "--methods", "hull")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert f"{mine}: report folder is not empty and holds no spinemesh report" in line, line
    assert _unchanged(mine)
    result = run_diff([meshed], ("hull",), limit=2)
    with pytest.raises(OutputError, match="report folder is not empty"):
        write_report(result, mine)
    assert _unchanged(mine)
    for _ in range(2):  # its own folder, written into again
        r = run("diff", str(meshed), "--out", str(tmp_path / "report"), "--methods", "hull", "--limit", "2")
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "report" / "index.html").is_file()
