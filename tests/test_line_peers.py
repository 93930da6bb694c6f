"""The benchmark's local-relief peer: it finds a trench as a line where the trench runs."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from benchmarks.line_peers import ReliefSetting, relief_lines, skeleton_lines
from tdb.raster import Raster


def _trench(length: int = 50) -> Raster:
    z = np.zeros((60, 80))
    z[29:32, 10 : 10 + length] = -0.6  # 3 m wide, along row 30 (y = 60 − 30.5)
    return Raster(z, 0.0, 60.0, 1.0)


def test_a_trench_is_found_along_its_axis():
    found = relief_lines(_trench(), ReliefSetting(radius=5.0, threshold=0.2, min_length=10.0), kind="ditch")
    axis = shapely.LineString([(10, 29.5), (60, 29.5)])
    assert found.length == pytest.approx(axis.length, rel=0.15)
    assert found.hausdorff_distance(axis) < 2.0
    assert relief_lines(_trench(), ReliefSetting(5.0, 0.2, 10.0), kind="ridge").length < 0.5 * axis.length


def test_short_pieces_are_dropped():
    setting = ReliefSetting(radius=5.0, threshold=0.2, min_length=20.0)
    assert relief_lines(_trench(length=12), setting, kind="ditch").is_empty
    assert not relief_lines(_trench(length=30), setting, kind="ditch").is_empty


def test_skeleton_segments_join_neighbouring_cells_once():
    mask = np.zeros((10, 10), bool)
    mask[np.arange(10), np.arange(10)] = True  # one diagonal line
    lines = skeleton_lines(mask, Raster(np.zeros((10, 10)), 0.0, 10.0, 1.0), min_length=1.0)
    assert lines.length == pytest.approx(9 * np.sqrt(2))
