"""``tdb rename``: give a version another name."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import db_option


@click.command("rename")
@click.argument("version")
@click.argument("new")
@db_option
def command(version: str, new: str, db_path: Path) -> None:
    """Rename VERSION to NEW, in one transaction; its model and stored shifts stay as they are.

    \b
    Examples:
      tdb rename survey-a 2019 --db park.tdb
    """
    import tdb

    with tdb.open(db_path) as db:
        db.rename_version(version, new)
    click.echo(f"version {version!r} is now {new!r} in {db_path}")
