"""A new user walks the guides a sixth time, from an installed wheel and a folder outside the
checkout, on corpus and example projects: what they met that the program said badly, each test
failing on the code before its fix.

Everything runs on the demo project drawn by our own code (no outside data needed).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

from test_pipeline import spinemesh

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "examples" / "demo"


def _run(*args, cwd: Path):
    """``spinemesh ARGS`` as a user runs it, from ``cwd``: never a traceback."""
    r = spinemesh(*args, cwd=cwd)
    assert "Traceback" not in r.stdout + r.stderr, r.stderr[-3000:]
    return r


def test_the_paper_preset_refuses_the_options_it_does_not_read(tmp_path):
    """``mesh sprites/ --preset paper --density 2 --max-vertices 60`` (the mesh guide's example)
    wrote meshes of up to 94 vertices on spine-examples' raptor images, the same as without the
    options, and ``upgrade --preset paper --min-saving 0.5`` meshed every region: the paper's
    preset reads none of them. Each is refused in one line, before anything is written."""
    res = _run("mesh", DEMO / "images", "--out", "m", "--preset", "paper", "--density", "2", "--max-vertices", "60",
               cwd=tmp_path)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "--density and --max-vertices tune the default preset only" in res.stderr, res.stderr
    res = _run("upgrade", DEMO, "--out", "u", "-p", "paper", "--min-saving", "0.5", cwd=tmp_path)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "--min-saving tunes the default preset only" in res.stderr, res.stderr
    assert not (tmp_path / "m").exists() and not (tmp_path / "u").exists()
    # the default preset takes them; the paper preset alone runs as before
    assert _run("mesh", DEMO / "images", "--out", "d", "--max-vertices", "12", cwd=tmp_path).returncode == 0
    assert _run("mesh", DEMO / "images", "--out", "p", "--preset", "paper", cwd=tmp_path).returncode == 0


def test_a_project_given_as_its_atlas_or_page_is_told_what_to_give(tmp_path):
    """A user who drops the atlas (or the page, or a skeleton to ``dataset``) onto a command was
    told ``not a Spine skeleton (.json or .skel)`` and no more; ``convert`` read an atlas as a
    binary skeleton (``expected a Spine version string in the header``), and ``dataset`` said
    ``folder not found`` of a file that is there. Each line now names what to give, in a form a
    shell takes (a folder with a space and an accent here)."""
    project = tmp_path / "Mes projets" / "héros 2"
    shutil.copytree(DEMO, project)
    said = f"give the project's folder, '{project}', or a skeleton in it (demo-binary.skel, demo.json)"
    for args in (("upgrade", project / "demo.atlas", "--out", "u"), ("pack", project / "demo.png", "--out", "p"),
                 ("info", project / "demo.atlas"), ("weights", project / "demo.atlas", "--out", "w")):
        r = _run(*args, cwd=tmp_path)
        assert r.returncode == 2 and r.stderr.strip().endswith(said), (args, r.stderr)
    for args in (("pose", project / "demo.png", "-a", "wave", "--out", "pose.json"),
                 ("convert", project / "demo.atlas", "demo.skel")):
        r = _run(*args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stdout + r.stderr)
        assert r.stderr.strip().endswith("give a skeleton of its folder (demo-binary.skel, demo.json)"), r.stderr
    r = _run("dataset", project / "demo.json", "--out", "DS", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.strip().endswith(f"not a folder: give the folder that holds it, "
                                                           f"'{project}'"), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["Mes projets"]  # nothing written


def test_convert_reads_a_binary_skeleton_of_any_name(tmp_path):
    """``convert`` reads a binary skeleton by its first bytes whatever its name (``hero.bytes``,
    as some Unity projects name it): refusing an atlas given to it refused every name but the
    skeletons' suffixes (``not a Spine skeleton``, exit 2)."""
    shutil.copy(DEMO / "demo-binary.skel", tmp_path / "demo.bytes")
    r = _run("convert", "demo.bytes", "demo.json", cwd=tmp_path)
    assert r.returncode == 0 and (tmp_path / "demo.json").is_file(), r.stdout + r.stderr


def test_a_windows_path_is_told_what_to_write(tmp_path):
    """A path pasted from Windows (``héros 2\\demo.json``) was said ``no such file or folder``
    alone of a project that was there (``mesh``: click's ``Path ... does not exist``); the line
    says that folders are separated by ``/`` and, where it is there, the path meant."""
    shutil.copytree(DEMO, tmp_path / "héros 2")
    for args in (("info", "héros 2\\demo.json"), ("upgrade", "héros 2\\", "--out", "u"),
                 ("mesh", "héros 2\\images", "--out", "m"), ("convert", "héros 2\\demo-binary.skel", "d.json")):
        r = _run(*args, cwd=tmp_path)
        meant = args[1].replace("\\", "/")
        assert r.returncode == 2, (args, r.stdout + r.stderr)
        assert r.stderr.strip() == (f"error: {args[1]}: no such file or folder (folders are separated by '/' here, "
                                    f"not '\\': did you mean '{meant}'?)"), r.stderr
    r = _run("upgrade", "C:\\Users\\art\\héros 2", "--out", "u", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.strip().endswith("no such file or folder (folders are separated by '/' "
                                                           "here, not '\\')"), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["héros 2"]  # nothing written


def test_the_wheel_holds_every_package_file_and_builds_without_a_deprecation(tmp_path):
    """``pip wheel . --no-deps`` (what a studio's build does) warned at every build that the
    licence table in pyproject.toml is deprecated and that builds stop working on 2027-02-18;
    the wheel's METADATA gave no licence a tool reads (``License: MIT`` free text). It builds
    without the warning, with ``License-Expression: MIT``, and holds every file of the package:
    the segmentation model and its card, the bone choice, the preview player, and the licence's
    text, which the MIT licence asks every copy to carry (the wheel held none)."""
    from conftest import unavailable

    source = tmp_path / "src"  # built from a copy: the build writes build/ and *.egg-info beside its sources
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        source.mkdir(exist_ok=True)
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "spinemesh", source / "spinemesh", ignore=shutil.ignore_patterns("__pycache__"))
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "-w", str(tmp_path / "wheel")],
                       capture_output=True, text=True, timeout=600)
    if r.returncode != 0 and "setuptools" in r.stdout + r.stderr and "No matching distribution" in r.stdout + r.stderr:
        unavailable("pip cannot fetch setuptools to build the wheel (no package index)")
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "deprecated" not in (r.stdout + r.stderr).lower(), r.stdout + r.stderr
    wheel = zipfile.ZipFile(next((tmp_path / "wheel").glob("spinemesh-*.whl")))
    names = set(wheel.namelist())
    package = {p.relative_to(source).as_posix() for p in (source / "spinemesh").rglob("*") if p.is_file()}
    assert {"spinemesh/models/segment.onnx", "spinemesh/player/player.js"} <= package
    assert package - names == set(), sorted(package - names)
    meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
    assert "License-Expression: MIT" in wheel.read(meta).decode().splitlines()
    licence = next((n for n in names if n.endswith(".dist-info/licenses/LICENSE")), None)
    assert licence and wheel.read(licence) == (REPO / "LICENSE").read_bytes(), sorted(names)[-8:]
    entry = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "spinemesh = spinemesh.cli:main" in wheel.read(entry).decode()


