"""Region images cut from real atlases against the original unpacked images of 4.2."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from spinemesh.atlas import parse_atlas, read_atlas
from spinemesh.errors import AtlasError, ImageError, UnsafePathError
from spinemesh.images.decode import load_rgba
from spinemesh.images.pages import PageStore
from spinemesh.images.regions import cut_region
from spinemesh.images.sources import AtlasImages, FolderImages
from spinemesh.images.texels import channel_max, premultiply, unpremultiply

from conftest import example_projects, memory_files_left


def _cases():
    """(atlas, region name, original image path) for every 4.2 region that has an original."""
    out = []
    for proj in example_projects("4.2"):
        for atlas_path in sorted(proj.glob("*.atlas")):
            atlas = read_atlas(atlas_path)
            for r in atlas.regions:
                orig = proj / "images" / f"{r.name}.png"
                if orig.exists():
                    out.append((atlas_path, r.name, orig, atlas.pages[r.page].pma, atlas.pages[r.page].scale))
    return out


CASES = _cases()


def _by_kind(pma: bool, scaled: bool):
    return [c for c in CASES if c[3] == pma and (c[4] != 1) == scaled]


def _load(case):
    atlas_path, name, orig_path, _, _ = case
    got = AtlasImages([read_atlas(atlas_path)]).get(name)
    orig = np.asarray(Image.open(orig_path).convert("RGBA"))
    return got, orig


def test_there_are_real_cases(examples):
    assert len(_by_kind(False, False)) == 148
    assert len(_by_kind(True, False)) == 148
    assert len(_by_kind(False, True)) + len(_by_kind(True, True)) > 500


def test_plain_atlas_regions_are_exact(examples):
    for case in _by_kind(False, False):
        got, orig = _load(case)
        assert got.scale == 1
        assert got.rgba.shape == orig.shape, case[1]
        assert np.array_equal(got.rgba[..., 3], orig[..., 3]), case[1]
        opaque = orig[..., 3] > 0
        assert np.array_equal(got.rgba[..., :3][opaque], orig[..., :3][opaque]), case[1]


def test_pma_atlas_regions_match_in_premultiplied_space(examples):
    for case in _by_kind(True, False):
        got, orig = _load(case)
        atlas = read_atlas(case[0])
        region = atlas.find(case[1])
        page = np.asarray(Image.open(case[0].parent / atlas.pages[region.page].name).convert("RGBA"))
        stored = cut_region(page, region, pma=False)  # the page's premultiplied pixels, uncut
        want = premultiply(orig).astype(int)
        assert np.abs(stored.astype(int) - want).max() <= 1, case[1]
        assert np.abs(premultiply(got.rgba).astype(int) - want).max() <= 1, case[1]


def test_scaled_atlas_regions_match_resized_originals(examples):
    import cv2

    ious = []
    for case in _by_kind(False, True) + _by_kind(True, True):
        got, orig = _load(case)
        assert got.scale == case[4]
        if (orig[..., 3] > 128).sum() < 200:
            continue
        h, w = got.rgba.shape[:2]
        assert abs(w - orig.shape[1] * got.scale) <= 1 and abs(h - orig.shape[0] * got.scale) <= 1
        resized = cv2.resize(orig, (w, h), interpolation=cv2.INTER_AREA)
        a, b = got.rgba[..., 3] > 128, resized[..., 3] > 128
        ious.append((a & b).sum() / max((a | b).sum(), 1))
    ious = np.array(ious)
    assert len(ious) > 400
    assert (ious >= 0.95).mean() >= 0.98
    assert np.median(ious) >= 0.99


def test_unpremultiply_round_trips_within_one():
    rng = np.random.default_rng(0)
    straight = rng.integers(0, 256, (64, 64, 4), dtype=np.uint8)
    pm = premultiply(straight)
    assert np.abs(premultiply(unpremultiply(pm)).astype(int) - pm.astype(int)).max() <= 1


def test_rotations_of_a_synthetic_region():
    """A region stored at 90, 180 and 270 degrees comes back upright."""
    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, (5, 3, 4), dtype=np.uint8)  # 3 wide, 5 tall
    for degrees in (0, 90, 180, 270):
        stored = np.rot90(image, degrees // 90)  # packers turn counter-clockwise
        page = np.zeros((10, 10, 4), np.uint8)
        page[1:1 + stored.shape[0], 2:2 + stored.shape[1]] = stored
        atlas = parse_atlas(f"p.png\n\tsize: 10, 10\nr\n\tbounds: 2, 1, 3, 5\n\trotate: {degrees}\n")
        assert np.array_equal(cut_region(page, atlas.regions[0]), image), degrees


def test_whitespace_is_restored_at_the_right_side():
    """offsets count from the left and from the bottom (y up)."""
    page = np.zeros((4, 4, 4), np.uint8)
    page[0:2, 0:2] = 255
    atlas = parse_atlas("p.png\n\tsize: 4, 4\nr\n\tbounds: 0, 0, 2, 2\n\toffsets: 1, 3, 5, 6\n")
    out = cut_region(page, atlas.regions[0])
    assert out.shape == (6, 5, 4)
    ys, xs = np.nonzero(out[..., 3])
    assert (ys.min(), ys.max(), xs.min(), xs.max()) == (1, 2, 1, 2)


def test_region_outside_page_is_an_error():
    atlas = parse_atlas("p.png\n\tsize: 4, 4\nr\n\tbounds: 3, 3, 2, 2\n", "x.atlas")
    with pytest.raises(AtlasError, match="outside"):
        cut_region(np.zeros((4, 4, 4), np.uint8), atlas.regions[0], source="x.atlas")


def test_page_name_leaving_the_project_is_refused(tmp_path):
    (tmp_path / "proj").mkdir()
    Image.new("RGBA", (4, 4)).save(tmp_path / "secret.png")
    f = tmp_path / "proj" / "a.atlas"
    f.write_text("../secret.png\n\tsize: 4, 4\nr\n\tbounds: 0, 0, 2, 2\n")
    with pytest.raises(UnsafePathError) as e:
        AtlasImages([read_atlas(f)]).get("r")
    assert "a.atlas" in str(e.value) and "outside" in str(e.value)


def test_folder_images(tmp_path):
    (tmp_path / "images" / "sub").mkdir(parents=True)
    Image.new("RGBA", (3, 2), (1, 2, 3, 4)).save(tmp_path / "images" / "sub" / "a.png")
    Image.new("RGBA", (2, 2), (9, 9, 9, 255)).save(tmp_path / "images" / "b.webp", lossless=True)
    src = FolderImages(tmp_path / "images")
    assert src.names() == ["b", "sub/a"]
    img = src.get("sub/a")
    assert img.rgba.shape == (2, 3, 4) and tuple(img.rgba[0, 0]) == (1, 2, 3, 4) and img.scale == 1
    assert tuple(src.get("b").rgba[1, 1]) == (9, 9, 9, 255)
    with pytest.raises(ImageError, match="no image"):
        src.get("missing")
    with pytest.raises(UnsafePathError):
        src.get("../../etc/passwd")


def test_broken_page_image_is_a_clear_error(tmp_path):
    (tmp_path / "p.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    f = tmp_path / "a.atlas"
    f.write_text("p.png\n\tsize: 4, 4\nr\n\tbounds: 0, 0, 2, 2\n")
    with pytest.raises(ImageError) as e:
        AtlasImages([read_atlas(f)]).get("r")
    assert "p.png" in str(e.value)


@pytest.mark.parametrize("fmt, suffix, exact", [("PNG", "png", True), ("WEBP", "webp", True), ("AVIF", "avif", False)])
def test_page_formats(tmp_path, fmt, suffix, exact):
    """Pages in PNG, WebP and AVIF decode; a 4x2 region comes back in place."""
    # A smooth gradient: lossy AVIF keeps it close, where random noise would not survive.
    yy, xx = np.mgrid[0:8, 0:8]
    pixels = np.stack([xx * 30, yy * 30, (xx + yy) * 15, np.full_like(xx, 255)], -1).astype(np.uint8)
    options = {"lossless": True} if fmt == "WEBP" else {"quality": 100} if fmt == "AVIF" else {}
    Image.fromarray(pixels).save(tmp_path / f"p.{suffix}", format=fmt, **options)
    f = tmp_path / "a.atlas"
    f.write_text(f"p.{suffix}\n\tsize: 8, 8\nr\n\tbounds: 1, 2, 4, 2\n")
    got = AtlasImages([read_atlas(f)]).get("r").rgba
    assert got.shape == (2, 4, 4)
    diff = np.abs(got.astype(int) - pixels[2:4, 1:5].astype(int)).max()
    assert diff == 0 if exact else diff <= 16


def _unpremultiply_by_division(rgba):
    """The division unpremultiply used to make, texel by texel: the table must give the same."""
    a = rgba[..., 3:4].astype(np.uint32)
    safe = np.maximum(a, 1)
    straight = np.where(a > 0, np.minimum((rgba[..., :3].astype(np.uint32) * 255 + safe // 2) // safe, 255), 0)
    return np.concatenate([straight.astype(np.uint8), rgba[..., 3:4]], axis=-1)


def test_unpremultiply_table_gives_the_division_for_every_alpha_and_colour():
    every = np.zeros((256, 256, 4), np.uint8)
    every[..., 3] = np.arange(256)[:, None]
    every[..., 0] = np.arange(256)[None, :]
    every[..., 1] = 255 - every[..., 0]
    every[..., 2] = every[..., 0] // 2
    assert np.array_equal(unpremultiply(every), _unpremultiply_by_division(every))


def test_channel_max_is_the_largest_channel_also_of_a_view():
    rng = np.random.default_rng(2)
    page = rng.integers(0, 256, (40, 50, 4), dtype=np.uint8)
    view = page[3:30, 7:41]
    assert np.array_equal(channel_max(view), view.max(axis=-1))


def test_loaded_pixels_are_the_files_texels_and_read_only(tmp_path):
    rng = np.random.default_rng(3)
    rgba = rng.integers(0, 256, (17, 23, 4), dtype=np.uint8)
    Image.fromarray(rgba).save(tmp_path / "a.png")
    Image.fromarray(rgba[..., :3]).save(tmp_path / "b.png")
    got = load_rgba(tmp_path / "a.png")
    assert np.array_equal(got, rgba) and got.dtype == np.uint8
    with pytest.raises(ValueError):
        got[0, 0, 0] = 1  # shared by the regions cut from it
    rgb = load_rgba(tmp_path / "b.png")
    assert np.array_equal(rgb[..., :3], rgba[..., :3]) and (rgb[..., 3] == 255).all()


def test_a_page_store_decodes_each_page_once_and_keeps_within_its_budget(tmp_path):
    for name in ("p1.png", "p2.png", "p3.png"):
        Image.new("RGBA", (8, 8), (10, 20, 30, 255)).save(tmp_path / name)
    atlas_text = "\n".join(f"p{i}.png\n\tsize: 8, 8\nr{i}\n\tbounds: 0, 0, 4, 4\n" for i in (1, 2, 3))
    (tmp_path / "a.atlas").write_text(atlas_text)
    (tmp_path / "b.atlas").write_text(atlas_text.replace("\nr", "\ns"))
    store = PageStore()
    a = AtlasImages([read_atlas(tmp_path / "a.atlas")], pages=store)
    b = AtlasImages([read_atlas(tmp_path / "b.atlas")], pages=store)
    for _ in range(3):
        for i in (1, 2, 3):
            assert a.get(f"r{i}").rgba.shape == (4, 4, 4)
            assert b.get(f"s{i}").rgba.shape == (4, 4, 4)
    assert store.decodes == 3  # two atlases naming the same three files: three decodes in all
    small = PageStore(max_bytes=8 * 8 * 4)  # room for one page
    c = AtlasImages([read_atlas(tmp_path / "a.atlas")], pages=small)
    for i in (1, 2, 1):
        c.get(f"r{i}")
    assert small.decodes == 3
    store.release()
    a.get("r1")
    assert store.decodes == 4


def _page_files(folder):
    """Three page files of different kinds (RGBA and RGB PNG, WebP) and one that is not an image."""
    rng = np.random.default_rng(7)
    files = []
    for name, mode in (("p1.png", "RGBA"), ("p2.png", "RGB"), ("p3.webp", "RGBA")):
        texels = rng.integers(0, 256, (24, 40, 4), dtype=np.uint8)
        Image.fromarray(texels).convert(mode).save(folder / name, **({"lossless": True} if name.endswith("webp") else {}))
        files.append((folder / name).resolve())
    bad = folder / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not a page")
    return files, bad.resolve()


def _lose_the_worker(path):
    import os
    import signal

    os.kill(os.getpid(), signal.SIGKILL)


def test_pages_decoded_ahead_by_workers_are_the_pages_this_process_decodes(tmp_path, monkeypatch):
    """Same texels, read-only, each page counted once, and none decoded by this process."""
    from spinemesh.cluster import open_workers
    from spinemesh.images import decode
    from spinemesh.images.pages import PagePrefetch
    from spinemesh.upgrade.plan import decode_page_shared

    pages, _ = _page_files(tmp_path)
    expected = [load_rgba(p) for p in pages]
    with open_workers(2) as workers:
        workers.submit(abs, -1).result()  # the workers are forked before this process's decoder is watched
        decoded_here = []
        real = decode.load_rgba
        monkeypatch.setattr(decode, "load_rgba", lambda path: decoded_here.append(path) or real(path))
        store = PageStore()
        store.prefetch = PagePrefetch(lambda path: workers.submit(decode_page_shared, path, first=True),
                                      window=2)  # the third waits for a turn
        store.decode_ahead(pages + pages[:1])
        for path, want in zip(pages, expected):
            got = store.page(path)
            assert np.array_equal(got, want) and got.dtype == np.uint8 and not got.flags.writeable
        assert store.page(pages[0]) is store.page(pages[0])
        assert decoded_here == [] and store.decodes == 3
        store.release()
        assert store.page(pages[1]) is not None and decoded_here == [pages[1]]  # released: decoded here again
        store.release()
        del got
    assert memory_files_left() == []


def test_a_decode_ahead_that_fails_or_is_lost_is_done_again_here_with_the_same_result(tmp_path):
    """A worker lost under a page (twice), or one that cannot decode it: this process decodes the
    page itself, so its texels, or its error, are what they are without workers."""
    from spinemesh.cluster import open_workers
    from spinemesh.images.pages import PagePrefetch
    from spinemesh.upgrade.plan import decode_page_shared

    pages, bad = _page_files(tmp_path)
    with pytest.raises(ImageError) as alone:
        load_rgba(bad)
    with open_workers(2) as workers:
        lost = []
        store = PageStore()
        store.prefetch = PagePrefetch(
            lambda path: lost.append(path) or workers.submit(_lose_the_worker, path, first=True), window=4)
        store.decode_ahead(pages[:1])
        assert np.array_equal(store.page(pages[0]), load_rgba(pages[0])) and lost == pages[:1]
        store = PageStore()
        store.prefetch = PagePrefetch(lambda path: workers.submit(decode_page_shared, path), window=4)
        store.decode_ahead([bad, pages[1]])
        with pytest.raises(ImageError) as ahead:
            store.page(bad)
        assert str(ahead.value) == str(alone.value)
        assert np.array_equal(store.page(pages[1]), load_rgba(pages[1]))
        assert store.decodes == 1  # the page that failed was not stored
        store.decode_ahead([pages[2]])
        store.release()  # asked for, never taken: dropped
    assert memory_files_left() == []


def test_an_untrimmed_region_is_a_view_of_its_page_and_a_trimmed_one_a_copy():
    page = np.arange(6 * 6 * 4, dtype=np.uint8).reshape(6, 6, 4)
    whole = parse_atlas("p.png\n\tsize: 6, 6\nr\n\tbounds: 1, 1, 3, 2\n").regions[0]
    trimmed = parse_atlas("p.png\n\tsize: 6, 6\nr\n\tbounds: 1, 1, 3, 2\n\toffsets: 0, 0, 4, 2\n").regions[0]
    assert np.shares_memory(cut_region(page, whole), page)
    out = cut_region(page, trimmed)
    assert not np.shares_memory(out, page) and out.shape == (2, 4, 4)
    assert np.array_equal(out[:, :3], cut_region(page, whole))


# --- decoders: imagecodecs where it gives Pillow's texels, Pillow elsewhere -------------------

def _pillow_rgba(path) -> np.ndarray:
    """The texels Pillow gives (what ``load_rgba`` returned before imagecodecs decoded PNG and WebP)."""
    with Image.open(path) as im:
        return np.asarray(im.convert("RGBA"))


def _chunk(kind: bytes, data: bytes, crc_delta: int = 0) -> bytes:
    """One PNG chunk, its CRC off by ``crc_delta``."""
    import struct
    import zlib

    crc = (zlib.crc32(kind + data) + crc_delta) & 0xFFFFFFFF
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)


def _png_chunks(path, width: int, height: int, depth: int, colour: int, rows: bytes, interlace: int = 0,
                extra: bytes = b"", idat_crc_delta: int = 0, idat: bytes | None = None) -> None:
    """A PNG from its parts (for kinds Pillow does not write: 16-bit RGBA, interlaced, a bad checksum);
    ``idat``: the image data chunks as they are, instead of one of ``rows`` compressed."""
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, interlace)
    if idat is None:
        idat = _chunk(b"IDAT", zlib.compress(rows), idat_crc_delta)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + extra + idat + _chunk(b"IEND", b""))


def _png_kinds(tmp_path) -> dict:
    """name -> (file, whether imagecodecs decodes it): every colour type and depth atlases may hold."""
    rng = np.random.default_rng(5)
    rgba = rng.integers(0, 256, (13, 21, 4), dtype=np.uint8)
    rgba[2:5, 3:9, 3] = 0
    kinds = {}

    def save(name, image, fast, **options):
        path = tmp_path / f"{name}.png"
        image.save(path, **options)
        kinds[name] = (path, fast)

    save("rgba", Image.fromarray(rgba), True)
    save("rgb", Image.fromarray(rgba[..., :3]), True)
    save("rgb-trns", Image.fromarray(rgba[..., :3]), True, transparency=tuple(int(v) for v in rgba[0, 0, :3]))
    palette = Image.fromarray(rgba).quantize(37)
    save("palette", palette, True)
    alphas = bytes(range(0, 250, 10))  # tRNS shorter than the palette: the rest opaque
    save("palette-trns", palette, True, transparency=alphas)
    save("grey", Image.fromarray(rgba[..., 0]), True)
    save("grey-trns", Image.fromarray(rgba[..., 0]), True, transparency=int(rgba[0, 0, 0]))
    save("grey-alpha", Image.fromarray(rgba[..., [0, 3]], "LA"), True)
    save("grey-1bit", Image.fromarray(rgba[..., 0] > 128), False)
    save("grey-4bit", Image.fromarray(rgba[..., 0] // 17 * 17), False, bits=4)
    save("grey-16bit", Image.fromarray(rgba[..., 0].astype(np.uint16) * 257), False)
    rows16 = b"".join(b"\0" + row.astype(">u2").tobytes() for row in rgba.astype(np.uint16) * 251)
    _png_chunks(tmp_path / "rgba-16bit.png", 21, 13, 16, 6, rows16)
    kinds["rgba-16bit"] = (tmp_path / "rgba-16bit.png", False)
    # one pixel interlaced: Adam7's first pass holds it, the other six are empty
    _png_chunks(tmp_path / "interlaced.png", 1, 1, 8, 6, b"\0" + bytes(rgba[0, 0]), interlace=1)
    kinds["interlaced"] = (tmp_path / "interlaced.png", False)
    return kinds


def test_every_png_kind_decodes_to_pillows_texels(tmp_path):
    """8-bit PNG of every colour type goes through imagecodecs; 1- to 4-bit, 16-bit and interlaced
    PNG through Pillow; the texels are Pillow's either way (palettes and tRNS included)."""
    from spinemesh.images.decode import _codec_rgba

    for name, (path, fast) in _png_kinds(tmp_path).items():
        with Image.open(path) as im:
            assert (_codec_rgba(im) is not None) == fast, name
        got = load_rgba(path)
        assert got.shape[2] == 4 and not got.flags.writeable, name
        assert np.array_equal(got, _pillow_rgba(path)), name


