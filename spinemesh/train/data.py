"""Training samples: real sprites flattened onto random backgrounds (paper section 3.4).

Each sprite becomes a new image every time it is drawn: a random kind of background
(solid, gradient, Perlin-like noise), a random transparent margin (so the foreground covers
between all and a small part of the frame) and a random horizontal flip. The target is the
alpha mask (alpha > 128, section 3.1). Resizing and normalisation are the ones inference
uses (:mod:`spinemesh.segment.preprocess`).
"""

from __future__ import annotations

import numpy as np
import torch
from torch.utils.data import Dataset

from ..segment.composite import BACKGROUNDS, alpha_mask, flatten
from ..segment.preprocess import to_input, to_target
from ..segment.samples import Sprite


def random_margin(rgba: np.ndarray, rng: np.random.Generator, max_frac: float = 0.25) -> np.ndarray:
    """Pad with transparent pixels, up to ``max_frac`` of the size on each side."""
    h, w = rgba.shape[:2]
    t, b = (rng.uniform(0, max_frac, 2) * h).astype(int)
    l, r = (rng.uniform(0, max_frac, 2) * w).astype(int)
    return np.pad(rgba, ((t, b), (l, r), (0, 0)))


def make_sample(rgba: np.ndarray, size: int, rng: np.random.Generator, kind: str | None = None,
                augment: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """One (input, target) pair.

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
    size : int
        Model input side.
    kind : str, optional
        Background kind; random when ``None``.
    augment : bool
        Margin and flip (off for validation, where only the background is random).

    Returns
    -------
    x : ndarray, shape (3, size, size), float32
    y : ndarray, shape (size, size), float32 in {0, 1}
    """
    if augment:
        rgba = random_margin(rgba, rng)
        if rng.random() < 0.5:
            rgba = rgba[:, ::-1]
    kind = kind or BACKGROUNDS[rng.integers(len(BACKGROUNDS))]
    rgb = flatten(rgba, kind, rng)
    return to_input(rgb, size), to_target(alpha_mask(rgba), size)


class CompositeDataset(Dataset):
    """Training set: every access draws a new background, margin and flip."""

    def __init__(self, sprites: list[Sprite], size: int, seed: int = 0):
        self.sprites, self.size, self.seed = sprites, size, seed
        self.calls = 0

    def __len__(self) -> int:
        return len(self.sprites)

    def __getitem__(self, i: int):
        self.calls += 1
        rng = np.random.default_rng((self.seed, i, self.calls))
        x, y = make_sample(self.sprites[i].rgba, self.size, rng)
        return torch.from_numpy(x), torch.from_numpy(y)[None]


class FixedValDataset(Dataset):
    """Validation set: one fixed image per sprite, the background kind cycling through the three
    (so every kind is equally represented and every epoch sees the same images)."""

    def __init__(self, sprites: list[Sprite], size: int, seed: int = 12345):
        self.items = []
        for i, s in enumerate(sprites):
            rng = np.random.default_rng((seed, i))
            kind = BACKGROUNDS[i % len(BACKGROUNDS)]
            x, y = make_sample(s.rgba, size, rng, kind=kind, augment=False)
            self.items.append((torch.from_numpy(x), torch.from_numpy(y)[None], kind))

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, i: int):
        x, y, _ = self.items[i]
        return x, y
