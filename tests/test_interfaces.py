"""Interfaces do what they say: options reach the work, errors name no CLI flag, one progress protocol."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import tdb
from ingest.pipeline import IngestOptions, ingest
from tdb.cli import main
from tdb.cloud import from_arrays
from tdb.errors import CRSError, Remedy, VersionExistsError


@pytest.fixture(scope="module")
def plane():
    """A gently tilted bare plane, 30 × 30 m at 4 points/m², no CRS; every fifth point labelled 7."""
    rng = np.random.default_rng(11)
    n = 3600
    x, y = rng.uniform(0, 30, n) + 500_000, rng.uniform(0, 30, n) + 5_400_000
    z = 50 + 0.03 * (x - 500_000) + rng.normal(0, 0.02, n)
    label = np.where(np.arange(n) % 5 == 0, 7, 0)
    return x, y, z, label


def test_ingest_labels_reach_the_reader(plane, tmp_path):
    """Read as ASPRS codes, label 7 is noise and excluded; read as ISPRS labels it is an object."""
    x, y, z, label = plane
    src = tmp_path / "samp.txt"
    np.savetxt(src, np.column_stack([x, y, z, label]), fmt="%.3f %.3f %.3f %d")
    db = str(tmp_path / "a.tdb")
    runner = CliRunner()
    common = ["ingest", str(src), "--db", db, "--crs", "EPSG:32632"]
    assert runner.invoke(main, [*common, "--version", "asprs"]).exit_code == 0
    r = runner.invoke(main, [*common, "--version", "isprs", "--labels", "isprs"])
    assert r.exit_code == 0, r.output
    with tdb.open(db) as d:
        assert d.version("asprs").stats.excluded_points == int((label == 7).sum())
        assert d.version("isprs").stats.excluded_points == 0


def test_ingest_takes_crs_for_a_point_cloud(plane, tmp_path):
    x, y, z, _ = plane
    cloud = from_arrays(x, y, z)
    with tdb.open(tmp_path / "a.tdb", create=True) as db:
        with pytest.raises(CRSError) as info:
            ingest(cloud, db, version="none")
        assert info.value.remedy is Remedy.GIVE_CRS
        ingest(cloud, db, version="utm", options=IngestOptions(crs="EPSG:32632"))
        assert db.crs("utm").to_epsg() == 32632


def test_library_messages_name_no_flags_and_the_cli_phrases_the_remedy(plane, tmp_path):
    x, y, z, _ = plane
    path = tmp_path / "a.tdb"
    with tdb.open(path, create=True) as db:
        ingest(from_arrays(x, y, z, crs="EPSG:32632"), db, version="v")
        with pytest.raises(VersionExistsError) as info:
            ingest(from_arrays(x, y, z, crs="EPSG:32632"), db, version="v")
    assert "--" not in str(info.value) and info.value.remedy is Remedy.REPLACE
    src = tmp_path / "p.txt"
    np.savetxt(src, np.column_stack([x, y, z]))
    r = CliRunner().invoke(main, ["ingest", str(src), "--db", str(path), "--version", "v", "--crs", "EPSG:32632"])
    assert r.exit_code == 1
    assert "--replace" in r.stderr and "Traceback" not in r.stderr
    r = CliRunner().invoke(main, ["ingest", str(src), "--db", str(path), "--version", "w"])
    assert r.exit_code == 1 and "--crs" in r.stderr


def test_write_version_reports_its_rows(plane, tmp_path):
    calls: list[tuple[str, int, int]] = []
    levels = {2: (np.array([0, 2]), np.array([0, 0]), np.array([0, 0], np.uint8))}
    pts = (np.array([0.0, 1.0, 2.0]), np.array([0.0, 0.0, 1.0]), np.array([1.0, 2.0, 3.0]), np.ones(3, np.uint8))
    with tdb.open(tmp_path / "a.tdb", create=True) as db:
        db.write_version("v", levels=levels, points=pts, progress=lambda *a: calls.append(a))
    assert calls[0] == ("database", 0, 5) and calls[-1] == ("database", 5, 5)


def test_ingest_tells_every_step_to_one_progress_callable(plane, tmp_path):
    x, y, z, _ = plane
    steps: list[str] = []
    with tdb.open(tmp_path / "a.tdb", create=True) as db:
        ingest(from_arrays(x, y, z, crs="EPSG:32632"), db, version="v", progress=lambda s, d, t: steps.append(s))
    order = list(dict.fromkeys(steps))
    assert order == [
        *("read", "units", "ground filter", "dense model", "categories and reduction"),
        *("vegetation and buildings", "buildings", "trees", "database"),
    ]


def test_categories_with_a_too_small_subgrid_is_a_clean_error(tmp_path):
    r = CliRunner().invoke(main, ["categories", "--atlas", str(tmp_path / "a.png"), "--subgrid", "3"])
    assert r.exit_code == 1
    assert r.stderr.startswith("tdb: error:") and "Traceback" not in r.stderr
    assert not (tmp_path / "a.png").exists()


def test_version_stats_round_trip_their_json():
    from tdb.stats import ReductionStats, VersionStats

    s = VersionStats(
        reduction=ReductionStats(10, 5, 4, 60.0, 0.05, 0.3, {2: 7, 4: 2}, {2: 1, 4: 0}),
        points=20,
        ground_points=12,
        kept_user_classes={65: 3},
        noise_m=0.02,
        bounds=(0.0, 1.0, 2.0, 3.0),
    )
    doc = s.to_json()
    assert doc["tiles_2m"] == 7 and doc["kept_user_classes"] == {"65": 3}
    assert VersionStats.from_json(doc) == s


def test_measure_has_one_sign_convention():
    from tdb.options import Measure, parse

    assert parse(Measure, "Depth") is Measure.DEPTH
    # relief is height times sign: a ditch 0.5 m below its banks has relief +0.5
    assert Measure.DEPTH.sign * (9.5 - 10.0) == 0.5
    assert Measure.HEIGHT.sign * (10.5 - 10.0) == 0.5


def test_filter_defaults_are_the_schemas():
    from dataclasses import fields

    from queries.filters import Filter, _schema

    defaults = {f.name: f.default for f in fields(Filter)}
    props = _schema()["properties"]
    stated = {k: v["default"] for k, v in props.items() if "default" in v}
    assert stated, "the schema states no defaults"
    for key, value in stated.items():
        assert defaults[key] == value, key
    import json
    from pathlib import Path

    from tdb.tiles import LEVELS

    shipped = json.loads((Path(__file__).parents[1] / "schemas" / "filter.schema.json").read_text())
    assert shipped["properties"]["level"]["enum"] == props["level"]["enum"] == list(LEVELS)


def test_feature_collections_name_their_crs_by_epsg_urn():
    import shapely
    from pyproj import CRS

    from tdb.geojson import feature, feature_collection

    f = feature(shapely.Point(1, 2), {"kind": "tree"})
    assert f["geometry"] == {"type": "Point", "coordinates": (1.0, 2.0)}
    doc = feature_collection([f], CRS.from_epsg(25832))
    assert doc["crs"]["properties"]["name"] == "urn:ogc:def:crs:EPSG::25832"
    assert feature_collection([f], "EPSG:2154")["crs"]["properties"]["name"].endswith("::2154")
    assert "crs" not in feature_collection([f], None)
    # a compound CRS with no one code (UTM 17N on NAD83 with CGVD28 heights): its horizontal part's,
    # so that GIS tools do not read UTM metres as degrees
    compound = CRS.from_user_input("EPSG:26917+5713")
    assert compound.to_epsg() is None
    assert feature_collection([f], compound)["crs"]["properties"]["name"] == "urn:ogc:def:crs:EPSG::26917"


def test_geojson_holds_no_nan():
    import json

    import shapely

    from tdb.geojson import feature, feature_collection

    f = feature(shapely.Point(1, 2), {"depth": float("nan"), "width": 2.5, "sides": [float("inf"), 1.0]})
    doc = feature_collection([f], None, members={"coregistration": {"nmad": float("nan")}})
    text = json.dumps(doc, allow_nan=False)  # raises on NaN
    back = json.loads(text)
    assert back["features"][0]["properties"] == {"depth": None, "width": 2.5, "sides": [None, 1.0]}
    assert back["coregistration"] == {"nmad": None}
