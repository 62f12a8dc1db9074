"""PNG files as small as oxipng makes them, losslessly, in any process.

oxipng (through ``pyoxipng``, MIT) compresses on rayon's pool of threads, made in a process the
first time it runs there. A process forked after that has a copy of the pool but none of its
threads, and oxipng then waits for them for ever (seen in a worker forked under pytest). So a
process that inherited a used pool by fork runs oxipng in a helper process of its own, a new
interpreter (never forked) started on first need and kept while the process lives, which ends
when its pipe closes; every other process runs it in place.
"""

from __future__ import annotations

import os
import struct
import sys
import zlib

import numpy as np

#: oxipng's effort (0-6). Level 2 took a packed 2048x2048 page from 2.66 MB, as Pillow writes it
#: by default, to 1.78 MB; levels 3 and 4 saved under 1% more for 2 to 3 times the time
#: (docs/benchmarks/pack.md).
LEVEL = 2

_used_here = False  # oxipng ran in this process: rayon's pool of threads lives here
_inherited = False  # this process was forked from one where it had run: the pool's threads are missing
_helper = None  # the helper process that compresses for an _inherited one (subprocess.Popen)


def _after_fork_in_child() -> None:
    global _used_here, _inherited, _helper
    _inherited = _inherited or _used_here
    _used_here, _helper = False, None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


#: oxipng's options that would change how a PNG file stores its texels (colour type, bit depth,
#: palette entries and their order): off where a file is re-encoded as it is (``keep_format``).
#: Measured on 12 corpus pages: the same bytes within 0.1% with them on or off.
_FORMAT_REDUCTIONS = ("bit_depth_reduction", "color_type_reduction", "palette_reduction", "grayscale_reduction")


class OptimiserFailed(Exception):
    """oxipng could not optimise an image (its error, named), or its helper process ended."""


def _compress(image, shape, keep_format: bool = False) -> bytes:
    """oxipng of a PNG file's bytes (``shape`` None) or of raw RGBA / RGB texels of ``shape`` (h, w, channels).

    Raises :class:`OptimiserFailed` for what oxipng refuses (a file it cannot read, texels that
    do not fit the shape) or has no memory for."""
    import oxipng

    try:
        if shape is None:
            kept = dict.fromkeys(_FORMAT_REDUCTIONS, False) if keep_format else {}
            return oxipng.optimize_from_memory(bytes(image), level=LEVEL, **kept)
        h, w, channels = shape
        color = oxipng.ColorType.rgba() if channels == 4 else oxipng.ColorType.rgb(None)
        return oxipng.RawImage(image, w, h, color_type=color).create_optimized_png(level=LEVEL)
    except (oxipng.PngError, MemoryError) as e:
        raise OptimiserFailed(f"{type(e).__name__}: {e}") from None


#: A request to the helper: its data's length, the texels' shape (-1s for a PNG file's bytes), keep_format.
_REQUEST = struct.Struct("<qqqqq")
#: Its answer: the PNG's length (negative: the length of an error message instead).
_ANSWER = struct.Struct("<q")


