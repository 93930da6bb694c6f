"""The ground noise and the flat threshold: a measure that does not depend on the order or the
company of the points, on one square of a fixed lattice."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.noise import (
    MIN_FLAT,
    PILOT_SQUARE,
    flat_threshold_for,
    fullest_square,
    ground_noise,
    pilot_threshold,
    square_counts,
)


def _plane(n: int, sigma: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0, 300, n), rng.uniform(0, 300, n)
    return np.column_stack([x, y, 0.05 * x - 0.02 * y + rng.normal(0, sigma, n)])


@pytest.mark.parametrize("sigma", [0.02, 0.05, 0.15])
def test_the_noise_of_a_tilted_plane_is_its_sigma(sigma):
    assert ground_noise(_plane(60_000, sigma)) == pytest.approx(sigma, rel=0.08)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_the_noise_does_not_depend_on_the_points_order(seed):
    xyz = _plane(30_000, 0.05)
    shuffled = xyz[np.random.default_rng(seed).permutation(len(xyz))]
    assert ground_noise(shuffled) == ground_noise(xyz)


def test_a_few_more_points_barely_move_it():
    """The sample is chosen per point by its coordinates: extra points do not reshuffle it."""
    xyz = _plane(50_000, 0.05)
    extra = _plane(50, 0.05, seed=9)
    a, b = ground_noise(xyz), ground_noise(np.vstack([extra, xyz]))
    assert abs(a - b) < 0.002 * a


def test_the_fullest_square_and_its_threshold():
    rng = np.random.default_rng(1)
    x = np.r_[rng.uniform(0, 256, 100), rng.uniform(256, 512, 300), rng.uniform(-256, 0, 200)]
    y = rng.uniform(0, 256, len(x))
    counts = square_counts(x, y)
    assert counts == {(0, 0): 100, (1, 0): 300, (-1, 0): 200}
    assert fullest_square(counts) == (PILOT_SQUARE, 0.0, 2 * PILOT_SQUARE, PILOT_SQUARE)
    assert fullest_square({(2, 1): 5, (1, 3): 5}) == (256.0, 768.0, 512.0, 1024.0)  # the first of equals
    xyz = _plane(80_000, 0.04)
    t = pilot_threshold(xyz, (0.0, 0.0, 256.0, 256.0))
    assert t == pytest.approx(5 * 0.04, abs=0.02) and round(t * 100, 9) == round(t * 100)


@given(noise=st.floats(0, 1))
def test_the_threshold_is_whole_centimetres_and_at_least_the_minimum(noise):
    t = flat_threshold_for(noise)
    assert t >= MIN_FLAT - 1e-12 and abs(t * 100 - round(t * 100)) < 1e-9
    assert abs(t - max(MIN_FLAT, 5 * noise)) <= 0.005 + 1e-12