def test_a_page_named_in_other_letter_case_is_said(tmp_path):
    """A project exported on Windows or macOS whose atlas names ``demo.png`` where the file is
    ``Demo.png`` loads there (their disks find it whatever the case) and nowhere else; on Linux
    every command said ``page image 'demo.png' not found`` beside the file it wanted."""
    project = tmp_path / "hero"
    shutil.copytree(DEMO, project)
    (project / "demo.png").rename(project / "Demo.png")
    r = _run("info", project, cwd=tmp_path)
    assert (f"{project / 'demo.atlas'}:1: page image 'demo.png' not found: 'Demo.png' is there, its name in other "
            "letter case") in r.stderr, r.stderr
    assert "rename the file or the atlas's page line so that they match" in r.stderr, r.stderr


def test_a_report_named_as_the_output_folder_is_refused_before_the_work(tmp_path):
    """``--report meshed`` beside ``--out meshed`` (a report that was meant to go in it) passed
    every check, the run wrote OUT, and only then the report was refused, exit 3: ``upgrade``,
    ``pack`` and ``weights`` alike. It is refused first, in one line saying what to write."""
    for command, out in (("upgrade", "m"), ("pack", "p"), ("weights", "w/inner")):
        report = out.split("/")[0]
        r = _run(command, DEMO, "--out", out, "--report", report, cwd=tmp_path)
        assert r.returncode == 2, (command, r.stdout + r.stderr)
        assert r.stderr.strip() == (f"error: {report}: --report names the output folder (--out {out}) or one above "
                                    f"it; give the report a file's name, beside the folder or in it "
                                    f"({out}/report.json)"), r.stderr
        assert list(tmp_path.iterdir()) == [], command  # nothing written


