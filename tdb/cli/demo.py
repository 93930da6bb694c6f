"""``make demo``: the main job end to end on a bundled synthetic scene.

Run as ``python -m tdb.cli.demo --out out``. Each step prints what it made and where.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def step(title: str) -> float:
    print(f"\n== {title}")
    return time.perf_counter()


def done(t0: float, what: str) -> None:
    print(f"   {what}  ({time.perf_counter() - t0:.1f} s)")


def run(out: Path, *, seed: int = 7, size: float = 250.0, density: float = 3.0) -> None:
    from ingest.readers import read
    from ingest.summary import format_summary, summarize
    from ingest.synth import apply_changes, changes_truth, make_scene, scene_truth, write_scene
    from ingest.synth.truth import write_json

    out.mkdir(parents=True, exist_ok=True)
    t = step(f"synthetic scene: {size:.0f} m square, {density} pulses/m², seed {seed}")
    scene = make_scene(seed=seed, size=size)
    n1 = write_scene(out / "survey_2020.laz", scene, density=density, seed=seed)
    write_json(out / "truth.geojson", scene_truth(scene))
    later, changes = apply_changes(scene, seed=seed)
    n2 = write_scene(out / "survey_2024.laz", later, density=density, seed=seed + 1)
    write_json(out / "changes.geojson", changes_truth(changes, scene.crs))
    done(
        t,
        f"{out / 'survey_2020.laz'} ({n1:,} points), {out / 'survey_2024.laz'} ({n2:,} points), "
        f"truth.geojson, changes.geojson",
    )

    t = step("what the first survey holds (tdb info)")
    print("   " + format_summary(summarize(read(out / "survey_2020.laz"))).replace("\n", "\n   "))
    done(t, "read back")

    import tdb
    from ingest.pipeline import ingest
    from queries.area import area_mesh, area_surface, write_ply
    from tdb.geotiff import write_geotiff
    from tdb.pictures import area_picture, category_atlas

    db_path = out / "park.tdb"
    for suffix in ("", "-wal", "-shm"):
        Path(f"{db_path}{suffix}").unlink(missing_ok=True)
    with tdb.open(db_path, create=True) as db:
        for name, laz, day in (
            ("2020", "survey_2020.laz", "2020-04-01"),
            ("2024", "survey_2024.laz", "2024-04-01"),
        ):
            t = step(f"ingest {laz} as version {name} (ground → dense model → categories → database)")
            import datetime as dt

            v = ingest(out / laz, db, version=name, acquired=dt.date.fromisoformat(day))
            r = v.stats.reduction
            done(
                t,
                f"{r.tiles.get(2, 0):,} tiles of 2 m; {r.kept_points:,} of {r.dense_posts:,} posts kept "
                f"({r.reduction_pct} % removed, RMSE {r.rmse_m} m)",
            )
        t = step("area of interest: mesh, surface and category picture (tdb aoi)")
        x0, y0 = scene.bounds[:2]
        area = db.aoi((x0 + 25, y0 + 25, x0 + 225, y0 + 225), level=2, version="2020")
        mesh = area_mesh(area)
        surface = area_surface(area, crs=db.crs("2020"), mesh=mesh)
        from queries.changes import detect, level_of_detection
        from queries.coregister import coregister
        from queries.dod import difference_of_surfaces
        from queries.run import run
        from tdb.geojson import feature_collection
        from tdb.geopackage import write_geopackage
        from tdb.pictures import change_map

        t2 = step("queries: ditches, and what changed from 2020 to 2024 (tdb query, tdb diff)")
        ditches = run(db, 'SELECT ditch FROM "2020" WHERE length > 10 AND depth > 0.3')
        write_json(out / "ditches.geojson", feature_collection(ditches, db.crs("2020")))
        shift = coregister(db, "2020", "2024")  # as tdb diff does by default
        print(f"   co-registration: {shift.describe()}")
        found = detect(db, "2020", "2024", shift=shift)
        members = {"coregistration": shift.to_json()}
        write_json(out / "diff.geojson", feature_collection(found, db.crs("2024"), members=members))
        dod = difference_of_surfaces(db, "2020", "2024", shift=shift)
        write_geotiff(out / "dod.tif", dod, tags={"before": "2020", "after": "2024", "units": "m"})
        change_map(
            out / "diff.png",
            found,
            title=f"2020 → 2024, 2 m tiles\n{shift.title()}",
            dod=dod,
            lod=level_of_detection(db, "2020", "2024", shift=shift),
        )
        write_geopackage(out / "results.gpkg", {"ditches_2020": ditches, "changes": found}, crs=db.crs("2024"))
        kinds = sorted({f["properties"]["kind"] for f in found})
        done(
            t2,
            f"{len(ditches)} ditch lines → ditches.geojson; {len(found)} changed regions ({', '.join(kinds)}) "
            "→ diff.geojson, diff.png (over the DEM of difference, dod.tif); both layers in results.gpkg "
            "(QGIS); true changes are in changes.geojson",
        )
        t3 = step("trees and buildings, and what changed of them (SELECT trees, buildings, object_changes)")
        trees = run(db, 'SELECT trees FROM "2020" WHERE height >= 5')
        houses = run(db, 'SELECT buildings FROM "2020"')
        moved = run(db, 'SELECT object_changes FROM "2020" TO "2024"')
        write_geopackage(
            out / "objects.gpkg",
            {"trees_2020": trees, "buildings_2020": houses, "changes": moved},
            crs=db.crs("2024"),
        )
        counts = ", ".join(
            f"{k}: {sum(f['properties']['kind'] == k for f in moved)}"
            for k in sorted({f["properties"]["kind"] for f in moved})
        )
        done(
            t3,
            f"{len(trees)} trees of 5 m or more, {len(houses)} buildings; {counts or 'no changes'} → objects.gpkg",
        )
    write_ply(out / "aoi.ply", area, mesh=mesh)
    write_geotiff(out / "aoi.tif", surface)
    area_picture(out / "aoi.png", area, surface)
    category_atlas(out / "atlas.png")
    done(t, f"{out / 'aoi.ply'}, {out / 'aoi.tif'}, {out / 'aoi.png'}, {out / 'atlas.png'}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("out"), help="folder for everything the demo makes")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    from tdb.errors import TdbError

    try:
        run(args.out, seed=args.seed)
    except TdbError as exc:
        print(f"demo: error: {exc}", file=sys.stderr)
        return 1
    print(f"\nAll outputs are in {args.out.resolve()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