def serve() -> None:
    """The helper's loop: requests on stdin, PNG files on stdout, until stdin closes (its parent ended)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is its parent's to handle
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    while True:
        head = stdin.read(_REQUEST.size)
        if len(head) < _REQUEST.size:
            return
        size, h, w, channels, keep_format = _REQUEST.unpack(head)
        data = stdin.read(size)
        try:
            out = _compress(data, None if h < 0 else (h, w, channels), bool(keep_format))
            stdout.write(_ANSWER.pack(len(out)) + out)
        except OptimiserFailed as e:  # handed back to the caller, which raises it
            message = str(e).encode()
            stdout.write(_ANSWER.pack(-len(message)) + message)
        stdout.flush()


def _in_helper(data: bytes, shape, keep_format: bool) -> bytes:
    """:func:`_compress` in the helper process (started on first use)."""
    import subprocess
    from pathlib import Path

    global _helper
    if _helper is None or _helper.poll() is not None:
        root = str(Path(__file__).resolve().parents[2])
        code = f"import sys; sys.path.insert(0, {root!r}); from spinemesh.pack.png import serve; serve()"
        _helper = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    h, w, channels = shape if shape is not None else (-1, -1, -1)
    _helper.stdin.write(_REQUEST.pack(len(data), h, w, channels, int(keep_format)) + data)
    _helper.stdin.flush()
    head = _helper.stdout.read(_ANSWER.size)
    if len(head) < _ANSWER.size:
        raise OptimiserFailed(f"its process ended (exit status {_helper.wait()})")
    (size,) = _ANSWER.unpack(head)
    answer = _helper.stdout.read(abs(size))
    if size < 0:
        raise OptimiserFailed(answer.decode(errors="replace"))
    return answer


def optimized_png(image: np.ndarray | bytes, keep_format: bool = False,
                  colour: tuple[tuple[bytes, bytes], ...] | None = None) -> bytes:
    """A PNG file of ``image``, as small as oxipng makes it at :data:`LEVEL`, losslessly.

    Parameters
    ----------
    image : ndarray, shape (H, W, 4) or (H, W, 3), uint8; or bytes
        Texels (RGBA or RGB), or a PNG file already encoded (a palette PNG: its palette is kept,
        or reduced where entries go unused).
    keep_format : bool, default False
        With a PNG file: store its texels as the file does (same colour type, bit depth, palette
        in the same order), only the rows' filters and compression chosen anew. Its other
        chunks (gamma, colour profile, text) are kept either way.
    colour : tuple of (bytes, bytes), optional
        Colour chunks to carry, ``(type, data)`` (:func:`colour_chunks` of the page the texels
        come from): the file returned has these and no other (:func:`with_colour_chunks`).
        Default: texels get none, a PNG file keeps its own.

    Returns
    -------
    bytes
        Every colour of every texel kept, transparent ones included (no alpha optimisation);
        oxipng stores the texels with fewer bits (a palette, grey, fewer bits per channel) only
        where that loses nothing. Callers writing what a runtime reads decode it back first
        (:func:`spinemesh.pack.page_files.encode_page`).
    """
    global _used_here
    if isinstance(image, np.ndarray):
        data, shape = np.ascontiguousarray(image).tobytes(), image.shape
    else:
        data, shape = bytes(image), None
    if not _inherited:
        _used_here = True
        out = _compress(data, shape, keep_format)
    else:
        out = _in_helper(data, shape, keep_format)
    return out if colour is None else with_colour_chunks(out, colour)


#: The PNG file signature, then each chunk: its data's length and its type, the data, a CRC.
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
CHUNK_HEAD = struct.Struct(">I4s")
#: IHDR's data: width, height, bit depth, colour type, compression, filter method, interlace.
IHDR = struct.Struct(">IIBBBBB")
#: Most chunks read from one file (a page has a handful; IDAT may be split in many).
MAX_CHUNKS = 100_000
#: Chunks whose data is zlib-compressed after a name ending in a zero byte and a method byte: an
#: optimiser may compress it anew, so they are compared by what they hold.
_COMPRESSED = (b"iCCP", b"zTXt")

def png_bit_depth(data: bytes) -> int | None:
    """Bits a channel (a palette index's bits for a palette PNG) of a PNG file, from its
    header; None when ``data`` is not a PNG file that starts with one."""
    if not data.startswith(PNG_SIGNATURE) or len(data) < len(PNG_SIGNATURE) + CHUNK_HEAD.size + IHDR.size:
        return None
    length, kind = CHUNK_HEAD.unpack_from(data, len(PNG_SIGNATURE))
    if kind != b"IHDR" or length != IHDR.size:
        return None
    return IHDR.unpack_from(data, len(PNG_SIGNATURE) + CHUNK_HEAD.size)[2]


def png_file_bit_depth(path) -> int | None:
    """:func:`png_bit_depth` of the file at ``path``, from its first bytes only; None when it
    cannot be read or is not a PNG file."""
    try:
        with open(path, "rb") as f:
            return png_bit_depth(f.read(len(PNG_SIGNATURE) + CHUNK_HEAD.size + IHDR.size))
    except OSError:
        return None


def png_chunks(data: bytes) -> list[tuple[bytes, bytes]] | None:
    """A PNG file's chunks in order, ``(type, data)``, up to IEND; None when ``data`` is not one
    (no signature, cut short, more than :data:`MAX_CHUNKS`). CRCs are not checked (the decoder does)."""
    if not data.startswith(PNG_SIGNATURE):
        return None
    chunks, at = [], len(PNG_SIGNATURE)
    for _ in range(MAX_CHUNKS):
        if at + CHUNK_HEAD.size > len(data):
            return None
        length, kind = CHUNK_HEAD.unpack_from(data, at)
        start, end = at + CHUNK_HEAD.size, at + CHUNK_HEAD.size + length
        if end + 4 > len(data):
            return None
        chunks.append((kind, data[start:end]))
        if kind == b"IEND":
            return chunks
        at = end + 4
    return None


def png_file_cut_short(path) -> int | None:
    """Where a PNG file at ``path`` is cut short: the byte at which its chunks (walked by their
    heads, seeking over their data, at most :data:`MAX_CHUNKS`) stop before IEND; None when
    they reach IEND, or when it is not a PNG file (its decoder says what is wrong then).
    Reads 8 bytes a chunk, whatever the file's size."""
    try:
        with open(path, "rb") as f:
            if f.read(len(PNG_SIGNATURE)) != PNG_SIGNATURE:
                return None
            size, at = os.fstat(f.fileno()).st_size, len(PNG_SIGNATURE)
            for _ in range(MAX_CHUNKS):
                head = f.read(CHUNK_HEAD.size)
                if len(head) < CHUNK_HEAD.size:
                    return at
                length, kind = CHUNK_HEAD.unpack(head)
                if kind == b"IEND":
                    return None
                at += CHUNK_HEAD.size + length + 4
                if at > size:
                    return size
                f.seek(at)
    except OSError:
        return None
    return None

def chunk_meaning(kind: bytes, body: bytes) -> bytes:
    """What a chunk says, whatever its compression: a compressed chunk's inflated data, after its
    name for a text (a colour profile's name is a label, which oxipng renames ``icc``)."""
    if kind in _COMPRESSED:
        name, _, rest = body.partition(b"\0")
        try:  # bounded: a colour profile or a text is small; more is not the same chunk anyway
            data = zlib.decompressobj().decompress(rest[1:], 1 << 26)
        except zlib.error:
            return body
        return data if kind == b"iCCP" else name + b"\0" + data
    return body


def png_differences(before: bytes, after: bytes) -> str:
    """How ``after`` (a PNG file re-encoded from ``before``) stores its image otherwise than
    ``before`` does, in words; empty when only how its texels are compressed changed.

    Compared: the header (size, bit depth, colour type, interlacing), the palette and its
    transparency, and every other chunk but the image data, in order, by what it holds
    (gamma, chromaticities, sRGB intent, colour profile, significant bits, text, ...: a
    browser or an engine that colour-manages a page reads them); a colour profile by its data,
    not its name.
    """
    a, b = png_chunks(before), png_chunks(after)
    if a is None or b is None:
        return "not a whole PNG file"
    if a[0][0] != b"IHDR" or b[0][0] != b"IHDR" or a[0][1] != b[0][1]:
        return "its header (size, bit depth, colour type or interlacing) would change"
    changed = chunk_differences([(k, v) for k, v in a if k != b"IDAT"], [(k, v) for k, v in b if k != b"IDAT"])
    if changed:
        return f"its chunks besides the image data would change ({', '.join(changed)})"
    return ""


def chunk_differences(before, after) -> list[str]:
    """The types of the chunks that say otherwise in ``after`` than in ``before`` (lists of
    ``(type, data)``), each compared by what it holds (a colour profile by its data, not its
    name); ``["order"]`` when only their order differs; empty when they say the same.

    The one chunk comparison: of a page re-encoded as it is (:func:`png_differences`) and of
    the colour chunks a page written anew carries (:func:`spinemesh.pack.page_files.decoded_as`).
    """
    a = [(k, chunk_meaning(k, v)) for k, v in before]
    b = [(k, chunk_meaning(k, v)) for k, v in after]
    if a == b:
        return []
    return sorted({k.decode("latin-1") for k in {x[0] for x in set(a) ^ set(b)}}) or ["order"]


#: Chunks that say what colours a PNG file's texels stand for: colour profile, sRGB rendering
#: intent, gamma, chromaticities, coding-independent code points, mastering display and light
#: levels. A browser or an engine that manages colour reads them, so a page written from other
#: pages' texels carries theirs. In the order written, all before the palette and image data, as
#: the PNG specification asks. (tRNS is part of how texels are stored: the palette path writes it,
#: an RGB page with one is written as RGBA; pHYs, text and times say nothing of colours.)
COLOUR_CHUNKS = (b"iCCP", b"sRGB", b"gAMA", b"cHRM", b"cICP", b"mDCv", b"cLLi")


def colour_chunks(data: bytes) -> tuple[tuple[bytes, bytes], ...] | None:
    """A PNG file's colour chunks (:data:`COLOUR_CHUNKS`), ``(type, data)``, in that order (several of
    one type, which no valid file has, in the file's order); None when ``data`` is not a PNG file."""
    chunks = png_chunks(data)
    if chunks is None:
        return None
    return tuple(c for kind in COLOUR_CHUNKS for c in chunks if c[0] == kind)


#: PNG colour types of grey texels (grey, grey and alpha); the others hold colours.
_GREY_TYPES = (0, 4)


def profile_misfit(data: bytes) -> str:
    """Why the colour profile of the PNG file ``data`` is one its texels cannot carry, or ``""``.

    The PNG specification allows a grey (``GRAY``) profile on grey texels and an ``RGB`` one on
    colour texels (palette included); libpng and browsers ignore any other, so the texels are
    shown as sRGB: a grey page's profile carried onto a palette page, or a CMYK JPEG's onto an
    RGBA image, is a profile dropped.
    """
    chunks = png_chunks(data)
    if not chunks or chunks[0][0] != b"IHDR" or len(chunks[0][1]) < 10:
        return ""
    grey = chunks[0][1][9] in _GREY_TYPES
    for kind, body in chunks:
        if kind == b"iCCP":
            space = chunk_meaning(kind, body)[16:20]
            if space != (b"GRAY" if grey else b"RGB "):
                said = space.decode("latin-1").strip() or "no"
                return (f"a colour profile of the {said} colour space on {'grey' if grey else 'colour'} texels, "
                        "which PNG readers ignore")
    return ""


def png_chunk(kind: bytes, body: bytes) -> bytes:
    """One chunk as a file stores it: length, type, data, CRC of type and data."""
    return CHUNK_HEAD.pack(len(body), kind) + body + struct.pack(">I", zlib.crc32(body, zlib.crc32(kind)))


def with_colour_chunks(data: bytes, colour: tuple[tuple[bytes, bytes], ...]) -> bytes:
    """The PNG file ``data`` with ``colour`` (``(type, data)`` chunks) as its colour chunks, right
    after its header, in place of any it had; everything else byte for byte.

    Raises
    ------
    ValueError
        When ``data`` is not a whole PNG file starting with its header.
    """
    chunks = png_chunks(data)
    if not chunks or chunks[0][0] != b"IHDR":
        raise ValueError("not a whole PNG file")
    out = [PNG_SIGNATURE, png_chunk(*chunks[0])]
    out += [png_chunk(kind, body) for kind, body in colour]
    out += [png_chunk(kind, body) for kind, body in chunks[1:] if kind not in COLOUR_CHUNKS]
    return b"".join(out)
