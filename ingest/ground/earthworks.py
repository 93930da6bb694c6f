"""Earthworks the ground filter would cut: long, narrow, low objects on the ground.

A ridge with steep sides, a dike or the crest of an embankment rises out of the
terrain too steeply for the opening windows and the slope-scaled threshold, so its
top is taken for an object, and not always the same way in two surveys of it.
Buildings, cars and trees are not long and narrow and low at once: a connected
group of object cells that is (by the moments of its cells) at least
``min_length`` long, ``min_ratio`` times as long as wide, between ``min_width``
and ``max_width`` wide and at most ``max_height`` above the ground surface is
terrain. The least width keeps out what a 1 m grid cannot follow: walls (their
cells alternate between ground and wall, so only pieces of them would be kept,
and not the same pieces in two surveys), hedges and rows of cars.

Walls get a test of their own (:func:`narrow_walls`), on the cells that hold any
point a little above the ground rather than on the cells whose lowest point is
above it: a wall narrower than two cells has its cells' lowest points on the
ground beside it, but its top points fill a band two or three cells wide. A wall
is long and narrow, low, level along its top (a hedge's top is rough) and stands
free (a low band along a building or under trees has taller points beside it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tdb.sort import scatter_max


@dataclass(frozen=True)
class EarthworkShape:
    """The shape of a group of object cells that is an earthwork (a dike, an embankment's crest):
    long (m), long for its width (length / width), narrow (m) and low (m)."""

    min_length: float = 15.0
    min_ratio: float = 4.0
    min_width: float = 2.5
    max_width: float = 8.0
    max_height: float = 2.5


@dataclass(frozen=True)
class WallShape:
    """A free-standing wall: points ``least_height`` to ``max_height`` m above the ground, in a band
    at least ``min_length`` m long, ``min_ratio`` times as long as wide and at most ``max_width`` m
    wide; its top level within ``max_roughness`` m (median absolute deviation); at most
    ``max_tall_share`` of its cells beside a point higher than any wall, at least
    ``min_clear_share`` of them with none over them; points over ``above_top`` m above its top are
    leaves, not the wall. Ratio and height are an earthwork's."""

    least_height: float = 0.4
    min_length: float = 20.0
    min_ratio: float = EarthworkShape.min_ratio
    max_width: float = 3.5
    max_height: float = EarthworkShape.max_height
    max_roughness: float = 0.15
    max_tall_share: float = 0.1
    min_clear_share: float = 0.3
    above_top: float = 0.3


def elongated_objects(
    objects: NDArray[np.bool_],
    height: NDArray[np.float64],
    *,
    cell: float,
    shape: EarthworkShape = EarthworkShape(),
) -> NDArray[np.bool_]:
    """Cells of the 8-connected groups of ``objects`` that are long, narrow and low.

    Parameters
    ----------
    objects : (rows, cols) cells whose lowest point is not ground.
    height : (rows, cols) height (m) of each cell's lowest point above the ground surface.
    cell : cell size (m).
    shape : the shape a group must have. Length and width are those of the rectangle with the
        group's second moments.
    """
    labels, n = ndimage.label(objects, structure=np.ones((3, 3)))
    if n == 0:
        return np.zeros(objects.shape, bool)
    r, c = np.nonzero(labels)
    lab = labels[r, c]
    count = np.bincount(lab, minlength=n + 1).astype(np.float64)
    count[0] = 1.0
    mean_c, mean_r = np.bincount(lab, c, n + 1) / count, np.bincount(lab, r, n + 1) / count
    dc, dr = c - mean_c[lab], r - mean_r[lab]
    scc, srr, scr = (np.bincount(lab, w, n + 1) / count for w in (dc * dc, dr * dr, dc * dr))
    half, gap = (scc + srr) / 2, np.sqrt(np.maximum(((scc - srr) / 2) ** 2 + scr**2, 0.0))
    # A uniform rectangle of side s has variance s²/12 along it; a cell adds one cell of extent.
    length = (np.sqrt(12 * (half + gap)) + 1) * cell
    width = (np.sqrt(12 * np.maximum(half - gap, 0.0)) + 1) * cell
    top = _group_max(height, labels, n)
    s = shape
    ok = (
        (length >= s.min_length)
        & (length >= s.min_ratio * width)
        & (width >= s.min_width)
        & (width <= s.max_width)
    )
    ok &= top <= s.max_height
    ok[0] = False
    return np.asarray(ok[labels], bool)


def _group_max(values: NDArray[np.float64], labels: NDArray[np.integer], n: int) -> NDArray[np.float64]:
    """Largest value of each labelled group (index 0, the background, and empty groups: -inf).
    Only the labelled cells are visited: ``ndimage.maximum`` sorts the whole raster."""
    inside = labels > 0
    out = np.full(n + 1, -np.inf)
    scatter_max(out, labels[inside], values[inside])
    return out


def narrow_walls(
    band: NDArray[np.bool_],
    top: NDArray[np.float64],
    tall: NDArray[np.bool_],
    *,
    cell: float,
    hidden: NDArray[np.bool_] | None = None,
    shape: WallShape = WallShape(),
) -> NDArray[np.float64]:
    """The height of the top of the free-standing wall over each cell of ``band`` whose group
    (8-connected, joined across single empty cells) is one; NaN elsewhere.

    Parameters
    ----------
    band : (rows, cols) cells holding a point that is not ground, a little above the ground.
    top : (rows, cols) height (m) of the highest such point of each cell above the ground surface.
    tall : (rows, cols) cells holding a point higher than any wall (a roof or a crown).
    cell : cell size (m).
    hidden : (rows, cols) cells whose low points may be leaves as well as the wall's top (a crown
        over the wall), so the top's height and roughness are judged on the other cells. None:
        the ``tall`` cells.
    shape : the shape a group must have (:class:`WallShape`). The width is twice the mean
        distance of the group's cells to its edge, so that curved walls are as narrow as straight
        ones; the length is the area over the width. The clear share counts cells not ``hidden``.
    """
    # Groups are joined across single empty cells: where a wall's top holds no point, or none
    # high enough, one survey would otherwise split it where the next does not. Two cells with
    # one empty cell between them (in any direction, a knight's move too: a thin diagonal wall
    # steps so) have overlapping 3 x 3 neighbourhoods; a closing would not fill that gap.
    joined, n = ndimage.label(ndimage.binary_dilation(band, structure=np.ones((3, 3))))
    labels = np.where(band, joined, 0)
    if n == 0:
        return np.full(band.shape, np.nan)
    index = np.arange(n + 1)
    area = np.bincount(labels.ravel(), minlength=n + 1).astype(np.float64)
    inside = np.bincount(labels.ravel(), ndimage.distance_transform_edt(band).ravel(), minlength=n + 1)
    width = 2 * inside / np.maximum(area, 1.0) * cell
    length = area * cell * cell / np.maximum(width, cell)
    clear = np.where(tall if hidden is None else hidden, 0, labels)
    clear_area = np.bincount(clear.ravel(), minlength=n + 1)
    highest = _group_max(top, clear, n)
    middle = np.asarray(ndimage.median(top, clear, index), np.float64)
    roughness = np.asarray(ndimage.median(np.abs(top - middle[clear]), clear, index), np.float64)
    beside_tall = ndimage.binary_dilation(tall, structure=np.ones((3, 3)))
    tall_share = np.bincount(labels.ravel(), beside_tall.ravel(), minlength=n + 1) / np.maximum(area, 1.0)
    s = shape
    ok = (length >= s.min_length) & (length >= s.min_ratio * width) & (width <= s.max_width)
    ok &= (highest <= s.max_height) & (roughness <= s.max_roughness) & (tall_share <= s.max_tall_share)
    ok &= clear_area >= s.min_clear_share * area
    ok[0] = False
    return np.where(ok[labels], middle[labels], np.nan)
