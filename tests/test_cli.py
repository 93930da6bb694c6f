"""The command line: help with examples, versions, one-line errors, --debug."""

from __future__ import annotations

import re

import numpy as np
import pytest
from click.testing import CliRunner

from tdb import __version__
from tdb.cli import main


@pytest.fixture
def runner():
    return CliRunner()


def test_version(runner):
    result = runner.invoke(main, ["--version"])
    assert result.exit_code == 0 and __version__ in result.output


def test_every_command_has_help_with_examples(runner):
    assert main.commands, "no subcommands registered"
    for name in main.commands:
        result = runner.invoke(main, [name, "--help"])
        assert result.exit_code == 0, name
        assert "Example" in result.output, f"{name} --help has no example"


def test_error_is_one_line_and_nonzero(runner, tmp_path):
    result = runner.invoke(main, ["info", str(tmp_path / "missing.laz")])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tdb: error:") and "Traceback" not in result.stderr


def test_debug_shows_traceback(runner, tmp_path):
    result = runner.invoke(main, ["--debug", "info", str(tmp_path / "missing.laz")])
    assert result.exit_code == 1
    assert "Traceback" in result.stderr


def test_synth_then_info(runner, tmp_path):
    out = tmp_path / "s.laz"
    result = runner.invoke(
        main,
        ["synth", "--size", "100", "--density", "1", "--out", str(out), "--truth", str(tmp_path / "t.geojson")],
    )
    assert result.exit_code == 0, result.output
    info = runner.invoke(main, ["info", str(out), "--json"])
    assert info.exit_code == 0
    import json

    facts = json.loads(info.output)
    assert facts["epsg"] == 25832 and facts["points"] > 5000


def test_bad_option_value_is_clean(runner, tmp_path):
    result = runner.invoke(main, ["synth", "--size", "5", "--out", str(tmp_path / "x.laz")])
    assert result.exit_code == 1
    assert "scene size" in result.stderr


def test_ground_command(runner, tmp_path):
    src = tmp_path / "s.laz"
    assert runner.invoke(main, ["synth", "--size", "100", "--density", "1", "--out", str(src)]).exit_code == 0
    out, dtm = tmp_path / "g.laz", tmp_path / "d.tif"
    result = runner.invoke(main, ["ground", str(src), "--out", str(out), "--dtm", str(dtm)])
    assert result.exit_code == 0, result.output
    from ingest.readers import read

    a, b = read(src), read(out)
    np.testing.assert_allclose(a.xyz, b.xyz, atol=1e-3)  # same points, same order
    # ASPRS noise (class 7 in synthetic scenes) keeps its class; the rest is ground or not
    assert set(np.unique(b.classification)) <= {1, 2, 7}
    np.testing.assert_array_equal(a.classification == 7, b.classification == 7)
    agree = ((a.classification == 2) == (b.classification == 2)).mean()
    assert agree > 0.95
    assert dtm.exists()


@pytest.fixture(scope="module")
def ingested(tmp_path_factory):
    """A 100 m synthetic scene ingested by the command line as version v1: (source, database)."""
    tmp = tmp_path_factory.mktemp("cli")
    runner = CliRunner()
    src = tmp / "s.laz"
    assert runner.invoke(main, ["synth", "--size", "100", "--density", "1", "--out", str(src)]).exit_code == 0
    db = tmp / "a.tdb"
    r = runner.invoke(main, ["ingest", str(src), "--db", str(db), "--version", "v1", "--date", "2021-05-01"])
    assert r.exit_code == 0, r.output
    # the summary: points, area, time and memory
    from ingest.readers import read

    summary = rf"^{len(read(src)):,} points, 0\.01 km² in [0-9.,]+ s \([0-9,]+ points/s\), peak memory"
    assert re.search(summary, r.output, re.M), r.output
    return src, db


def test_ingest_refuses_an_existing_version_and_bad_classes(runner, ingested):
    src, db = ingested
    again = runner.invoke(main, ["ingest", str(src), "--db", str(db), "--version", "v1"])
    assert again.exit_code == 1 and "exists" in again.stderr
    r = runner.invoke(main, ["ingest", str(src), "--db", str(db), "--version", "v2", "--exclude-classes", "x"])
    assert r.exit_code != 0 and "class codes" in r.output


def test_info_reports_what_ingest_stored(runner, ingested):
    import json

    from ingest.readers import read

    src, db = ingested
    doc = json.loads(runner.invoke(main, ["info", str(db), "--json"]).output)
    assert doc["versions"][0]["name"] == "v1" and doc["versions"][0]["acquired"] == "2021-05-01"
    assert doc["versions"][0]["params"]["exclude_classes"] == [7, 18]
    noise = int((read(src).classification == 7).sum())
    assert noise > 0 and doc["versions"][0]["stats"]["excluded_points"] == noise
    text = runner.invoke(main, ["info", str(db)])
    assert text.exit_code == 0 and "tiles 2/4/8/16 m: 2500/625/" in text.output
    deep = doc["versions"][0]["stats"]["deep_pct"]
    assert 0 <= deep <= 100 and f"returns saw in {deep} % of the" in text.output


