"""Orderings by group and value: numpy's lexsort order, faster; scatters that are numpy's ufunc.at."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tdb.sort import by_group, highest_per_group, order_within, scatter_max, scatter_min


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


@settings(max_examples=120, deadline=None)
@given(
    n=st.integers(0, 500),
    cells=st.integers(1, 40),
    seed=st.integers(0, 2**16),
    order=st.sampled_from(["random", "ascending", "descending", "zigzag"]),
    kind=st.sampled_from(["float", "int", "nan"]),
    highest=st.booleans(),
)
def test_scatters_are_the_ufuncs_at(n, cells, seed, order, kind, highest):
    rng = np.random.default_rng(seed)
    index = rng.integers(0, cells, n)
    values = rng.integers(-5, 5, n) if kind == "int" else rng.normal(size=n)
    if kind == "nan":
        values[rng.random(n) < 0.05] = np.nan
    if order != "random":
        rank = np.argsort(values, kind="stable")
        if order == "descending":
            rank = rank[::-1]
        elif order == "zigzag":  # the slowest order for alternating passes: the ufunc takes the rest
            rank = np.r_[rank[::2], rank[1::2][::-1]]
        index, values = index[rank], values[rank]
    start = rng.integers(-3, 3, cells).astype(values.dtype)  # what the cells held before counts
    got, expected = start.copy(), start.copy()
    with np.errstate(invalid="ignore"):  # NaN meets NaN
        (scatter_max if highest else scatter_min)(got, index, values)
        (np.maximum if highest else np.minimum).at(expected, index, values)
    np.testing.assert_array_equal(got, expected)


def test_a_scatter_into_a_raster_takes_flat_indices():
    raster = np.zeros((2, 3))
    scatter_max(raster, np.array([4, 4, 0]), np.array([1.0, 3.0, 2.0]))
    np.testing.assert_array_equal(raster, [[2.0, 0, 0], [0, 3.0, 0]])
    with pytest.raises(ValueError, match="contiguous"):
        scatter_min(np.zeros((3, 4))[:, :2], np.array([0]), np.array([-1.0]))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 300), seed=st.integers(0, 2**16), ties=st.booleans())
def test_one_order_by_height_serves_every_subset_and_grid(n, seed, ties):
    rng = np.random.default_rng(seed)
    z = rng.integers(0, 5, n).astype(float) if ties else rng.normal(size=n)
    subset = np.flatnonzero(rng.random(n) < 0.6)
    group = rng.integers(0, 7, len(subset))
    within = order_within(np.argsort(z, kind="stable"), subset, n)
    np.testing.assert_array_equal(within, np.argsort(z[subset], kind="stable"))
    np.testing.assert_array_equal(by_group(group, z[subset], key_order=within), np.lexsort((z[subset], group)))


def test_an_order_within_a_subset_out_of_order_is_refused():
    with pytest.raises(ValueError, match="ascending"):
        order_within(np.arange(4), np.array([2, 1]), 4)
