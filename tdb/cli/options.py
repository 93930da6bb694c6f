"""Options shared by several commands."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from tdb.options import LabelScheme

F = Callable[..., Any]


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
