"""Points a producer flags withheld are left out of every model, whatever their class; a
classified copy of a LAS/LAZ file keeps every record of the source but its class."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import laspy
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import CRS

from ingest.ground import classify_ground
from ingest.readers import read, read_box, write_classified, write_las
from tdb.cloud import PointCloud, from_arrays


def _plane(n: int = 6400, *, seed: int = 3) -> PointCloud:
    """A gentle bare plane, 40 × 40 m at 4 points/m², every point on it."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0, 40, n), rng.uniform(0, 40, n)
    return from_arrays(x, y, 100 + 0.02 * x + rng.normal(0, 0.02, n), classification=np.full(n, 2, np.uint8))


def _flagged(cloud: PointCloud, share: float, *, seed: int) -> PointCloud:
    return replace(cloud, withheld=np.random.default_rng(seed).random(len(cloud)) < share)


def test_the_reader_keeps_the_withheld_flags(tmp_path: Path) -> None:
    cloud = replace(_flagged(_plane(), 0.1, seed=1), crs=CRS.from_epsg(25832))
    path = tmp_path / "w.laz"
    write_las(path, cloud)
    whole = read(path)
    assert whole.withheld is not None and np.array_equal(whole.withheld, cloud.withheld)
    part = read_box(path, (0.0, 0.0, 20.0, 40.0))
    inside = cloud.xyz[:, 0] <= 20.0
    assert part.withheld is not None and np.array_equal(part.withheld, cloud.withheld[inside])
    # none flagged: no mask is kept at all
    write_las(path, replace(cloud, withheld=None))
    assert read(path).withheld is None


@settings(max_examples=6, deadline=None)
@given(share=st.floats(0.02, 0.5), seed=st.integers(0, 1000))
def test_withheld_points_are_never_ground(share: float, seed: int) -> None:
    cloud = _flagged(_plane(), share, seed=seed)
    assert cloud.withheld is not None
    ground = classify_ground(cloud, exclude=())
    assert not ground[cloud.withheld].any()
    # they lie on the plane: without the flag they are ground like the rest
    assert ground[~cloud.withheld].mean() > 0.95
    assert classify_ground(replace(cloud, withheld=None), exclude=())[cloud.withheld].mean() > 0.95


@pytest.mark.filterwarnings("ignore:.*single returns only")
def test_ingest_counts_withheld_points_as_excluded(tmp_path: Path) -> None:
    import tdb
    from ingest.blocked import Blocking, ingest_blocked
    from ingest.pipeline import ingest

    cloud = replace(_flagged(_plane(), 0.1, seed=2), crs=CRS.from_epsg(25832))
    assert cloud.withheld is not None
    path = tmp_path / "w.laz"
    write_las(path, cloud)
    db = tdb.open(tmp_path / "w.tdb", create=True)
    whole = ingest(str(path), db, version="whole")
    blocked = ingest_blocked(path, db, version="blocks", blocking=Blocking(block=32, buffer=16, workers=1))
    for v in (whole, blocked):
        stats = db.version(v.name).stats
        assert stats.excluded_points == int(cloud.withheld.sum()), v.name
        assert stats.ground_points <= len(cloud) - int(cloud.withheld.sum())


UTM32 = CRS.from_epsg(25832)


def _rich_file(path: Path, n: int = 4000, *, crs: CRS | None = UTM32) -> laspy.LasData:
    """A LAS 1.2 file of point format 3 (times, colours) with an extra dimension, over a plane."""
    plane = _plane(n, seed=5)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.add_extra_dim(laspy.ExtraBytesParams(name="tree_id", type=np.uint16))
    header.offsets, header.scales = np.array([0.0, 0.0, 0.0]), np.array([0.01, 0.01, 0.01])
    if crs is not None:
        header.add_crs(crs)
    las = laspy.LasData(header)
    las.x, las.y, las.z = plane.x, plane.y, plane.z
    rng = np.random.default_rng(7)
    las.gps_time = np.sort(rng.uniform(0, 1e5, n))
    las.red, las.green, las.blue = (rng.integers(0, 65535, n, dtype=np.uint16) for _ in range(3))
    las.point_source_id = rng.integers(1, 9, n, dtype=np.uint16)
    las.scan_angle_rank = rng.integers(-20, 20, n, dtype=np.int8)
    las.tree_id = rng.integers(0, 500, n, dtype=np.uint16)
    las.classification = np.full(n, 1, np.uint8)
    las.withheld = rng.random(n) < 0.05
    las.write(str(path))
    return las


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_a_classified_copy_keeps_every_record_but_the_class(tmp_path: Path, suffix: str) -> None:
    src = tmp_path / f"rich{suffix}"
    before = _rich_file(src)
    cloud = read(src)
    classes = np.where(np.arange(len(cloud)) % 3 == 0, 2, 5).astype(np.uint8)
    out = tmp_path / f"out{suffix}"
    write_classified(out, cloud, classes)
    after = laspy.read(str(out))
    assert after.header.point_format.id == 3 and after.header.point_count == len(cloud)
    assert np.array_equal(np.asarray(after.classification), classes)
    for name in before.point_format.dimension_names:
        if name != "classification":
            assert np.array_equal(np.asarray(after[name]), np.asarray(before[name])), name
    assert after.header.parse_crs() == CRS.from_epsg(25832)


def test_a_classified_copy_takes_the_crs_a_file_lacked(tmp_path: Path) -> None:
    src = tmp_path / "bare.las"
    _rich_file(src, crs=None)
    cloud = read(src, crs="EPSG:25833")
    out = tmp_path / "out.las"
    write_classified(out, cloud, np.full(len(cloud), 2, np.uint8))
    assert laspy.read(str(out)).header.parse_crs() == CRS.from_epsg(25833)


def test_a_text_cloud_is_written_whole(tmp_path: Path) -> None:
    text = tmp_path / "pts.txt"
    plane = _plane(500)
    np.savetxt(text, plane.xyz)
    cloud = read(text, crs="EPSG:25832")
    out = tmp_path / "out.laz"
    write_classified(out, cloud, np.full(len(cloud), 2, np.uint8))
    back = read(out)
    assert np.allclose(back.xyz, cloud.xyz, atol=1e-3) and (back.classification == 2).all()


def test_a_source_changed_under_the_copy_is_refused(tmp_path: Path) -> None:
    from tdb.errors import TdbIOError

    src = tmp_path / "rich.las"
    _rich_file(src)
    cloud = read(src)
    _rich_file(src, n=100)
    with pytest.raises(TdbIOError, match="changed"):
        write_classified(tmp_path / "out.las", cloud, np.full(len(cloud), 2, np.uint8))
    assert not (tmp_path / "out.las").exists()
