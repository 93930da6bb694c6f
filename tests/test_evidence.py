"""Ground evidence per 2 m tile: what it measures, how it is stored, and how change detection uses it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from sqlalchemy import text

import tdb
from ingest.dtm import dense_model
from ingest.evidence import envelope_lift, layer_window, noise_lift, tile_depth, tile_evidence
from ingest.pipeline import ingest
from queries import changes
from queries.changes import detect
from queries.tile_change import curved_lod, tile_lod
from tdb.cloud import from_arrays
from tdb.evidence import (
    GAP_SLOPE,
    MIN_SUPPORT,
    MISSED,
    SUPPORT_SPACINGS,
    TileEvidence,
    missed_relief,
    supported_change,
)

CRS = "EPSG:25832"


def _ground(size: float = 40.0, density: float = 4.0, *, seed: int = 0, noise: float = 0.02) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = int(size * size * density)
    x, y = rng.uniform(0, size, n), rng.uniform(0, size, n)
    return np.column_stack([x, y, 10 + 0.05 * x + rng.normal(0, noise, n)])


def _surface(g: np.ndarray):
    return dense_model(g, resolution=0.5)


def _tiles(size: float) -> tuple[np.ndarray, np.ndarray]:
    xg, yg = np.meshgrid(np.arange(0, size, 2), np.arange(0, size, 2))
    return xg.ravel().astype(np.int64), yg.ravel().astype(np.int64)


def _inner(xg: np.ndarray, yg: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return (xg >= lo) & (xg + 2 <= hi) & (yg >= lo) & (yg + 2 <= hi)


def test_open_ground_is_seen_everywhere_with_little_lift():
    g = _ground()
    xg, yg = _tiles(40)
    e = tile_evidence(g, xg, yg, spacing=0.5, surface=_surface(g))
    inner = _inner(xg, yg, 4, 36)
    assert (e.support[inner] == 1).all()
    assert (e.gap[inner] == 0).all()
    assert np.median(e.lift[inner]) < 0.06


def test_a_gap_in_the_ground_returns_is_unseen_and_uncertain():
    g = _ground()
    hole = (np.abs(g[:, 0] - 20) < 8) & (np.abs(g[:, 1] - 20) < 8)
    xg, yg = _tiles(40)
    e = tile_evidence(g[~hole], xg, yg, spacing=0.5, surface=_surface(g))
    centre = _inner(xg, yg, 16, 24)
    assert (e.support[centre] == 0).all()
    # the middle of a 16 m hole lies over 4 m from any return
    assert (e.gap[centre] > 4 - SUPPORT_SPACINGS * 0.5).all()
    assert (e.sigma[centre] >= GAP_SLOPE * e.gap[centre] * (1 - 1e-6)).all()
    assert e.supported_share() < 1


def test_low_vegetation_taken_for_ground_lifts_its_tiles():
    rng = np.random.default_rng(11)
    g = _ground(seed=1)
    shrub = (g[:, 0] > 20) & (rng.random(len(g)) < 0.6)
    g[shrub, 2] += rng.uniform(0.4, 1.2, shrub.sum())
    xg, yg = _tiles(40)
    e = tile_evidence(g, xg, yg, spacing=0.5, surface=_surface(g))
    bare, covered = _inner(xg, yg, 4, 16), (xg >= 24) & (xg <= 34) & _inner(xg, yg, 4, 36)
    assert np.median(e.lift[covered]) > 0.3
    assert np.median(e.lift[covered]) > 5 * np.median(e.lift[bare])


@settings(max_examples=15, deadline=None)
@given(st.floats(-0.15, 0.15), st.floats(-0.15, 0.15), st.floats(0, 0.5))
def test_a_smooth_curved_surface_has_no_lift(a, b, slope):
    """A quadratic surface (a bank, a hollow, a dome) is carried along: bare, it lies on its envelope."""
    rng = np.random.default_rng(2)
    x, y = rng.uniform(-8, 8, 1500), rng.uniform(-8, 8, 1500)
    z = a * x * x + b * y * y + slope * x
    assert np.percentile(envelope_lift(np.column_stack([x, y, z])), 95) < 1e-6


def test_evidence_is_stored_per_version_and_read_by_area(tmp_path):
    db = tdb.open(tmp_path / "e.tdb", create=True)
    g = _ground(size=160, density=0.5)
    cloud = from_arrays(g[:, 0] + 1000, g[:, 1] + 2000, g[:, 2], crs=CRS)
    v = ingest(cloud, db, version="a")
    e = db.evidence("a")
    assert len(e) == v.stats.reduction.tiles[2]  # one per 2 m tile
    assert v.stats.seen_pct is not None and v.stats.seen_pct > 90
    assert v.stats.sigma_m is not None and v.stats.sigma_m < 0.1
    assert v.stats.deep_pct is not None and v.stats.deep_pct < 5  # open ground: its surface on its returns
    part = db.evidence("a", bbox=(1100.0, 2100.0, 1110.0, 2110.0))
    assert len(part) == 25
    back = e.at(part.xg, part.yg)
    np.testing.assert_array_equal(back.lift, part.lift)
    np.testing.assert_array_equal(back.support, part.support)
    missing = e.at(np.array([0], np.int64), np.array([0], np.int64))
    assert np.isnan(missing.lift[0]) and missing.support[0] == 0
    db.delete_version("a")
    with db.engine.connect() as conn:
        assert conn.execute(text("SELECT count(*) FROM evidence_blocks")).scalar() == 0


def test_a_version_two_database_is_upgraded_and_its_versions_have_no_evidence(tmp_path):
    path = tmp_path / "old.tdb"
    db = tdb.open(path, create=True)
    g = _ground(size=60, density=1)
    ingest(from_arrays(*g.T, crs=CRS), db, version="a")
    with db.engine.begin() as conn:
        conn.execute(text("DROP TABLE evidence_blocks"))
        conn.execute(text("DROP TABLE coregistrations"))
        conn.execute(text("UPDATE meta SET value = '2' WHERE key = 'schema_version'"))
    db.close()
    db = tdb.open(path)
    assert db.schema_version() == tdb.schema.SCHEMA_VERSION
    assert len(db.evidence("a")) == 0
    ingest(from_arrays(*g.T, crs=CRS), db, version="b")
    assert len(db.evidence("b")) > 0
    # without evidence on one side the other side's still counts, and every tile counts as seen
    xg, yg = _tiles(60)
    judged = tile_lod(db, "a", "b", xg, yg, level=2, lod=0.1)
    assert judged.seen.all() and (judged.lod >= 0.1).all()
    assert (judged.depth[0] == 0).all()


def test_a_change_is_claimed_only_where_both_surveys_saw_the_ground(tmp_path):
    """A platform raised 1 m; the later survey sees its middle through a hole in the returns."""
    db = tdb.open(tmp_path / "c.tdb", create=True)
    before = _ground(size=80, density=2, seed=3)
    after = _ground(size=80, density=2, seed=4)
    raised = (np.abs(after[:, 0] - 40) < 15) & (np.abs(after[:, 1] - 40) < 15)
    after[raised, 2] += 1.0
    hole = (np.abs(after[:, 0] - 40) < 8) & (np.abs(after[:, 1] - 40) < 8)
    ingest(from_arrays(*before.T, crs=CRS), db, version="a")
    ingest(from_arrays(*after[~hole].T, crs=CRS), db, version="b")
    found = detect(db, "a", "b")
    assert found
    import shapely

    area = shapely.union_all([shapely.geometry.shape(f["geometry"]) for f in found])
    assert area.contains(shapely.Point(40, 27))  # seen: the raised rim
    assert not area.contains(shapely.Point(40, 40))  # bridged by the TIN: not claimed
    xg, yg = np.array([38], np.int64), np.array([38], np.int64)
    assert not tile_lod(db, "a", "b", xg, yg, level=2, lod=0.1).seen[0]
    assert db.evidence("b").at(xg, yg).support[0] < MIN_SUPPORT


def test_empty_evidence_has_no_tiles():
    e = TileEvidence.empty()
    assert len(e) == 0 and e.supported_share() == 0.0
    assert len(e.at(np.array([2], np.int64), np.array([4], np.int64))) == 1


@pytest.mark.parametrize("fields", [1, 3])
def test_evidence_blocks_round_trip(fields):
    from tdb.blocks import evidence_blocks, evidence_from_blocks

    rng = np.random.default_rng(5)
    xg = rng.choice(np.arange(-600, 600, 2), 300, replace=False).astype(np.int64)
    yg = rng.choice(np.arange(-600, 600, 2), 300, replace=False).astype(np.int64)
    values = [rng.random(300).astype(np.float32) for _ in range(fields)]
    blobs = list(evidence_blocks(xg, yg, values))
    x, y, back = evidence_from_blocks(blobs, (-1e9, -1e9, 1e9, 1e9), fields=fields)
    order, want = np.lexsort((y, x)), np.lexsort((yg, xg))
    np.testing.assert_array_equal(x[order], xg[want])
    for b, v in zip(back, values):
        np.testing.assert_allclose(b[order], v[want], atol=1e-3)


def _shrubs(
    g: np.ndarray, rng: np.random.Generator, where: np.ndarray, *, share: float = 0.6, heights=(0.4, 1.2)
) -> np.ndarray:
    """Low vegetation's top taken for ground over ``where``: ``share`` of the returns ``heights`` m up."""
    g = g.copy()
    top = where & (rng.random(len(g)) < share)
    g[top, 2] += rng.uniform(*heights, top.sum())
    return g


