"""benchmarks/bench_pack.py: what limits an atlas, read from the reasons ``pack`` gives."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import REPO
from PIL import Image

from spinemesh.pack.atlas_pack import PackRefused, kept_note
from spinemesh.pack.checks import check_bytes_shrink, check_lossy_pages_shrink
from spinemesh.pack.run import next_layout_reason

sys.path.insert(0, str(REPO / "benchmarks"))

import bench_pack


def _refusal(check, *args) -> str:
    with pytest.raises(PackRefused) as refused:
        check(*args)
    return str(refused.value)


def test_limits_are_read_from_the_reasons_pack_gives(tmp_path):
    page = tmp_path / "page.webp"
    Image.fromarray(np.random.default_rng(0).integers(0, 255, (64, 64, 4), np.uint8)).save(page, quality=50)
    lossy = _refusal(check_lossy_pages_shrink, [page], 100, 200)
    grows = _refusal(check_bytes_shrink, 100, 200, 1000, 800)
    cases = {
        "": "placement: packed, 81% full",
        lossy: "bytes: lossy WebP pages would grow written losslessly",
        grows: "bytes: the files would grow",
        grows + "; written as it was, with the rectangles' texels only":
            "bytes: written as it was, with the rectangles' texels only",
        next_layout_reason((800, 210), 200, (850, 190)): "bytes: packed in the next layout of fewer bytes, 81% full",
        kept_note(120, 100, 1, 100, False): "need: the footprints need 120% of the page texels",
        kept_note(90, 100, 1, 40, False): "page rule: the pages the rules allow hold less than the footprints need",
        kept_note(90, 100, 1, 100, False):
            "placement: the footprints need 90% of the page texels, no fill placed them on fewer",
        kept_note(61 * 1024 * 512 // 100 + 1, 1024 * 512, 1, 1024 * 1024, True):
            "page rule: the footprints need 61% of the page texels; the next smaller power-of-two page holds 50%",
    }
    for reason, limit in cases.items():
        assert bench_pack.limit_of(reason, 0.81) == limit, reason


def test_the_limits_table_counts_atlases_by_what_limits_them():
    rows = [bench_pack.Row("corpus/p", "a.atlas", texels=1000, b_texels=800, b_footprints=640, b_reason=""),
            bench_pack.Row("corpus/p", "b.atlas", texels=1000, b_texels=1000, b_footprints=0,
                           b_reason=kept_note(990, 1000, 1, 1000, False)),
            bench_pack.Row("corpus/q", "c.atlas", texels=400,
                           rules={"any": {"b": [300, 1, 10, 270, ""]}})]
    table = bench_pack.limits_table(rows, "original")
    assert "| p | a.atlas | 1,000 | 20.0% | placement: packed, 80% full |" in table
    assert table.endswith("atlases by what limits them: placement 2")
    gap = [{"project": "q", "atlas": "c.atlas", "before": 400, "kept": 100, "outline": 160, "reached": 280}]
    table = bench_pack.limits_table(rows, "any", gap)
    assert "| q | c.atlas | 400 | 25.0% | 65% | 30.0% | placement: packed, 90% full |" in table


def test_oxipng_levels_and_calls_are_measured_as_pack_encodes(tmp_path):
    """``bench_pack.py --png-levels`` runs the very encodes ``pack`` runs (a page written from its
    texels, a kept page re-encoded), at the level asked; ``bench_pack_scale.py --oxipng-threads``
    reads its log of oxipng calls into seconds summed, wall seconds covered and calls at once."""
    import bench_pack_scale

    from spinemesh.demo import make_demo_project
    from spinemesh.pack import png

    project = make_demo_project(tmp_path / "demo")
    pages = bench_pack.png_level_pages([project])
    assert [p.name for p in pages] == ["demo.png"]
    level, compress = png.LEVEL, png._compress
    rows = {n: bench_pack.png_level_child([str(p) for p in pages], n) for n in (1, 2)}
    assert png.LEVEL == level and png._compress is compress  # pack's own encoder as it was
    for n, (row,) in rows.items():
        assert row["texels"] == 512 * 256 and row["kept"][0] <= row["export"], (n, row)
        assert row["packed"][2] > 0, (n, row)  # oxipng ran, and was timed
    log = tmp_path / "calls"
    log.write_text("10 0 2\n10 5 6\n11 1 3\n")
    assert bench_pack_scale.oxipng_calls(log) == {"calls": 3, "sum": 5.0, "wall": 4.0, "at_once": 2, "processes": 2}
    assert bench_pack_scale.oxipng_calls(tmp_path / "none")["calls"] == 0
