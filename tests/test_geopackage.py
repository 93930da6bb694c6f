"""GeoPackage output: read back by GDAL (pyogrio) and checked against the spec's binary header."""

from __future__ import annotations

import sqlite3
import struct

import numpy as np
import pyogrio.raw
import pytest
import shapely
from pyproj import CRS

from tdb.errors import InputError
from tdb.geopackage import write_geopackage

APPLICATION_ID = 0x47504B47  # "GPKG"
CUSTOM_SRS = 100000  # GDAL's first id for a CRS without an EPSG code
LAMBERT_93_AS_DELIVERED = (  # as pyproj reads an IGN LiDAR HD file's header
    'PROJCRS["RGF93 / Lambert-93",BASEGEOGCRS["RGF93",DATUM["Reseau Geodesique Francais 1993",'
    'ELLIPSOID["GRS 1980",6378137,298.2572221,LENGTHUNIT["metre",1]]],'
    'PRIMEM["Greenwich",0,ANGLEUNIT["degree",0.0174532925199433]],ID["EPSG",4171]],'
    'CONVERSION["Lambert-93",METHOD["Lambert Conic Conformal (2SP)",ID["EPSG",9802]],'
    'PARAMETER["Latitude of false origin",46.5,ANGLEUNIT["degree",0.0174532925199433]],'
    'PARAMETER["Longitude of false origin",3,ANGLEUNIT["degree",0.0174532925199433]],'
    'PARAMETER["Latitude of 1st standard parallel",49,ANGLEUNIT["degree",0.0174532925199433]],'
    'PARAMETER["Latitude of 2nd standard parallel",44,ANGLEUNIT["degree",0.0174532925199433]],'
    'PARAMETER["Easting at false origin",700000,LENGTHUNIT["metre",1]],'
    'PARAMETER["Northing at false origin",6600000,LENGTHUNIT["metre",1]]],'
    'CS[Cartesian,2],AXIS["easting (X)",east,ORDER[1],LENGTHUNIT["metre",1]],'
    'AXIS["northing (Y)",north,ORDER[2],LENGTHUNIT["metre",1]],ID["EPSG",2154]]'
)

FEATURES = [
    {
        "type": "Feature",
        "geometry": shapely.geometry.mapping(shapely.LineString([(500000, 5500000), (500010.5, 5500003)])),
        "properties": {"kind": "ditch", "tiles": 7, "length": 10.92, "depth": 0.61},
    },
    {
        "type": "Feature",
        "geometry": shapely.geometry.mapping(
            shapely.MultiLineString(
                [[(500020, 5500020), (500030, 5500020)], [(500030, 5500020), (500030, 5500031)]]
            )
        ),
        "properties": {"kind": "ditch", "tiles": 12, "length": 21.0, "depth": None, "shoulder": 0.4},
    },
    {
        "type": "Feature",
        "geometry": shapely.geometry.mapping(shapely.box(500040, 5500040, 500044, 5500042)),
        "properties": {"kind": "pit", "tiles": 2, "length": 0, "depth": 1.25},
    },
]


def _parse_blob(blob: bytes) -> tuple[int, tuple[float, ...] | None, shapely.Geometry]:
    assert blob[:2] == b"GP" and blob[2] == 0
    flags = blob[3]
    order = "<" if flags & 1 else ">"
    (srs_id,) = struct.unpack(order + "i", blob[4:8])
    envelope = (flags >> 1) & 0b111
    if envelope == 0:
        return srs_id, None, shapely.from_wkb(blob[8:])
    assert envelope == 1  # xy
    env = struct.unpack(order + "4d", blob[8:40])
    return srs_id, env, shapely.from_wkb(blob[40:])


def test_gdal_reads_back_layer_geometry_attributes_and_crs(tmp_path):
    path = tmp_path / "out.gpkg"
    write_geopackage(path, {"ditch": FEATURES, "empty_layer": []}, crs=CRS.from_epsg(25832))
    layers = {name for name, _ in pyogrio.list_layers(path)}
    assert layers == {"ditch", "empty_layer"}
    meta, _, geometry, fields = pyogrio.raw.read(path, layer="ditch")
    assert CRS.from_user_input(meta["crs"]).to_epsg() == 25832
    assert list(meta["fields"]) == ["kind", "tiles", "length", "depth", "shoulder"]
    for f, wkb in zip(FEATURES, geometry):
        assert shapely.from_wkb(wkb).equals(shapely.geometry.shape(f["geometry"]))
    columns = dict(zip(meta["fields"], fields))
    assert list(columns["kind"]) == ["ditch", "ditch", "pit"]
    assert list(columns["tiles"]) == [7, 12, 2]
    assert np.isnan(columns["depth"][1]) and columns["depth"][2] == pytest.approx(1.25)
    assert np.isnan(columns["shoulder"][0]) and columns["shoulder"][1] == pytest.approx(0.4)
    info = pyogrio.read_info(path, layer="ditch")
    assert info["geometry_type"] == "Unknown"  # mixed lines and a polygon: a generic column
    assert info["total_bounds"] == pytest.approx((500000, 5500000, 500044, 5500042))


