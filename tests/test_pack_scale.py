"""Packing at scale: side by side on workers (the same pages as one after another), progress, page
rules, and the placement's shortcuts giving the same placements as without them."""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

import numpy as np
import pytest

from spinemesh.atlas import read_atlas
from spinemesh.demo import make_demo_project
from spinemesh.pack import place
from spinemesh.pack.atlas_pack import PageRules, is_power_of_two
from spinemesh.pack.run import PackOptions, PackProgress, pack_library, pack_project
from spinemesh.upgrade import Options, upgrade_project


def _digest(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and not p.name.startswith(".")}


class Recorder(PackProgress):
    def __init__(self) -> None:
        self.planned: dict[str, int] = {}
        self.advanced: dict[str, int] = {}
        self.done_names: list[str] = []
        self.steps: dict[str, list[str]] = {}

    def step(self, name: str, what: str) -> None:
        self.steps.setdefault(name, []).append(what)

    def atlas(self, name: str, steps: int) -> None:
        self.planned[name] = self.planned.get(name, 0) + steps

    def advance(self, name: str, steps: int = 1) -> None:
        self.advanced[name] = self.advanced.get(name, 0) + steps

    def done(self, name: str) -> None:
        self.done_names.append(name)


def test_fills_and_pages_on_workers_write_what_one_process_writes(meshed, tmp_path):
    one, progress = Recorder(), Recorder()
    a = pack_project(meshed, tmp_path / "one", PackOptions(jobs=1), progress=one)
    b = pack_project(meshed, tmp_path / "two", PackOptions(jobs=2), progress=progress)
    assert a.atlases[0].status == b.atlases[0].status == "packed"
    assert _digest(tmp_path / "one") == _digest(tmp_path / "two")
    # one bar per atlas: every fill tried and every page written is a step, and all of them end
    (name,) = one.planned
    pages = a.atlases[0].pages_after
    assert one.planned[name] == one.advanced[name] > pages and one.done_names == [name]
    assert progress.planned == one.planned and progress.advanced == one.advanced
    # each bar says what its atlas is doing, in order: the demo's page is a power of two, so
    # whole page sizes are tried with the placements
    assert one.steps[name] == ["reading pages", "placing regions, trying page sizes", "writing pages",
                               "proving"], one.steps
    assert progress.steps == one.steps
    free = Recorder()
    pack_project(meshed, tmp_path / "any", PackOptions(jobs=1, rules=PageRules("any")), progress=free)
    assert free.steps[name][1] == "placing regions", free.steps


def test_atlases_side_by_side_write_what_one_process_writes(meshed, tmp_path):
    import shutil

    library = tmp_path / "library"
    for name in ("a", "b", "c"):  # a project of three atlases (each its own copy of the pages)
        project = library / name
        shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    project = tmp_path / "three"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    for n in (2, 3):
        sub = project / f"copy{n}"
        sub.mkdir()
        for f in meshed.iterdir():
            if f.suffix in (".atlas", ".png"):
                shutil.copy(f, sub / f.name)
    progress = Recorder()
    a = pack_project(project, tmp_path / "one", PackOptions(jobs=1))
    b = pack_project(project, tmp_path / "two", PackOptions(jobs=2), progress=progress)
    assert [r.atlas for r in a.atlases] == [r.atlas for r in b.atlases] and len(a.atlases) == 3
    assert [r.status for r in b.atlases] == ["packed"] * 3
    assert _digest(tmp_path / "one") == _digest(tmp_path / "two")
    assert sorted(progress.done_names) == sorted(r.atlas for r in b.atlases)
    # a whole atlas packed on a worker tells nothing on the way: its bar says so
    assert progress.steps == {r.atlas: ["packing on a worker"] for r in b.atlases}, progress.steps
    lib = pack_library(library, tmp_path / "lib", PackOptions(jobs=2))
    assert [r.status for r in lib.atlases] == ["packed"] * 3


def _boxes(seed: int, count: int) -> list:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        h, w = (int(v) for v in rng.integers(4, 60, 2))
        m = np.ones((h, w), bool)
        out.append([m, np.ascontiguousarray(m.T)])
    return out


@pytest.mark.parametrize("tight", [False, True])
def test_boxes_passed_over_are_those_that_would_find_no_place(tight, monkeypatch):
    """The fill passes over a solid box no smaller than one that found no place: the very placements
    of a fill that tries every box."""
    boxes = _boxes(7, 160)
    fast = place.fill_pages(boxes, 256, 256, 2, tight=tight, pot=tight)
    monkeypatch.setattr(place, "_solid_boxes", lambda masks, hards: None)
    slow = place.fill_pages(boxes, 256, 256, 2, tight=tight, pot=tight)
    assert len(fast[1]) > 1 and fast == slow


