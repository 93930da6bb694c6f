"""``tdb info``: what a point cloud (or terrain database) holds."""

from __future__ import annotations

import json
from pathlib import Path

import click

from tdb.cli.options import input_options


@click.command("info")
@click.argument("path", type=click.Path(path_type=Path))
@input_options
@click.option("--json", "as_json", is_flag=True, help="Print the facts as JSON.")
def command(path: Path, crs: str | None, labels: str, as_json: bool) -> None:
    """Describe a point cloud: counts, bounds, CRS, units, density, classes, returns.

    \b
    Examples:
      tdb info survey.laz
      tdb info samp11.txt --crs EPSG:32632 --labels isprs
      tdb info area.tdb          # a terrain database: versions and extents
    """
    from ingest.readers import read
    from ingest.summary import format_summary, summarize

    info = summarize(read(path, crs=crs, labels=labels, validate=True))
    click.echo(json.dumps(info, indent=2) if as_json else format_summary(info))
