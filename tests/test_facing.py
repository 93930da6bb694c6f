"""Facing planes: the two banks of a form whose line runs along a tile edge."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.pipeline import ingest
from ingest.synth import make_scene, sample
from ingest.synth.scene import Feature
from queries.facing import facing_planes
from queries.match import find, resolve

EAST, WEST = 3, 7  # plane codes rising to the east, to the west


def test_planes_falling_towards_each_other_face_across_their_edge():
    xg, yg = np.array([0, 2, 6]), np.array([0, 0, 0])
    assert facing_planes(xg, yg, np.array([WEST, EAST, EAST]), level=2).tolist() == [True, True, False]
    assert not facing_planes(xg, yg, np.array([WEST, EAST, EAST]), level=2, falling=False).any()
    crest = facing_planes(xg, yg, np.array([EAST, WEST, EAST]), level=2, falling=False)
    assert crest.tolist() == [True, True, False]
    # a valley tile or a gap between the planes is no pair
    assert not facing_planes(np.array([0, 4]), yg[:2], np.array([WEST, EAST]), level=2).any()
    assert not facing_planes(xg[:2], yg[:2], np.array([WEST, 10]), level=2).any()


def _reversed(code: np.ndarray) -> np.ndarray:
    """Each plane turned round (inclination k → the opposite of the 8 directions)."""
    plane = (code >= 1) & (code <= 8)
    return np.where(plane, (code - 1 + 4) % 8 + 1, code)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 114), min_size=16, max_size=16))
def test_falling_pairs_are_the_rising_pairs_of_the_planes_turned_round(codes):
    code = np.array(codes)
    jj, ii = np.divmod(np.arange(16), 4)
    xg, yg = ii * 4, jj * 4
    falling = facing_planes(xg, yg, code, level=4)
    assert (falling == facing_planes(xg, yg, _reversed(code), level=4, falling=False)).all()
    assert not (falling & ~((code >= 1) & (code <= 8))).any()  # only planes


def test_a_wide_ditch_along_a_tile_edge_is_found(tmp_path):
    base = make_scene(seed=5, size=120)
    x0, y0 = base.bounds[:2]
    assert y0 % 2 == 0
    axis = shapely.LineString([(x0 + 15, y0 + 60), (x0 + 105, y0 + 60)])  # on the edge between tile rows
    scene = replace(base, features=(Feature("ditch", axis, 0.8, 3.6, "V", 0),), buildings=(), trees=())
    db = tdb.open(tmp_path / "e.tdb", create=True)
    ingest(sample(scene, density=4, seed=5), db, version="v")

    def along(flt):
        found = shapely.union_all([m.geometry for m in find(db, "v", flt)])
        return axis.intersection(found.buffer(2.0)).length / axis.length

    assert along(resolve("ditch")) > 0.9
    assert along(replace(resolve("ditch"), facing=False)) < 0.5  # its tiles are planes: no valley in any
