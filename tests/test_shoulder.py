"""Shoulders: a wall drops to its foot 0.8–1.6 m off its crest, a ridge does not; the ridge and
wall filters tell them apart."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.pipeline import ingest
from queries.match import find
from queries.shoulder import shoulders
from tdb.cloud import from_arrays
from tdb.options import Measure
from tdb.tiles import SUBGRID, node_lattice


def _form(x, y, *, angle, offset, width, height, profile):
    """Height of a straight form of the given cross-section, along a line through (0, offset)."""
    d = np.abs(-(x - 50) * np.sin(angle) + (y - offset) * np.cos(angle))
    u = np.clip(d / (width / 2), 0, 1)
    return height * ((1 - u**4) if profile == "U" else (1 - u))


def _terrain(x, y, angle):
    z = 100 + 0.01 * x - 0.02 * y
    z += _form(x, y, angle=angle, offset=20, width=1.2, height=1.5, profile="U")  # a wall
    z += _form(x, y, angle=angle, offset=50, width=4.0, height=1.0, profile="V")  # a ridge
    return z


def _axis(angle, offset):
    d = np.array([np.cos(angle), np.sin(angle)])
    c = np.array([50.0, offset])
    return shapely.LineString([c - 25 * d, c + 25 * d])


def _lattice(angle, flip=False):
    # Every node of the 2 m level's lattice (0.5 m apart) stored, as the corners are after ingest.
    s = 2 / (SUBGRID - 1)
    gx, gy = np.meshgrid(np.arange(0, 100 + s, s), np.arange(0, 70 + s, s))
    z = _terrain(gx, gy, angle)
    return node_lattice(gx.ravel(), gy.ravel(), (200 - z if flip else z).ravel(), 2)


@settings(max_examples=20, deadline=None)
@given(angle=st.floats(0.1, 0.6), sign=st.sampled_from([-1, 1]))
def test_a_wall_has_no_shoulder_and_a_ridge_has_one_at_bearings_off_the_lattice(angle, sign):
    angle *= sign
    wall, ridge = shoulders(_lattice(angle), [_axis(angle, 20), _axis(angle, 50)], np.array([1.5, 1.0]))
    assert wall < 0.1
    assert ridge > 0.3  # a 4 m V ridge stands at 0.2-0.6 of its height 0.8-1.6 m off its crest
    # Depth of a ditch: the same form upside down.
    narrow, broad = shoulders(
        _lattice(angle, flip=True),
        [_axis(angle, 20), _axis(angle, 50)],
        np.array([1.5, 1.0]),
        measure=Measure.DEPTH,
    )
    assert narrow < 0.1 and broad > 0.3


def test_a_line_on_a_row_of_corners_has_no_shoulder():
    # Both forms run along y = 20 and y = 50, rows of tile corners: every corner is 0 or 2 m off.
    assert np.isnan(shoulders(_lattice(0.0), [_axis(0.0, 20), _axis(0.0, 50)], np.array([1.5, 1.0]))).all()


def test_no_shoulder_where_nothing_is_measured():
    lat = node_lattice(np.array([0.0, 2.0]), np.array([0.0, 0.0]), np.array([1.0, 1.0]), 2)
    out = shoulders(lat, [shapely.LineString(), _axis(0.0, 50)], np.array([1.0, np.nan]))
    assert np.isnan(out).all()


@pytest.mark.parametrize("angle", [0.15, -0.35])
def test_the_ridge_filter_finds_the_ridge_and_the_wall_filter_the_wall(tmp_path, angle):
    rng = np.random.default_rng(1)
    n = 100 * 70 * 4
    x, y = rng.uniform(0, 100, n), rng.uniform(0, 70, n)
    z = _terrain(x, y, angle) + rng.normal(0, 0.03, n)
    db = tdb.open(tmp_path / "forms.tdb", create=True)
    ingest(from_arrays(x + 500_000, y + 5_500_000, z, crs="EPSG:25832"), db, version="v")
    wall = shapely.affinity.translate(_axis(angle, 20), 500_000, 5_500_000)
    ridge = shapely.affinity.translate(_axis(angle, 50), 500_000, 5_500_000)

    def near(found, line):
        return sum(m.geometry.intersection(line.buffer(2)).length for m in found)

    ridges, walls = find(db, "v", "ridge"), find(db, "v", "wall")
    assert near(ridges, ridge) > 30 and near(ridges, wall) < 5
    assert near(walls, wall) > 30 and near(walls, ridge) < 5
    assert all(m.shoulder <= 0.25 for m in walls) and all(not m.shoulder < 0.25 for m in ridges)
