"""One-point pits among ground points (ingest.ground.outliers.ground_spikes)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from ingest.ground.outliers import ground_spikes


def _brute(xyz, ground, *, k=8, base=0.5, slope=1.0):
    """Every ground point lower than each of its k nearest ground neighbours by base + slope × d."""
    gi = np.flatnonzero(ground)
    p = xyz[gi]
    dist, nb = cKDTree(p[:, :2]).query(p[:, :2], k=k + 1)
    own = nb == np.arange(len(p))[:, None]
    keep = np.argsort(own, axis=1, kind="stable")[:, :k]
    nb, dist = np.take_along_axis(nb, keep, axis=1), np.take_along_axis(dist, keep, axis=1)
    out = np.zeros(len(xyz), bool)
    out[gi[((p[nb, 2] - p[:, None, 2]) > base + slope * dist).all(axis=1)]] = True
    return out


def _plane(rng, n, size=40.0):
    x, y = rng.uniform(0, size, n), rng.uniform(0, size, n)
    return np.column_stack([x, y, 100 + 0.05 * x + rng.normal(0, 0.03, n)])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16), spikes=st.integers(1, 8), depth=st.floats(2.0, 3.0))
def test_single_low_points_are_found_and_nothing_else(seed, spikes, depth):
    # 4 points/m²: the eighth neighbour lies mostly within 1.2 m, so 2 m down is beyond
    # 0.5 m + 1.0 × distance from every neighbour; where it lies further off, not (both exact)
    rng = np.random.default_rng(seed)
    xyz = _plane(rng, 6400)
    chosen = rng.choice(len(xyz), spikes, replace=False)
    planted = [
        i for n, i in enumerate(chosen) if all(np.hypot(*(xyz[i, :2] - xyz[j, :2])) > 4 for j in chosen[:n])
    ]
    xyz[planted, 2] -= depth
    found = ground_spikes(xyz, np.ones(len(xyz), bool))
    dist, nb = cKDTree(xyz[:, :2]).query(xyz[planted, :2], k=9)
    deep = (xyz[nb[:, 1:], 2] - xyz[planted, 2][:, None] > 0.5 + dist[:, 1:]).all(axis=1)
    assert set(np.flatnonzero(found).tolist()) == {int(i) for i, d in zip(planted, deep) if d}
    assert deep.mean() >= 0.5  # the test is about found spikes, not about sparse corners


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), share=st.floats(0.3, 1.0), spread=st.floats(0.2, 3.0))
def test_every_point_found_passes_the_exact_neighbour_test(seed, share, spread):
    # rough ground, some of it not ground: what is found is a subset of the exact k-NN test's
    rng = np.random.default_rng(seed)
    xyz = _plane(rng, 3000)
    xyz[:, 2] += rng.normal(0, spread, len(xyz)) * (rng.random(len(xyz)) < 0.05)
    ground = rng.random(len(xyz)) < share
    found = ground_spikes(xyz, ground)
    assert not (found & ~ground).any()
    assert not (found & ~_brute(xyz, ground)).any()


def test_a_pit_and_a_cliff_foot_are_terrain():
    rng = np.random.default_rng(5)
    xyz = _plane(rng, 6400)
    x, y = xyz[:, 0], xyz[:, 1]
    r = np.hypot(x - 10, y - 10)
    xyz[:, 2] -= np.where(r < 1.5, 1.5 * (1 - r / 1.5), 0.0)  # a pit 3 m across, 1.5 m deep
    xyz[:, 2] += np.where(x > 30, 3.0, 0.0)  # a 3 m cliff
    assert not ground_spikes(xyz, np.ones(len(xyz), bool)).any()


def test_too_few_ground_points():
    xyz = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 5.0]])
    assert not ground_spikes(xyz, np.ones(2, bool)).any()
