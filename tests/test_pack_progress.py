"""Packing's progress counts work known before an atlas starts (spinemesh.pack.progress): its
bar is told the whole first, moves by parts that never pass it, and ends on it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from spinemesh.images.decode import image_size
from spinemesh.pack.atlas_pack import PageRules
from spinemesh.pack.progress import COST, AtlasMeter, atlas_work, kilotexels, page_kilotexels
from spinemesh.pack.run import PackOptions, PackProgress, pack_project


class Told(PackProgress):
    """Every call in order, as ``(what, atlas, steps)``."""

    def __init__(self) -> None:
        self.said: list[tuple] = []

    def work(self, steps: int) -> None:
        self.said.append(("work", "", steps))

    def atlas(self, name: str, steps: int) -> None:
        self.said.append(("atlas", name, steps))

    def advance(self, name: str, steps: int = 1) -> None:
        self.said.append(("advance", name, steps))

    def done(self, name: str) -> None:
        self.said.append(("done", name, 0))


def _walk(said: list[tuple], name: str) -> tuple[int, int, list[int]]:
    """``(planned, done, cumulative done after each advance)`` of ``name``; asserts that work is
    only ever done on work planned before it."""
    planned = done = 0
    path = []
    for what, atlas, steps in said:
        if atlas != name:
            continue
        if what == "atlas":
            planned += steps
        elif what == "advance":
            assert steps > 0, said
            done += steps
            assert done <= planned, (done, planned, said)
            path.append(done)
    return planned, done, path


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_packed_atlas_is_told_its_whole_work_first_and_ends_on_it(meshed, tmp_path, jobs):
    told = Told()
    (row,) = pack_project(meshed, tmp_path / "out", PackOptions(jobs=jobs), progress=told).atlases
    assert row.status == "packed", row.reason
    name = row.atlas
    whole = atlas_work(page_kilotexels([image_size(p) for p in sorted(meshed.glob("*.png"))]))
    # the project's work, then the atlas's, both before any of it is done
    assert told.said[0] == ("work", "", whole) and told.said[1] == ("atlas", name, whole), told.said[:3]
    assert [s for s in told.said if s[0] == "atlas"] == [("atlas", name, whole)]  # told once, never grown
    planned, done, path = _walk(told.said, name)
    assert planned == done == whole and path == sorted(path) and len(path) > 3, path
    assert told.said[-1] == ("done", name, 0)


def test_a_kept_atlas_never_does_more_than_it_was_told(meshed, tmp_path):
    told = Told()  # no region fits a page of 16x16 texels: kept, its PNG page re-encoded
    (row,) = pack_project(meshed, tmp_path / "out", PackOptions(jobs=1, rules=PageRules("any", 16)),
                          progress=told).atlases
    assert row.status == "kept", row.reason
    planned, done, _ = _walk(told.said, row.atlas)
    whole = atlas_work(page_kilotexels([image_size(p) for p in sorted(meshed.glob("*.png"))]))
    assert planned == whole and 0 < done <= planned


def test_the_meter_hands_each_phase_out_by_weight_and_grows_only_when_a_phase_begins_again():
    calls: list[tuple] = []
    meter = AtlasMeter([100, 300], [[0], [1]], lambda done=1, planned=0, step="": calls.append((done, planned, step)))
    meter.start()
    assert calls == [(0, sum(COST.values()) * 400, "")]
    meter.begin("read", [1], "reading")
    meter.end_part()
    assert calls[1:] == [(0, 0, "reading"), (COST["read"] * 400, 0, "")]
    calls.clear()
    meter(0, 3)  # the first group's fills: its page's share of the placing, in three
    meter()
    meter()
    meter()
    meter()  # a fill more than planned: nothing
    share = COST["place"] * 100 // 3
    assert [c[0] for c in calls] == [share, share, COST["place"] * 100 - 2 * share], calls
    calls.clear()
    meter.begin("write", [3, 1])  # pages of 3:1 texels
    meter.end_part()
    meter.end_part()
    assert [c[0] for c in calls] == [COST["write"] * 300, COST["write"] * 100]
    calls.clear()
    meter.begin("write", [1], "layout 2 of 2: writing pages")  # spent: planned anew
    assert calls[:2] == [(0, 0, "layout 2 of 2: writing pages"), (0, COST["write"] * 400, "")]
    assert meter.total == sum(COST.values()) * 400 + COST["write"] * 400


def test_kilotexels_round_up_and_an_unknown_page_counts_one():
    assert kilotexels((2048, 2048)) == 4195 and kilotexels((1, 1)) == 1 and kilotexels(None) == 1


def test_upgrade_pack_tells_its_phase_the_whole_work_once(meshed, tmp_path):
    """``upgrade --pack`` shows packing on its ``pack`` phase: its total is the project's work,
    told before any is done, and the work done reaches it."""
    from spinemesh.upgrade import Options
    from spinemesh.upgrade.pack import pack_written
    from spinemesh.upgrade.progress import Progress
    from spinemesh.upgrade.report import Result

    class Phases(Progress):
        def __init__(self) -> None:
            self.said: list[tuple] = []

        def add(self, phase: str, steps: int, project: str | None = None) -> None:
            self.said.append(("atlas", phase, steps))

        def advance(self, phase: str, steps: int = 1) -> None:
            self.said.append(("advance", phase, steps))

    out = tmp_path / "written"
    shutil.copytree(meshed, out, ignore=shutil.ignore_patterns(".*"))
    phases = Phases()
    result = Result()
    pack_written(out, result, Options(jobs=1, pack=True), progress=phases)
    assert result.atlases[0].status == "packed", result.atlases[0].reason
    whole = atlas_work(page_kilotexels([image_size(p) for p in sorted(Path(meshed).glob("*.png"))]))
    assert [s for s in phases.said if s[0] == "atlas"] == [("atlas", "pack", whole)], phases.said
    planned, done, _ = _walk(phases.said, "pack")
    assert planned == done == whole
