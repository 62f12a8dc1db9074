"""Original-size images of attachments, from atlas pages or from a plain images folder.

An atlas stores each image trimmed of transparent borders, possibly rotated, possibly
premultiplied and possibly scaled. :class:`AtlasImages` undoes all of that except the
scale: it returns the image at its original size *in atlas pixels* and reports the page
scale, so that ``skeleton units = atlas pixels / scale``.

:class:`FolderImages` reads the unpacked images the Spine editor works from
(``images/<path>.png``), so a skeleton can be processed without any atlas.
"""

from __future__ import annotations

import functools
import struct
import warnings
from collections import OrderedDict
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from .atlas import Atlas, AtlasRegion, RegionGeometry, read_atlas
from .errors import AtlasError, ImageError, UnsafePathError
from .files.inside import resolve_inside
from .files.names import portable_name
from .files.walk import walk_files
from .foreground import alpha_above, texels_as_words
from .limits import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, check_image_size
from .memory import image_memory

#: What opening an image that Pillow cannot read raises (a header cut short, broken or too large).
UNREADABLE_IMAGE = (OSError, ValueError, SyntaxError, EOFError, Image.DecompressionBombError)

#: Image file extensions looked for in an images folder, in order of preference.
IMAGE_EXTENSIONS = (".png", ".webp", ".avif", ".jpg", ".jpeg")

#: The only formats Pillow is allowed to decode: what atlases and editor images use. Others
#: (TIFF, PSD, EPS, which would even start Ghostscript) are refused whatever a file is named.
IMAGE_FORMATS = ("PNG", "WEBP", "AVIF", "JPEG")


@functools.lru_cache(maxsize=None)
def _decodable_formats() -> tuple[str, ...]:
    Image.init()
    return tuple(f for f in IMAGE_FORMATS if f in Image.OPEN)


class RegionImage:
    """An attachment image at its original size.

    Attributes
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
        Straight (not premultiplied) RGBA, with stripped whitespace restored.
    scale : float
        Image pixels per skeleton unit (the atlas page's ``scale:``; 1 for image folders).
    name : str
        The region or image path it was looked up by.
    source : str
        The file the pixels came from (page image or image file).
    content : tuple of int
        ``(x0, y0, x1, y1)``: the part of the original image that the atlas actually stores
        (the rest was stripped whitespace). Anything drawn outside it samples whatever lies
        next to the region on the page. The whole image for an images folder.
    drawn : ndarray, shape (H, W), bool
        Texels a runtime draws anything with: alpha > 0, or on a premultiplied page any
        channel > 0 (a premultiplied texel with alpha 0 and colour > 0 is light that adds to
        whatever lies below it, in normal and additive blending alike; straight alpha cannot
        hold it, so ``rgba`` shows it as transparent); from an atlas, also the border texels
        next to drawn texels just outside the stored rectangle on the page, which the quad's
        edge samples (:func:`bleeding_in`). Default: ``alpha > 0``.
    shown : ndarray, shape (H, W), bool
        The part of ``drawn`` that can change a pixel by more than :data:`FAINT_TEXEL`/255
        when drawn with normal blending (:func:`shown_texels`); the bleed-in border texels
        always. Default: ``alpha > FAINT_TEXEL``.

    ``drawn`` and ``shown`` are computed on first use when not given: a data set, which
    stores texels only, never pays for them.
    """

    def __init__(self, rgba: np.ndarray, scale: float, name: str, source: str,
                 content: tuple[int, int, int, int] | None = None, drawn: np.ndarray | None = None,
                 shown: np.ndarray | None = None):
        self._rgba, self.scale, self.name, self.source = rgba, scale, name, source
        self.shape = rgba.shape
        self.content = (0, 0, rgba.shape[1], rgba.shape[0]) if content is None else content
        self._drawn, self._shown = drawn, shown
        #: ``(rgba, drawn, shown)`` of the stored part alone (:meth:`from_stored`), else None
        self.stored: tuple | None = None

    @classmethod
    def from_stored(cls, rgba: np.ndarray, shape: tuple[int, ...], content: tuple[int, int, int, int], scale: float,
                    name: str, source: str, drawn: np.ndarray | None = None,
                    shown: np.ndarray | None = None) -> "RegionImage":
        """An image of ``shape`` (H, W, 4) that is zero outside ``content``, given by its part
        inside it: ``rgba`` (h, w, 4), ``drawn`` and ``shown`` (h, w) bool, the stored part
        of each. The whole-size arrays are made when first asked for (:meth:`place`): the
        planning of an upgrade meshes the stored part alone and never needs them.
        """
        image = cls(rgba, scale, name, source, content)
        image._rgba, image.shape = None, tuple(shape)
        image.stored = (rgba, drawn, shown)
        return image

    def place(self, part: np.ndarray) -> np.ndarray:
        """``part`` (the stored part's values, (h, w, ...)) at the original size, zero elsewhere;
        ``part`` itself when the stored part is the whole image."""
        return placed(part, self.shape[:2], self.content)

    @property
    def rgba(self) -> np.ndarray:
        if self._rgba is None:
            self._rgba = self.place(self.stored[0])
        return self._rgba

    @property
    def drawn(self) -> np.ndarray:
        if self._drawn is None:
            self._drawn = self.place(self.stored_masks()[0]) if self.stored else alpha_above(self.rgba, 0)
        return self._drawn

    @property
    def shown(self) -> np.ndarray:
        if self._shown is None:
            self._shown = self.place(self.stored_masks()[1]) if self.stored \
                else self.drawn & alpha_above(self.rgba, FAINT_TEXEL)
        return self._shown

    def stored_masks(self) -> tuple[np.ndarray, np.ndarray]:
        """``drawn`` and ``shown`` of the stored part alone, (h, w) bool each (:meth:`from_stored`
        images only), with the same defaults as the whole image's."""
        return self.stored_mask(shown=False), self.stored_mask(shown=True)

    def stored_mask(self, shown: bool) -> np.ndarray:
        """``shown`` (True) or ``drawn`` (False) of the stored part alone (:meth:`stored_masks`).

        A default is worked out when first asked for, then kept: a caller that needs one of
        the two masks (meshing for one blend mode) does not pay for the other.
        """
        rgba, drawn, shown_mask = self.stored
        if not shown:
            if drawn is None:
                drawn = alpha_above(rgba, 0)
                self.stored = (rgba, drawn, shown_mask)
            return drawn
        if shown_mask is None:
            # drawn & (alpha > FAINT_TEXEL); the default drawn (alpha > 0) holds every such texel
            faint = alpha_above(rgba, FAINT_TEXEL)
            shown_mask = faint if drawn is None else drawn & faint
            self.stored = (rgba, drawn, shown_mask)
        return shown_mask


