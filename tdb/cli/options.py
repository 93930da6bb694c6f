"""Options shared by several commands."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from tdb.bbox import check_bbox
from tdb.errors import InputError
from tdb.options import GroundMethod, LabelScheme
from tdb.tiles import LEVELS

F = Callable[..., Any]


class DatabaseParam(click.ParamType):
    """A terrain database: an SQLite file's path, or a database URL (``postgresql+psycopg://…``)
    passed on as written (a path type would fold its ``//``)."""

    name = "DATABASE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Path | str:
        text = str(value)
        return text if "://" in text else Path(text)


DATABASE = DatabaseParam()


def db_option(func: F) -> F:
    """``--db``: the terrain database, a file or a PostgreSQL URL."""
    return click.option(
        "--db",
        "db_path",
        type=DATABASE,
        required=True,
        help="Terrain database: a file, or a PostgreSQL URL (postgresql+psycopg://user@host/dbname).",
    )(func)


def input_options(func: F) -> F:
    """``--crs`` and ``--labels`` for commands that read a point cloud."""
    func = click.option(
        "--labels",
        type=click.Choice(LabelScheme.values()),
        default=LabelScheme.ASPRS.value,
        show_default=True,
        help="Meaning of a text file's 4th column: ASPRS class codes or ISPRS 0=ground/1=object.",
    )(func)
    func = click.option(
        "--crs", default=None, help="Coordinate system of the input, e.g. EPSG:25832 (overrides the file's)."
    )(func)
    return func


def level_option(func: F) -> F:
    """``--level``: a tile size of the pyramid (:data:`tdb.tiles.LEVELS`), as an int."""
    return click.option(
        "--level",
        type=click.Choice([str(lv) for lv in LEVELS]),
        default=str(LEVELS[0]),
        show_default=True,
        callback=lambda _ctx, _param, value: int(value),
        help="Tile size (m) of the pyramid level.",
    )(func)


def workers_option(func: F) -> F:
    """``--workers N``: the processes a whole survey's parts are read in."""
    return click.option(
        "--workers",
        type=click.IntRange(min=1),
        help="Read a whole survey's parts in this many processes [default: one per core].",
    )(func)


def _classes(_ctx: click.Context, _param: click.Parameter, value: str) -> tuple[int, ...]:
    from tdb.classes import parse_classes
    from tdb.errors import OptionError

    try:
        return parse_classes(value)
    except OptionError as exc:
        raise click.BadParameter(str(exc)) from None


def positive_metres(_ctx: click.Context, _param: click.Parameter, value: float | None) -> float | None:
    """A length in metres that must be a finite positive number."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise click.BadParameter(f"{value}: expected a positive length in metres")
    return value


def exclude_option(func: F) -> F:
    """``--exclude-classes`` for commands that filter ground."""
    return click.option(
        "--exclude-classes",
        "exclude",
        default="7,18",
        show_default=True,
        callback=_classes,
        help="Classes of points that are never ground (7,18: ASPRS noise; add 65 for IGN LiDAR HD artefacts); "
        "'none' keeps all. Points the file flags withheld are left out whatever their class.",
    )(func)


def parse_bbox(
    _ctx: click.Context | None, _param: click.Parameter | None, value: str | None
) -> tuple[float, float, float, float] | None:
    """``x0,y0,x1,y1`` → a tuple, with a clear message for anything else."""
    if value is None:
        return None
    try:
        parts = [float(v) for v in value.split(",")]
    except ValueError:
        raise click.BadParameter(f"{value!r}: expected four numbers x0,y0,x1,y1") from None
    if len(parts) != 4:
        raise click.BadParameter(f"{value!r}: expected four numbers x0,y0,x1,y1")
    try:
        return check_bbox((parts[0], parts[1], parts[2], parts[3]))
    except InputError as exc:
        raise click.BadParameter(f"{value!r}: {exc}") from None


def bbox_option(*, required: bool = False) -> Callable[[F], F]:
    return click.option(
        "--bbox", callback=parse_bbox, required=required, help="Area x0,y0,x1,y1 in the database's CRS (metres)."
    )


def method_option(func: F) -> F:
    """``--method``: how the ground is found (:class:`tdb.options.GroundMethod`)."""
    return click.option(
        "--method",
        type=click.Choice(GroundMethod.values()),
        default=GroundMethod.AUTO.value,
        show_default=True,
        help="auto: the default filter; sohn: Sohn & Dowman 2002; contour: Elmqvist active contour; "
        "classified: the file's own ground class (2), as its provider classified it.",
    )(func)
