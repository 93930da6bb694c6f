"""Coordinate reference systems from user input, and their EPSG codes."""

from __future__ import annotations

from typing import Any

import pyproj

from tdb.errors import CRSError


def as_crs(value: Any) -> pyproj.CRS | None:
    """Turn an EPSG code, WKT, PROJ string or CRS into a :class:`pyproj.CRS`."""
    if value is None or isinstance(value, pyproj.CRS):
        return value
    try:
        return pyproj.CRS.from_user_input(value)
    except pyproj.exceptions.CRSError as exc:
        raise CRSError(f"unknown coordinate system {value!r}: {exc}") from None


def epsg_of(crs: pyproj.CRS | None) -> int | None:
    """EPSG code of ``crs`` where one matches closely, else None."""
    if crs is None:
        return None
    code = crs.to_epsg(min_confidence=70)
    return int(code) if code is not None else None
