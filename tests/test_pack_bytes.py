"""Bytes on disk of what ``pack`` writes: pages through oxipng, no atlas larger in bytes by default.

The project is the demo project (drawn by our own code) upgraded to meshes, so that ``pack``
moves and crops its regions. How the byte rule decides is forced where needed by making the
encoder or the rule say "larger"; what is written is checked for real (decoded, compared).
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spinemesh.atlas import read_atlas
from spinemesh.images.decode import load_rgba
from spinemesh.images.regions import cut_region
from spinemesh.pack import page_files, run
from spinemesh.pack.atlas_pack import PackRefused, PageRules
from spinemesh.pack.checks import is_lossy_webp
from spinemesh.pack.png import png_chunks
from spinemesh.pack.report import write_report
from spinemesh.pack.run import PackOptions, pack_project

REPO = Path(__file__).resolve().parents[1]


def _pillow_png(rgba: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="PNG")
    return buf.getvalue()


def test_png_pages_are_written_through_oxipng(meshed, tmp_path):
    """Fewer bytes than Pillow's default for the same texels, and the very texels."""
    from spinemesh.pack.png import optimized_png

    rgba = np.ascontiguousarray(load_rgba(meshed / "demo.png"))
    data = optimized_png(rgba)
    assert len(data) < len(_pillow_png(rgba))
    np.testing.assert_array_equal(load_rgba_bytes(data), rgba)
    result = pack_project(meshed, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "packed" and row.pages_reencoded == 0 and 0 < row.texels_used <= row.texels_after
    page = load_rgba(tmp_path / "out" / "demo.png")
    assert (tmp_path / "out" / "demo.png").stat().st_size < len(_pillow_png(np.ascontiguousarray(page)))


def load_rgba_bytes(data: bytes) -> np.ndarray:
    from spinemesh.images.decode import decode_rgba

    return decode_rgba(data)


def test_the_optimiser_works_in_a_process_forked_after_it_ran():
    """oxipng's thread pool does not survive a fork: a forked child compresses through a helper."""
    code = (
        "import os, sys, numpy as np\n"
        "from spinemesh.pack.png import optimized_png\n"
        "a = np.random.default_rng(0).integers(0, 255, (40, 40, 4), dtype=np.uint8)\n"
        "n = len(optimized_png(a))\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    os._exit(0 if len(optimized_png(a)) == n else 1)\n"
        "sys.exit(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))\n")
    r = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=120,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def _bloated(image, keep_format=False, colour=None) -> bytes:
    """A PNG without compression: every packed page takes more bytes than the original."""
    from PIL import Image

    from spinemesh.pack.png import with_colour_chunks

    if isinstance(image, (bytes, bytearray)):
        image = np.asarray(Image.open(io.BytesIO(image)).convert("RGBA"))
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(buf, format="PNG", compress_level=0)
    return buf.getvalue() if colour is None else with_colour_chunks(buf.getvalue(), colour)


def test_an_atlas_whose_files_would_grow_is_kept_unless_asked(meshed, tmp_path, monkeypatch):
    monkeypatch.setattr(page_files, "optimized_png", _bloated)
    result = pack_project(meshed, tmp_path / "kept")
    (row,) = result.atlases
    assert row.status == "kept" and "bytes against" in row.reason and "--larger-files" in row.reason, row.reason
    assert row.bytes_after == row.bytes_before
    assert (tmp_path / "kept" / "demo.png").read_bytes() == (meshed / "demo.png").read_bytes()
    result = pack_project(meshed, tmp_path / "larger", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "packed" and row.bytes_after > row.bytes_before and row.texels_after < row.texels_before


def test_rectangles_only_when_that_is_smaller(meshed, tmp_path, monkeypatch):
    """Noise between the regions (read by nothing) cleared: the same atlas in fewer bytes, same reads."""
    from spinemesh.cli.pack import outcome_line
    from spinemesh.cli.upgrade import packed_line
    from spinemesh.pack.preview import write_preview

    project = tmp_path / "noisy"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    atlas = read_atlas(project / "demo.atlas")
    page = np.array(load_rgba(project / "demo.png"))
    keep = np.zeros(page.shape[:2], bool)
    for r in atlas.regions:
        g = r.geometry()
        keep[max(0, g.y - 1):g.y + g.page_height + 1, max(0, g.x - 1):g.x + g.page_width + 1] = True
    noise = np.random.default_rng(1).integers(0, 256, page.shape, dtype=np.uint8)
    page[~keep] = noise[~keep]
    from PIL import Image

    Image.fromarray(page).save(project / "demo.png")

    def grows(*args):
        raise PackRefused("packed, its files would take more bytes")

    monkeypatch.setattr(run, "check_bytes_shrink", grows)
    result = pack_project(project, tmp_path / "out", keep_previews=True)
    (row,) = result.atlases
    # its own status, not "packed": its layout is kept, and every consumer says so
    assert row.status == "cleared" and "rectangles' texels only" in row.reason, row.reason
    assert outcome_line(result.atlases) == "packed 0 of 1 atlas, 1 cleared outside its rectangles"
    assert "; 1 atlas cleared outside its rectangles (the layout kept); atlas files" in packed_line(
        result.atlases, "every region was kept")
    write_report(result, tmp_path / "report.json")
    assert json.loads((tmp_path / "report.json").read_text())["atlases"][0]["status"] == "cleared"
    index = write_preview(result, tmp_path / "preview").read_text(encoding="utf-8")
    kept = index.split("atlases that kept their layout", 1)
    assert len(kept) == 2 and "demo.atlas" in kept[1] and "rectangles&#x27; texels only" in kept[1], index[-800:]
    assert row.texels_after == row.texels_before and row.bytes_after < row.bytes_before
    assert (tmp_path / "out" / "demo.atlas").read_bytes() == (project / "demo.atlas").read_bytes()
    written = load_rgba(tmp_path / "out" / "demo.png")
    assert not written[~keep].any()
    for r in atlas.regions:
        np.testing.assert_array_equal(cut_region(written, r), cut_region(page, r), err_msg=r.name)


def test_bytes_before_and_after_per_atlas_and_in_total(meshed, tmp_path):
    library = tmp_path / "library"
    for name in ("a", "b"):
        shutil.copytree(meshed, library / name, ignore=shutil.ignore_patterns(".*"))
    report = tmp_path / "report.json"
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "200", "NO_COLOR": "1"}
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pack", str(library), "--out", str(tmp_path / "out"),
                        "--report", str(report), "--jobs", "1"], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    data = json.loads(report.read_text())
    rows = data["atlases"]
    assert len(rows) == 2 and all(a["bytes_after"] < a["bytes_before"] for a in rows)
    for key in ("bytes_before", "bytes_after"):
        assert data["totals"][key] == sum(a[key] for a in rows)
    total = next(line for line in r.stdout.splitlines() if "total" in line)
    assert f"{data['totals']['bytes_before']:,} -> {data['totals']['bytes_after']:,}" in total


