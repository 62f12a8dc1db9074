"""Packed pages say what their original pages say of their colours (gamma, sRGB, colour profile).

Fixtures are the demo project (made and upgraded by our own code) with colour chunks written
into its page here; the corpus check uses the corpus atlases whose pages have such chunks.
"""

from __future__ import annotations

import io
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import CORPUS, unavailable

from spinemesh.images.decode import load_rgba
from spinemesh.pack import page_files
from spinemesh.pack.atlas_pack import PackRefused
from spinemesh.pack.page_colours import colours_by_settings, packed_page_colours, page_colour
from spinemesh.pack.png import (
    chunk_differences,
    colour_chunks,
    png_chunk,
    png_chunks,
    png_differences,
    with_colour_chunks,
)
from spinemesh.pack.run import PackOptions, pack_project


def _profile() -> bytes:
    from PIL import ImageCms

    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


GAMMA = (b"gAMA", struct.pack(">I", 45455))
SRGB = (b"sRGB", b"\x00")
CHRM = (b"cHRM", struct.pack(">8I", 31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000))


def _iccp() -> tuple[bytes, bytes]:
    return (b"iCCP", b"exported profile\0\0" + zlib.compress(_profile(), 9))


def _copy(src: Path, dest: Path) -> Path:
    shutil.copytree(src, dest)
    return dest


def _say(page: Path, colour) -> None:
    """Give the PNG file ``page`` the colour chunks ``colour`` (its texels as they are)."""
    page.write_bytes(with_colour_chunks(page.read_bytes(), tuple(colour)))


def _two_pages(meshed: Path, dest: Path) -> Path:
    """The demo with its regions on two pages: the first four on ``demo.png``, the others on a copy."""
    project = _copy(meshed, dest)
    shutil.copy(project / "demo.png", project / "demo2.png")
    lines = (project / "demo.atlas").read_text().splitlines()
    head = lines[:lines.index("demo-arm")]
    page2 = ["", "demo2.png"] + [ln for ln in head[1:] if ln.startswith("\t") and ":" in ln and not
                                 any(ln.strip().startswith(k) for k in ("bounds", "offsets", "rotate"))][:2]
    text = "\n".join(head + page2 + lines[lines.index("demo-arm"):]) + "\n"
    (project / "demo.atlas").write_text(text)
    return project


def _said(page: Path):
    return page_colour(page.read_bytes())


def _written_pages(out: Path, suffix: str = ".png") -> list[Path]:
    return sorted(out.glob(f"*{suffix}"))


@pytest.mark.parametrize("colour", [[GAMMA], [SRGB, GAMMA], "profile", "all"], ids=["gamma", "srgb", "iccp", "all"])
def test_packed_pages_carry_the_colour_chunks_of_their_pages(meshed, tmp_path, colour):
    if colour == "profile":
        colour = [_iccp()]
    elif colour == "all":
        colour = [_iccp(), GAMMA, CHRM]
    project = _copy(meshed, tmp_path / "in")
    _say(project / "demo.png", colour)
    before = load_rgba(project / "demo.png")
    result = pack_project(project, tmp_path / "out", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "packed", row.reason
    (page,) = _written_pages(tmp_path / "out")
    assert load_rgba(page).shape != before.shape  # written anew from texels, not copied
    assert chunk_differences(_said(project / "demo.png"), _said(page)) == []
    kinds = [k for k, _ in colour_chunks(page.read_bytes())]
    assert sorted(kinds) == sorted(k for k, _ in colour)
    # where the PNG specification wants them: after the header, before the image data
    order = [k for k, _ in png_chunks(page.read_bytes())]
    assert order[0] == b"IHDR" and max(order.index(k) for k in kinds) < order.index(b"IDAT")


def test_a_page_without_colour_chunks_gets_none(meshed, tmp_path):
    project = _copy(meshed, tmp_path / "in")
    assert _said(project / "demo.png") == ()
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True)).atlases
    assert row.status == "packed", row.reason
    assert all(_said(p) == () for p in _written_pages(tmp_path / "out"))


def test_palette_and_rgb_pages_carry_them_too(meshed, tmp_path):
    from PIL import Image

    for mode in ("P", "RGB"):
        project = _copy(meshed, tmp_path / f"in-{mode}")
        image = Image.open(project / "demo.png")
        if mode == "P":
            image.quantize(colors=64, method=Image.Quantize.FASTOCTREE).save(project / "demo.png")
        else:
            flat = Image.new("RGB", image.size, (0, 0, 0))
            flat.paste(image, mask=image.getchannel("A"))
            flat.save(project / "demo.png")
        _say(project / "demo.png", [SRGB, GAMMA])
        (row,) = pack_project(project, tmp_path / f"out-{mode}", PackOptions(larger_files=True)).atlases
        assert row.status == "packed", row.reason
        (page,) = _written_pages(tmp_path / f"out-{mode}")
        assert Image.open(page).mode in (mode, "P")  # oxipng may store an RGB page of few colours as a palette
        assert chunk_differences(((b"sRGB", b"\x00"), GAMMA), _said(page)) == []


