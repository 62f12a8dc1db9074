"""benchmarks/bench_corpus_upgrade.py ``sweep``: every defect kind it reports is found in an
output made to have it, and none in a good one (the demo project, made by our own code)."""

from __future__ import annotations

import json
import shutil
import sys

import pytest
from conftest import REPO

from spinemesh.atlas import read_atlas
from spinemesh.demo import make_demo_project

sys.path.insert(0, str(REPO / "benchmarks"))

import bench_corpus_upgrade as bench


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The demo project, and ``spinemesh pack`` of it run by the sweep (no runtime): ``(project,
    entry, output folder)``; the output is kept in a copy for the negative controls."""
    base = tmp_path_factory.mktemp("sweep")
    project = make_demo_project(base / "demo", with_images_folder=False)
    scratch = base / "scratch"
    scratch.mkdir()
    entry = bench.sweep_one(project, "pack", 120, None, scratch)
    shutil.copytree(scratch / "out", base / "out")
    return project, entry, base / "out"


def _defects(project, out, tmp_path) -> list[str]:
    return bench.sweep_defects({"rc": 0, "traceback": False, **bench.check_output(project, out, None, tmp_path)})


def test_a_good_output_has_no_defect(swept):
    _, entry, _ = swept
    assert entry["rc"] == 0, entry["tail"]
    assert bench.sweep_defects(entry) == []
    assert set(entry["atlases"]) == {"demo.atlas"}
    before, after = entry["atlases"]["demo.atlas"]
    assert 0 < after <= before


@pytest.mark.parametrize("harm, defect", [
    ("drop a page", "files missing"),
    ("drop a skeleton", "files missing"),
    ("NaN in the skeleton", "NaN/Infinity written"),
    ("skeleton cut short", "unreadable output"),
    ("page grown", "atlas more bytes"),
])
def test_each_harm_is_found(swept, tmp_path, harm, defect):
    project, _, good = swept
    out = tmp_path / "out"
    shutil.copytree(good, out)
    page = out / read_atlas(out / "demo.atlas").pages[0].name
    if harm == "drop a page":
        page.unlink()
    elif harm == "drop a skeleton":
        (out / "demo-binary.skel").unlink()
    elif harm == "NaN in the skeleton":
        doc = json.loads((out / "demo.json").read_text())
        doc["bones"][0]["x"] = float("nan")
        (out / "demo.json").write_text(json.dumps(doc))
    elif harm == "skeleton cut short":
        text = (out / "demo.json").read_text()
        (out / "demo.json").write_text(text[: len(text) // 2])
    else:
        grown = (project / page.name).stat().st_size + 1
        page.write_bytes(page.read_bytes() + b"\0" * (grown - page.stat().st_size))
    assert defect in _defects(project, out, tmp_path / "work")


def test_exits_and_tracebacks_are_defects():
    assert bench.sweep_defects({"rc": None, "traceback": False}) == ["timed out"]
    assert bench.sweep_defects({"rc": 1, "traceback": True}) == ["exit 1", "traceback"]
    assert bench.sweep_defects({"rc": 3, "traceback": False}) == []


def test_the_runtime_loads_a_good_output_and_names_what_it_cannot_load(swept, spine_runtime, tmp_path):
    project, _, good = swept
    tools = {"harness": spine_runtime}
    assert bench.check_output(project, good, tools, tmp_path / "a")["runtime"] == {"demo.json": "ok",
                                                                                "demo-binary.skel": "ok"}
    out = tmp_path / "out"
    shutil.copytree(good, out)
    atlas = read_atlas(out / "demo.atlas")
    gone = atlas.regions[0].name
    atlas.regions = atlas.regions[1:]
    (out / "demo.atlas").write_text(atlas.dumps())
    for said in bench.check_output(project, out, tools, tmp_path / "b")["runtime"].values():
        assert said.startswith("Error") and gone in said, said


def test_options_reach_both_commands(swept, tmp_path):
    """``--option``: an unknown option is refused by the command (exit 2), so it was passed."""
    project, _, _ = swept
    for command in bench.SWEEP_COMMANDS:
        scratch = tmp_path / command.replace(" ", "")
        scratch.mkdir()
        entry = bench.sweep_one(project, command, 120, None, scratch, ("--pages", "any"))
        assert entry["rc"] == 0 and bench.sweep_defects(entry) == [], entry["tail"]
        scratch = tmp_path / (command.replace(" ", "") + "-bad")
        scratch.mkdir()
        assert bench.sweep_one(project, command, 120, None, scratch, ("--pages", "round"))["rc"] == 2
