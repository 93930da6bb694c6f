"""``tdb compact``: rewrite a terrain database with its tables in order and its free space given back."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import db_option


@click.command("compact")
@db_option
@click.option(
    "--into",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write the compact copy to this new file and leave the database as it is (SQLite only).",
)
def command(db_path: Path, into: Path | None) -> None:
    """Rewrite the database with each table's rows in key order and without the space deleted
    versions left. Areas are then read in a few runs of the file, which is faster where the
    file is larger than the system's cache. A database made before its tables of pages and objects
    were rowid tables gets that layout, whose reads fetch a third of the bytes. In place it needs
    free disk for two to three times the file; an interruption leaves the database as it was.

    \b
    Examples:
      tdb compact --db park.tdb
      tdb compact --db park.tdb --into archive/park-2019.tdb
      tdb compact --db postgresql+psycopg://survey@dbhost/terrain
    """
    import tdb
    from tdb.compact import compact

    with tdb.open(db_path, readonly=into is not None) as db:
        click.echo(f"compacting {db.name} …", err=True)
        done = compact(db, into=into)
    if done.bytes_before is None or done.bytes_after is None:
        click.echo(f"{done.destination}: rewritten")
        return
    mib = 2**20
    click.echo(f"{done.destination}: {done.bytes_after / mib:,.1f} MiB (was {done.bytes_before / mib:,.1f} MiB)")
