"""Rasters of the default ground filter: gap filling, corner heights, per-cell ordering, sampling."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from ingest.ground.grids import CellSort, Grid, corner_heights
from tdb.errors import InputError
from tdb.fill import NearestFill, fill_lines, fill_lines_stack, fill_nearest


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    a=st.floats(-2, 2),
    b=st.floats(-2, 2),
    holes=st.floats(0.0, 0.9),
)
def test_line_fill_then_nearest_reproduces_a_plane(seed, a, b, holes):
    rng = np.random.default_rng(seed)
    rows, cols = 30, 40
    i, j = np.mgrid[0:rows, 0:cols]
    plane = 5.0 + a * j + b * i
    raster = plane.copy()
    raster[rng.random(plane.shape) < holes] = np.nan
    raster[0, 0] = plane[0, 0]
    raster[-1, -1] = plane[-1, -1]
    filled = fill_nearest(fill_lines(raster))
    bracketed = ~np.isnan(raster)
    # cells bracketed along their row or column lie on the plane exactly
    row_ok = np.maximum.accumulate(bracketed, axis=1) & np.maximum.accumulate(bracketed[:, ::-1], axis=1)[:, ::-1]
    col_ok = np.maximum.accumulate(bracketed, axis=0) & np.maximum.accumulate(bracketed[::-1], axis=0)[::-1]
    inside = row_ok | col_ok
    assert not np.isnan(filled).any()
    np.testing.assert_allclose(filled[inside], plane[inside], atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(a=st.floats(-3, 3), b=st.floats(-3, 3), c=st.floats(-100, 100))
def test_two_passes_fill_tiles_known_at_their_corners_with_the_plane(a, b, c):
    i, j = np.mgrid[0:5, 0:5]
    plane = np.broadcast_to(c + a * j + b * i, (3, 5, 5)).copy()
    tiles = np.full_like(plane, np.nan)
    tiles[:, [0, 0, 4, 4], [0, 4, 0, 4]] = plane[:, [0, 0, 4, 4], [0, 4, 0, 4]]
    assert np.isnan(fill_lines(tiles)[:, 1:4, 1:4]).all()  # one pass reaches the edges only
    np.testing.assert_allclose(fill_lines(tiles, passes=2), plane, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    holes=st.floats(0.0, 1.0),
    passes=st.integers(1, 3),
    size=st.integers(2, 6),
    kinds=st.integers(1, 100),
)
def test_fill_lines_stack_equals_filling_each_raster(seed, holes, passes, size, kinds):
    rng = np.random.default_rng(seed)
    stack = rng.normal(size=(200, size, size)) * 10
    # holes drawn from a set of masks: few (patterns shared, weights used) or many (rare, filled one by one)
    masks = rng.random((kinds, size, size)) < holes
    stack[masks[rng.integers(0, kinds, 200)]] = np.nan
    cells = rng.choice(size * size, size=min(4, size * size), replace=False)
    expected = fill_lines(stack, passes=passes).reshape(200, -1)[:, cells]
    got = fill_lines_stack(stack, passes=passes, cells=cells)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
    np.testing.assert_allclose(got, expected, atol=1e-9)
    # the second call reads the cached weights and must agree too
    np.testing.assert_allclose(fill_lines_stack(stack, passes=passes, cells=cells), expected, atol=1e-9)


def test_nearest_fill_reuses_indices_not_values():
    rng = np.random.default_rng(9)
    holes = rng.random((40, 50)) < 0.3
    fill = NearestFill()
    for _ in range(3):  # same holes, new values: each raster is filled from its own cells
        raster = np.where(holes, np.nan, rng.normal(size=holes.shape))
        ri, ci = ndimage.distance_transform_edt(holes, return_distances=False, return_indices=True)
        np.testing.assert_array_equal(fill(raster), raster[ri, ci])
        np.testing.assert_array_equal(fill_nearest(raster), raster[ri, ci])
    other = np.where(rng.random((40, 50)) < 0.5, np.nan, rng.normal(size=holes.shape))  # new holes
    ri, ci = ndimage.distance_transform_edt(np.isnan(other), return_distances=False, return_indices=True)
    np.testing.assert_array_equal(fill(other), other[ri, ci])


def test_fill_nearest_takes_the_nearest_value_and_refuses_an_empty_raster():
    raster = np.full((5, 5), np.nan)
    raster[0, 0], raster[4, 4] = 1.0, 2.0
    filled = fill_nearest(raster)
    assert filled[1, 0] == 1.0 and filled[3, 4] == 2.0
    with pytest.raises(InputError):
        fill_nearest(np.full((3, 3), np.nan))


def test_cell_sort_lowest_matches_brute_force():
    rng = np.random.default_rng(1)
    xyz = np.column_stack([rng.uniform(0, 20, 2000), rng.uniform(0, 10, 2000), rng.normal(size=2000)])
    grid = Grid.covering(xyz[:, :2], 1.0)
    mask = rng.random(2000) < 0.5
    idx = CellSort.of(grid, xyz).lowest(mask)
    row, col = grid.index(xyz[:, :2])
    for r in range(grid.shape[0]):
        for c in range(grid.shape[1]):
            members = np.flatnonzero(mask & (row == r) & (col == c))
            if len(members) == 0:
                assert idx[r, c] == -1
            else:
                assert idx[r, c] == members[np.argmin(xyz[members, 2])]


def test_corner_heights_of_a_level_surface_and_empty_cells():
    rng = np.random.default_rng(2)
    xyz = np.column_stack([rng.uniform(0, 10, 500), rng.uniform(0, 10, 500), np.full(500, 7.5)])
    xyz = xyz[~((xyz[:, 0] > 4) & (xyz[:, 0] < 7) & (xyz[:, 1] > 4) & (xyz[:, 1] < 7))]
    grid = Grid.covering(xyz[:, :2], 1.0)
    corners = corner_heights(grid, xyz, CellSort.of(grid, xyz).lowest())
    assert corners.shape == (grid.shape[0] + 1, grid.shape[1] + 1)
    assert np.isnan(corners[5, 5])  # all four cells around (5, 5) are empty
    np.testing.assert_allclose(corners[~np.isnan(corners)], 7.5, atol=1e-5)


def test_corner_sampler_is_bilinear():
    rng = np.random.default_rng(3)
    grid = Grid(100.0, 200.0, 2.0, (6, 8))
    raster = rng.normal(size=(7, 9))
    xy = np.column_stack([rng.uniform(100, 116, 300), rng.uniform(200, 212, 300)])
    expected = ndimage.map_coordinates(raster, [(xy[:, 1] - 200) / 2, (xy[:, 0] - 100) / 2], order=1)
    np.testing.assert_allclose(grid.corner_sampler(xy)(raster), expected, atol=1e-12)


def test_by_tiles_equals_the_whole_cloud_for_a_local_filter():
    from ingest.ground.tiling import by_tiles

    rng = np.random.default_rng(4)
    xyz = np.column_stack([rng.uniform(0, 400, 20_000), rng.uniform(0, 300, 20_000), rng.normal(size=20_000)])

    def local(points):  # depends on each point alone, so tiling must not change it
        return points[:, 2] < 0.5 * np.sin(points[:, 0] / 7.0)

    calls = []
    tiled = by_tiles(xyz, local, target_points=2_000, buffer=10.0, progress=lambda k, n: calls.append((k, n)))
    np.testing.assert_array_equal(tiled, local(xyz))
    n = calls[-1][1]
    assert n >= 8 and calls == [(k, n) for k in range(1, n + 1)]  # one call per tile, in order
    assert by_tiles(xyz[:100], local, target_points=2_000).sum() == local(xyz[:100]).sum()


def test_by_tiles_in_two_processes_equals_one():
    from ingest.ground.auto import auto_ground
    from ingest.ground.tiling import by_tiles

    rng = np.random.default_rng(5)
    xyz = np.column_stack([rng.uniform(0, 200, 8_000), rng.uniform(0, 100, 8_000), rng.normal(0, 0.05, 8_000)])
    xyz[rng.random(8_000) < 0.1, 2] += 5.0  # objects for the filter to remove
    one = by_tiles(xyz, auto_ground, target_points=2_000, buffer=10.0)
    np.testing.assert_array_equal(by_tiles(xyz, auto_ground, target_points=2_000, buffer=10.0, workers=2), one)
    assert 0.5 < one.mean() < 0.95


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), holes=st.floats(0.1, 0.9), passes=st.integers(1, 3))
def test_fill_lines_stack_does_not_depend_on_what_earlier_calls_filled(seed, holes, passes):
    # A block of a distributed ingest is modelled in whatever process is free: its surface must be
    # the same bit for bit whether or not that process has filled the same hole patterns before.
    rng = np.random.default_rng(seed)
    masks = rng.random((60, 5, 5)) < holes  # each pattern held by one raster here: all rare
    stack = np.where(masks, np.nan, rng.normal(size=(60, 5, 5)) * 10)
    first = fill_lines_stack(stack, passes=passes)
    fill_lines_stack(np.repeat(stack, 10, axis=0), passes=passes)  # the same patterns, shared
    np.testing.assert_array_equal(fill_lines_stack(stack, passes=passes), first)
