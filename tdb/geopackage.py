"""Write features to an OGC GeoPackage (1.4), the single-file vector format QGIS opens natively.

A GeoPackage is an SQLite file with three metadata tables (spatial reference
systems, contents, geometry columns) and one table per layer whose geometry
column holds a GeoPackage binary: a short header (magic ``GP``, flags, SRS id,
envelope) followed by ISO WKB. Written here with the standard library's sqlite3
and shapely, so no GDAL is needed.
"""

from __future__ import annotations

import datetime as dt
import os
import re
import shutil
import sqlite3
import struct
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import shapely

from tdb.errors import InputError

APPLICATION_ID = 0x47504B47  # "GPKG"
USER_VERSION = 10400  # GeoPackage 1.4.0
UNDEFINED_CARTESIAN = -1
CUSTOM_SRS = 100000  # first id for a CRS without an EPSG code; ids below are EPSG's
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")

_BASE_SRS = [  # the three rows every GeoPackage must hold (spec 1.1.2.1.2)
    (
        "WGS 84 geodetic",
        4326,
        "EPSG",
        4326,
        'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
        'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]]',
        "longitude/latitude coordinates in decimal degrees on the WGS 84 spheroid",
    ),
    ("Undefined cartesian SRS", -1, "NONE", -1, "undefined", "undefined cartesian coordinate reference system"),
    ("Undefined geographic SRS", 0, "NONE", 0, "undefined", "undefined geographic coordinate reference system"),
]


