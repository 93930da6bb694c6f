"""Ditch, ridge, wall, mound and pit queries against synthetic truth.

Lines by length: a true line counts as found where a reported line lies within 2 m
of it; a reported line is right where a true line of that kind lies within 2 m.
Mounds and pits by count: a true one at least 0.5 m high (deep) is found where a
reported polygon lies within 2 m of its centre; a reported polygon is right where it
lies within 2 m of the footprint of a true one of any size. Walls (1–1.6 m wide,
1–1.8 m high) and ridges (3–6 m wide) make the same tiles; the ridge and wall filters
part them by their shoulders (queries/shoulder.py). ``precision_forms`` counts a
reported ridge or wall right near either. ``ditch_class`` asks for the size class
itself, ``SELECT ditch … WHERE depth >= 0.5 AND width >= 1.5``: stretches measured by
their cross-sections (queries/profile.py), scored against the same truth.
    python -m benchmarks.features [--seeds 1,2,...,10] [--size 300] [--density 4]
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import shapely

import tdb
from benchmarks.common import save_runs, synthetic_runs
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import make_scene, sample
from queries.match import find
from queries.run import run

TOL = 2.0
CLASS_QUERY = "SELECT ditch FROM v WHERE depth >= 0.5 AND width >= 1.5"


def score(truth: list[shapely.Geometry], found: list[shapely.Geometry]) -> tuple[float, float]:
    t = shapely.union_all(truth) if truth else shapely.GeometryCollection()
    f = shapely.union_all(found) if found else shapely.GeometryCollection()
    recall = t.intersection(f.buffer(TOL)).length / t.length if t.length else float("nan")
    precision = f.intersection(t.buffer(TOL)).length / f.length if f.length else float("nan")
    return recall, precision


def evaluate(seed: int, size: float, density: float, workdir: Path) -> dict[str, dict[str, float]]:
    scene = make_scene(seed=seed, size=size)
    db = tdb.open(workdir / f"s{seed}.tdb", create=True)
    # the scenes' low outliers (class 7) stay in: the filter must find them, as in an unclassified survey
    ingest(sample(scene, density=density, seed=seed), db, version="v", options=IngestOptions(exclude=()))
    out = {}
    size_class = lambda f: f.kind == "ditch" and f.size >= 0.5 and f.width >= 1.5  # noqa: E731
    for name, cut, forms, ask in (
        ("ditch", size_class, ("ditch",), lambda: [m.geometry for m in find(db, "v", "ditch")]),
        (
            "ridge",
            lambda f: f.kind == "ridge",
            ("ridge", "wall"),
            lambda: [m.geometry for m in find(db, "v", "ridge")],
        ),
        (
            "wall",
            lambda f: f.kind == "wall",
            ("ridge", "wall"),
            lambda: [m.geometry for m in find(db, "v", "wall")],
        ),
        (
            "ditch_class",
            size_class,
            ("ditch",),
            lambda: [shapely.geometry.shape(f["geometry"]) for f in run(db, CLASS_QUERY)],
        ),
    ):
        truth = [f.geometry for f in scene.features if cut(f)]
        t0 = time.perf_counter()
        found = ask()
        seconds = time.perf_counter() - t0
        r, p = score(truth, found)
        _, p_forms = score([f.geometry for f in scene.features if f.kind in forms], found)
        out[name] = {
            "recall": r,
            "precision": p,
            "precision_forms": p_forms,
            "true_m": float(sum(g.length for g in truth)),
            "found_m": float(sum(g.length for g in found)),
            "query_s": seconds,
        }
    for kind in ("mound", "pit"):
        t0 = time.perf_counter()
        found = [m.geometry for m in find(db, "v", kind)]
        seconds = time.perf_counter() - t0
        centres = [f.geometry for f in scene.features if f.kind == kind and f.size >= 0.5]
        footprints = [f.geometry.buffer(f.width / 2) for f in scene.features if f.kind == kind]
        hits = shapely.union_all(found) if found else shapely.GeometryCollection()
        anywhere = shapely.union_all(footprints) if footprints else shapely.GeometryCollection()
        out[kind] = {
            "recall": sum(hits.distance(c) <= TOL for c in centres) / len(centres) if centres else float("nan"),
            "precision": sum(g.distance(anywhere) <= TOL for g in found) / len(found) if found else float("nan"),
            "true": len(centres),
            "found": len(found),
            "query_s": seconds,
        }
    return out


def _mean(runs: dict[int, Any]) -> dict[str, dict[str, float]]:
    summary = {
        k: {m: float(np.mean([runs[s][k][m] for s in runs])) for m in ("recall", "precision", "precision_forms")}
        for k in ("ditch", "ditch_class", "ridge", "wall")
    }
    for k in ("mound", "pit"):
        summary[k] = {m: float(np.nanmean([runs[s][k][m] for s in runs])) for m in ("recall", "precision")}
    return summary


def main() -> None:
    runs, settings = synthetic_runs(__doc__, evaluate)
    print(save_runs("features", runs, settings, _mean))


if __name__ == "__main__":
    main()
