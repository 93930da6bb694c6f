"""``tdb query``: SQL-like feature queries on a terrain database."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

import click

from tdb.options import OutputFormat


@click.command("query")
@click.argument("text")
@click.option("--db", "db_path", type=click.Path(path_type=Path), required=True, help="Terrain database file.")
@click.option("--format", "fmt", type=click.Choice(OutputFormat.values()), default="geojson", show_default=True)
@click.option("--out", type=click.Path(path_type=Path), help="Write here instead of standard output.")
def command(text: str, db_path: Path, fmt: str, out: Path | None) -> None:
    """Run a query (see docs/query-language.md). GeoJSON goes to stdout by default, in the
    database's CRS.

    \b
    Examples:
      tdb query 'SELECT ditch FROM "2020" WHERE length > 20' --db park.tdb
      tdb query 'SELECT ridge FROM v1 WHERE bbox(500000, 5500000, 500400, 5500400) AT LEVEL 2' --db a.tdb
      tdb query 'SELECT wall FROM v1 WHERE length > 15' --db a.tdb --format table
      tdb query 'SELECT tiles FROM v1 WHERE category IN (10, 16)' --db a.tdb --format csv --out valleys.csv
    """
    import tdb
    from queries.language import parse
    from queries.run import run

    with tdb.open(db_path) as db:
        features = run(db, text)
        crs = db.crs(parse(text).version)
    body = _render(features, fmt, crs)
    if out:
        out.write_text(body)
        click.echo(f"{len(features)} result(s) → {out}", err=True)
    else:
        click.echo(body)


def _render(features: list[dict[str, Any]], fmt: str, crs: Any) -> str:
    from queries.run import feature_collection

    if fmt == "geojson":
        return json.dumps(feature_collection(features, crs))
    rows = [f["properties"] for f in features]
    keys = sorted({k for r in rows for k in r})
    if fmt == "csv":
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
        return buf.getvalue().rstrip("\n")
    widths = {k: max(len(k), *(len(str(r.get(k, ""))) for r in rows)) for k in keys} if rows else {}
    lines = ["  ".join(k.ljust(widths[k]) for k in keys)]
    lines += ["  ".join(str(r.get(k, "")).ljust(widths[k]) for k in keys) for r in rows]
    return "\n".join(lines) + f"\n({len(rows)} rows)"
