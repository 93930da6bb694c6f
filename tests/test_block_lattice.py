"""The blocks of a blocked ingest, found by arithmetic, are those a search of every block finds."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.block_lattice import BlockLattice
from tdb.bbox import points_in_box


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    side=st.sampled_from([16.0, 48.0, 64.0, 96.0]),
    buffer=st.sampled_from([0.0, 16.0, 32.0, 64.0, 96.0, 130.0]),
    cut=st.booleans(),
    on_edges=st.booleans(),
)
def test_the_blocks_holding_each_point_are_those_whose_boxes_hold_it(seed, side, buffer, cut, on_edges):
    rng = np.random.default_rng(seed)
    area = (1000.0 + rng.uniform(-40, 40), 2000.0 + rng.uniform(-40, 40), 1300.0, 2250.0)
    survey = (area[0] - 30.0, area[1] - 30.0, area[2] + 30.0, area[3] + 30.0)
    lattice = BlockLattice(area, side, buffer, survey, cut=cut)
    n = 300
    x = rng.uniform(area[0] - buffer - 20, area[2] + buffer + 20, n)
    y = rng.uniform(area[1] - buffer - 20, area[3] + buffer + 20, n)
    if on_edges:  # points on block edges and on the buffers' edges, where rounding would show
        ox, oy = lattice.origin
        x[::3] = ox + rng.integers(-2, 8, len(x[::3])) * side
        y[1::3] = oy + rng.integers(-2, 8, len(y[1::3])) * side - buffer
    k, at, own = lattice.holding(x, y)
    want_k, want_at, want_own = [], [], []
    for b in range(len(lattice)):
        blk = lattice.block(b)
        held = np.flatnonzero(points_in_box(x, y, blk.grown))
        want_k += [b] * len(held)
        want_at += held.tolist()
        want_own += points_in_box(x[held], y[held], blk.core, closed=False).tolist()
    assert k.tolist() == want_k
    assert at.tolist() == want_at
    assert own.tolist() == want_own
    # each point inside the blocks' squares is owned by one block at most
    assert np.bincount(at[own], minlength=n).max(initial=0) <= 1


def test_a_vast_empty_area_costs_nothing_per_block():
    """Two points 1,000 km apart: millions of blocks on the lattice, a few of them touched (a point
    within a buffer of a square's edge is read by the block beyond too)."""
    lattice = BlockLattice((0.0, 0.0, 1e6, 1e6), 512.0, 64.0, (0.0, 0.0, 1e6, 1e6))
    assert len(lattice) > 3_000_000
    k, _, own = lattice.holding(np.array([10.0, 999_990.0]), np.array([10.0, 999_990.0]))
    assert len(set(k.tolist())) <= 8 and own.sum() == 2
    assert lattice.cores() == (0.0, 0.0, 1_000_448.0, 1_000_448.0)