def test_a_surface_over_ground_seen_through_vegetation_has_depth():
    rng = np.random.default_rng(12)
    g = _shrubs(_ground(seed=1), rng, _ground(seed=1)[:, 0] > 20)
    xg, yg = _tiles(40)
    depth = tile_depth(g, _surface(g), xg, yg)
    bare, covered = _inner(xg, yg, 4, 16), (xg >= 24) & (xg <= 34) & _inner(xg, yg, 4, 36)
    assert np.median(depth[covered]) > 0.2
    assert np.median(depth[bare]) < 0.05
    assert (depth >= 0).all()
    assert tile_depth(g[:0], _surface(g), xg, yg).tolist() == [0.0] * len(xg)


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.floats(-3, 3), min_size=9, max_size=9),
    st.floats(0, 1),
    st.floats(0, 1),
)
def test_the_supported_change_never_exceeds_the_change_nor_turns_its_sign(dz, before, after):
    d = np.array([dz])
    s = supported_change(d, np.array([[before], [after]]))
    assert (np.abs(s) <= np.abs(d) + 1e-12).all()
    assert (s * d >= 0).all()
    rises = d > 0
    np.testing.assert_allclose(s[rises], np.maximum(d[rises] - after, 0))
    np.testing.assert_allclose(s[~rises], np.minimum(d[~rises] + before, 0))


