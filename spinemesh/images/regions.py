"""A region cut out of its atlas page: the stored rectangle, turned upright and placed at the
original size, and the page's border texels that bleed into the region's quad.

Separate from :mod:`.sources` (which pages and which regions an attachment uses) because these are
pure functions of a page's texels and one region's geometry.
"""

from __future__ import annotations

import numpy as np

from ..atlas import AtlasRegion, RegionGeometry
from ..errors import AtlasError
from ..foreground import alpha_above, texels_as_words
from .texels import unpremultiply


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
