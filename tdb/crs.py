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


def exact_epsg(crs: pyproj.CRS) -> int | None:
    """The EPSG code whose CRS ``crs`` is (pyproj finds the two equal), else None: stricter than
    :func:`epsg_of`, for writing the code in place of the definition."""
    code = crs.to_epsg()
    return int(code) if code is not None and crs.equals(pyproj.CRS.from_epsg(code)) else None


def horizontal_part(crs: pyproj.CRS | None) -> pyproj.CRS | None:
    """The horizontal CRS of ``crs`` (its first part where it is compound)."""
    if crs is None or not crs.is_compound:
        return crs
    return next((c for c in crs.sub_crs_list if not c.is_vertical), crs.sub_crs_list[0])


def vertical_part(crs: pyproj.CRS | None) -> pyproj.CRS | None:
    """The vertical CRS ``crs`` declares (the vertical part of a compound CRS), or None."""
    if crs is None:
        return None
    if crs.is_compound:  # checked first: pyproj calls a compound CRS with heights vertical too
        return next((c for c in crs.sub_crs_list if c.is_vertical and not c.is_compound), None)
    return crs if crs.is_vertical else None


def describe(crs: pyproj.CRS | None) -> str:
    """``name (EPSG:code)``, or a note that none is declared."""
    if crs is None:
        return "none declared"
    code = epsg_of(crs)
    return f"{crs.name} (EPSG:{code})" if code else crs.name


NEAR = 2.0  # m: two realisations of a datum this close at the site are compared as they are


def horizontal_offset(a: pyproj.CRS, b: pyproj.CRS, at: tuple[float, float]) -> float:
    """How far (m) the point ``at`` of ``a`` lies from the same coordinates in ``b``, by the best
    transformation pyproj has offline (inf where there is none)."""
    try:
        t = pyproj.Transformer.from_crs(horizontal_part(a), horizontal_part(b), always_xy=True)
        x, y = t.transform(*at)
    except pyproj.exceptions.ProjError:
        return float("inf")
    d = float(((x - at[0]) ** 2 + (y - at[1]) ** 2) ** 0.5)
    return d if d == d else float("inf")  # NaN: no transformation


def check_same_horizontal(
    a: pyproj.CRS | None,
    b: pyproj.CRS | None,
    *,
    names: tuple[str, str],
    at: tuple[float, float] | None = None,
) -> str | None:
    """Refuse to compare two surveys whose horizontal coordinate systems differ by more than
    :data:`NEAR` at the site ``at``; say so where they differ by less (two realisations of one
    datum, such as NAD83 and WGS 84 on the same UTM zone): co-registration finds the rest.

    Returns a note for a person, or None where the systems are the same.

    Raises
    ------
    CRSError
        If both declare a horizontal CRS and they are neither the same nor near at the site.
    """
    ha, hb = horizontal_part(a), horizontal_part(b)
    if ha is None or hb is None or ha.equals(hb, ignore_axis_order=True):
        return None
    offset = horizontal_offset(ha, hb, at) if at is not None else float("inf")
    if offset <= NEAR:
        return (
            f"versions {names[0]!r} and {names[1]!r} are in {describe(ha)} and {describe(hb)}, "
            f"{offset:.2f} m apart here by pyproj's transformation; compared as they are"
        )
    raise CRSError(
        f"versions {names[0]!r} and {names[1]!r} are in different horizontal coordinate systems "
        f"({describe(ha)}; {describe(hb)}); ingest one of them again in the other's"
    )


def height_reference_note(a: pyproj.CRS | None, b: pyproj.CRS | None, *, names: tuple[str, str]) -> str | None:
    """A sentence for a person where two surveys' heights may not share a reference: their
    vertical CRSs differ, or one declares none. None where both declare the same one, or neither."""
    va, vb = vertical_part(a), vertical_part(b)
    if va is None and vb is None:
        return None
    if va is not None and vb is not None and va.equals(vb):
        return None

    def heights(name: str, v: pyproj.CRS | None) -> str:
        return f"{name!r} declares no vertical CRS" if v is None else f"{name!r} gives {describe(v)} heights"

    return f"{heights(names[0], va)} and {heights(names[1], vb)}: they may not share a height reference"