#: A texel none of whose premultiplied channels exceeds this (/255) changes no pixel by more
#: than this much when drawn once with normal blending: below the 2/255 the runtime proof
#: tolerates (see :func:`shown_texels`).
FAINT_TEXEL = 2


def shown_texels(stored: np.ndarray, pma: bool) -> np.ndarray:
    """Texels of a page that change a pixel by more than :data:`FAINT_TEXEL`/255 in one normal-blended layer.

    Normal blending draws a premultiplied texel ``(c, a)`` over ``d`` as ``c + (1 - a) d``: it
    moves each channel by ``c - a d``, at most ``max(c, a)``; a straight texel is premultiplied
    first (``c = rgb a <= a``). Bilinear sampling never exceeds the largest of the four texels
    it mixes, and slot colours are at most 1, so a texel whose stored channels (premultiplied)
    are all at most :data:`FAINT_TEXEL` cannot move a pixel by more than that, wherever and
    however large it is drawn. Additive and other blend modes are meant to be stacked, where
    such faint layers add up, so ``upgrade`` covers every drawn texel there
    (:attr:`RegionImage.drawn`).

    Parameters
    ----------
    stored : ndarray, shape (H, W, 4), uint8
        Texels as the page stores them.
    pma : bool
        Whether the page is premultiplied (then colour counts as well as alpha).

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    if pma and stored.ndim == 3 and stored.strides[1:] == (4, 1) and stored.size:
        import cv2

        # Each byte over FAINT_TEXEL set to 255 (OpenCV, rows of texels at once), then a texel
        # is shown where its word is not 0: the same as channel_max(stored) > FAINT_TEXEL,
        # without three passes over strided planes.
        return texels_as_words(cv2.threshold(stored, FAINT_TEXEL, 255, cv2.THRESH_BINARY)[1]) != 0
    return channel_max(stored) > FAINT_TEXEL if pma else alpha_above(stored, FAINT_TEXEL)


def load_rgba(path: str | Path) -> np.ndarray:
    """Decode a PNG, WebP, AVIF or JPEG file to an (H, W, 4) uint8 RGBA array.

    The size is read from the header and checked against :mod:`spinemesh.limits` before
    any pixel is decoded, so a small file that claims a huge image (a decompression bomb,
    or a large, mostly empty sprite) is refused without allocating it. The one place the
    package decodes image files.

    Returns
    -------
    ndarray, shape (H, W, 4), uint8, read-only
        8-bit PNG and still WebP files are decoded by imagecodecs (libpng, libwebp) straight
        into the array (:func:`_codec_rgba`), the same texels with less CPU than Pillow: 1.2x
        to 1.3x over the corpus's pages, 1.5x to 2x on 6000x6000 sprites
        (``benchmarks/bench_speed.py``); a well-formed PNG's rows are inflated by libdeflate
        first (:func:`png_with_stored_rows`), which leaves libpng only their unfiltering. Other files
        (JPEG, AVIF, 16-bit or interlaced PNG, animated WebP), and any file imagecodecs
        refuses, go through Pillow as before, whose bytes the array wraps without a copy.
        Read-only either way (pages are shared by the regions cut from them): copy it to
        change it.

    Raises
    ------
    ImageError
        Missing or undecodable file.
    LimitError
        Image larger than the limits.
    """
    from .files.inputs import regular_file

    if Path(path).exists():  # a FIFO or device would block or never end: regular files only
        regular_file(path, "image")
    return _decode(path, path)


def image_file_bytes(path: str | Path) -> bytes:
    """An image file's bytes, for a caller that needs more of it than its texels (its palette, its
    colour chunks, the file itself to write again): read once, then decoded by :func:`decode_rgba`.

    Raises
    ------
    ImageError
        Missing, a folder, or unreadable.
    SpineMeshError
        Not a regular file (a FIFO or a device).
    """
    from .files.inputs import regular_file

    if Path(path).exists():  # a FIFO or device would block or never end: regular files only
        regular_file(path, "image")
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise ImageError("image file not found", path) from None
    except IsADirectoryError:
        raise ImageError("is a folder, not an image", path) from None
    except OSError as e:
        raise ImageError(f"cannot read image: {e.strerror or e}", path) from None


def image_size(path: str | Path) -> tuple[int, int] | None:
    """An image file's ``(width, height)`` from its header alone, or None when it cannot be read
    (whoever decodes it then reports why)."""
    try:
        with Image.open(path, formats=_decodable_formats()) as im:
            return int(im.width), int(im.height)
    except (OSError, ValueError, Image.DecompressionBombError):
        return None


def decode_rgba(data: bytes, source: str | Path | None = None) -> np.ndarray:
    """:func:`load_rgba` of a file's bytes already in memory (a data set's members).

    Parameters
    ----------
    data : bytes
        A PNG, WebP, AVIF or JPEG file.
    source : path, optional
        What errors name.

    Returns
    -------
    ndarray, shape (H, W, 4), uint8, read-only
    """
    import io

    return _decode(io.BytesIO(data), source, data)


def _decode(file, path, data: bytes | None = None) -> np.ndarray:
    """The decode of :func:`load_rgba`: ``file`` a path or a binary stream, ``path`` what errors name,
    ``data`` the stream's bytes when they are in memory already (not copied again)."""
    try:
        with warnings.catch_warnings():
            # Pillow's bomb warning becomes our error (the size check below comes first).
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(file, formats=_decodable_formats()) as im, \
                    image_memory("decode", path, im.width, im.height):
                check_image_size(im.width, im.height, "image", path)
                fast = _codec_rgba(im, data)
                if fast is not None:
                    fast.flags.writeable = False
                    return fast
                im.load()
                if im.mode != "RGBA":
                    im = im.convert("RGBA")
                # Wraps the bytes Pillow hands over, copying nothing more (read-only for that).
                return np.asarray(im, dtype=np.uint8)
    except FileNotFoundError:
        raise ImageError("image file not found", path) from None
    except IsADirectoryError:
        raise ImageError("is a folder, not an image", path) from None
    except PermissionError as e:  # the system's words, not Python's repr naming the path again
        raise ImageError(f"cannot read image: {e.strerror}", path) from None
    except (Image.DecompressionBombWarning, Image.DecompressionBombError):
        # Pillow refuses before it tells the size: the header's, in the words of every other size
        size = claimed_size(file)
        if size is not None:
            check_image_size(*size, "image", path)
        raise ImageError(f"image exceeds the limit of {MAX_IMAGE_PIXELS:,} pixels", path) from None
    except UnidentifiedImageError:  # Pillow's words name the stream it read (an object's address): ours name the file
        raise ImageError("cannot decode image: not a PNG, WebP, AVIF or JPEG file", path) from None
    except (OSError, ValueError, SyntaxError, EOFError) as e:
        raise ImageError(f"cannot decode image: {e}", path) from None


