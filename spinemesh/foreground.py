"""What counts as art in an image: the foreground by alpha (paper sec. 3.1).

One home below both the mesher (which meshes the foreground) and the segmentation model
(which learns it), so neither imports the other for it. Numpy only.
"""

from __future__ import annotations

import math

import numpy as np

#: Alpha above this is foreground in the paper (sec. 3.1, tau_alpha = 128): the masks a data
#: set stores and the segmentation model learns.
ALPHA_THRESHOLD = 128


def texels_as_words(rgba: np.ndarray) -> np.ndarray:
    """Each RGBA texel as one little-endian 32-bit word (alpha in the top byte): shape (H, W), uint32.

    A texel is all zeros exactly when its word is 0, and its alpha exceeds ``t`` exactly when
    its word is at least ``(t + 1) << 24``: one comparison of contiguous words per texel where
    :func:`~spinemesh.images.texels.channel_max` makes three passes over four planes (about 4x
    faster) and a slice of the alpha plane reads every fourth byte (about 3.5x slower on a
    page). A view of ``rgba`` when its texels lie four bytes apart (a page, or a rectangle of
    one); else (a turned view) of a contiguous copy.
    """
    if rgba.strides[-2:] != (4, 1):
        rgba = np.ascontiguousarray(rgba)
    return rgba.view("<u4")[..., 0]


def alpha_above(rgba: np.ndarray, threshold: int) -> np.ndarray:
    """The one test of alpha against a threshold: ``alpha > threshold``, shape (H, W), bool.

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4)
        Straight RGBA, uint8 (another dtype is compared on its alpha plane).
    threshold : int or float
        Alpha above this counts.

    Returns
    -------
    ndarray, shape (H, W), bool
        For uint8 texels four bytes apart (a page, or a rectangle of one) and an integer
        threshold from 0 to 254, compared as 32-bit words (:func:`texels_as_words`); else on
        the alpha plane, which gives the same.

    Examples
    --------
    >>> alpha_above(np.array([[[9, 9, 9, 128], [0, 0, 0, 129]]], np.uint8), 128).tolist()
    [[False, True]]
    """
    if rgba.dtype == np.uint8 and rgba.strides[-2:] == (4, 1) and isinstance(threshold, (int, np.integer)) \
            and 0 <= threshold < 255:
        return texels_as_words(rgba) >= (int(threshold) + 1) << 24
    return rgba[..., 3] > threshold


def foreground(image: np.ndarray, threshold: int = 8) -> np.ndarray:
    """The one definition of foreground by alpha: ``alpha >= threshold`` (:func:`alpha_above`).

    Parameters
    ----------
    image : ndarray, shape (H, W, 4) or (H, W, 3), uint8
        Straight RGBA; an image without alpha is foreground everywhere.
    threshold : int
        Smallest alpha that counts (0..255). 8 (default): faint glow and anti-aliasing are
        art too. The paper's ``alpha > 128`` (sec. 3.1) is ``threshold=129``.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 4:
        if image.dtype == np.uint8:  # whole alphas: at least t is above ceil(t) - 1
            return alpha_above(image, math.ceil(threshold) - 1)
        return image[..., 3] >= threshold
    return np.ones(image.shape[:2], dtype=bool)


def alpha_mask(rgba: np.ndarray, threshold: int = ALPHA_THRESHOLD) -> np.ndarray:
    """The paper's mask of a sprite: ``alpha > threshold`` (section 3.1: 128).

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
    threshold : int
        Alpha above this is foreground.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    return foreground(rgba, threshold + 1)
