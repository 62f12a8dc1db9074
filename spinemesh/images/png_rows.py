"""A PNG's image data inflated by libdeflate into stored deflate blocks, for libpng to unfilter.

Separate from :mod:`.decode` because it is a format of its own (chunks, zlib, stored blocks,
bounded against hostile files) that a reader of the decode need not read: :mod:`.decode` calls
:func:`png_with_stored_rows` and hands libpng what it returns.
"""

from __future__ import annotations

import functools

import numpy as np

from ..limits import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE

#: Samples per pixel of each PNG colour type (grey, RGB, palette, grey + alpha, RGBA), and the
#: bit depths the format allows for it.
_PNG_SAMPLES = {0: (1, (1, 2, 4, 8, 16)), 2: (3, (8, 16)), 3: (1, (1, 2, 4, 8)), 4: (2, (8, 16)), 6: (4, (8, 16))}


#: Most bytes one stored deflate block holds (its length is 16 bits).
_STORED_BLOCK = 65_535


#: Most bytes deflate can make of one byte: a 258-byte match in two bits.
_MAX_INFLATE_RATIO = 1032


#: Most chunks :func:`png_with_stored_rows` reads before leaving a file to libpng as it is (a
#: 16 MB page written in libpng's 8 KiB IDAT chunks has about 2,000).
_MAX_PNG_CHUNKS = 100_000


