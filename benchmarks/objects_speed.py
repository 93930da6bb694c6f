"""Speed of the objects step (issue 28): vegetation and buildings, trees, footprints.

On a synthetic scene (500 m, 10 pulses/m², seed 1) and the real files: the points per second
of :func:`ingest.objects.find_objects` (the ground model given, as ``tdb classify`` and
``tdb trees`` run it after the ground filter), and the time of a whole ``tdb ingest`` with the
objects and without (``IngestOptions(objects=False)``, ``--no-objects``), run in turns. Medians
of five, in the plain environment.

    python -m benchmarks.objects_speed
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import tdb
from benchmarks.common import DATA, save
from benchmarks.objects_cv import ground_model
from ingest.objects import find_objects
from ingest.pipeline import IngestOptions, ingest
from ingest.readers import read
from ingest.synth import make_scene
from ingest.synth import sample as survey_of
from tdb.classes import NOISE, excluded
from tdb.cloud import PointCloud
from tdb.units import to_metres

SIZE, DENSITY, SEED = 500.0, 10.0, 1
REAL = ("las/MixedConifer.laz", "epochs/TTP_2019.laz")
RUNS = 5


def _median_time(run: Any) -> float:
    times = []
    for _ in range(RUNS):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def objects_rate(cloud: PointCloud) -> dict[str, float]:
    ground, dtm = ground_model(cloud)
    skip = excluded(cloud.classification, NOISE)
    seconds = _median_time(lambda: find_objects(cloud, ground, dtm, skip=skip))
    return {"points": len(cloud), "seconds": seconds, "points_per_s": len(cloud) / seconds}


def ingest_times(cloud: PointCloud) -> dict[str, float]:
    """Medians of runs with and without the objects, taken in turns: the machine's speed drifts
    over minutes, and two blocks of runs one after the other would read the drift as a cost."""
    times: dict[str, list[float]] = {"with_objects": [], "without_objects": []}
    with tempfile.TemporaryDirectory() as tmp:
        db = tdb.open(Path(tmp) / "s.tdb", create=True)
        for k in range(RUNS):
            for label, objects in (("with_objects", True), ("without_objects", False)):
                start = time.perf_counter()
                ingest(cloud, db, version=f"{label}{k}", options=IngestOptions(objects=objects))
                times[label].append(time.perf_counter() - start)
        db.close()
    out = {label: statistics.median(t) for label, t in times.items()}
    out["slowdown_pct"] = 100 * (out["with_objects"] / out["without_objects"] - 1)
    return out


def main() -> None:
    scene = survey_of(make_scene(seed=SEED, size=SIZE), density=DENSITY, seed=SEED)
    doc: dict[str, Any] = {"scene": {"size_m": SIZE, "density": DENSITY, "seed": SEED, **objects_rate(scene)}}
    doc["ingest"] = ingest_times(scene)
    print(doc, flush=True)
    for name in REAL:
        if (DATA / name).exists():
            doc[name] = objects_rate(to_metres(read(DATA / name)))
            print(name, doc[name], flush=True)
    save("objects_speed", doc)


if __name__ == "__main__":
    main()
