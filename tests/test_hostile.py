"""Hostile input: what an attacker or an unlucky user gives the command line.

Every case mutates a copy (in ``tmp_path``) of a small project our own code draws
(``examples/demo``, made by ``scripts/make_demo_project.py``) or, when present, of
``../shared/spine-examples/4.2/powerup``, then runs ``python -m spinemesh`` in a subprocess
under a memory limit (``RLIMIT_AS``) and a time limit, and checks what the README's
"Safety" section promises:

- the exit status is 0, 2 (refused, one line naming the file) or 3 (partial);
- no traceback;
- every input file is byte-identical afterwards (sha256), and nothing is written outside
  the outputs the command was given;
- no JSON written holds NaN or Infinity, and no temporary file is left behind.

Cases are small so that the whole file runs in well under a minute and a half.
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import shutil
import signal
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from conftest import EXAMPLES, REPO, unavailable

DEMO = REPO / "examples" / "demo"
POWERUP = EXAMPLES / "4.2" / "powerup"

#: Address-space limit of every run: a tiny file asking for gigabytes fails fast instead.
MEMORY_LIMIT = 3 * 1024**3
#: Seconds one run may take (cases are small; a hang is a failure).
TIME_LIMIT = 90


def _limits(memory: int, file_size: int | None):
    def apply():
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        if file_size is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size, file_size))
    return apply


def run_cli(*args, cwd: Path, memory: int = MEMORY_LIMIT, file_size: int | None = None,
            timeout: float = TIME_LIMIT) -> subprocess.CompletedProcess:
    """``python -m spinemesh ARGS`` in ``cwd`` under the limits, with a narrow terminal."""
    env = {**os.environ, "COLUMNS": "60", "NO_COLOR": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout,
                          preexec_fn=_limits(memory, file_size))


def snapshot(root: Path) -> dict[str, str]:
    """sha256 of every file under ``root`` (symlinks as their target text), by relative path."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        if p.is_symlink():
            out[rel] = "link:" + os.readlink(p)
        elif p.is_file():
            with open(p, "rb") as f:
                out[rel] = hashlib.file_digest(f, "sha256").hexdigest()
    return out


def _strict(text: str, where: str):
    def refuse(name):
        raise AssertionError(f"{where} holds {name}")
    return json.loads(text, parse_constant=refuse)


def check_run(r: subprocess.CompletedProcess, before: dict, tmp: Path, outputs: list[str],
              codes=(0, 2, 3)) -> None:
    """The promises every run keeps, whatever it was given."""
    text = r.stdout + r.stderr
    assert r.returncode in codes, f"exit {r.returncode}\n{text[-3000:]}"
    assert "Traceback" not in text, text[-3000:]
    after = snapshot(tmp)
    for rel, digest in before.items():
        assert after.get(rel) == digest, f"input {rel} was changed or removed"
    copies = set(before.values())
    for rel in set(after) - set(before):
        assert any(rel == o or rel.startswith(o.rstrip("/") + "/") for o in outputs), \
            f"{rel} written outside the outputs {outputs}"
        name = rel.rsplit("/", 1)[-1]
        assert not name.endswith(".tmp"), f"temporary file {rel} left behind"
        if name.endswith(".json") and after[rel] not in copies:  # what we wrote, not a copied input
            _strict((tmp / rel).read_text("utf-8-sig"), rel)  # a byte-order mark is kept from the input
    if r.returncode == 2:
        # ours ("error: FILE: why"), the option parser's ("error: CMD: Invalid value for '--x': ..."),
        # or, for a folder of images of which none could be meshed, one "skipped: FILE: why" per image
        errors = [line for line in r.stderr.splitlines() if line.lower().startswith(("error:", "skipped:"))]
        assert errors, f"exit 2 without an 'error:' line:\n{r.stderr}"


def written_skeleton(path: Path) -> dict:
    from spinemesh.skeleton import first_non_finite, load_skeleton

    doc = load_skeleton(path)
    assert first_non_finite(doc) is None
    return doc


# --- projects -------------------------------------------------------------------------------

@pytest.fixture
def demo(tmp_path) -> Path:
    """A copy of the bundled demo project (atlas, page, images folder, .json and .skel)."""
    dest = tmp_path / "p"
    shutil.copytree(DEMO, dest)
    return dest


