"""A hill that rises smoothly out of sparse ground stays ground; a building of the same size does not."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.ground.auto import AutoParams, auto_ground
from ingest.ground.hills import point_spacing, smooth_hills


def _scene(seed: int, *, density: float = 0.17, hill: float = 7.0, building: float = 8.0):
    """Sparse points over 200 × 200 m: a round hill (cosine profile, 30 m across) and a
    15 × 15 m flat-roofed building, on a gently tilted plane."""
    rng = np.random.default_rng(seed)
    n = int(200 * 200 * density)
    x, y = rng.uniform(0, 200, n), rng.uniform(0, 200, n)
    base = 100 + 0.02 * x + 0.01 * y
    r = np.hypot(x - 60, y - 100)
    bump = hill * 0.5 * (1 + np.cos(np.pi * np.clip(r / 15, 0, 1)))
    roof = (np.abs(x - 140) < 7.5) & (np.abs(y - 100) < 7.5)
    z = base + bump + np.where(roof, building, 0.0) + rng.normal(0, 0.05, n)
    return np.c_[x, y, z], r < 12, roof


def test_point_spacing_follows_the_density():
    rng = np.random.default_rng(0)
    for density in (0.17, 1.0, 4.0):
        n = int(300 * 300 * density)
        xy = rng.uniform(0, 300, (n, 2))
        assert point_spacing(xy) == pytest.approx(1 / np.sqrt(density), rel=0.05)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_the_default_filter_keeps_a_steep_hill_in_sparse_data_and_cuts_the_building(seed):
    xyz, hill, roof = _scene(seed)
    ground = auto_ground(xyz)
    assert ground[hill].mean() > 0.8  # the convex cap above the last seeds may be cut
    assert ground[roof].mean() < 0.05
    # Without the hill stage the hill's top is cut: the test above can fail.
    no_hills = auto_ground(xyz, params=AutoParams(hill_area=1e9))
    assert no_hills[hill].mean() < ground[hill].mean() - 0.1


def test_a_group_standing_over_the_ground_is_no_hill():
    xyz, hill, roof = _scene(3)
    # The hill's and the roof's cells are object groups; only the hill meets the ground smoothly.
    found = smooth_hills(xyz, ~(hill | roof), cell=3.5)
    assert found[hill].any()
    assert not found[roof].any()
    # Too small a hill (min_area) or too gentle a cone (slope) finds nothing.
    assert not smooth_hills(xyz, ~(hill | roof), cell=3.5, min_area=1e4).any()
    assert not smooth_hills(xyz, ~(hill | roof), cell=3.5, slope=0.05, rise=0.0).any()
