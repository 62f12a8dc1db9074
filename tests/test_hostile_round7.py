"""Hostile input, seventh round: what a page file or an atlas page says besides its texels
(frames, EXIF orientation, wrap, text, filters, premultiplied alpha), atlas text as odd editors
save it, and the 4.3 constraints and sliders added after round six.

As in rounds five and six (tests/test_hostile_wave4.py, tests/test_hostile_round6.py), every
project and skeleton is made here by our own code; each case checks what docs/safety.md promises:
a page is written only when it draws as the original, else its atlas is kept byte for byte; no
traceback, one line naming the file, nothing non-finite written, bounded time.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from test_hostile_wave4 import _same_texels_drawn

from spinemesh.pack.run import PackOptions, pack_project


# --- pack: what a page file says besides its texels ---------------------------------------------

def _demo_texels(project: Path):
    from PIL import Image

    with Image.open(project / "demo.png") as im:
        return im.convert("RGBA")


def _exif(orientation: int) -> bytes:
    from PIL import Image

    exif = Image.Exif()
    exif[0x0112] = orientation
    return exif.tobytes()


def _apng(project: Path, im, default_apart: bool) -> None:
    from PIL import Image

    red = Image.new("RGBA", im.size, (255, 0, 0, 255))
    extra = {"default_image": True} if default_apart else {}
    im.save(project / "demo.png", save_all=True, append_images=[red, im] if default_apart else [red],
            duration=100, **extra)


def _webp(project: Path, im, **options) -> None:
    (project / "demo.png").unlink()
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("demo.png", "demo.webp"))
    im.save(project / "demo.webp", lossless=True, exact=True, **options)


def _animated_webp(project: Path, im) -> None:
    from PIL import Image

    _webp(project, im, save_all=True, append_images=[Image.new("RGBA", im.size, (255, 0, 0, 255))], duration=100)


def _field(line: str):
    def edit(project: Path, im) -> None:
        atlas = project / "demo.atlas"
        atlas.write_text(atlas.read_text().replace("filter: Linear, Linear", line, 1))
    return edit


#: Pages a packed page would silently draw otherwise than: (how the project is made, words the
#: reason must hold). Each once came out packed (exit 0): a still page of the first frame, the
#: orientation gone, a repeating page shared with other regions.
KEPT_PAGES = {
    "an APNG page": (lambda p, im: _apng(p, im, False), "animated (2 frames)"),
    "an APNG whose default image is not a frame": (lambda p, im: _apng(p, im, True), "animated (3 frames)"),
    "an animated WebP page": (_animated_webp, "animated (2 frames)"),
    "a PNG page turned by EXIF": (lambda p, im: im.save(p / "demo.png", exif=_exif(6)), "EXIF orientation 6"),
    "a PNG page mirrored by EXIF": (lambda p, im: im.save(p / "demo.png", exif=_exif(2)), "EXIF orientation 2"),
    "a WebP page turned by EXIF": (lambda p, im: _webp(p, im, exif=_exif(8)), "EXIF orientation 8"),
    "a page that repeats on x and y": (_field("filter: Linear, Linear\n\trepeat: xy"), "repeats (xy)"),
    "a page that repeats on x": (_field("filter: Linear, Linear\n\trepeat: x"), "repeats (x)"),
}


@pytest.mark.parametrize("case", sorted(KEPT_PAGES))
def test_a_page_runtimes_draw_otherwise_than_its_texels_keeps_its_atlas(meshed, tmp_path, case):
    make, words = KEPT_PAGES[case]
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    make(project, _demo_texels(meshed))
    before = {p.name: p.read_bytes() for p in project.iterdir()}
    result = pack_project(project, tmp_path / "out", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "kept" and words in row.reason and "'demo." in row.reason, row.reason
    for name, data in before.items():  # the atlas and its page byte for byte (never re-encoded)
        assert (tmp_path / "out" / name).read_bytes() == data, name
        assert (project / name).read_bytes() == data, name


#: Pages whose extras say nothing a runtime draws by, or that pack already handles: packed, every
#: texel drawn the original's (the proof's own claim, checked here by hand, through Pillow).
PACKED_PAGES = {
    "text chunks": lambda p, im: im.save(p / "demo.png", pnginfo=_text_chunks()),
    "EXIF orientation 1": lambda p, im: im.save(p / "demo.png", exif=_exif(1)),
    "an APNG of one frame": lambda p, im: im.save(p / "demo.png", save_all=True, append_images=[]),
    "a MipMap filter": _field("filter: MipMapLinearLinear, Linear"),
    "repeat: none": _field("filter: Linear, Linear\n\trepeat: none"),
    "a still WebP with EXIF orientation 1": lambda p, im: _webp(p, im, exif=_exif(1)),
}


def _text_chunks():
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    info.add_text("Software", "hand")
    info.add_itxt("Comment", "é", zip=True)
    return info


@pytest.mark.parametrize("case", sorted(PACKED_PAGES))
def test_pages_whose_extras_draw_nothing_pack_to_the_same_texels(meshed, tmp_path, case):
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    PACKED_PAGES[case](project, _demo_texels(meshed))
    result = pack_project(project, tmp_path / "out", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "packed", row.reason
    assert _same_texels_drawn(project, tmp_path / "out") > 20_000


def test_a_page_that_is_no_image_names_its_file_not_a_stream(meshed, tmp_path):
    """A TGA (or anything Pillow cannot name) saved as ``demo.png``: the atlas failed with
    Pillow's words, ``cannot identify image file <_io.BytesIO object at 0x7f...>`` (a memory
    address, not the file); now it says what the file is not."""
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    _demo_texels(meshed).save(project / "demo.png", "TGA")
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "failed" and "0x" not in row.reason and "BytesIO" not in row.reason, row.reason
    assert "demo.png: cannot decode image: not a PNG, WebP, AVIF or JPEG file" in row.reason, row.reason
    assert (tmp_path / "out" / "demo.png").read_bytes() == (project / "demo.png").read_bytes()


# --- the preview: memory refused while one skeleton's animations are sampled ---------------------

def _library(tmp_path: Path) -> Path:
    """Two copies of the demo project, one whose skeleton has the animations "doomed" and "late"."""
    import json

    from spinemesh.demo import make_demo_project

    for name in ("a", "b"):
        demo = make_demo_project(tmp_path / "lib" / name)
        (demo / "demo-binary.skel").unlink()
        if name == "a":
            doc = json.loads((demo / "demo.json").read_text())
            turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 2, "value": 90}]}}}
            doc["animations"] |= {"doomed": turn, "late": turn}
            (demo / "demo.json").write_text(json.dumps(doc))
    return tmp_path / "lib"


def _no_memory_for_doomed(real):
    def sample(sides, sampling, names):
        if "doomed" in names:
            raise MemoryError
        return real(sides, sampling, names)
    return sample


@pytest.mark.parametrize("jobs", [1, 2])
def test_memory_refused_while_the_preview_samples_costs_those_animations_only(tmp_path, monkeypatch, jobs):
    """A MemoryError while one skeleton's animations were sampled (in this process, or on a worker,
    where the task hands it back) ended the whole preview; now with ``--jobs 2`` those
    animations alone are left out, in one line on the page, and with one process that skeleton's
    player (the process samples a skeleton's animations together); every other page is written
    and plays."""
    import re

    from test_hostile_wave4 import within

    from spinemesh.player import frames
    from spinemesh.upgrade import Options, preview, upgrade_library
    from spinemesh.upgrade.preview import write_preview

    lib = _library(tmp_path)
    result = upgrade_library(lib, tmp_path / "out", Options(jobs=1))
    monkeypatch.setattr(preview, "CHUNK_SECONDS", 0.0)  # a worker's task per animation
    monkeypatch.setattr(frames, "sample_and_encode", _no_memory_for_doomed(frames.sample_and_encode))
    with within(120):
        index = write_preview(result, lib, tmp_path / "out", tmp_path / "v", jobs=jobs)
    pages = {p: p.read_text(encoding="utf-8") for p in index.parent.glob("s/*.html")}
    assert len(pages) == 2
    lines = [x for text in pages.values() for x in re.findall(r"<li>([^<]*)</li>", text)]
    (line,) = [x for x in lines if "memory" in x]
    assert "not enough memory to sample its poses" in line, line
    models = [m.read_text(encoding="utf-8") for m in index.parent.glob("data/*/model.js")]
    played = sorted(re.findall(r'"name":"([^"]+)","dur"', m) for m in models)
    if jobs == 1:
        assert "the player could not pose this skeleton" in line
        assert played == [["setup pose", "wave"]]  # the other skeleton's player
    else:  # the animations sampled with "doomed" in one task are left out with it, no others
        assert "doomed" in line and "not shown" in line, line
        assert ["setup pose", "wave"] in played, played  # the other skeleton's, whole
        assert any("late" in m and "doomed" not in m for m in played), played

