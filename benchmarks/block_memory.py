"""A block's peak memory against its read box and its points: the measure behind
:mod:`ingest.block_size`.

Each case is one block's read box (its square and buffer) modelled as a worker models it
(``survey`` with the block's extent, the model beyond the ground within the block's margin, then
the reduction figures, its allocator keeping freed memory), in a fresh process; its peak RSS
less the process's own before the block's points are read. Beside it, what
:func:`ingest.block_size.block_bytes` predicts for the same box and points: the prediction must
not fall short, or a worker could exceed its memory.

    python -m benchmarks.block_memory
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import DATA, run_child, save
from ingest.block_size import WORKER_BASE, WORKER_MEMORY, block_bytes

# (name, a file under ../shared/data or a synthetic scene (side m, pulses/m², seed), read box side m)
CASES: list[tuple[str, Any, float]] = [
    ("FSite5, 0.3 points/m²", "isprs/FSite5_orig-utm.laz", 640.0),
    ("synthetic, 2 pulses/m²", (640.0, 2.0, 3), 640.0),
    ("synthetic, 12 pulses/m²", (368.0, 12.0, 4), 368.0),
]


def _run(path: str, side: float) -> None:
    """One block's model in this process; prints its points, area and peak over the base as JSON."""
    from ingest.blocked import BUFFER, MARGIN
    from ingest.pipeline import IngestOptions, survey
    from ingest.pyramid import reduction_stats
    from ingest.readers import read
    from tdb.memory import peak_mib
    from tdb.threads import keep_freed_memory, one_blas_thread
    from tdb.tiles import SUBGRID

    keep_freed_memory()  # as a worker does at its first block
    base = peak_mib()  # a worker's before its block's points come
    cloud = read(path)
    x0, y0 = cloud.bounds[0], cloud.bounds[1]
    box = (x0, y0, x0 + side, y0 + side)
    t0 = time.perf_counter()
    inner = BUFFER - MARGIN  # the model beyond the ground is made within the margin, as a worker's
    model_box = (box[0] + inner, box[1] + inner, box[2] - inner, box[3] - inner)
    with one_blas_thread():
        options = IngestOptions(extent=box, flat_threshold=0.3, model_box=model_box)
        s = survey(cloud, options=options, measure=False)
        reduction_stats(s.dtm, s.model, n=SUBGRID)
    doc = {"points": len(cloud), "km2": side * side / 1e6, "peak_mib": peak_mib() - base}
    print(json.dumps({**doc, "seconds": time.perf_counter() - t0}))


def _corner(source: Path, side: float, out: Path) -> Path:
    """The points of ``source`` in the ``side`` m square at its south-west corner, written to ``out``."""
    import laspy

    las = laspy.read(source)
    keep = (las.x < las.header.mins[0] + side) & (las.y < las.header.mins[1] + side)
    part = laspy.LasData(las.header)
    part.points = las.points[np.asarray(keep)]
    part.write(out)
    return out


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--run":
        _run(sys.argv[2], float(sys.argv[3]))
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, source, side in CASES:
            if isinstance(source, str):
                if not (DATA / source).exists():
                    print(f"skip {name}: {DATA / source} is absent")
                    continue
                path = _corner(DATA / source, side, Path(tmp) / "box.laz")
            else:
                from ingest.synth import make_scene, write_scene

                size, density, seed = source
                path = Path(tmp) / f"scene_{seed}.laz"
                write_scene(path, make_scene(seed=seed, size=size), density=density, seed=seed)
            r = run_child("block_memory", str(path), str(side))
            predicted = block_bytes(r["km2"] * 1e6, r["points"]) / 2**20
            rows.append({"case": name, **r, "predicted_mib": predicted})
            print(
                f"{name}: {r['points']:,} points, {r['km2']:.3f} km², peak {r['peak_mib']:.0f} MiB, "
                f"predicted {predicted:.0f} MiB",
                flush=True,
            )
    save(
        "block_memory",
        {"cases": rows, "worker_memory_mib": WORKER_MEMORY / 2**20, "worker_base_mib": WORKER_BASE / 2**20},
    )


if __name__ == "__main__":
    main()
