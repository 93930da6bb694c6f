"""Crown diameters: from the area of a crown standing alone, from the free edge of crowns that meet."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.objects.crown_size import crown_diameters


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