def json_demo(tmp: Path) -> Path:
    """The demo project, drawn by our code into ``tmp / "p"``, with its JSON skeleton only."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    return project


def _demo_json(p: Path) -> dict:
    return json.loads((p / "demo.json").read_text())


def _write_json(path: Path, doc) -> None:
    path.write_text(json.dumps(doc))


def _json_only(p: Path) -> None:
    """Leave only demo.json as skeleton, so that a case is about one file."""
    (p / "demo-binary.skel").unlink()


def _attachment(doc: dict, slot: str, name: str) -> dict:
    return doc["skins"][0]["attachments"][slot][name]


def _set(p: Path, slot: str, name: str, **fields) -> None:
    doc = _demo_json(p)
    _attachment(doc, slot, name).update(fields)
    _write_json(p / "demo.json", doc)


def _upgrade(tmp: Path, p: Path, *extra, outputs=("o",), **kw):
    before = snapshot(tmp)
    r = run_cli("upgrade", p.name, "--out", "o", *extra, cwd=tmp, **kw)
    check_run(r, before, tmp, list(outputs))
    return r


# --- skeleton JSON mutations ------------------------------------------------------------------

SKELETON_CASES = {
    # issue #11 reproductions (3, 4, 5)
    "sequence count 200 million": lambda p: _set(p, "spark", "spark", sequence={"count": 200_000_000}),
    "sequence count not a number": lambda p: _set(p, "spark", "spark", sequence={"count": "many"}),
    "sequence digits a billion": lambda p: _set(p, "spark", "spark", sequence={"count": 3, "digits": 10**9}),
    "sequence count negative": lambda p: _set(p, "spark", "spark", sequence={"count": -5}),
    "nesting 5000 deep": lambda p: (p / "demo.json").write_text(
        (p / "demo.json").read_text().replace('"bones"', '"deep": ' + "[" * 5000 + "]" * 5000 + ', "bones"', 1)),
    "lone surrogate in a name": lambda p: (p / "demo.json").write_text(
        (p / "demo.json").read_text().replace('"demo-head"', '"demo-head\\ud800"', 1)),
    "width NaN": lambda p: (p / "demo.json").write_text(
        (p / "demo.json").read_text().replace('"width": 90', '"width": NaN', 1)),
    "x Infinity": lambda p: (p / "demo.json").write_text(
        (p / "demo.json").read_text().replace('"y": 10', '"y": Infinity', 1)),
    "number beyond float range": lambda p: (p / "demo.json").write_text(
        (p / "demo.json").read_text().replace('"y": 10', '"y": 1e999', 1)),
    "integer of 5000 digits": lambda p: (p / "demo.json").write_text(
        (p / "demo.json").read_text().replace('"y": 10', '"y": ' + "9" * 5000, 1)),
    "width a string": lambda p: _set(p, "head", "demo-head", width="wide"),
    "scale a list": lambda p: _set(p, "head", "demo-head", scaleX=[1, 2]),
    "region named to climb out": lambda p: _set(p, "head", "demo-head", path="../../../../etc/passwd"),
    "absolute image path": lambda p: _set(p, "head", "demo-head", path="/etc/passwd"),
    "NUL in a path": lambda p: _set(p, "head", "demo-head", path="demo\u0000head"),
    "skins not a list": lambda p: _write_json(p / "demo.json", {**_demo_json(p), "skins": 7}),
    "top level a list": lambda p: _write_json(p / "demo.json", [1, 2, 3]),
    "truncated JSON": lambda p: (p / "demo.json").write_text((p / "demo.json").read_text()[:300]),
    "not UTF-8": lambda p: (p / "demo.json").write_bytes(b'{"bones": ["\xff\xfe"]}'),
    "empty file": lambda p: (p / "demo.json").write_bytes(b""),
    "a 300 MB skeleton (sparse)": lambda p: _sparse(p / "demo.json", b'{"bones": [', 300 * 1024**2),
    # rich markup in names once crashed the summary with a MarkupError traceback
    "markup in names": lambda p: _write_json(p / "demo.json", _with_markup_names(_demo_json(p))),
}


def _sparse(path: Path, head: bytes, size: int) -> None:
    """``head`` followed by zeros up to ``size`` bytes, without using the disk space."""
    path.write_bytes(head)
    os.truncate(path, size)


def _with_markup_names(doc: dict) -> dict:
    attachments = doc["skins"][0]["attachments"]
    attachments["head"]["[/bold]"] = {"width": 10, "height": 10}  # no such region: fails, is printed
    attachments["head"]["[red]x"] = {"type": "[/x]"}
    return doc


@pytest.mark.parametrize("case", sorted(SKELETON_CASES))
def test_hostile_skeleton(tmp_path, demo, case):
    _json_only(demo)
    SKELETON_CASES[case](demo)
    _upgrade(tmp_path, demo, "--report", "o-report.json", outputs=("o", "o-report.json"))
    if "demo.json" in json.loads((tmp_path / "o-report.json").read_text())["skeletons_written"]:
        written_skeleton(tmp_path / "o" / "demo.json")


def test_refused_skeleton_names_its_file_and_others_go_on(tmp_path, demo):
    """A skeleton refused for NaN is reported with its name; its binary twin is still upgraded."""
    (demo / "demo.json").write_text((demo / "demo.json").read_text().replace('"width": 90', '"width": NaN', 1))
    r = _upgrade(tmp_path, demo)
    assert r.returncode == 3
    assert "demo.json" in r.stderr and "non-finite" in r.stderr.replace("NaN", "non-finite")
    written_skeleton(tmp_path / "o" / "demo-binary.skel")


def test_sequence_limit_fails_one_attachment_only(tmp_path, demo):
    _json_only(demo)
    _set(demo, "spark", "spark", sequence={"count": 200_000_000})
    t0 = time.perf_counter()
    r = _upgrade(tmp_path, demo, "--report", "r.json", outputs=("o", "r.json"))
    assert time.perf_counter() - t0 < 60
    assert r.returncode == 3
    rows = json.loads((tmp_path / "r.json").read_text())["attachments"]
    by_name = {row["name"]: row for row in rows}
    assert by_name["spark"]["status"] == "failed" and "count" in by_name["spark"]["reason"]
    assert by_name["demo-head"]["status"] == "meshed"


# --- binary .skel mutations -------------------------------------------------------------------

def _mutate_skel(p: Path, change) -> None:
    from spinemesh.skeleton_binary import encode_skel, read_skel

    path = p / "demo-binary.skel"
    doc = read_skel(path)
    change(doc)
    path.write_bytes(encode_skel(doc, path))


def _skel_attachment(doc, slot, name):
    skins = doc["skins"]
    return (skins[0]["attachments"] if isinstance(skins, list) else skins["default"])[slot][name]


@pytest.mark.parametrize("case", ["count 2e9", "x NaN", "width Infinity"])
def test_hostile_binary_skeleton(tmp_path, demo, case):
    (demo / "demo.json").unlink()
    if case == "count 2e9":
        _mutate_skel(demo, lambda d: _skel_attachment(d, "spark", "spark")["sequence"].update(count=2_000_000_000))
    elif case == "x NaN":
        _mutate_skel(demo, lambda d: _skel_attachment(d, "head", "demo-head").update(x=float("nan")))
    else:
        _mutate_skel(demo, lambda d: _skel_attachment(d, "head", "demo-head").update(width=float("inf")))
    r = _upgrade(tmp_path, demo)
    assert r.returncode in (0, 3)
    if (tmp_path / "o" / "demo-binary.skel").is_file():
        written_skeleton(tmp_path / "o" / "demo-binary.skel")


# --- atlas and page mutations -----------------------------------------------------------------

def _atlas(p: Path, old: str, new: str) -> None:
    text = (p / "demo.atlas").read_text()
    assert old in text
    (p / "demo.atlas").write_text(text.replace(old, new, 1))


def _png_header_only(path: Path, width: int, height: int) -> None:
    """A PNG that claims ``width x height`` pixels with almost no data (a decompression bomb's header)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\x00" * 64))
                     + chunk(b"IEND", b""))


def _as_tiff(path: Path) -> None:
    """The page re-encoded as TIFF under its .png name: only the formats atlases use are decoded."""
    from PIL import Image

    with Image.open(path) as im:
        im.load()
        im.save(path, format="TIFF")


