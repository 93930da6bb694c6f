"""A roof wider than the openings leaves the ground; a yard among buildings and a terrace stay."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.ground_roofs import roof_scene
from ingest.ground.auto import AutoParams, auto_ground
from ingest.ground.roofs import RoofShape, raised_roofs
from tdb.options import GroundStage

WITHOUT = AutoParams(skip=frozenset({GroundStage.ROOFS}))


def _hall(seed: int, *, density: float, width: float, length: float, height: float, upper: float = 0.0):
    """Points over 250 × 250 m of a tilted plane with a flat-roofed hall in the middle (a part of it
    ``upper`` m higher over its western third)."""
    rng = np.random.default_rng(seed)
    n = int(250 * 250 * density)
    x, y = rng.uniform(0, 250, n), rng.uniform(0, 250, n)
    z = 50 + 0.01 * x + 0.005 * y + rng.normal(0, 0.03, n)
    hall = (np.abs(x - 125) < width / 2) & (np.abs(y - 125) < length / 2)
    z[hall] = 51.9 + height + rng.normal(0, 0.03, hall.sum())
    z[hall & (x < 125 - width / 6)] += upper
    return np.c_[x, y, z], hall


@settings(max_examples=8, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    density=st.sampled_from([0.5, 2.0]),
    width=st.floats(40, 110),
    length=st.floats(40, 110),
    height=st.floats(4, 15),
    upper=st.sampled_from([0.0, 4.0]),
)
def test_a_hall_wider_than_the_openings_is_no_ground(seed, density, width, length, height, upper):
    xyz, hall = _hall(seed, density=density, width=width, length=length, height=height, upper=upper)
    ground = auto_ground(xyz)
    # Its edge too: the ground's cells astride the walls hold roof points a storey over them.
    assert ground[hall].mean() < 0.005
    assert ground[~hall].mean() > 0.995
    # Without the stage the openings leave the middle of the roof, and the passes spread it.
    assert auto_ground(xyz, params=WITHOUT)[hall].mean() > 0.5


def test_a_yard_among_buildings_and_the_ground_beside_a_terrace_stay_ground():
    scene = roof_scene(2, 2.0)
    ground = auto_ground(scene.xyz)
    assert scene.yard.sum() > 100
    assert ground[scene.yard].all()
    assert ground[scene.hall].mean() < 0.02
    # A terrace 4 m high with walls on three sides and the data's edge on the fourth: it may go
    # on beyond the data, so it stays ground.
    rng = np.random.default_rng(5)
    x, y = rng.uniform(0, 200, 40_000), rng.uniform(0, 200, 40_000)
    terrace = (np.abs(x - 100) < 40) & (y > 120)
    xyz = np.c_[x, y, 10 + 4.0 * terrace + rng.normal(0, 0.03, len(x))]
    ground = auto_ground(xyz)
    assert ground[terrace].mean() > 0.98  # its edge's points are the passes' to judge
    assert np.array_equal(ground, auto_ground(xyz, params=WITHOUT))


def test_a_roof_needs_a_drop_of_a_storey_nearly_all_round():
    xyz, hall = _hall(1, density=1.0, width=60, length=70, height=8)
    ground = auto_ground(xyz, params=WITHOUT)
    found = raised_roofs(xyz, ground, cell=1.5)
    assert found[hall].mean() > 0.9
    assert not found[~hall].any()
    # A drop taller than the hall, or walls down on fewer sides than asked, make no roof.
    assert not raised_roofs(xyz, ground, cell=1.5, shape=RoofShape(step=10.0)).any()
    # A ramp up to the roof from the north (a car park's deck): it meets the ground, like a terrace.
    x, y = xyz[:, 0], xyz[:, 1]
    ramp = (np.abs(x - 125) < 30) & (y >= 160) & (y < 224)
    ramped = xyz.copy()
    ramped[ramp, 2] += 8 * (224 - y[ramp]) / 64
    assert not raised_roofs(ramped, auto_ground(ramped, params=WITHOUT), cell=1.5)[hall].any()


def test_the_map_shows_the_roof_that_left_the_ground(tmp_path):
    import matplotlib.image

    from tdb.pictures import ground_change_map

    xyz, hall = _hall(2, density=0.5, width=70, length=60, height=6)
    before, after = auto_ground(xyz, params=WITHOUT), auto_ground(xyz)
    assert (before & ~after)[hall].mean() > 0.5
    ground_change_map(tmp_path / "m.png", xyz[:, :2], before, after, crs=None, title="hall")
    rgb = matplotlib.image.imread(tmp_path / "m.png")[..., :3]
    red = (rgb[..., 0] > 0.7) & (rgb[..., 1] < 0.25) & (rgb[..., 2] < 0.25)
    ground_change_map(tmp_path / "n.png", xyz[:, :2], after, after, crs=None, title="same")
    rgb = matplotlib.image.imread(tmp_path / "n.png")[..., :3]
    legend_only = (rgb[..., 0] > 0.7) & (rgb[..., 1] < 0.25) & (rgb[..., 2] < 0.25)
    # The roof's points, drawn red, outweigh the legend's red patch, all there is where nothing changed.
    assert red.sum() > 5 * legend_only.sum() > 0
