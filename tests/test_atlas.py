"""Atlas reading and writing over every real atlas, plus malformed input."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from spinemesh.atlas import parse_atlas, read_atlas
from spinemesh.errors import AtlasError

from conftest import CORPUS, EXAMPLES

ATLASES = sorted(EXAMPLES.glob("*/*/*.atlas")) + sorted(CORPUS.glob("**/*.atlas*"))


@pytest.fixture(scope="module", params=[p for p in ATLASES], ids=lambda p: str(p.relative_to(p.parents[2])))
def atlas_file(request, examples) -> Path:
    return request.param


def test_every_example_atlas_exists(examples):
    assert len(list(examples.glob("*/*/*.atlas"))) >= 90


def test_parse_write_parse_is_identical(atlas_file):
    atlas = read_atlas(atlas_file)
    text = atlas.dumps()
    again = parse_atlas(text, atlas_file)
    assert again.model() == atlas.model()
    # Written in the syntax it came in, line for line.
    original = atlas_file.read_text(encoding="utf-8-sig").replace("\r\n", "\n")
    assert text.strip("\n") == original.strip("\n")


def test_region_count_and_geometry_match_the_text(atlas_file):
    """Count region names and read their numbers straight from the text, independently."""
    text = atlas_file.read_text(encoding="utf-8-sig").replace("\r\n", "\n")
    atlas = read_atlas(atlas_file)
    # A region is a name line followed by a geometry line. A page's name line opens the file
    # or follows a blank line (the libGDX rule); a region may carry a page's name
    # (purattokun/nezumi has a region "nezumi.png"), so pages are told apart by position.
    lines = text.split("\n")
    geometry = re.compile(r"[ \t]*(?:bounds|rotate|xy|index|offsets|offset|orig|split|pad)\s*:")
    names = [line for i, line in enumerate(lines[:-1])
             if line.strip() and ":" not in line and geometry.match(lines[i + 1])
             and i > 0 and lines[i - 1].strip()]
    assert len(names) == len(atlas.regions)
    for region in atlas.regions:
        g = region.geometry()
        block = text.split("\n")[region.line - 1:region.line + 12]
        body = "\n".join(block[1:])
        m = re.search(r"bounds\s*:\s*(\d+)\s*,\s*(\d+)\s*,\s*(\d+)\s*,\s*(\d+)", body)
        if m:
            assert (g.x, g.y, g.width, g.height) == tuple(map(int, m.groups()))
        else:
            xy = re.search(r"xy\s*:\s*(\d+)\s*,\s*(\d+)", body)
            size = re.search(r"size\s*:\s*(\d+)\s*,\s*(\d+)", body)
            assert (g.x, g.y, g.width, g.height) == tuple(map(int, xy.groups() + size.groups()))


def test_syntax_is_detected(examples):
    assert read_atlas(examples / "3.8/spineboy/spineboy.atlas").syntax == "3"
    v4 = read_atlas(examples / "4.2/spineboy/spineboy-pma.atlas")
    assert v4.syntax == "4"
    assert v4.pages[0].pma and v4.pages[0].scale == 0.5


def test_3x_geometry_fields():
    text = ("\npage.png\nsize: 64,64\nformat: RGBA8888\nfilter: Linear,Linear\nrepeat: none\n"
            "a\n  rotate: true\n  xy: 2, 3\n  size: 10, 20\n  split: 1, 2, 3, 4\n  pad: 0, 0, 0, 0\n"
            "  orig: 14, 26\n  offset: 1, 2\n  index: 5\n")
    atlas = parse_atlas(text)
    g = atlas.regions[0].geometry()
    assert (g.x, g.y, g.width, g.height, g.degrees) == (2, 3, 10, 20, 90)
    assert (g.offset_x, g.offset_y, g.original_width, g.original_height) == (1, 2, 14, 26)
    assert (g.page_width, g.page_height) == (20, 10)
    assert atlas.regions[0].index == 5
    assert atlas.regions[0].get("split") == ["1", "2", "3", "4"]
    assert atlas.dumps() == text


def test_4x_fields_in_any_order_and_unknown_keys_kept():
    text = ("p.png\n\tscale: 0.5\n\tsize: 8, 8\n\tpma: true\n\tcustom: hello\n"
            "r\n\toffsets: 1, 1, 6, 6\n\trotate: 270\n\tbounds: 0, 0, 4, 3\n\tmyfield: 7, 8\n")
    atlas = parse_atlas(text)
    g = atlas.regions[0].geometry()
    assert (g.x, g.y, g.width, g.height, g.degrees) == (0, 0, 4, 3, 270)
    assert atlas.pages[0].pma and atlas.pages[0].scale == 0.5
    assert atlas.pages[0].get("custom") == ["hello"]
    assert atlas.regions[0].get("myfield") == ["7", "8"]
    assert atlas.dumps() == text


def test_multiple_pages_and_sub_folders():
    text = "sub/a.png\nsize: 4,4\nr1\n  bounds: 0,0,1,1\n\nsub/b.png\nsize: 4,4\nr2\n  bounds: 1,1,2,2\n"
    atlas = parse_atlas(text)
    assert [p.name for p in atlas.pages] == ["sub/a.png", "sub/b.png"]
    assert [(r.name, r.page) for r in atlas.regions] == [("r1", 0), ("r2", 1)]


@pytest.mark.parametrize("text, line, words", [
    ("p.png\nsize: 4,4\nr\n  bounds: 0, zero, 1, 1\n", 3, "whole numbers"),
    ("p.png\nsize: 4,4\nr\n  bounds: 0, 0\n", 3, "needs 4 numbers"),
    ("p.png\nsize: 4,4\nr\n  rotate: sideways\n  bounds: 0,0,1,1\n", 3, "rotate"),
    ("", None, "no atlas pages"),
])
def test_malformed_atlas_names_file_and_line(tmp_path, text, line, words):
    f = tmp_path / "bad.atlas"
    f.write_text(text)
    with pytest.raises(AtlasError) as e:
        read_atlas(f)
    assert "bad.atlas" in str(e.value) and words in str(e.value)
    assert e.value.line == line


def test_truncated_real_atlas_is_a_clear_error(tmp_path, examples):
    text = (examples / "4.2/spineboy/spineboy.atlas").read_text()
    cut = text[: text.index("bounds:", 200) + 12]  # ends inside a bounds: line
    f = tmp_path / "cut.atlas"
    f.write_text(cut)
    with pytest.raises(AtlasError) as e:
        read_atlas(f)
    assert e.value.line and "cut.atlas" in str(e.value)