def test_a_png_imagecodecs_refuses_is_decoded_by_pillow_as_before(tmp_path):
    """libpng checks the IDAT checksum, Pillow does not: such a file gives Pillow's texels, not an error."""
    rgba = np.arange(4 * 3 * 4, dtype=np.uint8).reshape(4, 3, 4)
    rows = b"".join(b"\0" + row.tobytes() for row in rgba)
    _png_chunks(tmp_path / "bad-crc.png", 3, 4, 8, 6, rows, idat_crc_delta=1)
    assert np.array_equal(load_rgba(tmp_path / "bad-crc.png"), _pillow_rgba(tmp_path / "bad-crc.png"))
    _png_chunks(tmp_path / "short.png", 3, 4, 8, 6, rows[:20])  # too few rows: an error either way
    with pytest.raises(ImageError, match="short.png"):
        load_rgba(tmp_path / "short.png")


def test_webp_still_through_imagecodecs_animated_through_pillow(tmp_path):
    """Lossless and lossy still WebP decode to Pillow's texels; an animated one to its first frame."""
    from spinemesh.images.decode import _codec_rgba

    yy, xx = np.mgrid[0:24, 0:32]
    rgba = np.stack([xx * 8, yy * 10, (xx + yy) * 4, np.where(xx > 4, 255, 0)], -1).astype(np.uint8)
    frames = [Image.fromarray(rgba), Image.fromarray(rgba[::-1].copy())]
    frames[0].save(tmp_path / "lossless.webp", lossless=True)
    frames[0].save(tmp_path / "lossy.webp", quality=80)
    Image.fromarray(rgba[..., :3]).save(tmp_path / "opaque.webp", quality=80)
    frames[0].save(tmp_path / "animated.webp", save_all=True, append_images=frames[1:], lossless=True)
    for name, fast in (("lossless", True), ("lossy", True), ("opaque", True), ("animated", False)):
        path = tmp_path / f"{name}.webp"
        with Image.open(path) as im:
            assert (_codec_rgba(im) is not None) == fast, name
        assert np.array_equal(load_rgba(path), _pillow_rgba(path)), name