def test_vegetation_taken_for_ground_is_no_rise_but_a_platform_is(tmp_path, monkeypatch):
    """The later survey sees a shrub field as ground beside a platform raised 1 m: the platform is
    reported, the shrubs, whose survey saw the ground through them, are not. Both surveys as
    noisy as TTP 2019's (0.08 m), so the level of detection is a real survey's."""

    from queries import changes, tile_change

    rng = np.random.default_rng(21)
    before = _ground(size=120, density=3, seed=3, noise=0.08)
    after = _ground(size=120, density=3, seed=4, noise=0.08)
    platform = (np.abs(after[:, 0] - 30) < 12) & (np.abs(after[:, 1] - 60) < 12)
    after[platform, 2] += 1.0
    field = (np.abs(after[:, 0] - 90) < 14) & (np.abs(after[:, 1] - 60) < 14)
    after = _shrubs(after, rng, field, share=0.4, heights=(0.3, 0.8))
    db = _two_versions(tmp_path / "s.tdb", before, after)
    # the shrub field is 5 % of the area: the share of tiles standing over their returns grows by it
    deep = (db.version("a").stats.deep_pct, db.version("b").stats.deep_pct)
    assert deep[0] is not None and deep[1] is not None and deep[1] > deep[0] + 3
    boxes = ((18, 48, 42, 72), (76, 46, 104, 74))
    raised, shrubs = _reported_in(db, *boxes)
    assert raised > 0.95 * 24 * 24
    assert shrubs < 0.15 * 28 * 28
    # the case at hand: the filter kept the shrubs' top, and the surfaces alone report them
    monkeypatch.setattr(tile_change, "supported_change", lambda dz, depth: dz)
    monkeypatch.setattr(changes, "_under_a_layer", lambda *_: False)
    uncut = _reported_in(db, *boxes)[1]
    assert uncut > 0.25 * 28 * 28 and uncut > 2 * shrubs


