"""Orderings by group and value: numpy's lexsort order, faster."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tdb.sort import by_group, highest_per_group


@settings(max_examples=80, deadline=None)
@given(
    n=st.integers(0, 400),
    groups=st.integers(1, 30),
    seed=st.integers(0, 2**16),
    ties=st.booleans(),
    nans=st.booleans(),
)
def test_by_group_is_lexsorts_order(n, groups, seed, ties, nans):
    rng = np.random.default_rng(seed)
    group = rng.integers(0, groups, n)
    key = rng.integers(0, 3, n).astype(float) if ties else rng.normal(size=n)
    if nans:
        key[rng.random(n) < 0.1] = np.nan
    np.testing.assert_array_equal(by_group(group, key), np.lexsort((key, group)))


def test_by_group_of_negative_groups_is_still_lexsorts_order():
    group, key = np.array([2, -1, 2, -1, 0]), np.array([1.0, 2.0, 0.0, 1.0, 5.0])
    np.testing.assert_array_equal(by_group(group, key), np.lexsort((key, group)))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 300), cells=st.integers(1, 40), seed=st.integers(0, 2**16))
def test_highest_per_cell_is_the_first_of_the_highest(n, cells, seed):
    rng = np.random.default_rng(seed)
    cell = rng.integers(0, cells, n).astype(np.int64)
    z = rng.integers(0, 4, n).astype(float)  # many ties
    expected = [np.flatnonzero((cell == c) & (z == z[cell == c].max()))[0] for c in np.unique(cell)]
    np.testing.assert_array_equal(highest_per_group(cell, z), expected)
