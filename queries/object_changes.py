"""Changes of what stands on the ground between two versions: trees felled and new, buildings
added and removed, each with its outline.

A tree is felled where the earlier survey has a tree whose top has neither a tree top within
:data:`MATCH` m in the later one nor a later crown over it; new the other way round. Asking
for both keeps a crown that one survey saw as two from reading as a felled and a new tree. A
building is removed where no later footprint covers :data:`COVERED` of its own, added the
other way round.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely
from scipy.spatial import cKDTree

from tdb.database import Database
from tdb.objects import Building, Tree, building_features, tree_features

MATCH = 1.5  # m: tops this close are one tree seen twice
COVERED = 0.5  # share of a footprint another survey's footprints must cover for it to stand


def object_changes(
    db: Database, before: str, after: str, *, bbox: tuple[float, float, float, float] | None = None
) -> list[dict[str, Any]]:
    """Trees felled and new, buildings removed and added, from ``before`` to ``after``, as GeoJSON
    features with ``kind``, ``height`` (m) and the outline."""
    trees_a, trees_b = db.trees(before, bbox=bbox), db.trees(after, bbox=bbox)
    houses_a, houses_b = db.buildings(before, bbox=bbox), db.buildings(after, bbox=bbox)
    return [
        *tree_features(_gone(trees_a, trees_b), kind="tree felled"),
        *tree_features(_gone(trees_b, trees_a), kind="tree new"),
        *building_features(_uncovered(houses_a, houses_b), kind="building removed"),
        *building_features(_uncovered(houses_b, houses_a), kind="building added"),
    ]


def _gone(these: list[Tree], others: list[Tree]) -> list[Tree]:
    """The trees of ``these`` that ``others`` has no tree for."""
    if not these or not others:
        return list(these)
    tops = np.array([[t.x, t.y] for t in these])
    near, _ = cKDTree([[t.x, t.y] for t in others]).query(tops, distance_upper_bound=MATCH)
    crowns = shapely.STRtree([t.crown for t in others])
    under = np.zeros(len(these), bool)
    hit, _ = crowns.query(shapely.points(tops), predicate="intersects")
    under[hit] = True
    return [t for t, d, u in zip(these, near, under, strict=True) if not np.isfinite(d) and not u]


def _uncovered(these: list[Building], others: list[Building]) -> list[Building]:
    if not others:
        return list(these)
    union = shapely.union_all([b.footprint for b in others])
    return [b for b in these if b.footprint.intersection(union).area < COVERED * b.area]
