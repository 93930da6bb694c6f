"""A second survey of a scene with known changes between the two.

Five terrain changes: a ditch dug, a ditch filled, a wall built, a mound removed;
and off the terrain, a building added and a tenth of the trees felled. These alter
the returns but not the bare earth, so ``terrain`` is false for them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.base import BaseGeometry

from ingest.synth.geometry import wander
from ingest.synth.scene import Building, Feature, Placer, Scene

FELLED = 10  # one tree in this many is felled


@dataclass(frozen=True)
class Change:
    kind: str  # ditch_dug, ditch_filled, wall_built, mound_removed, building_added, tree_felled
    area: BaseGeometry
    dz: float  # signed height change of the surface (m)
    terrain: bool = True


def apply_changes(scene: Scene, *, seed: int = 0) -> tuple[Scene, list[Change]]:
    """The scene as a later survey sees it, and the list of what changed.

    Deterministic from ``seed``. New features are placed clear of everything
    already in the scene.
    """
    rng = np.random.default_rng([seed, 7919])
    placer = Placer(scene.bounds, rng)
    placer.taken = [f.footprint() for f in scene.features] + [b.footprint for b in scene.buildings]
    placer.taken += [shapely.Point(t.x, t.y).buffer(t.crown_radius) for t in scene.trees]
    features = list(scene.features)
    changes: list[Change] = []

    parents = {f.joined_to for f in features if f.joined_to is not None}
    fillable = [
        f for f in features if f.kind == "ditch" and f.ident not in parents and f.size >= 0.5 and f.width >= 1.5
    ]
    if fillable:
        gone = fillable[int(rng.integers(len(fillable)))]
        features.remove(gone)
        changes.append(Change("ditch_filled", gone.footprint(), +gone.size))
    mounds = [f for f in features if f.kind == "mound" and f.size >= 0.5]
    if mounds:
        gone = mounds[int(rng.integers(len(mounds)))]
        features.remove(gone)
        changes.append(Change("mound_removed", gone.footprint(), -gone.size))

    for kind, size, width, length in (
        ("ditch", rng.uniform(0.6, 1.2), rng.uniform(2.0, 3.5), rng.uniform(40, 90)),
        ("wall", rng.uniform(1.0, 1.5), rng.uniform(1.0, 1.4), rng.uniform(25, 60)),
    ):
        new = _place_line(placer, kind, float(size), float(width), float(length), ident=len(features) + 100)
        if new is not None:
            features.append(new)
            changes.append(
                Change("ditch_dug" if kind == "ditch" else "wall_built", new.footprint(), new.sign * new.size)
            )
    building = _place_building(placer, ident=len(scene.buildings))
    buildings = list(scene.buildings)
    if building is not None:
        buildings.append(building)
        changes.append(Change("building_added", building.footprint, building.height, terrain=False))
    felled = (
        set(rng.choice(len(scene.trees), size=len(scene.trees) // FELLED, replace=False).tolist())
        if scene.trees
        else set()
    )
    for i in sorted(felled):
        t = scene.trees[i]
        changes.append(
            Change("tree_felled", shapely.Point(t.x, t.y).buffer(t.crown_radius), -t.height, terrain=False)
        )
    trees = tuple(t for i, t in enumerate(scene.trees) if i not in felled)
    return replace(scene, features=tuple(features), buildings=tuple(buildings), trees=trees), changes


def _place_line(
    placer: Placer, kind: str, size: float, width: float, length: float, *, ident: int
) -> Feature | None:
    for _ in range(200):
        coords = wander(
            placer.point(margin=15.0), placer.rng.uniform(0, 2 * np.pi), length, curvature=0.0, rng=placer.rng
        )
        feature = Feature(
            kind,
            LineString(coords),
            round(size, 2),
            round(width, 2),
            profile="V" if kind == "ditch" else "U",
            ident=ident,
        )
        if placer.free(feature.footprint(), gap=6.0):
            placer.taken.append(feature.footprint())
            return feature
    return None


def _place_building(placer: Placer, *, ident: int) -> Building | None:
    for _ in range(200):
        cx, cy = placer.point(margin=20.0)
        box = Polygon.from_bounds(cx - 7, cy - 5, cx + 7, cy + 5)
        if placer.free(box, gap=4.0):
            placer.taken.append(box)
            return Building(box, round(float(placer.rng.uniform(4, 8)), 2), "flat", ident=ident)
    return None
