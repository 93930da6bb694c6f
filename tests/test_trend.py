"""A ridge built by people keeps its height along its line; a natural spur rises as it widens
downstream (max_trend, :func:`queries.profile.height_trend`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import make_scene, sample
from ingest.synth.forms import Feature
from queries.filters import Match
from queries.match import find, resolve
from queries.profile import Stretch, height_trend
from queries.run import run


def _pieces(heights, *, length: float = 20.0, parts=None) -> list[Stretch]:
    parts = parts or [0] * len(heights)
    return [
        Stretch(shapely.LineString([(k * length, 0), ((k + 1) * length, 0)]), p, float(h), 4.0)
        for k, (h, p) in enumerate(zip(heights, parts))
    ]


@settings(max_examples=50, deadline=None)
@given(
    start=st.floats(0.3, 2.0),
    change=st.floats(-0.5, 0.5),
    count=st.integers(3, 12),
    length=st.floats(10.0, 30.0),
)
def test_a_steady_rise_reads_as_its_share_of_the_height(start, change, count, length):
    heights = start + change * start * np.linspace(0, 1, count)
    expected = abs(change) * start / float(np.median(heights))
    assert np.isclose(height_trend(_pieces(heights, length=length)), expected, rtol=1e-9, atol=1e-12)


def test_one_odd_piece_does_not_make_a_trend_and_too_little_reads_none():
    assert height_trend(_pieces([0.78, 1.15, 1.15, 1.15, 1.15])) == 0.0  # a junction's short piece
    assert np.isnan(height_trend(_pieces([1.0, 1.2])))
    assert np.isnan(height_trend(_pieces([1.0, np.nan, 1.2])))
    assert np.isnan(height_trend(_pieces([1.0, 0.01, 1.2])))  # a fit that found no form does not count


def test_a_line_broken_at_junctions_is_read_along_its_main_axis():
    """A spur with stubs beside it is matched as several parts: they are read as one line."""
    assert np.isclose(height_trend(_pieces([1.0, 1.1, 1.2, 1.3], parts=[0, 0, 1, 2])), 0.3 / 1.15)
    # branches leaving the line sideways, of the same section, read no trend
    arm = Stretch(shapely.LineString([(30, 0), (30, 20)]), 3, 1.0, 4.0)
    assert height_trend([*_pieces([1.0, 1.0, 1.0], parts=[0, 1, 2]), arm]) == 0.0


BASE_SEED = 3


def _across(y: float) -> shapely.LineString:
    """A line 130 m long across the 160 m test scene, ``y`` m from its south edge."""
    x0, y0 = make_scene(seed=BASE_SEED, size=160).bounds[:2]
    return shapely.LineString([(x0 + 15, y0 + y), (x0 + 145, y0 + y + 6)])


def _surveyed(path, *features: Feature):
    """A database holding the 160 m test scene with only ``features`` on it, as version "v"."""
    scene = replace(make_scene(seed=BASE_SEED, size=160), features=features, buildings=(), trees=())
    db = tdb.open(path, create=True)
    ingest(sample(scene, density=4, seed=BASE_SEED), db, version="v", options=IngestOptions(exclude=()))
    return db


@dataclass(frozen=True)
class _Line:
    geometry: shapely.Geometry


def _found_near(matches, feature: Feature, *, within: float = 3.0) -> float:
    """The length of ``matches`` within ``within`` m of ``feature``'s line, over that line's length."""
    found = shapely.union_all([m.geometry for m in matches])
    return float(found.intersection(feature.geometry.buffer(within)).length / feature.geometry.length)


@pytest.mark.slow
def test_the_ridge_filter_keeps_a_ridge_and_drops_a_spur_that_rises_as_it_widens(tmp_path):
    ridge = Feature("ridge", _across(40), 0.8, 4.0, "U", 0)
    # the rugged scenes' smallest spur: 0.4 m high and 4.5 m wide at its head, 1.2 m and 13 m at its foot
    spur = Feature("spur", _across(110), 0.45, 4.5, "natural", 1, end_size=1.25, end_width=12.5)
    db = _surveyed(tmp_path / "t.tdb", ridge, spur)
    flt = resolve("ridge")
    assert flt.max_trend is not None
    matches = find(db, "v", flt)
    assert _found_near(matches, ridge) > 0.8
    assert _found_near(matches, spur) < 0.1
    # the trend alone drops it (its widest stretch is wider than a ridge, too: max_width)
    assert _found_near(find(db, "v", replace(flt, max_width=None)), spur) < 0.1
    # without the tests the spur is taken for a ridge: they are what parts them
    assert _found_near(find(db, "v", replace(flt, max_trend=None, max_width=None)), spur) > 0.3


@pytest.mark.slow
def test_a_spur_wider_than_the_usual_band_is_read_again_with_a_wider_one(tmp_path, monkeypatch):
    """A spur that widens from 5 to 14 m as it rises from 0.4 to 1.2 m: fits 6 m wide read its top
    alone, about as high all along (a trend of 0.28); fits twice as wide see it grow (0.6)."""
    import queries.match

    spur = Feature("spur", _across(80), 0.4, 5.0, "natural", 1, end_size=1.2, end_width=14.0)
    db = _surveyed(tmp_path / "t.tdb", spur)
    assert _found_near(find(db, "v", "ridge"), spur) < 0.1
    monkeypatch.setattr(queries.match, "WIDE", 1)  # the usual band alone
    assert _found_near(find(db, "v", "ridge"), spur) > 0.3


@pytest.mark.slow
def test_the_ridge_filter_drops_a_crest_wider_than_a_ridge(tmp_path):
    """A broad natural rise 0.9 m high and 9 m wide that keeps its size along its line: no trend
    parts it from a ridge, but the usual 6 m cross-sections cannot see its feet, and ones twice as
    wide find them farther apart than a ridge's (max_width). A spur's stretch, a field edge whose
    terrace falls back behind its bank, read so."""
    ridge = Feature("ridge", _across(40), 0.8, 4.0, "U", 0)
    rise = Feature("spur", _across(105), 0.9, 9.0, "natural", 1)
    db = _surveyed(tmp_path / "t.tdb", ridge, rise)
    flt = resolve("ridge")
    assert flt.max_width is not None
    matches = find(db, "v", flt)
    assert _found_near(matches, ridge, within=4.0) > 0.8
    assert _found_near(matches, rise, within=4.0) < 0.1
    # without the width test the rise is taken for a ridge: the test is what parts them
    assert _found_near(find(db, "v", replace(flt, max_width=None)), rise, within=4.0) > 0.5


def _line(coords) -> Match:
    g = shapely.LineString(coords)
    return Match("ridge", 2, np.zeros(0, np.intp), g, g.length, 0.5)


def test_a_line_mostly_on_a_mound_is_its_crest():
    from queries.match import on_forms

    top = shapely.box(-1, -1, 1, 1)  # a mound's top tile; its relief read 4 m off
    crest = _line([(-4, 0), (4, 0)])  # all of it within the reach
    end = _line([(1, 0), (7, 0)])  # two-thirds of it within the reach
    beside = _line([(-4, 6), (4, 6)])
    over = _line([(-30, 1), (30, 1)])  # a long line passing over it: a sixth on it

    def kept(lines, mounds, most):
        crest = on_forms([m.geometry for m in lines], mounds, most, reach=4.0)
        return [m.geometry for m, on in zip(lines, crest) if not on]

    assert kept([crest, end, beside, over], [top], 0.5) == [beside.geometry, over.geometry]
    assert kept([crest, end, beside, over], [top], 0.7) == [end.geometry, beside.geometry, over.geometry]
    assert kept([crest, over], [], 0.5) == [crest.geometry, over.geometry]
    assert kept([crest, over], [top], 0.1) == []


def test_a_line_mostly_by_a_deeper_ditch_is_its_lip():
    from queries.match import on_forms

    ditch = shapely.LineString([(-50, 0), (50, 0)])
    lip = _line([(-40, 3), (40, 3)])  # 0.5 m high, all of it within the reach
    dike = _line([(-40, -3), (40, -3)])  # 1.0 m high
    lines = [lip, dike]

    def by(depth, ratio):
        least = ratio * np.array([0.5, 1.0])
        return on_forms([m.geometry for m in lines], [ditch], 0.5, reach=4.0, sizes=(np.array([depth]), least))

    assert by(0.8, 1.25).tolist() == [True, False]  # deeper than the lip is high, not than the dike
    assert by(1.5, 1.25).tolist() == [True, True]
    assert by(0.6, 1.25).tolist() == [False, False]
    assert by(np.nan, 1.0).tolist() == [False, False]  # a ditch whose depth was not read does not count


@pytest.mark.slow
def test_a_query_on_widths_drops_a_trough_wider_than_a_ditch(tmp_path):
    """A broad natural trough 1.2 m deep and 8 m wide that keeps its size along its line: the
    usual 6 m cross-sections cannot see its banks, and ones twice as wide find them farther apart
    than a ditch's (max_width). The ditch filter fits no cross-sections to match, so the bound is
    read where a query asks for widths."""
    ditch = Feature("ditch", _across(40), 0.8, 3.0, "U", 0)
    trough = Feature("valley", _across(105), 1.2, 8.0, "natural", 1)
    db = _surveyed(tmp_path / "t.tdb", ditch, trough)
    assert resolve("ditch").max_width == 6.0
    assert _found_near(find(db, "v", "ditch"), trough, within=4.0) > 0.3
    found = run(db, "SELECT ditch FROM v WHERE width >= 1.5")
    sized = [_Line(shapely.geometry.shape(f["geometry"])) for f in found]
    assert _found_near(sized, ditch, within=4.0) > 0.8
    assert _found_near(sized, trough, within=4.0) < 0.1


def _lips(db, matches):
    """The matches longer than 50 m half or more of which lies within 4 m of a ditch match."""
    near = shapely.union_all([d.geometry for d in find(db, "v", "ditch")]).buffer(4.0)
    return [m for m in matches if m.geometry.intersection(near).length >= 0.5 * m.length and m.length > 50]


@pytest.mark.slow
def test_the_ridge_filter_drops_the_lip_of_a_ditch_along_a_brink(tmp_path):
    """A ditch 1.2 m deep dug along the brink of a 1.5 m step: the strip between them stands above
    the ditch and the step's foot alike, a crest whose relief on one side is the ditch's."""
    brink = _across(50)
    step = Feature("edge", brink, 1.5, 6.0, "V", 0, terrace=1000.0)
    ditch = Feature("ditch", shapely.affinity.translate(brink, 0, 5.0), 1.2, 3.7, "U", 1)
    db = _surveyed(tmp_path / "t.tdb", step, ditch)
    flt = resolve("ridge")
    assert flt.max_by_ditches == 0.5
    assert _found_near(find(db, "v", "ditch"), ditch) > 0.8
    assert _lips(db, find(db, "v", replace(flt, max_by_ditches=None)))  # the lip is read as a ridge
    assert not _lips(db, find(db, "v", flt))


@pytest.mark.slow
def test_the_ridge_filter_keeps_a_dike_with_a_shallower_ditch_at_its_foot(tmp_path):
    dike = Feature("ridge", _across(80), 1.2, 5.0, "U", 0)
    foot = Feature("ditch", shapely.affinity.translate(dike.geometry, 0, 4.0), 0.6, 2.5, "V", 1)
    db = _surveyed(tmp_path / "t.tdb", dike, foot)
    assert _found_near(find(db, "v", "ditch"), foot) > 0.8
    matches = find(db, "v", "ridge")
    assert _found_near(matches, dike) > 0.8
    assert _lips(db, matches)  # it lies by the ditch, yet stands higher than the ditch is deep
    # a ratio that lets the shallower ditch count drops it: the depth test is what keeps it
    assert _found_near(find(db, "v", replace(resolve("ridge"), ditch_ratio=0.2)), dike) < 0.2


@pytest.mark.slow
def test_the_ridge_filter_keeps_a_ridge_over_a_knoll_beside_a_mound(tmp_path):
    ridge = Feature("ridge", _across(40), 0.8, 4.0, "U", 0)
    knoll = Feature("mound", ridge.geometry.interpolate(0.5, normalized=True), 2.0, 10.0, "U", 1)
    x, y = _across(110).coords[0]
    mound = Feature("mound", shapely.Point(x + 60, y + 3), 1.8, 8.0, "U", 2)
    db = _surveyed(tmp_path / "t.tdb", ridge, knoll, mound)
    flt = resolve("ridge")
    assert flt.max_on_mounds == 0.5
    matches = find(db, "v", flt)
    assert _found_near(matches, ridge) > 0.8  # a sixteenth of it on the knoll
    mounds = shapely.union_all([m.geometry for m in find(db, "v", "mound")]).buffer(4.0)
    assert not any(m.geometry.intersection(mounds).length >= 0.5 * m.geometry.length for m in matches)
    # a bound a long ridge over a knoll does not pass either
    assert _found_near(find(db, "v", replace(flt, max_on_mounds=0.02)), ridge) < 0.8
