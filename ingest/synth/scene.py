"""A synthetic terrain scene: relief, terrain features and off-terrain objects.

A :class:`Scene` is plain data; :mod:`ingest.synth.surface` evaluates its bare
earth exactly and :mod:`ingest.synth.sampling` turns it into LiDAR returns.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from ingest.synth import rugged as look_alikes
from ingest.synth.forms import GAP, Feature, Placer
from ingest.synth.geometry import wander
from tdb.errors import InputError
from tdb.options import Terrain, parse

DEFAULT_CRS = "EPSG:25832"
DEFAULT_ORIGIN = (500_000.0, 5_500_000.0)


@dataclass(frozen=True)
class Building:
    footprint: Polygon
    height: float
    roof: str  # "flat" or "gable"
    ridge_height: float = 0.0
    ident: int = 0


@dataclass(frozen=True)
class Tree:
    x: float
    y: float
    height: float
    crown_radius: float


@dataclass(frozen=True)
class Relief:
    """Hills (sums of sinusoids) plus one steep escarpment, in scene coordinates."""

    base: float
    waves: tuple[tuple[float, float, float, float], ...]  # amplitude, kx, ky, phase
    scarp_point: tuple[float, float]
    scarp_normal: tuple[float, float]
    scarp_height: float
    scarp_width: float


@dataclass(frozen=True)
class Scene:
    bounds: tuple[float, float, float, float]
    relief: Relief
    features: tuple[Feature, ...]
    buildings: tuple[Building, ...]
    trees: tuple[Tree, ...]
    crs: str = DEFAULT_CRS
    seed: int = 0
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    @property
    def size(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.bounds
        return x1 - x0, y1 - y0


MIN_SIZE, MAX_SIZE = 100.0, 20_000.0


def make_scene(
    *,
    seed: int = 0,
    size: float = 300.0,
    origin: tuple[float, float] = DEFAULT_ORIGIN,
    crs: str = DEFAULT_CRS,
    terrain: Terrain | str = Terrain.PLAIN,
) -> Scene:
    """Generate a scene of ``size`` × ``size`` metres, deterministic from ``seed``.

    Feature counts grow with the area: per hectare-scale blocks of ditches
    (straight, curved, V and U, some joined), ridges, walls, an embankment,
    pits and mounds, buildings with flat and gable roofs, and tree stands. A rugged
    ``terrain`` adds the look-alikes of real terrain (:mod:`ingest.synth.rugged`), a
    third of its ditches fade out, and all its ditches are 0.5–1.4 m deep and 1.8–4 m wide.

    Raises
    ------
    InputError
        If ``size`` is outside 100 m to 20 km.
    """
    if not (MIN_SIZE <= size <= MAX_SIZE):
        raise InputError(f"scene size must be {MIN_SIZE:.0f}..{MAX_SIZE:.0f} m, got {size}")
    terrain = parse(Terrain, terrain)
    rugged = terrain is Terrain.RUGGED
    rng = np.random.default_rng(seed)
    bounds = (origin[0], origin[1], origin[0] + size, origin[1] + size)
    relief = _make_relief(bounds, rng)
    placer = Placer(bounds, rng)
    blocks = max(1.0, (size / 150.0) ** 2)  # one set of features per ~150 m block
    features: list[Feature] = []
    counts = {
        "ditch": max(3, round(4 * blocks)),
        "ridge": max(1, round(1.5 * blocks)),
        "wall": max(1, round(blocks / 2)),
        "pit": max(1, round(blocks)),
        "mound": max(1, round(blocks)),
    }
    # One of every kind first, so small scenes hold them all; then the area-scaled rest.
    _add_embankments(features, placer, count=max(1, round(blocks / 4)))
    if rugged:
        _add_look_alikes(features, placer, blocks)
    buildings = _add_buildings(placer, count=1)
    for rest in (False, True):
        for kind, count in counts.items():
            n = count - 1 if rest else 1
            if kind in ("pit", "mound"):
                _add_points(features, placer, kind, count=n)
            else:
                _add_lines(
                    features,
                    placer,
                    kind,
                    count=n,
                    join_share=0.3 if kind == "ditch" and rest else 0.0,
                    rugged=rugged,
                )
    buildings += _add_buildings(placer, count=max(1, round(2 * blocks)) - 1, first_ident=1)
    trees = _add_trees(placer, stands=max(2, round(3 * blocks)))
    if rugged:
        stands = [(t.x, t.y, t.height, t.crown_radius) for t in trees]
        over = look_alikes.canopy_over_ditches(features, placer, stands, avoid=[b.footprint for b in buildings])
        trees += [Tree(*t) for t in over]
    meta = {"terrain": terrain.value}
    return Scene(bounds, relief, tuple(features), tuple(buildings), tuple(trees), crs=crs, seed=seed, meta=meta)


def _add_look_alikes(features: list[Feature], placer: Placer, blocks: float) -> None:
    """The rugged scene's natural and man-made relief, placed first: they are the largest."""
    look_alikes.add_roads(features, placer, count=max(1, round(blocks / 4)))
    look_alikes.add_field_edges(features, placer, count=max(1, round(blocks / 3)))
    look_alikes.add_natural(features, placer, "valley", count=max(2, round(0.6 * blocks)))
    look_alikes.add_natural(features, placer, "spur", count=max(1, round(0.4 * blocks)))


