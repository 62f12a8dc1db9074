"""Sprites with alpha, read from data sets made by ``spinemesh dataset``, for training and evaluation.

There is one data path: ``spinemesh dataset`` cuts every attachment image out of its project
and assigns its game to the ``train`` or ``val`` side (:func:`spinemesh.dataset.split_of`);
training and ``segment-eval`` read those folders through :func:`~spinemesh.dataset.open_dataset`.
Several data sets can be read together; an image in more than one (same content id) is
used once.

Numpy and OpenCV only: nothing here imports torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import cv2
import numpy as np

from ..foreground import alpha_mask
from ..images.texels import premultiply, unpremultiply


@dataclass
class Sprite:
    """One sprite image with its provenance.

    Attributes
    ----------
    id : str
        The data set's content id.
    name : str
        ``<project>/<image path>``, for people.
    project, game : str
        As the data set records them; the split is by ``game``.
    rgba : ndarray, shape (H, W, 4), uint8
        Straight alpha, the attachment's full frame, downscaled so that its longer side is at
        most the reader's ``max_side``.
    """

    id: str
    name: str
    project: str
    game: str
    rgba: np.ndarray


def shrink(rgba: np.ndarray, max_side: int) -> np.ndarray:
    """Downscale so the longer side is at most ``max_side`` (area filter on premultiplied colour,
    so transparent pixels do not bleed their hidden colour into the edges)."""
    h, w = rgba.shape[:2]
    s = max_side / max(h, w)
    if s >= 1:
        return rgba
    size = (max(1, round(w * s)), max(1, round(h * s)))
    return unpremultiply(cv2.resize(premultiply(rgba), size, interpolation=cv2.INTER_AREA))


def useful(rgba: np.ndarray, min_side: int = 16, min_fg: float = 0.02, max_fg: float = 0.98) -> bool:
    """Whether a sprite teaches (or tests) segmentation anything.

    Tiny images, nearly empty ones and fully opaque rectangles (whose mask is the whole
    image whatever the background) are left out.
    """
    h, w = rgba.shape[:2]
    if min(h, w) < min_side:
        return False
    fg = float(alpha_mask(rgba).mean())
    return min_fg <= fg <= max_fg


def dataset_rows(datasets: Iterable[str | Path], split: str | None = None,
                 limit_per_project: int | None = None, min_side: int = 16) -> list[tuple[object, dict]]:
    """``(dataset, row)`` for every sample of one side of the split, de-duplicated across data sets.

    Parameters
    ----------
    datasets : paths
        Data set folders written by ``spinemesh dataset``.
    split : {"train", "val", None}
        Which side of the data sets' game split (``None``: both).
    limit_per_project : int, optional
        At most this many samples per project, evenly spread in index order (quick runs).
    min_side : int
        Samples whose image is smaller than this on either side are left out.
    """
    from ..dataset import open_dataset

    seen: set[str] = set()
    by_project: dict[str, list[tuple[object, dict]]] = {}
    for path in datasets:
        ds = open_dataset(path)
        for row in ds.rows(split):
            if row["id"] in seen or min(row["width"], row["height"]) < min_side:
                continue
            seen.add(row["id"])
            by_project.setdefault(row["project"], []).append((ds, row))
    out = []
    for rows in by_project.values():
        if limit_per_project and len(rows) > limit_per_project:
            idx = np.linspace(0, len(rows) - 1, limit_per_project).round().astype(int)
            rows = [rows[i] for i in idx]
        out.extend(rows)
    return out


def load_sprites(datasets: Iterable[str | Path], split: str | None = None, max_side: int = 512,
                 limit_per_project: int | None = None) -> list[Sprite]:
    """Useful sprites of one side of the split, in memory (see :func:`dataset_rows`).

    Parameters
    ----------
    max_side : int
        Longest side kept, pixels (default 512).

    Returns
    -------
    list of Sprite
    """
    out = []
    for ds, row in dataset_rows(datasets, split, limit_per_project):
        rgba = ds.load_image(row)
        if not useful(rgba):
            continue
        out.append(Sprite(row["id"], f"{row['project']}/{row['name']}", row["project"], row["game"],
                          shrink(rgba, max_side)))
    return out
