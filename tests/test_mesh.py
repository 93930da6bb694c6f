"""The kept points' mesh: corner-only tiles split along the diagonal their category implies."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tdb.categories import NO_DATA, all_categories, subgrid_uv, templates
from tdb.rasterise import PostGrid
from tdb.surface import anti_diagonal, corner_nodes, kept_mesh, mesh_grid, mesh_height, split_heights

SW, SE, NW, NE = 0, 2, 6, 8  # sub-part indices of the corners
DIAGONAL = [c for c in all_categories() if c.orientation in ((SW, NE), (NE, SW), (SE, NW), (NW, SE))]


def test_there_are_twelve_diagonal_break_lines() -> None:
    assert len(DIAGONAL) == 12  # 2 diagonals x 6 plane combinations


@pytest.mark.parametrize("cat", DIAGONAL, ids=lambda c: c.description)
@given(base=st.floats(-50, 50), relief=st.floats(0.05, 5))
@settings(max_examples=20, deadline=None)
def test_a_tile_folded_along_a_diagonal_is_split_along_it(cat, base: float, relief: float) -> None:
    tile = base + relief * templates(5)[cat.code]
    corners = tile[corner_nodes(5)][None]
    anti = anti_diagonal(corners, np.array([cat.code], np.uint8))
    assert bool(anti[0]) == (cat.orientation in ((SE, NW), (NW, SE)))
    uv = subgrid_uv(5)
    # the template is two planes meeting on that diagonal, so the split reproduces it exactly
    np.testing.assert_allclose(split_heights(corners, uv[:, 0], uv[:, 1], anti), tile, atol=1e-9)


def test_without_a_category_the_closer_heights_are_joined() -> None:
    corners = np.array([[0.0, 1.0, 1.05, 3.0], [0.0, 1.0, 3.0, 0.2]])  # SW, SE, NW, NE
    codes = np.array([NO_DATA, 0], np.uint8)
    assert anti_diagonal(corners, codes).tolist() == [True, False]


def _block(rng: np.random.Generator, anti_tile: bool):
    """Points of a 3 x 2 block of 2 m tiles on the 0.5 m lattice: every tile keeps its corners,
    tile (1, 0) its centre as well; tile (0, 0) is a ridge along one diagonal."""
    ix, iy = np.meshgrid(np.arange(0, 13, 4), np.arange(0, 9, 4))
    pts = {(int(i), int(j)): rng.normal(0, 1) for i, j in zip(ix.ravel(), iy.ravel())}
    pts[(6, 2)] = rng.normal(0, 1)
    ridge = next(
        c
        for c in DIAGONAL
        if c.feature == 1 and c.orientation in (((SE, NW), (NW, SE)) if anti_tile else ((SW, NE), (NE, SW)))
    )
    tile = 10 + 2 * templates(5)[ridge.code]
    for node, (i, j) in zip(corner_nodes(5), ((0, 0), (4, 0), (0, 4), (4, 4))):
        pts[(i, j)] = float(tile[node])
    key = np.array(list(pts))
    x, y = key[:, 0] * 0.5, key[:, 1] * 0.5
    z = np.array(list(pts.values()))
    xg = np.array([0, 2, 4, 0, 2, 4])
    yg = np.array([0, 0, 0, 2, 2, 2])
    code = np.full(6, NO_DATA, np.uint8)
    code[0] = ridge.code
    return x, y, z, xg, yg, code, tile


@pytest.mark.parametrize("anti_tile", [False, True])
def test_the_mesh_follows_the_category_and_its_faces_agree_with_its_heights(anti_tile: bool) -> None:
    rng = np.random.default_rng(3)
    x, y, z, xg, yg, code, tile = _block(rng, anti_tile)
    mesh = kept_mesh(x, y, z, xg=xg, yg=yg, code=code, level=2)
    uv = subgrid_uv(5)
    np.testing.assert_allclose(mesh_height(mesh, uv * 2.0), tile, atol=1e-9)
    # five corner-only tiles are re-split; the one with its centre kept is Delaunay's
    assert (mesh.halves >= 0).sum() == 10
    # heights interpolated on the faces equal mesh_height everywhere inside
    q = rng.uniform([0.01, 0.01], [5.99, 3.99], (2000, 2))
    p = np.column_stack([x, y])
    a, b, c = (p[mesh.faces[:, k]] for k in range(3))
    cross = lambda u, v: u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]  # noqa: E731
    area = cross(b - a, c - a)
    l1 = cross(c[None] - b[None], q[:, None] - b[None]) / area
    l2 = cross(a[None] - c[None], q[:, None] - c[None]) / area
    l3 = 1 - l1 - l2
    inside = (l1 >= -1e-12) & (l2 >= -1e-12) & (l3 >= -1e-12)
    first = inside.argmax(axis=1)
    assert inside.any(axis=1).all()
    f = mesh.faces[first]
    k = np.arange(len(q))
    on_faces = l1[k, first] * z[f[:, 0]] + l2[k, first] * z[f[:, 1]] + l3[k, first] * z[f[:, 2]]
    np.testing.assert_allclose(mesh_height(mesh, q), on_faces, atol=1e-9)
    assert abs(np.abs(area).sum() / 2 - 24.0) < 1e-9  # the faces tile the block once
    # on a grid of posts, scan conversion gives mesh_height's heights without locating a post
    grid = PostGrid(0.05, 3.95, 0.1, 40, 60)
    gx, gy = np.meshgrid(grid.x0 + np.arange(grid.cols) * grid.cell, grid.y0 - np.arange(grid.rows) * grid.cell)
    located = mesh_height(mesh, np.column_stack([gx.ravel(), gy.ravel()])).reshape(gx.shape)
    np.testing.assert_allclose(mesh_grid(mesh, grid), located, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 300), seed=st.integers(0, 2**16))
def test_morton_order_interleaves_the_bits_of_x_and_y(n, seed):
    """The order is by the Z-order key, bit b of x at bit 2b and of y at 2b + 1, worked out here
    bit by bit; of equal keys the first first."""
    from tdb.bbox import column_range
    from tdb.tin import morton_order

    rng = np.random.default_rng(seed)
    xy = np.round(rng.uniform(0, 50, (n, 2)), 1)  # ties too
    lo, hi = column_range(xy)
    q = ((xy - lo) / max(float((hi - lo).max()), 1e-9) * 65535).astype(np.int64)
    key = sum(((q[:, 0] >> b) & 1) << (2 * b) | ((q[:, 1] >> b) & 1) << (2 * b + 1) for b in range(16))
    np.testing.assert_array_equal(morton_order(xy), np.argsort(key, kind="stable"))
