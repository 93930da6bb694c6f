"""``tdb query``: SQL-like feature queries on a terrain database."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.output import check_output, emit, output_options


@click.command("query")
@click.argument("text")
@click.option("--db", "db_path", type=click.Path(path_type=Path), required=True, help="Terrain database file.")
@output_options
def command(text: str, db_path: Path, fmt: str, out: Path | None) -> None:
    """Run a query (see docs/query-language.md). GeoJSON goes to stdout by default, in the
    database's CRS.

    \b
    Examples:
      tdb query 'SELECT ditch FROM "2020" WHERE length > 20' --db park.tdb
      tdb query 'SELECT ridge FROM v1 WHERE bbox(500000, 5500000, 500400, 5500400) AT LEVEL 2' --db a.tdb
      tdb query 'SELECT wall FROM v1 WHERE length > 15' --db a.tdb --format table
      tdb query 'SELECT tiles FROM v1 WHERE category IN (10, 16)' --db a.tdb --format csv --out valleys.csv
      tdb query 'SELECT ditch FROM v1 WHERE depth > 0.5' --db a.tdb --format gpkg --out ditches.gpkg
    """
    import tdb
    from queries.language import parse
    from queries.run import run

    check_output(fmt, out)
    query = parse(text)
    with tdb.open(db_path) as db:
        features = run(db, text)
        crs = db.crs(query.version)
    emit(features, fmt=fmt, crs=crs, out=out, layer=query.what, noun="result(s)")
