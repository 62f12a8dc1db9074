"""Packing on several workers: an atlas's fills side by side, and whole atlases side by side.

The fills of one group (:func:`~spinemesh.pack.atlas_pack.fill_plan`) are independent: run one
after another, each only stops early once it cannot beat the best so far; run side by side,
each stops at the atlas's own page texels instead, and the best of them (the first on a tie) is
the very packing the sequential run keeps, since a fill that stopped early could not have beaten
it. Footprints travel to the workers compactly: a solid box as its shape, any other mask as
bits (:func:`pack_masks`).
"""

from __future__ import annotations

import numpy as np


def _pack_mask(mask: np.ndarray) -> tuple:
    return (mask.shape, None) if mask.all() else (mask.shape, np.packbits(mask))


def _unpack_mask(packed: tuple) -> np.ndarray:
    shape, bits = packed
    if bits is None:
        return np.ones(shape, bool)
    return np.unpackbits(bits, count=shape[0] * shape[1]).reshape(shape).astype(bool)


def pack_masks(candidates: list[list[np.ndarray]], hard: list[list[np.ndarray]] | None) -> tuple:
    """Footprints' masks (and hard parts: None where a mask is all hard) as small picklable data."""
    masks = [[_pack_mask(m) for m in ms] for ms in candidates]
    hards = None if hard is None else [[None if h is m else _pack_mask(h) for h, m in zip(hs, ms)]
                                       for hs, ms in zip(hard, candidates)]
    return masks, hards


def unpack_masks(packed: tuple) -> tuple[list[list[np.ndarray]], list[list[np.ndarray]] | None]:
    """:func:`pack_masks` undone: the masks, and the hard parts (the mask itself where all hard)."""
    masks, hards = packed
    candidates = [[_unpack_mask(m) for m in ms] for ms in masks]
    if hards is None:
        return candidates, None
    return candidates, [[m if h is None else _unpack_mask(h) for h, m in zip(hs, ms)]
                        for hs, ms in zip(hards, candidates)]


def fill_task(arg: tuple):
    """A worker's task: one fill of a group, ``(fill, packed masks, page limits, best)`` ->
    ``(texels, placements, sizes)`` or the ``best`` given."""
    from .atlas_pack import run_fill

    fill, packed, limits, best = arg
    candidates, hard = unpack_masks(packed)
    return run_fill(fill, candidates, hard, *limits, best)


class FillRunner:
    """Runs a group's fills on ``workers`` (:class:`spinemesh.cluster.Workers`), telling
    ``on_fill()`` as each ends; the ``fills`` argument of
    :func:`~spinemesh.pack.atlas_pack.pack_atlas`."""

    def __init__(self, workers, on_fill=None):
        self.workers, self.on_fill = workers, on_fill

    def __call__(self, plan: list[tuple], args: tuple, best) -> list:
        candidates, hard, *limits = args
        packed = pack_masks(candidates, hard)
        # first: this process waits for them, ahead of work queued meanwhile (a library's meshing)
        futures = [self.workers.submit(fill_task, (fill, packed, tuple(limits), best), first=True) for fill in plan]
        if self.on_fill:
            for _ in self.workers.as_completed(futures):
                self.on_fill()
        return [f.result() for f in futures]