ATLAS_CASES = {
    "offsets 20000 square": lambda p: _atlas(p, "offsets: 5, 4, 90, 90", "offsets: 0, 0, 20000, 20000"),
    # just under the pixel limit: a large, almost empty original is meshed within the memory limit
    "offsets 9000 square": lambda p: _atlas(p, "offsets: 5, 4, 90, 90", "offsets: 5, 4, 9000, 9000"),
    "negative size region": lambda p: _atlas(p, "bounds: 105, 2, 81, 81", "bounds: 105, 2, -81, 81"),
    "scale abc": lambda p: _atlas(p, "filter: Linear, Linear", "filter: Linear, Linear\n\tscale: abc"),
    "scale 0": lambda p: _atlas(p, "filter: Linear, Linear", "filter: Linear, Linear\n\tscale: 0"),
    "scale nan": lambda p: _atlas(p, "filter: Linear, Linear", "filter: Linear, Linear\n\tscale: nan"),
    "bounds beyond the page": lambda p: _atlas(p, "bounds: 105, 2, 81, 81", "bounds: 2000000000, 2, 81, 81"),
    "region named to climb out": lambda p: _atlas(p, "demo-head\n", "../../../../x\n"),
    "page named to climb out": lambda p: _atlas(p, "demo.png", "../../../../etc/hostname"),
    "page absolute": lambda p: _atlas(p, "demo.png", "/etc/hostname"),
    "page missing": lambda p: (p / "demo.png").unlink(),
    "page not an image": lambda p: (p / "demo.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really"),
    "page truncated": lambda p: (p / "demo.png").write_bytes((p / "demo.png").read_bytes()[:400]),
    "page claims 13000 square": lambda p: _png_header_only(p / "demo.png", 13000, 13000),
    "page claims 100000 by 1": lambda p: _png_header_only(p / "demo.png", 100_000, 1),
    "page a TIFF named .png": lambda p: _as_tiff(p / "demo.png"),
    "page a FIFO": lambda p: ((p / "demo.png").unlink(), os.mkfifo(p / "demo.png")),
    "atlas not UTF-8": lambda p: (p / "demo.atlas").write_bytes(b"\xff\xfe\x00junk"),
    "atlas entry before a name": lambda p: (p / "demo.atlas").write_text("size: 1, 2\n"),
    "unreadable second atlas": lambda p: (p / "other.atlas").write_bytes(b"\xff" * 64),
    "second atlas climbing out": lambda p: (p / "other.atlas").write_text("../../x.png\nsize: 4, 4\nr\n  bounds: 0,0,1,1\n"),
    "rotate sideways": lambda p: _atlas(p, "rotate: 90", "rotate: sideways"),
    "huge number": lambda p: _atlas(p, "bounds: 105, 2, 81, 81", "bounds: 105, 2, 81, " + "9" * 5000),
}


@pytest.mark.parametrize("case", sorted(ATLAS_CASES))
def test_hostile_atlas(tmp_path, demo, case):
    _json_only(demo)
    ATLAS_CASES[case](demo)
    r = _upgrade(tmp_path, demo, "--images", "o-images", outputs=("o", "o-images"))
    assert r.returncode in (0, 3), r.stderr
    written_skeleton(tmp_path / "o" / "demo.json")  # one bad thing never stops the project


def test_unreadable_atlas_elsewhere_does_not_stop_info(tmp_path, demo):
    (demo / "other.atlas").write_bytes(b"\xff" * 64)
    before = snapshot(tmp_path)
    r = run_cli("info", demo.name, cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(0, 1, 3))
    assert "other.atlas" in r.stderr and "demo.json" in r.stdout


def test_scale_abc_names_the_atlas_and_line(tmp_path, demo):
    _json_only(demo)
    ATLAS_CASES["scale abc"](demo)
    r = _upgrade(tmp_path, demo)
    assert "demo.atlas:" in r.stderr and "scale" in r.stderr


def test_region_climbing_out_of_images_folder_blames_it(tmp_path, demo):
    _json_only(demo)
    _atlas(demo, "demo-head\n", "../../../../x\n")
    _set(demo, "head", "demo-head", path="../../../../x")
    r = _upgrade(tmp_path, demo, "--images", "o-images", outputs=("o", "o-images"))
    assert r.returncode == 3 and "--images folder" in r.stderr
    assert not (tmp_path.parent / "x.png").exists()


# --- image folder and containment ------------------------------------------------------------

def test_images_hint_outside_the_project_is_not_read(tmp_path, demo):
    """``skeleton.images: ../p-evil/`` once passed a string-prefix test for project ``p``."""
    _json_only(demo)
    (demo / "demo.atlas").unlink()
    shutil.move(demo / "images", tmp_path / "p-evil")
    doc = _demo_json(demo)
    doc["skeleton"]["images"] = "../p-evil/"
    _write_json(demo / "demo.json", doc)
    r = _upgrade(tmp_path, demo, "--images", "o-images", outputs=("o", "o-images"))
    assert r.returncode == 3 and "outside the project" in r.stderr
    assert not (tmp_path / "o-images").exists()
    out = written_skeleton(tmp_path / "o" / "demo.json")
    assert all(a.get("type", "region") == "region" for s in out["skins"][0]["attachments"].values()
               for a in s.values())


def test_relative_project_path_uses_its_images_folder(tmp_path, demo):
    _json_only(demo)
    (demo / "demo.atlas").unlink()
    r = _upgrade(tmp_path, demo)
    assert r.returncode == 0, r.stderr
    out = written_skeleton(tmp_path / "o" / "demo.json")
    assert _attachment(out, "head", "demo-head")["type"] == "mesh"


def test_symlink_to_outside_is_not_copied(tmp_path, demo):
    (tmp_path / "secret.txt").write_text("secret")
    (demo / "notes.txt").symlink_to(tmp_path / "secret.txt")
    (demo / "linked").symlink_to(tmp_path, target_is_directory=True)
    r = _upgrade(tmp_path, demo)
    assert r.returncode == 3 and "notes.txt" in r.stderr
    assert not (tmp_path / "o" / "notes.txt").exists() and not (tmp_path / "o" / "linked").exists()


# --- output targets ---------------------------------------------------------------------------

def _nested_project(tmp: Path, demo: Path) -> None:
    """``p/p/demo.json``: a project holding a folder of its own name (issue #11, case 1)."""
    _json_only(demo)
    (demo / "p").mkdir()
    _write_json(demo / "p" / "demo.json", {"skeleton": {"spine": "4.2.22"}, "bones": [{"name": "root"}]})


OUTPUT_CASES = {
    "out is the parent of the project": (["--out", "."], []),
    "out inside the project": (["--out", "p/o"], []),
    "out is the project": (["--out", "p"], []),
    "report onto an input": (["--out", "o", "--report", "p/demo.json"], ["o"]),
    "report inside the project": (["--out", "o", "--report", "p/new.json"], ["o"]),
    "images into the project": (["--out", "o", "--images", "p"], ["o"]),
    "images onto an input file": (["--out", "o", "--images", "p/demo.json"], ["o"]),
    "out names an existing file": (["--out", "f.txt"], []),
    "report is a folder": (["--out", "o", "--report", "o2"], ["o"]),
}


