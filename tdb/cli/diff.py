"""``tdb diff``: what changed between two surveys of an area."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from tdb.cli.options import bbox_option, db_option, level_option, workers_option
from tdb.cli.output import check_files, check_output, emit, output_options
from tdb.crs import check_same_horizontal, height_offset, height_reference_note
from tdb.options import Coregistration

if TYPE_CHECKING:  # the library is imported when the command runs
    from queries.changes import Unclaimed

PICTURE = 4_000_000  # most cells of a change map's background


@click.command("diff")
@click.argument("before")
@click.argument("after")
@db_option
@level_option
@bbox_option()
@output_options
@click.option(
    "--png", type=click.Path(path_type=Path), help="Also draw a change map (over the DEM of difference)."
)
@click.option(
    "--coregister",
    type=click.Choice(Coregistration.values()),
    default=Coregistration.AUTO.value,
    show_default=True,
    help="Align the later survey on stable ground first: auto applies each shift only where significant; "
    "vertical: a height shift only; nuth-kaab: horizontal and vertical whatever their size; none.",
)
@click.option(
    "--dod",
    type=click.Path(path_type=Path),
    help="Also write the DEM of difference (after - before, m) as a GeoTIFF on the level's sub-grid.",
)
@workers_option
def command(
    before: str,
    after: str,
    db_path: Path | str,
    level: int,
    bbox: tuple[float, float, float, float] | None,
    fmt: str,
    out: Path | None,
    layer: str | None,
    append: bool,
    png: Path | None,
    coregister: str,
    dod: Path | None,
    workers: int | None,
) -> None:
    """Compare the tile categories of two versions, gated by the level of detection, and
    report changed regions typed by the feature filters (ditch dug, ditch filled, …).

    \b
    Examples:
      tdb diff 2020 2024 --db park.tdb
      tdb diff 2020 2024 --db park.tdb --bbox 500000,5500000,500400,5500400 --png changes.png
      tdb diff 2020 2024 --db park.tdb --format table
      tdb diff 2020 2024 --db park.tdb --format gpkg --out changes.gpkg
      tdb diff 2020 2024 --db park.tdb --bbox 500000,5500000,500400,5500400 --dod dod.tif
      tdb diff 2019 2023 --db park.tdb --coregister nuth-kaab   # surveys on different height datums
      tdb diff 2020 2024 --db county.tdb --workers 4 --format gpkg --out changes.gpkg
    """
    import tdb
    from queries.changes import detect, level_of_detection
    from queries.coregister import coregister as align
    from queries.coregister import site
    from queries.dod import describe, difference_of_surfaces
    from tdb.cli.progress import Bars

    check_output(fmt, out, layer=layer, append=append)
    check_files(png=png, tif=dod)
    # the shift found is kept for later queries where the database can be written
    with tdb.open(db_path, readonly=not tdb.database.writable(db_path)) as db:
        at = site(db, before)
        plan = check_same_horizontal(db.crs(before), db.crs(after), names=(before, after), at=at)
        if plan:
            click.echo(f"note: {plan}; co-registration finds what is left", err=True)
        datums = None if at is None else height_offset(db.crs(before), db.crs(after), at=at)
        note = height_reference_note(db.crs(before), db.crs(after), names=(before, after), offset=datums)
        if note:
            rest = "" if datums else "; co-registration on stable ground aligns them"
            click.echo(f"note: {note}{rest}", err=True)
        shift = align(db, before, after, level=level, bbox=bbox, method=coregister)
        if shift.method is not Coregistration.NONE:
            click.echo(f"co-registration ({shift.method}): {shift.describe()}", err=True)
        held: list[Unclaimed] = []
        with Bars(unit="part") as bars:
            found = detect(
                db,
                before,
                after,
                level=level,
                bbox=bbox,
                shift=shift,
                progress=bars,
                workers=workers,
                unclaimed=held,
            )
        crs = db.crs(after)
        lod = level_of_detection(db, before, after, shift=shift)
        if dod:
            grid = difference_of_surfaces(db, before, after, level=level, bbox=bbox, shift=shift)
        elif png:  # a background for the map: coarser cells over a large area
            grid = difference_of_surfaces(
                db, before, after, level=level, bbox=bbox, max_cells=PICTURE, fit=True, shift=shift
            )
        else:
            grid = None
    not_claimed = [_as_feature(h) for h in held]
    emit(
        found,
        fmt=fmt,
        crs=crs,
        out=out,
        layer=layer or "changes",
        noun="changed region(s)",
        append=append,
        members={"coregistration": shift.to_json(), "not_claimed": not_claimed},
        side_layers={f"{layer or 'changes'}_not_claimed": not_claimed},
    )
    if held:
        click.echo(_held_back(held), err=True)
    if dod:
        assert grid is not None  # made above whenever --dod is given
        from tdb.geotiff import write_geotiff

        tags = {"before": before, "after": after, "level_of_detection_m": f"{lod:.3f}", "units": "m"}
        write_geotiff(dod, grid, tags=tags)
        d = describe(grid, lod=lod)
        click.echo(
            f"DEM of difference → {dod} ({grid.cell} m; beyond the {lod:.2f} m level of detection "
            f"{100 * d['lowered_share']:.1f} % lowered, {100 * d['raised_share']:.1f} % raised)",
            err=True,
        )
    if png:
        from tdb.pictures import change_map

        aligned = "" if shift.method is Coregistration.NONE else f"\n{shift.title()}"
        title = f"{before} → {after}, {level} m tiles{aligned}"
        change_map(png, found, title=title, dod=grid, lod=lod, crs=crs, held_back=[h.geometry for h in held])
        click.echo(f"change map → {png}", err=True)


def _held_back(held: list[Unclaimed]) -> str:
    """One line on the regions that moved but whose change is not claimed."""
    why = Counter(str(h.why) for h in held)
    reasons = "; ".join(f"{n} {reason}" for reason, n in why.most_common())
    area = sum(h.geometry.area for h in held)
    return (
        f"not claimed: {len(held)} more region(s) moved, {area:,.0f} m² in all, "
        f"where the ground evidence does not support a change ({reasons})"
    )


def _as_feature(held: Unclaimed) -> dict[str, Any]:
    """A region not claimed as a GeoJSON feature: its outline, mean height change, area and why."""
    from tdb.geojson import feature

    return feature(held.geometry, {"dz": held.dz, "area": round(held.geometry.area, 1), "why": str(held.why)})
