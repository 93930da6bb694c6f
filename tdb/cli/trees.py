"""``tdb trees``: individual trees with their height and crown."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import exclude_option, input_options, method_option


@click.command("trees")
@click.argument("cloud", type=click.Path(path_type=Path))
@click.option(
    "--out", type=click.Path(path_type=Path), required=True, help="GeoPackage (.gpkg) or GeoJSON of the trees."
)
@method_option
@click.option(
    "--min-height", type=float, default=2.0, show_default=True, help="Leave out trees lower than this (m)."
)
@click.option("--assume-metres", is_flag=True, help="Accept a file with no CRS as metres.")
@input_options
@exclude_option
def command(
    cloud: Path,
    out: Path,
    method: str,
    min_height: float,
    assume_metres: bool,
    crs: str | None,
    labels: str,
    exclude: tuple[int, ...],
) -> None:
    """Find individual trees: top position, height over the ground, crown diameter and crown.

    The crowns are segmented on a canopy model smoothed at three scales, each cell climbing
    to its local maximum, and the scale is chosen crown by crown by paraboloid fits (Elmqvist
    §2.3). The diameter is read over the crown above its base (0.35 of the tree's height),
    where a taller crown's segment took in a lower crown's edge. A GeoPackage gets two layers,
    ``trees`` (crowns) and ``tree_tops`` (points); a GeoJSON file gets the crowns, each with its
    top's x and y.

    \b
    Examples:
      tdb trees forest.laz --out trees.gpkg
      tdb trees forest.laz --out trees.geojson --min-height 15
    """
    from ingest.objects import objects_of
    from ingest.readers import read
    from tdb.atomic import GEOPACKAGE, check_destination
    from tdb.cli.progress import Bars
    from tdb.objects import FEATURES, tree_features, tree_top_features, write_features
    from tdb.units import to_metres

    check_destination(out, GEOPACKAGE + FEATURES, what="a GeoPackage or GeoJSON file")
    raw = read(cloud, crs=crs, labels=labels)
    metric = to_metres(raw, assume_metres=assume_metres)
    with Bars(unit="tile") as bars:
        found = objects_of(metric, method=method, exclude=exclude, progress=bars)
    trees = [t for t in found.trees if t.height >= min_height]
    write_features(out, {"trees": tree_features(trees), "tree_tops": tree_top_features(trees)}, crs=metric.crs)
    click.echo(f"wrote {out} ({len(trees)} trees of {min_height:g} m or more)")
