"""Scan conversion of a TIN onto posts gives the heights point location gives."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tdb.rasterise import PostGrid, rasterise
from tdb.tin import surface_height, triangulate


def _located(xy, z, grid):
    tin = triangulate(xy)
    gx, gy = np.meshgrid(grid.x0 + np.arange(grid.cols) * grid.cell, grid.y0 - np.arange(grid.rows) * grid.cell)
    ref, _ = surface_height(tin, z, np.column_stack([gx.ravel(), gy.ravel()]))
    return tin, ref.reshape(gx.shape)


@settings(max_examples=25, deadline=None)
@given(
    st.integers(3, 400),
    st.floats(0.05, 3.0),
    st.floats(-5.0, 5.0),
    st.floats(-5.0, 5.0),
    st.integers(0, 10_000),
)
def test_rasterised_heights_are_the_located_ones(n, cell, ox, oy, seed):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 40, (n, 2)) + np.array([500_000.0, 5_000_000.0])
    z = rng.normal(100, 5, n)
    grid = PostGrid(500_000.0 + ox, 5_000_040.0 + oy, cell, int(45 / cell) + 1, int(45 / cell) + 1)
    tin, ref = _located(xy, z, grid)
    out = rasterise(xy, z, tin.simplices, grid)
    both = ~np.isnan(ref) & ~np.isnan(out)
    np.testing.assert_allclose(out[both], ref[both], atol=1e-8)
    # a post on the hull's edge may fall to either side of round-off; no other may differ
    differ = np.isnan(ref) != np.isnan(out)
    assert differ.sum() <= max(2, 0.01 * (~np.isnan(ref)).sum())


def test_posts_on_a_lattice_of_vertices_and_shared_edges_take_their_heights():
    """Vertices on posts, edges through posts (east–west, north–south and diagonal)."""
    gx, gy = np.meshgrid(np.arange(11.0), np.arange(11.0))
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    z = 3 + 0.5 * xy[:, 0] - 0.25 * xy[:, 1]
    grid = PostGrid(0.0, 10.0, 0.5, 21, 21)
    tin = triangulate(xy)
    out = rasterise(xy, z, tin.simplices, grid)
    assert not np.isnan(out).any()
    px, py = np.meshgrid(np.arange(21) * 0.5, 10.0 - np.arange(21) * 0.5)
    np.testing.assert_allclose(out, 3 + 0.5 * px - 0.25 * py, atol=1e-12)


def test_no_faces_and_faces_off_the_grid_leave_it_empty():
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    grid = PostGrid(10.0, 20.0, 1.0, 5, 5)
    assert np.isnan(rasterise(xy, np.zeros(3), np.zeros((0, 3), np.intp), grid)).all()
    assert np.isnan(rasterise(xy, np.zeros(3), np.array([[0, 1, 2]]), grid)).all()


@settings(max_examples=25, deadline=None)
@given(st.integers(3, 400), st.integers(0, 10_000))
def test_the_incremental_mesh_is_qhulls_delaunay_triangulation(n, seed):
    """startinpy's mesh (the dense model's) gives the surface Qhull's triangulation gives."""
    from tdb.tin import delaunay_mesh

    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 40, (n, 2)) + np.array([500_000.0, 5_000_000.0])
    z = rng.normal(100, 5, n)
    grid = PostGrid(500_000.0, 5_000_040.0, 0.5, 81, 81)
    _, ref = _located(xy, z, grid)
    verts, faces = delaunay_mesh(np.column_stack([xy, z]))
    assert len(verts) == n and faces.shape == (2 * n - 2 - len(triangulate(xy).qhull.convex_hull), 3)
    out = rasterise(verts[:, :2], verts[:, 2], faces, grid)
    both = ~np.isnan(ref) & ~np.isnan(out)
    np.testing.assert_allclose(out[both], ref[both], atol=1e-8)
    assert (np.isnan(ref) != np.isnan(out)).sum() <= max(2, 0.01 * (~np.isnan(ref)).sum())


def test_the_incremental_mesh_keeps_the_lowest_of_one_position_and_refuses_a_line():
    import pytest

    from tdb.errors import DegenerateInputError
    from tdb.tin import delaunay_mesh

    xyz = np.array([[0.0, 0.0, 5.0], [1.0, 0.0, 1.0], [0.0, 1.0, 2.0], [1.0, 0.00001, 0.5], [1.0, 1.0, 3.0]])
    verts, faces = delaunay_mesh(xyz)
    assert len(verts) == 4 and len(faces) == 2
    assert verts[np.argmin(np.hypot(verts[:, 0] - 1, verts[:, 1])), 2] == 0.5
    with pytest.raises(DegenerateInputError):
        delaunay_mesh(np.array([[0.0, 0.0, 1.0], [1.0, 1.0, 1.0], [2.0, 2.0, 1.0]]))
    with pytest.raises(DegenerateInputError):
        delaunay_mesh(np.zeros((2, 3)))


@settings(max_examples=25, deadline=None)
@given(st.integers(3, 200), st.floats(2.0, 30.0), st.integers(0, 10_000))
def test_triangles_with_an_edge_over_the_longest_cover_no_post(n, longest, seed):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 40, (n, 2)) + np.array([500_000.0, 5_000_000.0])
    z = rng.normal(100, 5, n)
    grid = PostGrid(500_000.0, 5_000_040.0, 0.7, 58, 58)
    faces = triangulate(xy).simplices
    corners = xy[faces]  # (T, 3, 2)
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    near_the_bound = np.abs(edges - longest) < 1e-6  # round-off may put these either side
    if near_the_bound.any():
        return
    expected = rasterise(xy, z, faces[edges <= longest], grid)
    np.testing.assert_array_equal(rasterise(xy, z, faces, grid, max_edge=longest), expected)
