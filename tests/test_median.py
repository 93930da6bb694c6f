"""The window median: scipy's values, a band of rows at a time."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from tdb import median
from tdb.errors import InputError
from tdb.median import median_filter


@settings(max_examples=60, deadline=None)
@given(
    rows=st.integers(1, 40),
    cols=st.integers(1, 40),
    size=st.sampled_from([1, 3, 5, 7, 9]),
    mode=st.sampled_from(["constant", "nearest"]),
    seed=st.integers(0, 2**16),
    ties=st.booleans(),
)
def test_the_same_values_as_scipy(rows, cols, size, mode, seed, ties):
    rng = np.random.default_rng(seed)
    raster = rng.integers(0, 4, (rows, cols)).astype(float) if ties else rng.normal(size=(rows, cols))
    np.testing.assert_array_equal(
        median_filter(raster, size, mode=mode), ndimage.median_filter(raster, size=size, mode=mode)
    )


def test_bands_of_rows_join_without_a_seam(monkeypatch):
    """A raster worked in many bands (a few rows each) reads as in one."""
    raster = np.random.default_rng(3).normal(size=(57, 31)).astype(np.float32)
    whole = median_filter(raster, 5)
    monkeypatch.setattr(median, "CHUNK_VALUES", 31 * 25 * 2)  # two rows a band
    np.testing.assert_array_equal(median_filter(raster, 5), whole)
    assert median_filter(raster, 5).dtype == np.float32


@pytest.mark.parametrize("band", [1, 2, 5, 64])
def test_the_network_of_nine_joins_its_bands_without_a_seam(monkeypatch, band):
    """The 3 × 3 median's sorting network, worked a few rows at a time, reads as scipy's."""
    raster = np.random.default_rng(4).normal(size=(57, 31)).astype(np.float32)
    monkeypatch.setattr(median, "BAND_ROWS", band)
    for mode in ("constant", "nearest"):
        got = median_filter(raster, 3, mode=mode)
        np.testing.assert_array_equal(got, ndimage.median_filter(raster, size=3, mode=mode))
        assert got.dtype == np.float32


@pytest.mark.parametrize("size", [0, 2, -3])
def test_an_even_or_empty_window_is_refused(size):
    with pytest.raises(InputError, match="odd window"):
        median_filter(np.zeros((4, 4)), size)
