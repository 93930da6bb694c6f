"""The ground TIN that re-triangulates only where new vertices land."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from ingest.ground.ground_tin import GroundTin
from tdb.tin import barycentric

BOX = np.array([[-10, -10, 0], [110, -10, 0], [110, 110, 0], [-10, 110, 0]], float)


def _triangles(simplices):
    return set(map(tuple, np.sort(simplices, axis=1)))


def _area(xy, simplices):
    a, b, c = (xy[simplices[:, k]] for k in range(3))
    return 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]).sum()


def _holds(tin, simplex, xy):
    """Each position lies in (or on the edge of) its triangle."""
    return barycentric(tin, simplex, xy).min(axis=1) > -1e-9


def _grow(points, rounds, free_xy, rng):
    """Start from the box and two thirds of the points, add the rest in ``rounds`` batches.
    Returns the TIN, the triangles of ``free_xy`` and how many batches were added locally."""
    first = 2 * len(points) // 3
    tin = GroundTin.build(np.vstack([BOX, points[:first]]))
    simplex = tin.locate(free_xy)
    rest = points[first:]
    local = 0
    for batch in np.array_split(rng.permutation(len(rest)), rounds):
        new = rest[batch]
        tin, simplex = tin.insert(new, tin_locate(tin, new[:, :2]), free_xy, simplex)
        local += tin.tin is None
    return tin, simplex, local


def tin_locate(tin, xy):
    """Triangle of each position, by brute force (the TIN may not be freshly built)."""
    b = np.stack([barycentric(tin, np.full(len(xy), s), xy).min(axis=1) for s in range(len(tin.simplices))], 1)
    return b.argmax(axis=1)


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), rounds=st.integers(1, 10))
def test_inserting_gives_the_delaunay_triangulation_of_all_points(seed, rounds):
    rng = np.random.default_rng(seed)
    points = np.column_stack([rng.uniform(0, 100, (300, 2)), rng.normal(0, 1, 300)])
    free_xy = rng.uniform(0, 100, (200, 2))
    tin, simplex, local = _grow(points, rounds, free_xy, rng)
    if rounds >= 6:  # small batches: re-triangulated where they land (large ones are rebuilt whole)
        assert local >= rounds // 2
    whole = Delaunay(np.vstack([BOX, points])[:, :2])
    # The same triangles (vertex positions compared, as the TIN numbers vertices in insertion order).
    ours = {tuple(sorted(map(tuple, np.round(tin.points[s, :2], 9)))) for s in tin.simplices}
    theirs = {tuple(sorted(map(tuple, np.round(whole.points[s], 9)))) for s in whole.simplices}
    assert ours == theirs
    assert _holds(tin, simplex, free_xy).all()


@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_points_on_a_grid_and_repeated_returns_still_make_a_valid_tin(jitter):
    # A grid is all co-circular quadruples (where the cavity cannot be trusted the TIN is rebuilt
    # whole), and a second return on the spot of a vertex cannot be a vertex too: the result must
    # still tile the box, with every position in its triangle and no spot used twice.
    rng = np.random.default_rng(3)
    g = np.stack(np.meshgrid(np.arange(0, 100, 5.0), np.arange(0, 100, 5.0)), -1).reshape(-1, 2)
    g = g + rng.uniform(-jitter, jitter, g.shape)
    points = np.column_stack([g, rng.normal(0, 1, len(g))])
    points = np.vstack([points, points[rng.choice(len(points), 40, replace=False)] + [0, 0, 0.5]])
    free_xy = np.vstack([rng.uniform(0, 95, (150, 2)), g[:30]])
    tin, simplex, local = _grow(points, 4, free_xy, rng)
    assert local >= (1 if jitter else 0)
    assert np.isclose(_area(tin.points[:, :2], tin.simplices), 120.0 * 120.0)
    assert _holds(tin, simplex, free_xy).all()
    used = np.unique(tin.simplices)
    assert len(np.unique(np.round(tin.points[used, :2], 9), axis=0)) == len(used)


def test_closed_form_transforms_match_scipys():
    """The numpy transforms give the barycentrics scipy's LAPACK-based ones give."""
    from scipy.spatial import Delaunay

    from tdb.tin import transforms, triangulate

    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 100, (400, 2)) + np.array([500_000.0, 5_400_000.0])
    tin = triangulate(xy)
    scipy_tri = Delaunay(xy - tin.origin)
    assert np.array_equal(scipy_tri.simplices, tin.simplices)
    np.testing.assert_allclose(
        transforms(xy - tin.origin, tin.simplices), scipy_tri.transform, rtol=1e-9, atol=1e-9
    )
    lam = barycentric(tin, np.arange(len(tin.simplices)), xy[tin.simplices].mean(axis=1))
    np.testing.assert_allclose(lam, 1 / 3, atol=1e-9)
