"""Records of what stands on the ground: individual trees and buildings."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from tdb.atomic import GEOPACKAGE, write_text
from tdb.geojson import feature, feature_collection


@dataclass(frozen=True)
class Tree:
    """One tree: its top's position (m, in the survey's CRS), height over the ground (m), crown
    diameter (m: of the circle of the crown's area, or fitted to its free edge where it meets
    other crowns) and crown outline."""

    x: float
    y: float
    height: float
    crown_diameter: float
    crown: shapely.Polygon | shapely.MultiPolygon

    @property
    def crown_area(self) -> float:
        """The area of the crown's circle (m²)."""
        return float(np.pi * self.crown_diameter**2 / 4)


@dataclass(frozen=True)
class Building:
    """One building: its footprint and the height (m) of its roof's top over the ground."""

    footprint: shapely.Polygon | shapely.MultiPolygon
    height: float

    @property
    def area(self) -> float:
        return float(self.footprint.area)


FEATURES = (".geojson", ".json")  # a GeoJSON FeatureCollection; ".gpkg" for a GeoPackage


def tree_features(trees: list[Tree], *, kind: str = "tree") -> list[dict[str, Any]]:
    """The trees as GeoJSON features: crowns as polygons, with ``kind`` (another for a change)
    and the top's position in the properties."""
    return [
        feature(
            t.crown,
            {
                "kind": kind,
                "x": round(t.x, 3),
                "y": round(t.y, 3),
                "height": round(t.height, 2),
                "crown_diameter": round(t.crown_diameter, 2),
            },
        )
        for t in trees
    ]


def tree_top_features(trees: list[Tree]) -> list[dict[str, Any]]:
    """The trees' tops as GeoJSON points."""
    return [
        feature(
            shapely.Point(t.x, t.y), {"height": round(t.height, 2), "crown_diameter": round(t.crown_diameter, 2)}
        )
        for t in trees
    ]


def building_features(buildings: list[Building], *, kind: str = "building") -> list[dict[str, Any]]:
    """The buildings as GeoJSON features: footprints with ``kind``, roof height and area."""
    return [
        feature(b.footprint, {"kind": kind, "height": round(b.height, 2), "area": round(b.area, 1)})
        for b in buildings
    ]


def write_features(path: str | os.PathLike[str], layers: dict[str, list[dict[str, Any]]], *, crs: Any) -> None:
    """Write feature layers to a GeoPackage (``.gpkg``: one table per layer) or, for GeoJSON,
    the first layer as one FeatureCollection; either way whole or not at all."""
    from tdb.geopackage import write_geopackage

    if Path(path).suffix.lower() in GEOPACKAGE:
        write_geopackage(path, layers, crs=crs)
    else:
        write_text(path, json.dumps(feature_collection(next(iter(layers.values())), crs)))
