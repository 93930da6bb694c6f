"""The dense ground model and GeoTIFF output."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.dtm import dense_model
from ingest.synth import ground_height, make_scene, sample
from tdb.cloud import GROUND
from tdb.errors import InputError
from tdb.geotiff import write_geotiff


def test_plane_is_reproduced_exactly():
    rng = np.random.default_rng(0)
    x, y = rng.uniform(0, 40, 800), rng.uniform(0, 40, 800)
    z = 3 + 0.1 * x - 0.05 * y
    dtm = dense_model(np.column_stack([x, y, z]), resolution=0.5)
    xs, ys = dtm.centres()
    gx, gy = np.meshgrid(xs, ys)
    ok = ~np.isnan(dtm.data)
    assert ok.mean() > 0.9
    np.testing.assert_allclose(dtm.data[ok], (3 + 0.1 * gx - 0.05 * gy)[ok], atol=1e-9)


def test_no_data_outside_hull_and_in_big_gaps():
    t = np.linspace(0, 1, 50)
    # An L of points: the inside corner of the L is outside the hull? No: fill a triangle only.
    xyz = np.array([[0, 0, 0], [100, 0, 0], [0, 100, 0], [10, 10, 0]], float)
    dtm = dense_model(xyz, resolution=1.0, max_edge=None)
    assert np.isnan(dtm.sample(np.array([90.0]), np.array([90.0])))[0]
    assert dtm.sample(np.array([5.0]), np.array([5.0]))[0] == pytest.approx(0.0)
    gappy = dense_model(xyz, resolution=1.0, max_edge=50.0)
    assert np.isnan(gappy.data).all()
    del t


def test_synthetic_truth_error():
    scene = make_scene(seed=2, size=120)
    cloud = sample(scene, density=4, seed=2)
    g = cloud.classification == GROUND
    dtm = dense_model(cloud.xyz[g], resolution=0.5)
    xs, ys = dtm.centres()
    gx, gy = np.meshgrid(xs, ys)
    truth = ground_height(scene, gx.ravel(), gy.ravel()).reshape(gx.shape)
    ok = ~np.isnan(dtm.data)
    err = dtm.data[ok] - truth[ok]
    assert np.sqrt(np.mean(err**2)) < 0.15
    assert abs(np.median(err)) < 0.02


def test_geotiff_round_trip(tmp_path):
    import pyproj

    rng = np.random.default_rng(1)
    xyz = np.column_stack(
        [rng.uniform(500000, 500050, 300), rng.uniform(5e6, 5e6 + 50, 300), rng.normal(10, 1, 300)]
    )
    dtm = dense_model(xyz, resolution=0.5, crs=pyproj.CRS.from_epsg(25832))
    write_geotiff(tmp_path / "d.tif", dtm)
    back = read_geotiff(tmp_path / "d.tif")
    assert back.crs.to_epsg() == 25832
    assert back.cell == 0.5 and back.x0 == dtm.x0 and back.y1 == dtm.y1
    np.testing.assert_allclose(
        np.nan_to_num(back.data, nan=-1), np.nan_to_num(dtm.data.astype(np.float32), nan=-1)
    )


def test_bad_resolution():
    with pytest.raises(InputError):
        dense_model(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), resolution=0)


def test_sampling_on_a_post_beside_a_hole_keeps_its_value():
    from tdb.raster import Raster

    data = np.array([[1.0, np.nan], [3.0, 4.0]])
    r = Raster(data, 0.0, 2.0, 1.0)
    # Post centres are at 0.5 and 1.5; (0.5, 1.5) is the post holding 1.0.
    assert r.sample(np.array([0.5, 0.5, 1.5]), np.array([1.5, 0.5, 0.5])).tolist() == [1.0, 3.0, 4.0]
    assert np.isnan(r.sample(np.array([1.0]), np.array([1.5]))[0])  # halfway to the hole
    assert r.sample(np.array([1.0]), np.array([0.5]))[0] == 3.5
    assert np.isnan(r.sample(np.array([-0.1]), np.array([0.5]))[0])  # outside


def read_geotiff(path):
    """Band 1 of a GeoTIFF as a Raster (no-data as NaN), read with rasterio."""
    import pyproj
    import rasterio

    from tdb.raster import Raster

    with rasterio.open(path) as src:
        data = src.read(1).astype(np.float64)
        if src.nodata is not None:
            data[data == src.nodata] = np.nan
        t = src.transform
        crs = pyproj.CRS.from_wkt(src.crs.to_wkt()) if src.crs else None
    return Raster(data, float(t.c), float(t.f), float(t.a), crs)


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 6), cols=st.integers(1, 6), seed=st.integers(0, 2**16))
def test_sampling_is_bilinear_between_the_four_posts_around(rows, cols, seed):
    """Against the bilinear formula worked point by point: posts at cell centres, NaN outside the
    posts' hull or where a post with a weight is NaN, a post with no weight ignored."""
    from tdb.raster import Raster

    rng = np.random.default_rng(seed)
    data = rng.normal(size=(rows, cols))
    data[rng.random((rows, cols)) < 0.2] = np.nan
    r = Raster(data, 10.0, 20.0, 0.5)
    fc = np.r_[rng.uniform(-0.5, cols - 0.5, 40), rng.integers(0, cols, 20)]  # some on posts
    fr = np.r_[rng.uniform(-0.5, rows - 0.5, 40), rng.integers(0, rows, 20)]
    got = r.sample(10.0 + (fc + 0.5) * 0.5, 20.0 - (fr + 0.5) * 0.5)
    for k in range(len(fc)):
        if not (0 <= fc[k] <= cols - 1 and 0 <= fr[k] <= rows - 1):
            assert np.isnan(got[k])
            continue
        c0, r0 = int(np.floor(fc[k])), int(np.floor(fr[k]))
        tc, tr = fc[k] - c0, fr[k] - r0
        corners = ((0, 0, (1 - tr) * (1 - tc)), (0, 1, (1 - tr) * tc), (1, 0, tr * (1 - tc)), (1, 1, tr * tc))
        terms = [w * data[min(r0 + dr, rows - 1), min(c0 + dc, cols - 1)] for dr, dc, w in corners if w > 0]
        np.testing.assert_allclose(got[k], sum(terms), rtol=1e-12, atol=1e-12)
