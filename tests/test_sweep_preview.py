"""scripts/sweep_preview.py: the demo project (made by our own code) through ``upgrade --preview``
as the sweep runs it, its page opened in headless Chromium, and every defect kind it reports
found in a row made to have it. Needs Chromium: skipped when it is absent, a failure in CI."""

from __future__ import annotations

import sys

import pytest
from conftest import REPO

from spinemesh.demo import make_demo_project

sys.path.insert(0, str(REPO / "scripts"))

import sweep_preview as sweep


@pytest.fixture(scope="module")
def row(tmp_path_factory):
    from browser import chromium

    chromium()
    project = make_demo_project(tmp_path_factory.mktemp("sweep") / "demo")
    return sweep.sweep_one(project, timeout=300, at=0.5)


def test_a_good_project_is_swept_without_a_defect(row):
    assert row["rc"] == 0 and not row["traceback"] and not row["errors"], row
    assert row["upgrade_s"] > 0 and row["preview_s"] > 0
    assert row["pages"] == 1 and not row["problems"] and not row["notes"] and not row["no_player"]
    assert row["largest_page"][1].startswith("s/") and row["largest_script"][1].startswith("data/")
    (page,) = row["browser"].values()  # the demo's .json and .skel: one skeleton, one page
    assert not page["errors"] and min(page["visible"]) > 2000 and min(page["seen"]) > 2000, page
    assert min(page["frames_differ"]) > 1, page  # the player seeks: its frames change
    assert sweep.defects(row) == []


@pytest.mark.parametrize("change, kind", [
    ({"rc": None}, "timed out"),
    ({"rc": 1}, "exit 1"),
    ({"traceback": True}, "traceback"),
    ({"preview_s": None}, "no preview"),
    ({"problems": ["demo: animation 'walk' not shown: ..."]}, "preview problem line"),
    ({"notes": ["demo: Not as a game shows it: ..."]}, "'not as a game shows it' note"),
    ({"no_player": ["demo"]}, "page without player"),
    ({"page": {"errors": ["Uncaught TypeError"]}}, "page error"),
    ({"page": {"seeking": "chromium did not end"}}, "no test result"),
    ({"page": {"visible": [0, 0], "seen": [0, 0], "setup_visible": [0, 0]}}, "blank canvas"),
    ({"page": {"seen": [5000, 2000]}}, "the sides draw unlike areas"),
    ({"page": {"frames_differ": [1, 1]}}, "frames all alike"),
])
def test_each_defect_kind_is_found_in_a_row_made_to_have_it(row, change, kind):
    made = {**row, **{k: v for k, v in change.items() if k != "page"}}
    if "page" in change:
        made["browser"] = {name: {**page, **change["page"]} for name, page in row["browser"].items()}
    assert sweep.defects(made) == [kind]


def test_a_blank_animation_whose_setup_pose_draws_is_no_defect(row):
    blank = {"visible": [0, 0], "seen": [0, 0], "setup_visible": [9000, 9000]}
    assert sweep.defects({**row, "browser": {k: {**p, **blank} for k, p in row["browser"].items()}}) == []


def test_what_the_player_says_of_its_own_limits_is_no_defect(row):
    told = {"problems": ["hero: skins a, b, c, d, e not offered alone: the player offers at most 4 skins, those "
                         "that dress the setup pose first"],
            "notes": ["hero: Nothing to see in the setup pose: no slot shows an attachment ...",
                      "hero: Shown at 9.5 frames a second, not 30, to keep the preview small ..."]}
    assert sweep.defects({**row, **told}) == []
    told["notes"].append("hero: Not as a game shows it: bone ...")
    assert sweep.defects({**row, **told}) == ["'not as a game shows it' note"]
