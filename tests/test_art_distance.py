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
