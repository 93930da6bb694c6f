"""The 115 categories: count, codes, sub-indicators, templates classify as themselves."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.categorise import categorise
from tdb.categories import (
    COUNT,
    NO_DATA,
    NONE,
    PEAK,
    PIT,
    RIDGE,
    STEP_DOWN,
    STEP_UP,
    VALLEY,
    all_categories,
    feature_nodes,
    templates,
)


def test_exactly_115_with_stable_codes():
    cats = all_categories()
    assert len(cats) == COUNT == 115
    assert [c.code for c in cats] == list(range(115))
    assert NO_DATA not in {c.code for c in cats}


def test_sub_indicator_counts():
    features = Counter(c.feature for c in all_categories())
    assert features[RIDGE] == features[VALLEY] == 16
    assert features[STEP_UP] == features[STEP_DOWN] == 32
    assert features[NONE] == 9 and features[PEAK] == features[PIT] == 5
    divisions = {c.orientation for c in all_categories() if c.feature in (RIDGE, VALLEY)}
    assert len(divisions) == 16
    # Extreme points never sit in corners.
    assert all(c.orientation[0] not in (0, 2, 6, 8) for c in all_categories() if c.feature in (PEAK, PIT))
    # Every non-flat category has a rising direction except peaks and pits.
    assert all(1 <= c.inclination <= 8 for c in all_categories()[1:105])


@pytest.mark.parametrize("n", [5, 7, 9])
def test_templates_are_distinct_and_normalised(n):
    t = templates(n)
    assert t.shape == (115, n * n)
    assert (t[1:].min(axis=1) == 0).all() and (t[1:].max(axis=1) == 1).all()
    d = np.abs(t[1:, None, :] - t[None, 1:, :]).sum(axis=2)
    np.fill_diagonal(d, np.inf)
    assert d.min() > 0.3


def test_subgrid_too_small():
    with pytest.raises(ValueError):
        templates(4)


@pytest.mark.parametrize("exact", [True, False])
def test_every_template_classifies_as_itself(exact):
    t = templates(5)
    for amplitude in (0.3, 1.0, 5.0):
        codes = categorise(t[1:] * amplitude + 100.0, flat_threshold=0.1, exact=exact)
        np.testing.assert_array_equal(codes, np.arange(1, 115))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), amplitude=st.floats(0.5, 4.0))
def test_templates_with_noise_below_threshold_classify_as_themselves(seed, amplitude):
    rng = np.random.default_rng(seed)
    t = templates(5)
    noise = rng.uniform(-0.015, 0.015, (114, 25))  # peak-to-peak 3 cm < flat threshold 10 cm
    codes = categorise(t[1:] * amplitude + noise, flat_threshold=0.1)
    np.testing.assert_array_equal(codes, np.arange(1, 115))


def test_flat_and_no_data():
    tiles = np.zeros((3, 25))
    tiles[1] += np.linspace(0, 0.05, 25)  # range below threshold: flat
    tiles[2, 7] = np.nan
    assert categorise(tiles, flat_threshold=0.1).tolist() == [0, 0, NO_DATA]


def test_rotating_a_tile_rotates_its_category():
    t = templates(5)
    by_shape = {tuple(np.round(row, 6)): code for code, row in enumerate(t)}
    for code in range(1, 115):
        rotated = np.rot90(t[code].reshape(5, 5)).ravel()  # 90° anticlockwise
        assert tuple(np.round(rotated, 6)) in by_shape, f"rotation of {code} is not a category"


def test_feature_nodes():
    marks = feature_nodes(5)
    assert not marks[:9].any()  # flat and planes have no feature
    assert (marks[105:].sum(axis=1) == 1).all()  # one extreme node
    assert (marks[9:105].sum(axis=1) >= 3).all()
