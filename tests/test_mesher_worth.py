"""When a region stays a region (spinemesh.mesher.worth), and what the mesher hands upgrade."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from spinemesh.mesher import NotWorthMeshing, mesh_image, worth_meshing
from spinemesh.mesher.worth import MAX_HULL_VERTICES, VERTICES_PER_ISLAND, hull_reason, islands_reason
from spinemesh.metrics import coverage, mesh_problems


def _rgba(mask: np.ndarray) -> np.ndarray:
    img = np.zeros(mask.shape + (4,), np.uint8)
    img[mask] = (200, 120, 60, 255)
    return img


def test_art_filling_the_region_is_kept_before_any_geometry():
    mask = np.ones((64, 48), bool)
    mask[:3, :3] = False  # 97% filled: no mesh can save 10%
    assert worth_meshing(mask, 0.10).startswith("not worth meshing: the art fills 99.7%")  # its margin grown
    assert worth_meshing(mask, 0.0) == ""
    with pytest.raises(NotWorthMeshing, match="art fills"):
        mesh_image(_rgba(mask), min_saving=0.10)
    # without the rule (the mesh command's default) it is meshed
    assert len(mesh_image(_rgba(mask)).vertices) >= 3


def test_scattered_islands_are_kept_unless_they_save_enough_per_vertex():
    n = MAX_HULL_VERTICES // VERTICES_PER_ISLAND + 10  # the outline needs more than the budget
    grid = int(np.ceil(np.sqrt(n)))

    def drops(side):
        mask = np.zeros((side, side), np.uint8)
        step = side // (grid + 1)
        for k in range(n):
            cv2.circle(mask, (step * (1 + k % grid), step * (1 + k // grid)), 2, 1, -1)
        return mask.astype(bool)

    rain = drops(300)  # 300^2 px for ~230 vertices: under 500 px saved per vertex
    reason = worth_meshing(rain, 0.05)
    assert reason.startswith("not worth meshing:") and "islands" in reason
    # the same drops far apart on a big region save plenty per vertex: meshed
    assert worth_meshing(drops(1000), 0.05) == ""
    # a downscaled mask: each of its pixels stands for pixel_area full-size ones
    assert islands_reason(rain, pixel_area=16.0) == ""
    few = np.zeros((400, 400), np.uint8)
    for x in range(3):
        cv2.circle(few, (60 + 120 * x, 200), 30, 1, -1)
    assert worth_meshing(few.astype(bool), 0.05) == ""


def test_hull_rule_counts_saving_and_vertices():
    square = np.array([[0, 0], [90, 0], [90, 100], [0, 100]], float)
    assert "only 10% fewer" in hull_reason(square * [1, 1], 100, 100, 0.2)
    assert hull_reason(square, 100, 100, 0.05) == ""
    # a many-vertex outline that saves little per vertex
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    circle = np.stack([50 + 49 * np.cos(t), 50 + 49 * np.sin(t)], axis=1)
    assert "300 vertices" in hull_reason(circle, 100, 100, 0.05)
    # the same outline on a large region saves plenty per vertex: meshed
    assert hull_reason(circle * 10, 1000, 1000, 0.05) == ""


def test_sparse_art_is_meshed_with_rules_on():
    mask = np.zeros((120, 120), np.uint8)
    cv2.circle(mask, (60, 60), 30, 1, -1)
    img = _rgba(mask.astype(bool))
    mesh = mesh_image(img, min_saving=0.10)
    assert coverage(mesh.vertices, mesh.triangles, mask.astype(bool)) == 1.0


def test_hull_triangles_fill_holes_for_spine():
    # a ring: the default preset leaves its hole open; Spine needs the hull fully triangulated
    img = np.zeros((200, 200, 4), np.uint8)
    cv2.circle(img, (100, 100), 80, (200, 100, 50, 255), -1)
    cv2.circle(img, (100, 100), 40, (0, 0, 0, 0), -1)
    mesh = mesh_image(img)
    assert len(mesh.hole_triangles) > 0
    full = mesh.hull_triangles()
    assert full is not None and len(full) == 2 * len(mesh.vertices) - mesh.hull - 2
    assert not mesh_problems(mesh.vertices, full, mesh.hull)
    # holes filled: the hull polygon's area, exactly
    x, y = mesh.vertices[: mesh.hull].T
    hull_area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    a = mesh.vertices[full]
    area = 0.5 * np.abs((a[:, 1, 0] - a[:, 0, 0]) * (a[:, 2, 1] - a[:, 0, 1])
                        - (a[:, 2, 0] - a[:, 0, 0]) * (a[:, 1, 1] - a[:, 0, 1])).sum()
    assert area == pytest.approx(hull_area)


def test_preview_legend_and_hole_loops_drawn_distinctly():
    from spinemesh.mesher.preview import MAGENTA, edge_kinds, preview

    img = np.zeros((200, 200, 4), np.uint8)
    cv2.circle(img, (100, 100), 80, (200, 100, 50, 255), -1)
    cv2.circle(img, (100, 100), 40, (0, 0, 0, 0), -1)
    mesh = mesh_image(img)
    kinds = edge_kinds(mesh)
    assert len(kinds["hull"]) == mesh.hull and len(kinds["hole"]) >= 3
    pic = preview(img, mesh, size=400)
    assert pic.shape[0] > 400 and pic.shape[1] == 400  # a legend band below the picture
    # the hole loop is drawn in its own colour
    assert (np.abs(pic[:400].astype(int) - MAGENTA).sum(axis=2) < 30).sum() > 50


def test_reasons_print_a_saving_below_the_limit_they_name():
    """A saving of 4.8% against --min-saving 5% must not read "only 5% fewer (--min-saving 5%)"."""
    from spinemesh.mesher.worth import art_share_reason, percents_below

    assert percents_below(0.048, 0.05) == ("4.8%", "95.2%")
    assert percents_below(0.0499, 0.05) == ("4.99%", "95.01%")
    assert percents_below(0.04999, 0.05) == ("under 5%", "over 95%")
    assert percents_below(0.02, 0.05) == ("2%", "98%")
    # a share above 0 never reads 0% (nor its art 100%): "fills 100% ... at most 0% fewer" was printed
    assert percents_below(0.004, 0.05) == ("0.4%", "99.6%")
    assert percents_below(0.00004, 0.05) == ("under 0.01%", "over 99.99%")
    assert percents_below(0.0, 0.05) == ("0%", "100%")
    square = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], float)
    reason = hull_reason(square, 100 / 0.952 ** 0.5, 100 / 0.952 ** 0.5, 0.05)  # saves 4.8%
    assert "only 4.8% fewer pixels" in reason and "(--min-saving 5%)" in reason
    mask = np.ones((100, 100), bool)
    mask[:48, :10] = False  # 4.8% free
    reason = art_share_reason(mask, 0.05)
    assert "fills 95.2% of the region" in reason and "at most 4.8% fewer" in reason
    assert "(--min-saving 12.5%)" in art_share_reason(mask, 0.125)


def test_pieces_labelled_once_give_the_same_reason_and_bridges():
    """The pieces the keep rule counts, given to the bridges, give what each finds alone."""
    from spinemesh.mesher import exterior
    from spinemesh.mesher.worth import islands_reason

    rng = np.random.default_rng(7)
    for density in (0.002, 0.01, 0.05, 0.3):
        mask = rng.random((60, 80)) < density
        labels = exterior.pieces(mask)
        assert islands_reason(mask, labels=labels) == islands_reason(mask)
        assert islands_reason(mask, max_vertices=4, labels=labels) == islands_reason(mask, max_vertices=4)
        assert np.array_equal(exterior.bridge_islands(mask, labels=labels), exterior.bridge_islands(mask))
