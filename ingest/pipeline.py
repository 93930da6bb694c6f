"""Ingest: point cloud → ground → dense model → categories → reduction → pyramid → database."""

from __future__ import annotations

import dataclasses
import datetime as dt
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ingest.block_size import block_bytes, check_fits
from ingest.dtm import DEFAULT_RESOLUTION, dense_model
from ingest.evidence import tile_evidence, tile_over, tile_pulses
from ingest.ground import classify_ground
from ingest.ground.grids import quantised
from ingest.ground.hills import point_spacing
from ingest.noise import QUIET, fullest_square, ground_noises, pilot_threshold, square_counts
from ingest.objects import Objects, find_objects
from ingest.pyramid import TerrainModel, build
from ingest.readers import read
from tdb.bbox import Box, box_area, points_in_box
from tdb.classes import NOISE, parse_classes, user_classes
from tdb.cloud import PointCloud
from tdb.database import Database, Version, VersionInfo, check_version_name
from tdb.errors import InputError, Remedy, VersionExistsError
from tdb.evidence import MIN_SUPPORT, TileEvidence
from tdb.kdtree import plan_tree
from tdb.options import GroundMethod, LabelScheme, parse
from tdb.progress import Progress, or_silent
from tdb.raster import Raster
from tdb.stats import VersionStats
from tdb.tiles import LEVELS, SUBGRID, node_spacing
from tdb.units import as_crs, to_metres


@dataclass(frozen=True)
class Survey:
    """Everything ingest derives from one point cloud before it is stored."""

    cloud: PointCloud
    ground: np.ndarray
    dtm: Raster
    noise: float
    flat_threshold: float
    model: TerrainModel
    evidence: TileEvidence
    objects: Objects | None


@dataclass(frozen=True)
class IngestOptions:
    """How a survey is read and modelled.

    ``crs`` overrides (or supplies) the source's coordinate system, a file's or a cloud's alike;
    ``labels`` says what a text file's fourth column means; ``assume_metres`` accepts a source
    with no CRS as metres. ``method`` is the ground filter, ``resolution`` the dense model's post
    spacing (m), ``flat_threshold`` the height range (m) under which a tile is flat (None: from
    the measured ground noise). Points of the ``exclude`` classes (codes, or text like
    ``"7,18,65"``) are never ground; the default is ASPRS noise (:data:`tdb.classes.NOISE`).
    ``density`` is the survey's points per m² (None: measured), given where a survey is
    modelled in parts. ``objects``: find and store the trees and buildings (seed §2.2–2.3).
    ``extent`` (x0, y0, x1, y1, m) is the box the ground filter's grid covers (None: the cloud's
    own extent); given where a survey is modelled in parts: a part's box within the survey's.
    ``model_box`` (x0, y0, x1, y1, m) is the box whose points the rest of the model (dense model,
    categories, reduction, evidence, objects) is made from, once the ground filter has labelled
    them all (None: the whole cloud); given where a part needs the ground filter's reach around
    it but not the rest's.
    """

    crs: Any = None
    labels: LabelScheme = LabelScheme.ASPRS
    assume_metres: bool = False
    method: GroundMethod = GroundMethod.AUTO
    resolution: float = DEFAULT_RESOLUTION
    flat_threshold: float | None = None
    exclude: tuple[int, ...] = NOISE
    density: float | None = None
    objects: bool = True
    extent: Box | None = None
    model_box: Box | None = None

    def __post_init__(self) -> None:
        # user text is accepted and checked once, here
        object.__setattr__(self, "labels", parse(LabelScheme, self.labels))
        object.__setattr__(self, "method", parse(GroundMethod, self.method))
        object.__setattr__(self, "exclude", parse_classes(self.exclude))
        finest = node_spacing(min(LEVELS))
        steps = finest / self.resolution if np.isfinite(self.resolution) and self.resolution > 0 else 0.0
        if steps < 1 - 1e-9 or abs(steps - round(steps)) > 1e-6:
            raise InputError(
                f"the dense model's resolution must divide the finest node spacing ({finest} m: "
                f"{finest} m, {finest / 2} m, {finest / 4} m …), got {self.resolution}"
            )
        t = self.flat_threshold
        if t is not None and not (np.isfinite(t) and t >= 0):
            raise InputError(f"a flat threshold is a height range of 0 m or more, got {t}")


