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
    """Ground filters: the two from the papers and the product default; or the survey's own ground
    class (ASPRS 2), as its provider classified it."""

    AUTO = "auto"
    SOHN = "sohn"
    CONTOUR = "contour"
    CLASSIFIED = "classified"


class GroundStage(Option):
    """The default ground filter's stages after its refinement passes, each of which may be skipped
    (``docs/ground.md`` says what each finds and why it is there)."""

    PITS = "pits"  # deep narrow clusters of low outliers, found by the upside-down opening
    ROOFS = "roofs"  # ground surfaces a wall's drop above all the ground around: roofs too wide to open
    EARTHWORKS = "earthworks"  # long, narrow, low object groups: dikes, embankment crests
    HILLS = "hills"  # object groups that rise smoothly out of the ground
    WALLS = "walls"  # free-standing walls
    SPIKES = "spikes"  # one-point pits among the ground
    SUNKEN = "sunken"  # multipath scatter far below a void
    REJOIN = "rejoin"  # low outliers by their neighbourhood that lie on the settled ground surface


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


class Measure(Option):
    """What a feature filter measures of a form: its height, its depth, or the step of a slope."""

    HEIGHT = "height"  # a ridge, wall or mound stands above the terrain beside it
    DEPTH = "depth"  # a ditch or pit lies below it
    STEP = "step"  # an embankment's side: higher ground on one side, lower on the other

    @property
    def sign(self) -> float:
        """+1 where the form stands above the terrain, −1 where it lies below: heights times
        ``sign`` are the form's relief. A step has no side of its own (+1)."""
        return -1.0 if self is Measure.DEPTH else 1.0


class Coregistration(Option):
    """How a later survey is aligned to an earlier one before they are compared."""

    AUTO = "auto"  # estimate both shifts, apply each only where significant
    NONE = "none"
    VERTICAL = "vertical"  # a robust vertical shift only
    NUTH_KAAB = "nuth-kaab"  # horizontal (Nuth & Kääb 2011) and vertical, applied whatever their size


class Terrain(Option):
    """The landscape a synthetic scene is made of."""

    PLAIN = "plain"  # hills and an escarpment carrying the forms the queries look for
    # also natural valleys and spurs, roads with shoulders and roadside ditches, field edges,
    # ditches that fade out and ditches under canopy: the look-alikes of real terrain
    RUGGED = "rugged"


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
