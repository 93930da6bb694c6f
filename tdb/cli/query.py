"""``tdb query``: SQL-like feature queries on a terrain database."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from tdb.cli.options import db_option, workers_option
from tdb.cli.output import check_files, check_output, emit, output_options
from tdb.errors import InputError


@click.command("query")
@click.argument("text")
@db_option
@output_options
@click.option("--png", type=click.Path(path_type=Path), help="Also draw the results over a hillshade.")
@workers_option
def command(
    text: str,
    db_path: Path | str,
    fmt: str,
    out: Path | None,
    layer: str | None,
    append: bool,
    png: Path | None,
    workers: int | None,
) -> None:
    """Run a query (see docs/query-language.md). GeoJSON goes to stdout by default, in the
    database's CRS.

    \b
    Examples:
      tdb query 'SELECT ditch FROM "2020" WHERE length > 20' --db park.tdb
      tdb query 'SELECT ridge FROM v1 WHERE bbox(500000, 5500000, 500400, 5500400) AT LEVEL 2' --db a.tdb
      tdb query 'SELECT wall FROM v1 WHERE length > 15' --db a.tdb --format table
      tdb query 'SELECT tiles FROM v1 WHERE category IN (10, 16)' --db a.tdb --format csv --out valleys.csv
      tdb query 'SELECT ditch FROM v1 WHERE depth > 0.5' --db a.tdb --format gpkg --out ditches.gpkg
      tdb query 'SELECT ridge FROM v1' --db a.tdb --format gpkg --out ditches.gpkg --append  # 2nd layer
      tdb query 'SELECT ridge FROM v1' --db a.tdb --out ridges.geojson --png ridges.png
      tdb query 'SELECT ditch FROM v1 WHERE depth >= 0.5 ORDER BY length DESC LIMIT 10' --db a.tdb
      tdb query "SELECT changes FROM v1 TO v2 WHERE kind = 'ditch dug'" --db a.tdb --format table
      tdb query 'SELECT ridge FROM county' --db county.tdb --workers 4 --format gpkg --out ridges.gpkg
    """
    import tdb
    from queries.language import parse
    from queries.run import run
    from tdb.cli.progress import Bars

    check_output(fmt, out, layer=layer, append=append)
    check_files(png=png)
    query = parse(text)
    with tdb.open(db_path, readonly=True) as db:
        with Bars(unit="line") as bars:
            features = run(db, text, progress=bars, workers=workers)
        crs = db.crs(query.version)
        if png:
            from queries.area import overview_surface
            from tdb.pictures import feature_map

            level = query.level or 2
            box = query.bbox or _extent(features, margin=20.0) or db.version(query.version).stats.bounds
            if box is None:
                raise InputError(f"version {query.version!r} records no extent to draw; give a bbox")
            surface = overview_surface(db, query.version, box, level=level)
            feature_map(png, features, surface, title=f"{query.what} in {query.version}")
    emit(features, fmt=fmt, crs=crs, out=out, layer=layer or query.what, noun="result(s)", append=append)
    if png:
        click.echo(f"map → {png}", err=True)


def _extent(features: list[dict[str, Any]], *, margin: float) -> tuple[float, float, float, float] | None:
    """Bounds of the results' geometries grown by ``margin`` m (None: no results)."""
    import shapely

    geoms = [shapely.geometry.shape(f["geometry"]) for f in features]
    if not geoms:
        return None
    x0, y0, x1, y1 = shapely.total_bounds(geoms)
    return (float(x0) - margin, float(y0) - margin, float(x1) + margin, float(y1) + margin)
