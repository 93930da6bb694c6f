"""Write features to an OGC GeoPackage, the single-file vector format QGIS opens natively.

Written through GDAL's GPKG driver (pyogrio), one layer per feature kind. A layer takes one
geometry type, as GIS layers expect: a mix of single and multi parts is promoted to the multi type.
"""

from __future__ import annotations

import os
import re
import shutil
import sqlite3
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from tdb.atomic import atomic_path
from tdb.crs import exact_epsg
from tdb.errors import InputError, TdbWarning

NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_MULTI = {"LineString": "MultiLineString", "Polygon": "MultiPolygon", "Point": "MultiPoint"}


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
    crs : a pyproj CRS (or None: coordinates in no declared system).
    append : add the layers to an existing GeoPackage (a layer of the same name is replaced)
        instead of writing a new file.

    Raises
    ------
    InputError
        If a layer or attribute name is not a plain identifier, or ``append`` names a file
        that is not a GeoPackage.
    TdbIOError
        If the file cannot be written.
    """
    import pyogrio.errors

    for name in layers:
        _check_name(name, "layer")
    target = Path(path)
    extend = append and target.exists()
    if extend and not is_geopackage(target):
        raise InputError(f"{target}: not a GeoPackage; cannot add layers to it")
    wkt = None if crs is None else _srs(crs)
    with atomic_path(target, errors=(pyogrio.errors.DataSourceError, pyogrio.errors.DataLayerError)) as tmp:
        if extend:
            shutil.copyfile(target, tmp)
        for name, features in layers.items():
            _write_layer(tmp, name, features, wkt)


def _srs(crs: Any) -> str:
    """The CRS as GDAL is to record it: by its EPSG code where it is that code's CRS (GDAL then
    writes the register's definition, which QGIS knows by name), else by its own WKT."""
    code = exact_epsg(crs)
    return f"EPSG:{code}" if code is not None else str(crs.to_wkt())


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


def _check_name(name: str, what: str) -> None:
    if not NAME.fullmatch(name):
        raise InputError(f"GeoPackage {what} name {name!r} must be letters, digits and underscores")


def _write_layer(path: Path, name: str, features: Sequence[dict[str, Any]], wkt: str | None) -> None:
    from pyogrio.raw import write

    geoms = [shapely.geometry.shape(f["geometry"]) if f.get("geometry") else None for f in features]
    kinds = {g.geom_type for g in geoms if g is not None}
    for single, many in _MULTI.items():
        if kinds == {single, many}:
            geoms = [getattr(shapely, many)([g]) if g is not None and g.geom_type == single else g for g in geoms]
            kinds = {many}
    keys: list[str] = []
    for f in features:
        keys += [k for k in f.get("properties", {}) if k not in keys]
    for k in keys:
        _check_name(k, "attribute")
    if {k.lower() for k in keys} & {"fid", "geom"}:
        raise InputError(f"layer {name!r}: attribute names 'fid' and 'geom' are taken by the GeoPackage")
    columns = [_column([f.get("properties", {}).get(k) for f in features]) for k in keys]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        write(
            str(path),
            np.array([None if g is None else shapely.to_wkb(g, output_dimension=2) for g in geoms], dtype=object),
            columns,
            fields=keys,
            layer=name,
            driver="GPKG",
            crs=wkt,
            geometry_type=kinds.pop() if len(kinds) == 1 else "Unknown",
            promote_to_multi=False,
        )
    for w in caught:
        _pass_on(w, name)


def _pass_on(w: warnings.WarningMessage, layer: str) -> None:
    """GDAL's warnings while writing, said as tdb says things, or passed on as they came."""
    text = str(w.message)
    if issubclass(w.category, UserWarning):
        return  # pyogrio's: no CRS, which is what the caller asked for
    official = re.search(r"uses (\S+) identification, but its definition is not compatible", text)
    if official:
        warnings.warn(
            f"layer {layer!r}: GDAL finds the CRS named {official.group(1)} unlike that code's definition; "
            "it is written with the survey's own, which QGIS shows as a custom CRS",
            TdbWarning,
            stacklevel=3,
        )
        return
    warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _column(values: list[Any]) -> np.ndarray:
    """One attribute's values as a typed array: booleans, integers, reals or text (None: missing)."""
    present = [v for v in values if v is not None]
    complete = len(present) == len(values)
    if present and all(isinstance(v, bool) for v in present) and complete:
        return np.array(values, bool)
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present) and complete:
        return np.array(values, np.int64)
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return np.array([np.nan if v is None else float(v) for v in values], np.float64)
    return np.array([None if v is None else str(v) for v in values], dtype=object)