def test_page_rules(meshed, tmp_path):
    original = pack_project(meshed, tmp_path / "original").atlases[0]
    free = pack_project(meshed, tmp_path / "any", PackOptions(rules=PageRules("any"))).atlases[0]
    assert original.status == free.status == "packed"
    assert free.texels_after <= original.texels_after
    capped = pack_project(meshed, tmp_path / "cap", PackOptions(rules=PageRules("any", 64)))
    assert capped.atlases[0].status == "kept" and "more than the largest page allowed (64x64" in \
        capped.atlases[0].reason
    pot = pack_project(meshed, tmp_path / "pot", PackOptions(rules=PageRules("power-of-two"))).atlases[0]
    for folder in ("original", "pot"):
        for page in read_atlas(tmp_path / folder / "demo.atlas").pages:
            assert all(is_power_of_two(int(v)) for v in page.get("size"))
    assert PageRules("power-of-two").limits([(1723, 1719), (500, 300)]) == (1024, 1024 * 1024, True)
    assert PageRules("any").limits([(1024, 512), (256, 256)]) == (1024, 1024 * 512, False)
    assert PageRules("original", 4096).limits([(1024, 512)]) == (4096, 4096 * 4096, True)
    assert pot.status in ("packed", "kept")
    four = pack_project(meshed, tmp_path / "four", PackOptions(rules=PageRules("multiple-of-4"))).atlases[0]
    assert four.status == "packed" and free.texels_after <= four.texels_after
    for page in read_atlas(tmp_path / "four" / "demo.atlas").pages:
        assert all(int(v) % 4 == 0 for v in page.get("size"))
    assert PageRules("multiple-of-4").limits([(1723, 1719)]) == (1720, 1723 * 1719, False)


def test_upgrade_pack_timings_add_up(monkeypatch, tmp_path):
    """The pack stage has its own timing line, not counted in write's."""
    from spinemesh.pack import run

    real = run.pack_project_into

    def slow(*args, **kwargs):
        time.sleep(2.0)
        return real(*args, **kwargs)

    monkeypatch.setattr(run, "pack_project_into", slow)
    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    result = upgrade_project(demo, tmp_path / "out", Options(min_saving=None, jobs=1, pack=True))
    assert result.seconds["pack"] >= 2.0 and result.seconds["write"] < 2.0, result.seconds


def test_measured_padding_block_by_block_is_every_pair(monkeypatch):
    from spinemesh.atlas import RegionGeometry
    from spinemesh.pack import atlas_pack

    rng = np.random.default_rng(3)
    geometries = [RegionGeometry(int(x), int(y), int(w), int(h), 0, 0, int(w), int(h), 0)
                  for x, y, w, h in zip(*(rng.integers(0, 400, 50), rng.integers(0, 400, 50),
                                          rng.integers(3, 30, 50), rng.integers(3, 30, 50)))]
    whole = atlas_pack.measured_padding(geometries)
    monkeypatch.setattr(atlas_pack, "PADDING_BLOCK", 3)
    assert atlas_pack.measured_padding(geometries) == whole
    assert atlas_pack.measured_padding(geometries[:2] + [RegionGeometry(500, 0, 10, 10, 0, 0, 10, 10, 0)]) >= 0


def test_fill_counts_the_texels_under_footprints_once(meshed, tmp_path):
    from spinemesh.images.decode import load_rgba
    from spinemesh.images.sources import AtlasImages
    from spinemesh.pack.atlas_pack import pack_atlas
    from spinemesh.pack.uses import collect_uses
    from spinemesh.project import find_project, project_atlases

    proj = find_project(meshed)
    uses = collect_uses(proj)
    (path, atlas), = project_atlases(proj).items()
    pixels = [load_rgba(AtlasImages.page_path(atlas, p.name, proj.root)) for p in atlas.pages]
    packed = pack_atlas(atlas, pixels, uses.regions.get(path, {}))
    drawn = sum(int(p.any(axis=2).sum()) for p in packed.pages.values())
    # every texel written lies under a footprint; footprints hold more (their ring), never the whole page
    assert drawn <= packed.footprint_texels < packed.texels_after


@pytest.mark.parametrize("option", [["--pages", "round"], ["--max-page", "8"], ["--max-page", "x"], ["--jobs", "0"]])
def test_bad_page_rules_are_refused_in_one_line(meshed, tmp_path, option):
    import os
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "spinemesh", "pack", str(meshed), "--out", str(tmp_path / "o"), *option],
                       capture_output=True, text=True, env=dict(os.environ, COLUMNS="200"))
    assert r.returncode == 2 and "Traceback" not in r.stderr and option[0] in r.stderr, r.stderr
    assert not (tmp_path / "o").exists()