def _kinds_of_real_images(roots, per_kind: int = 4) -> list:
    """A few files of each kind among the real images: format, and for PNG its bit depth, colour
    type and whether it holds tRNS (``benchmarks/bench_speed.py --only decode`` checks them all)."""
    kinds: dict = {}
    for path in sorted(p for root in roots for p in root.rglob("*")
                       if p.suffix.lower() in (".png", ".webp", ".jpg", ".jpeg") and p.is_file()):
        head = path.read_bytes()[:4096]
        kind = (path.suffix.lower(), head[24:26], b"tRNS" in head) if head[12:16] == b"IHDR" else path.suffix
        kinds.setdefault(kind, []).append(path)
    return [p for paths in kinds.values() for p in paths[:per_kind]]


def test_real_page_images_of_every_kind_decode_to_pillows_texels(examples, corpus):
    """RGBA, RGB and palette PNG (with tRNS), WebP and JPEG of the examples and the corpus."""
    files = _kinds_of_real_images((examples, corpus))
    assert len(files) >= 12
    differ = [str(p) for p in files if not np.array_equal(load_rgba(p), _pillow_rgba(p))]
    assert not differ, differ


def test_turned_clockwise_is_numpys_turn_copied():
    """OpenCV turns bytes and booleans of up to four channels, numpy anything else: the values
    of np.rot90(values, -quarters) either way, contiguous, from views whose rows lie apart."""
    from spinemesh.images.regions import turned_clockwise

    rng = np.random.default_rng(0)
    for shape in [(5, 7), (5, 7, 1), (5, 7, 2), (5, 7, 4), (5, 7, 5), (1, 1, 4), (0, 3, 4)]:
        for dtype in (np.uint8, bool, np.int32):
            page = rng.integers(0, 2 if dtype is bool else 200, (shape[0] + 3, shape[1] + 4) + shape[2:]).astype(dtype)
            for values in (page[1:1 + shape[0], 2:2 + shape[1]], page[::-1], page[:, ::2]):
                for quarters in range(-1, 6):
                    turned = turned_clockwise(values, quarters)
                    expected = np.rot90(values, -quarters)
                    assert turned.dtype == expected.dtype and turned.flags.c_contiguous
                    assert np.array_equal(turned, expected)