# --- atlases kept as exported: their PNG pages re-encoded losslessly where smaller ---------------

def _chunk(kind: bytes, body: bytes) -> bytes:
    import struct
    import zlib

    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _with_chunks(png: bytes, extra: list[bytes]) -> bytes:
    """``png`` with ``extra`` chunks inserted right after IHDR (gamma and profile come before the data)."""
    return png[:33] + b"".join(extra) + png[33:]


def _full_page(side: int = 64) -> np.ndarray:
    """Four regions' art that fills the page: smooth gradients (they compress well), every texel opaque."""
    y, x = np.mgrid[0:side, 0:side]
    return np.dstack([(x * 3) % 256, (y * 5) % 256, ((x + y) * 2) % 256, np.full_like(x, 255)]).astype(np.uint8)


def _kept_project(folder: Path, pages: dict[str, bytes], side: int = 64) -> Path:
    """An atlas whose regions fill every page (no packing stores fewer texels: it is kept), one
    page per entry of ``pages`` (file name -> bytes), four regions of ``side / 2`` on each."""
    folder.mkdir(parents=True)
    half = side // 2
    lines = []
    for k, (name, data) in enumerate(pages.items()):
        (folder / name).write_bytes(data)
        lines += [name, f"size: {side},{side}", "filter: Linear,Linear"]
        for i in range(4):
            lines += [f"p{k}r{i}", f"bounds: {(i % 2) * half},{(i // 2) * half},{half},{half}"]
        lines.append("")
    (folder / "full.atlas").write_text("\n".join(lines))
    return folder


