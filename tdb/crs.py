"""Coordinate reference systems from user input, and their EPSG codes."""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from typing import Any

import pyproj
from pyproj.crs import CompoundCRS
from pyproj.transformer import AreaOfInterest, TransformerGroup

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


def height_reference_note(
    a: pyproj.CRS | None, b: pyproj.CRS | None, *, names: tuple[str, str], offset: HeightOffset | None = None
) -> str | None:
    """A sentence for a person where two surveys' heights may not share a reference: their
    vertical CRSs differ, or one declares none; with the ``offset`` (:func:`height_offset`) that
    expressed the later's heights in the earlier's reference, what it did. None where both declare
    one datum (a unit was made metres when each survey was read), or neither declares any."""
    va, vb = vertical_part(a), vertical_part(b)
    if va is None and vb is None:
        return None
    if va is not None and vb is not None and va.datum == vb.datum:
        return None

    def heights(name: str, v: pyproj.CRS | None) -> str:
        return f"{name!r} declares no vertical CRS" if v is None else f"{name!r} gives {describe(v)} heights"

    both = f"{heights(names[0], va)} and {heights(names[1], vb)}"
    if offset is not None:
        return f"{both}: {offset.describe(names)}"
    if va is not None and vb is not None:
        return f"{both}: PROJ holds no transformation between them here offline"
    return f"{both}: they may not share a height reference"


@dataclass(frozen=True)
class HeightOffset:
    """How a survey's heights read in another survey's vertical CRS (``reference``) at a site:
    ``dz`` (m) is how far its heights stand above the same points' heights in the other reference
    (subtract it to express them there), by the transformation PROJ describes as
    ``description``, good to ``accuracy`` m (PROJ's figure; NaN where it gives none)."""

    dz: float
    description: str
    accuracy: float
    reference: str  # the vertical CRS the heights are expressed in

    def describe(self, names: tuple[str, str]) -> str:
        """One sentence for a person: what was transformed, by what, by how much."""
        accuracy = f" (± {self.accuracy:.2f} m)" if math.isfinite(self.accuracy) else ""
        return (
            f"heights of {names[1]!r} expressed in {self.reference}, {-self.dz:+.3f} m here{accuracy}, "
            f"by pyproj ({self.description})"
        )


@functools.lru_cache(maxsize=16)  # a diff's note and its co-registration ask for the same (PROJ takes 0.1 s)
def height_offset(
    earlier: pyproj.CRS | None, later: pyproj.CRS | None, *, at: tuple[float, float]
) -> HeightOffset | None:
    """How far the ``later`` survey's heights stand above the same ground's in the ``earlier``
    one's vertical CRS at the site ``at`` (horizontal coordinates of both), by the best
    transformation PROJ holds offline for that place.

    None where there is nothing to transform (either declares no vertical CRS, or both share
    one datum: a unit was already made metres when the survey was read), and where PROJ holds no
    transformation but a ballpark one (an offset of zero, which it gives where the real one
    needs a grid it does not have): then only co-registration can align the heights.
    """
    va, vb = vertical_part(earlier), vertical_part(later)
    plan = horizontal_part(earlier)
    if va is None or vb is None or plan is None or va.datum == vb.datum:
        return None
    try:
        lon, lat = pyproj.Transformer.from_crs(plan, 4326, always_xy=True).transform(*at)
        source = CompoundCRS(f"{plan.name} + {vb.name}", [plan, vb])
        target = CompoundCRS(f"{plan.name} + {va.name}", [plan, va])
        with warnings.catch_warnings():  # the best transformation's missing grid is no news: we say so
            warnings.simplefilter("ignore")
            group = TransformerGroup(
                source, target, always_xy=True, area_of_interest=AreaOfInterest(lon, lat, lon, lat)
            )
    except pyproj.exceptions.ProjError:
        return None
    for t in group.transformers:
        if "ballpark" in t.description.lower():
            continue
        z = t.transform(at[0], at[1], 0.0)[2]
        if not math.isfinite(z):
            continue
        factor = va.axis_info[0].unit_conversion_factor if va.axis_info else 1.0
        accuracy = float(t.accuracy) if t.accuracy is not None and t.accuracy >= 0 else float("nan")
        return HeightOffset(-float(z) * factor, t.description, accuracy, describe(va))
    return None