def test_part_content_id_is_equal_exactly_for_equal_texels_and_masks():
    """The key of a part (and of its mask) depends on the values only: a view of a page whose rows
    lie apart, a turned copy and a contiguous copy of the same texels agree; one texel or one
    mask bit apart, or the same texels elsewhere, they differ."""
    from spinemesh.images.content_ids import content_id, part_content_id

    rng = np.random.default_rng(1)
    page = rng.integers(0, 256, (40, 50, 4)).astype(np.uint8)
    view = page[5:25, 10:40]
    copy = view.copy()
    mask = rng.random((20, 30)) < 0.5
    box = (3, 4, 30, 20)
    assert part_content_id((60, 70, 4), box, view) == part_content_id((60, 70, 4), box, copy)
    assert part_content_id((60, 70, 4), box, view) == content_id(
        np.pad(copy, ((4, 36), (3, 37), (0, 0))), box)  # without a mask: content_id's key
    turned = np.rot90(page, -1)[5:25, 10:40]
    assert part_content_id((60, 70, 4), box, turned) == part_content_id((60, 70, 4), box, turned.copy())
    with_mask = part_content_id((60, 70, 4), box, copy, mask)
    assert with_mask == part_content_id((60, 70, 4), box, view, mask[:, ::-1][:, ::-1])
    assert with_mask != part_content_id((60, 70, 4), box, copy)
    flipped = mask.copy()
    flipped[19, 29] = not flipped[19, 29]  # the last bit: packed bits end there
    assert with_mask != part_content_id((60, 70, 4), box, copy, flipped)
    changed = copy.copy()
    changed[0, 0, 2] ^= 1
    assert part_content_id((60, 70, 4), box, changed) != part_content_id((60, 70, 4), box, copy)
    assert part_content_id((60, 70, 4), (4, 4, 30, 20), copy) != part_content_id((60, 70, 4), box, copy)
    # a mask of other shape whose packed bits are the same bytes
    assert part_content_id((60, 70, 4), box, copy, np.zeros((8, 1), bool)) != \
        part_content_id((60, 70, 4), box, copy, np.zeros((1, 8), bool))