def _make_relief(bounds: tuple[float, float, float, float], rng: np.random.Generator) -> Relief:
    waves = []
    for wavelength, amplitude in ((700, 4.0), (350, 2.0), (180, 1.0)):
        angle = rng.uniform(0, np.pi)
        k = 2 * np.pi / (wavelength * rng.uniform(0.8, 1.25))
        waves.append(
            (amplitude * rng.uniform(0.6, 1.0), k * np.cos(angle), k * np.sin(angle), rng.uniform(0, 2 * np.pi))
        )
    x0, y0, x1, y1 = bounds
    angle = rng.uniform(0, 2 * np.pi)
    # The escarpment crosses the scene near one edge so most features sit on gentle ground.
    px = x0 + (x1 - x0) * rng.uniform(0.8, 0.9)
    py = y0 + (y1 - y0) * rng.uniform(0.1, 0.9)
    return Relief(
        base=float(rng.uniform(80, 300)),
        waves=tuple(waves),
        scarp_point=(px, py),
        scarp_normal=(1.0, 0.0)
        if rng.random() < 0.5
        else (float(np.cos(angle * 0.1)), float(np.sin(angle * 0.1))),
        scarp_height=float(rng.uniform(6, 12)),
        scarp_width=float(rng.uniform(8, 14)),
    )


RUGGED_DITCH = ((0.5, 1.4), (1.8, 4.0))  # depth, width (m)
FADE_SHARE = 1 / 3  # share of a rugged scene's free ditches that fade out towards one end
LINE_SPECS = {
    # kind: (size range, width range, length range, profiles)
    "ditch": ((0.3, 1.5), (1.0, 4.0), (40.0, 160.0), ("V", "U")),
    "ridge": ((0.5, 1.5), (3.0, 6.0), (40.0, 120.0), ("V", "U")),
    "wall": ((1.0, 1.8), (1.0, 1.6), (20.0, 80.0), ("U",)),
}


def _add_lines(
    features: list[Feature],
    placer: Placer,
    kind: str,
    *,
    count: int,
    join_share: float = 0.0,
    rugged: bool = False,
) -> None:
    rng = placer.rng
    (s0, s1), (w0, w1), (l0, l1), profiles = LINE_SPECS[kind]
    if rugged and kind == "ditch":
        (s0, s1), (w0, w1) = RUGGED_DITCH
    size = placer.bounds[2] - placer.bounds[0]
    mine: list[Feature] = []
    peers = [f for f in features if f.kind == kind]
    for _ in range(count * 60):
        if len(mine) >= count:
            break
        length = float(rng.uniform(min(l0, 0.3 * size), min(l1, 0.6 * size)))
        width = float(rng.uniform(w0, w1))
        joined_to = None
        if peers and rng.random() < join_share:
            parent = peers[int(rng.integers(len(peers)))]
            if parent.joined_to is not None:
                continue
            line = parent.geometry
            p = line.interpolate(rng.uniform(0.3, 0.7), normalized=True)
            a = line.interpolate(line.project(p) - 1.0)
            b = line.interpolate(line.project(p) + 1.0)
            along = np.arctan2(b.y - a.y, b.x - a.x)
            heading = along + rng.choice([-1, 1]) * rng.uniform(np.pi / 4, np.pi / 2)
            start = (p.x, p.y)
            joined_to = parent.ident
        else:
            # Centre the line on the random point so that it stays in the scene.
            cx, cy = placer.point(margin=10.0)
            heading = rng.uniform(0, 2 * np.pi)
            start = (cx - length / 2 * np.cos(heading), cy - length / 2 * np.sin(heading))
        curvature = 0.0 if rng.random() < 0.5 else float(rng.uniform(0.2, 0.5))
        coords = wander(start, heading, length, curvature=curvature, rng=rng)
        geom = LineString(coords)
        if joined_to is not None:
            # Only the part beyond the parent's banks must be free.
            parent_reach = features[joined_to].reach + width / 2 + GAP + 1.0
            check = geom.difference(features[joined_to].geometry.buffer(parent_reach))
        else:
            check = geom
        if check.is_empty or not placer.free(check.buffer(width / 2), gap=GAP):
            continue
        fades = rugged and kind == "ditch" and joined_to is None and rng.random() < FADE_SHARE
        feature = Feature(
            kind,
            geom,
            round(float(rng.uniform(s0, s1)), 2),
            round(width, 2),
            profile=str(rng.choice(profiles)),
            ident=len(features),
            joined_to=joined_to,
            end_size=0.0 if fades else None,
        )
        features.append(feature)
        mine.append(feature)
        peers.append(feature)
        placer.taken.append(feature.footprint())


