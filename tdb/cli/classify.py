"""``tdb classify``: ground, vegetation by height, buildings, per point."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import exclude_option, input_options, method_option


@click.command("classify")
@click.argument("cloud", type=click.Path(path_type=Path))
@click.option(
    "--out", type=click.Path(path_type=Path), required=True, help="LAS/LAZ of the input points, classified."
)
@click.option(
    "--buildings", type=click.Path(path_type=Path), help="GeoPackage or GeoJSON of the building footprints."
)
@method_option
@click.option("--assume-metres", is_flag=True, help="Accept a file with no CRS as metres.")
@input_options
@exclude_option
def command(
    cloud: Path,
    out: Path,
    buildings: Path | None,
    method: str,
    assume_metres: bool,
    crs: str | None,
    labels: str,
    exclude: tuple[int, ...],
) -> None:
    """Classify every point as ASPRS does: 2 ground, 3/4/5 low, medium and high vegetation,
    6 building, 1 other, 18 high noise (more than 150 m over the ground: birds, clouds).

    Cells whose highest return stands more than 2 m over the ground are told apart by the
    texture of the heights (buildings are smooth, crowns rough) and by double echoes, as in
    Elmqvist's §2.2. Points keep their input order and coordinates; points of the excluded
    classes (ASPRS noise by default) keep their own class.

    \b
    Examples:
      tdb classify survey.laz --out classified.laz
      tdb classify survey.laz --out classified.laz --buildings buildings.gpkg
      tdb classify lidarhd.laz --exclude-classes 7,18,65 --out classified.laz
    """
    import numpy as np

    from ingest.objects import objects_of
    from ingest.readers import read, write_classified
    from tdb.atomic import GEOPACKAGE, POINTS, check_destination
    from tdb.cli.progress import Bars
    from tdb.cloud import CLASS_NAMES
    from tdb.objects import FEATURES, building_features, write_features
    from tdb.units import to_metres

    check_destination(out, POINTS, what="a point file")
    if buildings:
        check_destination(buildings, GEOPACKAGE + FEATURES, what="a GeoPackage or GeoJSON file")
    raw = read(cloud, crs=crs, labels=labels)
    metric = to_metres(raw, assume_metres=assume_metres)
    with Bars(unit="tile") as bars:
        found = objects_of(metric, method=method, exclude=exclude, progress=bars)
    counts = np.bincount(found.classes, minlength=max(CLASS_NAMES) + 1)
    click.echo(", ".join(f"{counts[k]:,} {name}" for k, name in CLASS_NAMES.items()))
    write_classified(out, raw, found.classes)
    click.echo(f"wrote {out}")
    if buildings:
        write_features(buildings, {"buildings": building_features(found.buildings)}, crs=metric.crs)
        click.echo(f"wrote {buildings} ({len(found.buildings)} buildings)")