def _two_versions(path, before: np.ndarray, after: np.ndarray):
    """A database holding the ground ``before`` as version "a" and ``after`` as "b"."""
    db = tdb.open(path, create=True)
    ingest(from_arrays(*before.T, crs=CRS), db, version="a")
    ingest(from_arrays(*after.T, crs=CRS), db, version="b")
    return db


def _reported_in(db, *boxes: tuple[float, float, float, float]) -> list[float]:
    """The area (m²) reported changed from "a" to "b" inside each box."""
    import shapely

    area = shapely.union_all([shapely.geometry.shape(f["geometry"]) for f in detect(db, "a", "b")])
    return [area.intersection(shapely.box(*box)).area for box in boxes]


def test_evidence_pages_written_before_the_depth_read_it_as_nan():
    from tdb.blocks import evidence_blocks, evidence_from_blocks

    xg, yg = np.array([0, 2], np.int64), np.array([0, 0], np.int64)
    lift, gap, support = (np.array([0.1, 0.2], np.float32) * k for k in (1, 2, 5))
    old = list(evidence_blocks(xg, yg, [lift, gap, support]))
    x, _, fields = evidence_from_blocks(old, (-1e9, -1e9, 1e9, 1e9), fields=len(TileEvidence.FIELDS))
    e = TileEvidence(x, np.zeros(2, np.int64), *fields)
    np.testing.assert_allclose(np.sort(e.support), np.sort(support), atol=1e-3)
    assert np.isnan(e.depth).all()


def _understorey(g: np.ndarray, rng: np.random.Generator, where: np.ndarray, *, seen: float = 0.12) -> np.ndarray:
    """A closed canopy's understorey taken for ground over ``where``: all but ``seen`` of the
    returns there stand 0.25-0.4 m up, within a ground filter's threshold."""
    return _shrubs(g, rng, where, share=1 - seen, heights=(0.25, 0.4))


def test_an_understorey_taken_for_ground_is_a_layer_where_its_depth_misses_it():
    rng = np.random.default_rng(31)
    g = _ground(size=60, seed=2)
    g = _understorey(g, rng, g[:, 0] > 30)
    xg, yg = _tiles(60)
    e = tile_evidence(g, xg, yg, spacing=0.5, surface=_surface(g))
    bare, covered = _inner(xg, yg, 6, 24), (xg >= 36) & _inner(xg, yg, 6, 54)
    # few returns see the ground: the depth a fifth of them reach is the understorey's own
    assert np.median(e.depth[covered]) < 0.1
    assert np.median(e.layer[covered]) > 0.2
    assert np.median(e.layer[bare]) < 0.02
    np.testing.assert_allclose(e.standing, np.maximum(e.depth, e.layer))


@pytest.mark.parametrize("density", [4.0, 0.5])
def test_a_wall_lifts_its_edges_but_makes_no_layer(density):
    """A wall 2 m wide and 1.5 m high taken for ground: its edges' tiles are lifted (a quadratic does
    not follow a step), a band the median over the layer's window passes over, at a dense survey's
    5 × 5 tiles and at a sparse one's wider window (its neighbourhoods reach farther)."""
    g = _ground(size=80, density=density, seed=3)
    wall = np.abs(g[:, 0] - 41) < 1
    g[wall, 2] += 1.5
    xg, yg = _tiles(80)
    # with the ground's noise (σ 0.02 m), as an ingest passes it: the floor it makes is taken off
    e = tile_evidence(g, xg, yg, spacing=1 / np.sqrt(density), surface=_surface(g), noise=0.02)
    near = (np.abs(xg + 1 - 41) < 4) & _inner(xg, yg, 12, 68)
    assert np.max(e.lift[near]) > 0.3
    assert np.max(e.layer[near]) < 0.05


