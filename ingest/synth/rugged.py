"""The look-alikes of real terrain in a rugged scene.

A ditch query must not report a natural valley, a road's shoulder or a field edge, and
must still find a ditch under trees or where it fades out. So a rugged scene adds:
valleys and spurs of several sizes that widen (and deepen or rise) downstream, roads
raised on a bed with sloping shoulders and often a ditch beside them, field edges
(a bank with a terrace above it), and tree stands over ditches.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from ingest.synth.forms import GAP, Feature, Placer
from ingest.synth.geometry import wander

# natural hollows and spurs: (start width, start size) to (end width, end size), m
NATURAL_SIZES = (((5.0, 0.4), (12.0, 1.2)), ((8.0, 0.6), (24.0, 2.0)), ((12.0, 1.0), (40.0, 4.0)))
ROAD_TOP, ROAD_SHOULDER, ROAD_HEIGHT = (4.0, 7.0), (1.5, 3.0), (0.2, 0.6)
EDGE_HEIGHT, EDGE_BANK, EDGE_TERRACE = (0.3, 1.2), (2.0, 5.0), (12.0, 25.0)
ROADSIDE_DITCH = 0.6  # share of roads with a ditch along one side
CANOPY_SHARE = 0.3  # share of ditches under a stand of trees
TRIES = 40  # random draws per feature wanted before giving up on it


def _line(placer: Placer, length: float, curvature: float) -> LineString:
    cx, cy = placer.point(margin=10.0)
    heading = placer.rng.uniform(0, 2 * np.pi)
    start = (cx - length / 2 * np.cos(heading), cy - length / 2 * np.sin(heading))
    return LineString(wander(start, heading, length, curvature=curvature, rng=placer.rng))


def _place_many(
    features: list[Feature], placer: Placer, make: Callable[[int], list[Feature]], *, count: int
) -> None:
    """Place ``count`` draws of ``make`` (given how many are placed so far), each one or more
    features that must lie clear of what is already placed; ``TRIES`` draws per one wanted."""
    placed = 0
    for _ in range(count * TRIES):
        if placed >= count:
            return
        new = make(placed)
        shape = shapely.union_all([f.footprint() for f in new])
        if new and placer.free(shape, gap=GAP):
            features.extend(new)
            placer.taken.append(shape)
            placed += 1


def add_natural(features: list[Feature], placer: Placer, kind: str, *, count: int) -> None:
    """Valleys (``kind`` "valley") or spurs ("spur") that widen and grow along their line,
    cycling through small, medium and large."""
    rng = placer.rng
    span = placer.bounds[2] - placer.bounds[0]

    def make(placed: int) -> list[Feature]:
        (w0, s0), (w1, s1) = NATURAL_SIZES[placed % len(NATURAL_SIZES)]
        jitter = rng.uniform(0.8, 1.25, size=4)
        geom = _line(placer, float(rng.uniform(0.35, 0.7) * min(span, 300.0)), float(rng.uniform(0.2, 0.5)))
        return [
            Feature(
                kind,
                geom,
                float(round(s0 * jitter[0], 2)),
                float(round(w0 * jitter[1], 2)),
                profile="natural",
                ident=len(features),
                end_size=float(round(s1 * jitter[2], 2)),
                end_width=float(round(w1 * jitter[3], 2)),
            )
        ]

    _place_many(features, placer, make, count=count)


def add_roads(features: list[Feature], placer: Placer, *, count: int) -> None:
    """Roads on a raised bed with sloping shoulders, most with a ditch along one side."""
    rng = placer.rng
    span = placer.bounds[2] - placer.bounds[0]

    def make(_placed: int) -> list[Feature]:
        top, slope = float(rng.uniform(*ROAD_TOP)), float(rng.uniform(*ROAD_SHOULDER))
        geom = _line(placer, float(rng.uniform(0.5, 0.85) * span), float(rng.uniform(0.0, 0.3)))
        road = Feature(
            "road",
            geom,
            round(float(rng.uniform(*ROAD_HEIGHT)), 2),
            round(top + 2 * slope, 2),
            profile=f"top={top:.2f},slope={slope:.2f}",
            ident=len(features),
        )
        if rng.random() >= ROADSIDE_DITCH:
            return [road]
        width = float(rng.uniform(1.8, 3.0))
        offset = road.width / 2 + width / 2 + 0.5
        side = geom.offset_curve(offset * rng.choice([-1.0, 1.0]))
        if side.geom_type != "LineString" or side.is_empty:
            return [road]
        depth = round(float(rng.uniform(0.5, 1.0)), 2)
        return [road, Feature("ditch", side, depth, round(width, 2), "V", len(features) + 1)]

    _place_many(features, placer, make, count=count)


def add_field_edges(features: list[Feature], placer: Placer, *, count: int) -> None:
    """Straight field edges: a bank rising to a terrace that falls back to the field below."""
    rng = placer.rng
    span = placer.bounds[2] - placer.bounds[0]

    def make(_placed: int) -> list[Feature]:
        return [
            Feature(
                "edge",
                _line(placer, float(rng.uniform(0.3, 0.6) * span), 0.0),
                round(float(rng.uniform(*EDGE_HEIGHT)), 2),
                round(float(rng.uniform(*EDGE_BANK)), 2),
                profile="bank",
                ident=len(features),
                terrace=round(float(rng.uniform(*EDGE_TERRACE)), 1),
            )
        ]

    _place_many(features, placer, make, count=count)


def canopy_over_ditches(
    features: list[Feature],
    placer: Placer,
    trees: list[tuple[float, float, float, float]],
    *,
    avoid: list[BaseGeometry],
) -> list[tuple[float, float, float, float]]:
    """Tree stands (x, y, height, crown radius) along a share of the ditches, whose crowns may
    reach over a ditch but not into another crown, another feature or the shapes in ``avoid``."""
    rng = placer.rng
    others = [f.footprint() for f in features if f.kind != "ditch"] + avoid
    blocked = shapely.union_all(others) if others else shapely.GeometryCollection()
    out: list[tuple[float, float, float, float]] = []
    for ditch in (f for f in features if f.kind == "ditch"):
        if rng.random() >= CANOPY_SHARE:
            continue
        line = ditch.geometry
        for share in rng.uniform(0.1, 0.9, size=int(rng.integers(6, 16))):
            p = line.interpolate(float(share), normalized=True)
            x, y = p.x + rng.normal(0, 2.5), p.y + rng.normal(0, 2.5)
            r = float(rng.uniform(1.5, 3.5))
            crown = Point(x, y).buffer(r)
            if not placer.area.buffer(-2.0).contains(crown) or crown.intersects(blocked):
                continue
            if any(np.hypot(tx - x, ty - y) < 0.8 * (tr + r) for tx, ty, _, tr in trees + out):
                continue
            out.append((float(x), float(y), round(float(rng.uniform(6, 22)), 2), round(r, 2)))
    return out
