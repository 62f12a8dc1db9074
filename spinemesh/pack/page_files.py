"""Page files written losslessly: a packed page encoded in the format its name says (a palette
PNG as one, a page without alpha as RGB), a kept PNG page re-encoded smaller, and the one check
every page written passes, decoded back texel for texel (:func:`decoded_as`).

Separate from :mod:`.run` (which atlases are packed, and where they are written) because these
are functions of one page's texels and bytes.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from .atlas_pack import PackRefused
from .checks import check_eight_bits
from .page_colours import _CARRIED, colour_words, page_colour
from .png import (
    IHDR,
    OptimiserFailed,
    chunk_differences,
    chunk_meaning,
    optimized_png,
    png_chunks,
    png_differences,
    profile_misfit,
)

#: Page file formats written, by extension: (Pillow format, save options). Lossless only: a
#: packed page must hold the very texels the original held, and every page written is decoded
#: back first (:func:`encode_page`).
PAGE_FORMATS = {
    ".png": ("PNG", {}),
    # lossless effort 50 of 100: within 0.2% of the smallest file at half the time of 100
    ".webp": ("WEBP", {"lossless": True, "quality": 50, "method": 4, "exact": True}),
    # Pillow has no lossless AVIF (it ignores lossless=True and converts to YUV): the closest it
    # writes still changes texels by a step or two, so the decode-back check keeps such atlases
    ".avif": ("AVIF", {"quality": 100, "subsampling": "4:4:4"}),
}


def page_mode(page: bytes | Path):
    """How the original page (its file's bytes, or its path) stores colours: its palette, shape
    (n, 4) uint8 RGBA, for a palette PNG; ``"RGB"`` for a PNG without alpha, colour or grey (and
    without a transparent colour: one with a tRNS chunk has texels that are not opaque, written as RGBA);
    else None (RGBA)."""
    from PIL import Image

    with Image.open(io.BytesIO(page) if isinstance(page, bytes) else page) as im:
        if im.format == "PNG" and im.mode == "P":
            palette = im.getpalette() or []
            index = Image.new("P", (max(1, len(palette) // 3), 1))
            index.putdata(list(range(index.width)))
            index.putpalette(palette)
            if "transparency" in im.info:  # tRNS: alpha per entry, or one transparent entry
                index.info["transparency"] = im.info["transparency"]
            return np.asarray(index.convert("RGBA"))[0]
        # grey pages (of 1 to 8 bits) too: written as RGB, oxipng stores grey texels grey again
    return "RGB" if im.format == "PNG" and im.mode in ("RGB", "L", "1") and "transparency" not in im.info else None


def _as_palette(rgba: np.ndarray, lut: np.ndarray) -> tuple[bytes, np.ndarray] | None:
    """``rgba`` as a palette PNG with the palette ``lut`` (n, 4), and the texels it holds; None when a
    texel's colour is not in the palette.

    Packed texels are copies of the original page's, so a page a quantiser wrote as a palette
    PNG comes back as one (about a quarter of the bytes of RGBA). The empty background takes a
    transparent entry (black transparent if the palette has it; it is never sampled).
    """
    from PIL import Image

    keys = np.ascontiguousarray(lut).view(np.uint32).ravel()
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    texels = np.ascontiguousarray(rgba).view(np.uint32)[..., 0]
    if not (sorted_keys == 0).any():
        clear = np.flatnonzero(lut[:, 3] == 0)
        if clear.size == 0:
            return None
        texels = np.where(texels == 0, keys[clear[0]], texels)
    at = np.clip(np.searchsorted(sorted_keys, texels), 0, len(keys) - 1)
    if not (sorted_keys[at] == texels).all():
        return None
    image = Image.fromarray(order[at].astype(np.uint8), "P")
    image.putpalette(lut[:, :3].tobytes())
    buf = io.BytesIO()
    image.save(buf, format="PNG", transparency=lut[:, 3].tobytes())
    return buf.getvalue(), texels[..., None].view(np.uint8)


def _optimized(image, name: str, keep_format: bool = False, colour: tuple | None = None) -> bytes:
    """:func:`spinemesh.pack.png.optimized_png`, its failure (a third party's) the page's reason to stay."""
    try:
        return optimized_png(image, keep_format=keep_format, colour=colour)
    except OptimiserFailed as e:
        raise PackRefused(f"page {name!r}: the PNG optimiser failed ({e})") from None


@dataclass
class EncodedPage:
    """A page image ready to be written: its file's bytes and the texels they decode to."""

    data: bytes
    texels: np.ndarray  # (H, W, 4) uint8, decoded back from ``data``


def encode_page(rgba: np.ndarray, name: str, like=None, colour: tuple = ()) -> EncodedPage:
    """A page image in the file format its name says, proven lossless by decoding it back.

    ``like`` (:func:`page_mode` of the original page): a palette PNG is written with its
    palette when every texel's colour is in it, a page without alpha as RGB. Either way every
    texel comes back as it was, except all-zero ones (the empty background, never sampled),
    which come back as the palette's transparent entry or as opaque black.

    ``colour`` (:func:`page_colour` of the original pages, default none): the colour chunks the
    file carries (a WebP page its colour profile), checked on the bytes with the texels.

    Raises
    ------
    PackRefused
        For a format that cannot be written losslessly (JPEG has no alpha and loses texels), and
        for bytes that do not decode to the texels meant (Pillow's AVIF writer is never lossless:
        it converts to YUV whatever it is asked).
    """
    from PIL import Image, features

    ext = Path(name).suffix.lower()
    if ext not in PAGE_FORMATS:
        raise PackRefused(f"page {name!r}: {ext or 'no extension'} pages are kept (only PNG, WebP and AVIF "
                          "can be written without losing texels)")
    fmt, options = PAGE_FORMATS[ext]
    if fmt == "AVIF" and not features.check("avif"):
        raise PackRefused(f"page {name!r}: this Pillow cannot write AVIF")
    lost = [k for k, _ in colour if k not in _CARRIED[fmt]]
    if lost:
        raise PackRefused(f"page {name!r}: {fmt} cannot say what its original pages say of their colours "
                          f"({colour_words(tuple((k, b'') for k in lost))})")
    data = None
    expected = rgba
    if fmt == "PNG" and isinstance(like, np.ndarray):
        found = _as_palette(rgba, like)
        if found is not None:
            data, expected = found
    if data is not None:
        data = _optimized(data, name, colour=colour)
    else:
        image = rgba
        if fmt == "PNG" and isinstance(like, str) and like == "RGB":
            image = rgba[..., :3]  # the original had no alpha: every texel drawn is opaque
            expected = rgba.copy()
            expected[~rgba.any(axis=2), 3] = 255  # the empty background comes back opaque black
        if fmt == "PNG":
            data = _optimized(np.ascontiguousarray(image), name, colour=colour)
        else:
            profiles = [chunk_meaning(kind, body) for kind, body in colour if kind == b"iCCP"]
            profile = {"icc_profile": profiles[0]} if profiles else {}
            buf = io.BytesIO()
            Image.fromarray(np.ascontiguousarray(image)).save(buf, format=fmt, **options, **profile)
            data = buf.getvalue()
    return EncodedPage(data, decoded_as(data, expected, name, fmt, colour))


def decoded_as(data: bytes, expected: np.ndarray, name: str, fmt: str, colour: tuple | None = None) -> np.ndarray:
    """The texels the file ``data`` decodes to, when they are ``expected`` texel for texel, and
    it says what ``colour`` says of their colours.

    The one check every page written passes (packed pages, and kept pages re-encoded).

    Parameters
    ----------
    data : bytes
        The file to be written.
    expected : ndarray, shape (H, W, 4), uint8
        The texels it must hold.
    name, fmt
        The page (what errors name) and its format (``PNG``, ``WEBP``, ...).
    colour : tuple of (bytes, bytes), optional
        The colour chunks it must carry (:func:`page_colour`), compared by what they hold
        (:func:`spinemesh.pack.png.chunk_differences`). Default: not compared (a kept page
        re-encoded had all its chunks compared already, :func:`reencoded_page`).

    Returns
    -------
    ndarray, shape (H, W, 4), uint8, read-only

    Raises
    ------
    PackRefused
        When it does not decode, decodes to another size, any texel differs, or its colour
        chunks say otherwise.
    """
    from ..images.decode import decode_rgba

    if colour is not None:
        lost = chunk_differences(colour, page_colour(data))
        if lost:
            raise PackRefused(f"page {name!r}: the {fmt} written does not say what its original pages say of "
                              f"their colours ({', '.join(lost)} differ), so its pages are kept")
        misfit = profile_misfit(data) if fmt == "PNG" else ""
        if misfit:  # a grey page's profile on a palette page: said, but read by no one
            raise PackRefused(f"page {name!r}: the PNG written would carry {misfit}, so its pages are kept")

    try:
        back = decode_rgba(data, name)
    except SpineMeshError as e:
        raise PackRefused(f"page {name!r}: the {fmt} written does not decode ({e})") from None
    if back.shape != expected.shape:
        raise PackRefused(f"page {name!r}: the {fmt} written decodes to another size")
    differ = int(np.count_nonzero(np.ascontiguousarray(back).view(np.uint32)
                                  != np.ascontiguousarray(expected).view(np.uint32)))
    if differ:
        raise PackRefused(f"page {name!r}: {fmt} as written here does not come back texel for texel "
                          f"({differ:,} of {back.shape[0] * back.shape[1]:,} texels differ), so its pages are kept")
    return back


def reencoded_page(original: bytes, texels: np.ndarray, name: str) -> bytes:
    """A kept page's PNG file written anew by oxipng, losslessly, when that is strictly smaller.

    The file stores its texels as before (same colour type, bit depth and palette: a palette
    PNG stays one) and keeps every other chunk (gamma, colour profile, text): only the rows'
    filters and their compression change (:func:`spinemesh.pack.png.optimized_png`,
    ``keep_format``), and that is checked on the bytes (:func:`~spinemesh.pack.png.png_differences`)
    before they are decoded back and compared with ``texels``, texel for texel (:func:`decoded_as`).

    Parameters
    ----------
    original : bytes
        The page's file as exported.
    texels : ndarray, shape (H, W, 4), uint8
        What it decodes to (:func:`spinemesh.images.decode.load_rgba`).
    name : str
        The page's name in its atlas.

    Returns
    -------
    bytes
        The smaller file.

    Raises
    ------
    PackRefused
        Why the page is copied as it is: not a PNG file, 16 bits a channel (texels are compared at
        8), not smaller, another format or other chunks, or other texels.
    """
    chunks = png_chunks(original) if Path(name).suffix.lower() == ".png" else None
    if not chunks or chunks[0][0] != b"IHDR" or len(chunks[0][1]) != IHDR.size:
        raise PackRefused(f"page {name!r} is not a PNG file")
    check_eight_bits(original, name)
    data = _optimized(original, name, keep_format=True)
    if len(data) >= len(original):
        raise PackRefused(f"page {name!r} would not get smaller")
    changed = png_differences(original, data)
    if changed:
        raise PackRefused(f"page {name!r}: {changed}")
    decoded_as(data, texels, name, "PNG")
    return data
