"""The terrain forms of a synthetic scene, and the placing of them without overlap."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

CUTS = ("ditch", "pit", "valley")
NATURAL = ("valley", "spur")
GAP = 5.0  # plan clearance between features (m)


@dataclass(frozen=True)
class Feature:
    """A terrain feature carved into or built onto the bare earth.

    kind: ditch, ridge, wall, embankment, pit or mound (the forms the queries look for), or
    valley, spur, road or edge (natural and man-made relief they must not mistake for one).
    ``geometry`` is the centreline (LineString) or centre (Point). ``size`` is the depth
    (ditch, pit, valley) or height (others) in metres; ``width`` the full width (lines) or the
    diameter (points); ``profile`` V or U for ditches and ridges, ``top=…,slope=…`` for
    embankments and roads. A line whose ``end_size`` or ``end_width`` is set changes linearly
    from its first vertex to its last: a ditch that fades out, a valley that widens and
    deepens downstream. An edge is a field edge: a bank of ``width`` rising ``size`` to its
    left (seen along the line), with the field above it falling back over ``terrace`` metres.
    """

    kind: str
    geometry: BaseGeometry
    size: float
    width: float
    profile: str = "V"
    ident: int = 0
    joined_to: int | None = None
    end_size: float | None = None
    end_width: float | None = None
    terrace: float = 0.0

    @property
    def sign(self) -> float:
        return -1.0 if self.kind in CUTS else 1.0

    @property
    def reach(self) -> float:
        """Plan distance beyond which the feature leaves the terrain unchanged."""
        if self.kind == "edge":
            return self.width / 2 + self.terrace
        return max(self.width, self.end_width or 0.0) / 2

    @property
    def tapers(self) -> bool:
        return self.end_size is not None or self.end_width is not None

    def along(self, share: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Size and full width at ``share`` (0 at the first vertex, 1 at the last) of the line."""
        end_size = self.size if self.end_size is None else self.end_size
        end_width = self.width if self.end_width is None else self.end_width
        size = self.size + (end_size - self.size) * share
        if self.kind in NATURAL:  # a natural form rises out of the slope and opens onto the plain
            size = size * np.sin(0.5 * np.pi * np.clip(np.minimum(share / 0.1, (1 - share) / 0.15), 0, 1))
        return size, self.width + (end_width - self.width) * share

    def footprint(self) -> BaseGeometry:
        return self.geometry.buffer(self.reach)


class Placer:
    """Rejection sampling of shapes that must not overlap what is already placed."""

    def __init__(self, bounds: tuple[float, float, float, float], rng: np.random.Generator):
        self.bounds = bounds
        self.rng = rng
        self.taken: list[BaseGeometry] = []
        self.area = Polygon.from_bounds(*bounds)

    def free(self, shape: BaseGeometry, gap: float) -> bool:
        if not self.area.buffer(-2.0).contains(shape):
            return False
        grown = shape.buffer(gap)
        return not any(grown.intersects(t) for t in self.taken)

    def point(self, margin: float = 0.0) -> tuple[float, float]:
        x0, y0, x1, y1 = self.bounds
        return (
            float(self.rng.uniform(x0 + margin, x1 - margin)),
            float(self.rng.uniform(y0 + margin, y1 - margin)),
        )
