"""``tdb diff``: what changed between two surveys of an area."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import bbox_option
from tdb.cli.output import check_output, emit, output_options


@click.command("diff")
@click.argument("before")
@click.argument("after")
@click.option("--db", "db_path", type=click.Path(path_type=Path), required=True, help="Terrain database file.")
@click.option("--level", type=click.Choice(["2", "4", "8", "16"]), default="2", show_default=True)
@bbox_option()
@output_options
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
      tdb diff 2020 2024 --db park.tdb --format gpkg --out changes.gpkg
    """
    import tdb
    from queries.changes import detect

    check_output(fmt, out)
    with tdb.open(db_path) as db:
        found = detect(db, before, after, level=int(level), bbox=bbox)
        crs = db.crs(after)
    emit(found, fmt=fmt, crs=crs, out=out, layer="changes", noun="changed region(s)")
    if png:
        from tdb.pictures import change_map

        change_map(png, found, title=f"{before} → {after}, {level} m tiles")
        click.echo(f"change map → {png}", err=True)
