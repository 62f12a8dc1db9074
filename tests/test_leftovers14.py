"""Leftovers of earlier stops: a library's projects found once per run, ``pack``'s project
warnings, ``weights --jobs``, Windows paths given as outputs, an empty ``edges`` list in convert.

Everything runs on the demo project drawn by our own code (no ../shared data needed).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from spinemesh.cli import app
from spinemesh.demo import make_demo_project

runner = CliRunner()


def _library(tmp_path: Path) -> Path:
    library = tmp_path / "library"
    make_demo_project(library / "heroes" / "knight")
    make_demo_project(library / "props")
    return library


def _count_searches(monkeypatch) -> list[Path]:
    """The folders searched for projects (:func:`spinemesh.project.find_projects` joins the halves
    of each search's projects once), as a run goes."""
    from spinemesh import project as project_module

    searched: list[Path] = []
    join = project_module._joined_halves

    def counted(found, root):
        searched.append(root)
        return join(found, root)

    monkeypatch.setattr(project_module, "_joined_halves", counted)
    return searched


def test_a_library_run_searches_for_its_projects_once(tmp_path, monkeypatch):
    """``upgrade LIBRARY`` (with its preview) and ``pack LIBRARY`` searched the library two to
    four times (is it a library, which projects, the preview's again), reading the skeletons of
    folders that may be halves of one project each time."""
    library = _library(tmp_path)
    searched = _count_searches(monkeypatch)
    r = runner.invoke(app, ["upgrade", str(library), "--out", str(tmp_path / "up"), "--preview",
                            str(tmp_path / "view"), "-j", "1"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "view" / "index.html").is_file()
    assert searched == [library]
    searched.clear()
    r = runner.invoke(app, ["pack", str(tmp_path / "up"), "--out", str(tmp_path / "packed"), "-j", "1"])
    assert r.exit_code == 0, r.output
    assert searched == [tmp_path / "up"]


def test_pack_warns_of_an_atlas_runtimes_draw_differently_as_upgrade_does(tmp_path):
    """An atlas whose ``size:`` line disagrees with its image: ``upgrade`` says ``warning:`` (and
    in its report's ``warnings``); ``pack`` said nothing when the atlas was kept for another
    reason (its page shared with a twin atlas), and its report had no ``warnings``."""
    import json

    project = make_demo_project(tmp_path / "p")
    atlas = project / "demo.atlas"
    (project / "twin.atlas").write_bytes(atlas.read_bytes())  # the same page: kept, "shared"
    atlas.write_text(atlas.read_text().replace("size: 512, 256", "size: 1024, 512"))
    said = {}
    for command in ("upgrade", "pack"):
        r = runner.invoke(app, [command, str(project), "--out", str(tmp_path / command), "-j", "1",
                                "--report", str(tmp_path / f"{command}.json")])
        assert r.exit_code == 0, r.output
        said[command] = [line for line in r.output.splitlines() if line.startswith("warning:")]
        assert json.loads((tmp_path / f"{command}.json").read_text())["warnings"] == [
            "p/demo.atlas: page 'demo.png' (line 1): its size line says 1024, 512 but its image is 512x256; "
            "spine-c scales UVs by the size line, libGDX by the image, so they draw it differently"]
    assert len(said["upgrade"]) == 1 and said["pack"] == said["upgrade"], said


def test_weights_takes_jobs_and_writes_the_same_bytes_on_any_number(tmp_path, meshed):
    """``weights`` had no ``-j/--jobs``; on two processes its skeletons, copies and report (but for
    the times) are those of one, each mesh put back in its place whatever order the jobs end in."""
    import json

    reports = []
    for jobs in ("1", "2"):
        r = runner.invoke(app, ["weights", str(meshed), "--out", str(tmp_path / jobs), "--replace",
                                "--jobs", jobs, "--report", str(tmp_path / f"{jobs}.json")])
        assert r.exit_code == 0, r.output
        report = json.loads((tmp_path / f"{jobs}.json").read_text())
        reports.append({key: value if key != "attachments" else [{k: v for k, v in row.items() if k != "seconds"}
                                                                  for row in value]
                        for key, value in report.items() if key != "seconds"})
    assert reports[0] == reports[1] and reports[0]["counts"].get("weighted", 0) >= 4, reports[0]["counts"]
    files = sorted(p.relative_to(tmp_path / "1") for p in (tmp_path / "1").rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(tmp_path / "2") for p in (tmp_path / "2").rglob("*") if p.is_file())
    assert all((tmp_path / "1" / f).read_bytes() == (tmp_path / "2" / f).read_bytes() for f in files)


def _spinemesh(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, cwd=cwd,
                          env=dict(os.environ, COLUMNS="200"))


def test_an_output_given_as_a_windows_path_is_refused_with_the_inputs_hint(tmp_path):
    """``--out 'C:\\out'`` made a folder of that name here and said nothing, where a project given
    so got ``folders are separated by '/' here``; every output (OUT, ``--report``, ``--preview``)
    now gets that hint, before any work; one of that very name already there is written to."""
    make_demo_project(tmp_path / "p")
    hint = "(folders are separated by '/' here, not '\\')"
    for args, said in ((["upgrade", "p", "--out", "C:\\out"], "C:\\out: output folder not made"),
                       (["upgrade", "p", "--out", "o", "--report", "C:\\r.json"], "C:\\r.json: output file not made"),
                       (["upgrade", "p", "--out", "o", "--preview", "C:\\v"], "C:\\v: output folder not made"),
                       (["pack", "p", "--out", "q\\x"], "q\\x: output folder not made"),
                       (["weights", "p", "--out", "C:\\w", "-j", "1"], "C:\\w: output folder not made")):
        r = _spinemesh(*args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stdout + r.stderr)
        assert r.stderr.strip() == f"error: {said} {hint}", (args, r.stderr)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["p"], args  # nothing written
    (tmp_path / "builds").mkdir()
    r = _spinemesh("pack", "p", "--out", "builds\\y", cwd=tmp_path)  # its folder is there: named with slashes
    assert r.stderr.strip().endswith("(folders are separated by '/' here, not '\\': did you mean builds/y?)"), r.stderr
    (tmp_path / "C:\\out").mkdir()  # a folder of that very name: written to as given
    r = _spinemesh("upgrade", "p", "--out", "C:\\out", "--overwrite", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr


_PARENT = os.getpid()


def _weigh_killed_on_workers(job):
    """``weigh_meshes``, except on a worker process, which is killed (SIGKILL) on each of its tries."""
    import signal

    from spinemesh.rig import document

    if os.getpid() != _PARENT:
        os.kill(os.getpid(), signal.SIGKILL)
    return document.weigh_meshes(job)


def test_weights_on_workers_that_are_killed_weighs_here_the_same(tmp_path, meshed, monkeypatch):
    """``weights --jobs 2`` whose every worker is killed while it weighs: each job is weighed in
    this process instead, the same skeletons byte for byte as ``--jobs 1``, every mesh weighted."""
    from spinemesh.rig import run
    from spinemesh.rig.document import WeightOptions

    one = run.weight_project(meshed, tmp_path / "1", WeightOptions(replace=True), jobs=1)
    monkeypatch.setattr(run, "weigh_meshes", _weigh_killed_on_workers)
    two = run.weight_project(meshed, tmp_path / "2", WeightOptions(replace=True), jobs=2)
    assert [o.row() | {"seconds": 0} for o in two.outcomes] == [o.row() | {"seconds": 0} for o in one.outcomes]
    assert sum(o.status == "weighted" for o in two.outcomes) >= 4 and not two.errors, two.errors
    for rel in one.written:
        assert (tmp_path / "2" / rel).read_bytes() == (tmp_path / "1" / rel).read_bytes(), rel