def test_lazy_masks_are_the_eager_defaults():
    """A straight page's region without bleed leaves its masks to from_stored's defaults: the
    same masks as alpha > 0 and alpha > FAINT_TEXEL, made when asked for, each on its own."""
    from spinemesh.images.sources import RegionImage
    from spinemesh.images.texels import FAINT_TEXEL

    rng = np.random.default_rng(2)
    rgba = rng.integers(0, 5, (6, 9, 4)).astype(np.uint8)
    image = RegionImage.from_stored(rgba, (10, 12, 4), (1, 2, 10, 8), 1.0, "a", "p.png")
    shown = image.stored_mask(shown=True)
    assert np.array_equal(shown, rgba[..., 3] > FAINT_TEXEL) and image.stored[1] is None  # drawn not made
    drawn, shown_again = image.stored_masks()
    assert np.array_equal(drawn, rgba[..., 3] > 0) and shown_again is shown
    assert not (shown & ~drawn).any()
    assert np.array_equal(image.shown[2:8, 1:10], shown) and not image.shown[:2].any()


def test_shown_texels_of_premultiplied_rectangles_is_the_channel_maximum():
    """On a premultiplied page a texel shows where any channel exceeds FAINT_TEXEL: OpenCV's
    threshold on rectangles of a page (rows apart) gives what the channel maximum gives."""
    from spinemesh.images.texels import FAINT_TEXEL, shown_texels

    rng = np.random.default_rng(3)
    for high in (6, 256):
        page = rng.integers(0, high, (30, 40, 4)).astype(np.uint8)
        for stored in (page, page[3:20, 5:31], np.rot90(page[3:20, 5:31]), page[:0]):
            assert np.array_equal(shown_texels(stored, True), channel_max(stored) > FAINT_TEXEL)