def _pillow(image, **options) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    (image if isinstance(image, Image.Image) else Image.fromarray(image)).save(buf, format="PNG", **options)
    return buf.getvalue()


def _loose_png(rgba: np.ndarray) -> bytes:
    """A PNG as a careless exporter writes it: hardly compressed, with gamma, a colour profile and a text."""
    import struct
    import zlib

    from PIL import ImageCms

    profile = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    return _with_chunks(_pillow(rgba, compress_level=1), [
        _chunk(b"gAMA", struct.pack(">I", 45455)),
        _chunk(b"iCCP", b"sRGB\0\0" + zlib.compress(profile, 1)),
        _chunk(b"tEXt", b"Software\0an exporter"),
    ])


def _non_image_chunks(data: bytes) -> list:
    from spinemesh.pack.png import chunk_meaning, png_chunks

    return [(k, chunk_meaning(k, v)) for k, v in png_chunks(data) if k != b"IDAT"]


def test_a_kept_png_atlas_is_reencoded_losslessly_and_keeps_its_metadata(tmp_path):
    original = _loose_png(_full_page())
    project = _kept_project(tmp_path / "full", {"full.png": original})
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "kept" and row.pages_reencoded == 1, row.reason
    assert "kept its layout, its page re-encoded losslessly" in row.reason, row.reason
    written = (tmp_path / "out" / "full.png").read_bytes()
    assert len(written) < len(original) and row.bytes_after == row.bytes_before - len(original) + len(written)
    assert (tmp_path / "out" / "full.atlas").read_bytes() == (project / "full.atlas").read_bytes()
    np.testing.assert_array_equal(load_rgba(tmp_path / "out" / "full.png"), load_rgba(project / "full.png"))
    # gamma, colour profile and text as they were, in the same order; the same header (RGBA, 8 bits)
    assert _non_image_chunks(written) == _non_image_chunks(original)
    assert [k for k, _ in _non_image_chunks(written)][:4] == [b"IHDR", b"gAMA", b"iCCP", b"tEXt"]
    # asked for files as exported: byte for byte
    result = pack_project(project, tmp_path / "as-exported", PackOptions(keep_files_as_exported=True))
    (row,) = result.atlases
    assert row.status == "kept" and row.pages_reencoded == 0 and row.bytes_after == row.bytes_before
    assert (tmp_path / "as-exported" / "full.png").read_bytes() == original


def test_a_palette_page_stays_a_palette_page(tmp_path):
    from PIL import Image

    from spinemesh.pack.png import IHDR, png_chunks

    page = Image.fromarray(_full_page()).convert("RGB").quantize(64)
    original = _pillow(page, compress_level=1, transparency=0)
    project = _kept_project(tmp_path / "full", {"full.png": original})
    (row,) = pack_project(project, tmp_path / "out").atlases
    assert row.pages_reencoded == 1, row.reason
    written = (tmp_path / "out" / "full.png").read_bytes()
    assert len(written) < len(original)
    chunks, before = dict(png_chunks(written)), dict(png_chunks(original))
    assert IHDR.unpack(chunks[b"IHDR"])[2:4] == (8, 3)  # 8-bit palette, as exported
    assert chunks[b"PLTE"] == before[b"PLTE"] and chunks[b"tRNS"] == before[b"tRNS"]  # the same palette, in order
    np.testing.assert_array_equal(load_rgba(tmp_path / "out" / "full.png"), load_rgba(project / "full.png"))


