"""Backgrounds and compositing: how a sprite with alpha becomes "art without alpha".

Paper section 3.4 (Data Augmentation): every training sprite is flattened onto a random
solid colour, a random two-colour gradient, or Perlin-like noise, and the mask to learn is
its alpha thresholded at 128 (section 3.1). The same functions build the evaluation images
of ``segment-eval``, so training and evaluation see the same three kinds of background.

Numpy and OpenCV only: nothing here imports torch.
"""

from __future__ import annotations

import numpy as np
import cv2

#: The three kinds of background of paper section 3.4.
BACKGROUNDS = ("solid", "gradient", "noise")

#: Alpha above this is foreground (paper section 3.1, tau_alpha = 128).
ALPHA_THRESHOLD = 128


def alpha_mask(rgba: np.ndarray, threshold: int = ALPHA_THRESHOLD) -> np.ndarray:
    """Ground-truth mask of a sprite: ``alpha > threshold``.

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
    threshold : int
        Paper section 3.1: 128.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    return rgba[..., 3] > threshold


def _random_colour(rng: np.random.Generator) -> np.ndarray:
    return rng.integers(0, 256, size=3).astype(np.float32)


def solid_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """One random RGB colour everywhere. Returns (h, w, 3) float32 in 0..255."""
    return np.broadcast_to(_random_colour(rng), (h, w, 3)).astype(np.float32)


def gradient_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Linear gradient between two random colours in a random direction.

    Returns (h, w, 3) float32 in 0..255.
    """
    angle = rng.uniform(0, 2 * np.pi)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    t = xx * np.cos(angle) + yy * np.sin(angle)
    t = (t - t.min()) / max(float(t.max() - t.min()), 1e-6)
    a, b = _random_colour(rng), _random_colour(rng)
    return a + t[..., None] * (b - a)


def noise_field(h: int, w: int, rng: np.random.Generator, octaves: int = 4) -> np.ndarray:
    """Perlin-like fractal value noise in 0..1, shape (h, w), float32.

    Each octave is a coarse random grid enlarged with bicubic interpolation; octaves double
    in frequency and halve in amplitude, which gives the cloudy look of Perlin noise at a
    fraction of the code.
    """
    base = rng.uniform(2, 8)  # cells across the longer side at the first octave
    out = np.zeros((h, w), np.float32)
    amp, total = 1.0, 0.0
    for o in range(octaves):
        cells = base * 2 ** o
        gh = max(2, int(round(cells * h / max(h, w))) + 1)
        gw = max(2, int(round(cells * w / max(h, w))) + 1)
        grid = rng.random((gh, gw), dtype=np.float32)
        out += amp * cv2.resize(grid, (w, h), interpolation=cv2.INTER_CUBIC)
        total += amp
        amp *= 0.5
    out /= total
    lo, hi = float(out.min()), float(out.max())
    return (out - lo) / max(hi - lo, 1e-6)


def noise_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Perlin-like noise mapped between two random colours, plus a little per-channel noise.

    Returns (h, w, 3) float32 in 0..255.
    """
    t = noise_field(h, w, rng)
    a, b = _random_colour(rng), _random_colour(rng)
    out = a + t[..., None] * (b - a)
    # A second, independent field per channel keeps the texture from being a pure two-tone ramp.
    for c in range(3):
        out[..., c] += (noise_field(h, w, rng, octaves=3) - 0.5) * rng.uniform(0, 80)
    return np.clip(out, 0, 255)


def make_background(kind: str, h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """A background of one of :data:`BACKGROUNDS`, shape (h, w, 3), float32 in 0..255."""
    if kind == "solid":
        return solid_background(h, w, rng)
    if kind == "gradient":
        return gradient_background(h, w, rng)
    if kind == "noise":
        return noise_background(h, w, rng)
    raise ValueError(f"unknown background kind {kind!r}; expected one of {BACKGROUNDS}")


def composite(rgba: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Flatten a straight-alpha sprite over an opaque background ("over" operator).

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
        Straight (not premultiplied) alpha.
    background : ndarray, shape (H, W, 3), float32 or uint8, 0..255

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
    """
    a = rgba[..., 3:4].astype(np.float32) / 255.0
    out = rgba[..., :3].astype(np.float32) * a + background.astype(np.float32) * (1.0 - a)
    return np.clip(out + 0.5, 0, 255).astype(np.uint8)


def flatten(rgba: np.ndarray, kind: str, rng: np.random.Generator) -> np.ndarray:
    """The sprite flattened onto a fresh random background of ``kind``: (H, W, 3) uint8."""
    h, w = rgba.shape[:2]
    return composite(rgba, make_background(kind, h, w, rng))