def png_with_stored_rows(data: bytes | memoryview) -> np.ndarray | None:
    """The same PNG with its image data stored uncompressed, inflated by libdeflate; or None.

    libpng spends most of a page's decode in zlib's inflate. libdeflate inflates the same
    stream in a third to two thirds of zlib's time; handed the rows back in stored deflate
    blocks (level 0), libpng only copies them before unfiltering, and gives the texels it gives for the
    file. Every chunk but the image data is kept byte for byte, so libpng reads the same
    palette, transparency and colour information.

    Parameters
    ----------
    data : bytes or memoryview
        A PNG file.

    Returns
    -------
    ndarray, shape (N,), uint8, or None
        The bytes of the PNG with one IDAT chunk of stored blocks, with a valid Adler-32 and
        CRC. None (decode the file as it is) unless the file is well formed as far as this
        reads (:func:`_png_image_data`), its zlib header names a window of at most 32 KiB and
        no preset dictionary, and libdeflate inflates the stream, its Adler-32 checked, to
        exactly the filtered rows the header implies. Nothing is allocated before the
        header's size is checked against :mod:`spinemesh.limits`.

    Examples
    --------
    >>> import io
    >>> from PIL import Image
    >>> out = io.BytesIO()
    >>> Image.new("RGBA", (3, 2), (1, 2, 3, 4)).save(out, "PNG")
    >>> stored = png_with_stored_rows(out.getvalue())
    >>> Image.open(io.BytesIO(stored.tobytes())).getpixel((2, 1))
    (1, 2, 3, 4)
    >>> png_with_stored_rows(out.getvalue()[:-1]) is None  # IEND cut short
    True
    """
    import struct

    codecs = _imagecodecs()
    found = _png_image_data(data) if codecs.DEFLATE.available else None
    if found is None:
        return None
    size, idat = found
    view = memoryview(data)
    stream = view[idat[0][0]:idat[0][1]] if len(idat) == 1 else _joined(view, idat)
    if len(stream) < 6:
        return None
    cmf, flags = int(stream[0]), int(stream[1])
    if cmf & 0x0F != 8 or cmf >> 4 > 7 or (cmf << 8 | flags) % 31 or flags & 0x20:
        return None
    if size > _MAX_INFLATE_RATIO * len(stream):
        return None  # too short a stream for the rows (a bomb's header): nothing allocated for them
    blocks = -(-size // _STORED_BLOCK)
    packed = 2 + 5 * blocks + size + 4  # zlib header, each block's header, the rows, Adler-32
    start, tail = idat[0][0] - 8, view[idat[-1][1] + 4:]  # the IDAT run's first byte, what follows it
    out = np.empty(start + 8 + packed + 4 + len(tail), np.uint8)
    # The rows are inflated into the file's last bytes, then moved down block by block to
    # make room for the blocks' headers: no second buffer of rows, no second copy of them.
    rows_at = len(out) - size
    try:  # a zlib stream: libdeflate checks its Adler-32
        inflated = codecs.deflate_decode(stream, out=memoryview(out)[rows_at:])
    except codecs.DeflateError:
        return None
    if len(inflated) != size:
        return None
    adler = codecs.deflate_adler32(out[rows_at:])
    out[:start] = np.frombuffer(view[:start], np.uint8)
    out[start:start + 10] = np.frombuffer(struct.pack(">I4s", packed, b"IDAT") + b"\x78\x01", np.uint8)
    at = _stored_blocks_in_place(out, start + 10, rows_at, size)  # 78 01: a 32 KiB window, level 0
    out[at:at + 4] = np.frombuffer(struct.pack(">I", adler), np.uint8)
    out[at + 4:at + 8] = np.frombuffer(struct.pack(">I", codecs.deflate_crc32(out[start + 4:at + 4])), np.uint8)
    out[at + 8:] = np.frombuffer(tail, np.uint8)
    return out


def _joined(view: memoryview, spans: list[tuple[int, int]]) -> np.ndarray:
    """The bytes of ``view`` at each ``(start, end)`` of ``spans``, one after another (the zlib
    stream of a PNG's IDAT chunks), in a NumPy buffer (huge pages, as :func:`.decode._file_bytes`)."""
    out = np.empty(sum(end - start for start, end in spans), np.uint8)
    at = 0
    for start, end in spans:
        out[at:at + end - start] = np.frombuffer(view[start:end], np.uint8)
        at += end - start
    return out


def _png_image_data(data: bytes | memoryview) -> tuple[int, list[tuple[int, int]]] | None:
    """The filtered rows' size a PNG's header implies and where its IDAT chunks' data lie, or None.

    None unless IHDR comes first with a size within :mod:`spinemesh.limits`, a depth its colour
    type allows and no interlacing (interlaced rows come in seven passes: left to libpng), the
    IDAT chunks come one after another, and every chunk's CRC up to IEND holds, within
    :data:`_MAX_PNG_CHUNKS` chunks.

    Returns
    -------
    tuple or None
        ``(size, [(start, end), ...])``: the bytes of filtered rows, and each IDAT chunk's data
        as offsets into ``data``.
    """
    import struct

    crc32 = _imagecodecs().deflate_crc32
    if data[:16] != b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR" or len(data) < 33:
        return None
    width, height, depth, colour, compression, filtering, interlace = struct.unpack(">IIBBBBB", data[16:29])
    channels, depths = _PNG_SAMPLES.get(colour, (0, ()))
    if depth not in depths or compression or filtering or interlace or not (0 < width <= MAX_IMAGE_SIDE) \
            or not (0 < height <= MAX_IMAGE_SIDE) or width * height > MAX_IMAGE_PIXELS:
        return None
    view = memoryview(data)
    idat: list[tuple[int, int]] = []
    at = 8
    for _ in range(_MAX_PNG_CHUNKS):
        if at + 12 > len(data):
            return None  # cut short before IEND
        length, kind = struct.unpack(">I4s", data[at:at + 8])
        end = at + 8 + length
        if length > 0x7FFFFFFF or end + 4 > len(data) \
                or crc32(view[at + 4:end]) != int.from_bytes(data[end:end + 4], "big"):
            return None
        if kind == b"IDAT":
            if idat and idat[-1][1] + 4 != at:
                return None  # image data in two runs: libpng's call
            idat.append((at + 8, end))
        elif kind == b"IEND":
            return (height * (1 + (width * channels * depth + 7) // 8), idat) if idat else None
        at = end + 4
    return None


def _stored_blocks_in_place(out: np.ndarray, at: int, rows_at: int, size: int) -> int:
    """Move the ``size`` bytes of rows at ``out[rows_at:]`` down into stored deflate blocks from
    ``out[at]`` on (each a 5-byte header, then up to :data:`_STORED_BLOCK` bytes); the offset
    just past the last block. Each block lands below where its bytes lay and above where the
    next block's lie, so moving them in order overwrites nothing still to be moved."""
    for first in range(0, size, _STORED_BLOCK):
        n = min(_STORED_BLOCK, size - first)
        out[at + 5:at + 5 + n] = out[rows_at + first:rows_at + first + n]  # NumPy copies overlapping parts safely
        out[at:at + 5] = (first + n == size, n & 0xFF, n >> 8, ~n & 0xFF, (~n >> 8) & 0xFF)
        at += 5 + n
    return at


@functools.lru_cache(maxsize=1)
def _imagecodecs():
    """imagecodecs, imported on first use (start-up does not pay for it); its warnings
    (libpng's "iCCP: extra compressed data") are not printed unless the application logs them."""
    import logging

    import imagecodecs

    logging.getLogger("imagecodecs").addHandler(logging.NullHandler())
    return imagecodecs
