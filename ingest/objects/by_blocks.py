"""The objects of a survey of any extent: whole where it fits, else block by block, as a blocked
ingest finds them (:func:`objects_of`, what ``tdb classify`` and ``tdb trees`` run).

The dense model and the objects' rasters cover the whole extent, filled or not. Where they would
not fit the machine's memory (a corridor survey, two sites in one file), the points are cut into
the blocks of a lattice (:mod:`ingest.block_lattice`), each block modelled with
:data:`ingest.block_lattice.BUFFER` m of its neighbours' points; a point takes the class its own
block gives it, a tree belongs to the block its top is in and a building to the block its
centroid is in, as in a blocked ingest.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.block_lattice import BlockLattice
from ingest.block_size import block_bytes, fits
from ingest.dtm import DEFAULT_RESOLUTION, dense_model
from ingest.ground import classify_ground
from ingest.ground.outliers import point_density
from ingest.objects.find import ObjectParams, find_objects, survey_objects
from tdb.bbox import Box, box_area
from tdb.cloud import GROUND, OTHER, PointCloud
from tdb.objects import Building, Tree
from tdb.options import GroundMethod
from tdb.progress import Progress, or_silent

STEP = "objects"


@dataclass(frozen=True)
class FoundObjects:
    """Per point ASPRS classes, and the survey's trees and buildings."""

    classes: NDArray[np.uint8]
    trees: list[Tree]
    buildings: list[Building]


def objects_of(
    cloud: PointCloud,
    *,
    method: GroundMethod | str = GroundMethod.AUTO,
    exclude: tuple[int, ...],
    params: ObjectParams | None = None,
    progress: Progress | None = None,
) -> FoundObjects:
    """Ground, then the classes, trees and buildings of a cloud in metres: whole
    (:func:`ingest.objects.survey_objects`) where its extent's rasters fit the machine's memory,
    else block by block (:func:`objects_by_blocks`). Points of the ``exclude`` classes keep
    their class."""
    b = cloud.bounds
    survey = (b[0], b[1], b[3], b[4])
    if fits(block_bytes(box_area(survey), len(cloud))):
        whole = survey_objects(cloud, method=method, exclude=exclude, params=params, progress=progress)
        return FoundObjects(whole.classes, whole.trees, whole.buildings)
    ground = classify_ground(cloud, method=method, progress=progress, exclude=exclude)
    seen = ~cloud.excluded(exclude)
    density = point_density(cloud.xyz[seen, :2])
    return objects_by_blocks(
        cloud, ground, density=density, survey=survey, exclude=exclude, params=params, progress=progress
    )


def objects_by_blocks(
    cloud: PointCloud,
    ground: NDArray[np.bool_],
    *,
    density: float,
    survey: Box,
    exclude: tuple[int, ...],
    params: ObjectParams | None = None,
    progress: Progress | None = None,
) -> FoundObjects:
    """Classes, trees and buildings of ``cloud`` (metres) with its ``ground`` mask, block by block
    over ``survey`` (x0, y0, x1, y1), blocks sized to the survey's ``density`` (points per m²).
    Points of the ``exclude`` classes keep their class. ``progress`` is told
    ``("objects", blocks done, blocks)``; what the blocks warn of is said once."""
    report = or_silent(progress)
    lattice = BlockLattice.over(survey, density=density)
    groups = list(lattice.groups(cloud.x, cloud.y))
    skip = cloud.excluded(exclude)
    classes = np.where(skip, cloud.classification, np.where(ground, GROUND, OTHER)).astype(np.uint8)
    trees: list[Tree] = []
    buildings: list[Building] = []
    said: dict[str, warnings.WarningMessage] = {}
    for n, (k, part, mine) in enumerate(groups):
        report(STEP, n, len(groups))
        if not mine.any() or ground[part].sum() < 3:  # no ground to stand on: classes as above
            continue
        sub = cloud.take(part)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            dtm = dense_model(sub.xyz[ground[part]], resolution=DEFAULT_RESOLUTION, crs=cloud.crs)
            found = find_objects(sub, ground[part], dtm, params=params, skip=skip[part])
        said.update((str(w.message).split(": ", 1)[-1], w) for w in caught)
        classes[part[mine]] = found.classes[mine]
        own_trees, own_buildings = lattice.block(k).kept(found.trees, found.buildings)
        trees += own_trees
        buildings += own_buildings
    report(STEP, len(groups), len(groups))
    for text, w in said.items():
        warnings.warn(f"{cloud.source}: {text}", w.category, stacklevel=2)
    return FoundObjects(classes, trees, buildings)
