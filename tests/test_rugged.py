"""Rugged synthetic scenes: the look-alikes of real terrain, with exact truth."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from ingest.synth import ground_height, make_scene, scene_truth
from ingest.synth.forms import Feature
from ingest.synth.surface import feature_offset
from tdb.errors import OptionError

LOOK_ALIKES = {"valley", "spur", "road", "edge"}


@pytest.fixture(scope="module")
def rugged():
    return make_scene(seed=3, size=400, terrain="rugged")


def test_rugged_scene_holds_every_look_alike(rugged):
    kinds = {f.kind for f in rugged.features}
    assert LOOK_ALIKES <= kinds
    assert {"ditch", "ridge", "wall", "pit", "mound", "embankment"} <= kinds
    assert not LOOK_ALIKES & {f.kind for f in make_scene(seed=3, size=400).features}
    ditches = [f for f in rugged.features if f.kind == "ditch"]
    assert all(0.5 <= f.size <= 1.4 and 1.8 <= f.width <= 4.0 for f in ditches if f.joined_to is not None)


def test_plain_scene_is_unchanged_by_the_terrain_option():
    assert scene_truth(make_scene(seed=4, size=200)) == scene_truth(make_scene(seed=4, size=200, terrain="plain"))
    with pytest.raises(OptionError):
        make_scene(seed=4, size=200, terrain="alpine")


def _depth_along(feature: Feature, share: float) -> float:
    p = feature.geometry.interpolate(share, normalized=True)
    return float(-feature_offset(feature, np.array([p.x]), np.array([p.y]))[0])


def _width_along(feature: Feature, share: float) -> float:
    """Full width where the feature's offset is at least a tenth of its depth on the axis."""
    line = feature.geometry
    p = line.interpolate(share, normalized=True)
    q = line.interpolate(min(share + 0.01, 1.0), normalized=True)
    nx, ny = -(q.y - p.y), q.x - p.x
    norm = np.hypot(nx, ny)
    s = np.linspace(-30, 30, 1201)
    off = np.abs(feature_offset(feature, p.x + s * nx / norm, p.y + s * ny / norm))
    inside = s[off >= 0.1 * off.max()]
    return float(inside.max() - inside.min())


def test_valleys_widen_and_deepen_downstream(rugged):
    valleys = [f for f in rugged.features if f.kind == "valley"]
    assert valleys
    for v in valleys:
        assert _depth_along(v, 0.8) > _depth_along(v, 0.3) > 0
        assert _width_along(v, 0.8) > 1.3 * _width_along(v, 0.3)


def test_fading_ditches_fade_to_nothing(rugged):
    fading = [f for f in rugged.features if f.kind == "ditch" and f.end_size == 0.0]
    assert fading
    for f in fading:
        assert _depth_along(f, 0.05) > 0.9 * f.size
        assert _depth_along(f, 0.98) < 0.05 * f.size + 1e-9


def test_field_edge_is_a_bank_to_a_terrace():
    line = shapely.LineString([(0, 0), (100, 0)])
    edge = Feature("edge", line, 0.8, 4.0, profile="bank", terrace=20.0)
    y = np.array([-10.0, -2.0, 0.0, 2.0, 12.0, 22.0, 40.0])
    z = feature_offset(edge, np.full(y.shape, 50.0), y)
    np.testing.assert_allclose(z, [0, 0, 0.4, 0.8, 0.4, 0, 0], atol=1e-9)
    beyond = feature_offset(edge, np.array([105.0, 115.0]), np.array([2.0, 2.0]))
    np.testing.assert_allclose(beyond, [0.4, 0.0], atol=1e-9)


def test_roads_raise_their_bed_and_some_ditches_lie_under_canopy(rugged):
    road = next(f for f in rugged.features if f.kind == "road")
    mid = road.geometry.interpolate(0.5, normalized=True)
    assert feature_offset(road, np.array([mid.x]), np.array([mid.y]))[0] == pytest.approx(road.size)
    ditches = shapely.union_all([f.footprint() for f in rugged.features if f.kind == "ditch"])
    crowns = [shapely.Point(t.x, t.y).buffer(t.crown_radius) for t in rugged.trees]
    assert sum(c.intersects(ditches) for c in crowns) >= 5


def test_truth_names_how_a_tapering_line_ends(rugged):
    props = [f["properties"] for f in scene_truth(rugged)["features"]]
    valleys = [p for p in props if p["kind"] == "valley"]
    assert valleys and all(p["end_depth"] > p["depth"] and p["end_width"] > p["width"] for p in valleys)
    assert any(p["kind"] == "ditch" and p.get("end_depth") == 0.0 for p in props)
    assert any(p["kind"] == "edge" and p["terrace"] > 0 for p in props)
    # the bare earth stays finite everywhere
    x0, y0, x1, y1 = rugged.bounds
    gx, gy = np.meshgrid(np.linspace(x0, x1, 50), np.linspace(y0, y1, 50))
    assert np.isfinite(ground_height(rugged, gx.ravel(), gy.ravel())).all()
