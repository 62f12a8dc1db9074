"""Metrics on shapes whose answers are known, and on the artists' own meshes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spinemesh.images.decode import load_rgba
from spinemesh.metrics import (angle_ratio, boundary_adherence, coverage, mesh_coverage_mask, mesh_problems,
                               opaque_mask, triangle_areas, waste)

from conftest import EXAMPLES

SQUARE_V = np.array([[2, 2], [6, 2], [6, 5], [2, 5]], float)
SQUARE_T = np.array([[0, 1, 2], [0, 2, 3]])


def test_square_on_grid_lines_covers_exactly_its_pixels():
    inside = mesh_coverage_mask(SQUARE_V, SQUARE_T, (8, 8), "inside")
    expected = np.zeros((8, 8), bool)
    expected[2:5, 2:6] = True
    assert (inside == expected).all()
    # touching squares: one ring more, the corners included
    touch = mesh_coverage_mask(SQUARE_V, SQUARE_T, (8, 8), "touch")
    ring = np.zeros((8, 8), bool)
    ring[1:6, 1:7] = True
    assert (touch == ring).all()
    assert (mesh_coverage_mask(SQUARE_V, SQUARE_T, (8, 8), "centre") == expected).all()


def test_shifted_square_loses_partial_pixels():
    inside = mesh_coverage_mask(SQUARE_V + 0.3, SQUARE_T, (8, 8), "inside")
    expected = np.zeros((8, 8), bool)
    expected[3:5, 3:6] = True
    assert (inside == expected).all()


def test_diagonal_edge_through_lattice_corners_is_exact():
    v = np.array([[1, 1], [7, 1], [1, 7]], float)
    inside = mesh_coverage_mask(v, [[0, 2, 1]], (8, 8), "inside")
    r, c = np.mgrid[0:8, 0:8]
    # pixel square [c, c+1] x [r, r+1] is inside x >= 1, y >= 1, x + y <= 8
    expected = (c >= 1) & (r >= 1) & (c + r + 2 <= 8)
    assert (inside == expected).all()


def test_coverage_and_waste_of_a_full_image_mesh():
    img = np.zeros((10, 20, 4), np.uint8)
    img[:, :10, 3] = 255
    v = np.array([[0, 0], [20, 0], [20, 10], [0, 10]], float)
    t = np.array([[0, 1, 2], [0, 2, 3]])
    art = opaque_mask(img)
    assert coverage(v, t, art) == 1.0
    assert waste(v, t, art) == pytest.approx(0.5)
    # half the image: the left half exactly
    v2 = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    assert coverage(v2, t, art) == 1.0 and waste(v2, t, art) == pytest.approx(0.0)
    v3 = v2 - [0.5, 0]
    assert coverage(v3, t, art) == pytest.approx(0.9)


def test_angle_ratio_known_triangles():
    eq = np.array([[0, 0], [2, 0], [1, np.sqrt(3)]])
    assert angle_ratio(eq, [[0, 1, 2]]) == pytest.approx(1.0)
    right = np.array([[0, 0], [1, 0], [0, 1]], float)
    assert angle_ratio(right, [[0, 1, 2]]) == pytest.approx(0.5)


def test_problems_are_found():
    assert mesh_problems(SQUARE_V, SQUARE_T, hull=4, min_distance=1) == []
    assert any("inverted" in p for p in mesh_problems(SQUARE_V, [[0, 1, 2], [0, 3, 2]]))
    assert any("degenerate" in p for p in mesh_problems(np.r_[SQUARE_V, [[4, 2]]], [[0, 1, 2], [0, 2, 3], [0, 4, 1]]))
    over = mesh_problems(SQUARE_V, [[0, 1, 2], [0, 2, 3], [0, 1, 3]])
    assert any("overlap" in p for p in over)
    close = np.r_[SQUARE_V, [[4, 3.5], [4.2, 3.5]]]
    assert any("apart" in p for p in mesh_problems(close, [[0, 1, 4]], min_distance=0.5))
    assert triangle_areas(SQUARE_V, SQUARE_T).tolist() == [6.0, 6.0]


def test_boundary_adherence_counts_edge_pixels_near_vertices():
    edges = np.zeros((50, 100), bool)
    edges[25, 10:90] = True
    near = np.array([[x, 27.0] for x in range(10, 91, 16)])
    assert boundary_adherence(near, edges) == 1.0
    far = np.array([[50.0, 5.0]])
    assert boundary_adherence(far, edges) == 0.0
    one = np.array([[10.0, 25.0]])
    assert boundary_adherence(one, edges) == pytest.approx(11 / 80)


def _artist_meshes(limit=20):
    out = []
    for js in sorted(EXAMPLES.glob("4.2/*/*.json"))[:6]:
        doc = json.loads(js.read_text(encoding="utf-8"))
        for skin in doc.get("skins", []):
            for slot, atts in sorted(skin.get("attachments", {}).items()):
                for key, att in sorted(atts.items()):
                    png = js.parent / "images" / f"{att.get('path') or att.get('name') or key}.png"
                    if att.get("type") == "mesh" and png.exists():
                        out.append((png, att))
                    if len(out) >= limit:
                        return out
    return out


def test_artist_meshes_measure_sensibly(examples):
    meshes = _artist_meshes()
    assert meshes, "the 4.2 examples have mesh attachments"
    covs = []
    for png, att in meshes:
        img = load_rgba(png)
        h, w = img.shape[:2]
        v = np.asarray(att["uvs"], float).reshape(-1, 2) * [w, h]
        t = np.asarray(att["triangles"]).reshape(-1, 3)
        art = opaque_mask(img)
        c = coverage(v, t, art)
        assert 0.5 < c <= 1.0
        assert 0.0 <= waste(v, t, art) < 1.0
        covs.append(c)
    # artists mostly cover their art, not always to the last faint pixel
    assert np.median(covs) > 0.99