@pytest.mark.parametrize("case", sorted(OUTPUT_CASES))
def test_hostile_output_target(tmp_path, demo, case):
    _nested_project(tmp_path, demo)
    (tmp_path / "f.txt").write_text("keep me")
    (tmp_path / "o2").mkdir()
    args, outputs = OUTPUT_CASES[case]
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", *args, cwd=tmp_path)
    check_run(r, before, tmp_path, outputs)
    assert r.returncode == 2, r.stdout + r.stderr


def test_symlink_planted_in_output_is_not_written_through(tmp_path, demo):
    _json_only(demo)
    out = tmp_path / "o"
    out.mkdir()
    (out / "demo.json").symlink_to(demo / "demo.json")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o"])
    assert r.returncode == 2
    older = "written by spinemesh upgrade; --overwrite may replace this folder\n"
    (out / ".spinemesh-output").write_text(older)  # as an earlier (older) spinemesh wrote it
    before = {k: v for k, v in snapshot(tmp_path).items() if not k.startswith("o/")}
    r = run_cli("upgrade", "p", "--out", "o", "--overwrite", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o"])
    assert r.returncode == 0 and not (out / "demo.json").is_symlink()


def test_output_through_symlinked_folder_is_refused(tmp_path, demo):
    (tmp_path / "o").symlink_to(demo, target_is_directory=True)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2


def test_full_disk_leaves_no_temporary_file(tmp_path, demo):
    """A write that the file system refuses (here: a file-size limit, as a full disk would) is one line."""
    _json_only(demo)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", cwd=tmp_path, file_size=3000)
    check_run(r, before, tmp_path, ["o"])
    assert r.returncode in (2, 3) and "cannot write" in r.stderr


def test_two_runs_into_one_output(tmp_path, demo):
    _json_only(demo)
    before = snapshot(tmp_path)
    env = {**os.environ, "COLUMNS": "60"}
    procs = [subprocess.Popen([sys.executable, "-m", "spinemesh", "upgrade", "p", "--out", "o", "--overwrite"],
                              cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    for p in procs:
        stdout, stderr = p.communicate(timeout=TIME_LIMIT)
        check_run(subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr), before, tmp_path, ["o"])


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_output(tmp_path, demo):
    _json_only(demo)
    (tmp_path / "o").mkdir()
    (tmp_path / "o").chmod(0o500)
    try:
        before = snapshot(tmp_path)
        r = run_cli("upgrade", "p", "--out", "o", cwd=tmp_path)
        check_run(r, before, tmp_path, ["o"])
        assert r.returncode in (2, 3)
    finally:
        (tmp_path / "o").chmod(0o700)


# --- options ----------------------------------------------------------------------------------

OPTION_CASES = {
    "preset bogus": ["--preset", "bogus"],
    "mask bogus": ["--mask", "bogus"],
    "density nan": ["--density", "nan"],
    "density inf": ["--density", "inf"],
    "density negative": ["--density", "-1"],
    "density zero": ["--density", "0"],
    "max vertices negative": ["--max-vertices", "-5"],
    "min size nan": ["--min-size", "nan"],
    "jobs zero": ["--jobs", "0"],
}


@pytest.mark.parametrize("case", sorted(OPTION_CASES))
def test_hostile_option(tmp_path, demo, case):
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", *OPTION_CASES[case], cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("args", [["--density", "nan"], ["--preset", "bogus"], ["--alpha-threshold", "-3"],
                                  ["--max-vertices", "0"]])
