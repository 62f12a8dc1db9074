"""Classical masks for art without alpha, to compare the network against.

``floodfill``
    Everything connected to the image border through small colour steps is background.
    Works on solid and smooth backgrounds; leaks into sprites whose edge blends into the
    background, and stops short on busy textures.
``grabcut``
    OpenCV's GrabCut, with the one-pixel border as sure background and the rest as
    probable foreground: colour models rather than connectivity.

Both take an (H, W, 3) uint8 image and return an (H, W) bool mask (True: sprite), or raise
:class:`BaselineFailed` when the method gives no answer (evaluation counts that as a
failure, never as some default mask).
"""

from __future__ import annotations

import cv2
import numpy as np

BASELINES = ("floodfill", "grabcut")


class BaselineFailed(ValueError):
    """A classical method could not produce a mask for this image."""


def floodfill_mask(rgb: np.ndarray, tolerance: int = 6) -> np.ndarray:
    """Foreground as what the border's flood fill does not reach.

    Parameters
    ----------
    rgb : ndarray, shape (H, W, 3), uint8
    tolerance : int
        Largest step per channel between neighbouring background pixels (floating range,
        so gradients and soft noise are followed).

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    img = np.ascontiguousarray(rgb[..., :3])
    h, w = img.shape[:2]
    reached = np.zeros((h + 2, w + 2), np.uint8)  # floodFill's mask has a one-pixel frame
    diff = (tolerance,) * 3
    border = ([(x, 0) for x in range(w)] + [(x, h - 1) for x in range(w)]
              + [(0, y) for y in range(h)] + [(w - 1, y) for y in range(h)])
    for x, y in border:
        if reached[y + 1, x + 1]:
            continue
        cv2.floodFill(img.copy(), reached, (x, y), (0, 0, 0), diff, diff,
                      flags=4 | cv2.FLOODFILL_MASK_ONLY | (1 << 8))
    return reached[1:-1, 1:-1] == 0


def grabcut_mask(rgb: np.ndarray, iterations: int = 5, max_side: int = 256) -> np.ndarray:
    """GrabCut from a border-is-background start.

    Parameters
    ----------
    rgb : ndarray, shape (H, W, 3), uint8
    iterations : int
        GrabCut iterations.
    max_side : int
        Larger images are cut at this size and the mask enlarged (GrabCut is slow).

    Returns
    -------
    ndarray, shape (H, W), bool

    Raises
    ------
    BaselineFailed
        When OpenCV cannot fit its colour models (too few pixels of one class).
    """
    h, w = rgb.shape[:2]
    s = min(1.0, max_side / max(h, w))
    small = cv2.resize(rgb[..., :3], (max(2, round(w * s)), max(2, round(h * s))),
                       interpolation=cv2.INTER_AREA) if s < 1 else np.ascontiguousarray(rgb[..., :3])
    mask = np.full(small.shape[:2], cv2.GC_PR_FGD, np.uint8)
    mask[0, :] = mask[-1, :] = mask[:, 0] = mask[:, -1] = cv2.GC_BGD
    bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    try:
        cv2.grabCut(small, mask, None, bgd, fgd, iterations, cv2.GC_INIT_WITH_MASK)
    except cv2.error as e:
        raise BaselineFailed(f"GrabCut failed on a {w}x{h} image: {str(e).strip().splitlines()[-1]}") from None
    fg = np.isin(mask, (cv2.GC_FGD, cv2.GC_PR_FGD)).astype(np.uint8)
    if s < 1:
        fg = cv2.resize(fg, (w, h), interpolation=cv2.INTER_NEAREST)
    return fg.astype(bool)


def baseline_mask(rgb: np.ndarray, method: str) -> np.ndarray:
    """Dispatch by name: ``floodfill`` or ``grabcut``."""
    if method == "floodfill":
        return floodfill_mask(rgb)
    if method == "grabcut":
        return grabcut_mask(rgb)
    raise ValueError(f"unknown baseline {method!r}; expected one of {BASELINES}")
