"""Ground filters: Sohn–Dowman, Elmqvist's active contour, and the default."""

from __future__ import annotations

import functools
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from ingest.block_size import fits, ground_bytes
from ingest.ground.auto import AutoParams, auto_ground
from ingest.ground.by_blocks import ground_by_blocks
from ingest.ground.contour import ContourParams, active_contour
from ingest.ground.outliers import deep_pits, low_outliers, point_density
from ingest.ground.sohn import SohnParams, sohn_dowman
from ingest.ground.tiling import by_tiles
from tdb.bbox import box_area
from tdb.classes import NOISE
from tdb.cloud import GROUND, PointCloud, check_spread, from_arrays
from tdb.errors import InputError
from tdb.options import GroundMethod, parse
from tdb.progress import Progress, or_silent
from tdb.raster import MAX_CELLS
from tdb.workers import available_cores

STEP = "ground filter"

__all__ = [
    "AutoParams",
    "ContourParams",
    "SohnParams",
    "classify_ground",
    "deep_pits",
    "low_outliers",
    "paper_ground",
]


def classify_ground(
    points: PointCloud | NDArray[np.float64],
    *,
    method: str | GroundMethod = "auto",
    progress: Progress | None = None,
    exclude: Iterable[int] = NOISE,
    density: float | None = None,
    extent: tuple[float, float, float, float] | None = None,
) -> NDArray[np.bool_]:
    """Ground mask of a point cloud (coordinates in metres).

    Parameters
    ----------
    points : a :class:`PointCloud` or an (N, 3) array.
    method : ``auto`` (default filter), ``sohn`` (Sohn & Dowman 2002),
        ``contour`` (Elmqvist active contour), or ``classified``: the points the survey's provider
        classified as ground (ASPRS class 2), as national surveys deliver them. See
        :class:`GroundMethod`.
    progress : told ``("ground filter", tiles done, tiles)`` as Sohn–Dowman's tiles finish (the
        other filters run whole: once, with (1, 1), at the end); see :mod:`tdb.progress`.
    exclude : class codes of points the filter never sees and never calls ground
        (default ASPRS noise, 7 and 18; see :mod:`tdb.classes`). Arrays carry no classes.
    density : the survey's points per m² the filter sizes its outlier test to (of the points it
        sees: :func:`ingest.ground.outliers.point_density`); None: measured on them.
    extent : (xmin, ymin, xmax, ymax) the default filter's grid covers, holding every point;
        None: the points' own extent. Given where a survey is filtered in parts, so that a part's
        grid ends where the whole survey's does (or in its buffer), not at its own points.

    Raises
    ------
    DegenerateInputError
        For fewer than three points, or points spanning no area (once ``exclude`` is applied).
    InputError
        For ``classified``, where no point the filter sees is classified ground.

    Where filtering the extent whole would need more memory than the machine has (a corridor
    survey, two sites in one file), the points are filtered block by block, as a blocked ingest
    filters them (:mod:`ingest.ground.by_blocks`).
    """
    m = parse(GroundMethod, method)
    cloud = points if isinstance(points, PointCloud) else from_arrays(*np.asarray(points, float).T, validate=False)
    drop = cloud.excluded(exclude)
    if not drop.any():
        check_spread(cloud)
        return _fitting(cloud, m, progress, density, extent)
    use = np.flatnonzero(~drop)
    kept = cloud.take(use)
    check_spread(kept)
    ground = np.zeros(len(drop), bool)
    ground[use] = _fitting(kept, m, progress, density, extent)
    return ground


def _fitting(
    cloud: PointCloud,
    m: GroundMethod,
    progress: Progress | None,
    density: float | None,
    extent: tuple[float, float, float, float] | None,
) -> NDArray[np.bool_]:
    """The ground, filtered whole where the filter's grids over the extent fit the machine's
    memory, else block by block (:mod:`ingest.ground.by_blocks`). An extent beyond any grid the
    filter lays is left to it to refuse, with a word on the units."""
    b = cloud.bounds
    survey = extent if extent is not None else (b[0], b[1], b[3], b[4])
    area = box_area(survey)
    if (
        m is GroundMethod.CLASSIFIED
        or area / AutoParams().cell ** 2 > MAX_CELLS
        or fits(ground_bytes(area, len(cloud)))
    ):
        return _ground(cloud, m, progress, density, extent)
    density = density or point_density(cloud.xyz[:, :2])
    return ground_by_blocks(
        cloud,
        lambda part, box: _ground(part, m, None, density, box),
        density=density,
        survey=survey,
        progress=progress,
        step=STEP,
    )


def _ground(
    cloud: PointCloud,
    m: GroundMethod,
    progress: Progress | None,
    density: float | None,
    extent: tuple[float, float, float, float] | None,
) -> NDArray[np.bool_]:
    xyz = cloud.xyz
    report = or_silent(progress)
    report(STEP, 0, 1)
    if m is GroundMethod.CLASSIFIED:
        ground = cloud.classification == GROUND
        if not ground.any():
            raise InputError(
                f"{cloud.source}: no point is classified ground (ASPRS class 2), so its "
                "own ground class cannot be used; a ground filter can find the ground instead"
            )
        report(STEP, 1, 1)
        return ground
    if m is GroundMethod.AUTO:
        ground = auto_ground(
            xyz, returns=(cloud.return_number, cloud.number_of_returns), density=density, extent=extent
        )
        report(STEP, 1, 1)
        return ground
    return paper_ground(xyz, m, density=density, progress=report)


def paper_ground(
    xyz: NDArray[np.float64],
    method: str | GroundMethod,
    *,
    sohn: SohnParams | None = None,
    contour: ContourParams | None = None,
    density: float | None = None,
    progress: Progress | None = None,
) -> NDArray[np.bool_]:
    """Ground mask of (N, 3) coordinates in metres by one of the papers' filters (``sohn`` or
    ``contour``), with its settings (the shipped ones by default), after the default filter's low
    outlier and deep pit tests, which the papers have not.

    Raises
    ------
    InputError
        If ``method`` is not one of the papers' filters.
    """
    m = parse(GroundMethod, method)
    if m not in (GroundMethod.SOHN, GroundMethod.CONTOUR):
        raise InputError(f"{m.value} is not one of the papers' filters (sohn, contour)")
    report = or_silent(progress)
    # Sohn's downward step would make a 25 m deep multipath cluster a TIN vertex (samp41).
    out = low_outliers(xyz, density=density) | deep_pits(xyz)
    ground = np.zeros(len(xyz), bool)
    keep = np.flatnonzero(~out)
    if m is GroundMethod.SOHN:
        ground[keep] = by_tiles(
            xyz[keep],
            functools.partial(sohn_dowman, params=sohn or SohnParams()),
            workers=available_cores(),
            progress=lambda done, total: report(STEP, done, total),
        )
    else:
        ground[keep] = active_contour(xyz[keep], params=contour or ContourParams())
        report(STEP, 1, 1)
    return ground