def test_the_layer_window_widens_with_the_spacing():
    windows = [layer_window(s) for s in (0.2, 0.5, 0.9, 1.0, 1.5, 2.5)]
    assert windows == sorted(windows) and all(w % 2 == 1 and w >= 5 for w in windows)
    assert windows[0] == 5 and windows[-1] > 9


@settings(max_examples=8, deadline=None)
@given(st.floats(0.01, 0.08), st.sampled_from([0.35, 0.5, 0.7, 1.0]), st.integers(1, 1000))
def test_noise_alone_makes_no_layer(sigma, spacing, seed):
    """A bare plane with the noise and spacing the floor was measured for: its median layer is 0,
    with any other sample of the noise, and the floor grows with the noise."""
    rng = np.random.default_rng(seed)
    n = int(50 * 50 / spacing**2)
    x, y = rng.uniform(0, 50, n), rng.uniform(0, 50, n)
    g = np.column_stack([x, y, 3 + 0.02 * x + rng.normal(0, sigma, n)])
    xg, yg = _tiles(50)
    e = tile_evidence(g, xg, yg, spacing=spacing, surface=_surface(g), noise=sigma)
    inner = _inner(xg, yg, 8, 42)
    assert np.median(e.layer[inner]) < 0.25 * sigma + 0.005
    assert noise_lift(spacing, sigma) <= noise_lift(spacing, 1.5 * sigma)
    assert noise_lift(spacing, 0.0) == 0.0


