"""Ingest: point cloud → ground → dense model → categories → reduction → pyramid → database."""

from __future__ import annotations

import datetime as dt
import os
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ingest.dtm import DEFAULT_RESOLUTION, dense_model
from ingest.ground import classify_ground
from ingest.noise import ground_noise
from ingest.pyramid import TerrainModel, build
from ingest.readers import read
from tdb.classes import NOISE, excluded, parse_classes, user_classes
from tdb.cloud import PointCloud
from tdb.database import Database, Version
from tdb.options import GroundMethod, parse
from tdb.raster import Raster
from tdb.tiles import SUBGRID
from tdb.units import to_metres

MIN_FLAT = 0.10  # m: below this a threshold would call noise a form
NOISE_FACTOR = 5.0  # flat threshold = this × the measured ground noise


@dataclass(frozen=True)
class Survey:
    """Everything ingest derives from one point cloud before it is stored."""

    cloud: PointCloud
    ground: np.ndarray
    dtm: Raster
    noise: float
    flat_threshold: float
    model: TerrainModel


def flat_threshold_for(noise: float) -> float:
    return max(MIN_FLAT, NOISE_FACTOR * noise)


def survey(
    cloud: PointCloud,
    *,
    method: str | GroundMethod = GroundMethod.AUTO,
    resolution: float = DEFAULT_RESOLUTION,
    flat_threshold: float | None = None,
    assume_metres: bool = False,
    exclude: Iterable[int] = NOISE,
    stage: Any = None,
) -> Survey:
    """Derive the terrain model of one cloud (pure: nothing is written).

    ``stage(name)`` is called as each step starts (for progress display), and during the
    ground filter with ``"ground filter (k/n tiles)"`` as Sohn–Dowman's tiles finish.
    Points of the ``exclude`` classes (default ASPRS noise) are never ground.
    """
    report = stage or (lambda _name: None)
    report("units")
    metric = to_metres(cloud, assume_metres=assume_metres)
    report("ground filter")

    def tiles(done: int, total: int) -> None:
        if total > 1:
            report(f"ground filter ({done}/{total} tiles)")

    ground = classify_ground(metric, method=parse(GroundMethod, method), progress=tiles, exclude=exclude)
    report("dense model")
    gxyz = metric.xyz[ground]
    dtm = dense_model(gxyz, resolution=resolution, crs=metric.crs)
    noise = ground_noise(gxyz)
    threshold = flat_threshold if flat_threshold is not None else flat_threshold_for(noise)
    report("categories and reduction")
    model = build(dtm, flat_threshold=threshold, n=SUBGRID)
    return Survey(metric, ground, dtm, noise, threshold, model)


def ingest(
    source: str | os.PathLike[str] | PointCloud,
    db: Database,
    *,
    version: str,
    acquired: dt.date | None = None,
    method: str | GroundMethod = GroundMethod.AUTO,
    resolution: float = DEFAULT_RESOLUTION,
    flat_threshold: float | None = None,
    replace: bool = False,
    crs: Any = None,
    assume_metres: bool = False,
    exclude: str | Iterable[int] = NOISE,
    progress: bool = False,
) -> Version:
    """Ingest one survey into ``db`` as ``version``, in one transaction.

    ``exclude``: class codes (or text like ``"7,18,65"``) of points that are never
    ground; the default is ASPRS noise (:data:`tdb.classes.NOISE`).

    Raises
    ------
    VersionExistsError
        If ``version`` exists and ``replace`` is false (checked before any work).
    """
    from tqdm import tqdm

    exclude = parse_classes(exclude)
    if not replace and any(v.name == version for v in db.versions()):
        from tdb.errors import VersionExistsError

        raise VersionExistsError(f"{db.name}: version {version!r} exists (use --replace)")
    steps = ["read", "units", "ground filter", "dense model", "categories and reduction", "database"]
    bar = tqdm(
        total=len(steps), disable=not progress, unit="step", bar_format="{desc:<28} {bar} {n}/{total} [{elapsed}]"
    )

    def stage(name: str) -> None:
        bar.set_description(name)
        # a step's own progress ("ground filter (3/9 tiles)") renames the bar, not advances it
        bar.update(0 if name == "read" or name.endswith(" tiles)") else 1)

    stage("read")
    cloud = source if isinstance(source, PointCloud) else read(source, crs=crs)
    result = survey(
        cloud,
        method=method,
        resolution=resolution,
        flat_threshold=flat_threshold,
        assume_metres=assume_metres,
        exclude=exclude,
        stage=stage,
    )
    stage("database")
    m = result.model
    stats = dict(
        m.stats,
        ground_points=int(result.ground.sum()),
        points=len(cloud),
        excluded_points=int(excluded(cloud.classification, exclude).sum()),
        kept_user_classes=user_classes(cloud.classification, exclude),
        noise_m=round(result.noise, 4),
        flat_threshold_m=round(result.flat_threshold, 3),
        bounds=list(result.dtm.bounds),
    )
    params = {
        "method": str(parse(GroundMethod, method)),
        "resolution": resolution,
        "subgrid": SUBGRID,
        "flat_threshold": result.flat_threshold,
        "exclude_classes": list(exclude),
    }
    v = db.write_version(
        version,
        levels={lv: (t.xg, t.yg, t.code) for lv, t in m.levels.items()},
        points=(m.x, m.y, m.z, m.n),
        acquired=acquired,
        source=str(cloud.source),
        crs=None if result.cloud.crs is None else result.cloud.crs.to_wkt(),
        params=params,
        stats=stats,
        replace=replace,
    )
    bar.update(1)
    bar.close()
    return v