def test_metadata_tables_follow_the_spec(tmp_path):
    path = tmp_path / "out.gpkg"
    write_geopackage(path, {"pit": FEATURES[2:]}, crs=CRS.from_epsg(32632))
    con = sqlite3.connect(path)
    try:
        assert con.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID
        srs = {r[0] for r in con.execute("SELECT srs_id FROM gpkg_spatial_ref_sys")}
        assert srs == {4326, -1, 0, 32632}
        kind, srs_id = con.execute("SELECT geometry_type_name, srs_id FROM gpkg_geometry_columns").fetchone()
        assert (kind, srs_id) == ("POLYGON", 32632)
        (stamp,) = con.execute("SELECT last_change FROM gpkg_contents").fetchone()
        assert len(stamp) == 24 and stamp.endswith("Z")  # YYYY-MM-DDTHH:MM:SS.SSSZ
        (blob,) = con.execute("SELECT geom FROM pit").fetchone()
    finally:
        con.close()
    srs_id, env, geom = _parse_blob(blob)
    assert srs_id == 32632 and env == (500040, 500044, 5500040, 5500042)
    assert geom.equals(shapely.box(500040, 5500040, 500044, 5500042))


def test_single_and_multi_parts_make_one_multi_layer(tmp_path):
    write_geopackage(tmp_path / "l.gpkg", {"ditch": FEATURES[:2]}, crs=CRS.from_epsg(25832))
    assert pyogrio.read_info(tmp_path / "l.gpkg", layer="ditch")["geometry_type"] == "MultiLineString"
    _, _, geometry, _ = pyogrio.raw.read(tmp_path / "l.gpkg", layer="ditch")
    first = shapely.from_wkb(geometry[0])
    assert first.geom_type == "MultiLineString" and first.equals(shapely.geometry.shape(FEATURES[0]["geometry"]))


def test_append_adds_and_replaces_layers(tmp_path):
    path = tmp_path / "a.gpkg"
    write_geopackage(path, {"ditch": FEATURES[:2]}, crs=CRS.from_epsg(25832), append=True)  # new file
    write_geopackage(path, {"pit": FEATURES[2:]}, crs=CRS.from_epsg(25832), append=True)
    assert {name for name, _ in pyogrio.list_layers(path)} == {"ditch", "pit"}
    write_geopackage(path, {"ditch": FEATURES[:1]}, crs=CRS.from_epsg(25832), append=True)
    assert pyogrio.read_info(path, layer="ditch")["features"] == 1  # replaced, not doubled
    assert pyogrio.read_info(path, layer="pit")["features"] == 1
    local = CRS.from_proj4("+proj=tmerc +lon_0=9.5 +x_0=200000 +ellps=GRS80 +units=m")
    write_geopackage(path, {"local": FEATURES[:1]}, crs=local, append=True)
    write_geopackage(path, {"local2": FEATURES[:1]}, crs=local, append=True)  # same CRS, same row
    con = sqlite3.connect(path)
    custom = con.execute("SELECT COUNT(*) FROM gpkg_spatial_ref_sys WHERE srs_id >= ?", (CUSTOM_SRS,)).fetchone()
    assert custom[0] == 1
    con.close()
    other = tmp_path / "not.gpkg"
    other.write_text("a text file")
    with pytest.raises(InputError, match="not a GeoPackage"):
        write_geopackage(other, {"ditch": FEATURES}, crs=None, append=True)
    assert other.read_text() == "a text file"


def test_crs_without_epsg_code_and_no_crs(tmp_path):
    local = CRS.from_proj4("+proj=tmerc +lat_0=0 +lon_0=9.5 +k=1 +x_0=200000 +y_0=0 +ellps=GRS80 +units=m")
    write_geopackage(tmp_path / "a.gpkg", {"x": FEATURES}, crs=local)
    meta, *_ = pyogrio.raw.read(tmp_path / "a.gpkg")
    assert CRS.from_user_input(meta["crs"]).equals(local, ignore_axis_order=True)
    con = sqlite3.connect(tmp_path / "a.gpkg")
    assert con.execute("SELECT srs_id FROM gpkg_geometry_columns").fetchone()[0] == CUSTOM_SRS
    con.close()
    write_geopackage(tmp_path / "b.gpkg", {"x": FEATURES}, crs=None)
    meta, *_ = pyogrio.raw.read(tmp_path / "b.gpkg")
    assert meta["crs"] is None


def test_a_failed_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "out.gpkg"
    write_geopackage(path, {"ditch": FEATURES}, crs=None)
    before = path.read_bytes()
    bad = [{"type": "Feature", "geometry": FEATURES[0]["geometry"], "properties": {"depth (m)": 1.0}}]
    with pytest.raises(InputError, match="letters, digits"):
        write_geopackage(path, {"ditch": bad}, crs=None)
    with pytest.raises(InputError, match="layer name"):
        write_geopackage(path, {"two words": FEATURES}, crs=None)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.gpkg"]  # no temporary file left


def test_a_crs_that_is_an_epsg_code_is_written_as_that_code_without_gdal_warnings(tmp_path):
    """A LAS header's WKT (IGN LiDAR HD's) that names EPSG:2154 with an older datum name and its
    flattening rounded is EPSG:2154 to pyproj; GDAL would call it incompatible, warn, and write
    a custom CRS."""
    import warnings

    rounded = CRS.from_wkt(LAMBERT_93_AS_DELIVERED)
    assert rounded.to_wkt() != CRS.from_epsg(2154).to_wkt() and rounded.equals(CRS.from_epsg(2154))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        write_geopackage(tmp_path / "a.gpkg", {"x": FEATURES}, crs=rounded)
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)]
    con = sqlite3.connect(tmp_path / "a.gpkg")
    assert con.execute("SELECT srs_id FROM gpkg_geometry_columns").fetchone()[0] == 2154
    con.close()
