"""Mounds and pits: closed forms stand out of the ring of tiles around them, lines do not."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.pipeline import ingest
from queries.match import find
from queries.relief import ring_extremes, ring_relief
from tdb.cloud import from_arrays
from tdb.options import Measure
from tdb.tiles import SUBGRID, node_lattice


def _dome(x, y, cx, cy, *, width, height):
    u = np.clip(np.hypot(x - cx, y - cy) / (width / 2), 0, 1)
    return height * 0.5 * (1 + np.cos(np.pi * u))


def _line(x, y, *, offset, angle, width, height):
    """A straight form through (75, offset) east of x = 55."""
    d = np.abs(-(x - 75) * np.sin(angle) + (y - offset) * np.cos(angle))
    return np.where(x > 55, height * (1 - np.clip(d / (width / 2), 0, 1)), 0.0)


def _terrain(x, y, *, cx, cy, angle):
    z = 100 + 0.01 * x - 0.02 * y
    z += _dome(x, y, cx, cy, width=6.0, height=1.0)  # a mound
    z -= _dome(x, y, cx, cy + 30, width=6.0, height=1.0)  # a pit
    z += _line(x, y, offset=55, angle=angle, width=2.0, height=1.0)  # a ridge
    z -= _line(x, y, offset=25, angle=angle, width=1.5, height=1.0)  # a ditch
    return z


def _every_node(cx, cy, angle, sign=1.0):
    s = 2 / (SUBGRID - 1)
    gx, gy = np.meshgrid(np.arange(0, 100 + s, s), np.arange(0, 80 + s, s))
    z = sign * _terrain(gx, gy, cx=cx, cy=cy, angle=angle)
    return node_lattice(gx.ravel(), gy.ravel(), z.ravel(), 2)


@settings(max_examples=25, deadline=None)
@given(cx=st.floats(20, 35), cy=st.floats(20, 30), angle=st.floats(-0.4, 0.4))
def test_a_mound_stands_out_all_round_and_a_ridge_does_not(cx, cy, angle):
    lat = _every_node(cx, cy, angle)
    tiles = np.arange(0, 100, 2)
    xg, yg = (a.ravel() for a in np.meshgrid(tiles, np.arange(0, 80, 2)))
    top = lat.tile_nodes(xg, yg).reshape(len(xg), -1).max(axis=1)
    rel = ring_relief(lat, xg, yg, top, measure=Measure.HEIGHT, tiles=2)
    mound = (np.abs(xg + 1 - cx) <= 1) & (np.abs(yg + 1 - cy) <= 1)
    ridge = np.abs(-(xg + 1 - 75) * np.sin(angle) + (yg + 1 - 55) * np.cos(angle)) < 2
    assert np.nanmax(rel[mound]) > 0.5  # the dome's top is 1 m over ground 4-6 m away
    # along the ridge the ring holds its crest: nothing stands out by more than the terrain's tilt
    assert np.nanmax(rel[ridge & (xg > 60) & (xg < 88)]) < 0.15
    # the same lattice upside down: the pit and not the ditch
    lat = _every_node(cx, cy, angle, sign=-1.0)
    low = lat.tile_nodes(xg, yg).reshape(len(xg), -1).max(axis=1)
    rel = ring_relief(lat, xg, yg, low, measure=Measure.HEIGHT, tiles=2)
    assert np.nanmax(rel[mound]) < 0.15  # the mound is a pit upside down
    assert np.nanmax(rel[(np.abs(xg + 1 - cx) <= 1) & (np.abs(yg + 1 - cy - 30) <= 1)]) > 0.5
    ditch = np.abs(-(xg + 1 - 75) * np.sin(angle) + (yg + 1 - 25) * np.cos(angle)) < 2
    assert np.nanmax(rel[ditch & (xg > 60) & (xg < 88)]) < 0.15


@settings(max_examples=25, deadline=None)
@given(
    grade=st.floats(0.0, 0.25),
    aspect=st.floats(0.0, 2 * np.pi),
    cx=st.floats(20, 35),
    cy=st.floats(20, 30),
    angle=st.floats(-0.4, 0.4),
)
def test_on_a_slope_a_mound_still_stands_out_and_a_ridge_does_not(grade, aspect, cx, cy, angle):
    # Up to 0.25 m/m, any way: the ring's uphill side lies up to 1.5 m over the dome's foot, more
    # than the dome's height; the ring's own plane is taken off before the comparison. The dome is
    # 4 m across, so its flanks stay out of the ring: where they reach into it the ring is not
    # a plane, and the tile is read as on flat ground (docs/query-language.md).
    gx, gy = grade * np.cos(aspect), grade * np.sin(aspect)
    s = 2 / (SUBGRID - 1)
    nx, ny = np.meshgrid(np.arange(0, 100 + s, s), np.arange(0, 80 + s, s))
    z = 100 + gx * nx + gy * ny
    z = (
        z
        + _dome(nx, ny, cx, cy, width=4.0, height=1.0)
        + _line(nx, ny, offset=55, angle=angle, width=2.0, height=1.0)
    )
    lat = node_lattice(nx.ravel(), ny.ravel(), z.ravel(), 2)
    xg, yg = (a.ravel() for a in np.meshgrid(np.arange(0, 100, 2), np.arange(0, 80, 2)))
    top = lat.tile_nodes(xg, yg).reshape(len(xg), -1).max(axis=1)
    rel = ring_relief(lat, xg, yg, top, measure=Measure.HEIGHT, tiles=2)
    mound = (np.abs(xg + 1 - cx) <= 1) & (np.abs(yg + 1 - cy) <= 1)
    ridge = np.abs(-(xg + 1 - 75) * np.sin(angle) + (yg + 1 - 55) * np.cos(angle)) < 2
    assert np.nanmax(rel[mound]) > 0.3  # the filter's least height; a tile's highest node sits on its uphill edge
    assert np.nanmax(rel[ridge & (xg > 60) & (xg < 88)]) < 0.15
    plane = (np.abs(xg + 1 - cx) > 12) & (np.abs(yg + 1 - 55) > 8) & (xg > 4) & (xg < 94) & (yg > 4) & (yg < 74)
    assert np.nanmax(rel[plane]) < 0.05  # a tilted plane holds no closed form


def test_ring_relief_is_unknown_at_the_edge_of_the_data():
    lat = node_lattice(np.array([0.0, 0.5, 2.0]), np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, 1.0]), 2)
    rel = ring_relief(lat, np.array([0]), np.array([0]), np.array([2.0]), measure=Measure.HEIGHT, tiles=2)
    assert np.isnan(rel).all()


def test_the_mound_and_pit_filters_find_the_dome_and_the_bowl_not_the_lines(tmp_path):
    rng = np.random.default_rng(3)
    n = 100 * 80 * 4
    x, y = rng.uniform(0, 100, n), rng.uniform(0, 80, n)
    cx, cy, angle = 30.3, 28.7, 0.3
    z = _terrain(x, y, cx=cx, cy=cy, angle=angle) + rng.normal(0, 0.03, n)
    db = tdb.open(tmp_path / "closed.tdb", create=True)
    ingest(from_arrays(x + 500_000, y + 5_500_000, z, crs="EPSG:25832"), db, version="v")
    mound = shapely.Point(cx + 500_000, cy + 5_500_000)
    pit = shapely.Point(cx + 500_000, cy + 30 + 5_500_000)
    mounds, pits = find(db, "v", "mound"), find(db, "v", "pit")
    assert len(mounds) == 1 and mounds[0].geometry.distance(mound) < 2 and mounds[0].measure > 0.5
    assert len(pits) == 1 and pits[0].geometry.distance(pit) < 2 and pits[0].measure > 0.5


@settings(max_examples=40, deadline=None)
@given(
    i0=st.integers(-9, 9),
    j0=st.integers(-9, 9),
    rows=st.integers(1, 23),
    cols=st.integers(1, 23),
    holes=st.floats(0, 0.6),
    seed=st.integers(0, 2**16),
    depth=st.booleans(),
)
def test_ring_relief_matches_reading_every_ring_tile(i0, j0, rows, cols, holes, seed, depth):
    # The per-tile extremes are read from one padded grid and the ring's plane fitted over all
    # tiles at once; here each ring tile's nodes are read, and the plane worked out, one by one.
    rng = np.random.default_rng(seed)
    z = rng.normal(0, 1, (rows, cols))
    z[rng.random((rows, cols)) < holes] = np.nan
    s = 2 / (SUBGRID - 1)
    jj, ii = np.nonzero(~np.isnan(z))
    lat = node_lattice((ii + i0) * s, (jj + j0) * s, z[jj, ii], 2)
    if lat.z.size == 0:
        return
    xg, yg = (a.ravel() * 2 for a in np.meshgrid(np.arange(-4, 8), np.arange(-4, 8)))
    top = rng.normal(0, 2, len(xg))
    measure = Measure.DEPTH if depth else Measure.HEIGHT
    got = ring_relief(lat, xg, yg, top, measure=measure, tiles=2)
    sign = -1.0 if depth else 1.0
    ext = {}  # (di, dj) -> each tile's extreme node of that ring tile
    for di in range(-2, 3):
        for dj in range(-2, 3):
            if max(abs(di), abs(dj)) == 2:
                nodes = lat.tile_nodes(xg + 2 * di, yg + 2 * dj).reshape(len(xg), -1)
                known = ~np.isnan(nodes).all(axis=1)
                ext[di, dj] = np.full(len(xg), np.nan)
                ext[di, dj][known] = sign * np.nanmax(sign * nodes[known], axis=1)
    # the ring's plane, tile by tile: the median of the facing tiles' differences per axis
    gx = np.median([ext[2, d] - ext[-2, d] for d in range(-2, 3)], axis=0) / 4
    gy = np.median([ext[d, 2] - ext[d, -2] for d in range(-2, 3)], axis=0) / 4
    level = {k: v - gx * k[0] - gy * k[1] for k, v in ext.items()}

    def least_relief(heights):
        rel = np.array([sign * (top - h) for h in heights.values()])
        least, most = rel.min(axis=0), rel.max(axis=0)
        return np.where(~(least < 0.35 * most), least, 0.0)

    raw, flat = least_relief(ext), least_relief(level)
    stack = np.array(list(level.values()))
    spread = np.abs(stack - np.median(stack, axis=0)).max(axis=0)
    want = np.where(spread <= 0.5 * flat, flat, raw)
    want[~np.isfinite(want) | np.isnan(stack).any(axis=0)] = np.nan
    np.testing.assert_allclose(got, want, equal_nan=True)
    # the two ways of reading the ring agree: all tiles of the lattice first, or the ring tiles alone
    ring = np.array([(2, 0), (-2, 1), (0, -2), (2, 2), (-1, -2)])
    np.testing.assert_array_equal(
        ring_extremes(lat, xg, yg, ring, sign=sign, whole=True),
        ring_extremes(lat, xg, yg, ring, sign=sign, whole=False),
    )