def claimed_size(file) -> tuple[int, int] | None:
    """The ``(width, height)`` an image's header claims, read past Pillow's decompression-bomb
    check, which refuses an image of too many pixels before it says how wide and high it is.

    Each decodable format's own opener is tried as :func:`PIL.Image.open` tries them (its
    ``accept`` test on the first bytes, then the opener, which reads the header only): the
    check lives in ``open`` alone, and lifting Pillow's limit for a moment would lift it for
    every other thread's images too. Nothing is decoded.

    Parameters
    ----------
    file : path or binary stream
        The image (a stream is read from its start and left there).

    Returns
    -------
    tuple of int or None
        None when no opener reads the header (the decode says why).
    """
    import contextlib

    with contextlib.ExitStack() as stack:
        try:
            fp = stack.enter_context(open(file, "rb")) if isinstance(file, (str, Path)) else file
            fp.seek(0)
            prefix = fp.read(16)
        except OSError:
            return None
        for fmt in _decodable_formats():
            factory, accept = Image.OPEN[fmt]
            if accept is not None and not accept(prefix):
                continue
            try:
                fp.seek(0)
                im = factory(fp, "")
                return int(im.width), int(im.height)
            except (SyntaxError, IndexError, TypeError, struct.error):  # what Image.open passes over to the next
                continue
            finally:
                fp.seek(0)
    return None


#: PNG colour types imagecodecs' libpng decoder turns into the texels Pillow gives (grey,
#: RGB, palette, grey + alpha, RGBA; tRNS becomes alpha), checked on every page of the corpus.
_PNG_COLOUR_TYPES = (0, 2, 3, 4, 6)


def _codec_rgba(im: "Image.Image", data: bytes | None = None) -> np.ndarray | None:
    """The texels of an opened (not yet loaded) image through imagecodecs, or None for Pillow to decode.

    Only where imagecodecs gives exactly Pillow's texels: 8-bit, non-interlaced PNG (16-bit
    PNG, which Pillow cuts to its high bytes, and interlaced PNG stay with Pillow) and still
    WebP (Pillow shows an animated WebP's first frame; imagecodecs would decode every frame).
    A PNG whose image data checks out reaches libpng with its rows already inflated by
    libdeflate (:func:`png_with_stored_rows`), any other as it is. A file imagecodecs refuses
    (a bad checksum Pillow does not check, say) is left to Pillow, which decodes it as before
    or raises its error. The size was checked before this call.

    Returns
    -------
    ndarray, shape (H, W, 4), uint8, or None
    """
    if im.format == "PNG":
        im.fp.seek(0)
        head = im.fp.read(33)
        # IHDR comes first (Pillow checked): bit depth at 24, colour type at 25, interlace at 28
        if len(head) < 33 or head[12:16] != b"IHDR" or head[24] != 8 or head[25] not in _PNG_COLOUR_TYPES \
                or head[28] != 0:
            return None
        decode = "png_decode"
    elif im.format == "WEBP" and getattr(im, "n_frames", 1) == 1:
        decode = "webp_decode"
    else:
        return None
    codecs = _imagecodecs()
    if data is None:  # the file's bytes (in memory already for decode_rgba)
        data = _file_bytes(im.fp)
    samples = None
    if decode == "png_decode":
        stored = png_with_stored_rows(data)
        if stored is not None:
            try:
                samples = codecs.png_decode(stored)
            except (codecs.PngError, ValueError):  # not expected (the stream checked out): the file decides
                samples = None
            del stored
    if samples is None:
        try:
            samples = getattr(codecs, decode)(data)
        except (codecs.PngError, codecs.WebpError):  # libpng's or libwebp's refusal: Pillow decides
            return None
    if samples.shape[:2] != (im.height, im.width) or samples.dtype != np.uint8:
        return None
    return rgba_from_samples(samples)


def _file_bytes(fp) -> memoryview:
    """The whole of a binary file or stream, in a NumPy buffer: a large one is handed huge memory
    pages (a bytes object of a 50 MB file is 12,000 page faults, each a kernel call)."""
    import io

    size = fp.seek(0, io.SEEK_END)
    fp.seek(0)
    buffer = np.empty(size, np.uint8)
    return memoryview(buffer)[:fp.readinto(buffer)]


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
    stream of a PNG's IDAT chunks), in a NumPy buffer (huge pages, as :func:`_file_bytes`)."""
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


def rgba_from_samples(samples: np.ndarray) -> np.ndarray:
    """RGBA from grey, grey + alpha, RGB or RGBA texels, as Pillow's ``convert("RGBA")`` makes it.

    Parameters
    ----------
    samples : ndarray, shape (H, W) or (H, W, C) with C in 1 to 4, uint8

    Returns
    -------
    ndarray, shape (H, W, 4), uint8
        ``samples`` itself when it already is RGBA; else a new array, opaque where there was
        no alpha.

    Examples
    --------
    >>> rgba_from_samples(np.array([[[7, 9]]], np.uint8)).tolist()
    [[[7, 7, 7, 9]]]
    """
    if samples.ndim == 2:
        samples = samples[..., None]
    channels = samples.shape[2]
    if channels == 4:
        return samples
    out = np.empty(samples.shape[:2] + (4,), np.uint8)
    out[..., :3] = samples[..., :3] if channels == 3 else samples[..., :1]
    out[..., 3] = samples[..., 1] if channels == 2 else 255
    return out


