"""tdb's ditch and ridge queries beside two peers, on rugged synthetic scenes, in one run.

Each scene (``make_scene(terrain="rugged")``: natural valleys and spurs, roads with
shoulders, field edges, fading ditches, ditches under trees) is sampled and ingested;
tdb answers plain ``SELECT ditch``, ``SELECT ridge`` and the size class
``SELECT ditch … WHERE depth >= 0.5 AND width >= 1.5``. The peers
(:mod:`benchmarks.line_peers`: a local relief model, GRASS geomorphons) read a 1 m model:
the exact bare earth, and tdb's own dense model from its ground filter.

Scoring is by length, as in :mod:`benchmarks.features` (within 2 m), read at points
every 0.25 m. Recall counts the true ditches where they are at least 0.3 m deep (0.5 m
for the size class; a fading ditch's faint end is not asked for) and the ridges;
precision counts a reported line right near any true ditch, or near a ridge or a wall (no peer parts the two).

The peers' settings are chosen by leave-one-scene-out: each scene is scored with the
setting of best mean F1 on the other scenes. Beside it, the setting chosen on all scenes.
tdb's settings were chosen on the plain scenes, none on these.
    python -m benchmarks.feature_peers [--seeds 1,2,3,4,5] [--size 400] [--density 4]
Other densities are saved beside the main table (``feature_peers_d1.json`` …) and reported as its
density rows.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from pyproj import CRS
from shapely.ops import substring

import tdb
from benchmarks.common import save
from benchmarks.features import CLASS_QUERY, TOL
from benchmarks.line_peers import (
    geomorphon_forms,
    geomorphon_lines,
    geomorphon_settings,
    grass_available,
    relief_lines,
    relief_settings,
)
from ingest.dtm import dense_model
from ingest.ground import classify_ground
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import ground_grid, make_scene, sample
from ingest.synth.forms import Feature
from ingest.synth.scene import Scene
from queries.match import find
from queries.run import run
from tdb.raster import Raster

CELL = 1.0
DENSITY = 4.0  # pulses/m² of the main table
STEP = 0.25  # m between the points at which lines are scored
KINDS = ("ditch", "ridge")
Truth = tuple[list[shapely.Geometry], list[shapely.Geometry]]  # what recall counts, what precision counts


def _deeper_than(f: Feature, depth: float) -> shapely.Geometry:
    """The part of a ditch at least ``depth`` deep (a fading ditch's faint end is left out)."""
    if f.end_size is None:
        return f.geometry if f.size >= depth else shapely.LineString()
    last = (f.size - depth) / (f.size - f.end_size) if f.size > depth else 0.0
    return substring(f.geometry, 0.0, min(1.0, last), normalized=True) if last > 0 else shapely.LineString()


def truths(scene: Scene) -> dict[str, Truth]:
    """Per kind: (what recall counts, what precision counts)."""
    ditches = [f for f in scene.features if f.kind == "ditch"]
    forms = [f.geometry for f in scene.features if f.kind in ("ridge", "wall")]

    def parts(depth: float) -> list[shapely.Geometry]:
        return [g for g in (_deeper_than(f, depth) for f in ditches) if not g.is_empty]

    return {
        "ditch": (parts(0.3), [f.geometry for f in ditches]),
        "ditch_class": (parts(0.5), parts(0.5)),
        "ridge": ([f.geometry for f in scene.features if f.kind == "ridge"], forms),
    }


def _share_near(lines: list[shapely.Geometry], targets: list[shapely.Geometry]) -> float:
    """Share of the length of ``lines`` lying within ``TOL`` of ``targets``, read at points
    every ``STEP`` m (buffering thousands of skeleton segments is what would take the time)."""
    parts = [p for g in lines for p in shapely.get_parts(g) if p.length > 0]
    if not parts:
        return float("nan")
    dense = shapely.segmentize(np.array(parts, dtype=object), STEP)
    points = shapely.points(shapely.get_coordinates(dense))
    if not targets:
        return 0.0
    near = shapely.STRtree(targets).query(points, predicate="dwithin", distance=TOL)[0]
    return len(np.unique(near)) / len(points)


def figures(truth: Truth, found: shapely.Geometry) -> dict[str, float]:
    parts = list(shapely.get_parts(found)) if not found.is_empty else []
    recall = _share_near(truth[0], parts) if truth[0] else float("nan")
    precision = _share_near(parts, truth[1])
    f1 = 2 * recall * precision / (recall + precision) if recall + precision > 0 else 0.0
    return {"recall": recall, "precision": precision, "f1": float(np.nan_to_num(f1))}


def _tdb(db: tdb.Database, truth: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for name, ask in (
        ("ditch", lambda: [m.geometry for m in find(db, "v", "ditch")]),
        ("ridge", lambda: [m.geometry for m in find(db, "v", "ridge")]),
        ("ditch_class", lambda: [shapely.geometry.shape(f["geometry"]) for f in run(db, CLASS_QUERY)]),
    ):
        t0 = time.perf_counter()
        found = shapely.union_all(ask())
        out[name] = {**figures(truth[name], found), "query_s": time.perf_counter() - t0}
    return out


def _peer_grid(
    lines: Callable[[Any, str], shapely.Geometry], settings: list[Any], truth: dict[str, Any]
) -> dict[str, list[dict[str, float]]]:
    """Per kind, the figures of every setting in order."""
    return {kind: [figures(truth[kind], lines(s, kind)) for s in settings] for kind in KINDS}


def evaluate(seed: int, size: float, density: float, workdir: Path) -> dict[str, Any]:
    scene = make_scene(seed=seed, size=size, terrain="rugged")
    truth = truths(scene)
    cloud = sample(scene, density=density, seed=seed)
    db = tdb.open(workdir / f"s{seed}.tdb", create=True)
    t0 = time.perf_counter()
    ingest(cloud, db, version="v", options=IngestOptions(exclude=()))
    out: dict[str, Any] = {"ingest_s": time.perf_counter() - t0, "tdb": _tdb(db, truth)}
    _, _, z = ground_grid(scene, resolution=CELL)
    crs = CRS(scene.crs)
    models = {"exact": Raster(z, scene.bounds[0], scene.bounds[3], CELL, crs)}
    ground = classify_ground(cloud, exclude=())
    models["tdb_dtm"] = dense_model(cloud.xyz[ground], resolution=CELL, bounds=scene.bounds, crs=crs)
    for name, dtm in models.items():
        lrm = relief_settings()
        out[f"relief_{name}"] = _peer_grid(lambda s, k, d=dtm: relief_lines(d, s, kind=k), lrm, truth)
        if grass_available():
            gms = geomorphon_settings()
            forms = geomorphon_forms(dtm, gms)
            out[f"geomorphon_{name}"] = _peer_grid(
                lambda s, k, d=dtm, f=forms: geomorphon_lines(f[(s.search, s.flat)], d, s, kind=k), gms, truth
            )
    return out


def cross_validate(per_scene: dict[int, list[dict[str, float]]]) -> dict[str, Any]:
    """Leave-one-scene-out choice of setting by mean F1; the held-out and the tuned figures per scene."""
    seeds = sorted(per_scene)
    f1 = np.array([[r["f1"] for r in per_scene[s]] for s in seeds])
    best_all = int(np.argmax(f1.mean(axis=0)))
    out: dict[str, Any] = {"tuned_setting": best_all, "held_out": {}, "tuned": {}}
    for i, s in enumerate(seeds):
        others = np.delete(f1, i, axis=0).mean(axis=0)
        pick = int(np.argmax(others))
        out["held_out"][s] = {**per_scene[s][pick], "setting": pick}
        out["tuned"][s] = per_scene[s][best_all]
    for part in ("held_out", "tuned"):
        out[f"{part}_mean"] = {
            m: float(np.nanmean([out[part][s][m] for s in seeds])) for m in ("recall", "precision", "f1")
        }
    return out


def summarise(runs: dict[int, dict[str, Any]]) -> dict[str, Any]:
    seeds = sorted(runs)
    summary: dict[str, Any] = {
        "tdb": {
            k: {m: float(np.nanmean([runs[s]["tdb"][k][m] for s in seeds])) for m in ("recall", "precision", "f1")}
            for k in ("ditch", "ridge", "ditch_class")
        }
    }
    for method in (m for m in runs[seeds[0]] if m.startswith(("relief_", "geomorphon_"))):
        summary[method] = {k: cross_validate({s: runs[s][method][k] for s in seeds}) for k in KINDS}
    return summary


def result_name(density: float) -> str:
    """The results file of a run: the 4 pulses/m² one is the main table, the others its density rows."""
    return "feature_peers" if density == DENSITY else f"feature_peers_d{density:g}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--size", type=float, default=400.0)
    parser.add_argument("--density", type=float, default=DENSITY)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    runs = {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            t0 = time.perf_counter()
            runs[seed] = evaluate(seed, args.size, args.density, Path(tmp))
            print(f"seed {seed}: {time.perf_counter() - t0:.0f} s, tdb {runs[seed]['tdb']}", flush=True)
    summary = summarise(runs)
    settings = {
        "relief": [vars(s) for s in relief_settings()],
        "geomorphon": [vars(s) for s in geomorphon_settings()] if grass_available() else [],
    }
    path = save(
        result_name(args.density),
        {"size": args.size, "density": args.density, "runs": runs, "summary": summary, "settings": settings},
    )
    for method, kinds in summary.items():
        for kind, r in kinds.items():
            print(method, kind, r.get("held_out_mean", r), r.get("tuned_mean", ""))
    print(path)


if __name__ == "__main__":
    main()