def test_alpha_above_compares_words_as_the_alpha_plane_does():
    """Every threshold, on a page, a rectangle of it (rows apart), a turned view and other dtypes;
    foreground (alpha >= t) agrees with it for whole and fractional thresholds."""
    from spinemesh.foreground import alpha_above, foreground

    rng = np.random.default_rng(4)
    page = rng.integers(0, 256, (17, 23, 4)).astype(np.uint8)
    page[0, :, 3] = np.arange(23) * 11 + 1  # alphas next to each threshold as well
    for texels in (page, page[2:15, 3:20], np.rot90(page), page[:0], page.astype(np.float32)):
        for threshold in (-1, 0, 1, 2, 127, 128, 254, 255, 256, np.uint8(8)):
            assert np.array_equal(alpha_above(texels, threshold), texels[..., 3] > threshold), threshold
        for threshold in (0, 1, 8, 8.5, 129, 255, 256):
            assert np.array_equal(foreground(texels, threshold), texels[..., 3] >= threshold), threshold


def _decoded_as_before(path):
    """What ``load_rgba`` gave for an 8-bit PNG before the stored rows: libpng's texels for the file
    as it is, else Pillow's, else the error's kind."""
    from spinemesh.images.decode import rgba_from_samples
    from spinemesh.images.png_rows import _imagecodecs

    codecs = _imagecodecs()
    try:
        return rgba_from_samples(codecs.png_decode(path.read_bytes()))
    except codecs.PngError:
        try:
            return _pillow_rgba(path)
        except (OSError, ValueError, SyntaxError, EOFError):
            return ImageError
    except ValueError:  # imagecodecs failing to word libpng's error (no image data at all)
        return ImageError


