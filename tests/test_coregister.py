"""Co-registration: a known offset of one surface is recovered, and none is applied where none is."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from queries.coregister import Shift, estimate_shift, resample, stable_cells
from tdb.errors import CRSError
from tdb.options import Coregistration
from tdb.raster import Raster

CELL = 1.0


def terrain(x, y):
    """Hills of several sizes: slopes facing every way, up to about 30°."""
    return (
        100
        + 8 * np.sin(x / 37.0) * np.cos(y / 29.0)
        + 3 * np.sin((x + 2 * y) / 13.0)
        + 1.5 * np.cos((x - y) / 7.0)
    )


def grids(dx, dy, dz, *, noise=0.03, seed=0, size=240, change=True):
    """Before and after on one grid; ``after`` is the terrain surveyed with offset (dx, dy, dz),
    with noise, and with a raised block (a change) that must not pull the estimate."""
    rng = np.random.default_rng(seed)
    xs = np.arange(size) * CELL + CELL / 2
    ys = (np.arange(size) * CELL + CELL / 2)[::-1]  # rows north to south
    gx, gy = np.meshgrid(xs, ys)
    before = terrain(gx, gy) + rng.normal(0, noise, gx.shape)
    # the later survey sees the point (x, y) at (x + dx, y + dy), dz too high
    after = terrain(gx - dx, gy - dy) + dz + rng.normal(0, noise, gx.shape)
    if change:
        after[40:80, 150:200] += 2.0
    top = size * CELL
    return Raster(before, 0.0, top, CELL), Raster(after, 0.0, top, CELL)


@settings(max_examples=12, deadline=None)
@given(
    st.floats(-1.0, 1.0),
    st.floats(-1.0, 1.0),
    st.floats(-0.5, 0.5),
    st.integers(0, 1000),
)
def test_a_known_offset_is_recovered(dx, dy, dz, seed):
    before, after = grids(dx, dy, dz, seed=seed)
    s = estimate_shift(before, after, method=Coregistration.NUTH_KAAB)
    assert abs(s.dx - dx) <= 0.10 and abs(s.dy - dy) <= 0.10
    assert abs(s.dz - dz) <= 0.02
    aligned = s.apply(after).data - before.data
    stable = stable_cells(aligned)
    assert np.nanmedian(np.abs(aligned[stable])) < 0.05  # down to the noise


def test_auto_applies_nothing_without_an_offset_and_all_with_one():
    noise = 0.03 * np.sqrt(2)  # both surfaces' own
    before, after = grids(0.0, 0.0, 0.0, seed=3)
    s = estimate_shift(before, after, method=Coregistration.AUTO, noise=noise)
    assert not s.horizontal and not s.vertical
    before, after = grids(0.6, -0.4, 0.25, seed=3)
    s = estimate_shift(before, after, method=Coregistration.AUTO, noise=noise)
    assert s.horizontal and s.vertical
    assert abs(s.dx - 0.6) <= 0.1 and abs(s.dz - 0.25) <= 0.02


def test_a_shift_under_the_noise_is_estimated_but_not_applied():
    before, after = grids(0.0, 0.0, 0.01, seed=4, noise=0.005)
    s = estimate_shift(before, after, method=Coregistration.AUTO, noise=0.03)
    assert abs(s.dz - 0.01) <= 0.003 and not s.vertical  # significant, but under the noise
    assert estimate_shift(before, after, method=Coregistration.AUTO, noise=0.0).vertical


def test_vertical_only_leaves_the_plan_alone_and_none_does_nothing():
    before, after = grids(0.0, 0.0, -0.4, seed=5)
    s = estimate_shift(before, after, method=Coregistration.VERTICAL)
    assert not s.horizontal and s.vertical and abs(s.dz + 0.4) <= 0.02
    assert s.dx == 0 and s.dy == 0
    none = estimate_shift(before, after, method=Coregistration.NONE)
    assert not none.applied and none.apply(after).data is after.data


def test_the_spread_is_that_of_the_change_the_ground_evidence_supports():
    """The later survey took shrubs' top for ground on a third of the site, 0.05–0.2 m over the
    ground it saw there: its surface stands over its returns by that depth. The spread a level
    of detection is drawn from is the surveys' noise, not the shrubs'."""
    rng = np.random.default_rng(8)
    before, after = grids(0.0, 0.0, 0.0, seed=6, change=False)
    shrubs = np.zeros(after.shape, bool)
    shrubs[:, :80] = True
    lift = np.where(shrubs, rng.uniform(0.05, 0.2, after.shape), 0.0)
    after = Raster(after.data + lift, after.x0, after.y1, after.cell)
    plain = estimate_shift(before, after, method=Coregistration.AUTO, noise=0.04)
    none = np.zeros(after.shape)
    seen = estimate_shift(before, after, method=Coregistration.AUTO, noise=0.04, depth=(none, lift))
    assert plain.nmad > 0.06  # the shrubs widen the raw differences
    assert seen.nmad < 0.05  # 0.03 m noise in each survey: 0.042 m together
    assert abs(seen.dz - plain.dz) < 1e-9  # the shift itself is estimated on the raw surfaces
    # a person is shown the surfaces' own residual spread, and beside it the supported one
    assert abs(seen.residual_nmad - plain.nmad) < 1e-9 and plain.residual_nmad == plain.nmad
    assert f"{seen.residual_nmad:.3f} m, {seen.nmad:.3f} m of the change" in seen.describe()
    assert f"NMAD on stable ground {plain.nmad:.3f} m;" in plain.describe()
    assert f"NMAD on stable ground {seen.residual_nmad:.3f} m" in seen.title()
    again = Shift.from_json(seen.to_json())
    assert np.allclose([again.nmad, again.residual_nmad], [seen.nmad, seen.residual_nmad], atol=1e-4)


def test_resample_moves_by_the_fraction_asked_and_keeps_holes():
    data = np.arange(20.0).reshape(4, 5)
    data[1, 1] = np.nan
    out = resample(data, 0.5, 0.0)
    assert out[0, 0] == pytest.approx(0.5)
    assert np.isnan(out[1, 0]) and np.isnan(out[1, 1])  # a neighbour is a hole
    assert np.isnan(out[0, 4])  # beyond the edge


def test_differing_horizontal_crs_are_refused():
    from pyproj import CRS

    from tdb.crs import check_same_horizontal, vertical_part

    utm = CRS.from_epsg(26917)
    with_height = CRS.from_user_input("EPSG:26917+5713")  # NAD83 / UTM 17N + CGVD28
    check_same_horizontal(utm, with_height, names=("a", "b"))  # the same plan; only one has heights
    assert vertical_part(with_height) is not None and vertical_part(utm) is None
    with pytest.raises(CRSError, match="different horizontal"):
        check_same_horizontal(utm, CRS.from_epsg(32617), names=("a", "b"))


@pytest.mark.slow
def test_an_offset_resurvey_reads_as_the_same_changes_once_aligned(tmp_path):
    """A re-survey 0.6 m east, 0.4 m south and 0.3 m high: as it is, the offset reads as change;
    co-registered, the changes and their kinds are those of the re-survey without the offset."""
    import dataclasses

    import tdb
    from ingest.pipeline import ingest
    from ingest.synth import apply_changes, make_scene, sample
    from queries.changes import detect
    from queries.coregister import coregister

    scene = make_scene(seed=7, size=150)
    later, changes = apply_changes(scene, seed=7)
    resurvey = sample(later, density=3, seed=8)
    offset = np.array([0.6, -0.4, 0.3])
    moved = dataclasses.replace(resurvey, xyz=resurvey.xyz + offset)
    db = tdb.open(tmp_path / "o.tdb", create=True)
    ingest(sample(scene, density=3, seed=7), db, version="a")
    ingest(resurvey, db, version="b")
    ingest(moved, db, version="b_moved")
    s = coregister(db, "a", "b_moved")
    assert s.horizontal and s.vertical
    assert np.hypot(s.dx - 0.6, s.dy + 0.4) <= 0.10 and abs(s.dz - 0.3) <= 0.02
    reference = detect(db, "a", "b", shift=coregister(db, "a", "b"))
    aligned = detect(db, "a", "b_moved", shift=s)
    raw = detect(db, "a", "b_moved")
    # every true change is found and typed as without the offset; the ground filter's grid meets
    # the shifted cloud at another phase, which moves the interpolated ground here and there
    # (a building's foot, a natural ridge): at most a third of the reference's area more may read
    # as changed
    import shapely

    def kind_over(found, change):
        overlaps = [(shapely.geometry.shape(f["geometry"]).intersection(change.area).area, f) for f in found]
        best = max(overlaps, key=lambda o: o[0], default=(0.0, None))
        return best[1]["properties"]["kind"] if best[0] > 0 else None

    truth = [c for c in changes if c.terrain and abs(c.dz) >= 0.5]
    assert truth
    assert all(kind_over(aligned, c) == kind_over(reference, c) is not None for c in truth)

    def area(found):
        return sum(f["properties"]["area"] for f in found)

    assert area(aligned) <= 4 / 3 * area(reference)
    assert area(raw) > 10 * area(aligned)  # as it is, the offset swamps every change
    # the shift found is stored and reused, not estimated again; a replaced version drops it
    import queries.coregister as module

    def refuse(*args, **kwargs):
        raise AssertionError("estimated again")

    original = module.estimate_shift
    module.estimate_shift = refuse
    try:
        again = coregister(db, "a", "b_moved")
    finally:
        module.estimate_shift = original
    assert np.allclose([again.dx, again.dy, again.dz, again.nmad], [s.dx, s.dy, s.dz, s.nmad], atol=1e-4)
    assert (again.horizontal, again.vertical, again.method) == (s.horizontal, s.vertical, s.method)
    key = f"auto level 2 all estimator {module.ESTIMATOR}"
    assert db.coregistration("a", "b_moved", key) is not None
    ingest(moved, db, version="b_moved", replace=True)
    assert db.coregistration("a", "b_moved", key) is None


def test_a_note_where_heights_may_not_share_a_reference():
    from pyproj import CRS

    from tdb.crs import height_reference_note

    utm = CRS.from_epsg(26917)
    cgvd28 = CRS.from_user_input("EPSG:26917+5713")
    navd88 = CRS.from_user_input("EPSG:26917+5703")
    assert height_reference_note(utm, utm, names=("a", "b")) is None
    assert height_reference_note(cgvd28, cgvd28, names=("a", "b")) is None
    note = height_reference_note(cgvd28, utm, names=("2019", "2023"))
    assert note and "'2019' gives CGVD28" in note and "'2023' declares no vertical CRS" in note
    assert "NAVD88" in (height_reference_note(cgvd28, navd88, names=("a", "b")) or "")


@pytest.mark.slow
def test_changes_over_three_versions_have_a_history(tmp_path):
    """a → b: the scene's changes; b → c: a second set, surveyed on a height datum 0.3 m higher
    (two of its changes lie well away from the first set's). Each region's history says when it
    first changed; the datum does not read as change."""
    import dataclasses

    import tdb
    from ingest.pipeline import ingest
    from ingest.synth import apply_changes, make_scene, sample
    from queries.run import run

    scene = make_scene(seed=3, size=150)
    later, first = apply_changes(scene, seed=3)
    latest, second = apply_changes(later, seed=28)
    c = sample(latest, density=3, seed=13)
    db = tdb.open(tmp_path / "h.tdb", create=True)
    ingest(sample(scene, density=3, seed=3), db, version="a")
    ingest(sample(later, density=3, seed=4), db, version="b")
    ingest(dataclasses.replace(c, xyz=c.xyz + np.array([0.0, 0.0, 0.3])), db, version="c")
    found = run(db, "SELECT changes FROM a TO b TO c")
    assert found
    site = 150 * 150
    assert max(f["properties"]["area"] for f in found) < 0.2 * site  # no region spans the site
    geoms = [(shapely_shape(f), f["properties"]) for f in found]
    for changes, version in ((first, "b"), (second, "c")):
        for change in changes:
            hits = [p for g, p in geoms if g.intersects(change.area)]
            if hits:  # what is found is dated to the interval it happened in
                assert any(p["first_changed"] == version or p[f"dz_{version}"] != 0.0 for p in hits)
    dated = {p["first_changed"] for _, p in geoms}
    assert dated == {"b", "c"}
    from queries.coregister import coregister

    assert abs(coregister(db, "b", "c").dz - 0.3) <= 0.02


def shapely_shape(f):
    import shapely

    return shapely.geometry.shape(f["geometry"])


def test_two_realisations_of_a_datum_are_compared_and_other_zones_refused():
    from pyproj import CRS

    from tdb.crs import check_same_horizontal

    at = (630000.0, 4835000.0)
    note = check_same_horizontal(CRS.from_epsg(32617), CRS.from_epsg(26917), names=("2015", "2019"), at=at)
    assert note and "compared as they are" in note
    with pytest.raises(CRSError, match="different horizontal"):
        check_same_horizontal(CRS.from_epsg(32617), CRS.from_epsg(32618), names=("a", "b"), at=at)


def test_two_sites_far_apart_are_aligned_and_compared(tmp_path, small_cloud):
    """A version of two patches 20 km apart: the surfaces are rebuilt part by part, and the
    co-registration's sample stripes are spaced for the tiles held, not for the empty box between:
    a re-survey 0.3 m lower is found so, and nothing else changed."""
    import dataclasses

    import tdb
    from ingest.blocked import Blocking, ingest_blocked
    from ingest.readers import write_las
    from queries.changes import detect
    from queries.coregister import coregister
    from tests.conftest import two_patches

    wide = two_patches(small_cloud, 20_000.0)
    lower = dataclasses.replace(wide, xyz=wide.xyz - np.array([0.0, 0.0, 0.3]))
    for name, cloud in (("a", wide), ("b", lower)):
        write_las(tmp_path / f"{name}.laz", cloud)
    db = tdb.open(tmp_path / "w.tdb", create=True)
    for name in "ab":
        ingest_blocked(tmp_path / f"{name}.laz", db, version=name, blocking=Blocking(workers=1))
    shift = coregister(db, "a", "b", method="auto")
    assert shift.dz == pytest.approx(-0.3, abs=0.02) and shift.vertical
    assert detect(db, "a", "b", shift=shift) == []


@pytest.mark.parametrize("cover", ["none", "crowns"])
def test_gentle_ground_carries_no_horizontal_shift(tmp_path, cover):
    """A plane rising 2 % (under the 3° that carry a shift) surveyed twice, the re-survey sparser
    and, with ``cover``, a thicket in its middle: no slope stands out of the noise to carry a
    horizontal shift, so none is found or applied. Judged on each cell's own gradient, the few
    cells whose noise adds to the slope leaned the fit along it (4.1 m east under the thicket)."""
    import tdb
    from ingest.pipeline import IngestOptions, ingest
    from queries.coregister import coregister
    from tests.conftest import thicket

    rng = np.random.default_rng(12)
    db = tdb.open(tmp_path / "p.tdb", create=True)
    options = IngestOptions(method="classified", objects=False)
    ingest(thicket(rng, cover="none", density=4.0), db, version="a", options=options)
    ingest(thicket(rng, cover=cover), db, version="b", options=options)
    s = coregister(db, "a", "b")
    assert not s.horizontal
    assert abs(s.dz) < 0.02


def test_height_offset_between_vertical_datums_offline():
    from pyproj import CRS

    from tdb.crs import height_offset, height_reference_note

    belgium = (600000.0, 5640000.0)  # ETRS89 / UTM 31N
    evrf = CRS.from_user_input("EPSG:25831+5621")  # EVRF2007 heights
    ostend = CRS.from_user_input("EPSG:25831+5710")  # Belgium's Ostend heights (TAW)
    offset = height_offset(evrf, ostend, at=belgium)
    assert offset is not None
    # Ostend heights stand about 2.3 m above EVRF2007's for the same ground
    assert 2.2 < offset.dz < 2.45 and offset.accuracy <= 0.2
    back = height_offset(ostend, evrf, at=belgium)
    assert back is not None and back.dz == pytest.approx(-offset.dz, abs=1e-6)
    note = height_reference_note(evrf, ostend, names=("a", "b"), offset=offset)
    assert note and "Ostend" in note and f"{-offset.dz:+.3f} m" in note
    # nothing to do: no vertical CRS, one datum in two units, or the same CRS
    utm17 = (600000.0, 4800000.0)
    assert height_offset(CRS.from_epsg(26917), CRS.from_user_input("EPSG:26917+5703"), at=utm17) is None
    navd88_m, navd88_ft = CRS.from_user_input("EPSG:26917+5703"), CRS.from_user_input("EPSG:26917+6360")
    assert height_offset(navd88_m, navd88_ft, at=utm17) is None
    assert height_reference_note(navd88_m, navd88_ft, names=("a", "b")) is None
    # CGVD28 to CGVD2013 needs a geoid grid PROJ does not ship: no ballpark zero is taken for it
    cgvd28, cgvd2013 = CRS.from_user_input("EPSG:26917+5713"), CRS.from_user_input("EPSG:26917+6647")
    assert height_offset(cgvd28, cgvd2013, at=utm17) is None
    assert "no transformation" in (height_reference_note(cgvd28, cgvd2013, names=("a", "b")) or "")


def test_surveys_on_two_vertical_datums_compare_once_transformed(tmp_path):
    """The same re-survey delivered in Ostend heights rather than EVRF2007: expressed in the
    earlier survey's reference by PROJ, it reads the same changes, with every method."""
    import dataclasses

    from pyproj import CRS

    import tdb
    from ingest.pipeline import ingest
    from ingest.synth import apply_changes, make_scene, sample
    from queries.changes import detect
    from queries.coregister import coregister
    from tdb.crs import height_offset

    scene = make_scene(seed=3, size=120, origin=(600000.0, 5640000.0), crs="EPSG:25831+5621")
    later, _ = apply_changes(scene, seed=3)
    resurvey = sample(later, density=2, seed=4)
    ostend = CRS.from_user_input("EPSG:25831+5710")
    offset = height_offset(resurvey.crs, ostend, at=(600060.0, 5640060.0))
    assert offset is not None
    in_ostend = dataclasses.replace(resurvey, xyz=resurvey.xyz + np.array([0.0, 0.0, offset.dz]), crs=ostend)
    db = tdb.open(tmp_path / "d.tdb", create=True)
    ingest(sample(scene, density=2, seed=3), db, version="a")
    ingest(resurvey, db, version="b")
    ingest(in_ostend, db, version="b_ostend")
    for method in ("none", "auto"):
        same = coregister(db, "a", "b", method=method)
        other = coregister(db, "a", "b_ostend", method=method)
        assert same.datum_dz == 0.0 and not same.datum
        assert other.datum_dz == pytest.approx(offset.dz, abs=0.01) and "Ostend" in other.datum
        assert other.z_offset == pytest.approx(same.z_offset + offset.dz, abs=0.01)
        assert other.to_json()["datum_dz"] == pytest.approx(offset.dz, abs=1e-3)
        found = detect(db, "a", "b", shift=same)
        moved = detect(db, "a", "b_ostend", shift=other)
        assert found
        assert [f["properties"]["kind"] for f in moved] == [f["properties"]["kind"] for f in found]
        assert sum(f["properties"]["area"] for f in moved) == pytest.approx(
            sum(f["properties"]["area"] for f in found), rel=0.05
        )
    # as it is, 2.3 m of datum reads as change everywhere
    raw = detect(db, "a", "b_ostend")
    assert sum(f["properties"]["area"] for f in raw) > 10 * sum(f["properties"]["area"] for f in found)


@settings(max_examples=25, deadline=None)
@given(st.floats(560000.0, 680000.0), st.floats(5620000.0, 5680000.0))
def test_a_height_offset_read_back_is_its_opposite(x, y):
    # Anywhere in central Belgium (ETRS89 / UTM 31N): Ostend heights over EVRF2007 and back.
    from pyproj import CRS

    from tdb.crs import height_offset

    evrf, ostend = CRS.from_user_input("EPSG:25831+5621"), CRS.from_user_input("EPSG:25831+5710")
    there, back = height_offset(evrf, ostend, at=(x, y)), height_offset(ostend, evrf, at=(x, y))
    assert there is not None and back is not None
    assert there.dz == pytest.approx(-back.dz, abs=1e-6)
    assert 2.0 < there.dz < 2.6


def test_datum_offsets_against_one_reference_give_the_offset_between_two_later_surveys():
    from queries.coregister import Shift
    from queries.history import between

    first = Shift(dz=0.05, vertical=True, datum_dz=2.32, datum="Ostend to EVRF2007")
    second = Shift(dz=0.02, vertical=True, datum_dz=0.0)
    step = between(first, second)
    # the first survey's heights stand 2.37 m over the reference, the second's 0.02 m
    assert step.z_offset == pytest.approx(second.z_offset - first.z_offset)
    assert step.datum_dz == pytest.approx(-2.32) and "Ostend" in step.datum
