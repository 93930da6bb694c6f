"""``tdb categories``: the 115 tile categories, listed or drawn."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("categories")
@click.option("--atlas", type=click.Path(path_type=Path), help="Draw all 115 canonical templates to this PNG.")
@click.option(
    "--subgrid",
    type=int,
    default=5,
    show_default=True,
    help="Sub-grid nodes per tile side in the atlas, 5..65.",
)
def command(atlas: Path | None, subgrid: int) -> None:
    """List the tile categories: code, inclination, feature, orientation.

    \b
    Examples:
      tdb categories
      tdb categories --atlas atlas.png
    """
    from tdb.categories import all_categories, check_subgrid

    check_subgrid(subgrid)
    if atlas:
        from tdb.atomic import PNG, check_destination
        from tdb.pictures import category_atlas

        check_destination(atlas, PNG, what="a PNG picture")
        category_atlas(atlas, n=subgrid)
        click.echo(f"wrote {atlas}")
        return
    for c in all_categories():
        click.echo(f"{c.code:4d}  {c.description}")
