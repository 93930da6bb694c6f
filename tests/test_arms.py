"""Lines that meet: a group of touching tiles split into the arms of its junctions."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import make_scene, sample
from ingest.synth.forms import Feature
from queries import match
from queries.centreline import branches

LINK, REACH = 8.0, 20.0


def _arms(x, y):
    return sorted(len(b) for b in branches(np.asarray(x, float), np.asarray(y, float), link=LINK, reach=REACH))


def test_a_cross_is_four_arms_and_a_tee_three():
    t = np.arange(-40.0, 41.0, 2.0)
    # The crossing point is given once per line: each arm holds both and its own 20 points.
    assert _arms(np.r_[t, 0 * t], np.r_[0 * t, t]) == [22, 22, 22, 22]
    stem = np.arange(2.0, 42.0, 2.0)
    assert _arms(np.r_[t, 0 * stem], np.r_[0 * t, stem]) == [21, 21, 21]


def test_lines_farther_apart_than_the_link_are_two():
    t = np.arange(0.0, 60.0, 2.0)
    # Two lines 10 m apart (tiles that touch within a gap can hold nodes that far apart); a
    # fragment shorter than the reach beside them is left out.
    x, y = np.r_[t, t, 100.0, 102.0], np.r_[0 * t, 0 * t + 10.0, 0.0, 0.0]
    assert _arms(x, y) == [30, 30]


@pytest.mark.parametrize("between", [50.0, 60.0, 80.0])
def test_a_line_turning_back_at_an_acute_corner_is_two(between):
    # Two legs 40 m long from one corner, their headings ``between`` degrees apart: the line
    # turns through more than a right angle there (BEND), as where one ditch runs on into
    # another. The points nearest the corner, whose own arms bend as well, may go to neither.
    t = np.arange(2.0, 42.0, 2.0)
    a = np.radians(between)
    x, y = np.r_[0.0, t, t * np.cos(a)], np.r_[0.0, 0 * t, t * np.sin(a)]
    arms = _arms(x, y)
    assert len(arms) == 2 and min(arms) >= 15


@pytest.mark.parametrize("between", [100.0, 135.0, 180.0])
def test_a_line_turning_a_right_angle_or_less_is_one(between):
    t = np.arange(2.0, 42.0, 2.0)
    a = np.radians(between)
    x, y = np.r_[0.0, t, t * np.cos(a)], np.r_[0.0, 0 * t, t * np.sin(a)]
    assert _arms(x, y) == [41]


@settings(max_examples=30, deadline=None)
@given(st.floats(0, np.pi), st.floats(0.0, 0.02), st.floats(40.0, 150.0), st.floats(0.5, 9.0))
def test_one_line_is_never_split(angle, curvature, length, spur):
    # A line (straight or bent into an arc), two tiles wide, with a short spur at its middle.
    s = np.arange(0.0, length, 2.0)
    u, v = s, curvature * (s - length / 2) ** 2
    u, v = np.r_[u, u], np.r_[v, v + 2.0]
    stub = np.arange(2.0, spur + 1e-9, 2.0)
    u, v = np.r_[u, np.full(len(stub), s[len(s) // 2])], np.r_[v, v[len(s) // 2] + 2.0 + stub]
    c, d = np.cos(angle), np.sin(angle)
    x, y = c * u - d * v, d * u + c * v
    assert _arms(x, y) == [len(x)]


@pytest.mark.slow
def test_ridges_that_cross_are_both_found(tmp_path, monkeypatch):
    base = make_scene(seed=2, size=160)
    x0, y0 = base.bounds[:2]
    one = shapely.LineString([(x0 + 25, y0 + 30), (x0 + 135, y0 + 130)])
    two = shapely.LineString([(x0 + 25, y0 + 130), (x0 + 135, y0 + 30)])
    features = (Feature("ridge", one, 1.0, 4.0, "U", 0), Feature("ridge", two, 1.0, 4.0, "U", 1))
    scene = replace(base, features=features, buildings=(), trees=())
    db = tdb.open(tmp_path / "x.tdb", create=True)
    ingest(sample(scene, density=4, seed=2), db, version="v", options=IngestOptions(exclude=()))

    def found(matches, line):
        got = shapely.union_all([m.geometry for m in matches])
        return got.intersection(line.buffer(3.0)).length / line.length

    matches = match.find(db, "v", "ridge")
    assert min(found(matches, one), found(matches, two)) > 0.8
    # The cross as one object is not elongated: without its arms, neither ridge is found.
    monkeypatch.setattr(match._Candidates, "arms", lambda self, g, flt, *, level: [])
    unsplit = match.find(db, "v", "ridge")
    assert max(found(unsplit, one), found(unsplit, two)) < 0.5
