"""``tdb synth``: a synthetic LiDAR scene with exact ground truth."""

from __future__ import annotations

from pathlib import Path

import click

from tdb.options import Terrain


@click.command("synth")
@click.option(
    "--out", "out", type=click.Path(path_type=Path), required=True, help="Point file to write (.las/.laz)."
)
@click.option("--truth", type=click.Path(path_type=Path), help="GeoJSON of the true features.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed: same seed, same scene.")
@click.option(
    "--size", type=float, default=300.0, show_default=True, help="Side of the square scene (m), 100..20000."
)
@click.option("--density", type=float, default=4.0, show_default=True, help="Pulses per m², 0.05..50.")
@click.option("--changed", type=click.Path(path_type=Path), help="Also write a later survey with known changes.")
@click.option("--changes", type=click.Path(path_type=Path), help="GeoJSON of the changes (with --changed).")
@click.option(
    "--terrain",
    type=click.Choice(Terrain.values()),
    default=Terrain.PLAIN.value,
    show_default=True,
    help="rugged adds natural valleys and spurs, roads, field edges, fading ditches and ditches under trees.",
)
def command(
    out: Path,
    truth: Path | None,
    seed: int,
    size: float,
    density: float,
    changed: Path | None,
    changes: Path | None,
    terrain: str,
) -> None:
    """Write a synthetic scene: relief, ditches, ridges, walls, an embankment, pits,
    mounds, buildings and trees, classified 2 ground, 5 vegetation, 6 building, 7 noise.

    \b
    Examples:
      tdb synth --out scene.laz --truth truth.geojson
      tdb synth --size 1000 --density 10 --seed 3 --out big.laz
      tdb synth --out v1.laz --changed v2.laz --changes changes.geojson
      tdb synth --terrain rugged --size 400 --out rugged.laz --truth truth.geojson
    """
    from ingest.synth import apply_changes, changes_truth, make_scene, scene_truth, write_scene
    from ingest.synth.truth import write_json
    from tdb.atomic import POINTS, check_destination
    from tdb.cli.progress import Bars

    if changes and not changed:
        raise click.UsageError("--changes describes the later survey: give --changed FILE too")
    files = [p.resolve() for p in (out, truth, changed, changes) if p is not None]
    if len(set(files)) < len(files):
        raise click.UsageError("each output needs its own file")
    for path in (out, changed):
        if path is not None:
            check_destination(path, POINTS, what="a point file")
    for path in (truth, changes):
        if path is not None:
            check_destination(path, what="a GeoJSON file")
    scene = make_scene(seed=seed, size=size, terrain=terrain)
    with Bars(unit="block") as bars:
        n = write_scene(out, scene, density=density, seed=seed, progress=bars)
    click.echo(f"wrote {n:,} points to {out}")
    if truth:
        write_json(truth, scene_truth(scene))
        click.echo(
            f"wrote {len(scene.features)} features, {len(scene.buildings)} buildings, "
            f"{len(scene.trees)} trees to {truth}"
        )
    if changed:
        later, diffs = apply_changes(scene, seed=seed)
        with Bars(unit="block") as bars:
            n2 = write_scene(changed, later, density=density, seed=seed + 1, progress=bars)
        click.echo(f"wrote {n2:,} points of the changed scene to {changed}")
        if changes:
            write_json(changes, changes_truth(diffs, scene.crs))
            click.echo(f"wrote {len(diffs)} changes to {changes}")
