"""Arithmetic on RGBA texels: premultiplied and straight alpha, the texels that show, shrinking.

Pure functions of arrays, whatever file or page the texels came from: separate from
:mod:`.decode` (files) and :mod:`.regions` (where a region lies on its page).
"""

from __future__ import annotations

import numpy as np

from ..foreground import alpha_above, texels_as_words

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
    (:attr:`.sources.RegionImage.drawn`).

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
