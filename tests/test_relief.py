"""Two-sided relief, centre lines and elongation of matched objects, on analytic surfaces."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from queries.centreline import centrelines, elongation
from queries.filters import BREAK_LINES
from queries.relief import tile_relief, two_sided_relief
from tdb.categories import PEAK, PIT, SUBPART_UV, all_categories
from tdb.options import Measure
from tdb.tiles import node_lattice

LEVEL = 2
S = LEVEL / 4


def lattice_of(fn, size=40.0):
    """Every node of the level-2 lattice over [0, size]² stored, heights from ``fn``."""
    g = np.arange(0, size + S / 2, S)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    return node_lattice(x, y, fn(x, y), LEVEL)


def tiles(size=40.0):
    g = np.arange(8, size - 8, LEVEL)
    xg, yg = (a.ravel().astype(np.int64) for a in np.meshgrid(g, g))
    return xg, yg


def relief(fn, measure):
    lat = lattice_of(fn)
    xg, yg = tiles()
    return (xg, yg, *tile_relief(lat, xg, yg, measure=measure, reach=2 * LEVEL)[2:])


@settings(max_examples=25, deadline=None)
@given(
    st.floats(0.3, 2.0),
    st.floats(-0.2, 0.2),
    st.floats(-0.2, 0.2),
    st.floats(16.0, 24.0),
    st.sampled_from([Measure.DEPTH, Measure.HEIGHT]),
)
def test_a_ditch_or_bank_on_a_slope_stands_out_by_its_depth(size, gx, gy, y0, measure):
    # A 2 m wide V trough (or bank) along x at y0 on a tilted plane: its tiles measure
    # close to its depth; tiles off it, on the plane, measure no relief at all.
    sign = -1.0 if measure == "depth" else 1.0

    def fn(x, y):
        return 100 + gx * x + gy * y + sign * size * np.clip(1 - np.abs(y - y0) / 1.0, 0, None)

    _, yg, rel = relief(fn, measure)
    inside = (yg < y0) & (y0 < yg + LEVEL)  # the trough crosses the tile, not along its edge
    far = np.abs(yg + LEVEL / 2 - y0) > 6
    # The bottom lies between nodes unless y0 is on the lattice: the nearest node is at most
    # half a node spacing up the 1 m half-width; the slope across 2 × reach moves the sides apart,
    # and along the slope the lowest node may be the other neighbour, up to |gy| × S lower.
    assert np.all(rel[inside] > size * (1 - S / 2) - 2 * LEVEL * abs(gy) - abs(gy) * S - 1e-9)
    assert np.all(rel[inside] < size + 1e-9)
    assert np.all(rel[far] < 1e-9)  # a plane has no relief; on a tilted one it is negative


@settings(max_examples=25, deadline=None)
@given(st.floats(0.3, 2.0), st.floats(-0.25, 0.25), st.floats(16.0, 24.0), st.sampled_from([-1.0, 1.0]))
def test_on_a_slope_across_it_a_bank_reads_its_whole_height(size, gy, y0, sign):
    # The terrain across the bank is a plane: the relief is read against it, not against its
    # uphill side (which would take the slope's rise over the reach off the height).
    measure = Measure.HEIGHT if sign > 0 else Measure.DEPTH

    def fn(x, y):
        return 100 + gy * y + sign * size * np.clip(1 - np.abs(y - y0) / 1.0, 0, None)

    _, yg, rel = relief(fn, measure)
    inside = (yg < y0) & (y0 < yg + LEVEL)
    # the crest lies between nodes: the nearest is at most half a node spacing down its flank,
    # and the extreme node picked may be its neighbour, up to |gy| × S off
    assert np.all(rel[inside] > size * (1 - S / 2) - abs(gy) * S - 1e-9)
    assert np.all(rel[inside] < size + abs(gy) * S + 1e-9)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.5, 2.0), st.floats(0.0, 0.15), st.sampled_from([Measure.DEPTH, Measure.HEIGHT]))
def test_a_step_on_a_slope_is_still_no_ridge_nor_ditch(size, gy, measure):
    # A field edge on land rising the bank's way (land falling into a bank's foot makes a true
    # hollow there): beyond the bank both fields keep the land's slope, which the chord across
    # the bank does not; so the relief stays the smaller difference.
    def fn(x, y):
        return 50 + gy * y + np.clip((y - 19) / 2, 0, 1) * size

    _, _, rel = relief(fn, measure)
    assert np.nanmax(rel) <= 0.25 * size + 1e-9


@pytest.mark.parametrize("measure", [Measure.DEPTH, Measure.HEIGHT])
def test_a_step_has_no_depth_nor_height_but_a_step_measure(measure):
    # A 1 m step (an embankment's side, a ditch rim at a terrace) along y = 20.
    def fn(x, y):
        return 50 + np.clip((y - 19) / 2, 0, 1) * 1.0

    _, yg, rel = relief(fn, measure)
    # The side terrain is read bilinearly from the 2 m corner lattice, which rounds the step's
    # kinks: at most a quarter of the step shows as relief (a rim tile passes no 0.3 m filter).
    assert np.nanmax(rel) <= 0.25 + 1e-9
    _, yg, step = relief(fn, Measure.STEP)
    near = np.abs(yg + LEVEL / 2 - 20) <= 2
    assert np.allclose(step[near], 1.0)


@pytest.mark.parametrize("measure", [Measure.DEPTH, Measure.HEIGHT])
def test_along_a_narrow_trench_its_rim_is_no_ridge_across_its_break_line(measure):
    # A 1 m wide, 1.3 m deep trench (or wall) along y = 20; a node on the plane 1 m off its axis.
    # Along x the cells beside the node hold corners in the trench, so read along the rim the
    # terrain "beside" it sinks (rises) and the rim seems to stand out; across it, it does not.
    sign = 1.0 if measure == "height" else -1.0

    def fn(x, y):
        return 100 - sign * 1.3 * (np.abs(y - 20) <= 0.5)

    lat = lattice_of(fn)
    x, y, z = np.array([20.0]), np.array([19.0]), np.array([100.0])
    every_way = two_sided_relief(lat, x, y, z, measure=measure, reach=4)
    across = two_sided_relief(lat, x, y, z, measure=measure, reach=4, along=np.array([[1.0, 0.0]]))
    assert every_way[0] > 0.3  # a 0.3 m filter would take the rim
    assert abs(across[0]) < 1e-9
    no_line = two_sided_relief(lat, x, y, z, measure=measure, reach=4, along=np.full((1, 2), np.nan))
    assert no_line[0] == every_way[0]  # a peak or a plane has no line: every direction is read


def test_break_lines_run_between_the_sub_parts_of_each_category():
    cats = all_categories()
    for c in cats:
        d = BREAK_LINES[c.code]
        if c.orientation is None or c.feature in (PEAK, PIT):
            assert np.isnan(d).all()
            continue
        a, b = SUBPART_UV[c.orientation[0]], SUBPART_UV[c.orientation[1]]
        assert np.linalg.norm(d) == pytest.approx(1.0)
        assert abs(d[0] * (b - a)[1] - d[1] * (b - a)[0]) < 1e-12 and np.dot(d, b - a) > 0
    assert np.isnan(BREAK_LINES[len(cats) :]).all()


def test_relief_is_unknown_without_terrain_beside():
    lat = lattice_of(lambda x, y: x * 0.0)
    rel = two_sided_relief(lat, np.array([1.0]), np.array([1.0]), np.array([-1.0]), measure=Measure.DEPTH, reach=4)
    # West and south of the lattice: no terrain there; the north-east diagonal pair is unknown too.
    assert np.isnan(rel[0])


def test_centreline_follows_a_chain_and_drops_spurs():
    t = np.linspace(0, 60, 61)
    x, y = t, 10 + 0.0 * t
    # Rim nodes one metre off the line beside every fifth node: spurs at junctions.
    rx, ry = t[::5][1:-1], np.full(len(t[::5]) - 2, 11.0)
    line = centreline(np.r_[x, rx], np.r_[y, ry], link=6)
    assert line.length == pytest.approx(60, abs=1e-6)
    assert shapely.LineString([(0, 10), (60, 10)]).buffer(1e-6).contains(line)
    assert centreline(np.array([1.0, 1.0]), np.array([2.0, 2.0]), link=6).is_empty


def test_elongation_tells_a_line_from_a_blob():
    t = np.linspace(0, 40, 21)
    assert elongation(t, 0.5 * t, level=2) == pytest.approx(np.hypot(40, 20) / 2)
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    assert elongation(6 * np.cos(a), 6 * np.sin(a), level=2) < 1.2


def test_tile_nodes_read_the_lattice_inside_and_nan_beyond_it():
    level = 2
    s = level / 4
    x, y = (a.ravel() for a in np.meshgrid(np.arange(0, 8.01, s), np.arange(0, 5.01, s)))
    z = 3.0 * x + 0.5 * y
    lattice = node_lattice(x, y, z, level)
    xg, yg = np.array([0, 2, 6]), np.array([0, 2, 4])
    inside = lattice.tile_nodes(xg[:2], yg[:2])  # wholly on the lattice: one gather of windows
    d = np.arange(5) * s
    np.testing.assert_allclose(inside[1], 3.0 * (2 + d[None, :]) + 0.5 * (2 + d[:, None]))
    partly = lattice.tile_nodes(xg, yg)  # the last tile runs off the lattice's north edge
    np.testing.assert_allclose(partly[:2], inside)
    assert np.isnan(partly[2, 3:]).all() and not np.isnan(partly[2, :3]).any()  # rows y = 4, 4.5, 5 only


def test_centrelines_of_groups_side_by_side_stay_apart():
    t = np.arange(0.0, 20.0, 1.0)
    x = np.concatenate([t, t])
    y = np.concatenate([np.zeros_like(t), np.full_like(t, 2.0)])  # two lines 2 m apart, link 3 m
    group = np.repeat([0, 1], len(t))
    lines = centrelines(x, y, group, link=3.0, count=3)
    for g in (0, 1):
        alone = centreline(x[group == g], y[group == g], link=3.0)
        assert lines[g].equals(alone) and lines[g].length == pytest.approx(19.0)
    assert lines[2].is_empty  # a group with no points


def centreline(x, y, *, link):
    """One group's centre line."""
    return centrelines(x, y, np.zeros(len(x), np.intp), link=link, count=1)[0]
