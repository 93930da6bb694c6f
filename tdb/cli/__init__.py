"""The ``tdb`` command line: a thin shell over the library.

Each subcommand lives in its own module; library errors are turned into one
line on stderr and a non-zero exit here, at the boundary.
"""

from __future__ import annotations

import sys
import traceback
from typing import Any

import click

from tdb import __version__
from tdb.errors import Remedy, TdbError

EXIT_ERROR = 1
EXIT_USAGE = 2  # as click's own

# How this command line says what a user can do about an error.
REMEDIES = {
    Remedy.REPLACE: "use --replace to write over it",
    Remedy.GIVE_CRS: "give one with --crs EPSG:XXXX, or pass --assume-metres",
    Remedy.BLOCKS: "tdb ingest does so with --block",
}


class TdbGroup(click.Group):
    """A click group that reports :class:`TdbError` and a bad command line as one line
    (``--debug``: traceback)."""

    def invoke(self, ctx: click.Context) -> Any:
        from tdb.cli.progress import echo_warnings

        try:
            with echo_warnings():
                return super().invoke(ctx)
        except click.UsageError as exc:
            command = f" {exc.ctx.command_path}" if exc.ctx is not None else ""
            hint = f" (tdb{command.removeprefix(' tdb')} --help)" if exc.ctx is not None else ""
            click.echo(f"tdb: error: {exc.format_message()}{hint}", err=True)
            sys.exit(EXIT_USAGE)
        except TdbError as exc:
            if ctx.obj and ctx.obj.get("debug"):
                traceback.print_exc()
            message = str(exc).splitlines() or [type(exc).__name__]
            remedy = REMEDIES.get(exc.remedy) if exc.remedy else None
            click.echo(f"tdb: error: {message[0]}{'; ' + remedy if remedy else ''}", err=True)
            for extra in message[1:]:  # query carets need their context lines
                click.echo(extra, err=True)
            sys.exit(EXIT_ERROR)
        except KeyboardInterrupt:
            click.echo("tdb: interrupted", err=True)
            sys.exit(130)


@click.group(cls=TdbGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="tdb")
@click.option("--debug", is_flag=True, help="Show the full traceback of errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """tdb: terrain database and query engine for airborne LiDAR.

    \b
    Examples:
      tdb info cloud.laz
      tdb synth --size 200 --density 4 --out scene.laz
      tdb ground cloud.laz --out ground.laz --dtm dtm.tif
    """
    ctx.ensure_object(dict)
    ctx.obj["debug"] = debug


def _register() -> None:
    from tdb.cli import (
        aoi,
        categories,
        check,
        classify,
        compact,
        diff,
        ground,
        info,
        ingest,
        query,
        rename,
        rm,
        synth,
        trees,
    )

    commands = (
        info,
        synth,
        ground,
        classify,
        trees,
        ingest,
        aoi,
        categories,
        query,
        diff,
        rm,
        rename,
        check,
        compact,
    )
    for module in commands:
        main.add_command(module.command)


_register()