@pytest.mark.parametrize("jobs", [1, 2])
def test_every_page_of_an_atlas_whose_pages_agree_carries_them(meshed, tmp_path, jobs):
    """Also with --jobs 2, where the pages are encoded on workers."""
    project = _two_pages(meshed, tmp_path / "in")
    for name in ("demo.png", "demo2.png"):
        _say(project / name, [_iccp(), GAMMA])
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True, jobs=jobs)).atlases
    assert row.status == "packed" and row.pages_before == 2, row.reason
    pages = _written_pages(tmp_path / "out")
    assert pages and all(chunk_differences(_said(project / "demo.png"), _said(p)) == [] for p in pages)


@pytest.mark.parametrize("first, second", [([SRGB], "profile"), ([GAMMA], [])], ids=["srgb-vs-profile", "gamma-vs-none"])
def test_pages_in_different_colour_spaces_keep_the_atlas(meshed, tmp_path, first, second):
    project = _two_pages(meshed, tmp_path / "in")
    _say(project / "demo.png", first)
    _say(project / "demo2.png", [_iccp()] if second == "profile" else second)
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True)).atlases
    assert row.status == "kept" and "its pages are in different colour spaces" in row.reason, row.reason
    assert "'demo.png'" in row.reason and "'demo2.png'" in row.reason
    assert (tmp_path / "out" / "demo.atlas").read_bytes() == (project / "demo.atlas").read_bytes()
    for name in ("demo.png", "demo2.png"):  # as exported, or re-encoded with every chunk kept
        written = (tmp_path / "out" / name).read_bytes()
        assert png_differences((project / name).read_bytes(), written) == ""
        np.testing.assert_array_equal(load_rgba(tmp_path / "out" / name), load_rgba(project / name))


def test_pages_that_disagree_but_are_never_packed_together_are_packed(meshed, tmp_path):
    """Pages of different settings (here: filters) never share a packed page: each says its own."""
    project = _two_pages(meshed, tmp_path / "in")
    text = (project / "demo.atlas").read_text()
    head, tail = text.split("demo2.png\n")
    (project / "demo.atlas").write_text(head + "demo2.png\n" + tail.replace("filter: Linear, Linear",
                                                                            "filter: Nearest, Nearest", 1))
    _say(project / "demo.png", [SRGB])
    _say(project / "demo2.png", [_iccp()])
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True)).atlases
    assert row.status == "packed" and row.pages_after == 2, row.reason
    from spinemesh.atlas import parse_atlas

    after = parse_atlas((tmp_path / "out" / "demo.atlas").read_text(), tmp_path / "out" / "demo.atlas")
    for page in after.pages:
        said = _said(tmp_path / "out" / page.name)
        nearest = "nearest" in page.get("filter")[0].lower()
        assert [k for k, _ in said] == ([b"iCCP"] if nearest else [b"sRGB"])


def test_a_dropped_colour_chunk_is_caught_and_the_atlas_kept(meshed, tmp_path, monkeypatch):
    """Negative control: an optimiser that loses the gamma chunk of a packed page is caught by the
    decode-back check; the atlas keeps its pages, which keep theirs."""
    project = _copy(meshed, tmp_path / "in")
    _say(project / "demo.png", [SRGB, GAMMA])
    real = page_files.optimized_png

    def no_gamma(image, keep_format=False, colour=None):
        data = real(image, keep_format=keep_format, colour=colour)
        if colour is None:  # the kept atlas's re-encode: untouched
            return data
        return b"".join([data[:8]] + [png_chunk(k, v) for k, v in png_chunks(data) if k != b"gAMA"])

    monkeypatch.setattr(page_files, "optimized_png", no_gamma)
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True)).atlases
    assert row.status == "kept" and "does not say what its original pages say" in row.reason, row.reason
    assert "gAMA" in row.reason
    written = (tmp_path / "out" / "demo.png").read_bytes()
    assert png_differences((project / "demo.png").read_bytes(), written) == ""
    # the same page, checked directly
    rgba = np.array(load_rgba(project / "demo.png"))
    with pytest.raises(PackRefused, match="gAMA"):
        page_files.encode_page(rgba, "demo.png", None, ((b"sRGB", b"\x00"), GAMMA))


