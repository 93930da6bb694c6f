"""``tdb diff``: what changed between two surveys of an area."""

from __future__ import annotations

import json
from pathlib import Path

import click

from tdb.cli.options import bbox_option
from tdb.options import OutputFormat


@click.command("diff")
@click.argument("before")
@click.argument("after")
@click.option("--db", "db_path", type=click.Path(path_type=Path), required=True, help="Terrain database file.")
@click.option("--level", type=click.Choice(["2", "4", "8", "16"]), default="2", show_default=True)
@bbox_option()
@click.option("--format", "fmt", type=click.Choice(OutputFormat.values()), default="geojson", show_default=True)
@click.option("--out", type=click.Path(path_type=Path), help="Write the result here instead of standard output.")
@click.option("--png", type=click.Path(path_type=Path), help="Also draw a change map.")
def command(
    before: str,
    after: str,
    db_path: Path,
    level: str,
    bbox: tuple[float, float, float, float] | None,
    fmt: str,
    out: Path | None,
    png: Path | None,
) -> None:
    """Compare the tile categories of two versions, gated by the level of detection, and
    report changed regions typed by the feature filters (ditch dug, ditch filled, …).

    \b
    Examples:
      tdb diff 2020 2024 --db park.tdb
      tdb diff 2020 2024 --db park.tdb --bbox 500000,5500000,500400,5500400 --png changes.png
      tdb diff 2020 2024 --db park.tdb --format table
    """
    import tdb
    from queries.changes import detect
    from queries.run import feature_collection
    from tdb.cli.query import _render

    with tdb.open(db_path) as db:
        found = detect(db, before, after, level=int(level), bbox=bbox)
        crs = db.crs(after)
    body = json.dumps(feature_collection(found, crs)) if fmt == "geojson" else _render(found, fmt, crs)
    if out:
        out.write_text(body)
        click.echo(f"{len(found)} changed region(s) → {out}", err=True)
    else:
        click.echo(body)
    if png:
        from tdb.pictures import change_map

        change_map(png, found, title=f"{before} → {after}, {level} m tiles")
        click.echo(f"change map → {png}", err=True)