def test_a_page_that_would_not_shrink_is_copied_byte_for_byte(tmp_path):
    from spinemesh.pack.png import optimized_png

    noise = np.random.default_rng(3).integers(0, 256, (64, 64, 4), dtype=np.uint8)
    original = optimized_png(_pillow(noise), keep_format=True)  # already as small as oxipng makes it
    project = _kept_project(tmp_path / "full", {"full.png": original})
    (row,) = pack_project(project, tmp_path / "out").atlases
    assert row.status == "kept" and row.pages_reencoded == 0 and row.bytes_after == row.bytes_before, row.reason
    assert "re-encoded" not in row.reason
    assert (tmp_path / "out" / "full.png").read_bytes() == original


def test_lossy_webp_and_jpeg_pages_are_never_reencoded(tmp_path):
    from PIL import Image

    lossy = io.BytesIO()
    Image.fromarray(_full_page()).save(lossy, format="WEBP", quality=80)
    project = _kept_project(tmp_path / "mixed", {"a.png": _loose_png(_full_page()), "b.webp": lossy.getvalue()})
    assert is_lossy_webp(project / "b.webp")
    (row,) = pack_project(project, tmp_path / "out").atlases
    assert row.status == "kept" and row.pages_reencoded == 1 and "1 of its 2 pages" in row.reason, row.reason
    assert (tmp_path / "out" / "b.webp").read_bytes() == lossy.getvalue()
    assert (tmp_path / "out" / "a.png").stat().st_size < (project / "a.png").stat().st_size
    jpeg = io.BytesIO()
    Image.fromarray(_full_page()[..., :3]).save(jpeg, format="JPEG", quality=90)
    project = _kept_project(tmp_path / "jpeg", {"a.png": _loose_png(_full_page()), "b.jpg": jpeg.getvalue()})
    (row,) = pack_project(project, tmp_path / "out-jpeg").atlases
    assert row.status == "kept" and row.pages_reencoded == 0 and "JPEG" in row.reason, row.reason
    for name in ("a.png", "b.jpg"):
        assert (tmp_path / "out-jpeg" / name).read_bytes() == (project / name).read_bytes()


def test_a_tampered_reencode_is_caught_and_the_page_copied(tmp_path, monkeypatch):
    """Negative controls: an optimiser that changes one texel, or drops the gamma chunk, is caught."""
    from spinemesh.pack.png import optimized_png

    original = _loose_png(_full_page())
    project = _kept_project(tmp_path / "full", {"full.png": original})

    def one_texel_off(image, keep_format=False, colour=None):
        rgba = np.array(load_rgba_bytes(bytes(image)))
        rgba[10, 20, 0] ^= 1
        return optimized_png(_with_chunks(_pillow(rgba), [c for c in original_chunks(b"gAMA", b"iCCP", b"tEXt")]),
                             keep_format=True)

    def no_gamma(image, keep_format=False, colour=None):
        data = optimized_png(image, keep_format=keep_format)
        return b"".join([data[:8]] + [_chunk(k, v) for k, v in png_chunks(data) if k != b"gAMA"])

    def original_chunks(*kinds):
        return [_chunk(k, v) for k, v in png_chunks(original) if k in kinds]

    for tamper, why in ((one_texel_off, "texel for texel"), (no_gamma, "gAMA")):
        monkeypatch.setattr(page_files, "optimized_png", tamper)
        data = tamper(original)
        assert len(data) < len(original)  # it would have been written, were it not checked
        try:
            page_files.reencoded_page(original, load_rgba(project / "full.png"), "full.png")
            raise AssertionError("not caught")
        except PackRefused as e:
            assert why in str(e), e
        out = tmp_path / f"out-{why[:4]}"
        (row,) = pack_project(project, out).atlases
        assert row.status == "kept" and row.pages_reencoded == 0, row.reason
        assert (out / "full.png").read_bytes() == original


