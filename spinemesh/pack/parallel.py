"""Packing on several workers: an atlas's fills side by side, and whole atlases side by side.

The fills of one group (:func:`~spinemesh.pack.atlas_pack.fill_plan`) are independent: run one
after another, each stops early once it cannot beat the best so far. Run side by side, as many
at a time as there are workers, in the plan's order, each is given the best of the fills
before it in the plan that have ended (the atlas's own page texels when none has): a fill that
stopped early could not have beaten those, and one that ends keeps its packing whatever bound
it was given. A fill's result can still depend on its bound beyond stopping early (whole
power-of-two page sizes are chosen below it, a single page's height is capped by it), so a fill
that ran with a looser bound than the run one after another would have given it, and beats that
bound, is run again here with it (:func:`rerun_loosely_bounded`): the fills that beat every fill
before them (the packing kept, and the layouts kept besides it) are then the very ones the run one
after another finds, whatever the workers' timing, and the output never depends on ``--jobs``.
Only the fills running at the same time as an earlier one cannot stop at its result. Footprints
travel to the workers compactly: a solid box as its shape, any other mask as bits
(:func:`pack_masks`).
"""

from __future__ import annotations

import numpy as np

from .atlas_pack import beats, run_fill


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
    fill, packed, limits, best = arg
    candidates, hard = unpack_masks(packed)
    return run_fill(fill, candidates, hard, *limits, best)


class FillRunner:
    """Runs a group's fills on ``workers`` (:class:`spinemesh.cluster.Workers`), telling
    ``on_fill()`` as each ends; the ``fills`` argument of
    :func:`~spinemesh.pack.atlas_pack.pack_atlas`.

    As many fills run at once as the workers have slots, started in the plan's order, each
    bounded by the best result of the fills before it that have ended (see the module notes):
    with all of them started at once, every fill ran until the atlas's own page texels, and two
    processes spent more CPU time than one (the 18-page atlas of ``bench_pack_scale.py --made``,
    19.9 CPU s against 15.3; now 16.8).
    """

    def __init__(self, workers, on_fill=None):
        self.workers, self.on_fill = workers, on_fill

    def __call__(self, plan: list[tuple], args: tuple, best) -> list:
        candidates, hard, *limits = args
        packed = pack_masks(candidates, hard)
        results: list = [None] * len(plan)
        bounds: list = [None] * len(plan)
        running: dict = {}
        waiting = iter(range(len(plan)))
        while True:
            while len(running) < max(1, self.workers.slots):
                k = next(waiting, None)
                if k is None:
                    break
                bound = bounds[k] = _best_before(results[:k], best)
                # first: this process waits for them, ahead of work queued meanwhile (a library's meshing)
                future = self.workers.submit(fill_task, (plan[k], packed, tuple(limits), bound), first=True)
                running[future] = k
            if not running:
                return rerun_loosely_bounded(results, bounds, best,
                                             lambda k, exact: run_fill(plan[k], *args, exact))
            done = next(iter(self.workers.as_completed(list(running))))
            results[running.pop(done)] = done.result()
            if self.on_fill:
                self.on_fill()


def rerun_loosely_bounded(results: list, bounds: list, best, rerun) -> list:
    """``results`` of a plan's fills, each fill that ran with a looser bound than the fills before
    it give, one after another, and beats that bound, replaced by ``rerun(k, exact bound)``.

    ``bounds``: the bound each fill was given (``(texels, None, None)``, or None for no bound);
    ``best``: the bound of the first fill. Only a fill that beats every fill before it is kept
    (:func:`~spinemesh.pack.atlas_pack.group_layouts`), so one that does not beat the exact bound
    needs no second run whatever it found.
    """
    results = list(results)
    for k, found in enumerate(results):
        exact = _best_before(results[:k], best)
        looser = exact is not None and (bounds[k] is None or bounds[k][0] > exact[0])
        if looser and beats(found, exact):
            results[k] = rerun(k, exact)
    return results


def _best_before(results: list, best):
    """The bound a fill is given: the fewest texels of ``results`` (the fills before it that have
    ended, None for the others) and ``best``, as ``(texels, None, None)`` (its placements stay here)."""
    for found in results:
        if beats(found, best):
            best = found
    return best if best is None else (best[0], None, None)