def unpremultiply(rgba: np.ndarray) -> np.ndarray:
    """Straight-alpha RGBA from premultiplied RGBA (uint8 in, uint8 out, a new array).

    Colour channels are divided by alpha with rounding, ``min(255, (c * 255 + a // 2) // a)``;
    fully transparent pixels become black. At low alpha the division cannot be exact in 8
    bits; premultiplying the result again gives back the input within 1 per channel.
    OpenCV's ``COLOR_mRGBA2RGBA`` computes exactly that (checked for every alpha and colour
    by the tests), about 10x faster than a look-up table in numpy.
    """
    import cv2

    if rgba.strides[1:] != (4, 1):  # OpenCV takes rows of contiguous texels (a turned view is not)
        rgba = np.ascontiguousarray(rgba)
    return cv2.cvtColor(rgba, cv2.COLOR_mRGBA2RGBA)


def channel_max(rgba: np.ndarray) -> np.ndarray:
    """The largest of the four channels of each texel: shape (H, W), same dtype.

    ``rgba.max(axis=-1)`` reduces over an axis of 4, element by element; three pairwise
    maxima over whole planes give the same values about 3x faster.
    """
    return np.maximum(np.maximum(rgba[..., 0], rgba[..., 1]), np.maximum(rgba[..., 2], rgba[..., 3]))