def test_webp_pages_carry_their_colour_profile(meshed, tmp_path):
    from PIL import Image

    project = _copy(meshed, tmp_path / "in")
    profile = _profile()
    Image.open(project / "demo.png").save(project / "demo.webp", lossless=True, exact=True, icc_profile=profile)
    (project / "demo.png").unlink()
    (project / "demo.atlas").write_text((project / "demo.atlas").read_text().replace("demo.png", "demo.webp"))
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True)).atlases
    assert row.status == "packed", row.reason
    (page,) = _written_pages(tmp_path / "out", ".webp")
    assert Image.open(page).info.get("icc_profile") == profile
    # a WebP page cannot say a gamma: such an atlas is kept, not written without it
    rgba = np.array(load_rgba(page))
    with pytest.raises(PackRefused, match="cannot say"):
        page_files.encode_page(rgba, "p.webp", None, (GAMMA,))


def test_an_rgb_page_with_a_transparent_colour_is_written_with_alpha(tmp_path):
    """tRNS on an RGB page makes one colour transparent: writing the page as RGB would lose it."""
    from PIL import Image

    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[4:12, 4:12] = (200, 10, 10)
    rgb[6:8, 6:8] = (0, 255, 0)
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG", transparency=(0, 255, 0))
    (tmp_path / "p.png").write_bytes(buf.getvalue())
    assert page_files.page_mode(tmp_path / "p.png") is None
    rgba = np.array(load_rgba(tmp_path / "p.png"))
    assert rgba[6, 6, 3] == 0
    page = page_files.encode_page(rgba, "p.png", page_files.page_mode(tmp_path / "p.png"))
    np.testing.assert_array_equal(page.texels, rgba)


def _corpus_atlases_with_colour(most_bytes: int = 1_000_000) -> list[tuple[Path, str]]:
    """Corpus projects and their atlases whose pages say something of their colours, pages of at
    most ``most_bytes`` in all (the largest, of 34 million texels, is left to scripts/page_colours.py)."""
    from spinemesh.images.sources import AtlasImages
    from spinemesh.project import find_project, find_projects, project_atlases

    found = []
    for path in find_projects(CORPUS):
        project = find_project(path)
        for atlas_path, atlas in project_atlases(project).items():
            pages = [AtlasImages.page_path(atlas, p.name) for p in atlas.pages]
            if sum(f.stat().st_size for f in pages) <= most_bytes and any(_said(f) for f in pages):
                found.append((path, atlas_path.name))
    return found


def test_corpus_pages_with_colour_chunks_keep_them(tmp_path):
    """Every corpus atlas whose pages say something of their colours (a handful): packed pages say
    the same; pages that disagree keep the atlas."""
    from spinemesh.atlas import parse_atlas
    from spinemesh.pack.atlas_pack import page_settings

    if not CORPUS.is_dir():
        unavailable("the Spine corpus is not here")
    atlases = _corpus_atlases_with_colour()
    assert len(atlases) >= 4, atlases
    statuses = []
    for n, (project, name) in enumerate(atlases):
        rows = [r for r in pack_project(project, tmp_path / str(n), PackOptions(jobs=1)).atlases
                if Path(r.atlas).name == name]
        for row in rows:
            statuses.append(row.status if "colour spaces" not in row.reason else "disagree")
            if row.status != "packed":
                continue
            written = tmp_path / str(n) / row.atlas
            before = parse_atlas((project / row.atlas).read_text(), project / row.atlas)
            folder = (project / row.atlas).parent
            said = colours_by_settings(before, [_said(folder / p.name) for p in before.pages])
            for page in parse_atlas(written.read_text(), written).pages:
                assert chunk_differences(said[page_settings(page)], _said(written.parent / page.name)) == [], page.name
    assert "packed" in statuses and "disagree" in statuses, statuses


def test_upgrade_repack_pages_carry_the_colour_chunks_of_their_page(trimmed_project, tmp_path):
    """``upgrade --repack`` writes new pages too (sequence frames stored untrimmed): they say what
    the page their regions come from says."""
    from spinemesh.upgrade import Options, upgrade_project

    folder = trimmed_project
    _say(folder / "demo.png", [_iccp(), GAMMA])
    result = upgrade_project(folder, tmp_path / "out", Options(repack=True))
    assert not result.errors
    new = tmp_path / "out" / "demo-untrimmed-1.png"
    assert new.is_file()
    assert chunk_differences(_said(folder / "demo.png"), _said(new)) == []
    assert [k for k, _ in _said(new)] == [b"iCCP", b"gAMA"]


def test_a_packed_page_of_unknown_settings_takes_the_colours_all_pages_share():
    from types import SimpleNamespace

    from spinemesh.pack.atlas_pack import PackRefused, page_settings

    page = SimpleNamespace(name="new.png", entries=[])
    other = (("filter", ("nearest",)),)
    assert page_settings(page) != other
    atlas = SimpleNamespace(pages=[page])
    assert packed_page_colours(atlas, {other: (GAMMA,)}) == {"new.png": (GAMMA,)}
    with pytest.raises(PackRefused, match="cannot be told"):
        packed_page_colours(atlas, {other: (GAMMA,), (("wrap", ("x",)),): (SRGB,)})