def survey(
    cloud: PointCloud,
    *,
    options: IngestOptions | None = None,
    progress: Progress | None = None,
    measure: bool = True,
) -> Survey:
    """Derive the terrain model of one cloud (pure: nothing is written).

    ``measure``: whether the model carries its reduction figures; a caller keeping only a part
    of it (a block's own square) measures that part instead.

    ``progress`` (:mod:`tdb.progress`) is told each step as it starts, and the ground filter's
    tiles as they finish. ``options.crs`` and ``options.labels`` are for reading: see :func:`ingest`.

    Raises
    ------
    InputError
        Before any work, where modelling the cloud's extent whole needs more memory than the
        machine has (:func:`ingest.block_size.check_fits`): model it block by block
        (:func:`ingest.blocked.ingest_blocked`).
    """
    o = options or IngestOptions()
    report = or_silent(progress)
    report("units", 0, 1)
    metric = to_metres(cloud, assume_metres=o.assume_metres)
    b = metric.bounds
    extent = o.extent if o.extent is not None else (b[0], b[1], b[3], b[4])
    check_fits(block_bytes(box_area(extent), len(metric)), what=metric.source, area=box_area(extent))
    ground = classify_ground(
        metric, method=o.method, progress=report, exclude=o.exclude, density=o.density, extent=extent
    )
    if o.model_box is not None:
        inside = np.flatnonzero(points_in_box(metric.xyz[:, 0], metric.xyz[:, 1], o.model_box))
        metric, ground = metric.take(inside), ground[inside]
    report("dense model", 0, 1)
    gxyz = metric.xyz[ground]
    dtm = dense_model(gxyz, resolution=o.resolution, crs=metric.crs)
    # one k-d tree of the ground returns for the noise and the evidence
    tree = plan_tree(gxyz[:, :2]) if len(gxyz) else None
    noise, quiet = ground_noises(gxyz, (50.0, QUIET), tree=tree)
    left_out = metric.excluded(o.exclude)
    threshold = o.flat_threshold
    if threshold is None:
        seen = metric.xyz[~left_out]
        threshold = pilot_threshold(gxyz, fullest_square(square_counts(seen[:, 0], seen[:, 1])))
    report("categories and reduction", 0, 1)
    model = build(dtm, flat_threshold=threshold, n=SUBGRID, measure=measure)
    finest = model.levels[min(model.levels)]
    spacing = quantised(point_spacing(metric.xyz[:, :2]))
    evidence = tile_evidence(gxyz, finest.xg, finest.yg, spacing=spacing, surface=dtm, noise=quiet, tree=tree)
    low, high = tile_over(metric.xyz[~ground & ~left_out], dtm, finest.xg, finest.yg)
    pulses = ~left_out & (metric.return_number >= metric.number_of_returns)  # each pulse's last return
    density, share = tile_pulses(metric.xyz[pulses, :2], ground[pulses], finest.xg, finest.yg)
    evidence = dataclasses.replace(
        evidence,
        over_low=low.astype(np.float32),
        over_high=high.astype(np.float32),
        pulses=density.astype(np.float32),
        ground_share=share.astype(np.float32),
    )
    objects = find_objects(metric, ground, dtm, progress=report, skip=left_out) if o.objects else None
    return Survey(metric, ground, dtm, noise, threshold, model, evidence, objects)


def ingest(
    source: str | os.PathLike[str] | PointCloud,
    db: Database,
    *,
    version: str,
    acquired: dt.date | None = None,
    replace: bool = False,
    options: IngestOptions | None = None,
    progress: Progress | None = None,
) -> Version:
    """Ingest one survey into ``db`` as ``version``, in one transaction.

    ``options``: how the source is read and modelled (:class:`IngestOptions`); ``progress``: see
    :mod:`tdb.progress`.

    Raises
    ------
    VersionExistsError
        If ``version`` exists and ``replace`` is false (checked before any work).
    InputError
        Where the survey's extent is too large to model whole (see :func:`survey`).
    """
    o = options or IngestOptions()
    check_version_name(version)
    if not replace and any(v.name == version for v in db.versions()):
        raise VersionExistsError(f"{db.name}: version {version!r} exists", remedy=Remedy.REPLACE)
    report = or_silent(progress)
    report("read", 0, 1)
    cloud = _cloud(source, o)
    result = survey(cloud, options=o, progress=report)
    m = result.model
    assert m.stats is not None
    stats = VersionStats(
        reduction=m.stats,
        points=len(cloud),
        ground_points=int(result.ground.sum()),
        excluded_points=int(cloud.excluded(o.exclude).sum()),
        kept_user_classes={int(c): n for c, n in user_classes(cloud.classification, o.exclude).items()},
        noise_m=round(result.noise, 4),
        flat_threshold_m=round(result.flat_threshold, 3),
        bounds=result.dtm.bounds,
        seen_pct=tiles_pct(result.evidence.support >= MIN_SUPPORT),
        sigma_m=median_sigma(result.evidence),
        deep_pct=tiles_pct(result.evidence.deep),
        covered_pct=tiles_pct(result.evidence.covered),
    )
    params = {
        "method": str(o.method),
        "resolution": o.resolution,
        "subgrid": SUBGRID,
        "flat_threshold": result.flat_threshold,
        "exclude_classes": list(o.exclude),
    }
    return db.write_version(
        version,
        levels={lv: (t.xg, t.yg, t.code) for lv, t in m.levels.items()},
        points=(m.x, m.y, m.z, m.n),
        info=VersionInfo(
            acquired=acquired,
            source=str(cloud.source),
            crs=None if result.cloud.crs is None else result.cloud.crs.to_wkt(),
            params=params,
            stats=stats,
        ),
        evidence=result.evidence,
        objects=None if result.objects is None else (result.objects.trees, result.objects.buildings),
        replace=replace,
        progress=report,
    )


def tiles_pct(tiles: NDArray[np.bool_]) -> float | None:
    """Share (%) of the 2 m tiles marked in ``tiles`` (their evidence's support, depth or cover),
    for :class:`VersionStats`; None where no tile holds evidence."""
    return round(100 * float(tiles.mean()), 1) if len(tiles) else None


def median_sigma(evidence: TileEvidence) -> float | None:
    """The median uncertainty (m) of a 2 m tile's surface, for :class:`VersionStats`."""
    return round(float(np.median(evidence.sigma)), 3) if len(evidence) else None


def _cloud(source: str | os.PathLike[str] | PointCloud, options: IngestOptions) -> PointCloud:
    """The source's points, with the options' CRS in place of their own where given."""
    if not isinstance(source, PointCloud):
        return read(source, crs=options.crs, labels=options.labels)
    return source if options.crs is None else dataclasses.replace(source, crs=as_crs(options.crs))
