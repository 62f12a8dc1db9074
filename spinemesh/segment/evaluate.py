"""``segment-eval``: how well the network and the classical baselines recover sprite masks.

Every held-out sprite (games on the ``val`` side of the data sets' split, which training
never reads) is flattened, in its own frame, onto each kind of background of
:data:`~spinemesh.segment.composite.BACKGROUNDS`; every method predicts a mask at the image's
own size, scored against the alpha mask (alpha > 128): IoU, Dice and pixel accuracy per
image, their mean and median per kind and method, and the worst cases.

A method that fails on an image (a baseline raising
:class:`~spinemesh.segment.baseline.BaselineFailed`) scores 0 there and is counted.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..foreground import alpha_mask
from .baseline import BaselineFailed, baseline_mask
from .composite import BACKGROUNDS, flatten
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
    failed: int = 0

    def add(self, pred: np.ndarray | None, truth: np.ndarray, seconds: float) -> float:
        """Score one prediction (``None``: the method failed, scored 0); returns its IoU."""
        if pred is None:
            self.failed += 1
            i, d, a = 0.0, 0.0, float((~truth).mean())
        else:
            i, d, a = mask_metrics(pred, truth)
        self.iou.append(i)
        self.dice.append(d)
        self.acc.append(a)
        self.seconds.append(seconds)
        return i

    def summary(self) -> dict[str, float]:
        return {"iou": float(np.mean(self.iou)), "iou_median": float(np.median(self.iou)),
                "dice": float(np.mean(self.dice)), "dice_median": float(np.median(self.dice)),
                "acc": float(np.mean(self.acc)), "ms": 1000 * float(np.median(self.seconds)),
                "n": len(self.iou), "failed": self.failed}


def eval_image(sprite: Sprite, kind_index: int, sprite_index: int, seed: int) -> np.ndarray:
    """The flattened image one (sprite, background kind) pair is scored on: (H, W, 3) uint8.

    Deterministic in its arguments, so every method (and a later picture of the worst
    cases) sees the same image.
    """
    rng = np.random.default_rng((seed, kind_index, sprite_index))
    return flatten(sprite.rgba, BACKGROUNDS[kind_index], rng)


def evaluate_methods(sprites: list[Sprite], methods: dict, backgrounds=BACKGROUNDS, seed: int = 7,
                     progress=None) -> tuple[dict, list[tuple[float, str, int]]]:
    """Score mask methods on sprites flattened onto each kind of background.

    Parameters
    ----------
    sprites : list of Sprite
        Held-out sprites with alpha (the ground truth).
    methods : dict of name -> callable((H, W, 3) uint8) -> (H, W) bool
        The first one is "the" method whose worst cases are returned.
    backgrounds : iterable of str
        Kinds from :data:`~spinemesh.segment.composite.BACKGROUNDS`.
    seed : int
        The backgrounds are drawn from this seed.
    progress : callable(), optional
        Called once per sprite and background.

    Returns
    -------
    scores : dict
        ``scores[background][method] = {"iou", "iou_median", "dice", "dice_median", "acc",
        "ms", "n", "failed"}`` (``ms``: median time per image).
    per_image : list of (iou, background, sprite index)
        The first method's IoU on every image.
    """
    out: dict[str, dict[str, MethodScores]] = {b: {m: MethodScores() for m in methods} for b in backgrounds}
    first = next(iter(methods))
    per_image = []
    for kind in backgrounds:
        ki = BACKGROUNDS.index(kind)
        for si, sprite in enumerate(sprites):
            rgb = eval_image(sprite, ki, si, seed)
            truth = alpha_mask(sprite.rgba)
            for name, fn in methods.items():
                t0 = time.perf_counter()
                try:
                    pred = fn(rgb)
                except BaselineFailed:
                    pred = None
                iou = out[kind][name].add(pred, truth, time.perf_counter() - t0)
                if name == first:
                    per_image.append((iou, kind, si))
            if progress:
                progress()
    return {b: {m: s.summary() for m, s in per.items()} for b, per in out.items()}, per_image


def _fit(image: np.ndarray, cell: int, nearest: bool) -> np.ndarray:
    """An (H, W, 3) uint8 image scaled to fit a (cell, cell) box, centred on mid grey."""
    import cv2

    h, w = image.shape[:2]
    s = cell / max(h, w)
    size = (max(1, round(w * s)), max(1, round(h * s)))
    small = cv2.resize(image, size, interpolation=cv2.INTER_NEAREST if nearest else cv2.INTER_AREA)
    box = np.full((cell, cell, 3), 128, np.uint8)
    y, x = (cell - size[1]) // 2, (cell - size[0]) // 2
    box[y:y + size[1], x:x + size[0]] = small
    return box


def worst_cases_picture(sprites: list[Sprite], per_image: list[tuple[float, str, int]], method, n: int = 16,
                        seed: int = 7, cell: int = 128) -> np.ndarray:
    """A grid of the ``n`` lowest-IoU images, two columns; each entry shows the flattened
    input, the truth and the prediction (white: sprite), each fitted in a ``cell`` px square
    on grey, over a line with the IoU, the background kind and the sprite's name.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8 RGB
    """
    import cv2

    entries = []
    for iou, kind, si in sorted(per_image)[:n]:
        rgb = eval_image(sprites[si], BACKGROUNDS.index(kind), si, seed)
        panels = [_fit(rgb, cell, False)]
        for m in (alpha_mask(sprites[si].rgba), method(rgb)):
            panels.append(_fit(np.repeat(np.where(m, 255, 0).astype(np.uint8)[..., None], 3, 2), cell, True))
        row = np.hstack([np.pad(p, ((0, 0), (0, 4), (0, 0)), constant_values=255) for p in panels])
        label = np.full((30, row.shape[1], 3), 255, np.uint8)
        name = sprites[si].name
        cv2.putText(label, f"IoU {iou:.2f} on {kind}", (2, 12), cv2.FONT_HERSHEY_PLAIN, 0.9, (0, 0, 0), 1,
                    cv2.LINE_AA)
        cv2.putText(label, name if len(name) <= 64 else "..." + name[-61:], (2, 26), cv2.FONT_HERSHEY_PLAIN,
                    0.8, (0, 0, 0), 1, cv2.LINE_AA)
        entries.append(np.vstack([row, label, np.full((6, row.shape[1], 3), 255, np.uint8)]))
    if not entries:
        return np.full((cell, cell, 3), 255, np.uint8)
    half = (len(entries) + 1) // 2
    left = np.vstack(entries[:half])
    right = np.vstack(entries[half:]) if entries[half:] else np.full((1, left.shape[1], 3), 255, np.uint8)
    right = np.pad(right, ((0, left.shape[0] - right.shape[0]), (0, 0), (0, 0)), constant_values=255)
    return np.hstack([left, np.full((left.shape[0], 12, 3), 255, np.uint8), right])


def default_methods(model_path=None, baselines=("floodfill", "grabcut"), threads: int = 0, **options) -> dict:
    """The network (ONNX, with ``predict_mask`` options) and the named classical baselines."""
    from . import predict_mask

    methods = {"network": lambda rgb: predict_mask(rgb, model_path, threads=threads, **options)}
    for b in baselines:
        methods[b] = lambda rgb, b=b: baseline_mask(rgb, b)
    return methods
