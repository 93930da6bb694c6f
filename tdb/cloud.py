"""The point-cloud type every reader returns and every filter takes."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.bbox import column_range
from tdb.classes import excluded
from tdb.crs import as_crs
from tdb.errors import DegenerateInputError, InputError

# ASPRS classes tdb reads and writes
OTHER = 1  # unclassified: over the ground but neither vegetation nor building
GROUND = 2
LOW_VEGETATION = 3
MEDIUM_VEGETATION = 4
VEGETATION = HIGH_VEGETATION = 5
BUILDING = 6
NOISE = 7
HIGH_NOISE = 18  # ASPRS (LAS 1.4): returns above any surface, from birds, clouds, dust
CLASS_NAMES = {
    GROUND: "ground",
    LOW_VEGETATION: "low vegetation",
    MEDIUM_VEGETATION: "medium vegetation",
    HIGH_VEGETATION: "high vegetation",
    BUILDING: "building",
    OTHER: "other",
    HIGH_NOISE: "high noise",
}


@dataclass(frozen=True)
class PointCloud:
    """Points as parallel arrays plus their coordinate system.

    Attributes
    ----------
    xyz : (N, 3) float64 array of coordinates.
    classification : (N,) uint8 ASPRS class codes (0 where unknown).
    return_number, number_of_returns : (N,) uint8 (1 where unknown).
    intensity : (N,) uint16 or None where the source has none.
    withheld : (N,) bool, the points the source flags withheld (LAS: to be considered deleted),
        or None where it flags none.
    crs : a :class:`pyproj.CRS` or None where the source names none.
    source : where the points came from, for messages.
    """

    xyz: NDArray[np.float64]
    classification: NDArray[np.uint8]
    return_number: NDArray[np.uint8]
    number_of_returns: NDArray[np.uint8]
    intensity: NDArray[np.uint16] | None = None
    withheld: NDArray[np.bool_] | None = None
    crs: Any = None
    source: str = "<array>"
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        n = len(self.xyz)
        if self.xyz.ndim != 2 or self.xyz.shape[1] != 3:
            raise InputError(f"{self.source}: xyz must have shape (N, 3), got {self.xyz.shape}")
        for name in ("classification", "return_number", "number_of_returns", "intensity", "withheld"):
            arr = getattr(self, name)
            if arr is not None and len(arr) != n:
                raise InputError(f"{self.source}: {name} has {len(arr)} values for {n} points")

    def __len__(self) -> int:
        return len(self.xyz)

    @property
    def x(self) -> NDArray[np.float64]:
        return self.xyz[:, 0]

    @property
    def y(self) -> NDArray[np.float64]:
        return self.xyz[:, 1]

    @property
    def z(self) -> NDArray[np.float64]:
        return self.xyz[:, 2]

    @property
    def bounds(self) -> tuple[float, float, float, float, float, float]:
        """(xmin, ymin, zmin, xmax, ymax, zmax)."""
        lo, hi = column_range(self.xyz)
        return (float(lo[0]), float(lo[1]), float(lo[2]), float(hi[0]), float(hi[1]), float(hi[2]))

    def take(self, index: NDArray[Any]) -> PointCloud:
        """A new cloud of the points selected by ``index`` (mask or indices)."""
        return replace(
            self,
            xyz=self.xyz[index],
            classification=self.classification[index],
            return_number=self.return_number[index],
            number_of_returns=self.number_of_returns[index],
            intensity=None if self.intensity is None else self.intensity[index],
            withheld=None if self.withheld is None else self.withheld[index],
        )

    def excluded(self, classes: Iterable[int]) -> NDArray[np.bool_]:
        """Mask of the points no model is made from: those of ``classes`` and those the source
        flags withheld."""
        out = excluded(self.classification, classes)
        return out if self.withheld is None else out | self.withheld


def from_arrays(  # noqa: PLR0913 (one argument per field of a PointCloud)
    x: NDArray[Any],
    y: NDArray[Any],
    z: NDArray[Any],
    *,
    classification: NDArray[Any] | None = None,
    return_number: NDArray[Any] | None = None,
    number_of_returns: NDArray[Any] | None = None,
    intensity: NDArray[Any] | None = None,
    crs: Any = None,
    source: str = "<array>",
    validate: bool = True,
) -> PointCloud:
    """Build a :class:`PointCloud` from coordinate arrays.

    Raises
    ------
    InputError
        If arrays differ in length, are empty or hold NaN or infinite values.
    DegenerateInputError
        If the points span no area (see :func:`check_spread`).
    """
    try:
        xyz = np.column_stack([np.asarray(x, float), np.asarray(y, float), np.asarray(z, float)])
    except ValueError as exc:
        raise InputError(f"{source}: coordinate arrays differ in length ({exc})") from None
    n = len(xyz)
    ones = np.ones(n, np.uint8)
    cloud = PointCloud(
        xyz=xyz,
        classification=np.zeros(n, np.uint8) if classification is None else np.asarray(classification, np.uint8),
        return_number=ones if return_number is None else np.asarray(return_number, np.uint8),
        number_of_returns=ones.copy() if number_of_returns is None else np.asarray(number_of_returns, np.uint8),
        intensity=None if intensity is None else np.asarray(intensity, np.uint16),
        crs=as_crs(crs),
        source=source,
    )
    if validate:
        check_finite(cloud)
        check_spread(cloud)
    return cloud


def check_finite(cloud: PointCloud) -> None:
    """Raise :class:`InputError` for an empty cloud or non-finite coordinates."""
    if len(cloud) == 0:
        raise InputError(f"{cloud.source}: no points")
    bad = ~np.isfinite(cloud.xyz).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{cloud.source}: {int(bad.sum())} points have NaN or infinite coordinates (first at index {first})"
        )


def check_spread(cloud: PointCloud, *, tolerance: float = 1e-6) -> None:
    """Raise :class:`DegenerateInputError` unless the points span an area in x, y.

    A terrain surface needs at least three points that are not all identical
    and not all on one line in plan view.
    """
    n = len(cloud)
    if n < 3:
        raise DegenerateInputError(f"{cloud.source}: {n} point(s); a surface needs at least 3")
    xy = cloud.xyz[:, :2]
    centred = xy - xy.mean(axis=0)
    extent = float(np.abs(centred).max())
    if extent == 0.0:
        raise DegenerateInputError(f"{cloud.source}: all {n} points are at the same position")
    # The smaller singular value of the centred xy is the spread across the best line.
    sv = np.linalg.svd(centred / extent, compute_uv=False)
    if sv[-1] / np.sqrt(n) < tolerance:
        raise DegenerateInputError(f"{cloud.source}: all {n} points lie on one line in plan view")