def test_upgrade_pack_reencodes_kept_pages_in_place_unless_asked(tmp_path):
    """``upgrade --pack`` packs what it wrote in place through the same code: kept pages re-encoded,
    or left byte for byte with ``--keep-files-as-exported``."""
    from spinemesh.upgrade import Options
    from spinemesh.upgrade.pack import pack_written
    from spinemesh.upgrade.report import Result

    original = _loose_png(_full_page())
    for keep, expect in ((False, 1), (True, 0)):
        out = _kept_project(tmp_path / f"written-{keep}", {"full.png": original})
        result = Result()
        pack_written(out, result, Options(jobs=1, pack=True, pack_keep_files=keep))
        (row,) = result.atlases
        assert row.status == "kept" and row.pages_reencoded == expect, row.reason
        assert ((out / "full.png").read_bytes() == original) == keep
        np.testing.assert_array_equal(load_rgba(out / "full.png"), load_rgba_bytes(original))


def test_kept_pages_reencoded_on_workers_are_the_same_files(tmp_path):
    """With --jobs 2 the pages of one kept atlas are re-encoded side by side: the same bytes as one
    process writes (oxipng may have run in this process before the workers were forked)."""
    pages = {f"p{k}.png": _loose_png(np.roll(_full_page(), 7 * k, axis=1)) for k in range(3)}
    project = _kept_project(tmp_path / "full", pages)
    one = pack_project(project, tmp_path / "one", PackOptions(jobs=1)).atlases[0]
    two = pack_project(project, tmp_path / "two", PackOptions(jobs=2)).atlases[0]
    assert one.pages_reencoded == two.pages_reencoded == 3 and one.bytes_after == two.bytes_after, two.reason
    for name in pages:
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes()


def _demo_layouts(meshed: Path, rules):
    """Every layout the fills keep for the meshed demo atlas under ``rules``, composited: (packed atlases,
    each one's bytes as oxipng writes it, the atlas's bytes as exported)."""
    from spinemesh.pack.atlas_pack import compose, plan_layouts
    from spinemesh.pack.png import optimized_png
    from spinemesh.pack.uses import collect_uses
    from spinemesh.project import find_project, project_atlases

    proj = find_project(meshed)
    ((path, atlas),) = project_atlases(proj).items()
    layouts = plan_layouts(atlas, [load_rgba(meshed / "demo.png")], collect_uses(proj).regions.get(path, {}),
                           rules=rules)
    packed = [compose(layouts, rank) for rank in range(layouts.count)]
    sizes = [sum(len(optimized_png(np.ascontiguousarray(p))) for p in a.pages.values()) + len(a.atlas.dumps().encode())
             for a in packed]
    return packed, sizes, path.stat().st_size + (meshed / "demo.png").stat().st_size


def _bloating(packed: list, ranks: set[int]):
    """An encoder that writes the pages of the layouts ``ranks`` of ``packed`` uncompressed (more bytes
    than the atlas as exported), the others as oxipng does."""
    sizes = {(p.shape[1], p.shape[0]) for rank in ranks for p in packed[rank].pages.values()}
    real = page_files.optimized_png

    def encode(image, keep_format=False, colour=None):
        if not isinstance(image, (bytes, bytearray)) and (image.shape[1], image.shape[0]) in sizes:
            return _bloated(image, keep_format, colour)
        return real(image, keep_format=keep_format, colour=colour)

    return encode


