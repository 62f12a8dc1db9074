"""spinemesh in a build pipeline (CI, a Makefile, a cache keyed by file hashes).

- The same input gives the same bytes, from any folder, by relative or absolute paths, with any
  hash seed, time zone, locale, number of workers, and whatever the input files' times.
- A run into a folder an earlier run wrote leaves no file of that run the new one did not write
  again, and never removes a file spinemesh did not write.
- Exit statuses and logs a script can rely on.

The demo project drawn by our own code is the input (no ../shared data needed); the corpus test
runs where the data are.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from spinemesh.demo import make_demo_project

REPO = Path(__file__).resolve().parents[1]


def spinemesh(*args, cwd: Path, **env: str) -> subprocess.CompletedProcess:
    """``spinemesh ARGS`` in ``cwd`` with ``env`` added, as a build step runs it (no terminal)."""
    environ = dict(os.environ, COLUMNS="200", PYTHONPATH=str(REPO), **env)
    r = subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], capture_output=True, text=True,
                       env=environ, cwd=cwd)
    return r


def files_of(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too) by its path under it, with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def without_times(report: bytes):
    """A JSON report with every timing taken out (the one thing a report may differ in)."""
    def strip(o):
        if isinstance(o, dict):
            return {k: strip(v) for k, v in o.items() if "seconds" not in k}
        return [strip(v) for v in o] if isinstance(o, list) else o

    return strip(json.loads(report))


def _build(where: Path, relative: bool, jobs: int, **env: str) -> dict[str, bytes]:
    """Every command a build runs on the demo project, into ``where``: relative paths from
    ``where``, or absolute ones from another folder; returns every file written."""
    make_demo_project(where / "demo")
    for f in (where / "demo").rglob("*"):  # a fresh checkout: other file times
        os.utime(f, (1_000_000_000 + jobs, 1_000_000_000 + jobs))
    cwd = where if relative else where.parent
    at = (lambda p: Path(p)) if relative else (lambda p: where / p)
    steps = [
        ("upgrade", at("demo"), "--out", at("meshed"), "--pack", "--weights", "auto", "--jobs", jobs,
         "--preview", at("preview"), "--report", at("upgrade.json")),
        ("upgrade", at("demo/demo.json"), "--out", at("meshed-json"), "--jobs", jobs),
        ("pack", at("meshed"), "--out", at("packed"), "--jobs", jobs, "--report", at("pack.json"),
         "--preview", at("pack-preview")),
        ("convert", at("demo/demo-binary.skel"), at("converted.json")),
        ("convert", at("converted.json"), at("converted.skel")),
        ("pose", at("meshed/demo.json"), "-a", "wave", "--times", "0.1,0.25", "--out", at("pose.json")),
    ]
    for step in steps:
        r = spinemesh(*step, cwd=cwd, **env)
        assert r.returncode == 0, (step, r.stdout[-2000:], r.stderr[-2000:])
    out = files_of(where)
    return {k: v for k, v in out.items() if not k.startswith("demo/")}


def test_the_same_bytes_from_any_folder_seed_zone_and_workers(tmp_path):
    """Two builds of the demo, one by relative paths with --jobs 1, hash seed 0, UTC and the C
    locale, the other by absolute paths from another folder with --jobs 2, hash seed 1, another
    time zone and a UTF-8 locale, input files of other times: every skeleton, atlas, page,
    preview file and pose is the same bytes; the reports differ in their timings only. (The
    preview's index and the pose file named the input and output by the paths given.)"""
    a = _build(tmp_path / "a" / "build", relative=True, jobs=1, PYTHONHASHSEED="0", TZ="UTC", LC_ALL="C")
    b = _build(tmp_path / "b" / "build", relative=False, jobs=2, PYTHONHASHSEED="1", TZ="Asia/Kathmandu",
               LC_ALL="C.UTF-8")
    assert sorted(a) == sorted(b)
    reports = {"upgrade.json", "pack.json"}
    differ = sorted(k for k in a if k not in reports and a[k] != b[k])
    assert not differ, differ
    for name in reports:
        assert without_times(a[name]) == without_times(b[name]), name
    assert any(k.startswith("preview/") for k in a) and "pose.json" in a


# --- reruns into one folder -----------------------------------------------------------------------

def test_overwrite_removes_the_earlier_runs_files_and_keeps_the_users(tmp_path):
    """A nightly build upgrades into the same folder, which a game engine (Unity's .meta files)
    or the team (a .gitignore, notes) adds files to. --overwrite removed every file there; now it
    removes the files the earlier run wrote (its report too), so that no stale skeleton or page
    stays for a runtime to load, and keeps every other file, byte for byte."""
    demo = make_demo_project(tmp_path / "demo")
    r = spinemesh("upgrade", demo, "--out", "X", "--pack", "--report", "X/report.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    first = files_of(tmp_path / "X")
    assert {"demo-binary.skel", "demo.json", "report.json"} <= set(first)
    users = {"demo.atlas.meta": b"guid: 1", ".gitignore": b"*.tmp\n", "notes/todo.txt": b"mine",
             "images/demo-head.png.meta": b"guid: 2"}
    for name, data in users.items():
        (tmp_path / "X" / name).parent.mkdir(exist_ok=True)
        (tmp_path / "X" / name).write_bytes(data)
    # the skeleton file alone: its twin demo-binary.skel, the report and the images are not written again
    r = spinemesh("upgrade", demo / "demo.json", "--out", "X", "--overwrite", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    second = files_of(tmp_path / "X")
    assert {k: second.get(k) for k in users} == users, "a file spinemesh did not write is kept"
    alone = files_of(tmp_path / "alone") if spinemesh("upgrade", demo / "demo.json", "--out", "alone",
                                                      cwd=tmp_path).returncode == 0 else {}
    ours = {k: v for k, v in second.items() if k not in users}
    assert ours == alone, sorted(set(ours) ^ set(alone))  # what a fresh run writes, and nothing stale
    assert "demo-binary.skel" not in second and "report.json" not in second
    marker = json.loads(second[".spinemesh-output"])
    assert sorted(marker["written"]) == sorted(k for k in alone if k != ".spinemesh-output")
    r = spinemesh("upgrade", demo, "--out", "X", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--overwrite" in r.stderr, r.stderr


def test_a_run_that_did_not_end_is_removed_by_the_next_and_a_users_file_kept(tmp_path):
    """A run killed half-way (SIGKILL: no clean-up) leaves its files; the marker it wrote first
    lists the files it found, so the next --overwrite removes all but those."""
    out = tmp_path / "X"
    out.mkdir()
    (out / ".spinemesh-output").write_text("written by spinemesh upgrade; --overwrite may replace this folder\n")
    (out / "mine.txt").write_text("an earlier spinemesh emptied its folder as a whole: so does this one")
    code = ("import os, sys\nfrom pathlib import Path\nfrom spinemesh.output import output_folder\n"
            "out = Path(sys.argv[1])\n"
            "with output_folder(out, True):\n"
            "    (out / 'ours.txt').write_text('the run')\n"
            "(out / 'kept.txt').write_text('mine')\n"
            "with output_folder(out, True):\n"
            "    (out / 'sub').mkdir()\n"
            "    (out / 'sub' / 'half.skel').write_bytes(b'half')\n"
            "    os._exit(9)\n")
    r = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert r.returncode == 9, r.stderr
    assert not (out / "mine.txt").exists()  # the old marker: the whole folder was the run's
    assert not (out / "ours.txt").exists()  # the marker's list: removed by the next run
    assert (out / "sub" / "half.skel").exists() and json.loads((out / ".spinemesh-output").read_text())["running"]
    from spinemesh.output import output_folder

    with output_folder(out, True):
        assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == [".spinemesh-output", "kept.txt"]


def test_a_marker_never_removes_a_file_outside_its_folder(tmp_path):
    """The marker is a file anyone can write: a name that climbs out, is absolute or passes
    through a symlinked folder removes nothing (an output folder holding a symlinked folder is
    refused before anything is removed; the rule that removes listed files checks it too)."""
    from spinemesh.errors import OutputError
    from spinemesh.files.disk import file_digest
    from spinemesh.output import output_folder
    from spinemesh.written_folder import marker_listing, remove_listed_files

    out, elsewhere = tmp_path / "X", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (elsewhere / "precious.txt").write_text("precious")
    (out / "stale.atlas").write_text("stale")
    outside = {name: file_digest(elsewhere / "precious.txt")  # even with the file's own digest
               for name in ["../elsewhere/precious.txt", str(elsewhere / "precious.txt"), "link/precious.txt"]}
    listed = marker_listing(out, outside, ["stale.atlas"])
    (out / ".spinemesh-output").write_text(json.dumps({"spinemesh": "output folder", **listed}))
    (out / "link").symlink_to(elsewhere)
    remove_listed_files(out, outside)
    assert (elsewhere / "precious.txt").read_text() == "precious" and (out / "link").is_symlink()
    with pytest.raises(OutputError):
        with output_folder(out, True):
            pass
    assert (out / "stale.atlas").exists() and (elsewhere / "precious.txt").exists()
    (out / "link").unlink()
    with output_folder(out, True):
        pass
    assert (elsewhere / "precious.txt").read_text() == "precious"
    assert not (out / "stale.atlas").exists()


def test_weights_report_never_replaces_a_skeleton_it_wrote(tmp_path):
    """``weights --report OUT/demo.json`` replaced the weighted skeleton by the report, exit 0; it
    is refused as ``upgrade``'s and ``pack``'s are, in one line (exit 3: the skeletons are written)."""
    from spinemesh.upgrade import Options, upgrade_project

    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    upgrade_project(demo, tmp_path / "meshed", Options(min_saving=None, jobs=1))
    r = spinemesh("weights", "meshed", "--out", "w", "--report", "w/demo.json", cwd=tmp_path)
    assert r.returncode == 3 and r.stderr.count("\n") == 1, r.stderr
    assert "--report would replace a file in the output folder" in r.stderr and "--report not written" in r.stderr
    assert "skeleton" in json.loads((tmp_path / "w" / "demo.json").read_text())


def test_a_data_set_is_the_same_bytes_from_any_folder(tmp_path):
    """``dataset`` wrote each project's errors naming its files by the path given (relative,
    absolute): the data set's projects.jsonl differed from one folder to the next."""
    for side in ("a", "b"):
        demo = make_demo_project(tmp_path / side / "library" / "demo")
        (demo / "broken.skel").write_bytes(b"\x00not a skeleton")
    a = spinemesh("dataset", "library", "--out", "ds", "--jobs", "1", cwd=tmp_path / "a")
    b = spinemesh("dataset", tmp_path / "b" / "library", "--out", tmp_path / "b" / "ds", "--jobs", "2",
                  cwd=tmp_path, PYTHONHASHSEED="3")
    assert a.returncode == b.returncode == 0, a.stderr + b.stderr
    first, second = files_of(tmp_path / "a" / "ds"), files_of(tmp_path / "b" / "ds")
    assert b"broken.skel" in first["projects.jsonl"]
    assert sorted(first) == sorted(second)
    assert [k for k in first if first[k] != second[k]] == []


def _pose_mesh_info(where: Path, cwd: Path, at) -> dict[str, bytes]:
    """``pose``, ``mesh`` (a folder and an image) and ``info`` (a project with an atlas, one with
    its images folder only) of the demo in ``where``, run from ``cwd`` with paths ``at(p)``:
    every file written, and info's standard output (what a build keeps in a log file)."""
    demo = make_demo_project(where / "demo")
    bare = make_demo_project(where / "bare")
    for name in ("demo.atlas", "demo.png", "demo-binary.skel"):
        (bare / name).unlink()
    steps = [("pose", at("demo/demo.json"), "-a", "wave", "--times", "0.1", "--out", at("pose.json")),
             ("mesh", at("demo/images"), "--out", at("meshes"), "--preview", at("previews")),
             ("mesh", at("demo/images/demo-head.png"), "--out", at("head.json"), "--preview", at("head.png"))]
    for step in steps:
        r = spinemesh(*step, cwd=cwd)
        assert r.returncode == 0, (step, r.stderr[-2000:])
    out = {k: v for k, v in files_of(where).items() if not k.startswith(("demo/", "bare/"))}
    for name in ("demo", "bare"):
        r = spinemesh("info", at(name), cwd=cwd)
        assert r.returncode == 0, r.stderr
        out[f"info {name}"] = r.stdout.encode()
    # from inside the project too, as "."
    for name, project in (("demo", demo), ("bare", bare)):
        r = spinemesh("info", ".", cwd=project)
        assert r.stdout.encode() == out[f"info {name}"], (r.stdout, out[f"info {name}"])
    return out


def test_pose_mesh_and_info_are_the_same_bytes_from_any_folder(tmp_path):
    """``pose``, ``mesh`` and ``info`` name the project's files by its folder's name as the reports
    do (``files.names.named_within``): the same bytes by relative paths, absolute ones from elsewhere
    and ``.`` from inside. ``info`` said "Atlases in " and "images from: " by the paths given."""
    a = _pose_mesh_info(tmp_path / "a" / "build", tmp_path / "a" / "build", lambda p: Path(p))
    b = _pose_mesh_info(tmp_path / "b" / "build", tmp_path, lambda p: tmp_path / "b" / "build" / p)
    assert sorted(a) == sorted(b) and "pose.json" in a and "meshes/demo-head.json" in a
    assert [k for k in a if a[k] != b[k]] == []
    assert b"Atlases in bare" in a["info bare"] and b"images from: bare/images" in a["info bare"]


def test_a_reports_counts_come_in_one_order_whatever_the_project(tmp_path):
    """The report's ``counts`` listed statuses in the order they first occurred: a project whose
    first attachment was meshed one night and kept the next gave reports whose text differed in
    the order of two keys."""
    from spinemesh.upgrade.report import Result, Target, write_report

    texts = []
    for statuses in (["meshed", "kept", "failed"], ["kept", "failed", "meshed"]):
        result = Result()
        result.targets = [Target(skeleton="s.json", skin="default", slot=f"s{i}", name=f"a{i}", paths=[f"a{i}"],
                                 status=status) for i, status in enumerate(statuses)]
        write_report(result, tmp_path / "report.json")
        texts.append(json.loads((tmp_path / "report.json").read_text())["counts"])
    assert list(texts[0]) == list(texts[1]) == ["failed", "kept", "meshed"]


def test_every_command_is_in_the_exit_status_table():
    """docs/reference/cli.md says each command's exit statuses where a build script looks for
    them: a new command is named there, or this fails."""
    from test_cli import COMMANDS

    text = (REPO / "docs" / "reference" / "cli.md").read_text()
    section = text[text.index("## Exit statuses"):text.index("## In a build pipeline")]
    for status in ("| 0 |", "| 2 |", "| 3 |", "| 130, 143, 129 |"):
        assert status in section
    told = set(re.findall(r"`([a-z-]+)`", section))
    assert not [c for c in COMMANDS if c not in told], sorted(set(COMMANDS) - told)


def test_a_preview_written_again_leaves_no_page_of_the_earlier_one(tmp_path):
    """``--preview P`` of every nightly build into one folder: a skeleton removed from the project
    left its page, its players' data and its pictures there (pictures are named by content, so
    every change of art added more), linked from nowhere. Now the earlier preview's files that
    the new one does not write again are removed; a file spinemesh did not write stays."""
    demo = make_demo_project(tmp_path / "demo")
    r = spinemesh("upgrade", demo, "--out", "o1", "--preview", "P", "--pack", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = spinemesh("pack", "o1", "--out", "p1", "--preview", "Q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    first = files_of(tmp_path / "P")
    (tmp_path / "P" / "notes.txt").write_text("mine")
    (demo / "demo-binary.skel").unlink()  # the project loses a skeleton: its page goes
    r = spinemesh("upgrade", demo, "--out", "o2", "--preview", "P", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = spinemesh("pack", "o2", "--out", "p2", "--preview", "Q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for name in ("P", "Q"):
        again = files_of(tmp_path / name)
        r = spinemesh("upgrade" if name == "P" else "pack", demo if name == "P" else "o2", "--out", f"fresh-{name}",
                      "--preview", f"fresh{name}", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        fresh = files_of(tmp_path / f"fresh{name}")
        assert sorted(k for k in again if k != "notes.txt") == sorted(fresh), name
    assert (tmp_path / "P" / "notes.txt").read_text() == "mine"
    assert len(first) > len(files_of(tmp_path / "freshP"))


@pytest.mark.parametrize("project", ["tga-hero", "cm-character"])
def test_real_projects_give_the_same_bytes_from_any_folder(tmp_path, corpus, project):
    """A corpus project (binary 3.x; JSON 4.1 exported from 4.2) upgraded with --pack, --weights
    auto and a preview, and posed: from the corpus by its name with --jobs 1 and hash seed 0,
    and by its absolute path from elsewhere with --jobs 2, hash seed 1 and another time zone."""
    skeleton = next(p.name for p in sorted((corpus / project).iterdir())
                    if p.suffix in (".skel", ".json") and not p.name.startswith("."))
    animation = next(iter(load_skeleton_animations(corpus / project / skeleton)), None)
    builds = []
    for side, jobs, env in (("a", 1, {"PYTHONHASHSEED": "0"}), ("b", 2, {"PYTHONHASHSEED": "1", "TZ": "Asia/Tokyo"})):
        where = tmp_path / side / "build"
        given = Path(project) if side == "a" else corpus / project
        cwd = corpus if side == "a" else tmp_path
        r = spinemesh("upgrade", given, "--out", where / "out", "--pack", "--weights", "auto", "--jobs", jobs,
                      "--preview", where / "preview", cwd=cwd, **env)
        assert r.returncode in (0, 3), r.stderr
        pose = ["-a", animation, "--times", "0.2,0.5"] if animation else []
        r = spinemesh("pose", given / skeleton, *pose, "--out", where / "pose.json", cwd=cwd, **env)
        assert r.returncode in (0, 3), r.stderr
        builds.append(files_of(where))
    a, b = builds
    assert sorted(a) == sorted(b)
    assert [k for k in a if a[k] != b[k]] == []


def load_skeleton_animations(path: Path) -> list[str]:
    from spinemesh.skeleton import load_skeleton

    return [str(name) for name in (load_skeleton(path).get("animations") or {})]


def test_reports_and_previews_name_a_projects_files_by_the_project_not_the_machine(tmp_path):
    """A page that cannot be decoded fails its attachments; the reports and previews said why
    naming the page by its absolute path (or the path given): two checkouts in other folders
    gave other bytes. Now by the project's name (``demo/demo.png: ...``), from any folder."""
    builds = []
    for side in ("a", "b"):
        demo = make_demo_project(tmp_path / side / "demo", with_images_folder=False)
        (demo / "demo.png").write_bytes((demo / "demo.png").read_bytes()[:300])  # truncated
        relative = side == "a"
        cwd = tmp_path / side if relative else tmp_path
        at = (lambda p: Path(p)) if relative else (lambda p, s=side: tmp_path / s / p)
        r = spinemesh("upgrade", at("demo"), "--out", at("o"), "--report", at("upgrade.json"), "--preview",
                      at("preview"), cwd=cwd)
        assert r.returncode == 3, r.stderr
        assert str(tmp_path / side / "demo" / "demo.png") in r.stderr or "demo/demo.png" in r.stderr
        r = spinemesh("pack", at("demo"), "--out", at("p"), "--report", at("pack.json"), "--preview",
                      at("pack-preview"), cwd=cwd)
        assert r.returncode in (2, 3), r.stderr
        builds.append({k: v for k, v in files_of(tmp_path / side).items() if not k.startswith("demo/")})
    a, b = builds
    assert b"demo/demo.png: " in a["upgrade.json"] and str(tmp_path).encode() not in a["upgrade.json"]
    assert sorted(a) == sorted(b)
    assert [k for k in a if k not in ("upgrade.json", "pack.json") and a[k] != b[k]] == []
    for name in ("upgrade.json", "pack.json"):
        if name in a:
            assert without_times(a[name]) == without_times(b[name]), name


def test_images_and_weights_pictures_written_again_leave_none_of_the_earlier_run(tmp_path):
    """``upgrade --images I`` and ``weights --preview W`` into the same folders every night: a
    region no longer upgraded or weighted (here: left out by --only) left its pictures there.
    Now the earlier run's files that the new one did not write again are removed: each folder
    holds what a fresh run writes, and a user's file stays."""
    from spinemesh.upgrade import Options, upgrade_project

    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    upgrade_project(demo, tmp_path / "meshed", Options(min_saving=None, jobs=1))

    def build(images: str, pictures: str, *only: str) -> None:
        r = spinemesh("upgrade", demo, "--out", f"o-{images}-{len(only)}", "--images", images, *only, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        r = spinemesh("weights", "meshed", "--out", f"w-{pictures}-{len(only)}", "--preview", pictures, "--replace",
                      *only, cwd=tmp_path)
        assert r.returncode == 0, r.stderr

    build("I", "W")
    first = {name: files_of(tmp_path / name) for name in ("I", "W")}
    for name in ("I", "W"):
        (tmp_path / name / "mine.txt").write_text("mine")
    build("I", "W", "--only", "demo-head")
    build("fresh-I", "fresh-W", "--only", "demo-head")
    for name in ("I", "W"):
        again, fresh = files_of(tmp_path / name), files_of(tmp_path / f"fresh-{name}")
        assert again.pop("mine.txt") == b"mine"
        assert len(fresh) < len(first[name]), name  # the earlier run wrote more
        assert sorted(again) == sorted(fresh), name


def test_an_upgrade_of_its_own_output_changes_nothing_and_says_so(tmp_path):
    """A build step run twice on its own output (a Makefile rule whose input is the last output):
    every skeleton, atlas and page is copied byte for byte, exit 0, and the run says there was
    nothing to upgrade."""
    from spinemesh.upgrade import Options, upgrade_project

    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    upgrade_project(demo, tmp_path / "meshed", Options(min_saving=None, jobs=1))
    r = spinemesh("upgrade", "meshed", "--out", "again", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "nothing to upgrade: every attachment is already a mesh" in r.stderr, r.stderr
    first, again = files_of(tmp_path / "meshed"), files_of(tmp_path / "again")
    first.pop(".spinemesh-output"), again.pop(".spinemesh-output")
    assert first == again


def test_mesh_of_a_folder_written_again_leaves_no_mesh_of_a_removed_image(tmp_path):
    """``mesh art/ --out meshes/ --preview previews/`` every night: an image removed from art/
    left its mesh and picture. Now they go with the next run; a user's file stays."""
    import shutil

    demo = make_demo_project(tmp_path / "demo")
    art = tmp_path / "art"
    shutil.copytree(demo / "images", art)
    r = spinemesh("mesh", "art", "--out", "meshes", "--preview", "previews", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (tmp_path / "meshes" / "mine.txt").write_text("mine")
    gone = sorted(art.glob("*.png"))[0]
    gone.unlink()
    r = spinemesh("mesh", "art", "--out", "meshes", "--preview", "previews", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = spinemesh("mesh", "art", "--out", "fresh-meshes", "--preview", "fresh-previews", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    meshes = files_of(tmp_path / "meshes")
    assert meshes.pop("mine.txt") == b"mine"
    assert sorted(meshes) == sorted(files_of(tmp_path / "fresh-meshes"))
    assert sorted(files_of(tmp_path / "previews")) == sorted(files_of(tmp_path / "fresh-previews"))
    assert f"{gone.stem}.json" not in meshes