def _shapes(seed: int, count: int, soft: bool) -> tuple[list, list]:
    """Footprints made here: polygons of 7 to 12 corners in boxes of 12-70 texels, each in its two
    quarter turns; with ``soft``, every other one has a soft outer ring (its hard part eroded)."""
    import cv2

    rng = np.random.default_rng(seed)
    masks, hards = [], []
    for n in range(count):
        h, w = (int(v) for v in rng.integers(12, 70, 2))
        corners = int(rng.integers(7, 13))
        angles = np.sort(rng.uniform(0, 2 * np.pi, corners))
        radii = rng.uniform(0.5, 1.0, corners)
        pts = np.stack([(w - 1) / 2 * (1 + radii * np.cos(angles)), (h - 1) / 2 * (1 + radii * np.sin(angles))], 1)
        m = np.zeros((h, w), np.uint8)
        cv2.fillPoly(m, [np.round(pts).astype(np.int32)], 1)
        m = m.astype(bool)
        hard = cv2.erode(m.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool) if soft and n % 2 else m
        if not hard.any():
            hard = m
        masks.append([m, np.ascontiguousarray(np.rot90(m))])
        hards.append([hard, np.ascontiguousarray(np.rot90(hard))] if hard is not m else masks[-1])
    return masks, hards


def test_least_share_is_a_lower_bound_exact_for_boxes():
    """A footprint's hard texels grown by half the padding take at least :func:`place.least_share`
    texels, in every quarter turn; a box takes exactly that."""
    _, hards = _shapes(3, 40, soft=True)
    for reach in (0, 1, 5, 17):
        for hs in hards:
            for h in hs:
                grown = int(place._grow(h, reach).sum())
                assert place.least_share(h, reach) <= grown
                assert place.least_share(h, reach) == place.least_share(np.rot90(h), reach)
        box = np.ones((9, 23), bool)
        assert place.least_share(box, reach) == int(place._grow(box, reach).sum())


@pytest.mark.parametrize("soft", [False, True])
def test_fills_stopped_by_the_pages_left_find_what_full_fills_find(soft, monkeypatch):
    """A fill that stops once the footprints left cannot go on the pages left (however placed) keeps
    the very placements of one that fills page after page: every page size, both placements, and
    the plan's fills of a group of several pages; and it does stop some fills early."""
    from spinemesh.pack.atlas_pack import fill_plan, run_fill

    masks, hards = _shapes(11, 90, soft)
    hard = hards if soft else None
    padding, max_pages = 12, 6
    sizes = [(128, 128), (256, 128), (128, 256), (256, 256), (512, 256), (512, 512)]
    pages_opened = []

    def fills(bounded: bool):
        if not bounded:
            monkeypatch.setattr(place, "least_share", lambda h, reach: 0)
        out = []
        for w, h in sizes:
            for tight in (False, True):
                placements, used = place.fill_pages(masks, w, h, padding, max_pages=max_pages, tight=tight,
                                                    pot=True, hard=hard)
                pages_opened.append((bounded, len(used)))
                out.append(placements if all(placements) else None)  # a fill that fails: its pages are of no use
        limits = (512, 512, 512 * 512, True, padding, max_pages)
        out += [run_fill(fill, masks, hard, *limits, None) for fill in fill_plan(True, soft, max_pages)]
        monkeypatch.undo()
        return out

    bounded, full = fills(True), fills(False)
    assert bounded == full
    assert any(p is not None for p in bounded) and any(p is None for p in bounded)  # some fit, some do not
    opened = {b: sum(n for bb, n in pages_opened if bb == b) for b in (True, False)}
    assert opened[True] < opened[False]  # the bound spared pages


@pytest.mark.parametrize("padding", [12, 20])
def test_surely_taken_only_where_no_texel_finds_room(padding):
    """Wherever the full-cell grid proves a footprint finds no place on a page, no top-left texel
    (searched texel by texel) keeps its hard texels off the taken ones; and it proves some."""
    import cv2

    masks, hards = _shapes(5, 160, soft=True)  # placed by the masks, tried by their hard parts
    proved = 0
    for width, height in ((512, 512), (1024, 256)):
        page = place.Page(width, height, padding)
        for ms, hs in zip(masks, hards):  # fill the page as the first fit does
            at = page.first_fit(ms[0], hs[0])
            if at is not None:
                page.take(ms[0], *at, (ms[0].shape[1], ms[0].shape[0]), hs[0])
        taken = page.taken.astype(np.float32)
        for hs in hards:
            for h in hs:
                last_x, last_y = page.width - h.shape[1], page.height - h.shape[0]
                if not page._surely_taken(h, last_x, last_y):
                    continue
                proved += 1
                scores = cv2.matchTemplate(taken, h.astype(np.float32), cv2.TM_CCORR)
                assert (scores >= 0.5).all()
    assert proved > 20