def premultiply(rgba: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA from straight RGBA, rounding to nearest (uint8 in, uint8 out)."""
    a = rgba[..., 3:4].astype(np.uint32)
    out = rgba.copy()
    out[..., :3] = ((rgba[..., :3].astype(np.uint32) * a + 127) // 255).astype(np.uint8)
    return out


def cut_region(page: np.ndarray, region: AtlasRegion, pma: bool = False,
               source: str | None = None) -> np.ndarray:
    """Cut one region out of a page image and restore its original size and orientation.

    Parameters
    ----------
    page : ndarray, shape (PH, PW, 4), uint8
        The page image as stored.
    region : AtlasRegion
        The region; its geometry is in page pixels.
    pma : bool
        Whether the page is premultiplied; the result is always straight alpha.

    Returns
    -------
    ndarray, shape (original_height, original_width, 4), uint8
    """
    crop = stored_rectangle(page, region, source)
    return upright_at_original_size(unpremultiply(crop) if pma else crop, region, source)


def stored_rectangle(page: np.ndarray, region: AtlasRegion, source: str | None = None,
                     geometry: RegionGeometry | None = None) -> np.ndarray:
    """The region's rectangle as it lies on the page (a view), refused where it leaves the page.

    ``geometry`` is ``region.geometry(source)`` where the caller has it already (here and in
    :func:`upright_part` and :func:`bleeding_border`): parsed once per region, not once a step.

    Returns
    -------
    ndarray, shape (page_height, page_width, 4), uint8
        Texels as the page stores them (a rotated region lies turned), without the stripped
        whitespace; :func:`upright_at_original_size` places per-texel values upright.
    """
    g = region.geometry(source) if geometry is None else geometry
    ph, pw = page.shape[:2]
    if g.x < 0 or g.y < 0 or g.x + g.page_width > pw or g.y + g.page_height > ph:
        raise AtlasError(f"region {region.name!r} ({g.x}, {g.y}, {g.page_width}x{g.page_height}) "
                         f"lies outside its {pw}x{ph} page", source, line=region.line)
    return page[g.y:g.y + g.page_height, g.x:g.x + g.page_width]


def upright_at_original_size(stored: np.ndarray, region: AtlasRegion, source: str | None = None) -> np.ndarray:
    """Texels (or any per-texel values) as the page stores them, turned upright and placed at the offsets.

    Parameters
    ----------
    stored : ndarray, shape (page_height, page_width, ...)
        The region's rectangle as it lies on the page.

    Returns
    -------
    ndarray, shape (original_height, original_width, ...)
        Zero where whitespace was stripped; ``stored`` itself (a view of the page) when nothing
        was and the region is not rotated, its turned copy when it is.
    """
    part, size, content = upright_part(stored, region, source)
    return placed(part, size, content)


def placed(part: np.ndarray, size: tuple[int, int], content: tuple[int, int, int, int]) -> np.ndarray:
    """``part`` (h, w, ...) at ``(x0, y0, x1, y1) = content`` in an image of ``size`` (height,
    width), zero elsewhere; ``part`` itself (a view stays a view) when it fills that size."""
    if part.shape[:2] == tuple(size):
        return part
    x0, y0, x1, y1 = content
    out = np.zeros(tuple(size) + part.shape[2:], part.dtype)
    out[y0:y1, x0:x1] = part
    return out


def upright_part(stored: np.ndarray, region: AtlasRegion, source: str | None = None,
                 geometry: RegionGeometry | None = None
                 ) -> tuple[np.ndarray, tuple[int, int], tuple[int, int, int, int]]:
    """:func:`upright_at_original_size` before the placing: ``stored`` turned upright (a view of
    it when not turned, else a contiguous copy: :func:`turned_clockwise`),
    the original ``(height, width)``, and where the part lies in it, ``(x0, y0, x1, y1)``.

    Raises
    ------
    AtlasError
        The offsets place the part outside the original size, or do not fit its size.
    """
    g = region.geometry(source) if geometry is None else geometry
    if g.degrees:
        # Packers store the image turned counter-clockwise; turning it clockwise undoes that.
        stored = turned_clockwise(stored, g.degrees // 90)
    top = g.original_height - g.offset_y - g.height
    left = g.offset_x
    if top < 0 or left < 0 or left + g.width > g.original_width or top + g.height > g.original_height \
            or stored.shape[:2] != (g.height, g.width):
        raise AtlasError(f"region {region.name!r}: offsets place the image outside its original "
                         f"{g.original_width}x{g.original_height} size", source, line=region.line)
    return stored, (g.original_height, g.original_width), (left, top, left + g.width, top + g.height)


#: OpenCV's turn for each number of clockwise quarter turns (1 to 3).
_CV2_TURNS = {1: "ROTATE_90_CLOCKWISE", 2: "ROTATE_180", 3: "ROTATE_90_COUNTERCLOCKWISE"}


def turned_clockwise(values: np.ndarray, quarters: int) -> np.ndarray:
    """``values`` turned clockwise by ``quarters`` quarter turns, as a new contiguous array.

    The values of ``np.rot90(values, -quarters)``, copied: every caller copies a turned region
    (to mesh it, hash it, place it), and copying numpy's turned view goes texel by texel, byte
    by byte (about 0.4 GB/s here), where OpenCV's turn moves whole texels through blocks
    (about 2.5 GB/s for RGBA, 5.7 GB/s for masks). Bytes and booleans of up to four channels
    go through OpenCV; anything else through numpy.

    Parameters
    ----------
    values : ndarray, shape (H, W) or (H, W, C)
        Per-texel values; rows may lie apart (a rectangle of a page).
    quarters : int
        Clockwise quarter turns (any integer; taken modulo 4).

    Returns
    -------
    ndarray, shape (W, H, ...) for an odd number of quarters, else (H, W, ...)

    Examples
    --------
    >>> turned_clockwise(np.array([[1, 2], [3, 4]], np.uint8), 1).tolist()
    [[3, 1], [4, 2]]
    """
    import cv2

    quarters %= 4
    if quarters == 0:
        return np.ascontiguousarray(values)
    as_bytes = values.view(np.uint8) if values.dtype == bool else values
    channels = as_bytes.shape[2] if as_bytes.ndim == 3 else 1
    # OpenCV takes rows of whole texels lying side by side; rows themselves may lie apart
    texel_rows = as_bytes.ndim in (2, 3) and 1 <= channels <= 4 and as_bytes.strides[0] > 0 \
        and as_bytes.strides[1:] == ((channels, 1) if as_bytes.ndim == 3 else (1,))
    if as_bytes.dtype != np.uint8 or not texel_rows or as_bytes.size == 0:
        return np.ascontiguousarray(np.rot90(values, -quarters))
    out = cv2.rotate(as_bytes, getattr(cv2, _CV2_TURNS[quarters]))
    if as_bytes.ndim == 3 and out.ndim == 2:  # OpenCV drops a single channel
        out = out[..., None]
    return out.view(bool) if values.dtype == bool else out


def bleeding_in(page: np.ndarray, region: AtlasRegion, pma: bool = False, source: str | None = None) -> np.ndarray:
    """Texels on the border of a region's rectangle next to drawn texels just outside it on the page.

    A runtime draws a region's quad up to the rectangle's edge, sampling bilinearly, so the
    pixels along that edge take some colour from the page's texels just outside it: a
    neighbouring region's art where the packer left no padding. A mesh reproduces that only
    if it covers those border texels too.

    Returns
    -------
    ndarray, shape (original_height, original_width), bool
    """
    return upright_at_original_size(bleeding_border(page, region, pma, source), region, source)


def bleeding_border(page: np.ndarray, region: AtlasRegion, pma: bool = False,
                    source: str | None = None, geometry: RegionGeometry | None = None) -> np.ndarray:
    """:func:`bleeding_in` as the rectangle lies on the page: shape (page_height, page_width), bool.

    Only the rectangle's outermost rows and columns can touch a texel outside it, so only
    the page's one-texel frame around the rectangle is read and each side's three-texel
    strip dilated (the same texels as a dilation of the whole rectangle, which read it all).
    """
    g = region.geometry(source) if geometry is None else geometry
    border = _bleeding_border(page, g, pma)
    return np.zeros((g.page_height, g.page_width), bool) if border is None else border


def _frame_drawn(page: np.ndarray, x0: int, y0: int, x1: int, y1: int, pma: bool) -> bool:
    """Whether any texel of the page's one-texel frame just inside ``(x0, y0, x1, y1)`` is drawn
    (alpha > 0; any channel > 0 on a premultiplied page). The frame may leave the page."""
    ph, pw = page.shape[:2]
    for ya, yb, xa, xb in ((y0, y0 + 1, x0, x1), (y1 - 1, y1, x0, x1),
                           (y0 + 1, y1 - 1, x0, x0 + 1), (y0 + 1, y1 - 1, x1 - 1, x1)):
        ya, yb, xa, xb = max(0, ya), min(ph, yb), max(0, xa), min(pw, xb)
        if yb > ya and xb > xa:
            side = page[ya:yb, xa:xb]
            if side.any() if pma else alpha_above(side, 0).any():
                return True
    return False


def _bleeding_border(page: np.ndarray, g: RegionGeometry, pma: bool) -> np.ndarray | None:
    """:func:`bleeding_border` of a region of geometry ``g``, or None where no texel of the frame
    around it is drawn (most regions: packers leave padding), which then costs four strips."""
    import cv2

    ph, pw = page.shape[:2]
    x0, y0, x1, y1 = g.x - 1, g.y - 1, g.x + g.page_width + 1, g.y + g.page_height + 1
    if not _frame_drawn(page, x0, y0, x1, y1, pma):
        return None
    ring = np.zeros((y1 - y0, x1 - x0), np.uint8)  # the frame only; the inside stays 0
    for rows, cols in ((slice(0, 1), slice(None)), (slice(-1, None), slice(None)),
                       (slice(1, -1), slice(0, 1)), (slice(1, -1), slice(-1, None))):
        r0, r1, _ = rows.indices(ring.shape[0])
        c0, c1, _ = cols.indices(ring.shape[1])
        ya, yb, xa, xb = max(0, y0 + r0), min(ph, y0 + r1), max(0, x0 + c0), min(pw, x0 + c1)
        if yb > ya and xb > xa:
            near = page[ya:yb, xa:xb]
            ring[ya - y0:yb - y0, xa - x0:xb - x0] = texels_as_words(near) != 0 if pma else alpha_above(near, 0)
    border = np.zeros((g.page_height, g.page_width), bool)
    k = np.ones((3, 3), np.uint8)
    border[0] = cv2.dilate(ring[:3], k)[1, 1:-1]  # each texel of the border from the 3x3 around it
    border[-1] |= cv2.dilate(ring[-3:], k)[1, 1:-1].astype(bool)
    border[:, 0] |= cv2.dilate(ring[:, :3], k)[1:-1, 1].astype(bool)
    border[:, -1] |= cv2.dilate(ring[:, -3:], k)[1:-1, 1].astype(bool)
    return border


class PageStore:
    """Decoded atlas pages by real path: each page decoded once, however many skeletons use it.

    One store serves every atlas of a project (:func:`spinemesh.project.project_pages`), so
    skeletons, skins and sequences that share a page share its one decode. Pages are kept
    read-only (regions are cut from them as views) until :meth:`release` or until they would
    exceed ``max_bytes`` together; then the least recently used page goes first.

    Parameters
    ----------
    max_bytes : int
        Decoded texels kept at most (default :data:`spinemesh.limits.MAX_PAGE_STORE_BYTES`),
        pages decoded ahead and not taken yet (:attr:`PagePrefetch.bytes_ahead`) included; the
        page in use is kept whatever its size. A project whose pages exceed it together may
        have a page decoded again.
    max_pages : int, optional
        Pages kept at most (default: no limit besides ``max_bytes``).

    Attributes
    ----------
    decodes : int
        Pages decoded so far (for the benchmarks).
    """

    def __init__(self, max_bytes: int | None = None, max_pages: int | None = None):
        from .limits import MAX_PAGE_STORE_BYTES

        self.max_bytes = MAX_PAGE_STORE_BYTES if max_bytes is None else max_bytes
        self.max_pages = max_pages
        self.decodes = 0
        #: Decodes pages ahead on worker processes (:meth:`decode_ahead`); None: none ahead.
        self.prefetch: PagePrefetch | None = None
        self._pages: OrderedDict[Path, np.ndarray] = OrderedDict()
        self._ahead: set[Path] = set()  # asked of self.prefetch and not taken yet

    def decode_ahead(self, paths) -> None:
        """Have ``self.prefetch`` decode these pages (real, checked paths) before :meth:`page` asks.

        Nothing without a prefetch; pages held already or asked for already are not asked again.
        """
        if self.prefetch is None:
            return
        new = [p for p in dict.fromkeys(paths) if p not in self._pages and p not in self._ahead]
        self._ahead.update(new)
        self.prefetch.want(new)

    def page(self, path: Path) -> np.ndarray:
        """The page image at ``path``: (H, W, 4) uint8, read-only.

        ``path`` is the page's real path, checked to lie inside its project
        (:meth:`AtlasImages.page_path`): one key per file however it was named. A page
        decoded ahead (:meth:`decode_ahead`) is taken as the worker decoded it; one whose decode
        ahead failed or never ran is decoded here, so that its texels, or its error, are this
        process's own.
        """
        pixels = self._pages.get(path)
        if pixels is not None:
            self._pages.move_to_end(path)
            return pixels
        pixels = None
        if path in self._ahead:
            self._ahead.discard(path)
            pixels = self.prefetch.take(path)
        if pixels is None:
            pixels = load_rgba(path)
        self.decodes += 1
        pixels.flags.writeable = False  # shared by every region cut from it
        self._pages[path] = pixels
        # pages decoded ahead and not taken yet are this process's memory too: one budget for both
        ahead = self.prefetch.bytes_ahead if self.prefetch is not None else 0
        while len(self._pages) > 1 and (sum(p.nbytes for p in self._pages.values()) + ahead > self.max_bytes
                                        or (self.max_pages is not None and len(self._pages) > self.max_pages)):
            self._pages.popitem(last=False)
        return pixels

    def release(self) -> None:
        """Drop every decoded page (a project is planned: its regions are cut), and any decode ahead
        this store asked for and did not take."""
        self._pages.clear()
        if self._ahead:
            self.prefetch.forget(self._ahead)
            self._ahead.clear()


#: Pages a :class:`PagePrefetch` has decoding or decoded and not yet taken, per worker: enough
#: that the workers are a few pages ahead of the planning (pages are 16 MB at 2048x2048).
PREFETCH_PAGES_PER_WORKER = 4
#: Bytes of texels a :class:`PagePrefetch` has decoding or decoded and not yet taken, at most,
#: whatever the number of workers: half of :data:`~spinemesh.limits.MAX_PAGE_STORE_BYTES`, the
#: budget of every decoded page a process holds (:class:`PageStore` counts these in). Sixteen
#: 2048x2048 pages fit; of 9400x9400 pages (353 MB), one.
PREFETCH_BYTES = 512 << 20


def texel_bytes(path: Path) -> int:
    """Bytes of the RGBA texels that :func:`load_rgba` makes of the image at ``path``, from its
    header alone (nothing decoded); 0 when the header cannot be read (the decode will say why)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path, formats=_decodable_formats()) as im:
                return 4 * im.width * im.height
    except UNREADABLE_IMAGE:
        return 0