def write_geopackage(
    path: str | os.PathLike[str],
    layers: Mapping[str, Sequence[dict[str, Any]]],
    *,
    crs: Any,
    append: bool = False,
) -> None:
    """Write GeoJSON-like features to ``path`` as a GeoPackage, one table per layer.

    The file is written beside ``path`` and moved into place at the end, so an
    existing file is replaced whole (or, with ``append``, extended) or left as it was.

    Parameters
    ----------
    path : the ``.gpkg`` file to write.
    layers : layer name → features (dicts with ``geometry`` as a GeoJSON mapping and
        ``properties``). Names are letters, digits and underscores.
    crs : a pyproj CRS (or None: undefined Cartesian coordinates).
    append : add the layers to an existing GeoPackage (a layer of the same name is replaced)
        instead of writing a new file.

    Raises
    ------
    InputError
        If a layer or attribute name is not a plain identifier, or ``append`` names a file
        that is not a GeoPackage.
    """
    for name in layers:
        _check_name(name, "layer")
    target = Path(path)
    extend = append and target.exists()
    if extend and not is_geopackage(target):
        raise InputError(f"{target}: not a GeoPackage; cannot add layers to it")
    fd, tmp = tempfile.mkstemp(suffix=".gpkg", dir=target.parent)
    os.close(fd)
    try:
        if extend:
            shutil.copyfile(target, tmp)
        con = sqlite3.connect(tmp)
        try:
            with con:
                if not extend:
                    _create(con)
                srs_id = _srs(con, crs)
                for name, features in layers.items():
                    _drop_layer(con, name)
                    _write_layer(con, name, features, srs_id)
        finally:
            con.close()
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def is_geopackage(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an SQLite file with GeoPackage contents."""
    try:
        con = sqlite3.connect(f"file:{Path(path).resolve()}?mode=ro", uri=True)
        try:
            return con.execute("SELECT 1 FROM sqlite_master WHERE name = 'gpkg_contents'").fetchone() is not None
        finally:
            con.close()
    except sqlite3.DatabaseError:
        return False


def _drop_layer(con: sqlite3.Connection, name: str) -> None:
    known = con.execute("SELECT 1 FROM gpkg_contents WHERE table_name = ?", (name,)).fetchone()
    if known:
        con.execute("DELETE FROM gpkg_geometry_columns WHERE table_name = ?", (name,))
        con.execute("DELETE FROM gpkg_contents WHERE table_name = ?", (name,))
        con.execute(f'DROP TABLE IF EXISTS "{name}"')


def _check_name(name: str, what: str) -> None:
    if not NAME.fullmatch(name):
        raise InputError(f"GeoPackage {what} name {name!r} must be letters, digits and underscores")


def _create(con: sqlite3.Connection) -> None:
    con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
    con.execute(f"PRAGMA user_version = {USER_VERSION}")
    con.execute(
        "CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY,"
        " organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL,"
        " definition TEXT NOT NULL, description TEXT)"
    )
    con.execute(
        "CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL,"
        " identifier TEXT UNIQUE, description TEXT DEFAULT '', last_change DATETIME NOT NULL"
        " DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')), min_x DOUBLE, min_y DOUBLE, max_x DOUBLE,"
        " max_y DOUBLE, srs_id INTEGER REFERENCES gpkg_spatial_ref_sys(srs_id))"
    )
    con.execute(
        "CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL,"
        " geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL,"
        " CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name),"
        " CONSTRAINT fk_gc_tn FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name),"
        " CONSTRAINT fk_gc_srs FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys (srs_id))"
    )
    con.executemany("INSERT INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)", _BASE_SRS)


def _srs(con: sqlite3.Connection, crs: Any) -> int:
    """The srs_id of ``crs``, its row added where the file lacks it."""
    if crs is None:
        return UNDEFINED_CARTESIAN
    epsg = crs.to_epsg()
    wkt = crs.to_wkt("WKT1_GDAL")
    if epsg:
        srs_id = int(epsg)
    else:  # the same custom CRS again reuses its row; another one gets the next free id
        row = con.execute("SELECT srs_id FROM gpkg_spatial_ref_sys WHERE definition = ?", (wkt,)).fetchone()
        if row:
            return int(row[0])
        (top,) = con.execute(
            "SELECT MAX(srs_id) FROM gpkg_spatial_ref_sys WHERE srs_id >= ?", (CUSTOM_SRS,)
        ).fetchone()
        srs_id = CUSTOM_SRS if top is None else int(top) + 1
    con.execute(
        "INSERT OR IGNORE INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)",
        (crs.name, srs_id, "EPSG" if epsg else "NONE", srs_id, wkt, ""),
    )
    return srs_id


def _column_type(values: list[Any]) -> str:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return "BOOLEAN"
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "INTEGER"
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return "DOUBLE"
    return "TEXT"


def _write_layer(con: sqlite3.Connection, name: str, features: Sequence[dict[str, Any]], srs_id: int) -> None:
    geoms = [shapely.geometry.shape(f["geometry"]) if f.get("geometry") else None for f in features]
    kinds = {g.geom_type for g in geoms if g is not None}
    multi = {"LineString": shapely.MultiLineString, "Polygon": shapely.MultiPolygon, "Point": shapely.MultiPoint}
    for single, many in multi.items():
        if kinds == {single, many.__name__}:  # one type for the layer, as GIS layers expect
            geoms = [many([g]) if g is not None and g.geom_type == single else g for g in geoms]
    keys: list[str] = []
    for f in features:
        keys += [k for k in f.get("properties", {}) if k not in keys]
    for k in keys:
        _check_name(k, "attribute")
    if {k.lower() for k in keys} & {"fid", "geom"}:
        raise InputError(f"layer {name!r}: attribute names 'fid' and 'geom' are taken by the GeoPackage")
    types = {k: _column_type([f.get("properties", {}).get(k) for f in features]) for k in keys}
    columns = "".join(f', "{k}" {types[k]}' for k in keys)
    con.execute(f'CREATE TABLE "{name}" (fid INTEGER PRIMARY KEY AUTOINCREMENT, geom GEOMETRY{columns})')
    rows = []
    for f, g in zip(features, geoms):
        props = f.get("properties", {})
        values = [props.get(k) for k in keys]
        values = [v if types[k] != "TEXT" or v is None else str(v) for k, v in zip(keys, values)]
        rows.append((None if g is None else _blob(g, srs_id), *values))
    marks = ", ".join("?" * (len(keys) + 1))
    names = "".join(f', "{k}"' for k in keys)
    con.executemany(f'INSERT INTO "{name}" (geom{names}) VALUES ({marks})', rows)
    kinds = {g.geom_type.upper() for g in geoms if g is not None}  # after promotion to multi types
    extent = shapely.GeometryCollection([g for g in geoms if g is not None and not g.is_empty]).bounds
    con.execute(
        "INSERT INTO gpkg_contents (table_name, data_type, identifier, last_change, min_x, min_y, max_x, max_y,"
        " srs_id) VALUES (?, 'features', ?, ?, ?, ?, ?, ?, ?)",
        (name, name, _now(), *extent, srs_id),
    )
    con.execute(
        "INSERT INTO gpkg_geometry_columns VALUES (?, 'geom', ?, ?, 0, 0)",
        (name, kinds.pop() if len(kinds) == 1 else "GEOMETRY", srs_id),
    )


def _now() -> str:
    """UTC time as the spec writes it: YYYY-MM-DDTHH:MM:SS.SSSZ."""
    return dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def _blob(geom: shapely.Geometry, srs_id: int) -> bytes:
    """GeoPackage binary: header (spec 2.1.3) then little-endian WKB."""
    wkb = shapely.to_wkb(geom, byte_order=1, output_dimension=2)  # 2D: ISO and extended WKB agree
    if geom.is_empty:  # no envelope; the empty flag (bit 4) set
        return b"GP" + struct.pack("<BBi", 0, 0b00010001, srs_id) + wkb
    x0, y0, x1, y1 = geom.bounds
    # flags: little endian (bit 0), envelope [minx, maxx, miny, maxy] (indicator 1 in bits 1-3)
    return b"GP" + struct.pack("<BBi4d", 0, 0b00000011, srs_id, x0, x1, y0, y1) + wkb
