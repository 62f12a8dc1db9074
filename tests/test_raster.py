"""The exact rasteriser's two walks agree, and so do the two ways Douglas-Peucker finds its farthest point."""

from __future__ import annotations

import numpy as np
import pytest

from spinemesh.mesher import raster
from spinemesh.mesher.geometry import loop_is_simple


def _random_segments(rng: np.random.Generator, kind: int) -> np.ndarray:
    k = int(rng.integers(1, 12))
    if kind == 0:  # anywhere, partly outside the box
        return rng.uniform(-5, 45, (k, 2, 2))
    if kind == 1:  # on grid lines and corners
        return rng.integers(-3, 43, (k, 2, 2)).astype(float)
    if kind == 2:  # through pixel centres
        return np.round(rng.uniform(-5, 45, (k, 2, 2)) * 2) / 2
    loop = rng.uniform(-3, 43, (k + 2, 2))  # a loop with some zero-length segments
    s = np.stack([loop, np.roll(loop, -1, axis=0)], axis=1)
    zero = rng.random(len(s)) < 0.2
    s[zero, 1] = s[zero, 0]
    return s


@pytest.mark.parametrize("walk", [raster.centres_inside, raster.crossed_pixels])
def test_few_segment_walk_equals_array_walk(walk, monkeypatch):
    monkeypatch.setattr(raster, "RASTER_FEW_CROSSINGS", raster.FEW_CROSSINGS)  # the walk wherever it may be taken
    rng = np.random.default_rng(27)
    cases = []
    for trial in range(2000):
        h, w = (int(v) for v in rng.integers(1, 40, 2))
        cases.append((_random_segments(rng, trial % 4), (h, w)))
    few = [walk(s, shape) for s, shape in cases]
    monkeypatch.setattr(raster, "FEW_SEGMENTS", -1)  # the array walk for every case
    for (s, shape), got in zip(cases, few):
        assert np.array_equal(got, walk(s, shape)), (s.tolist(), shape)


def test_changed_edges_check_equals_whole_loop_check():
    """A simple loop with one vertex moved: testing only its two edges answers as the whole test."""
    rng = np.random.default_rng(3)
    compared = 0
    for _ in range(3000):
        loop = rng.integers(0, 12, (int(rng.integers(4, 9)), 2)).astype(float)
        if not loop_is_simple(loop):
            continue
        i = int(rng.integers(len(loop)))
        moved = loop.copy()
        moved[i] = rng.integers(0, 12, 2)
        assert loop_is_simple(moved, np.array([(i - 1) % len(loop), i])) == loop_is_simple(moved)
        compared += 1
    assert compared > 100


def test_art_hit_tests_equal_masked_rasters(monkeypatch):
    """any_centre_inside and any_crossed answer as the rasters ANDed with the art, either walk."""
    rng = np.random.default_rng(28)
    cases = []
    for trial in range(2000):
        h, w = (int(v) for v in rng.integers(1, 40, 2))
        cases.append((_random_segments(rng, trial % 4), rng.random((h, w)) < rng.choice([0.01, 0.2, 0.9])))
    hits = 0
    for few in (True, False):
        if not few:
            monkeypatch.setattr(raster, "FEW_SEGMENTS", -1)
        for s, art in cases:
            centre = bool((art & raster.centres_inside(s, art.shape)).any())
            crossed = bool((art & raster.crossed_pixels(s, art.shape)).any())
            assert raster.any_centre_inside(s, art) == centre, (s.tolist(), art.shape)
            assert raster.any_crossed(s, art) == crossed, (s.tolist(), art.shape)
            hits += centre + crossed
    assert 0 < hits < 8000


def test_douglas_peucker_keeps_the_same_points_with_hypot_taken_only_near_the_farthest(monkeypatch):
    """Long stretches find their farthest point from squared lengths first (_farthest): the
    same kept points as np.hypot over every point, on contour-like and arbitrary points."""
    from spinemesh.mesher import geometry

    rng = np.random.default_rng(29)
    cases = []
    for i in range(1500):
        n = int(rng.integers(3, 300))
        if i % 4 == 3:
            points = rng.uniform(0, 400, (n, 2))
        else:
            points = np.cumsum(rng.integers(-1, 2, (n, 2)), axis=0) + rng.integers(0, 500, 2) + 0.5 * (i % 2)
        cases.append((points, float(rng.choice([0.0, 0.5, 1.0, 2 ** 0.5, 3.0, 8.0])), bool(i % 3)))
    monkeypatch.setattr(geometry, "LONG_STRETCH", 4)
    squared_first = [geometry.dp_indices(p, eps, closed) for p, eps, closed in cases]
    monkeypatch.setattr(geometry, "LONG_STRETCH", 10 ** 9)
    for (p, eps, closed), kept in zip(cases, squared_first):
        assert np.array_equal(kept, geometry.dp_indices(p, eps, closed)), (p.tolist(), eps, closed)


