"""Extents taken column by column."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tdb.bbox import column_range
from tdb.errors import InputError


@given(arrays(np.float64, st.tuples(st.integers(1, 50), st.integers(1, 4)), elements=st.floats(-1e6, 1e6)))
def test_column_range_is_the_least_and_greatest_of_each_column(a: np.ndarray) -> None:
    lo, hi = column_range(a)
    np.testing.assert_array_equal(lo, a.min(axis=0))
    np.testing.assert_array_equal(hi, a.max(axis=0))


def test_a_slice_of_columns_and_a_flat_array():
    xyz = np.arange(12, dtype=float).reshape(4, 3)
    lo, hi = column_range(xyz[:, :2])
    assert lo.tolist() == [0.0, 1.0] and hi.tolist() == [9.0, 10.0]
    with pytest.raises(InputError):
        column_range(np.zeros(5))
