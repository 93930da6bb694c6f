"""Outlines of labelled raster segments: valid polygons, holes and parts, the cells' area."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from tdb.outlines import outlines


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 12), cols=st.integers(1, 12), labels=st.integers(1, 4), seed=st.integers(0, 2**16))
def test_each_label_is_a_valid_shape_of_its_cells(rows, cols, labels, seed):
    rng = np.random.default_rng(seed)
    raster = rng.integers(-1, labels, (rows, cols))
    shapes = outlines(raster, x0=100.0, y0=200.0, cell=0.5)
    assert set(shapes) == set(np.unique(raster[raster >= 0]).tolist())
    for k, shape in shapes.items():
        assert shape.is_valid
        assert shape.area == np.count_nonzero(raster == k) * 0.25
        r, c = np.nonzero(raster == k)
        centres = shapely.points(100.0 + (c + 0.5) * 0.5, 200.0 + (r + 0.5) * 0.5)
        assert shapely.contains(shape, centres).all()


def test_a_ring_has_its_hole_and_cells_meeting_at_a_corner_are_two_parts():
    raster = -np.ones((6, 6), int)
    raster[0:5, 0:5] = 0
    raster[2, 2] = -1  # a hole
    raster[5, 5] = 0  # meets the ring at a corner only
    shape = outlines(raster, x0=0.0, y0=0.0, cell=1.0)[0]
    assert shape.geom_type == "MultiPolygon"
    ring = max(shape.geoms, key=lambda p: p.area)
    assert len(ring.interiors) == 1
    assert shapely.Polygon(ring.interiors[0]).area == 1.0
