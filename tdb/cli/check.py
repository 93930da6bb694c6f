"""``tdb check``: is a terrain database whole?"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import click

from tdb.cli.options import DATABASE

FREE_NOTE = 0.1  # a share of free pages worth a compaction


@click.command("check")
@click.argument("db_path", type=DATABASE)
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def command(db_path: Path, as_json: bool) -> None:
    """Check a terrain database without writing to it: the file's integrity (SQLite's own check),
    its schema version, and whether every version holds the tiles and points its figures record;
    the share of the file's pages left free (by deleted versions), and tables laid out as older
    versions of tdb made them, which compaction renews. Exits non-zero where anything is wrong.

    \b
    Examples:
      tdb check park.tdb
      tdb check park.tdb --json
    """
    import tdb

    with tdb.open(db_path, readonly=True) as db:
        report = db.check()
    if as_json:
        click.echo(json.dumps({**asdict(report), "ok": report.ok}, indent=2))
    else:
        click.echo(f"{db_path}: schema {report.schema_version}, integrity {report.integrity}")
        if report.free_share is not None and report.free_share >= FREE_NOTE:
            click.echo(f"free pages: {100 * report.free_share:.0f} % of the file (tdb compact gives them back)")
        if report.old_layout:
            click.echo(
                f"older layout of {', '.join(report.old_layout)}: area reads fetch about three times the bytes "
                "(tdb compact lays them out anew)"
            )
        for v in report.versions:
            tiles = "/".join(str(v.tiles[lv]) for lv in sorted(v.tiles))
            click.echo(f"- {v.name}: {v.points:,} points, tiles {tiles}: {'ok' if v.ok else 'rows missing'}")
    if not report.ok:
        from tdb.errors import DatabaseError

        wrong = [v.name for v in report.versions if not v.ok]
        what = (
            f"integrity {report.integrity}" if report.integrity != "ok" else f"rows missing in {', '.join(wrong)}"
        )
        raise DatabaseError(f"{db_path}: {what}")
