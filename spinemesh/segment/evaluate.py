"""``segment-eval``: how well the network and the classical baselines recover sprite masks.

Each held-out sprite (games the network never saw, :func:`~spinemesh.segment.samples.split_of`)
is flattened onto each of the three kinds of background of paper section 3.4, every method
predicts a mask at the image's own size, and IoU, Dice and pixel accuracy are averaged per
image against the alpha mask (alpha > 128).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .baseline import baseline_mask
from .composite import BACKGROUNDS, alpha_mask, flatten
from .samples import Sprite


def mask_metrics(pred: np.ndarray, truth: np.ndarray) -> tuple[float, float, float]:
    """(IoU, Dice, pixel accuracy) of two (H, W) bool masks; two empty masks score 1."""
    inter = float(np.logical_and(pred, truth).sum())
    union = float(np.logical_or(pred, truth).sum())
    total = float(pred.sum() + truth.sum())
    iou = inter / union if union else 1.0
    dice = 2 * inter / total if total else 1.0
    return iou, dice, float((pred == truth).mean())


@dataclass
class MethodScores:
    """Per-image scores of one method on one kind of background."""

    iou: list[float] = field(default_factory=list)
    dice: list[float] = field(default_factory=list)
    acc: list[float] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)

    def add(self, pred: np.ndarray, truth: np.ndarray, seconds: float) -> None:
        i, d, a = mask_metrics(pred, truth)
        self.iou.append(i)
        self.dice.append(d)
        self.acc.append(a)
        self.seconds.append(seconds)

    def summary(self) -> dict[str, float]:
        return {"iou": float(np.mean(self.iou)), "dice": float(np.mean(self.dice)),
                "acc": float(np.mean(self.acc)), "ms": 1000 * float(np.median(self.seconds)),
                "n": len(self.iou)}


def evaluate_methods(sprites: list[Sprite], methods: dict, backgrounds=BACKGROUNDS, seed: int = 7,
                     progress=None) -> dict[str, dict[str, dict[str, float]]]:
    """Score mask methods on sprites flattened onto each kind of background.

    Parameters
    ----------
    sprites : list of Sprite
        Held-out sprites with alpha (the ground truth).
    methods : dict of name -> callable((H, W, 3) uint8) -> (H, W) bool
    backgrounds : iterable of str
        Kinds from :data:`~spinemesh.segment.composite.BACKGROUNDS`.
    seed : int
        The backgrounds are drawn from this seed, so every method sees the same images.
    progress : callable(), optional
        Called once per sprite and background.

    Returns
    -------
    dict
        ``scores[background][method] = {"iou", "dice", "acc", "ms", "n"}`` (means per image;
        ``ms`` is the median time per image).
    """
    out: dict[str, dict[str, MethodScores]] = {b: {m: MethodScores() for m in methods} for b in backgrounds}
    for bi, kind in enumerate(backgrounds):
        for si, sprite in enumerate(sprites):
            rng = np.random.default_rng((seed, bi, si))
            rgb = flatten(sprite.rgba, kind, rng)
            truth = alpha_mask(sprite.rgba)
            for name, fn in methods.items():
                t0 = time.perf_counter()
                pred = fn(rgb)
                out[kind][name].add(pred, truth, time.perf_counter() - t0)
            if progress:
                progress()
    return {b: {m: s.summary() for m, s in per.items()} for b, per in out.items()}


def default_methods(model_path=None, baselines=("floodfill", "grabcut"), threads: int = 0) -> dict:
    """The network (ONNX) and the named classical baselines, as ``evaluate_methods`` wants them."""
    from . import predict_mask

    methods = {"network": lambda rgb: predict_mask(rgb, model_path, threads=threads)}
    for b in baselines:
        methods[b] = lambda rgb, b=b: baseline_mask(rgb, b)
    return methods
