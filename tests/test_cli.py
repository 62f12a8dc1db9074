"""The command line as a user meets it: start-up, options, output folders, exit codes.

Everything runs on the demo project drawn by our own code (no ../shared data needed).
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spinemesh.demo import make_demo_project

REPO = Path(__file__).resolve().parents[1]


def _commands() -> list[str]:
    """Every command the app registers, so that a new one is checked too."""
    import typer

    from spinemesh.cli import app

    return sorted(typer.main.get_command(app).commands)


COMMANDS = _commands()
HEAVY = ("numpy", "cv2", "onnxruntime", "matplotlib", "PIL", "torch", "scipy")


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


@pytest.fixture
def demo(tmp_path) -> Path:
    return make_demo_project(tmp_path / "demo")


# --- start-up -------------------------------------------------------------------------------

@pytest.mark.parametrize("args", [["--help"], ["upgrade", "--help"], ["mesh", "--help"], ["convert", "--help"],
                                  ["--version"]])
def test_help_imports_nothing_heavy(args):
    """`--help` and `--version` load typer and our option definitions only (issue 19: start-up)."""
    code = ("import sys, runpy; sys.argv = ['spinemesh', *%r]\n"
            "try:\n    runpy.run_module('spinemesh', run_name='__main__')\n"
            "except SystemExit:\n    pass\n"
            "print('LOADED', sorted(m for m in %r if m in sys.modules))" % (args, HEAVY))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "LOADED []" in r.stdout, r.stdout[-500:] + r.stderr[-2000:]


def test_convert_imports_nothing_heavy(tmp_path):
    """Not even numpy: a .skel becomes JSON with the standard library alone."""
    doc = tmp_path / "d"
    make_demo_project(doc, with_images_folder=False)
    code = ("import sys, runpy; sys.argv = ['spinemesh', 'convert', %r, %r]\n"
            "try:\n    runpy.run_module('spinemesh', run_name='__main__')\n"
            "except SystemExit as e:\n    assert not e.code, e.code\n"
            "print('LOADED', sorted(m for m in %r if m in sys.modules))"
            % (str(doc / "demo-binary.skel"), str(tmp_path / "o.json"), HEAVY))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "LOADED []" in r.stdout, r.stdout[-500:] + r.stderr[-2000:]
    assert json.loads((tmp_path / "o.json").read_text())["skeleton"]["spine"].startswith("4.2")


def _convert_both_ways(args: list[str], cwd: Path) -> list[tuple]:
    """``spinemesh convert ARGS`` run by the console script with its plain path and with the
    plain path turned off (typer parses): (exit code, stdout, stderr, output bytes) of each."""
    results = []
    for entry in ("from spinemesh.cli import main as run",
                  "import spinemesh.cli.convert_files as f; f.run_plain_convert = lambda args: False\n"
                  "from spinemesh.cli import main as run"):
        out = cwd / "out"
        if out.exists():
            for f in out.iterdir():
                f.unlink()
        else:
            out.mkdir()
        code = (f"import sys; sys.argv = ['spinemesh', 'convert', *{args!r}]\n{entry}\n"
                "try:\n    run()\nfinally:\n    print('typer parsed:', 'spinemesh.cli.convert' in sys.modules, file=sys.stderr)")
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd)
        files = {f.name: f.read_bytes() for f in sorted(out.iterdir())}
        stderr, typer_parsed = r.stderr.rsplit("typer parsed: ", 1)
        results.append((r.returncode, r.stdout, stderr, files, typer_parsed.strip() == "True"))
    return results


@pytest.mark.parametrize("args", [["demo-binary.skel", "out/a.json"], ["demo-binary.skel", "out/a.skel"],
                                  ["--keep-binary-info", "demo-binary.skel", "out/a.json"],
                                  ["demo.json", "out/a.skel"], ["demo-binary.skel", "out/a.txt"],
                                  ["demo-binary.skel", "demo-binary.skel"], ["missing.skel", "out/a.json"],
                                  ["images", "out/a.json"], ["demo-binary.skel", "out/a.json", "--bogus"]])
def test_plain_convert_is_the_typer_command(demo, args):
    """The console script runs a plain ``convert`` without typer (start-up, issue 19): same files,
    output and exit code as the typer command; what it does not handle falls through to typer."""
    plain, typed = _convert_both_ways(args, demo)
    assert plain[:4] == typed[:4]
    assert typed[4], "the typer path did not run the typer command"
    handled = not any(a in ("missing.skel", "images", "--bogus") for a in args)
    assert plain[4] != handled, f"plain path {'not ' if handled else ''}taken for {args}"
    if handled and args[-1] == "out/a.json":
        assert plain[0] == 0 and "a.json" in plain[3]


def test_shortest_float32_matches_numpy():
    """convert's pure-Python float32 rounding (no numpy import) gives numpy's shortest decimals."""
    import numpy as np

    from spinemesh.skeleton_binary import shortest_float32

    rng = np.random.default_rng(1)
    values = rng.integers(0, 2 ** 32, 50_000, dtype=np.uint64).astype(np.uint32).view(np.float32)
    human = (rng.integers(-10 ** 5, 10 ** 5, 20_000) / 10.0 ** rng.integers(0, 5, 20_000)).astype(np.float32)
    for v in np.concatenate([values[np.isfinite(values)], human, np.float32([1e-45, -3e-45, 1.1754944e-38])]):
        assert shortest_float32(float(v)) == float(str(v)), repr(v)


def test_float32_text_is_numpys_shortest_decimal_as_the_editor_writes_it():
    """convert's JSON text of a float32 (exact arithmetic, no formatting per candidate) is numpy's
    shortest decimal, written as the editor does (integers without ``.0``, Java exponents)."""
    import numpy as np

    from spinemesh.json_style import _scalar
    from spinemesh.skeleton_binary import Float32Text

    rng = np.random.default_rng(2)
    values = rng.integers(0, 2 ** 32, 50_000, dtype=np.uint64).astype(np.uint32).view(np.float32)
    in_range = (rng.choice([-1, 1], 100_000) * 10.0 ** rng.uniform(-3.2, 7.2, 100_000)).astype(np.float32)
    human = (rng.integers(-10 ** 5, 10 ** 5, 20_000) / 10.0 ** rng.integers(0, 5, 20_000)).astype(np.float32)
    powers = np.float32([10.0 ** k for k in range(-4, 8)] + [-(10.0 ** k) for k in range(-4, 8)] + [1e-45, 0.0, -0.0])
    text = Float32Text()
    for v in np.concatenate([values[np.isfinite(values)], in_range, human, powers]):
        x = float(v)
        expected = str(int(x)) if x > 0 and x.is_integer() else _scalar(float(str(v)), java_exponents=True)
        if x == 0 and math.copysign(1.0, x) < 0:
            expected = "-0.0"  # the sign kept: -0.0 packs to other float32 bytes than 0
        assert text[x] == expected, repr(v)
    # Zeros are not remembered as keys, where 0 and -0.0 are the same one.
    assert [text[v] for v in (0.0, -0.0, 0, -0.0, 0.0)] == ["0", "-0.0", "0", "-0.0", "0"]
    # Beyond float32 (a physics mass read as 1 / a tiny float32) is written as it is; NaN and
    # infinities are refused with the writer's ValueError.
    assert text[-1e40] == "-1.0E40" and float(text[1e40]) == 1e40
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError):
            text[bad]


# --- options --------------------------------------------------------------------------------

def test_version():
    from spinemesh import __version__

    r = run("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"spinemesh {__version__}"


@pytest.mark.parametrize("command", COMMANDS)
def test_every_help_has_an_example_and_no_team_paths(command):
    r = run(command, "--help")
    assert r.returncode == 0, r.stderr
    assert "Example" in r.stdout
    for internal in ("../shared", "spine-examples", "spine-corpus", "--shared"):
        assert internal not in r.stdout, f"{command} --help mentions {internal}"


def test_the_package_never_names_team_paths():
    """The product (code, help, defaults) does not point at this team's data folders."""
    for path in (REPO / "spinemesh").rglob("*"):
        if path.suffix in (".py", ".json", ".txt", ".md", ".atlas") and path.is_file():
            text = path.read_text(encoding="utf-8", errors="replace")
            for internal in ("../shared", "spine-examples", "spine-corpus"):
                assert internal not in text, f"{path.relative_to(REPO)} mentions {internal}"