def test_aoi_writes_mesh_surface_and_picture(runner, ingested, tmp_path):
    _, db = ingested
    out = tmp_path / "area"
    r = runner.invoke(main, ["aoi", "--db", str(db), "--bbox", "500010,5500010,500060,5500060", "--out", str(out)])
    assert r.exit_code == 0, r.output
    for suffix in (".ply", ".tif", ".png"):
        assert out.with_suffix(suffix).stat().st_size > 100
    assert out.with_suffix(".ply").read_text().startswith("ply")


def test_categories_are_listed_and_drawn(runner, tmp_path):
    r = runner.invoke(main, ["categories"])
    assert r.exit_code == 0 and len(r.output.strip().splitlines()) == 115
    r = runner.invoke(main, ["categories", "--atlas", str(tmp_path / "atlas.png")])
    assert r.exit_code == 0 and (tmp_path / "atlas.png").read_bytes()[:4] == b"\x89PNG"


def test_query_results_as_geojson_and_geopackage_agree(runner, ingested, tmp_path):
    """The same tiles as GeoJSON on stdout and as a GeoPackage that GDAL reads, in the survey's CRS."""
    import json

    import pyogrio
    import pyogrio.raw
    from pyproj import CRS

    _, db = ingested
    text = "SELECT tiles FROM v1 WHERE bbox(500010, 5500010, 500030, 5500030)"
    r = runner.invoke(main, ["query", text, "--db", str(db)])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    r = runner.invoke(main, ["query", text, "--db", str(db), "--format", "gpkg"])
    assert r.exit_code != 0 and "--out" in r.output
    gpkg = tmp_path / "tiles.gpkg"
    r = runner.invoke(main, ["query", text, "--db", str(db), "--format", "gpkg", "--out", str(gpkg)])
    assert r.exit_code == 0, r.output
    meta, _, geometry, fields = pyogrio.raw.read(gpkg, layer="tiles")
    assert CRS.from_user_input(meta["crs"]).to_epsg() == int(doc["crs"]["properties"]["name"].split(":")[-1])
    assert len(geometry) == len(doc["features"]) == 100
    categories = dict(zip(meta["fields"], fields))["category"]
    assert list(categories) == [f["properties"]["category"] for f in doc["features"]]
    more = ["query", "SELECT ditch FROM v1", "--db", str(db), "--format", "gpkg", "--out", str(gpkg)]
    r = runner.invoke(main, [*more, "--layer", "ditches", "--append"])
    assert r.exit_code == 0, r.output
    assert {name for name, _ in pyogrio.list_layers(gpkg)} == {"tiles", "ditches"}
    r = runner.invoke(main, ["query", text, "--db", str(db), "--layer", "x"])
    assert r.exit_code != 0 and "belong to --format gpkg" in r.output


def test_query_and_diff_take_a_number_of_workers(runner, ingested):
    _, db = ingested
    r = runner.invoke(main, ["query", "SELECT ditch FROM v1", "--db", str(db), "--workers", "1"])
    assert r.exit_code == 0, r.output
    for command in (["query", "SELECT ditch FROM v1"], ["diff", "v1", "v1"]):
        r = runner.invoke(main, [*command, "--db", str(db), "--workers", "0"])
        assert r.exit_code == 2 and "--workers" in r.output


def test_query_draws_its_results(runner, ingested, tmp_path):
    _, db = ingested
    text = "SELECT tiles FROM v1 WHERE bbox(500010, 5500010, 500030, 5500030)"
    png = tmp_path / "tiles.png"
    r = runner.invoke(main, ["query", text, "--db", str(db), "--png", str(png), "--out", str(tmp_path / "t.json")])
    assert r.exit_code == 0, r.output
    assert png.read_bytes()[:4] == b"\x89PNG" and "map" in r.stderr


def test_bad_date_and_bbox(runner, tmp_path):
    r = runner.invoke(
        main, ["ingest", "x.laz", "--db", str(tmp_path / "a.tdb"), "--version", "v", "--date", "31/12"]
    )
    assert r.exit_code != 0 and "date" in r.output
    r = runner.invoke(main, ["aoi", "--db", str(tmp_path / "a.tdb"), "--bbox", "3,3,1,1"])
    assert r.exit_code != 0 and "x0 < x1" in r.output