def test_segments_along_grid_lines_are_skipped_by_the_walk_as_the_array_walk_finds_nothing(monkeypatch):
    """A segment lying on a grid line (the image border of a clipped hull) crosses no open square:
    the walk leaves it out, with the same squares and answers as the array version."""
    monkeypatch.setattr(raster, "RASTER_FEW_CROSSINGS", raster.FEW_CROSSINGS)  # the walk wherever it may be taken
    rng = np.random.default_rng(30)
    cases = []
    for trial in range(1500):
        h, w = (int(v) for v in rng.integers(1, 40, 2))
        s = _random_segments(rng, trial % 4)
        on_line = rng.random(len(s)) < 0.5
        axis = rng.integers(0, 2, len(s))
        for i in np.flatnonzero(on_line):  # both ends on one whole x (or y), some on the border
            value = float(rng.choice([0, w, h, int(rng.integers(-3, 43))]))
            s[i, :, axis[i]] = value
        cases.append((s, rng.random((h, w)) < rng.choice([0.2, 0.9])))
    few = [(raster.crossed_pixels(s, art.shape), raster.any_crossed(s, art)) for s, art in cases]
    monkeypatch.setattr(raster, "FEW_SEGMENTS", -1)  # the array walk for every case
    skipped = 0
    for (s, art), (crossed, hit) in zip(cases, few):
        assert np.array_equal(crossed, raster.crossed_pixels(s, art.shape)), (s.tolist(), art.shape)
        assert hit == bool((art & crossed).any())
        skipped += int(((s[:, 0, 0] == s[:, 1, 0]) & (s[:, 0, 0] % 1 == 0)).sum())
    assert skipped > 1000


def test_douglas_peucker_with_splits_kept_across_tolerances_keeps_the_same_points():
    """dp_indices given the splits of earlier calls on the same points (coarse to fine, as the
    hull tries its tolerances, or in any order) keeps the same points as a fresh call."""
    from spinemesh.mesher import geometry

    rng = np.random.default_rng(31)
    for i in range(400):
        n = int(rng.integers(3, 400))
        points = np.cumsum(rng.integers(-1, 2, (n, 2)), axis=0).astype(np.float64)
        closed = bool(i % 3)
        tolerances = [8.0, 4.0, 2.0, 0.5] if i % 2 else list(rng.choice([0.5, 1.0, 3.0, 8.0], 4))
        splits: dict = {}
        for eps in tolerances:
            kept = geometry.dp_indices(points, float(eps), closed, splits=splits)
            assert np.array_equal(kept, geometry.dp_indices(points, float(eps), closed)), (points.tolist(), eps)
        assert splits or n <= 2


def test_pair_keys_find_the_rows_np_unique_finds():
    """np.unique of pair_keys: the same rows, order, inverse and counts as np.unique(axis=0);
    the boundary edges of random triangle sets as with the row-wise unique."""
    rng = np.random.default_rng(32)
    for k in (1, 2, 5, 40, 300):
        pairs = rng.integers(0, int(rng.integers(1, 60)), (k, 2))
        rows, inv, counts = np.unique(pairs, axis=0, return_inverse=True, return_counts=True)
        keys, kinv, kcounts = np.unique(raster.pair_keys(pairs), return_inverse=True, return_counts=True)
        m = int(pairs[:, 1].max()) + 1
        assert np.array_equal(np.stack([keys // m, keys % m], axis=1), rows)
        assert np.array_equal(kinv, inv.reshape(-1)) and np.array_equal(kcounts, counts)
        t = rng.integers(0, 30, (k, 3))
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        _, inv, counts = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True, return_counts=True)
        assert np.array_equal(raster.boundary_index_edges(t), e[counts[inv.reshape(-1)] == 1])
    assert raster.boundary_index_edges(np.zeros((0, 3), np.int64)).shape == (0, 2)


def test_toggle_parity_is_the_parity_of_the_counts():
    """The parities of the cells named, as the counts' parities, and the same rows of odd pixels."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        h, w = (int(v) for v in rng.integers(1, 40, 2))
        cells = rng.integers(0, h * (w + 1), int(rng.integers(0, 300)))
        counts = np.bincount(cells, minlength=h * (w + 1))
        parity = raster._toggle_parity(cells, h * (w + 1))
        assert parity.dtype == np.uint8 and (parity == counts % 2).all()
        assert (raster._odd_from_left(parity, h, w) == raster._odd_from_left(counts, h, w)).all()
