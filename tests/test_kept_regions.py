"""scripts/kept_regions.py: which worth rule kept a region, and the tables of what meshing it would save."""

from __future__ import annotations

import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))

from kept_regions import KeptRow, general, threshold_table, worth_rule  # noqa: E402

from spinemesh.mesher.worth import art_share_reason, hull_reason, islands_reason  # noqa: E402


def _circle(n: int, radius: float, centre: float) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[centre + radius * np.cos(t), centre + radius * np.sin(t)]


def test_worth_rule_names_the_rule_of_each_reason_worth_writes():
    """The labels follow the reasons spinemesh.mesher.worth writes: a change of wording fails here."""
    full = np.ones((20, 20), bool)
    assert worth_rule(art_share_reason(full, 0.05)) == "worth rule 1: the art fills the region"
    rain = np.zeros((100, 100), bool)
    rain[::10, ::10] = True  # 100 single-texel islands: 300 outline vertices, 33 pixels saved each
    assert worth_rule(islands_reason(rain)) == "worth rule 2: scattered islands"
    square = np.array([[0.5, 0.5], [99.5, 0.5], [99.5, 99.5], [0.5, 99.5]])
    assert worth_rule(hull_reason(square, 100, 100, 0.05)) == "worth rule 3: the hull saves too few pixels"
    round_hull = _circle(250, 49.9, 50.0)  # saves 22% of the quad, 9 pixels per vertex
    assert worth_rule(hull_reason(round_hull, 100, 100, 0.05)) == \
        "worth rule 3: too many hull vertices for the pixels saved"
    assert worth_rule("sequence frames were trimmed differently on the atlas page") == ""


def test_general_groups_reasons_of_different_regions():
    assert general("drawn as a region attachment (hero.json, slot 'head')") == "drawn as a region attachment"
    assert general("its footprints alone take 1,234 texels") == general("its footprints alone take 99 texels")


def test_threshold_table_meshes_only_worth_kept_regions_that_save_enough():
    rows = [KeptRow("p", "a.atlas", "rain", "worth rule 2: scattered islands", 1000, 100, 20, 300),
            KeptRow("p", "a.atlas", "box", "worth rule 1: the art fills the region", 1000, 100, 95, 8),
            KeptRow("p", "a.atlas", "seq", "kept: sequence frames were trimmed differently", 1000, 200)]
    lines = threshold_table(rows, 1000).splitlines()
    assert lines[2] == "| 0% | 2 | 20.00% | 11.50% | 8.50% | 154, 300 |"
    assert lines[3] == "| 10% | 1 | 10.00% | 2.00% | 8.00% | 300, 300 |"
    assert lines[-1] == "| 50% | 1 | 10.00% | 2.00% | 8.00% | 300, 300 |"