def test_hostile_mesh_option(tmp_path, demo, args):
    before = snapshot(tmp_path)
    r = run_cli("mesh", "p/images/demo-head.png", "--out", "m.json", *args, cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2


# --- the other commands' outputs and inputs ---------------------------------------------------

def test_convert_refuses_its_own_source_and_names_bad_files(tmp_path, demo):
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/demo.json", "p/demo.json", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2
    (tmp_path / "link.json").symlink_to(demo / "demo-binary.skel")
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/demo.json", "link.json", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2
    doc = _demo_json(demo)
    doc["skeleton"]["spine"] = "banana"
    _write_json(tmp_path / "banana.json", doc)
    before = snapshot(tmp_path)
    r = run_cli("convert", "banana.json", "b.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, ["b.skel"])
    assert r.returncode == 2 and "b.skel" in r.stderr or "banana.json" in r.stderr


def test_mesh_and_segment_refuse_writing_onto_their_input(tmp_path, demo):
    img = "p/images/demo-head.png"
    for args in (["mesh", img, "--out", img], ["mesh", img, "--preview", img], ["segment", img, "--out", img],
                 ["mesh", "p/images", "--out", "p/images/sub"]):
        before = snapshot(tmp_path)
        r = run_cli(*args, cwd=tmp_path)
        check_run(r, before, tmp_path, [])
        assert r.returncode == 2, args
    # a symlink planted inside the output folder, leading into the input
    (tmp_path / "art" / "sub").mkdir(parents=True)
    shutil.copy(demo / "images" / "demo-head.png", tmp_path / "art" / "sub")
    (tmp_path / "mo").mkdir()
    (tmp_path / "mo" / "sub").symlink_to(demo / "images", target_is_directory=True)
    before = snapshot(tmp_path)
    r = run_cli("mesh", "art", "--out", "mo", cwd=tmp_path)
    check_run(r, before, tmp_path, ["mo"])
    assert r.returncode == 2 and not list((demo / "images").glob("*.json"))


def test_mesh_image_bomb_and_noise(tmp_path):
    from PIL import Image
    import numpy as np

    _png_header_only(tmp_path / "bomb.png", 13000, 13000)
    before = snapshot(tmp_path)
    r = run_cli("mesh", "bomb.png", "--out", "bomb.json", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2 and "bomb.png" in r.stderr and "limit" in r.stderr
    rng = np.random.default_rng(0)
    Image.fromarray(rng.integers(0, 256, (600, 600, 4), dtype=np.uint8)).save(tmp_path / "noise.png")
    before = snapshot(tmp_path)
    r = run_cli("mesh", "noise.png", "--preset", "paper", "--out", "noise.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["noise.json"])


def test_dataset_refuses_writing_into_its_corpus(tmp_path, demo):
    before = snapshot(tmp_path)
    r = run_cli("dataset", "p", "--out", "p/ds", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2


def test_malformed_source_json_is_reported_not_guessed(tmp_path, demo):
    (demo / ".source.json").write_text("{not json")
    before = snapshot(tmp_path)
    r = run_cli("dataset", "p", "--out", "ds", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["ds"])
    assert ".source.json" in r.stdout + r.stderr


def test_error_line_is_not_wrapped(tmp_path, demo):
    """A long path in an error stays on one line when stderr is not a terminal."""
    deep = tmp_path / ("a" * 60) / ("b" * 60)
    deep.mkdir(parents=True)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", str(deep / "missing"), "--out", "o", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    line = next(line for line in r.stderr.splitlines() if line.startswith("error:"))
    assert str(deep / "missing") in line


# --- interruption and worker processes --------------------------------------------------------

def test_workers_end_with_their_parent(tmp_path):
    """A pool started with spinemesh's worker initializer does not outlive a SIGKILLed parent."""
    script = tmp_path / "parent.py"
    script.write_text(
        "import os, sys, time\n"
        "from spinemesh.cluster import ProcessWorkers\n"
        "w = ProcessWorkers(2)\n"
        "futures = [w.submit(time.sleep, 60) for _ in range(2)]\n"
        "time.sleep(1.5)\n"
        "print(' '.join(map(str, w.pids)), flush=True)\n"
        "time.sleep(60)\n")
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True, cwd=REPO)
    pids = [int(p) for p in parent.stdout.readline().split()]
    assert len(pids) == 2
    parent.send_signal(signal.SIGKILL)
    parent.wait(10)
    deadline = time.monotonic() + 10
    alive = pids
    while alive and time.monotonic() < deadline:
        time.sleep(0.2)
        alive = [p for p in pids if _alive(p)]
    assert not alive, f"workers {alive} outlived their parent"


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_interrupted_write_leaves_no_temporary_file(tmp_path, monkeypatch):
    """Ctrl-C while a copy is being written (its temporary file made and half full): no
    temporary file stays. (The source is opened before anything is staged.)"""
    from spinemesh.files import atomic

    class Interrupted(KeyboardInterrupt):
        pass

    src = tmp_path / "src.bin"
    src.write_bytes(b"x" * 100)

    def interrupted_copy(source, target, *a, **k):
        target.write(source.read(10))
        raise Interrupted

    monkeypatch.setattr(atomic.shutil, "copyfileobj", interrupted_copy)
    with pytest.raises(Interrupted):
        atomic.atomic_copy(src, tmp_path / "out" / "dst.bin")
    assert list((tmp_path / "out").iterdir()) == []


def test_sigterm_during_upgrade_cleans_up(tmp_path, demo):
    """SIGTERM mid-run ends the run like Ctrl-C: no temporary file stays, no traceback."""
    before = snapshot(tmp_path)
    env = {**os.environ, "COLUMNS": "60"}
    proc = subprocess.Popen([sys.executable, "-m", "spinemesh", "upgrade", "p", "--out", "o", "--jobs", "2",
                             "--density", "4"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    # Signalled only once the run holds its output folder, so its handler is set: a signal
    # that came during Python's start-up would end it as SIGTERM's default does (exit -15).
    deadline = time.monotonic() + TIME_LIMIT
    while not (tmp_path / "o" / ".spinemesh-output").exists() and proc.poll() is None:
        assert time.monotonic() < deadline, "the run never started"
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=TIME_LIMIT)
    # A run faster than the wait has written everything and printed its summary before the
    # signal comes; Python's default for SIGTERM then ends it at exit (-15), with nothing left over.
    finished = "read " in stdout and " write " in stdout
    check_run(subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr), before, tmp_path, ["o"],
              codes=(0, 3, 128 + signal.SIGTERM) + ((-signal.SIGTERM,) if finished else ()))


# --- a real project, when present --------------------------------------------------------------

@pytest.fixture
def powerup(tmp_path) -> Path:
    if not POWERUP.is_dir():
        unavailable(f"{POWERUP} is absent: the real-data reproduction needs it")  # a failure in CI
    dest = tmp_path / "p"
    dest.mkdir()
    for name in ("powerup.atlas", "powerup.png", "powerup-pro.json"):
        shutil.copy(POWERUP / name, dest / name)
    return dest


def test_powerup_issue_reproduction(tmp_path, powerup):
    """Issue #11 case 1 on real data: the nested same-named folder, upgraded into the parent."""
    (powerup / "p").mkdir()
    for name in ("powerup.atlas", "powerup.png"):
        shutil.copy(powerup / name, powerup / "p" / name)
    _write_json(powerup / "p" / "powerup-pro.json", {"skeleton": {"spine": "4.2.22"}, "bones": [{"name": "root"}]})
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", ".", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2
    r = run_cli("upgrade", "p", "--out", "o", "--report", "o-report.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "o-report.json"])
    assert r.returncode == 0, r.stderr
    written_skeleton(tmp_path / "o" / "powerup-pro.json")


@pytest.mark.parametrize("args", [
    ["segment-eval", "--data", "ds", "--json", "ds/index.jsonl"],
    ["train", "--data", "ds", "--out", "ds/runs"],
    ["segment-export", "best.pt", "--data", "ds", "--out", "ds/model.onnx"],
], ids=["segment-eval --json", "train --out", "segment-export --out"])
def test_training_commands_never_write_into_a_data_set(tmp_path, args):
    """The segmentation commands' outputs are guarded like every other command's."""
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "index.jsonl").write_text("{}\n")
    (tmp_path / "best.pt").write_bytes(b"not a checkpoint")
    before = snapshot(tmp_path)
    r = run_cli(*args, cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2 and "lies inside the input" in r.stderr


# --- third round: dead workers, symlinked folders, wrong types, huge numbers, limits, names -----

def _children(pid: int) -> list[int]:
    """Process ids of the children of ``pid`` (its worker processes)."""
    out = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out += [int(x) for x in (task / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError):
            pass
    return out


def _library_of_demos(tmp: Path, demo: Path, count: int) -> Path:
    """``L/d0 ... L/dN``: copies of the demo project whose page colours differ, so that no image is shared."""
    from PIL import Image

    _json_only(demo)
    library = tmp / "L"
    for i in range(count):
        dest = library / f"d{i}"
        shutil.copytree(demo, dest)
        page = np.array(Image.open(dest / "demo.png").convert("RGBA"))
        page[..., :3] = (page[..., :3].astype(int) + 7 * (i + 1)) % 256
        Image.fromarray(page).save(dest / "demo.png")
    return library


def _kill_a_worker_while_running(args: list, cwd: Path, started: Path) -> subprocess.CompletedProcess:
    """Run ``python -m spinemesh ARGS``; once ``started`` exists and workers run, SIGKILL one of them."""
    env = {**os.environ, "COLUMNS": "60", "NO_COLOR": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_limits(MEMORY_LIMIT, None))
    killed = None
    deadline = time.monotonic() + TIME_LIMIT
    while proc.poll() is None and time.monotonic() < deadline and killed is None:
        workers = _children(proc.pid)
        if started.exists() and workers:
            time.sleep(0.3)  # inside a task
            try:
                os.kill(workers[0], signal.SIGKILL)
                killed = workers[0]
            except ProcessLookupError:  # that worker ended meanwhile (its last task done): pick another
                pass
        time.sleep(0.05)
    stdout, stderr = proc.communicate(timeout=TIME_LIMIT)
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


def test_a_killed_worker_does_not_hang_or_lose_the_library(tmp_path, demo):
    """``kill -9`` of one worker mid-run: its task runs again in a fresh worker; every project is written."""
    library = _library_of_demos(tmp_path, demo, 4)
    before = snapshot(tmp_path)
    t0 = time.monotonic()
    r = _kill_a_worker_while_running(["upgrade", "L", "--out", "o", "--jobs", "2", "--report", "r.json"],
                                     tmp_path, tmp_path / "o" / ".spinemesh-output")
    check_run(r, before, tmp_path, ["o", "r.json"], codes=(0, 3))
    assert time.monotonic() - t0 < TIME_LIMIT
    for i in range(4):
        written_skeleton(tmp_path / "o" / f"d{i}" / "demo.json")
    assert library.is_dir()


def test_a_killed_worker_does_not_hang_a_data_set(tmp_path, demo):
    _library_of_demos(tmp_path, demo, 4)
    before = snapshot(tmp_path)
    r = _kill_a_worker_while_running(["dataset", "L", "--out", "ds", "--jobs", "2"], tmp_path,
                                     tmp_path / "ds" / "meta.json")
    check_run(r, before, tmp_path, ["ds"], codes=(0, 3))
    projects = [json.loads(line) for line in (tmp_path / "ds" / "projects.jsonl").read_text().splitlines()]
    assert sorted(p["project"] for p in projects) == [f"L/d{i}" for i in range(4)]


def test_a_task_that_kills_its_worker_twice_fails_alone():
    """Local processes: the task is run once more in a fresh worker, then fails with the reason."""
    from spinemesh.cluster import ProcessWorkers, WorkerLost

    with ProcessWorkers(2) as w:
        doomed = w.submit(os._exit, 7)
        fine = [w.submit(abs, -i) for i in range(10)]
        assert sorted(f.result(timeout=60) for f in fine) == list(range(10))
        with pytest.raises(WorkerLost, match="exited with status 7.*2 times"):
            doomed.result(timeout=60)
        assert w.submit(abs, -5).result(timeout=60) == 5  # the workers go on


def test_a_task_that_kills_its_dask_worker_twice_fails_alone():
    pytest.importorskip("distributed")
    from spinemesh.cluster import DaskWorkers, WorkerLost

    with DaskWorkers("local", 1) as w:
        doomed = w.submit(os._exit, 7)
        with pytest.raises(WorkerLost, match="Dask lost the worker"):
            doomed.result(timeout=120)
        assert w.submit(abs, -5).result(timeout=120) == 5


#: The image key whose worker dies, and the real worker function (set by the test below; a
#: forked worker sees them too).
_DOOMED: dict = {}


def _die_on_one_image(task):
    """A worker that dies (as an out-of-memory kill would) on one chosen image, every time."""
    if task.key == _DOOMED["key"]:
        os._exit(9)
    return _DOOMED["mesh_one"](task)


def test_an_image_whose_worker_dies_twice_fails_alone(tmp_path, demo, monkeypatch):
    """In a real upgrade: the image's attachments stay regions with the reason; the rest is written."""
    from spinemesh.cluster import ProcessWorkers
    from spinemesh.project import find_project
    from spinemesh.upgrade import Options, Result, meshing, upgrade_project
    from spinemesh.upgrade.plan import plan_project

    _json_only(demo)
    plan = plan_project(find_project(demo), Options(), Result())
    monkeypatch.setitem(_DOOMED, "key", sorted(plan.tasks)[0])
    monkeypatch.setitem(_DOOMED, "mesh_one", meshing.mesh_one)
    monkeypatch.setattr(meshing, "mesh_one", _die_on_one_image)
    with ProcessWorkers(2) as workers:
        result = upgrade_project(demo, tmp_path / "o", Options(jobs=2), workers=workers)
    failed = [t for t in result.targets if t.key == _DOOMED["key"]]
    assert failed and all(t.status == "failed" and "exited with status 9" in t.reason for t in failed)
    assert any(t.status == "meshed" for t in result.targets) and result.partial
    assert result.written == ["demo.json"]


@pytest.mark.parametrize("command", [["upgrade", "L", "--out", "o"], ["upgrade", "L", "--out", "o", "--dry-run"],
                                     ["dataset", "L", "--out", "o"]], ids=["upgrade", "dry run", "dataset"])
def test_library_walk_does_not_follow_symlinked_folders(tmp_path, demo, command):
    """A link to a folder outside, and links that loop (``ln -s .``), are never entered."""
    _json_only(demo)
    library = tmp_path / "L"
    library.mkdir()
    shutil.copytree(demo, library / "real")
    shutil.copytree(demo, tmp_path / "outside")
    (library / "evil").symlink_to("../outside", target_is_directory=True)
    for name in ("l1", "l2", "loop"):
        (library / name).symlink_to(".", target_is_directory=True)
    (library / "real" / "loop").symlink_to("..", target_is_directory=True)
    before = snapshot(tmp_path)
    t0 = time.monotonic()
    r = run_cli(*command, "--report", "r.json", cwd=tmp_path, memory=1024**3, timeout=60) \
        if command[0] == "upgrade" else run_cli(*command, cwd=tmp_path, memory=1024**3, timeout=60)
    check_run(r, before, tmp_path, ["o", "r.json"])
    assert time.monotonic() - t0 < 60
    written = [p.relative_to(tmp_path / "o").as_posix() for p in (tmp_path / "o").rglob("*")] \
        if (tmp_path / "o").is_dir() else []
    assert not any(w.startswith(("evil", "l1", "l2", "loop")) or "/loop" in w for w in written), written
    if command[0] == "upgrade":
        rows = json.loads((tmp_path / "r.json").read_text())["attachments"]
        assert {row["skeleton"] for row in rows} == {"real/demo.json"}  # once, not once per loop


def test_mesh_folder_does_not_follow_a_symlink_out(tmp_path, demo):
    (tmp_path / "imgs").mkdir()
    shutil.copy(demo / "images" / "demo-head.png", tmp_path / "imgs" / "a.png")
    (tmp_path / "secret").mkdir()
    shutil.copy(demo / "images" / "demo-head.png", tmp_path / "secret" / "b.png")
    (tmp_path / "imgs" / "b.png").symlink_to("../secret/b.png")
    (tmp_path / "imgs" / "up").symlink_to("../secret", target_is_directory=True)
    os.mkfifo(tmp_path / "imgs" / "pipe.png")
    before = snapshot(tmp_path)
    r = run_cli("mesh", "imgs", "--out", "m", cwd=tmp_path, timeout=60)
    check_run(r, before, tmp_path, ["m"])
    names = {p.name for p in (tmp_path / "m").rglob("*") if p.is_file()}
    assert not any(n.startswith(("b", "pipe", "up")) for n in names), names


@pytest.mark.parametrize("scale", ["0.002", "1e-300", "1e300", "0.0005"])
def test_tiny_atlas_scale_is_refused_before_any_huge_image(tmp_path, demo, scale):
    _json_only(demo)
    _atlas(demo, "filter: Linear, Linear", f"filter: Linear, Linear\n\tscale: {scale}")
    t0 = time.monotonic()
    r = _upgrade(tmp_path, demo, "--images", "o-images", outputs=("o", "o-images"), memory=1024**3, timeout=60)
    assert time.monotonic() - t0 < 60
    assert r.returncode == 3, r.stderr
    assert "scale" in r.stderr


def _many_regions_skeleton(p: Path, count: int) -> None:
    doc = _demo_json(p)
    head = dict(_attachment(doc, "head", "demo-head"))
    doc["skins"][0]["attachments"]["head"] = {f"h{i}": {**head, "path": "demo-head"} for i in range(count)}
    _write_json(p / "demo.json", doc)


def test_twenty_thousand_edits_are_written_in_linear_time(tmp_path, demo):
    """20,000 region attachments drawing one image: one mesh, 20,000 splices in one pass."""
    _json_only(demo)
    _many_regions_skeleton(demo, 20_000)
    t0 = time.monotonic()
    r = _upgrade(tmp_path, demo, "--report", "r.json", outputs=("o", "r.json"), timeout=120)
    assert time.monotonic() - t0 < 120
    assert r.returncode == 0, r.stderr
    counts = json.loads((tmp_path / "r.json").read_text())["counts"]
    assert counts.get("meshed", 0) >= 20_000
    doc = written_skeleton(tmp_path / "o" / "demo.json")
    assert doc["skins"][0]["attachments"]["head"]["h19999"]["type"] == "mesh"


def test_too_many_attachments_are_refused_quickly(tmp_path, demo):
    from spinemesh.limits import MAX_ATTACHMENTS

    _json_only(demo)
    _many_regions_skeleton(demo, MAX_ATTACHMENTS + 1)
    t0 = time.monotonic()
    r = _upgrade(tmp_path, demo, memory=1536 * 1024**2, timeout=90)
    assert time.monotonic() - t0 < 90
    assert r.returncode == 3 and f"{MAX_ATTACHMENTS:,} per skeleton" in r.stderr


def test_a_million_region_atlas_is_refused_in_little_memory(tmp_path, demo):
    from spinemesh.limits import MAX_ATLAS_REGIONS

    _json_only(demo)
    with open(demo / "big.atlas", "w") as f:
        f.write("big.png\nsize: 64, 64\n")
        for i in range(1_000_000):
            f.write(f"r{i}\n  bounds: 0, 0, 4, 4\n")
    shutil.copy(demo / "demo.png", demo / "big.png")
    t0 = time.monotonic()
    r = _upgrade(tmp_path, demo, memory=1024**3, timeout=60)
    assert time.monotonic() - t0 < 60
    assert r.returncode == 3 and f"{MAX_ATLAS_REGIONS:,} regions" in r.stderr


HUGE = "9" * 401

TYPE_CASES = {
    # (mutation of demo.json, JSON path expected in the one error line, or None: the skeleton is written)
    "slot name a list": (lambda d: d["slots"][0].update(name=["a"]), "slots[0].name: expected a name, found a list"),
    "slot bone a list": (lambda d: d["slots"][3].update(bone=["root"]), "slots[3].bone: expected a name, found a list"),
    "bone parent a list": (lambda d: d["bones"][1].update(parent=["root"]), "bones[1].parent: expected a name"),
    "bone name an object": (lambda d: d["bones"][1].update(name={"a": 1}), "bones[1].name: expected a name"),
    "ik target a list": (lambda d: d.update(ik=[{"name": "k", "bones": [d["bones"][1]["name"]], "target": ["x"]}]),
                         "ik[0].target: expected a name, found a list"),
    "ik bones a name": (lambda d: d.update(ik=[{"name": "k", "bones": "root", "target": "root"}]),
                        "ik[0].bones: expected a list of names"),
    "bone x of 401 digits": (lambda d: d["bones"][0].update(x=HUGE), "bones[0].x: expected a finite number"),
    "bone y 1e300": (lambda d: d["bones"][0].update(y=1e300), "bones[0].y: expected a finite number"),
    "attachments of a slot a list": (lambda d: d["skins"][0]["attachments"].update(head=[1]),
                                     "skins[0].attachments.head: expected an object"),
    "width of 401 digits": (lambda d: _attachment(d, "head", "demo-head").update(width=HUGE), None),
    "x of 401 digits": (lambda d: _attachment(d, "head", "demo-head").update(x=HUGE), None),
    "x 1e300": (lambda d: _attachment(d, "head", "demo-head").update(x=1e300), None),
    "path a list": (lambda d: _attachment(d, "head", "demo-head").update(path=["a"]), None),
    "vertices of text": (lambda d: _attachment(d, "head", "demo-head").update(vertices=["a"]), None),
}


@pytest.mark.parametrize("case", sorted(TYPE_CASES))
@pytest.mark.parametrize("weights", ["none", "auto"])
def test_wrong_types_and_huge_numbers(tmp_path, demo, case, weights):
    """One line with the file and JSON path for the skeleton's parts; one attachment alone otherwise."""
    _json_only(demo)
    change, expected = TYPE_CASES[case]
    doc = _demo_json(demo)
    change(doc)
    # json.dumps writes a huge int as its digits: the 401-digit string becomes a number
    (demo / "demo.json").write_text(json.dumps(doc).replace(f'"{HUGE}"', HUGE))
    r = _upgrade(tmp_path, demo, "--weights", weights, "--report", "r.json", outputs=("o", "r.json"))
    assert r.returncode == 3, r.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    if expected is not None:
        line = next(e for e in report["errors"] if "demo.json" in e)
        assert expected in line, line
        assert report["skeletons_written"] == []
    else:
        assert report["skeletons_written"] == ["demo.json"]
        head = next(row for row in report["attachments"] if row["name"] == "demo-head")
        assert head["status"] == "failed" and "skins[0].attachments.head.demo-head." in head["reason"]
        assert any(row["status"] == "meshed" for row in report["attachments"])
        written = (tmp_path / "o" / "demo.json").read_text()
        assert "demo-head" in written


def test_convert_refuses_a_huge_number_naming_its_path(tmp_path, demo):
    _json_only(demo)
    doc = _demo_json(demo)
    doc["bones"][0]["x"] = 123456789
    (demo / "demo.json").write_text(json.dumps(doc).replace('"x": 123456789', '"x": ' + HUGE, 1))
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/demo.json", "out.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, ["out.skel"])
    assert r.returncode == 2 and "bones[0].x" in r.stderr


NAME_CASES = {
    "page name": lambda p: _atlas(p, "demo.png\n", "x" * 300 + ".png\n"),
    "attachment path in an images folder": lambda p: (
        (p / "demo.atlas").unlink(), (p / "demo.png").unlink(), _set(p, "head", "demo-head", path="y" * 300)),
}


@pytest.mark.parametrize("case", sorted(NAME_CASES))
def test_names_the_file_system_cannot_hold(tmp_path, demo, case):
    _json_only(demo)
    NAME_CASES[case](demo)
    r = _upgrade(tmp_path, demo, "--images", "o-images", outputs=("o", "o-images"))
    assert r.returncode in (2, 3) and "longer than a file system allows" in r.stderr


def test_report_name_too_long(tmp_path, demo):
    _json_only(demo)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--report", "r" * 300 + ".json", cwd=tmp_path)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2 and "longer than a file system allows" in r.stderr


@pytest.mark.parametrize("args", [["convert", "f.json", "out.json"], ["mesh", "g.png"], ["info", "f.json"],
                                  ["upgrade", "f.json", "--out", "o"]], ids=lambda a: a[0])
def test_fifo_as_the_file_argument(tmp_path, args):
    os.mkfifo(tmp_path / "f.json")
    os.mkfifo(tmp_path / "g.png")
    before = snapshot(tmp_path)
    r = run_cli(*args, cwd=tmp_path, timeout=30)
    check_run(r, before, tmp_path, [])
    assert r.returncode == 2


@pytest.mark.parametrize("option", ["--images", "--preview"])
def test_output_options_overlapping_out_are_refused(tmp_path, demo, option):
    _json_only(demo)
    for target in ("o", "o/sub"):
        before = snapshot(tmp_path)
        r = run_cli("upgrade", "p", "--out", "o", option, target, cwd=tmp_path)
        check_run(r, before, tmp_path, [])
        assert r.returncode == 2 and "overlaps the output folder" in r.stderr


def test_report_never_replaces_a_written_file(tmp_path, demo):
    _json_only(demo)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--report", "o/demo.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o"])
    assert r.returncode == 3 and "--report not written" in r.stderr  # the skeletons are written
    written_skeleton(tmp_path / "o" / "demo.json")


def test_newline_in_a_file_name_cannot_forge_an_error_line(tmp_path, demo):
    _json_only(demo)
    (demo / "x\nerror: forged.json").write_text('{"skeleton": {"spine": "4.2"}, "bones": 7}')
    r = _upgrade(tmp_path, demo)
    assert r.returncode == 3
    assert not any(line.startswith("error: forged") for line in r.stderr.splitlines()), r.stderr
    assert "x\\nerror: forged.json" in r.stderr


def test_a_skeleton_not_written_is_not_counted_as_meshed(tmp_path, demo):
    """The skeleton's write fails (a file-size limit, as a full disk would): nothing says it was
    meshed. Every later write would fail too, so the run stops there in one line (exit 3); a
    report, where one is written, lists no skeleton written and counts nothing meshed."""
    _json_only(demo)
    doc = _demo_json(demo)
    doc["padding"] = "x" * 200_000  # the skeleton is far larger than the report
    _write_json(demo / "demo.json", doc)
    r = _upgrade(tmp_path, demo, "--report", "r.json", outputs=("o", "r.json"), file_size=150_000)
    assert r.returncode == 3
    assert "so the run stopped" in r.stderr and r.stderr.count("error:") == 1, r.stderr
    if (tmp_path / "r.json").exists():
        report = json.loads((tmp_path / "r.json").read_text())
        assert report["skeletons_written"] == [] and "meshed" not in report["counts"]


def test_byte_order_mark_is_kept(tmp_path, demo):
    _json_only(demo)
    data = (demo / "demo.json").read_bytes()
    (demo / "demo.json").write_bytes(b"\xef\xbb\xbf" + data)
    r = _upgrade(tmp_path, demo)
    assert r.returncode == 0, r.stderr
    out = (tmp_path / "o" / "demo.json").read_bytes()
    assert out.startswith(b"\xef\xbb\xbf") and not out.startswith(b"\xef\xbb\xbf" * 2)


def test_no_worker_traceback_when_the_parent_is_killed(tmp_path, demo):
    """SIGKILL of the parent mid-run: its workers end quietly (no BrokenPipeError traceback)."""
    _library_of_demos(tmp_path, demo, 3)
    env = {**os.environ, "COLUMNS": "60", "NO_COLOR": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "spinemesh", "upgrade", "L", "--out", "o", "--jobs", "2"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + TIME_LIMIT
    while not _children(proc.pid) and proc.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    workers = _children(proc.pid)
    time.sleep(1.0)
    proc.kill()
    # stderr stays open while a worker holds it: read until every worker has ended
    _, stderr = proc.communicate(timeout=30)
    assert "Traceback" not in stderr, stderr
    deadline = time.monotonic() + 10
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not any(_alive(p) for p in workers)


def test_the_shape_check_reads_43_constraints_by_their_kind():
    """4.3 lists every constraint in one ``constraints`` list, where a field means different
    things by kind: an IK constraint's ``scaleY`` names a mode, a transform constraint's is a
    number. Each entry is checked by its ``type``."""
    from spinemesh.skeleton_check import document_problem

    ik = {"type": "ik", "name": "k", "bones": ["b"], "target": "t", "scaleY": "uniform"}
    physics = {"type": "physics", "name": "p", "bone": "b", "scaleY": "uniform"}
    assert document_problem({"constraints": [ik, physics]}) == ""
    transform = {"type": "transform", "name": "t", "bones": ["b"], "source": "s", "scaleY": [1]}
    assert document_problem({"constraints": [ik, transform]}).startswith("constraints[1].scaleY:")
