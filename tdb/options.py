"""The registry of string options shared by the library and the command line.

Each option set is a ``str`` enum; :func:`parse` turns user text into a member
or raises :class:`~tdb.errors.OptionError` naming the valid choices.
"""

from __future__ import annotations

from enum import Enum
from typing import TypeVar

from tdb.errors import OptionError


class Option(str, Enum):
    """Base of every registered option set."""

    @classmethod
    def values(cls) -> list[str]:
        return [m.value for m in cls]

    def __str__(self) -> str:
        return self.value


class GroundMethod(Option):
    """Ground filters: the two from the papers and the product default."""

    AUTO = "auto"
    SOHN = "sohn"
    CONTOUR = "contour"


class LabelScheme(Option):
    """Meaning of the fourth column of a text point file."""

    ASPRS = "asprs"  # LAS classification codes (2 = ground)
    ISPRS = "isprs"  # ISPRS filter test: 0 = bare earth, 1 = object


class OutputFormat(Option):
    """Formats of query and diff results."""

    GEOJSON = "geojson"
    CSV = "csv"
    TABLE = "table"
    GPKG = "gpkg"  # a GeoPackage file, which needs a path


E = TypeVar("E", bound=Option)


def parse(kind: type[E], value: str | E) -> E:
    """Return the member of ``kind`` named by ``value``.

    Raises
    ------
    OptionError
        If ``value`` is not one of ``kind.values()``.
    """
    if isinstance(value, kind):
        return value
    try:
        return kind(str(value).lower())
    except ValueError:
        raise OptionError(
            f"invalid {kind.__name__} {value!r}; choose one of: {', '.join(kind.values())}"
        ) from None
