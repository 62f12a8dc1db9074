"""scripts/pack_gap.py: the next smaller page set the page rules allow, and the fill it needs."""

from __future__ import annotations

import sys
from itertools import combinations_with_replacement

import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))

from pack_gap import GapRow, largest_set_below, next_step  # noqa: E402


def brute_force(limit: int, need: int, pages: int, max_area: int, smallest: int = 256) -> int:
    """Every sum of 1..pages power-of-two areas, the largest below ``limit`` holding ``need`` (0 if none)."""
    areas = [1 << k for k in range(smallest.bit_length() - 1, max_area.bit_length()) if 1 << k <= max_area]
    sums = {sum(c) for n in range(1, pages + 1) for c in combinations_with_replacement(areas, n)}
    fit = [s for s in sums if need <= s < limit]
    return max(fit, default=0)


@pytest.mark.parametrize("limit,need,pages,max_area", [
    (2048 * 1024, 893_091, 1, 2048 * 2048),       # one page: 2048x1024 -> 1024x1024
    (2048 * 2048, 1_800_000, 1, 2048 * 2048),     # 2048x2048 -> 2048x1024
    (65_536, 33_000, 1, 65_536),                  # 256x128 holds no more than 32,768: none
    (4 << 20, 100, 2, 4 << 20),                   # two pages: 2048x1024 + 1024x1024 under 2048x2048
    ((5 << 20) + 1, 100, 2, 4 << 20),             # exactly 2048x2048 + 1024x1024
    (3 * (1 << 20) + 5, 2_000_000, 3, 1 << 20),   # three whole 1024x1024 pages
    (1_000_000, 500_000, 3, 1 << 18),             # pages capped at 512x512
])
def test_largest_set_below_matches_brute_force(limit, need, pages, max_area):
    assert largest_set_below(limit, need, pages, max_area) == brute_force(limit, need, pages, max_area)


def test_next_step_columns():
    row = GapRow("p", "a.atlas", 8, 8, 1, 4 << 20, 0, 0, 0, 893_091, 0, 2 << 20, "packed", pot=True,
                 next_set=1 << 20)
    assert next_step(row) == ("25%", "85%")
    row.next_set = 0
    assert next_step(row) == ("none", "-")
    row.pot = False
    assert next_step(row) == ("any", "43%")