def test_when_the_best_layout_grows_in_bytes_the_next_layout_of_fewest_bytes_is_written(meshed, tmp_path,
                                                                                       monkeypatch):
    """The layouts the fills found besides the best are tried in turn; of those that take fewer bytes
    than exported, the one of fewest bytes is written, proven; none larger than exported, ever."""
    rules = PageRules("any")
    packed, sizes, before = _demo_layouts(meshed, rules)
    assert len(packed) >= 3 and [p.texels_after for p in packed] == sorted({p.texels_after for p in packed})
    assert len({tuple(p.shape for p in a.pages.values()) for a in packed}) == len(packed)  # told apart by size
    assert all(p.texels_after < p.texels_before for p in packed) and max(sizes) < before
    others = range(1, len(packed))
    fewest = min(others, key=lambda r: (sizes[r], r))
    for bloated, expected in (({0}, fewest), ({0, fewest}, min(set(others) - {fewest}, key=lambda r: (sizes[r], r)))):
        monkeypatch.setattr(page_files, "optimized_png", _bloating(packed, bloated))
        out = tmp_path / f"out-{len(bloated)}"
        result = pack_project(meshed, out, PackOptions(rules=rules))
        (row,) = result.atlases
        assert row.status == "packed" and "another layout" in row.reason, row.reason
        assert row.texels_after == packed[expected].texels_after and row.bytes_after == sizes[expected]
        assert row.bytes_after < row.bytes_before == before and row.texels_after < row.texels_before
        assert (out / "demo.atlas").read_text() == packed[expected].atlas.dumps()
        np.testing.assert_array_equal(load_rgba(out / "demo.png"), packed[expected].pages["demo.png"])
    # every layout larger than exported: none of them is written (the rectangles-only rewrite or the atlas kept)
    monkeypatch.setattr(page_files, "optimized_png", _bloating(packed, set(range(len(packed)))))
    result = pack_project(meshed, tmp_path / "none", PackOptions(rules=rules))
    (row,) = result.atlases
    assert "another layout" not in row.reason and row.bytes_after <= row.bytes_before, row.reason
    assert row.texels_after == row.texels_before


def _opens_while_packing(monkeypatch, pages: list[Path]):
    """How many times each file of ``pages`` is opened while ``pack_atlas_files`` runs (a Counter by
    name): every ``open`` of Python and of Pillow goes through ``builtins.open`` or ``io.open``."""
    import builtins
    from collections import Counter

    watched = {p.resolve() for p in pages}
    counted: Counter = Counter()
    packing = [False]

    def counting(real):
        def opened(file, *args, **kwargs):
            if packing[0] and isinstance(file, (str, os.PathLike)) and Path(file).resolve() in watched:
                counted[Path(file).name] += 1
            return real(file, *args, **kwargs)
        return opened

    monkeypatch.setattr(builtins, "open", counting(builtins.open))
    monkeypatch.setattr(io, "open", counting(io.open))
    real = run.pack_atlas_files

    def pack_atlas_files(*args, **kwargs):
        packing[0] = True
        try:
            return real(*args, **kwargs)
        finally:
            packing[0] = False

    monkeypatch.setattr(run, "pack_atlas_files", pack_atlas_files)
    return counted


def test_each_page_is_read_once_while_its_atlas_is_packed(meshed, tmp_path, monkeypatch):
    """Texels, palette, colour chunks and the file to re-encode all come from one read of each page,
    whether the atlas is packed, kept with its pages re-encoded, or kept for its bytes."""
    from PIL import Image

    palette = _pillow(Image.fromarray(_full_page()).convert("RGB").quantize(64), compress_level=1, transparency=0)
    kept = _kept_project(tmp_path / "kept", {"a.png": _loose_png(_full_page()), "b.png": palette})
    for project, expected in ((meshed, "packed"), (kept, "kept")):
        pages = sorted(project.glob("*.png"))
        opens = _opens_while_packing(monkeypatch, pages)
        result = pack_project(project, tmp_path / f"out-{project.name}")
        (row,) = result.atlases
        assert row.status == expected and (expected == "packed" or row.pages_reencoded == 2), row.reason
        assert opens == {p.name: 1 for p in pages}, opens
        monkeypatch.undo()
    # the files would grow: the other layouts, the rectangles-only rewrite and the kept pages read nothing more
    opens = _opens_while_packing(monkeypatch, [meshed / "demo.png"])
    monkeypatch.setattr(page_files, "optimized_png", _bloated)
    (row,) = pack_project(meshed, tmp_path / "grows", PackOptions(rules=PageRules("any"))).atlases
    assert row.status == "kept" and "bytes against" in row.reason, row.reason
    assert opens == {"demo.png": 1}, opens


