"""Map furniture: the scale bar's length is round and fits the map."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from tdb.pictures import nice_length


@given(st.floats(1.0, 1e6))
def test_scale_bar_length_is_round_and_about_a_fifth_of_the_map(span):
    length = nice_length(span)
    mantissa = length / 10 ** np.floor(np.log10(length))
    assert round(mantissa, 9) in (1.0, 2.0, 5.0)
    assert span / 12.6 <= length <= span * 0.3
