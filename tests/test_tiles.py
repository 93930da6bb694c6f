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


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-20, 60), st.floats(-20, 60), st.floats(0, 30), st.floats(0, 30)), max_size=4),
    st.floats(0, 10),
    st.integers(0, 2**31 - 1),
)
def test_the_nodes_near_boxes_are_every_node_within_the_margin_in_the_same_order(boxes, margin, seed):
    from tdb.tiles import NodeLattice

    rng = np.random.default_rng(seed)
    z = np.where(rng.random((40, 50)) < 0.3, np.nan, rng.normal(size=(40, 50)))
    lattice = NodeLattice(z, i0=-7, j0=3, spacing=0.5)
    boxes = [(x, y, x + w, y + h) for x, y, w, h in boxes]
    x, y, z_all = lattice.points()

    def beyond(px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """How far (m, along the farther axis) each point lies outside the nearest box's margin."""
        out = np.full(len(px), np.inf)
        for x0, y0, x1, y1 in boxes:
            gap = np.maximum.reduce([x0 - margin - px, px - x1 - margin, y0 - margin - py, py - y1 - margin])
            out = np.minimum(out, np.maximum(gap, 0.0))
        return out

    nx, ny, nz = lattice.points_near(boxes, margin)
    kept = np.flatnonzero(np.isin(x + 1j * y, nx + 1j * ny))
    assert set(np.flatnonzero(beyond(x, y) == 0)) <= set(kept)  # every node within the margin
    assert np.array_equal(nx + 1j * ny, (x + 1j * y)[kept]) and np.array_equal(nz, z_all[kept])  # in order
    assert (beyond(nx, ny) <= lattice.spacing + 1e-9).all()  # and none more than a node beyond it