def test_an_understorey_is_no_rise_but_a_platform_is(tmp_path, monkeypatch):
    """The later survey sees the ground through a closed canopy in one return of eight and takes
    the understorey for it: the layer (a lower bound of its height, the lift's tolerance less)
    takes most of the claim there away; a platform raised 0.6 m beside it is reported."""

    rng = np.random.default_rng(41)
    before = _ground(size=120, density=3, seed=5, noise=0.03)
    after = _ground(size=120, density=3, seed=6, noise=0.03)
    platform = (np.abs(after[:, 0] - 30) < 12) & (np.abs(after[:, 1] - 60) < 12)
    after[platform, 2] += 0.6
    stand = (np.abs(after[:, 0] - 88) < 16) & (np.abs(after[:, 1] - 60) < 16)
    after = _understorey(after, rng, stand)
    db = _two_versions(tmp_path / "u.tdb", before, after)
    boxes = ((18, 48, 42, 72), (72, 44, 104, 76))
    raised, stood = _reported_in(db, *boxes)
    assert raised > 0.9 * 24 * 24
    monkeypatch.setattr(TileEvidence, "standing", property(lambda e: np.nan_to_num(e.depth.astype(float))))
    by_the_layer_alone = _reported_in(db, *boxes)
    monkeypatch.setattr(changes, "_under_a_layer", lambda *_: False)
    uncut = _reported_in(db, *boxes)[1]
    assert uncut > 0.8 * 32 * 32
    assert stood < 0.5 * uncut
    # a region whose later surface lies in a layer thicker than the LoD is no rise at all
    assert by_the_layer_alone[1] < 0.1 * uncut
    assert by_the_layer_alone[0] > 0.9 * 24 * 24


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(1, 60),
    spacing=st.sampled_from([0.3, 0.7, 1.0, 1.8, 3.0]),
    seed=st.integers(0, 10_000),
)
def test_support_gap_and_reach_are_those_of_the_nearest_return(n, spacing, seed):
    """Every node's support, gap and reach, found by measuring the nodes near each return and
    searching only the rest, equal those of the nearest return found by brute force."""
    rng = np.random.default_rng(seed)
    # returns in clumps, with wide gaps between them, some exactly on nodes
    g = np.column_stack([rng.uniform(0, 30, n), rng.uniform(0, 30, n), np.zeros(n)])
    g[: n // 3, :2] = np.round(g[: n // 3, :2])
    xg, yg = (a.ravel().astype(np.int64) for a in np.meshgrid(np.arange(-4, 34, 2), np.arange(-4, 34, 2)))
    surface = dense_model(np.array([[-10, -10, 0], [50, -10, 0], [-10, 50, 0], [50, 50, 0.0]]), resolution=1.0)
    e = tile_evidence(g, xg, yg, spacing=spacing, surface=surface)
    radius = SUPPORT_SPACINGS * spacing
    nx = (xg[:, None] + np.array([0, 1, 2] * 3)[None, :]).ravel()
    ny = (yg[:, None] + np.repeat([0, 1, 2], 3)[None, :]).ravel()
    d = np.hypot(nx[:, None] - g[None, :, 0], ny[:, None] - g[None, :, 1]).min(axis=1).reshape(len(xg), 9)
    np.testing.assert_allclose(e.support, (d <= radius).mean(axis=1), atol=1e-6)
    np.testing.assert_allclose(e.gap, np.maximum(d - radius, 0.0).mean(axis=1), rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(e.reach, np.sqrt((d**2).mean(axis=1)), rtol=1e-5, atol=1e-4)


@settings(max_examples=20, deadline=None)
@given(heights=st.lists(st.floats(-2.0, 6.0), min_size=1, max_size=12), slope=st.floats(-0.2, 0.2))
def test_a_tile_keeps_the_lowest_and_highest_return_not_taken_for_ground_within_reach(heights, slope):
    from ingest.evidence import tile_over
    from tdb.evidence import OVER, OVER_CAP

    # a sloping plane of ground returns every 0.5 m over 10 m; the returns stand in tile (4, 4)
    gx, gy = (a.ravel() for a in np.meshgrid(np.arange(0, 10.01, 0.5), np.arange(0, 10.01, 0.5)))
    g = np.column_stack([gx, gy, slope * gx])
    h = np.array(heights)
    assume(np.abs(h - OVER).min() > 1e-6 and np.abs(h - OVER_CAP).min() > 1e-6)  # rounding at the bounds
    x = np.linspace(4.2, 5.8, len(h))
    others = np.column_stack([x, np.full(len(h), 4.5), slope * x + h])
    xg, yg = np.array([4, 6], np.int64), np.array([4, 4], np.int64)
    low, high = tile_over(others, _surface(g), xg, yg)
    kept = h[(h >= OVER) & (h <= OVER_CAP)]
    if len(kept):
        assert low[0] == pytest.approx(kept.min(), abs=1e-6) and high[0] == pytest.approx(kept.max(), abs=1e-6)
    else:
        assert np.isnan(low[0]) and np.isnan(high[0])
    assert np.isnan(low[1]) and np.isnan(high[1])  # the tile beside holds none


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 60), st.floats(0.0, 1.0))
def test_a_tiles_pulses_and_the_share_taken_for_ground_are_counted(seed, n, ground_share):
    from ingest.evidence import tile_pulses

    rng = np.random.default_rng(seed)
    xy = rng.uniform(-2, 8, (n, 2))  # some fall outside the tiles asked for
    ground = rng.random(n) < ground_share
    xg, yg = np.array([0, 2, 4, 0], np.int64), np.array([0, 0, 0, 4], np.int64)
    density, share = tile_pulses(xy, ground, xg, yg)
    for k, (x, y) in enumerate(zip(xg, yg, strict=True)):
        inside = (xy[:, 0] >= x) & (xy[:, 0] < x + 2) & (xy[:, 1] >= y) & (xy[:, 1] < y + 2)
        if inside.any():
            assert density[k] == pytest.approx(inside.sum() / 4.0)
            assert share[k] == pytest.approx(ground[inside].mean())
        else:
            assert density[k] == 0 and np.isnan(share[k])


@pytest.mark.parametrize(("pulses", "share"), [("two returns each", 1.0), ("one return each", 0.5)])
def test_the_ground_share_counts_each_pulse_once_by_its_last_return(tmp_path, pulses, share):
    from ingest.pipeline import IngestOptions

    g = _ground(size=30, density=2.0, seed=4)
    canopy = g + np.array([0.0, 0.0, 12.0])
    xyz = np.vstack([canopy, g])
    cls = np.r_[np.full(len(g), 5, np.uint8), np.full(len(g), 2, np.uint8)]
    if pulses == "two returns each":  # every pulse's first return in the crowns, its last on the ground
        number, count = np.r_[np.ones(len(g)), np.full(len(g), 2)], np.full(2 * len(g), 2)
    else:  # the crowns' returns and the ground's are pulses of their own
        number, count = np.ones(2 * len(g)), np.ones(2 * len(g))
    cloud = from_arrays(*xyz.T, classification=cls, return_number=number, number_of_returns=count, crs=CRS)
    db = tdb.open(tmp_path / "s.tdb", create=True)
    ingest(cloud, db, version="v", options=IngestOptions(method="classified", objects=False))
    e = db.evidence("v", bbox=(4.0, 4.0, 26.0, 26.0))
    held = np.isfinite(e.ground_share)
    assert held.sum() > 50
    np.testing.assert_allclose(e.ground_share[held], share, atol=1e-3)
    pulses_per_m2 = 2.0 if pulses == "two returns each" else 4.0
    assert np.median(e.pulses[held]) == pytest.approx(pulses_per_m2, rel=0.5)


