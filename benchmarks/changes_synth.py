"""Change detection on synthetic survey pairs: recall and precision by area, and typing.

Each seed makes a scene and its re-survey with known changes (ditch dug, ditch
filled, mound removed, wall built; the added building is not a ground change).
Terrain changes at least 0.5 m high or deep are the truth. A true change's area
counts as found where a reported region covers it; a reported region's area is
right where it lies within 2 m (one tile) of a true change.

The speed of a diff over 1 km² is measured on a mosaic of 4 × 4 scene pairs of
250 m (one cloud per survey, 4 M points each), diffed over its whole extent.
    python -m benchmarks.changes_synth [--seeds 1,2,3] [--size 300] [--density 4]
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import shapely

import tdb
from benchmarks.common import save, synthetic_runs
from ingest.pipeline import ingest
from ingest.synth import apply_changes, make_scene, sample
from queries.changes import detect

EXPECTED = {
    "ditch_dug": "ditch dug",
    "ditch_filled": "ditch filled",
    "mound_removed": "mound removed",
    "wall_built": "ridge or wall built",
}


def evaluate(seed: int, size: float, density: float, workdir: Path) -> dict[str, object]:
    scene = make_scene(seed=seed, size=size)
    later, changes = apply_changes(scene, seed=seed)
    db = tdb.open(workdir / f"c{seed}.tdb", create=True)
    ingest(sample(scene, density=density, seed=seed), db, version="before")
    ingest(sample(later, density=density, seed=seed + 1000), db, version="after")
    t0 = time.perf_counter()
    found = detect(db, "before", "after")
    diff_s = time.perf_counter() - t0
    truth = [c for c in changes if c.terrain and abs(c.dz) >= 0.5]
    true_area = shapely.union_all([c.area for c in truth]) if truth else shapely.GeometryCollection()
    regions = [(shapely.geometry.shape(f["geometry"]), f["properties"]["kind"]) for f in found]
    found_area = shapely.union_all([g for g, _ in regions]) if regions else shapely.GeometryCollection()
    recall = true_area.intersection(found_area).area / true_area.area if true_area.area else float("nan")
    near = true_area.buffer(2.0)
    precision = found_area.intersection(near).area / found_area.area if found_area.area else float("nan")
    typed = {}
    for c in truth:
        overlaps = [(g.intersection(c.area).area, kind) for g, kind in regions]
        best = max(overlaps, default=(0.0, None))
        typed[c.kind] = {"expected": EXPECTED.get(c.kind), "got": best[1] if best[0] > 0 else None}
    return {"recall": recall, "precision": precision, "typed": typed, "regions": len(regions), "diff_s": diff_s}


def mosaic_diff_seconds(
    workdir: Path, *, density: float, blocks: int = 4, size: float = 250.0
) -> dict[str, float]:
    """Seconds of three diffs over a ``blocks`` × ``blocks`` mosaic of changed scene pairs."""
    from ingest.synth.scene import DEFAULT_ORIGIN
    from tdb.cloud import PointCloud

    before, after = [], []
    for k in range(blocks * blocks):
        origin = (DEFAULT_ORIGIN[0] + size * (k % blocks), DEFAULT_ORIGIN[1] + size * (k // blocks))
        scene = make_scene(seed=100 + k, size=size, origin=origin)
        later, _ = apply_changes(scene, seed=100 + k)
        before.append(sample(scene, density=density, seed=k))
        after.append(sample(later, density=density, seed=k + 1000))
    db = tdb.open(workdir / "mosaic.tdb", create=True)
    for name, parts in (("before", before), ("after", after)):
        cloud = PointCloud(
            np.concatenate([c.xyz for c in parts]),
            np.concatenate([c.classification for c in parts]),
            np.concatenate([c.return_number for c in parts]),
            np.concatenate([c.number_of_returns for c in parts]),
            crs=parts[0].crs,
        )
        ingest(cloud, db, version=name)
    seconds = []
    for _ in range(3):
        t0 = time.perf_counter()
        found = detect(db, "before", "after")
        seconds.append(time.perf_counter() - t0)
    side = blocks * size
    return {"km2": side * side / 1e6, "seconds": float(np.median(seconds)), "regions": len(found)}


def main() -> None:
    runs, settings = synthetic_runs(__doc__, evaluate)
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        settings["mosaic"] = mosaic_diff_seconds(Path(tmp), density=float(settings["density"]))
    print(settings["mosaic"])
    typed = [t for r in runs.values() for t in r["typed"].values()]  # type: ignore[attr-defined]
    summary = {
        "recall": float(np.mean([r["recall"] for r in runs.values()])),
        "precision": float(np.mean([r["precision"] for r in runs.values()])),
        "typed_right": sum(t["expected"] == t["got"] for t in typed),
        "changes": len(typed),
    }
    print(summary)
    print(save("changes_synth", {"runs": runs, "mean": summary, **settings}))


if __name__ == "__main__":
    main()
