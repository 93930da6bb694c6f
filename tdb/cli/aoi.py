"""``tdb aoi``: an area of interest as a mesh, a GeoTIFF and a picture."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import bbox_option, db_option, level_option


@click.command("aoi")
@db_option
@click.option("--version", "version", help="Survey name (optional when the database holds one).")
@bbox_option(required=True)
@level_option
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    default=Path("aoi"),
    show_default=True,
    help="Output prefix: writes PREFIX.ply, PREFIX.tif and PREFIX.png.",
)
def command(
    db_path: Path | str, version: str | None, bbox: tuple[float, float, float, float], level: int, out: Path
) -> None:
    """Read an area from the database: the kept points triangulated (PLY), the surface
    rebuilt on a grid (GeoTIFF) and a hillshade coloured by tile category (PNG).

    \b
    Examples:
      tdb aoi --db park.tdb --version 2020 --bbox 500100,5500100,500300,5500300
      tdb aoi --db park.tdb --bbox 500000,5500000,500400,5500400 --level 8 --out coarse
    """
    import tdb
    from queries.area import area_mesh, area_surface, write_ply
    from tdb.geotiff import write_geotiff
    from tdb.pictures import area_picture

    with tdb.open(db_path, readonly=True) as db:
        area = db.aoi(bbox, level=level, version=version)
        crs = db.crs(area.version)
    mesh = area_mesh(area)
    surface = area_surface(area, crs=crs, mesh=mesh)
    write_ply(out.with_suffix(".ply"), area, mesh=mesh)
    write_geotiff(out.with_suffix(".tif"), surface)
    area_picture(out.with_suffix(".png"), area, surface)
    click.echo(f"{len(area.code):,} tiles, {len(area.x):,} points → {out}.ply, {out}.tif, {out}.png")