def test_choices_match_the_library():
    from spinemesh.cli._app import MaskSource, Preset
    from spinemesh.mesher import PRESETS
    from spinemesh.segment import MASK_MODES

    assert sorted(p.value for p in Preset) == sorted(PRESETS)
    assert sorted(m.value for m in MaskSource) == sorted(MASK_MODES)


def test_progress_bars_show_the_time_remaining():
    """Every command's progress bar comes from one place, which has an ETA column."""
    from rich.progress import TimeRemainingColumn

    from spinemesh.cli._app import progress_bar

    assert any(isinstance(c, TimeRemainingColumn) for c in progress_bar("x").columns)
    for path in (REPO / "spinemesh" / "cli").glob("*.py"):
        if path.name != "_app.py":
            assert "Progress(" not in path.read_text(), f"{path.name}: use _app.progress_bar (it shows the ETA)"


def test_mask_defaults_to_auto_everywhere():
    for command in ("mesh", "upgrade", "segment"):
        r = run(command, "--help")
        options = " ".join(r.stdout.split("Options:", 1)[1].split())
        assert "--mask <auto|alpha|model>" in options, options
        assert options.split("--mask", 1)[1].split(" --", 1)[0].count("[default: auto]") == 1, command


@pytest.mark.parametrize("bad", [["--preset", "nope"], ["--mask", "alfa"], ["--density", "0"],
                                 ["--density", "-3"], ["--density", "nan"], ["--density", "inf"],
                                 ["--max-vertices", "2"], ["--jobs", "0"], ["--min-size", "-1"]])
