"""A ditch's banks lie within the reach of its line; a natural valley widens beyond (max_spread); a
ditch lies below the land beyond its sides too (min_spread)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import shapely

import tdb
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import make_scene, sample
from ingest.synth.forms import Feature
from ingest.synth.scene import Relief
from queries.match import find, resolve

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def hollows(tmp_path_factory):
    """A 160 m scene holding a ditch and a ridge, each beside a natural valley or spur about as deep
    (high) but three to five times as wide, and nothing else."""
    base = make_scene(seed=2, size=160)
    x0, y0 = base.bounds[:2]

    def line(y: float) -> shapely.LineString:
        return shapely.LineString([(x0 + 20, y0 + y), (x0 + 110, y0 + y + 8)])

    features = (
        Feature("ditch", line(20), 0.8, 3.0, "V", 0),
        Feature("valley", line(55), 0.8, 16.0, "natural", 1),
        Feature("ridge", line(95), 0.8, 4.0, "U", 2),
        Feature("spur", line(130), 1.0, 16.0, "natural", 3),
    )
    scene = replace(base, features=features, buildings=(), trees=())
    db = tdb.open(tmp_path_factory.mktemp("spread") / "s.tdb", create=True)
    ingest(sample(scene, density=4, seed=2), db, version="v", options=IngestOptions(exclude=()))
    return scene, db


def _found_near(matches, feature: Feature) -> float:
    found = shapely.union_all([m.geometry for m in matches])
    return float(found.intersection(feature.geometry.buffer(3.0)).length / feature.geometry.length)


@pytest.mark.parametrize(("kind", "form", "look_alike"), [("ditch", 0, 1), ("ridge", 2, 3)])
def test_the_filter_keeps_the_narrow_form_and_drops_the_wide_one(hollows, kind, form, look_alike):
    scene, db = hollows
    flt = resolve(kind)  # the built-in filter, with its own bound
    assert flt.max_spread is not None
    matches = find(db, "v", flt)
    assert _found_near(matches, scene.features[form]) > 0.8
    assert _found_near(matches, scene.features[look_alike]) < 0.1
    # without the test, the wide form is taken for the narrow one: the test is what parts them
    unbounded = find(db, "v", replace(flt, max_spread=None))
    assert _found_near(unbounded, scene.features[look_alike]) > 0.3
    assert np.isclose(_found_near(unbounded, scene.features[form]), _found_near(matches, scene.features[form]))


def test_the_trough_at_a_banks_uphill_foot_is_no_ditch(tmp_path):
    # A 1.2 m bank along the contour of a 12 % slope, and a true ditch on the same slope: against
    # the terrain 4 m off, the foot between the bank and the slope above it is a trough; 8 m
    # off, past the bank, the land lies below it.
    base = make_scene(seed=2, size=160)
    x0, y0 = base.bounds[:2]
    k = 2 * np.pi / 1000.0  # one long wave: about a plane rising 12 % across the bank
    relief = Relief(100.0, ((0.12 / k, 0.0, k, -k * (y0 + 80)),), (x0, y0), (1.0, 0.0), 0.0, 1.0)
    bank = Feature("ridge", shapely.LineString([(x0 + 20, y0 + 80), (x0 + 140, y0 + 80)]), 1.2, 4.0, "U", 0)
    ditch = Feature("ditch", shapely.LineString([(x0 + 20, y0 + 125), (x0 + 140, y0 + 125)]), 0.8, 3.0, "V", 1)
    scene = replace(base, relief=relief, features=(bank, ditch), buildings=(), trees=())
    db = tdb.open(tmp_path / "foot.tdb", create=True)
    ingest(sample(scene, density=4, seed=2), db, version="v", options=IngestOptions(exclude=()))
    flt = resolve("ditch")
    assert flt.min_spread is not None
    matches = find(db, "v", flt)
    assert _found_near(matches, ditch) > 0.8
    assert _found_near(matches, bank) < 0.1
    unbounded = find(db, "v", replace(flt, min_spread=None))  # the bound is what drops the foot
    assert _found_near(unbounded, bank) > 0.5


def test_a_ditch_dug_along_a_valley_floor_is_found_and_a_natural_valley_is_not(tmp_path):
    # Land rolling 2 m either way over 80 m across the lines: a ditch 2 m wide and 0.8 m deep
    # along a trough's floor, and a natural valley 16 m wide and 0.8 m deep on the crest beside
    # it. Read twice as far off, the ditch's depth is the trough's too, so the spread bound
    # alone takes it for a valley that widens; its cross-sections read it narrow.
    base = make_scene(seed=2, size=160)
    x0, y0 = base.bounds[:2]
    k = 2 * np.pi / 80.0
    relief = Relief(100.0, ((2.0, 0.0, k, -np.pi / 2 - k * (y0 + 50)),), (x0, y0), (1.0, 0.0), 0.0, 1.0)

    def line(y: float) -> shapely.LineString:
        return shapely.LineString([(x0 + 20, y0 + y - 2), (x0 + 140, y0 + y + 2)])

    ditch = Feature("ditch", line(50), 0.8, 2.0, "V", 0)
    valley = Feature("valley", line(90), 0.8, 16.0, "natural", 1)
    scene = replace(base, relief=relief, features=(ditch, valley), buildings=(), trees=())
    db = tdb.open(tmp_path / "floor.tdb", create=True)
    ingest(sample(scene, density=4, seed=2), db, version="v", options=IngestOptions(exclude=()))
    flt = resolve("ditch")
    assert flt.notch_width is not None and flt.max_spread is not None
    matches = find(db, "v", flt)
    assert _found_near(matches, ditch) > 0.8
    assert _found_near(matches, valley) < 0.1
    assert _found_near(find(db, "v", replace(flt, notch_width=None)), ditch) < 0.2