def test_pack_and_weights_say_where_their_preview_is(tmp_path, meshed):
    """``upgrade --preview`` ends with the page to open; ``pack --preview`` and ``weights
    --preview`` wrote theirs without a word, so a user looked for the page (or the pictures) in
    the folder. Each says it on its last line."""
    r = _run("pack", meshed, "--out", "packed", "--preview", "packed-preview", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.strip().splitlines()[-1] == "preview: packed-preview/index.html", r.stdout
    assert (tmp_path / "packed-preview" / "index.html").is_file()
    r = _run("weights", meshed, "--out", "weighted", "--preview", "weighted-preview", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    pictures = sorted((tmp_path / "weighted-preview").glob("*.png"))
    assert pictures and r.stdout.strip().splitlines()[-1] == f"preview: weighted-preview ({len(pictures)} pictures)", \
        r.stdout


def _stats_without_matplotlib(ds: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``spinemesh dataset-stats DS ARGS`` where matplotlib is not installed (``pip install .``)."""
    code = ("import sys; sys.modules['matplotlib'] = None; from spinemesh.cli import main; "
            f"sys.argv = ['spinemesh', 'dataset-stats', {str(ds)!r}, *{list(args)!r}]; main()")
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "200"})


def test_dataset_stats_without_the_stats_extra_prints_its_counts_and_exits_0(tmp_path):
    """``spinemesh dataset-stats DS`` (the data set guide's example) on a plain ``pip install .``
    printed its counts and then ``error: dataset-stats plots need matplotlib``, exit 2, the plots
    being the ``stats`` extra's; ``--plots DIR``, which asks for them, was refused only after the
    counts. The counts end with a warning (exit 0); ``--plots`` is refused first."""
    from test_newuser5 import _one_game_data_set

    ds = _one_game_data_set(tmp_path)
    r = _stats_without_matplotlib(ds, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "samples" in r.stdout and "Traceback" not in r.stderr, r.stdout + r.stderr
    assert r.stderr.strip() == ("warning: no plots written: dataset-stats plots need matplotlib: "
                                "pip install 'spinemesh[stats]'"), r.stderr
    assert not (ds / "stats").exists()
    r = _stats_without_matplotlib(ds, "--plots", "plots", cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == "", r.stdout + r.stderr
    assert r.stderr.strip() == "error: --plots: dataset-stats plots need matplotlib: pip install 'spinemesh[stats]'"


def test_getting_started_draws_the_demo_for_a_wheel_without_the_checkout(tmp_path):
    """Getting started tries the demo at ``examples/demo``, a folder of the checkout that no wheel
    holds: a user who installed the wheel had no project to try. The page gives the line that
    draws it from the installed package; run as written, it draws the checkout's demo byte for byte."""
    import shlex

    page = (REPO / "docs" / "getting-started.md").read_text(encoding="utf-8")
    line = next(line for line in page.splitlines() if line.startswith("python -c ") and "make_demo_project" in line)
    args = shlex.split(line)
    subprocess.run([sys.executable, *args[1:]], cwd=tmp_path, check=True, timeout=120,
                   env={**os.environ, "PYTHONPATH": str(REPO)})
    drawn = tmp_path / "examples" / "demo"
    assert sorted(p.relative_to(drawn) for p in drawn.rglob("*")) == sorted(p.relative_to(DEMO) for p in DEMO.rglob("*"))
    assert all(p.read_bytes() == (drawn / p.relative_to(DEMO)).read_bytes() for p in DEMO.rglob("*") if p.is_file())
