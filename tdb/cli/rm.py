"""``tdb rm``: delete a version from a terrain database."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import db_option


@click.command("rm")
@click.argument("version")
@db_option
def command(version: str, db_path: Path) -> None:
    """Delete VERSION and everything stored of it (tiles, points, evidence, shifts), in one
    transaction: an interruption leaves it whole.

    \b
    Examples:
      tdb rm 2019 --db park.tdb
    """
    import tdb

    with tdb.open(db_path) as db:
        db.delete_version(version)
        left = ", ".join(v.name for v in db.versions()) or "none"
    click.echo(f"version {version!r} deleted from {db_path}; versions left: {left}")