def _add_embankments(features: list[Feature], placer: Placer, *, count: int) -> None:
    rng = placer.rng
    size = placer.bounds[2] - placer.bounds[0]
    for _ in range(count * 30):
        if sum(f.kind == "embankment" for f in features) >= count:
            return
        length = float(rng.uniform(0.3, 0.5) * size)
        cx, cy = placer.point(margin=10.0)
        heading = rng.uniform(0, 2 * np.pi)
        start = (cx - length / 2 * np.cos(heading), cy - length / 2 * np.sin(heading))
        coords = wander(start, heading, length, curvature=0.0, rng=rng)
        geom = LineString(coords)
        top = float(rng.uniform(6, 12))
        slope = float(rng.uniform(2, 4))
        feature = Feature(
            "embankment",
            geom,
            round(float(rng.uniform(1.0, 2.5)), 2),
            round(top + 2 * slope, 2),
            profile=f"top={top:.2f},slope={slope:.2f}",
            ident=len(features),
        )
        if placer.free(feature.footprint(), gap=8.0):
            features.append(feature)
            placer.taken.append(feature.footprint())


def _add_points(features: list[Feature], placer: Placer, kind: str, *, count: int) -> None:
    rng = placer.rng
    added = 0
    for _ in range(count * 30):
        if added >= count:
            return
        diameter = float(rng.uniform(4, 12))
        geom = Point(placer.point(margin=10.0))
        feature = Feature(
            kind, geom, round(float(rng.uniform(0.5, 2.0)), 2), round(diameter, 2), ident=len(features)
        )
        if placer.free(feature.footprint(), gap=5.0):
            features.append(feature)
            placer.taken.append(feature.footprint())
            added += 1


def _add_buildings(placer: Placer, *, count: int, first_ident: int = 0) -> list[Building]:
    rng = placer.rng
    out: list[Building] = []
    for _ in range(count * 30):
        if len(out) >= count:
            break
        w, d = float(rng.uniform(8, 25)), float(rng.uniform(8, 16))
        cx, cy = placer.point(margin=20.0)
        box = shapely.affinity.rotate(
            Polygon.from_bounds(cx - w / 2, cy - d / 2, cx + w / 2, cy + d / 2),
            float(rng.uniform(0, 180)),
            origin=(cx, cy),
        )
        if not placer.free(box, gap=4.0):
            continue
        gable = rng.random() < 0.5
        out.append(
            Building(
                box,
                round(float(rng.uniform(3, 10)), 2),
                "gable" if gable else "flat",
                round(float(rng.uniform(1.5, 4)), 2) if gable else 0.0,
                ident=first_ident + len(out),
            )
        )
        placer.taken.append(box)
    return out


def _add_trees(placer: Placer, *, stands: int) -> list[Tree]:
    rng = placer.rng
    trees: list[Tree] = []
    for _ in range(stands):
        cx, cy = placer.point(margin=15.0)
        for _ in range(int(rng.integers(10, 40))):
            x, y = cx + rng.normal(0, 10), cy + rng.normal(0, 10)
            r = float(rng.uniform(1.5, 4.0))
            crown = Point(x, y).buffer(r)
            if placer.free(crown, gap=1.0) and not any(
                np.hypot(t.x - x, t.y - y) < 0.8 * (t.crown_radius + r) for t in trees
            ):
                trees.append(Tree(float(x), float(y), round(float(rng.uniform(6, 25)), 2), round(r, 2)))
    placer.taken.extend(Point(t.x, t.y).buffer(t.crown_radius) for t in trees)
    return trees
