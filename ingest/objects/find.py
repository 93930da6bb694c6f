"""The whole objects step: classes, buildings and trees of one survey."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ingest.block_size import block_bytes, check_fits
from ingest.dtm import DEFAULT_RESOLUTION, dense_model
from ingest.ground import classify_ground
from ingest.objects.buildings import FootprintParams, find_buildings
from ingest.objects.cover import Cover, CoverParams, classify_cover
from ingest.objects.trees import TreeParams, find_trees
from tdb.bbox import box_area
from tdb.classes import NOISE
from tdb.cloud import PointCloud
from tdb.objects import Building, Tree
from tdb.options import GroundMethod
from tdb.progress import Progress, or_silent
from tdb.raster import Raster


@dataclass(frozen=True)
class ObjectParams:
    cover: CoverParams = field(default_factory=CoverParams)
    trees: TreeParams = field(default_factory=TreeParams)
    footprints: FootprintParams = field(default_factory=FootprintParams)


@dataclass(frozen=True)
class Objects:
    """Per point ASPRS classes, and the survey's trees and buildings."""

    cover: Cover
    trees: list[Tree]
    buildings: list[Building]

    @property
    def classes(self) -> NDArray[np.uint8]:
        return self.cover.classes


def find_objects(
    cloud: PointCloud,
    ground: NDArray[np.bool_],
    dtm: Raster,
    *,
    params: ObjectParams | None = None,
    progress: Progress | None = None,
    skip: NDArray[np.bool_] | None = None,
) -> Objects:
    """Classify the points over the ground, then find the buildings and the trees.

    ``skip``: points (such as noise) that are no object and keep their class; None: none.
    """
    p = params or ObjectParams()
    report = or_silent(progress)
    report("vegetation and buildings", 0, 1)
    cover = classify_cover(cloud, ground, dtm, params=p.cover, skip=skip)
    report("buildings", 0, 1)
    buildings = find_buildings(cloud.xyz, cover, params=p.footprints)
    report("trees", 0, 1)
    trees = find_trees(cloud, cover, params=p.trees)
    return Objects(cover, trees, buildings)


def survey_objects(
    cloud: PointCloud,
    *,
    method: GroundMethod | str = GroundMethod.AUTO,
    exclude: tuple[int, ...] = NOISE,
    params: ObjectParams | None = None,
    progress: Progress | None = None,
) -> Objects:
    """Ground, dense model and objects of a cloud in metres, in one call (what ``tdb classify``
    and ``tdb trees`` run). Points of the ``exclude`` classes are never ground nor objects: they
    keep their own class.

    Raises
    ------
    InputError
        Before any work, where the dense model and the objects' rasters over the cloud's extent
        need more memory than the machine has (:func:`ingest.block_size.check_fits`): a blocked
        ingest finds and stores the objects of such a survey block by block.
    """
    b = cloud.bounds
    area = box_area((b[0], b[1], b[3], b[4]))
    check_fits(block_bytes(area, len(cloud)), what=cloud.source, area=area)
    report = or_silent(progress)
    ground = classify_ground(cloud, method=method, progress=report, exclude=exclude)
    report("dense model", 0, 1)
    dtm = dense_model(cloud.xyz[ground], resolution=DEFAULT_RESOLUTION, crs=cloud.crs)
    return find_objects(cloud, ground, dtm, params=params, progress=report, skip=cloud.excluded(exclude))