def test_a_next_layout_whose_pages_do_not_come_back_is_never_written(meshed, tmp_path, monkeypatch):
    """Negative control of the next layouts' proof: the layout of fewest bytes besides the best is
    encoded one texel off (and smaller, so it would win): it is refused, and the next of fewest
    bytes that comes back is written, texel for texel."""
    rules = PageRules("any")
    packed, sizes, _ = _demo_layouts(meshed, rules)
    others = range(1, len(packed))
    fewest = min(others, key=lambda r: (sizes[r], r))
    expected = min(set(others) - {fewest}, key=lambda r: (sizes[r], r))
    off = {(p.shape[1], p.shape[0]) for p in packed[fewest].pages.values()}
    bloating = _bloating(packed, {0})
    from spinemesh.pack.png import optimized_png

    def encode(image, keep_format=False, colour=None):
        if not isinstance(image, (bytes, bytearray)) and (image.shape[1], image.shape[0]) in off:
            rgba = np.array(image)
            ys, xs = np.nonzero(rgba[..., 3])
            rgba[ys[0], xs[0], 0] ^= 1  # a drawn texel
            return optimized_png(rgba)
        return bloating(image, keep_format, colour)

    monkeypatch.setattr(page_files, "optimized_png", encode)
    out = tmp_path / "out"
    (row,) = pack_project(meshed, out, PackOptions(rules=rules)).atlases
    assert row.status == "packed" and "another layout" in row.reason, row.reason
    assert row.texels_after == packed[expected].texels_after and row.bytes_after == sizes[expected]
    assert (out / "demo.atlas").read_text() == packed[expected].atlas.dumps()
    np.testing.assert_array_equal(load_rgba(out / "demo.png"), packed[expected].pages["demo.png"])


def test_an_atlas_that_cannot_be_written_leaves_its_pages_as_they_were(meshed, tmp_path, monkeypatch):
    """The packed atlas cannot be written (disk full) after its pages could: none of its files is,
    so the atlas and the pages in the output are the originals that go together (copied into OUT,
    or left as they were where ``upgrade --pack`` packs in place); no temporary file stays. A full
    disk refuses every later write too: the run stops there, saying so once."""
    import errno
    import os

    from spinemesh.errors import OutputStopped
    from spinemesh.pack.report import PackResult
    from spinemesh.pack.run import pack_project_into
    from spinemesh.project import find_project

    real, refused = os.open, []

    def disk_full_once(path, flags, *args, **kwargs):  # the atlas's temporary file cannot be made
        if os.path.basename(path).startswith(".demo.atlas.") and flags & os.O_EXCL and not refused:
            refused.append(path)
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", disk_full_once)
    in_place = tmp_path / "in-place"
    shutil.copytree(meshed, in_place)
    with pytest.raises(OutputStopped, match="disk full"):
        pack_project_into(find_project(in_place), in_place, PackOptions(), PackResult())
    for name in ("demo.atlas", "demo.png"):
        assert (in_place / name).read_bytes() == (meshed / name).read_bytes(), name
    refused.clear()
    with pytest.raises(OutputStopped, match="disk full"):
        pack_project(meshed, tmp_path / "out")
    out = tmp_path / "out"  # neither the packed page nor the atlas: none is written without the other
    assert not (out / "demo.atlas").exists() and not (out / "demo.png").exists(), sorted(out.rglob("*"))
    assert not [p for p in (*in_place.rglob("*.tmp"), *out.rglob("*.tmp"))]