class PagePrefetch:
    """Atlas pages decoded by local worker processes ahead of the planning that cuts them.

    Decoding pages is most of what the parent process of a library run spends reading and
    planning. :meth:`PageStore.decode_ahead` queues a project's pages here, in the order the
    planning will take them; they are submitted to the workers (ahead of their queued meshes,
    :func:`spinemesh.upgrade.plan.decode_page_shared`), at most ``window`` not yet taken at
    once. :meth:`take` gives a page's texels, or None when its decode failed, its worker was
    lost or it was not submitted yet: the store then decodes it itself, as without workers, so
    texels and errors are the same either way.

    Memory is bounded by bytes as well as pages: a page is submitted only while the texels of
    those submitted and not taken stay within ``max_bytes`` (sizes read from the headers,
    :func:`texel_bytes`); a page larger than ``max_bytes`` alone is not decoded ahead at all
    (the store decodes it when it is needed). What the workers hold while they decode is
    within the same bound, so decoded pages of a run with workers take at most
    :data:`~spinemesh.limits.MAX_PAGE_STORE_BYTES` in this process (the store counts these in)
    plus ``max_bytes`` in flight, whatever ``--jobs`` is.

    Parameters
    ----------
    submit : callable
        ``submit(path) -> Future`` of the page's :func:`load_rgba` texels, decoded elsewhere.
    window : int
        Pages submitted and not yet taken, at most.
    max_bytes : int
        Texels of the pages submitted and not yet taken, at most (default :data:`PREFETCH_BYTES`).
    """

    def __init__(self, submit, window: int, max_bytes: int = PREFETCH_BYTES):
        self._submit = submit
        self.window = window
        self.max_bytes = max_bytes
        #: Bytes of texels of the pages submitted and not taken yet.
        self.bytes_ahead = 0
        self._wanted: OrderedDict[Path, None] = OrderedDict()  # not submitted yet, in order
        self._submitted: dict[Path, tuple[object, int]] = {}  # path -> (Future, bytes of texels)

    def want(self, paths) -> None:
        """Queue these pages (real paths checked inside their project) for decoding ahead."""
        for path in paths:
            if path not in self._submitted:
                self._wanted[path] = None
        self._top_up()

    def _top_up(self) -> None:
        while self._wanted and len(self._submitted) < self.window:
            path = next(iter(self._wanted))
            nbytes = texel_bytes(path)
            if nbytes > self.max_bytes:  # never ahead: the store decodes it when it comes to it
                del self._wanted[path]
                continue
            if self.bytes_ahead + nbytes > self.max_bytes:
                return  # its turn comes when a page is taken
            del self._wanted[path]
            try:
                self._submitted[path] = (self._submit(path), nbytes)
            except RuntimeError:  # the workers are closing: the store decodes what is left
                self._wanted.clear()
                return
            self.bytes_ahead += nbytes

    def _pop(self, path: Path):
        """The future of a submitted page, no longer counted ahead; None if not submitted."""
        future, nbytes = self._submitted.pop(path, (None, 0))
        self.bytes_ahead -= nbytes
        return future

    def take(self, path: Path) -> np.ndarray | None:
        """The page decoded ahead, read-only; None if the caller must decode it (see the class)."""
        from concurrent.futures import CancelledError

        self._wanted.pop(path, None)  # still waiting for a turn: decoded by the caller, now
        future = self._pop(path)
        try:
            return future.result() if future is not None else None
        except (Exception, CancelledError):  # failed or lost: the caller's own decode says why
            return None
        finally:
            self._top_up()

    def forget(self, paths) -> None:
        """Drop these pages: not decoded if still waiting, their texels freed if decoded."""
        for path in paths:
            self._wanted.pop(path, None)
            future = self._pop(path)
            if future is not None:
                future.cancel()
        self._top_up()


