"""Crown diameters: from the area of a crown standing alone, from the free edge of crowns that meet."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.objects.crown_size import UNDER_BASE, crown_diameters, under_base


def _disks(centres: list[tuple[float, float]], radius: float, size: int = 80) -> np.ndarray:
    """Labels of disks of ``radius`` cells: each cell to the nearest centre whose disk holds it."""
    j, i = np.mgrid[0:size, 0:size] + 0.5
    d = np.stack([np.hypot(i - cx, j - cy) for cx, cy in centres])
    nearest = d.argmin(axis=0)
    return np.where(d.min(axis=0) <= radius, nearest, -1)


def test_a_crown_alone_has_the_diameter_of_its_area():
    labels = _disks([(30.3, 30.7)], 6.0)
    cells = (labels == 0).sum()
    np.testing.assert_allclose(crown_diameters(labels, 0.5), [2 * np.sqrt(cells / np.pi) * 0.5])


def _pair(radius: float, apart: float, angle: float, offset: float) -> np.ndarray:
    cx, cy = 40 + offset, 40 - offset
    return _disks([(cx, cy), (cx + apart * radius * np.cos(angle), cy + apart * radius * np.sin(angle))], radius)


@settings(max_examples=40, deadline=None)
@given(
    radius=st.floats(4.0, 9.0),
    apart=st.floats(1.1, 1.8),
    angle=st.floats(0, 2 * np.pi),
    offset=st.floats(0, 1),
)
def test_crowns_that_meet_keep_their_own_diameter(radius, apart, angle, offset):
    """Two crowns of 4-9 cells' radius overlapping by up to 0.9 of it: each reads its diameter
    within half a cell's diagonal, how far a digitised edge can stand from the true one (a disc
    of radius 5.7 cells centred on a cell corner reads 0.68 of a cell wide)."""
    found = crown_diameters(_pair(radius, apart, angle, offset), 1.0)
    assert np.all(np.abs(found - 2 * radius) <= np.sqrt(0.5))


def test_the_free_edge_reads_crowns_that_meet_better_than_their_area():
    """A segment's area misses the part of its crown the other covers."""
    rng = np.random.default_rng(5)
    edge, area = [], []
    for _ in range(40):
        radius = rng.uniform(4, 9)
        labels = _pair(radius, rng.uniform(1.1, 1.4), rng.uniform(0, 2 * np.pi), rng.uniform(0, 1))
        edge.extend(crown_diameters(labels, 1.0) - 2 * radius)
        area.extend(2 * np.sqrt(np.bincount(labels[labels >= 0]) / np.pi) - 2 * radius)
    assert np.sqrt(np.mean(np.square(edge))) < 0.5 * np.sqrt(np.mean(np.square(area)))
    assert np.mean(area) < -0.5 < 0.0 < np.mean(edge) + 0.3


def test_a_crown_hemmed_in_by_others_keeps_its_area():
    """Its free edge runs less than half way round: no circle is fitted to it."""
    centre = (40.2, 40.6)
    ring = [(40.2 + 9 * np.cos(a), 40.6 + 9 * np.sin(a)) for a in np.linspace(0, 2 * np.pi, 7)[:-1]]
    labels = _disks([centre, *ring], 6.0)
    cells = (labels == 0).sum()
    assert crown_diameters(labels, 1.0)[0] == 2 * np.sqrt(cells / np.pi)


def test_no_crowns():
    assert len(crown_diameters(np.full((5, 5), -1), 1.0)) == 0


def _domes(trees: list[tuple[float, float, float, float]], size: int = 80) -> np.ndarray:
    """Canopy heights of crowns (x, y, radius in cells, height), each reaching down to 0.4 of its
    height at its rim; the highest crown over each cell shows."""
    j, i = np.mgrid[0:size, 0:size] + 0.5
    canopy = np.full((size, size), np.nan)
    for cx, cy, r, h in trees:
        u = np.hypot(i - cx, j - cy) / r
        canopy = np.fmax(canopy, np.where(u <= 1, h * (1 - 0.6 * u**2), np.nan))
    return canopy


def test_a_lower_crown_captured_by_a_taller_one_leaves_its_diameter_as_it_was():
    """One segment holds a tall crown and the lower one beside it (the climb led up the tall
    crown's flank): by area it reads far too wide. Under a base of 0.35 of the top the lower
    crown is canopy of no measured crown, and the tall one reads its own diameter."""
    radius = 6.0
    canopy = _domes([(30.3, 30.6, radius, 20.0), (40.5, 31.0, 7.0, 6.0)])
    captured = np.where(np.isfinite(canopy), 0, -1)
    wide = crown_diameters(captured, 1.0)[0]
    cut = under_base(captured, canopy, 0.35)
    assert wide > 2 * radius + 3
    assert (cut == UNDER_BASE).sum() > 50
    assert abs(crown_diameters(cut, 1.0)[0] - 2 * radius) <= np.sqrt(0.5)


@settings(max_examples=40, deadline=None)
@given(share=st.floats(0.05, 0.95), seed=st.integers(0, 10_000))
def test_a_crown_base_only_takes_cells_below_it_and_never_a_top(share, seed):
    rng = np.random.default_rng(seed)
    canopy = rng.uniform(-3, 30, (12, 14))
    labels = rng.integers(-1, 4, canopy.shape)
    cut = under_base(labels, canopy, share)
    assert np.array_equal(under_base(labels, canopy, None), labels)
    assert np.array_equal(cut == labels, cut != UNDER_BASE)
    for k in np.unique(labels[labels >= 0]):
        top = canopy[labels == k].max()
        below = (canopy[labels == k] < share * top) & (canopy[labels == k] < top)
        assert np.array_equal(cut[labels == k] == UNDER_BASE, below)
        assert (cut[labels == k] == k).any()


def test_a_crown_beside_captured_cells_is_read_by_its_free_edge():
    """A tall crown's segment took the near part of a lower crown; under its base that part is
    canopy of no measured crown, not ground: the lower crown still meets a crown there and
    reads its diameter from its free edge, not from the area it kept."""
    canopy = _domes([(30.3, 30.6, 6.0, 20.0), (41.5, 31.0, 7.0, 6.0)])
    j, i = np.mgrid[0:80, 0:80] + 0.5
    near_tall = np.hypot(i - 30.3, j - 30.6) <= 9.0
    labels = np.where(np.isfinite(canopy), np.where(near_tall, 0, 1), -1)
    cut = under_base(labels, canopy, 0.35)
    kept = (cut == 1).sum()
    found = crown_diameters(cut, 1.0)[1]
    assert found > 2 * np.sqrt(kept / np.pi) + 1
    assert abs(found - 14.0) <= 1.0