def _loaded(path):
    try:
        return load_rgba(path)
    except ImageError:
        return ImageError


def test_png_rows_inflated_by_libdeflate_give_libpngs_texels(tmp_path):
    """Pillow's and OpenCV's PNGs of every 8-bit kind, in one or many IDAT chunks and many stored
    blocks, give libpng's texels for the file; a broken CRC, Adler-32, zlib header, a second run
    of image data, too little or too much data leave the file to libpng and Pillow as before."""
    import zlib

    import cv2

    from spinemesh.images.png_rows import _imagecodecs, png_with_stored_rows

    png_decode = _imagecodecs().png_decode
    kinds = _png_kinds(tmp_path)
    yy, xx = np.mgrid[0:230, 0:310]  # 285 KB of RGBA rows: five stored blocks
    large = np.stack([xx % 256, yy, (xx * yy) % 253, np.where((xx - 150) ** 2 + (yy - 110) ** 2 < 9000, 255, xx % 7)],
                     -1).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "opencv.png"), cv2.cvtColor(large, cv2.COLOR_RGBA2BGRA))  # 8 KiB IDAT chunks
    kinds["opencv"] = (tmp_path / "opencv.png", True)
    Image.fromarray(large).save(tmp_path / "pillow-large.png")
    kinds["pillow-large"] = (tmp_path / "pillow-large.png", True)
    assert (tmp_path / "opencv.png").read_bytes().count(b"IDAT") > 3
    for name, (path, fast) in kinds.items():
        data = path.read_bytes()
        stored = png_with_stored_rows(data)
        assert (stored is None) == (name == "interlaced"), name  # every depth but interlaced rows
        if stored is not None:
            stored = stored.tobytes()
            at = stored.index(b"IDAT") + 4
            assert stored.count(b"IDAT") == 1 and stored[at:at + 2] == b"\x78\x01", name  # stored blocks
            assert np.array_equal(png_decode(stored), png_decode(data)), name
        assert np.array_equal(load_rgba(path), _pillow_rgba(path)), name

    rows = b"".join(b"\0" + row.tobytes() for row in large)
    stream = zlib.compress(rows, 6)
    parts = [stream[i:i + 5000] for i in range(0, len(stream), 5000)]
    broken = {
        # several IDAT chunks, one of them empty, and bytes after the zlib stream (libpng ignores them)
        "split": (True, b"".join(_chunk(b"IDAT", p) for p in parts[:2] + [b""] + parts[2:])),
        "trailing": (True, _chunk(b"IDAT", stream + b"\0\0")),
        "crc": (False, _chunk(b"IDAT", stream, 1)),
        "adler": (False, _chunk(b"IDAT", stream[:-1] + bytes([stream[-1] ^ 1]))),
        "window": (False, _chunk(b"IDAT", bytes([0x88, 0x1C]) + stream[2:])),  # a 64 KiB window
        "dictionary": (False, _chunk(b"IDAT", bytes([0x78, 0xBB]) + stream[2:])),
        "two-runs": (False, _chunk(b"IDAT", parts[0]) + _chunk(b"tEXt", b"a\0b")
                     + b"".join(_chunk(b"IDAT", p) for p in parts[1:])),
        "too-little": (False, _chunk(b"IDAT", zlib.compress(rows[:-310 * 4 - 1]))),
        "too-much": (False, _chunk(b"IDAT", zlib.compress(rows + b"\0" * 9))),
        "cut": (False, _chunk(b"IDAT", stream[:len(stream) // 2])),
        "missing": (False, b""),
    }
    for name, (fast, idat) in broken.items():
        path = tmp_path / f"{name}.png"
        _png_chunks(path, 310, 230, 8, 6, b"", idat=idat)
        assert (png_with_stored_rows(path.read_bytes()) is not None) == fast, name
        before, got = _decoded_as_before(path), _loaded(path)
        assert got is before if before is ImageError else np.array_equal(got, before), name
        if fast:
            assert np.array_equal(got, large), name
    # a header claiming 4000x4000 over a few rows' stream: too short to inflate to them, nothing allocated
    _png_chunks(tmp_path / "bomb.png", 4000, 4000, 8, 6, b"\0" * 16001 * 3)
    assert png_with_stored_rows((tmp_path / "bomb.png").read_bytes()) is None
    before = _decoded_as_before(tmp_path / "bomb.png")
    assert _loaded(tmp_path / "bomb.png") is before if before is ImageError \
        else np.array_equal(load_rgba(tmp_path / "bomb.png"), before)
