"""Ingest: point cloud → ground → dense model → categories → reduction → pyramid → database."""

from __future__ import annotations

import datetime as dt
import os
from collections.abc import Iterable
from dataclasses import dataclass
from dataclasses import replace as replace_crs
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
from tdb.errors import Remedy, VersionExistsError
from tdb.options import GroundMethod, LabelScheme, parse
from tdb.progress import Progress, or_silent
from tdb.raster import Raster
from tdb.stats import VersionStats
from tdb.tiles import SUBGRID
from tdb.units import as_crs, to_metres

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
    progress: Progress | None = None,
) -> Survey:
    """Derive the terrain model of one cloud (pure: nothing is written).

    ``progress`` (:mod:`tdb.progress`) is told each step as it starts, and the ground filter's
    tiles as they finish. Points of the ``exclude`` classes (default ASPRS noise) are never ground.
    """
    report = or_silent(progress)
    report("units", 0, 1)
    metric = to_metres(cloud, assume_metres=assume_metres)
    ground = classify_ground(metric, method=parse(GroundMethod, method), progress=report, exclude=exclude)
    report("dense model", 0, 1)
    gxyz = metric.xyz[ground]
    dtm = dense_model(gxyz, resolution=resolution, crs=metric.crs)
    noise = ground_noise(gxyz)
    threshold = flat_threshold if flat_threshold is not None else flat_threshold_for(noise)
    report("categories and reduction", 0, 1)
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
    labels: str | LabelScheme = LabelScheme.ASPRS,
    assume_metres: bool = False,
    exclude: str | Iterable[int] = NOISE,
    progress: Progress | None = None,
) -> Version:
    """Ingest one survey into ``db`` as ``version``, in one transaction.

    ``crs`` overrides (or supplies) the source's coordinate system, a file's or a cloud's alike;
    ``labels`` says what a text file's fourth column means. ``exclude``: class codes (or text like
    ``"7,18,65"``) of points that are never ground; the default is ASPRS noise
    (:data:`tdb.classes.NOISE`). ``progress``: see :mod:`tdb.progress`.

    Raises
    ------
    VersionExistsError
        If ``version`` exists and ``replace`` is false (checked before any work).
    """
    exclude = parse_classes(exclude)
    if not replace and any(v.name == version for v in db.versions()):
        raise VersionExistsError(f"{db.name}: version {version!r} exists", remedy=Remedy.REPLACE)
    report = or_silent(progress)
    report("read", 0, 1)
    cloud = _cloud(source, crs=crs, labels=labels)
    result = survey(
        cloud,
        method=method,
        resolution=resolution,
        flat_threshold=flat_threshold,
        assume_metres=assume_metres,
        exclude=exclude,
        progress=report,
    )
    m = result.model
    assert m.stats is not None
    stats = VersionStats(
        reduction=m.stats,
        points=len(cloud),
        ground_points=int(result.ground.sum()),
        excluded_points=int(excluded(cloud.classification, exclude).sum()),
        kept_user_classes={int(c): n for c, n in user_classes(cloud.classification, exclude).items()},
        noise_m=round(result.noise, 4),
        flat_threshold_m=round(result.flat_threshold, 3),
        bounds=result.dtm.bounds,
    )
    params = {
        "method": str(parse(GroundMethod, method)),
        "resolution": resolution,
        "subgrid": SUBGRID,
        "flat_threshold": result.flat_threshold,
        "exclude_classes": list(exclude),
    }
    return db.write_version(
        version,
        levels={lv: (t.xg, t.yg, t.code) for lv, t in m.levels.items()},
        points=(m.x, m.y, m.z, m.n),
        acquired=acquired,
        source=str(cloud.source),
        crs=None if result.cloud.crs is None else result.cloud.crs.to_wkt(),
        params=params,
        stats=stats,
        replace=replace,
        progress=report,
    )


def _cloud(source: str | os.PathLike[str] | PointCloud, *, crs: Any, labels: str | LabelScheme) -> PointCloud:
    """The source's points, with ``crs`` in place of their own where given."""
    if not isinstance(source, PointCloud):
        return read(source, crs=crs, labels=labels)
    return source if crs is None else replace_crs(source, crs=as_crs(crs))
