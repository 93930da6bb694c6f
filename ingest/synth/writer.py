"""Streaming a scene's returns to LAS/LAZ, block by block, in bounded memory."""

from __future__ import annotations

import os
from pathlib import Path

import laspy
import numpy as np

from ingest.synth.sampling import iter_samples
from ingest.synth.scene import Scene
from tdb.atomic import atomic_path
from tdb.progress import Progress, or_silent
from tdb.units import as_crs


def write_scene(
    path: str | os.PathLike[str], scene: Scene, *, density: float, seed: int = 0, progress: Progress | None = None
) -> int:
    """Write the returns of ``scene`` to ``path`` (LAZ where it ends in .laz); return the point count.

    Written to a temporary file and moved into place: an interrupted run leaves no partial file.
    ``progress`` is told ``("sampling", blocks done, 0)`` (:mod:`tdb.progress`).
    """
    report = or_silent(progress)

    p = Path(path)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.array([scene.bounds[0], scene.bounds[1], 0.0])
    header.scales = np.array([0.001, 0.001, 0.001])
    header.add_crs(as_crs(scene.crs))
    total = 0
    with atomic_path(p) as tmp:
        with laspy.open(str(tmp), mode="w", header=header, do_compress=p.suffix.lower() == ".laz") as writer:
            for block, cols in enumerate(iter_samples(scene, density=density, seed=seed), start=1):
                report("sampling", block, 0)
                if len(cols["x"]) == 0:
                    continue
                pts = laspy.ScaleAwarePointRecord.zeros(len(cols["x"]), header=header)
                pts.x, pts.y, pts.z = cols["x"], cols["y"], cols["z"]
                pts.classification = cols["cls"]
                pts.return_number = cols["rn"]
                pts.number_of_returns = cols["nr"]
                writer.write_points(pts)
                total += len(cols["x"])
    return total
