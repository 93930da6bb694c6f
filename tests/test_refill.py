"""Filling again after a few cells changed (ingest.ground.refill) is the full fill to the bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.ground.refill import LineFill, touched_runs
from tdb.fill import fill_lines


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    rows=st.integers(1, 16),
    cols=st.integers(1, 16),
    holes=st.floats(0.0, 1.0),
    change=st.floats(0.0, 0.4),
    single=st.booleans(),
)
def test_refilling_a_changing_raster_equals_filling_it_whole(seed, rows, cols, holes, change, single):
    rng = np.random.default_rng(seed)
    raster = (rng.normal(size=(rows, cols)) * 10).astype(np.float32 if single else np.float64)
    raster[rng.random(raster.shape) < holes] = np.nan
    fill = LineFill(full_share=1.0)  # always the partial path after the first call
    for _ in range(4):
        got = fill(raster)
        np.testing.assert_array_equal(got, fill_lines(raster))  # NaN where NaN, bit for bit elsewhere
        assert got.dtype == raster.dtype
        got[:] = 0  # the caller's copy: changing it must not reach the next call
        raster = raster.copy()
        changed = rng.random(raster.shape) < change
        new = rng.normal(size=int(changed.sum())) * 10
        raster[changed] = np.where(rng.random(len(new)) < holes, np.nan, new)


def test_a_changed_bank_refills_the_runs_either_side_only():
    raster = np.array([[1.0, np.nan, np.nan, 4.0, np.nan, 6.0, np.nan, 8.0]])
    # cell 3 closes the runs 1–2 and 4; the run at 6 is untouched
    np.testing.assert_array_equal(touched_runs(raster, np.array([3])), [1, 2, 4])
    # a changed hole's whole run, never past the row's end
    two_rows = np.array([[1.0, np.nan, np.nan], [np.nan, np.nan, 5.0]])
    np.testing.assert_array_equal(touched_runs(two_rows, np.array([2])), [1, 2])
    np.testing.assert_array_equal(touched_runs(two_rows, np.array([4])), [3, 4])


def test_many_changes_fill_the_whole_raster_again():
    rng = np.random.default_rng(3)
    raster = rng.normal(size=(30, 30))
    raster[rng.random(raster.shape) < 0.5] = np.nan
    fill = LineFill(full_share=0.05)
    fill(raster)
    other = np.where(rng.random(raster.shape) < 0.5, np.nan, rng.normal(size=raster.shape))
    np.testing.assert_array_equal(fill(other), fill_lines(other))
    np.testing.assert_array_equal(fill(other[:, :20].copy()), fill_lines(other[:, :20]))  # a new shape
