"""``tdb info``: what a point cloud (or terrain database) holds."""

from __future__ import annotations

import json
from pathlib import Path

import click

from tdb.cli.options import DATABASE, input_options
from tdb.evidence import DEEP, GROUNDED
from tdb.geojson import finite
from tdb.tiles import LEVELS


@click.command("info")
@click.argument("path", type=DATABASE)
@input_options
@click.option("--json", "as_json", is_flag=True, help="Print the facts as JSON.")
def command(path: Path | str, crs: str | None, labels: str, as_json: bool) -> None:
    """Describe a point cloud: counts, bounds, CRS, units, density, classes, returns.

    \b
    Examples:
      tdb info survey.laz
      tdb info samp11.txt --crs EPSG:32632 --labels isprs
      tdb info area.tdb          # a terrain database: versions and extents
    """
    from tdb.database import is_database

    if "://" in str(path) or is_database(path):
        _database_info(path, as_json)
        return
    from ingest.readers import read
    from ingest.summary import format_summary, summarize

    info = summarize(read(path, crs=crs, labels=labels, validate=True))
    click.echo(json.dumps(finite(info), indent=2, allow_nan=False) if as_json else format_summary(info))


def _database_info(path: Path | str, as_json: bool) -> None:
    import tdb
    from tdb.crs import describe, horizontal_part, vertical_part

    with tdb.open(path, readonly=True) as db:
        versions = db.versions()
        crs = {v.name: db.crs(v.name) for v in versions}
        objects = {v.name: db.object_counts(v.name) for v in versions}
        doc = {
            "database": str(path),
            "schema_version": db.schema_version(),
            "versions": [
                {
                    "name": v.name,
                    "acquired": v.acquired.isoformat() if v.acquired else None,
                    "source": v.source,
                    "created": v.created,
                    "horizontal_crs": describe(horizontal_part(crs[v.name])),
                    "vertical_crs": describe(vertical_part(crs[v.name])),
                    "params": v.params,
                    "stats": v.stats.to_json(),
                    "trees": objects[v.name][0],
                    "buildings": objects[v.name][1],
                }
                for v in versions
            ],
        }
    if as_json:
        click.echo(json.dumps(finite(doc), indent=2, allow_nan=False))  # JSON has no NaN: null
        return
    click.echo(f"database:    {path} (schema {doc['schema_version']}), {len(versions)} version(s)")
    for v in versions:
        s, r = v.stats, v.stats.reduction
        b = s.bounds or (0.0, 0.0, 0.0, 0.0)
        click.echo(f"- {v.name}: acquired {v.acquired or 'unknown'}, from {v.source}")
        click.echo(
            f"    horizontal CRS {describe(horizontal_part(crs[v.name]))}; "
            f"heights {describe(vertical_part(crs[v.name]))}"
        )
        click.echo(f"    extent x {b[0]:.1f} .. {b[2]:.1f}, y {b[1]:.1f} .. {b[3]:.1f}")
        click.echo(
            f"    tiles {'/'.join(map(str, LEVELS))} m: {'/'.join(str(r.tiles.get(lv)) for lv in LEVELS)}; "
            f"points kept {r.kept_points:,} of {r.dense_posts:,} posts "
            f"({r.reduction_pct} % removed, RMSE {r.rmse_m} m, max {r.max_error_m} m)"
        )
        click.echo(
            f"    ground noise {s.noise_m} m, flat threshold {s.flat_threshold_m} m, "
            f"method {v.params.get('method')}"
        )
        if s.seen_pct is not None:  # versions from before ground evidence was kept have none
            click.echo(
                f"    ground seen under {s.seen_pct} % of the 2 m tiles; median surface uncertainty {s.sigma_m} m"
            )
        if s.deep_pct is not None:  # versions from before the depth was kept have none
            click.echo(
                f"    surface may stand {DEEP} m or more over the ground its returns saw in {s.deep_pct} % of the "
                "2 m tiles (vegetation taken for ground: rises there are cut)"
            )
        if s.covered_pct is not None:  # versions from before the pulses were kept have none
            click.echo(
                f"    under cover in {s.covered_pct} % of the 2 m tiles (most pulses ended above what was taken "
                f"for ground, and fewer than {GROUNDED:g} per m² reached it: no change is claimed where this "
                "version's surface stands higher there)"
            )
        click.echo(f"    trees {objects[v.name][0]:,}, buildings {objects[v.name][1]:,}")
        if "exclude_classes" in v.params:  # versions from before the option have no record
            classes = ",".join(map(str, v.params["exclude_classes"])) or "none"
            left_out = f"{s.excluded_points:,} of {s.points:,} points"
            click.echo(f"    excluded (classes {classes}, or withheld): {left_out}")
        twice = v.params.get("overlap_points_dropped")
        if twice:
            click.echo(f"    points overlapping tiles held twice, kept once: {twice:,}")
