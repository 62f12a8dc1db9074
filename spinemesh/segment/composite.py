"""Backgrounds and compositing: how a sprite with alpha becomes "art without alpha".

Paper section 3.4 (Data Augmentation) flattens every training sprite onto a random solid
colour, gradient or Perlin-like noise; the mask to learn is its alpha thresholded at 128
(section 3.1). Users flatten sprites onto more than that, so there are more kinds here,
and ``segment-eval`` scores each kind separately:

``solid``       one random colour;
``gradient``    linear gradient between two random colours in a random direction;
``noise``       coarse colour noise: random RGB at 1/16 of the size, enlarged bicubically;
``radial``      radial gradient around a random centre;
``perlin``      fractal value noise between two colours (the paper's "Perlin-like");
``grain``       a solid or gradient with fine per-pixel grain;
``texture``     stripes, checks or waves in two colours, at a random scale and angle;
``clutter``     a busy texture with other sprites pasted over it (the "sprite-like colours"
                case; only training draws the clutter sprites, see ``spinemesh.train.augment``).

Every generator takes ``(h, w, rng)`` and returns (h, w, 3) float32 in 0..255.
Numpy and OpenCV only: nothing here imports torch.
"""

from __future__ import annotations

import cv2
import numpy as np

#: The kinds ``segment-eval`` scores; the first three are the ones the model card leads with.
BACKGROUNDS = ("solid", "gradient", "noise", "radial", "perlin", "grain", "texture")


def _random_colour(rng: np.random.Generator) -> np.ndarray:
    return rng.integers(0, 256, size=3).astype(np.float32)


def _ramp(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Map a (h, w) field in 0..1 between two random colours: (h, w, 3) float32."""
    a, b = _random_colour(rng), _random_colour(rng)
    return a + t[..., None] * (b - a)


def solid_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """One random RGB colour everywhere."""
    return np.broadcast_to(_random_colour(rng), (h, w, 3)).astype(np.float32)


def gradient_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Linear gradient between two random colours in a random direction."""
    angle = rng.uniform(0, 2 * np.pi)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    t = xx * np.cos(angle) + yy * np.sin(angle)
    t = (t - t.min()) / max(float(t.max() - t.min()), 1e-6)
    return _ramp(t, rng)


def radial_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Radial gradient: two colours from a random centre (possibly outside the image) outwards."""
    cy, cx = rng.uniform(-0.25, 1.25) * h, rng.uniform(-0.25, 1.25) * w
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    r = np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2)
    t = r / max(float(r.max()), 1e-6)
    return _ramp(t ** rng.uniform(0.5, 2.0), rng)


def coarse_noise_background(h: int, w: int, rng: np.random.Generator, cell: float = 16.0) -> np.ndarray:
    """Random RGB on a grid ``cell`` times coarser than the image, enlarged bicubically.

    ``cell`` 16 is the "coarse colour noise" of ``segment-eval``; training draws it from fine
    grain (2) to large blotches (64).
    """
    gh, gw = max(2, int(round(h / cell))), max(2, int(round(w / cell)))
    grid = rng.integers(0, 256, size=(gh, gw, 3)).astype(np.float32)
    return np.clip(cv2.resize(grid, (w, h), interpolation=cv2.INTER_CUBIC), 0, 255)


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


def perlin_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Perlin-like noise between two random colours, plus an independent field per channel."""
    out = _ramp(noise_field(h, w, rng), rng)
    # A second field per channel keeps the texture from being a pure two-tone ramp.
    for c in range(3):
        out[..., c] += (noise_field(h, w, rng, octaves=3) - 0.5) * rng.uniform(0, 80)
    return np.clip(out, 0, 255)


def grain_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """A solid or a gradient with per-pixel grain (film grain, dithering, paper texture)."""
    base = solid_background(h, w, rng) if rng.random() < 0.5 else gradient_background(h, w, rng)
    sigma = rng.uniform(4, 30)
    grain = rng.normal(0, sigma, (h, w, 1 if rng.random() < 0.5 else 3)).astype(np.float32)
    return np.clip(base + grain, 0, 255)


def texture_background(h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Two-colour stripes, checks or waves at a random period (4-64 px) and angle."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    angle = rng.uniform(0, np.pi)
    u = xx * np.cos(angle) + yy * np.sin(angle)
    v = -xx * np.sin(angle) + yy * np.cos(angle)
    period = rng.uniform(4, 64)
    pattern = rng.integers(3)
    if pattern == 0:      # stripes
        t = (np.floor(u / period) % 2).astype(np.float32)
    elif pattern == 1:    # checks
        t = ((np.floor(u / period) + np.floor(v / period)) % 2).astype(np.float32)
    else:                 # waves
        t = 0.5 + 0.25 * (np.sin(2 * np.pi * u / period) + np.sin(2 * np.pi * v / (period * rng.uniform(0.5, 2))))
    if rng.random() < 0.5:  # soften the edges
        t = cv2.GaussianBlur(t, (0, 0), rng.uniform(0.5, 3))
    return _ramp(t, rng)


GENERATORS = {
    "solid": solid_background,
    "gradient": gradient_background,
    "noise": coarse_noise_background,
    "radial": radial_background,
    "perlin": perlin_background,
    "grain": grain_background,
    "texture": texture_background,
}


def make_background(kind: str, h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """A background of one of :data:`BACKGROUNDS`, shape (h, w, 3), float32 in 0..255."""
    try:
        gen = GENERATORS[kind]
    except KeyError:
        raise ValueError(f"unknown background kind {kind!r}; expected one of {BACKGROUNDS}") from None
    return gen(h, w, rng)


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
