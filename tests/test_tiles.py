"""The tile index finds the same tiles whether it looks them up in a raster or in sorted keys."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tdb.tiles import TileIndex


class Sorted(TileIndex):
    DENSE = 0  # never a raster: the sorted keys


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 400), st.integers(1, 2000), st.integers(0, 10_000))
def test_raster_and_sorted_lookups_agree(count, spread, seed):
    rng = np.random.default_rng(seed)
    keys = np.unique(rng.integers(-spread, spread, (count, 2)), axis=0)
    i, j = keys[:, 0], keys[:, 1]
    probe = np.vstack([keys[rng.permutation(len(keys))], rng.integers(-2 * spread, 2 * spread, (50, 2))])
    index = TileIndex(i, j)
    found = index.find(probe[:, 0], probe[:, 1])
    np.testing.assert_array_equal(found, Sorted(i, j).find(probe[:, 0], probe[:, 1]))
    hit = found >= 0
    np.testing.assert_array_equal(keys[found[hit]], probe[hit])
    assert hit[: len(keys)].all()


def test_a_lattice_over_a_vast_box_is_refused_not_allocated():
    """Two nodes 1,000 km apart would need a lattice of 4·10¹² nodes: one clear error, at once."""
    from tdb.errors import InputError
    from tdb.tiles import node_lattice

    x, y = np.array([0.0, 1e6]), np.array([0.0, 1e6])
    with pytest.raises(InputError, match="smaller area"):
        node_lattice(x, y, np.zeros(2), 2)
    assert node_lattice(x[:1], y[:1], np.zeros(1), 2).z.shape == (1, 1)
