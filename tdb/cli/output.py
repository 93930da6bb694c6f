"""Where query and diff results go: GeoJSON, CSV or a table as text, or a GeoPackage file."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from tdb.atomic import GEOPACKAGE, GEOTIFF, PNG, check_destination, write_text
from tdb.options import OutputFormat, parse

F = Callable[..., Any]


def output_options(func: F) -> F:
    """``--format``, ``--out``, and for GeoPackages ``--layer`` and ``--append``, for commands that
    return features."""
    func = click.option(
        "--append", is_flag=True, help="gpkg: add the layer to an existing GeoPackage (same name: replaced)."
    )(func)
    func = click.option("--layer", help="gpkg: the layer's name (default: what was selected).")(func)
    func = click.option(
        "--out", type=click.Path(path_type=Path), help="Write here instead of standard output (needed for gpkg)."
    )(func)
    return click.option(
        "--format",
        "fmt",
        type=click.Choice(OutputFormat.values()),
        default=OutputFormat.GEOJSON.value,
        show_default=True,
        help="geojson, csv or table as text; gpkg: a GeoPackage file for QGIS.",
    )(func)


def check_output(fmt: str, out: Path | None, *, layer: str | None = None, append: bool = False) -> None:
    """Refuse what cannot be written before any work is done."""
    gpkg = parse(OutputFormat, fmt) is OutputFormat.GPKG
    if gpkg and out is None:
        raise click.UsageError("--format gpkg writes a file: give --out FILE.gpkg")
    if not gpkg and (layer is not None or append):
        raise click.UsageError("--layer and --append belong to --format gpkg")
    if out is not None:
        check_destination(out, GEOPACKAGE if gpkg else (), what="a GeoPackage" if gpkg else "the output")


def check_files(*, png: Path | None = None, tif: Path | None = None) -> None:
    """Refuse a picture or a GeoTIFF that could not be written, before any work is done."""
    if png is not None:
        check_destination(png, PNG, what="a PNG picture")
    if tif is not None:
        check_destination(tif, GEOTIFF, what="a GeoTIFF")


def emit(
    features: list[dict[str, Any]],
    *,
    fmt: str,
    crs: Any,
    out: Path | None,
    layer: str,
    noun: str,
    append: bool = False,
    members: dict[str, Any] | None = None,
    side_layers: dict[str, list[dict[str, Any]]] | None = None,
) -> None:
    """Write ``features`` in ``fmt`` to ``out`` (or stdout) and say on stderr what went where;
    GeoJSON carries ``members`` beside the features, a GeoPackage the ``side_layers`` (name →
    features) beside its layer."""
    kind = parse(OutputFormat, fmt)
    if kind is OutputFormat.GPKG:
        from tdb.geopackage import write_geopackage

        assert out is not None  # check_output ran first
        side = {name: f for name, f in (side_layers or {}).items() if f}
        write_geopackage(out, {layer: features, **side}, crs=crs, append=append)
        beside = "".join(f", {len(f)} more in layer {name}" for name, f in side.items())
        click.echo(f"{len(features)} {noun} → {out}, layer {layer}{beside}", err=True)
        return
    body = render(features, kind, crs, members=members)
    if out is None:
        click.echo(body)
        return
    write_text(out, body)
    click.echo(f"{len(features)} {noun} → {out}", err=True)


def render(
    features: list[dict[str, Any]], fmt: OutputFormat, crs: Any, *, members: dict[str, Any] | None = None
) -> str:
    """Features as GeoJSON text, CSV of their properties, or an aligned table."""
    from tdb.geojson import feature_collection

    if fmt is OutputFormat.GEOJSON:
        return json.dumps(feature_collection(features, crs, members=members), allow_nan=False)
    rows = [f["properties"] for f in features]
    keys = sorted({k for r in rows for k in r})
    if fmt is OutputFormat.CSV:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
        return buf.getvalue().rstrip("\n")
    widths = {k: max(len(k), *(len(str(r.get(k, ""))) for r in rows)) for k in keys} if rows else {}
    lines = ["  ".join(k.ljust(widths[k]) for k in keys)]
    lines += ["  ".join(str(r.get(k, "")).ljust(widths[k]) for k in keys) for r in rows]
    return "\n".join(lines) + f"\n({len(rows)} rows)"