class AtlasImages:
    """Region images from one or more atlases, cut from pages decoded once (:class:`PageStore`).

    Parameters
    ----------
    atlases : list of Atlas
        Parsed atlases, each with its ``path`` set; earlier atlases win on duplicate names.
    root : path, optional
        Folder that page files may not leave (default: each atlas's own folder).
    cache_pages : int, optional
        Without ``pages``: how many decoded pages this source keeps (pages can be 64 MB each);
        default: as many as :data:`spinemesh.limits.MAX_PAGE_STORE_BYTES` holds.
    pages : PageStore, optional
        The store to decode pages through, shared with other sources of the same project
        (:func:`spinemesh.project.project_pages`); default: one of this source's own.
    """

    def __init__(self, atlases: list[Atlas], root: str | Path | None = None, cache_pages: int | None = None,
                 pages: PageStore | None = None):
        self.atlases = atlases
        self.root = Path(root) if root else None
        self.pages = pages if pages is not None else PageStore(max_pages=cache_pages)
        self._page_files: dict[tuple[int, int], Path] = {}
        self._index: dict[str, tuple[Atlas, AtlasRegion]] = {}
        for atlas in atlases:
            for region in atlas.regions:
                self._index.setdefault(region.name, (atlas, region))
        #: portable name (:func:`.files.names.portable_name`) -> region names of that name, once a name missed
        self._portable: dict[str, list[str]] | None = None

    @classmethod
    def from_files(cls, paths: list[str | Path], root: str | Path | None = None) -> "AtlasImages":
        return cls([read_atlas(p) for p in paths], root)

    def __contains__(self, name: str) -> bool:
        return name in self._index

    def names(self) -> list[str]:
        return list(self._index)

    @staticmethod
    def page_path(atlas: Atlas, page_name: str, root: str | Path | None = None) -> Path:
        """The real path of a page image named in ``atlas``, refusing names that leave ``root``.

        Raises
        ------
        UnsafePathError
            If the page name climbs out of ``root`` (default: the atlas's folder), also through
            a symlink.
        """
        assert atlas.path is not None
        root = Path(root) if root is not None else atlas.path.parent
        try:
            rel_dir = atlas.path.parent.resolve().relative_to(root.resolve())
        except ValueError:
            raise UnsafePathError("atlas lies outside the project folder", atlas.path) from None
        return resolve_inside(root, f"{rel_dir.as_posix()}/{page_name}", atlas.path)

    def page_files(self, names) -> list[Path]:
        """The page files the regions ``names`` lie on, each once, in the order first named.

        Names no atlas holds and pages whose path is refused are left out: :meth:`get` reports
        those when asked.
        """
        out: dict[Path, None] = {}
        for name in names:
            found = self._index.get(name)
            if found is not None and 0 <= found[1].page < len(found[0].pages):
                try:
                    out[self.page_file(found[0], found[1].page)] = None
                except UnsafePathError:
                    continue
        return list(out)

    def page_file(self, atlas: Atlas, page_index: int) -> Path:
        """The page image path, refusing names that leave the project (``../``).

        Resolved once per page (real paths cost a system call per folder), then remembered.
        """
        key = (id(atlas), page_index)
        found = self._page_files.get(key)
        if found is None:
            found = self._page_files[key] = self.page_path(atlas, atlas.pages[page_index].name, self.root)
        return found

    def _alike(self, name: str) -> str:
        """For a name no region has: the regions named so but for case or Unicode form (a project
        moved between macOS, Windows and Linux), which runtimes do not match either; or ``""``."""
        if self._portable is None:
            self._portable = {}
            for other in self._index:
                self._portable.setdefault(portable_name(other), []).append(other)
        alike = self._portable.get(portable_name(name), [])
        if not alike:
            return ""
        return (f"; the atlas has {', '.join(map(repr, alike[:3]))}, other in case or Unicode form only, which "
                "runtimes do not match either")

    def get(self, name: str, coverage: bool = True) -> RegionImage:
        """The original-size image of region ``name``. Raises :class:`ImageError` if absent.

        ``coverage=False`` (a data set, which stores texels only) leaves out what the page
        adds to :attr:`RegionImage.drawn` and :attr:`RegionImage.shown` (premultiplied
        light, the bleed-in border): they are then the alpha defaults, as from an images folder.
        """
        found = self._index.get(name)
        if found is None:
            raise ImageError(f"no atlas region named {name!r}{self._alike(name)}",
                             self.atlases[0].path if self.atlases else None)
        atlas, region = found
        page_path = self.page_file(atlas, region.page)
        page = atlas.pages[region.page]
        pixels = self.pages.page(page_path)
        # Everything per texel is worked out on the stored rectangle, then placed upright at
        # the original size: stripped whitespace is zero either way, and an original size
        # may be many times the rectangle (a 1999x3553 shadow stored as 1987x202).
        # Placing it at the original size waits until something asks for the whole image
        # (RegionImage.from_stored): the planning of an upgrade needs the stored part alone.
        source = str(atlas.path)
        g = region.geometry(source)
        stored = stored_rectangle(pixels, region, source, g)
        rgba, (height, width), content = upright_part(unpremultiply(stored) if page.pma else stored, region,
                                                      source, g)
        shape = (height, width, 4)
        if not coverage:
            return RegionImage.from_stored(rgba, shape, content, page.scale, name, str(page_path))
        bleed = _bleeding_border(pixels, g, page.pma)
        if bleed is None and not page.pma:
            # The defaults of from_stored are these masks exactly (alpha > 0, alpha > FAINT_TEXEL
            # of the straight texels): worked out only if asked for, on the upright part.
            return RegionImage.from_stored(rgba, shape, content, page.scale, name, str(page_path))
        drawn = texels_as_words(stored) != 0 if page.pma else alpha_above(stored, 0)
        shown = shown_texels(stored, page.pma)
        if bleed is not None:  # most regions have none: no pass over either mask then
            drawn |= bleed
            shown |= bleed
        drawn = upright_part(drawn, region, source, g)[0]
        shown = upright_part(shown, region, source, g)[0]
        return RegionImage.from_stored(rgba, shape, content, page.scale, name, str(page_path), drawn, shown)


