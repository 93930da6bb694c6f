"""``tdb ground``: classify ground points and write the dense ground model."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.cli.options import exclude_option, input_options, method_option, positive_metres


@click.command("ground")
@click.argument("cloud", type=click.Path(path_type=Path))
@method_option
@click.option(
    "--out", type=click.Path(path_type=Path), help="LAS/LAZ of the input points, class 2 ground, 1 other."
)
@click.option("--dtm", type=click.Path(path_type=Path), help="GeoTIFF of the dense ground model.")
@click.option(
    "--resolution", type=float, default=0.5, show_default=True, callback=positive_metres, help="DTM cell size (m)."
)
@click.option("--assume-metres", is_flag=True, help="Accept a file with no CRS as metres.")
@input_options
@exclude_option
def command(
    cloud: Path,
    method: str,
    out: Path | None,
    dtm: Path | None,
    resolution: float,
    assume_metres: bool,
    crs: str | None,
    labels: str,
    exclude: tuple[int, ...],
) -> None:
    """Find the ground in a point cloud.

    Points keep their input order; the output carries classification 2 for
    ground and 1 for everything else, in the input's coordinates and CRS.
    Points of the excluded classes (ASPRS noise by default) keep their own class.

    \b
    Examples:
      tdb ground survey.laz --out ground.laz --dtm dtm.tif
      tdb ground survey.laz --method sohn --out sohn.laz
      tdb ground classified.laz --method classified --dtm dtm.tif   # the file's own ground class
      tdb ground samp11.txt --crs EPSG:32632 --dtm samp11.tif --resolution 1
      tdb ground lidarhd.laz --exclude-classes 7,18,65 --out ground.laz
    """
    import numpy as np

    from ingest.dtm import dense_model
    from ingest.ground import classify_ground
    from ingest.readers import read, write_classified
    from tdb.atomic import GEOTIFF, POINTS, check_destination
    from tdb.cli.progress import Bars
    from tdb.units import to_metres

    if out:
        check_destination(out, POINTS, what="a point file")
    if dtm:
        check_destination(dtm, GEOTIFF, what="a GeoTIFF")
    raw = read(cloud, crs=crs, labels=labels)
    metric = to_metres(raw, assume_metres=assume_metres)
    with Bars(unit="tile") as bars:
        ground = classify_ground(metric, method=method, progress=bars, exclude=exclude)
    click.echo(f"{int(ground.sum()):,} of {len(raw):,} points are ground ({100 * ground.mean():.1f} %)")
    if out:
        labels_out = np.where(ground, 2, 1).astype(np.uint8)
        kept = raw.excluded(exclude)
        labels_out[kept] = raw.classification[kept]
        write_classified(out, raw, labels_out)
        click.echo(f"wrote {out}")
    if dtm:
        from tdb.geotiff import write_geotiff

        model = dense_model(metric.xyz[ground], resolution=resolution, crs=metric.crs)
        write_geotiff(dtm, model)
        click.echo(f"wrote {dtm} ({model.shape[1]} × {model.shape[0]} cells of {resolution} m)")
