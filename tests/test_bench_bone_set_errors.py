"""benchmarks/bench_bone_set_errors.py: how a chosen bone set that is not the artist's is counted."""

from __future__ import annotations

import sys

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))

import bench_bone_set_errors as errors  # noqa: E402


def test_each_miss_is_counted_under_the_first_kind_that_holds():
    exact, beyond, many, left_out, extra, both = errors.KINDS
    assert errors.kind_of({1, 2}, {1, 2}, beyond=False) == exact
    assert errors.kind_of({1}, {1, 2}, beyond=True) == beyond
    assert errors.kind_of(set(range(8)), set(range(9)), beyond=False) == many
    assert errors.kind_of({1}, {1, 2}, beyond=False) == left_out
    assert errors.kind_of({1, 2, 3}, {1, 2}, beyond=False) == extra
    assert errors.kind_of({1, 3}, {1, 2}, beyond=False) == both