class FolderImages:
    """Images from a folder laid out as the Spine editor's images folder.

    ``get("eyes/blink")`` reads ``<folder>/eyes/blink.png`` (or ``.webp``, ``.avif``,
    ``.jpg``). Scale is 1: editor images are at skeleton size. A name found under no spelling of
    its own is the one image that is that file on a macOS or Windows disk, where the editor that
    exported the skeleton found it: ``Hero`` for ``hero.png``, ``head`` for ``head.PNG``, ``café``
    written in the other Unicode form (macOS writes NFD); none when several are.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        #: portable name (:func:`.files.names.portable_name`) -> images of that name, once a name missed
        self._portable: dict[str, list[Path]] | None = None

    def path_of(self, name: str) -> Path | None:
        for ext in IMAGE_EXTENSIONS:
            p = resolve_inside(self.folder, name + ext)
            if p.is_file():
                return p
        if self._portable is None:
            self._portable = {}
            for p in self._files():
                self._portable.setdefault(portable_name(self._name(p)), []).append(p)
        found = self._portable.get(portable_name(name), [])
        return found[0] if len(found) == 1 else None

    def _files(self) -> list[Path]:
        if not self.folder.is_dir():
            return []
        return [p for p in walk_files(self.folder) if p.suffix.lower() in IMAGE_EXTENSIONS]

    def _name(self, path: Path) -> str:
        return path.relative_to(self.folder).with_suffix("").as_posix()

    def __contains__(self, name: str) -> bool:
        return self.path_of(name) is not None

    def names(self) -> list[str]:
        return [self._name(p) for p in self._files()]

    def get(self, name: str, coverage: bool = True) -> RegionImage:
        """The image ``name`` at its size; ``coverage`` is for :meth:`AtlasImages.get`'s sake (same here)."""
        p = self.path_of(name)
        if p is None:
            alike = [q.relative_to(self.folder).as_posix() for q in (self._portable or {}).get(portable_name(name), [])]
            if alike:  # several: the editor's disk held one of them, which one is unknown here
                raise ImageError(f"no image {name!r}; {', '.join(alike[:4])} are each that file on a macOS or "
                                 "Windows disk (case, Unicode form), so which one is meant is unknown", self.folder)
            raise ImageError(f"no image {name!r} (looked for {', '.join(name + e for e in IMAGE_EXTENSIONS)})",
                             self.folder)
        return RegionImage(load_rgba(p), 1.0, name, str(p))


def content_id(rgba: np.ndarray, box: tuple[int, int, int, int]) -> str:
    """128-bit hash of an image's size and the pixels inside ``box``, as 32 hex digits.

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
    box : (x, y, w, h)
        The part that counts (the callers know everything outside it is zero, or unused).
        The size and the box are hashed too, so equal pixels in other places differ.

    SHA-256, truncated, because CPUs hash it in hardware. The one image hash of the
    package: ``upgrade`` meshes each id once, ``dataset`` stores each id once.
    """
    x, y, w, h = box
    return part_content_id(rgba.shape, box, rgba[y:y + h, x:x + w])


def part_content_id(shape: tuple[int, ...], box: tuple[int, int, int, int], part: np.ndarray,
                    mask: np.ndarray | None = None) -> str:
    """:func:`content_id` of an image of ``shape`` whose pixels inside ``box`` are ``part``.

    For callers that hold that part already: hashed as it is when contiguous (no copy).

    Parameters
    ----------
    mask : ndarray of bool, optional
        A per-texel mask that belongs to the identity too (the texels a mesh must cover), of
        the shape it has: hashed after the pixels, as bits (eight texels a byte, an eighth of
        its bytes to hash). Equal ids then mean equal pixels and equal masks. Without it, the
        id is :func:`content_id`'s.
    """
    import hashlib

    digest = hashlib.sha256()
    digest.update(np.asarray(tuple(shape) + tuple(box), np.int64).tobytes())
    digest.update(part if part.flags.c_contiguous else np.ascontiguousarray(part))
    if mask is not None:
        digest.update(np.asarray(mask.shape, np.int64).tobytes())
        digest.update(np.packbits(mask))
    return digest.hexdigest()[:32]


def fit_within(rgba: np.ndarray, size: int) -> np.ndarray:
    """``rgba`` shrunk (area averaging) so that its longer side is at most ``size`` pixels;
    returned as it is when it already fits.

    Examples
    --------
    >>> fit_within(np.zeros((40, 10, 4), np.uint8), 20).shape
    (20, 5, 4)
    """
    import cv2

    h, w = rgba.shape[:2]
    k = size / max(h, w)
    if k >= 1:
        return rgba
    return cv2.resize(rgba, (max(1, round(w * k)), max(1, round(h * k))), interpolation=cv2.INTER_AREA)
