"""GeoJSON of a scene's true features and of the changes between two versions.

Coordinates are in the scene's projected CRS, named in a ``crs`` member as
QGIS and GDAL read it.
"""

from __future__ import annotations

import json
import os
from typing import Any

import shapely

from ingest.synth.changes import Change
from ingest.synth.scene import Scene
from tdb.atomic import write_text
from tdb.geojson import feature, feature_collection


def scene_truth(scene: Scene) -> dict[str, Any]:
    """All true terrain features, buildings and trees of ``scene`` as a FeatureCollection."""
    out = []
    for f in scene.features:
        props: dict[str, Any] = {"kind": f.kind, "id": f.ident, "width": f.width}
        props["depth" if f.sign < 0 else "height"] = f.size
        if f.kind in ("ditch", "ridge", "wall"):
            props["profile"] = f.profile
            props["length"] = round(f.geometry.length, 2)
        if f.joined_to is not None:
            props["joined_to"] = f.joined_to
        if f.kind in ("embankment", "road"):
            props["length"] = round(f.geometry.length, 2)
            props.update({k: float(v) for k, v in (p.split("=") for p in f.profile.split(","))})
        if f.tapers:  # towards the line's last vertex; depth (height) and width are at its first
            props["end_depth" if f.sign < 0 else "end_height"] = f.size if f.end_size is None else f.end_size
            props["end_width"] = f.width if f.end_width is None else f.end_width
        if f.kind == "edge":
            props.update({"length": round(f.geometry.length, 2), "terrace": f.terrace})
        out.append(feature(f.geometry, props))
    for b in scene.buildings:
        out.append(feature(b.footprint, {"kind": "building", "id": b.ident, "height": b.height, "roof": b.roof}))
    for t in scene.trees:
        out.append(
            feature(shapely.Point(t.x, t.y), {"kind": "tree", "height": t.height, "crown_radius": t.crown_radius})
        )
    return feature_collection(out, scene.crs)


def changes_truth(changes: list[Change], crs: str) -> dict[str, Any]:
    """The changes as polygons with kind, signed height change and area."""
    return feature_collection(
        [
            feature(
                c.area, {"kind": c.kind, "dz": round(c.dz, 2), "area": round(c.area.area, 1), "terrain": c.terrain}
            )
            for c in changes
        ],
        crs,
    )


def write_json(path: str | os.PathLike[str], doc: dict[str, Any]) -> None:
    write_text(path, json.dumps(doc))
