"""The nearest filled cell, from the 8 neighbours: scipy's feature transform, cell for cell."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from tdb.fill import _pattern_codes, fill_nearest, nearest_adjacent, nearest_cells


@settings(max_examples=80, deadline=None)
@given(
    rows=st.integers(1, 30),
    cols=st.integers(1, 30),
    share=st.floats(0.05, 1.0),
    seed=st.integers(0, 2**16),
)
def test_the_nearest_adjacent_cell_is_the_feature_transforms(rows, cols, share, seed):
    filled = np.random.default_rng(seed).random((rows, cols)) < share
    near = nearest_adjacent(filled)
    if not filled.any():
        assert (near == -1).all()
        return
    distance, (ri, ci) = ndimage.distance_transform_edt(~filled, return_indices=True)
    close = distance <= 1.5
    np.testing.assert_array_equal(near >= 0, close)
    np.testing.assert_array_equal(near[close], (ri * cols + ci)[close])
    holes = ~filled
    np.testing.assert_array_equal(np.stack(np.divmod(nearest_cells(holes), holes.shape[1])), np.stack((ri, ci)))


def test_a_raster_with_far_holes_falls_back_to_the_transform():
    holes = np.ones((9, 9), bool)
    holes[0, 0] = holes[8, 3] = False
    ri, ci = ndimage.distance_transform_edt(holes, return_distances=False, return_indices=True)
    np.testing.assert_array_equal(np.stack(np.divmod(nearest_cells(holes), holes.shape[1])), np.stack((ri, ci)))


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 62), rows=st.integers(0, 20), seed=st.integers(0, 2**16))
def test_a_pattern_code_holds_bit_i_for_cell_i(n, rows, seed):
    known = np.random.default_rng(seed).random((rows, n)) < 0.5
    expected = [sum(1 << i for i in np.flatnonzero(r)) for r in known]
    assert _pattern_codes(known).tolist() == expected


@settings(max_examples=60, deadline=None)
@given(
    rows=st.integers(1, 25),
    cols=st.integers(1, 25),
    share=st.floats(0.05, 1.0),
    asked=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**16),
)
def test_a_fill_asked_for_some_cells_gives_them_the_whole_fills_values(rows, cols, share, asked, seed):
    rng = np.random.default_rng(seed)
    raster = np.where(rng.random((rows, cols)) < share, rng.normal(size=(rows, cols)), np.nan)
    if np.isnan(raster).all():
        raster[0, 0] = 1.0
    where = rng.random((rows, cols)) < asked
    np.testing.assert_array_equal(fill_nearest(raster, where=where)[where], fill_nearest(raster)[where])