def test_bad_option_values_are_refused_in_one_line(demo, tmp_path, bad):
    r = run("upgrade", str(demo), "--out", str(tmp_path / "o"), *bad)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr and "Invalid value" in r.stderr
    assert not (tmp_path / "o").exists()


def test_mesh_writes_into_the_current_folder_not_beside_the_art(demo, tmp_path):
    here = tmp_path / "here"
    here.mkdir()
    art = demo / "images" / "demo-head.png"
    before = sorted(p.name for p in art.parent.iterdir())
    r = run("mesh", str(art), cwd=here)
    assert r.returncode == 0, r.stderr
    assert (here / "demo-head.mesh.json").is_file()
    assert sorted(p.name for p in art.parent.iterdir()) == before
    r = run("mesh", str(demo / "images" / "demo-spark"), cwd=here)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (here / "demo-spark-meshes").iterdir()) == [
        ".spinemesh-written", "frame1.json", "frame2.json", "frame3.json"]  # marked: written into again


def test_mesh_of_a_jpeg_follows_the_art_not_its_rectangle(tmp_path):
    """--mask auto (the default): an image without alpha is masked by the segmentation network."""
    import numpy as np
    from PIL import Image, ImageDraw

    im = Image.new("RGB", (160, 160), (255, 255, 255))
    draw = ImageDraw.Draw(im)
    draw.ellipse((30, 30, 130, 130), fill=(200, 40, 40))
    draw.ellipse((60, 60, 80, 80), fill=(30, 30, 120))
    im.save(tmp_path / "disc.jpg", quality=95)
    r = run("mesh", str(tmp_path / "disc.jpg"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    mesh = json.loads((tmp_path / "disc.mesh.json").read_text())
    x, y = np.asarray(mesh["vertices"], float)[: mesh["hull"]].T
    hull_area = 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))
    disc = np.pi * 50 ** 2
    assert disc <= hull_area < 1.3 * disc < 160 * 160  # the disc, not the 160x160 rectangle


# --- output folder --------------------------------------------------------------------------

@pytest.mark.parametrize("options", [["--pages", "any"], ["--max-page", "512", "--keep-files-as-exported"]])
def test_packing_options_without_pack_are_refused_in_one_line(demo, tmp_path, options):
    """Without --pack nothing is packed: a --pages any that was silently ignored would ship the
    export's pages to a user who believes them packed."""
    r = run("upgrade", str(demo), "--out", str(tmp_path / "out"), *options)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert "add --pack" in line and options[0] in line, line
    assert not (tmp_path / "out").exists()
    r = run("upgrade", str(demo), "--out", str(tmp_path / "out"), *options, "--pack", "--jobs", "1")
    assert r.returncode == 0, r.stderr


def test_a_dry_run_with_pack_says_it_packed_nothing(demo, tmp_path):
    """A dry run plans: its counts say "would mesh", its timing line names only the reading (it
    meshed and wrote nothing), and with --pack it says that nothing was packed either."""
    r = run("upgrade", str(demo), "--out", str(tmp_path / "out"), "--pack", "--dry-run", "--jobs", "1")
    assert r.returncode == 0, r.stderr
    assert "dry run: nothing meshed or written nor packed" in r.stdout and "spinemesh pack" not in r.stdout, r.stdout
    assert not (tmp_path / "out").exists()
    r = run("upgrade", str(demo), "--out", str(tmp_path / "out"), "--dry-run", "--jobs", "1")
    assert "nothing packed" not in r.stdout and "dry run: nothing meshed or written;" in r.stdout, r.stdout
    header = next(line for line in r.stdout.splitlines() if "skeleton" in line)
    assert "would mesh" in header and "meshed" not in header and "vertices" not in header, header
    timing = next(line for line in r.stdout.splitlines() if line.startswith("read "))
    assert "mesh" not in timing and "write" not in timing, timing
    assert not (tmp_path / "out").exists()


