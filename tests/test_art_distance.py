"""Distances to the art (:func:`spinemesh.rig.choice.distance_to_art`) and to bone segments
(:func:`spinemesh.rig.weights.segment_distances`), against shapely's (GEOS) and a point-by-point
reference."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from spinemesh.rig.choice import distance_to_art, outline_edges
from spinemesh.rig.weights import segment_distances


def _grid(n: int = 4, size: float = 30.0):
    """An n x n grid of squares, two triangles each."""
    xs = np.linspace(0, size, n + 1)
    world = np.array([(x, y) for y in xs for x in xs])
    tris = []
    for r in range(n):
        for c in range(n):
            a = r * (n + 1) + c
            tris += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return world, np.array(tris)


def _by_geos(points, world, tris):
    art = shapely.union_all(shapely.polygons(world[tris]))
    return shapely.distance(art, shapely.points(points))


def test_the_outline_leaves_out_the_edges_inside_the_art():
    world, tris = _grid(4)
    edges = outline_edges(world, tris)
    # the grid's border: 16 edges; its 40 inner edges and 16 diagonals have art on both sides
    assert len(edges) == 16
    on_border = (world[edges] % 30 == 0).all(axis=1).any(axis=1)
    assert on_border.all()


def test_a_folded_edge_stays_on_the_outline():
    world = np.array([[0.0, 0.0], [10.0, 0.0], [5.0, 8.0], [5.0, 4.0]])
    tris = np.array([[0, 1, 2], [0, 1, 3]])      # both on the same side of edge 0-1
    keys = {tuple(sorted(e)) for e in outline_edges(world, tris).tolist()}
    assert (0, 1) in keys
    # below the fold the art is 3 away, as GEOS measures it
    assert distance_to_art(np.array([[5.0, -3.0]]), world, tris)[0] == pytest.approx(3.0)


@pytest.mark.parametrize("seed", range(6))
def test_distances_match_geos_on_random_meshes(seed):
    rng = np.random.default_rng(seed)
    world, tris = _grid(int(rng.integers(1, 7)), float(rng.uniform(5, 500)))
    world = world @ np.array([[np.cos(seed), -np.sin(seed)], [np.sin(seed), np.cos(seed)]]) + rng.normal(size=2) * 50
    world += rng.normal(size=world.shape) * 0.3                  # no longer a perfect grid
    keep = rng.random(len(tris)) < 0.8                            # holes and bays
    tris = tris[keep] if keep.any() else tris
    span = np.ptp(world, axis=0).max()
    points = np.concatenate([
        world.mean(axis=0) + rng.normal(size=(400, 2)) * span,   # all around
        world[tris[:, 0]],                                         # the art's own corners
        (world[tris[:, 0]] + world[tris[:, 1]]) / 2,               # the middles of its edges
    ])
    ours, geos = distance_to_art(points, world, tris), _by_geos(points, world, tris)
    tiny = 1e-9 * span
    assert np.allclose(ours, geos, rtol=1e-12, atol=tiny)
    # on the art (GEOS may measure an edge's middle off its edge by rounding): 0, exactly
    assert np.array_equal(ours[geos <= tiny], np.zeros((geos <= tiny).sum()))
    assert (ours == 0).sum() > len(tris)


def test_no_points_or_no_triangles():
    world, tris = _grid(1)
    assert distance_to_art(np.zeros((0, 2)), world, tris).shape == (0,)
    assert np.isinf(distance_to_art(np.ones((2, 2)), world, np.zeros((0, 3), int))).all()


def test_segment_distances_match_point_by_point():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(50, 2)) * 40
    segments = rng.normal(size=(7, 2, 2)) * 40
    segments[2, 1] = segments[2, 0]                              # a point bone
    want = np.empty((50, 7))
    for i, p in enumerate(points):
        for j, (a, b) in enumerate(segments):
            ab = b - a
            t = 0.0 if not ab.any() else min(max(float((p - a) @ ab / (ab @ ab)), 0.0), 1.0)
            want[i, j] = np.hypot(*(p - (a + t * ab)))
    assert np.allclose(segment_distances(points, segments), want, rtol=1e-12, atol=1e-9)


def _every_point_against_the_outline_then_every_triangle(points, world, tris):
    """distance_to_art as it was measured before: every point against the outline edges, then
    0 for those within the art's box at more than 0 that lie in any triangle (all at once)."""
    from spinemesh.rig.choice import distance_to_outline

    out = distance_to_outline(points, world, tris)
    corner = world[tris]
    lo, hi = corner.reshape(-1, 2).min(axis=0), corner.reshape(-1, 2).max(axis=0)
    test = np.flatnonzero((points >= lo).all(axis=1) & (points <= hi).all(axis=1) & (out > 0))
    cx, cy = corner[..., 0].T[..., None], corner[..., 1].T[..., None]
    ex, ey = cx[[1, 2, 0]] - cx, cy[[1, 2, 0]] - cy
    px, py = points[test, 0], points[test, 1]
    u, v = ex * (py - cy), ey * (px - cx)
    cross = u - v
    slack = 1e-13 * (np.abs(u) + np.abs(v))
    out[test[((cross >= -slack).all(axis=0) | (cross <= slack).all(axis=0)).any(axis=0)]] = 0.0
    return out


@pytest.mark.parametrize("seed", range(8))
def test_the_triangles_tested_first_give_the_distances_to_the_last_bit(seed, monkeypatch):
    """Points found in a triangle are measured against no edge and no further triangle: the
    distances are those of measuring every point against every edge and triangle, bit for bit,
    degenerate triangles, folds and points on corners and edges included."""
    from spinemesh.rig import choice

    rng = np.random.default_rng(seed)
    world, tris = _grid(int(rng.integers(1, 9)), float(rng.uniform(5, 500)))
    world = world + rng.normal(size=world.shape) * rng.uniform(0, 2)
    tris = tris[rng.permutation(len(tris))][: max(1, int(len(tris) * rng.uniform(0.5, 1)))]
    flat = np.array([[0, 1, 2]])
    world = np.concatenate([world, [[-40.0, 3.0], [-20.0, 3.0], [-30.0, 3.0]]])  # a triangle of no area
    tris = np.concatenate([tris, flat + len(world) - 3, tris[:1, [0, 2, 1]]])   # and one folded back
    span = np.ptp(world, axis=0).max()
    points = np.concatenate([
        world.mean(axis=0) + rng.normal(size=(3000, 2)) * span / 2,
        world[tris[:, 0]], (world[tris[:, 0]] + world[tris[:, 1]]) / 2,
        np.column_stack([np.linspace(-60, 10, 50), np.full(50, 3.0)]),           # along the flat one
    ])
    want = _every_point_against_the_outline_then_every_triangle(points, world, tris)
    for at_once in (1, 3, choice.TRIANGLES_AT_ONCE, 1000):
        monkeypatch.setattr(choice, "TRIANGLES_AT_ONCE", at_once)
        got = distance_to_art(points, world, tris)
        assert got.tobytes() == want.tobytes()
    assert (want == 0).sum() > len(tris) and np.isfinite(want).all() and (want > 0).sum() > 100
