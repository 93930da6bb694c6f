"""``tdb ingest``: a survey into a terrain database."""

from __future__ import annotations

import datetime as dt
import time
from pathlib import Path

import click

from tdb.cli.options import bbox_option, db_option, exclude_option, input_options, method_option
from tdb.options import GroundMethod, LabelScheme


def _date(_ctx: click.Context, _param: click.Parameter, value: str | None) -> dt.date | None:
    if value is None:
        return None
    try:
        return dt.date.fromisoformat(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a date like 2024-05-31") from None


BOX_SHOWN = 2.0  # the box is named too where it is this many times the area modelled


def _summary(
    points: int,
    bounds: tuple[float, float, float, float] | None,
    tiles: int,
    seconds: float,
    *,
    worker_mib: float | None,
) -> str:
    """Points, the area modelled (its 2 m ``tiles``; the ``bounds``' box too where the points
    leave most of it empty: a corridor, two sites), time and peak memory (this process's, and the
    largest worker's: as the workers told it, ``worker_mib``, else of the child processes waited
    for) of an ingest."""
    from tdb.bbox import box_area
    from tdb.memory import peak_mib, workers_peak_mib
    from tdb.tiles import LEVELS

    own = peak_mib()
    workers = workers_peak_mib(worker_mib)
    km2 = tiles * min(LEVELS) ** 2 / 1e6
    box = box_area(bounds) / 1e6 if bounds else 0.0
    area = f"{km2:,.2f} km²" + (f" (in a box of {box:,.2f} km²)" if box > BOX_SHOWN * km2 else "")
    memory = f"peak memory {own:,.0f} MiB" + (f", {workers:,.0f} MiB per worker" if workers else "")
    rate = points / max(seconds, 1e-9)
    return f"{points:,} points, {area} in {seconds:,.1f} s ({rate:,.0f} points/s), {memory}"


@click.command("ingest")
@click.argument("cloud", type=click.Path(path_type=Path))
@click.option(
    "--block",
    type=float,
    help="Ingest block by block, blocks of this many metres (a multiple of 16), in parallel: for surveys "
    "too large to model whole. A directory or a glob of tiles is always ingested so, and a file whose "
    "header's points or extent need more than half this machine's memory in a whole ingest [default: "
    "the largest a worker models in 1.5 GB at the survey's density, at most 512].",
)
@click.option("--workers", type=int, help="Ingest block by block in this many processes [default: one per core].")
@click.option(
    "--scheduler",
    help="Model the blocks on a dask.distributed cluster: its scheduler's address (tcp://host:8786). "
    "Its workers need tdb installed; the blocks' points travel with the jobs.",
)
@db_option
@click.option("--version", "version", required=True, help="Name of this survey in the database.")
@click.option("--date", callback=_date, help="Acquisition date, YYYY-MM-DD.")
@method_option
@click.option("--resolution", type=float, default=0.5, show_default=True, help="Dense model post spacing (m).")
@click.option(
    "--flat-threshold",
    type=float,
    help="Height range (m) below which a tile is flat [default: 5 × the measured ground noise, at least 0.1 m].",
)
@click.option("--replace", is_flag=True, help="Replace an existing version of the same name.")
@click.option(
    "--resume",
    is_flag=True,
    help="Continue a blocked ingest that was killed or failed, from the blocks it finished "
    "(the same files, version and options).",
)
@click.option("--no-objects", is_flag=True, help="Do not find and store trees and buildings.")
@bbox_option()
@click.option("--assume-metres", is_flag=True, help="Accept a file with no CRS as metres.")
@input_options
@exclude_option
def command(
    cloud: Path,
    db_path: Path | str,
    version: str,
    date: dt.date | None,
    method: str,
    resolution: float,
    flat_threshold: float | None,
    replace: bool,
    resume: bool,
    no_objects: bool,
    assume_metres: bool,
    block: float | None,
    workers: int | None,
    scheduler: str | None,
    bbox: tuple[float, float, float, float] | None,
    crs: str | None,
    labels: str,
    exclude: tuple[int, ...],
) -> None:
    """Build the terrain model of a survey and store it: ground filter, dense model,
    tile categories at 2/4/8/16 m, reduction, trees and buildings, in one transaction.

    A failure or interruption leaves the database as it was. A blocked ingest keeps its
    finished blocks beside the database until the version is stored: --resume continues it.

    CLOUD is a LAS/LAZ or text file, or a catalog of LAS/LAZ tiles: a directory or a quoted
    glob pattern. With --bbox only that area is modelled (block by block), and only its points
    and a buffer around it are read: from a COPC file by range.

    \b
    Examples:
      tdb ingest survey_2020.laz --db park.tdb --version 2020 --date 2020-04-02
      tdb ingest tiles/ --db county.tdb --version 2024            # a directory of tiles, block by block
      tdb ingest 'tiles/*.laz' --db county.tdb --version 2024 --block 1024 --workers 2
      tdb ingest tiles/ --db county.tdb --version 2024 --scheduler tcp://10.0.0.5:8786
      tdb ingest tiles/ --db county.tdb --version 2024 --resume   # after a kill, from its finished blocks
      tdb ingest survey_2024.laz --db park.tdb --version 2024 --replace
      tdb ingest lidarhd.laz --db ign.tdb --version 2023 --exclude-classes 7,18,65
      tdb ingest ahn4.laz --db dike.tdb --version 2022 --method classified   # the provider's ground
      tdb ingest county.copc.laz --db town.tdb --version 2024 --bbox 500000,5500000,501000,5501000
    """
    import tdb
    from ingest.blocked import Blocking, ingest_blocked
    from ingest.catalog import is_catalog, too_large_to_model_whole
    from ingest.pipeline import IngestOptions, ingest
    from tdb.cli.progress import Bars

    options = IngestOptions(
        crs=crs,
        labels=LabelScheme(labels),
        assume_metres=assume_metres,
        method=GroundMethod(method),
        resolution=resolution,
        flat_threshold=flat_threshold,
        exclude=exclude,
        objects=not no_objects,
    )
    started = time.perf_counter()
    asked = (resume, block is not None, workers is not None, scheduler is not None, bbox is not None)
    blocked = any(asked) or is_catalog(cloud)
    if not blocked and too_large_to_model_whole(cloud):
        blocked = True
        click.echo(f"note: {cloud} is too large to model whole in this machine's memory: block by block", err=True)
    with tdb.open(db_path, create=True) as db, Bars(unit="step") as bars:
        if blocked:
            blocking = Blocking(block=block, workers=workers, scheduler=scheduler, region=bbox)
            v = ingest_blocked(
                str(cloud),
                db,
                version=version,
                acquired=date,
                replace=replace,
                resume=resume,
                options=options,
                blocking=blocking,
                progress=bars,
            )
        else:
            v = ingest(cloud, db, version=version, acquired=date, replace=replace, options=options, progress=bars)
    r = v.stats.reduction
    seconds = time.perf_counter() - started
    click.echo(
        _summary(
            v.stats.points, v.stats.bounds, r.tiles.get(2, 0), seconds, worker_mib=v.params.get("worker_peak_mib")
        )
    )
    click.echo(
        f"version {v.name!r} in {db_path}: {r.tiles.get(2, 0):,} tiles of 2 m, {r.kept_points:,} points kept "
        f"of {r.dense_posts:,} posts ({r.reduction_pct} % removed, RMSE {r.rmse_m} m)"
    )
    twice = v.params.get("overlap_points_dropped")
    if twice:
        click.echo(f"note: {twice:,} points were held by two overlapping tiles; each was kept once", err=True)
    user = v.stats.kept_user_classes
    if user:
        found = ", ".join(f"{n:,} of class {c}" for c, n in user.items())
        click.echo(
            f"note: the file uses classes ASPRS leaves to producers ({found}); if they mark noise or "
            "artefacts (IGN LiDAR HD: 65), ingest again with --exclude-classes 7,18,<codes> --replace",
            err=True,
        )