def test_existing_output_is_refused_then_written_again_with_overwrite(demo, tmp_path):
    out = tmp_path / "out"
    r = run("upgrade", str(demo), "--out", str(out), "--preview", str(tmp_path / "preview"))
    assert r.returncode == 0, r.stderr
    assert f"preview: {tmp_path / 'preview' / 'index.html'} (" in r.stdout.replace("\n", "")
    assert re.search(r"index\.html \(\d+\.\d s\)", r.stdout.replace("\n", "")), r.stdout  # its time: not in the timing line
    (out / "mine.txt").write_text("not spinemesh's")
    r = run("upgrade", str(demo), "--out", str(out))
    assert r.returncode == 2 and "--overwrite" in r.stderr and "Traceback" not in r.stderr
    assert (out / "mine.txt").exists()
    r = run("upgrade", str(demo / "demo.json"), "--out", str(out), "--overwrite", "--only", "demo-head")
    assert r.returncode == 0, r.stderr
    assert not (out / "demo-binary.skel").exists(), "--overwrite removes what the earlier run wrote"
    assert (out / "mine.txt").exists(), "and keeps what it did not write (tests/test_pipeline.py)"
    assert (out / "demo.json").is_file()


def test_overwrite_never_deletes_a_folder_we_did_not_write(demo, tmp_path):
    mine = tmp_path / "documents"
    mine.mkdir()
    (mine / "thesis.txt").write_text("precious")
    r = run("upgrade", str(demo), "--out", str(mine), "--overwrite")
    assert r.returncode == 2 and "not written by spinemesh" in r.stderr
    # --overwrite removes only the files a marker lists: the refusal says nothing is written, not "delete"
    assert "nothing is written there" in r.stderr and "delete it" not in r.stderr, r.stderr
    assert (mine / "thesis.txt").read_text() == "precious"


def test_a_report_is_not_a_skeleton(demo, tmp_path):
    out = tmp_path / "out"
    r = run("upgrade", str(demo), "--out", str(out), "--report", str(out / "report.json"))
    assert r.returncode == 0, r.stderr
    info = run("info", str(out))
    assert info.returncode == 0, info.stderr
    assert "report.json" not in info.stdout and "demo.json" in info.stdout


def test_one_skeleton_file_brings_only_what_it_needs(demo, tmp_path):
    out = tmp_path / "out"
    r = run("upgrade", str(demo / "demo.json"), "--out", str(out))
    assert r.returncode == 0, r.stderr
    written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()
                     and not p.name.startswith("."))
    assert written == ["demo.atlas", "demo.json", "demo.png"], written  # not its twin demo-binary.skel


# --- exit codes and messages ----------------------------------------------------------------

def test_deliberate_skips_exit_0_and_are_counted_as_kept(demo, tmp_path):
    r = run("upgrade", str(demo), "--out", str(tmp_path / "o"), "--min-size", "95",
            "--report", str(tmp_path / "r.json"))
    assert r.returncode == 0, r.stderr
    assert "kept as region" in r.stdout and "smaller than --min-size 95" in r.stdout
    rows = json.loads((tmp_path / "r.json").read_text())["attachments"]
    assert {t["status"] for t in rows} == {"meshed", "kept"}


def test_only_that_matches_nothing_is_refused_with_a_hint(demo, tmp_path):
    r = run("upgrade", str(demo), "--out", str(tmp_path / "o"), "--only", "no-such-*")
    assert r.returncode == 2
    assert "error:" in r.stderr and "--only 'head*'" in r.stderr