@settings(max_examples=30, deadline=None)
@given(st.floats(0.1, 4.0), st.floats(0.1, 2.0), st.floats(-5.0, 5.0))
def test_the_missed_relief_is_what_a_line_between_returns_misses_midway(curvature, reach, x0):
    """Returns at x0 and x0 + 2r on ground z = κx²/2: the line between them misses κr²/2 midway."""
    ground = lambda x: curvature * x**2 / 2  # noqa: E731
    line = (ground(x0) + ground(x0 + 2 * reach)) / 2
    assert missed_relief(np.array(curvature), np.array(reach)) == pytest.approx(line - ground(x0 + reach))


def test_a_tiles_lod_grows_with_its_curvature_and_its_nodes_reach():
    """A flat tile keeps its LoD; a tile across a ditch (second difference 2 m over 1 m nodes)
    gains each version's κr²/2 in quadrature, from the curvature either version shows."""
    flat = np.zeros((2, 1, 9))
    ditch = np.tile(np.array([0.0, -2.0, 0.0]), 3)[None, :]  # across the rows: 0, −2, 0
    surfaces = np.concatenate([flat, np.stack([flat[0], ditch])], axis=1)  # the later one shows it
    reach = np.array([[0.5, 0.5], [1.0, 1.0]])
    lod = curved_lod(np.full(2, 0.1), surfaces, reach, spacing=1.0)
    assert lod[0] == pytest.approx(0.1)
    kappa = 4.0  # |0 − 2·(−2) + 0| / 1²
    assert lod[1] == pytest.approx(np.sqrt(0.1**2 + (kappa * 0.25 / 2) ** 2 + (kappa * 1.0 / 2) ** 2))


def _ditched(g: np.ndarray, *, width: float, depth: float) -> np.ndarray:
    """``g`` with a ditch of cosine section along x = 40."""
    out = g.copy()
    across = np.abs(out[:, 0] - 40.0)
    inside = across < width / 2
    out[inside, 2] -= depth * (1 + np.cos(2 * np.pi * across[inside] / width)) / 2
    return out


@pytest.mark.parametrize("missed", [MISSED, 0.0])
def test_a_ditch_two_sparse_surveys_cut_at_other_depths_is_no_change(tmp_path, monkeypatch, missed):
    """At 0.75 pulses/m² a ditch 2 m wide holds a return at its bottom here and there, at other
    places in each survey: without the relief the lines between returns miss, its unchanged
    stretches read as dug or filled. A ditch dug at that density is still claimed."""
    monkeypatch.setattr("tdb.evidence.MISSED", missed)
    db = tdb.open(tmp_path / "d.tdb", create=True)
    ditch = {"width": 2.0, "depth": 1.0}
    for name, seed in (("a", 5), ("b", 6)):
        ingest(from_arrays(*_ditched(_ground(80, 0.75, seed=seed), **ditch).T, crs=CRS), db, version=name)
    ingest(from_arrays(*_ground(80, 0.75, seed=7).T, crs=CRS), db, version="flat")
    ingest(from_arrays(*_ditched(_ground(80, 0.75, seed=8), width=4.0, depth=1.0).T, crs=CRS), db, version="dug")
    unchanged = detect(db, "a", "b")
    if missed:
        assert unchanged == []
        dug = detect(db, "flat", "dug")
        assert [f["properties"]["kind"] for f in dug] == ["ditch dug"]
    else:
        assert unchanged  # the test can fail: without the term the sampling reads as change
