"""Image files decoded to RGBA texels: the one place the package decodes image files.

Sizes are read from the headers and checked against :mod:`spinemesh.limits` before any texel
is decoded; the formats Pillow may open are those atlases and editor images use. 8-bit PNG and
still WebP go through imagecodecs (:mod:`.png_rows` inflates a PNG's rows first), everything
else through Pillow. Separate from what is done with the texels (:mod:`.texels`,
:mod:`.regions`) so that the decoding rules, and the errors they raise, live in one file.
"""

from __future__ import annotations

import functools
import struct
import warnings
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from ..errors import ImageError
from ..limits import MAX_IMAGE_PIXELS, check_image_size
from ..memory import image_memory
from .png_rows import _imagecodecs, png_with_stored_rows

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
    from ..files.inputs import regular_file

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
    from ..files.inputs import regular_file

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