def test_empty_folder_warns_with_a_hint(tmp_path):
    (tmp_path / "empty").mkdir()
    r = run("upgrade", str(tmp_path / "empty"), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "no Spine skeleton found" in r.stderr
    assert not (tmp_path / "o").exists()  # refused: nothing written (it wrote an empty OUT)
    assert r.stdout == "", r.stdout  # no timing line of phases that never ran
    (tmp_path / "atlas-only").mkdir()  # an atlas without a skeleton: nothing to upgrade either
    (tmp_path / "atlas-only" / "a.atlas").write_text("a.png\nsize: 4,4\n")
    r = run("upgrade", str(tmp_path / "atlas-only"), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "no Spine skeleton found" in r.stderr and not (tmp_path / "o").exists()
    r = run("info", str(tmp_path / "empty"))
    assert r.returncode == 2 and "no Spine skeleton" in r.stderr


def test_an_upgraded_project_has_nothing_to_do(demo, tmp_path):
    assert run("upgrade", str(demo), "--out", str(tmp_path / "a")).returncode == 0
    r = run("upgrade", str(tmp_path / "a"), "--out", str(tmp_path / "b"))
    # what the first run upgraded is a mesh now; what it kept (not worth meshing) is kept again
    assert r.returncode == 0 and "nothing to upgrade" in r.stderr, r.stderr
    # with --pack the same run packs: it says what it packed, not that it did nothing
    r = run("upgrade", str(tmp_path / "a"), "--out", str(tmp_path / "c"), "--pack")
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr
    assert "nothing meshed: every" in r.stdout and "packed 1 of 1 atlas: 1 page into 1" in r.stdout, r.stdout


def test_a_run_that_only_rewrites_pages_says_so(tmp_path):
    """A project whose one region fills its page: nothing is meshed (an opaque rectangle gains
    nothing), no smaller page holds it, and its page, stored without compression, is written
    smaller losslessly: the run says that, not that it did nothing."""
    from PIL import Image

    project = tmp_path / "p"
    project.mkdir()
    y, x = np.mgrid[0:64, 0:64]
    page = np.dstack([x * 4, y * 4, (x + y) * 2, np.full_like(x, 255)]).astype(np.uint8)
    Image.fromarray(page).save(project / "tile.png", compress_level=0)
    (project / "tile.atlas").write_text("tile.png\n\tsize: 64, 64\n\tfilter: Linear, Linear\n"
                                        "tile\n\tbounds: 0, 0, 64, 64\n", encoding="utf-8")
    doc = {"skeleton": {"spine": "4.2.40"}, "bones": [{"name": "root"}],
           "slots": [{"name": "tile", "bone": "root", "attachment": "tile"}],
           "skins": [{"name": "default", "attachments": {"tile": {"tile": {"width": 64, "height": 64}}}}]}
    (project / "tile.json").write_text(json.dumps(doc), encoding="utf-8")
    r = run("upgrade", str(project), "--out", str(tmp_path / "o"), "--pack")
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr
    line = next(t for t in r.stdout.splitlines() if t.startswith("nothing meshed"))
    assert "packed none of 1 atlas; 1 page of kept atlases re-encoded losslessly; atlas files" in line, line
    assert (tmp_path / "o" / "tile.png").stat().st_size < (project / "tile.png").stat().st_size


def test_a_failure_exits_3(demo, tmp_path):
    doc = json.loads((demo / "demo.json").read_text())
    doc["skins"][0]["attachments"]["head"]["ghost"] = {"width": 10, "height": 10}
    (demo / "demo.json").write_text(json.dumps(doc))
    r = run("upgrade", str(demo), "--out", str(tmp_path / "o"))
    assert r.returncode == 3 and "ghost" in r.stderr


def test_memory_refused_past_every_stage_ends_in_one_line():
    """A MemoryError no stage caught: one line and exit code 2, no traceback."""
    code = ("import sys; sys.argv = ['spinemesh', 'info', '.']\n"
            "import spinemesh.cli as cli\n"
            "def app():\n    raise MemoryError()\n"
            "cli._load_app = lambda: app\n"
            "cli.main()")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr[-2000:]
    assert "Traceback" not in r.stderr and r.stderr.strip().count("\n") == 0, r.stderr
    assert r.stderr.startswith("error: not enough memory to finish")


@pytest.mark.parametrize("command", ["upgrade", "pack", "weights"])
@pytest.mark.parametrize("columns", ["80", "100"])
def test_help_reads_at_the_terminal_width(command, columns):
    """At 80 (and 100) columns no help line runs past the edge, and no option name is cut at its hyphen."""
    env = dict(os.environ, COLUMNS=columns)
    r = subprocess.run([sys.executable, "-m", "spinemesh", command, "--help"], capture_output=True, text=True,
                       env=env, check=False)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert all(len(line) <= int(columns) for line in lines), [line for line in lines if len(line) > int(columns)]
    cut = [line for line in lines if re.search(r"(^|\s)--?[a-z]+(-[a-z]+)*-$", line)]
    assert not cut, cut


@pytest.mark.parametrize("command", ["upgrade", "pack", "weights"])
def test_help_names_the_folders_it_speaks_of(command):
    """--overwrite's help says "Write OUT again": OUT is the name --out shows, and the project is PROJECT."""
    r = run(command, "--help")
    assert r.returncode == 0, r.stderr
    assert "--overwrite" in r.stdout and "OUT again" in r.stdout
    assert re.search(r"-o, --out OUT\b", r.stdout), r.stdout
    assert re.search(r"^Usage: .* \{?PROJECT\}?$", r.stdout, re.MULTILINE), r.stdout.splitlines()[0]
    assert "<path>" not in r.stdout