@pytest.mark.parametrize("soft", [False, True])
def test_fills_with_places_proved_taken_find_what_full_searches_find(soft, monkeypatch):
    """Every fill of the plan, with footprints passed over where the full-cell grid proves them no
    place, keeps the very placements of fills that search every page in full."""
    from spinemesh.pack.atlas_pack import fill_plan, run_fill

    masks, hards = _shapes(13, 80, soft)
    hard = hards if soft else None
    proved = []
    real = place.Page._surely_taken

    def counted(self, *args):
        found = real(self, *args)
        proved.append(found)
        return found

    results = {}
    for on in (True, False):
        monkeypatch.setattr(place.Page, "_surely_taken", counted if on else lambda self, *args: False)
        for pot in (True, False):
            limits = (512, 512, 512 * 512, pot, 6, 4)
            results[on, pot] = [run_fill(fill, masks, hard, *limits, None) for fill in fill_plan(pot, soft, 4)]
    assert results[True, True] == results[False, True] and results[True, False] == results[False, False]
    assert sum(proved) > 20


class _ThreadWorkers:
    """Two threads standing for two worker processes, noting the bound each fill is handed."""

    slots = 2

    def __init__(self) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self.pool = ThreadPoolExecutor(2)
        self.bounds: list = []

    def submit(self, fn, arg, first=False):
        self.bounds.append(arg[3])
        return self.pool.submit(fn, arg)

    def as_completed(self, futures):
        from concurrent.futures import as_completed

        return as_completed(futures)


@pytest.mark.parametrize("soft, pot, pages", [(False, False, 1), (True, False, 2), (True, True, 3)])
def test_fills_side_by_side_bounded_by_those_before_keep_the_same_layouts(soft, pot, pages):
    """Fills run two at a time, each bounded by the best of the fills before it that ended, keep the
    very layouts (the best and those kept besides it) that the fills one after another keep; and
    fills are bounded below the atlas's own texels (by what an earlier fill found)."""
    from types import SimpleNamespace

    from spinemesh.pack.atlas_pack import group_layouts
    from spinemesh.pack.parallel import FillRunner

    masks, hards = _shapes(17, 30, soft)
    items = [SimpleNamespace(masks=m, hard_masks=h) for m, h in zip(masks, hards)]
    ceiling = pages * 256 * 256
    limits = (256, 256, 256 * 256, pot, 6, pages, ceiling)
    one = group_layouts(items, *limits)
    workers = _ThreadWorkers()
    ends = []
    two = group_layouts(items, *limits, fills=FillRunner(workers, lambda: ends.append(1)))
    assert two == one and len(one) > 1
    assert len(ends) == len(workers.bounds) > 2
    assert workers.bounds[:2] == [(ceiling, None, None)] * 2  # the first two start side by side
    assert min(b[0] for b in workers.bounds) < ceiling


@pytest.mark.parametrize("seed, count, soft, pages", [(1, 25, False, 2), (0, 40, True, 4)])
def test_fills_all_at_once_keep_the_layouts_of_fills_one_after_another(seed, count, soft, pages):
    """With as many workers as fills, every fill starts bounded by the atlas's own texels only: the
    fills whose result depends on their bound (whole power-of-two sizes chosen below it) are run
    again with the bound the fills before them give, so the layouts are those of one process (on
    these footprints, the loosely bounded results alone keep other layouts)."""
    from types import SimpleNamespace

    from spinemesh.pack.atlas_pack import group_layouts, run_fill
    from spinemesh.pack.parallel import FillRunner

    masks, hards = _shapes(seed, count, soft)
    items = [SimpleNamespace(masks=m, hard_masks=h) for m, h in zip(masks, hards)]
    ceiling = pages * 256 * 256
    limits = (256, 256, 256 * 256, True, 6, pages, ceiling)
    one = group_layouts(items, *limits)
    workers = _ThreadWorkers()
    workers.slots = 64
    everywhere = group_layouts(items, *limits, fills=FillRunner(workers))
    assert everywhere == one
    assert set(workers.bounds) == {(ceiling, None, None)}  # all started at once

    def loose(plan, args, best):  # the same fills, none run again
        return [run_fill(fill, *args, best) for fill in plan]

    assert group_layouts(items, *limits, fills=loose) != one
