"""Feature filters: objects as patterns over tile categories (the paper's Match step).

A filter is data (JSON validated by ``schemas/filter.schema.json``): the tile
features it accepts, how tiles join (``lines``: only where their break lines
meet at the shared edge middle or corner; ``touch``: where the tiles touch),
whether the match is a line along the break lines or a polygon, its default level.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from tdb.categories import FEATURE_NAMES, SUBPART_UV, all_categories
from tdb.errors import FilterError

# Feature of each uint8 code (-1 for codes that are no category: no data, absent).
FEATURES = np.array([c.feature for c in all_categories()] + [-1] * (256 - len(all_categories())))


@dataclass(frozen=True)
class Filter:
    name: str
    features: frozenset[int]
    linear: bool
    level: int = 2
    min_tiles: int = 1
    measure: str = "height"
    description: str = ""
    join: str = "lines"
    min_measure: float = 0.0
    gap: int = 0
    min_elongation: float = 0.0


@cache
def _validator() -> Any:
    import jsonschema

    schema = _schema()
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def _schema() -> dict[str, Any]:
    path = Path(__file__).resolve().parents[1] / "schemas" / "filter.schema.json"
    if not path.exists():  # installed without the source tree
        path = Path(str(resources.files("schemas") / "filter.schema.json"))
    return json.loads(path.read_text())


def parse_filter(doc: dict[str, Any]) -> Filter:
    """Validate a filter document and build the :class:`Filter`.

    Raises
    ------
    FilterError
        If the document does not follow ``schemas/filter.schema.json``.
    """
    from jsonschema.exceptions import best_match

    error = best_match(_validator().iter_errors(doc))
    if error is not None:
        where = "/".join(map(str, error.absolute_path)) or "filter"
        raise FilterError(f"invalid filter ({where}): {error.message}")
    codes = frozenset(FEATURE_NAMES.index(f) for f in doc["features"])
    join = doc.get("join", "lines" if doc["linear"] else "touch")
    return Filter(
        doc["name"],
        codes,
        doc["linear"],
        doc.get("level", 2),
        doc.get("min_tiles", 1),
        doc.get("measure", "height"),
        doc.get("description", ""),
        join,
        float(doc.get("min_measure", 0.0)),
        int(doc.get("gap", 0)),
        float(doc.get("min_elongation", 0.0)),
    )


def load_filter(path: str | os.PathLike[str]) -> Filter:
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise FilterError(f"{path}: cannot read filter ({exc})") from None
    return parse_filter(doc)


def builtin_filters() -> dict[str, Filter]:
    folder = Path(__file__).resolve().parent / "filters"
    return {f.name: f for f in (load_filter(p) for p in sorted(folder.glob("*.json")))}


@dataclass(frozen=True)
class Match:
    """One matched object: its tiles and geometry (a line for linear filters, else a polygon)."""

    filter: str
    level: int
    tiles: NDArray[np.intp]
    geometry: shapely.Geometry
    length: float
    measure: float


# For each category, the sub-parts its feature touches on the tile boundary.
def _endpoints() -> list[tuple[int, ...]]:
    out: list[tuple[int, ...]] = []
    for c in all_categories():
        if c.orientation is None:
            out.append(())
        else:
            out.append(tuple(sorted(set(c.orientation))))
    return out


# Neighbour offsets and the sub-part pairs that meet across the shared edge or corner.
LINKS = {
    (1, 0): ((2, 0), (5, 3), (8, 6)),
    (0, 1): ((6, 0), (7, 1), (8, 2)),
    (1, 1): ((8, 0),),
    (1, -1): ((2, 6),),
}


def _touching(gap: int) -> dict[tuple[int, int], tuple[tuple[int, int], ...]]:
    """Offsets (one of each ± pair) of the tiles within ``gap`` tiles of touching."""
    r = gap + 1
    return {(dx, dy): () for dx in range(0, r + 1) for dy in range(-r, r + 1) if dx > 0 or dy > 0}


def components(
    xg: NDArray[np.int64], yg: NDArray[np.int64], code: NDArray[np.uint8], flt: Filter, level: int
) -> list[NDArray[np.intp]]:
    """Groups of tile indices forming one object under ``flt``."""
    sel = np.flatnonzero(np.isin(FEATURES[code], list(flt.features)))
    if len(sel) == 0:
        return []
    ends = _endpoints()
    index = {(int(x), int(y)): k for k, (x, y) in enumerate(zip(xg[sel], yg[sel]))}
    rows, cols = [], []
    links = LINKS if flt.join == "lines" else _touching(flt.gap)
    for k, (x, y) in enumerate(zip(xg[sel], yg[sel])):
        for (dx, dy), pairs in links.items():
            j = index.get((int(x) + dx * level, int(y) + dy * level))
            if j is None:
                continue
            if flt.join == "lines":
                a, b = ends[int(code[sel[k]])], ends[int(code[sel[j]])]
                if not any(p in a and q in b for p, q in pairs):
                    continue
            rows.append(k)
            cols.append(j)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(sel), len(sel)))
    n, labels = connected_components(graph, directed=False)
    groups = [sel[labels == g] for g in range(n)]
    return [g for g in groups if len(g) >= flt.min_tiles]


def tile_lines(xg: NDArray[np.int64], yg: NDArray[np.int64], code: NDArray[np.uint8], level: int) -> list[Any]:
    """Each tile's break line in world coordinates (None for tiles without one)."""
    out: list[Any] = []
    for x, y, c in zip(xg, yg, code):
        cat = all_categories()[int(c)] if c < 115 else None
        if cat is None or cat.orientation is None or cat.orientation[0] == cat.orientation[1]:
            out.append(None)
            continue
        p, q = SUBPART_UV[cat.orientation[0]], SUBPART_UV[cat.orientation[1]]
        out.append(
            shapely.LineString([(x + p[0] * level, y + p[1] * level), (x + q[0] * level, y + q[1] * level)])
        )
    return out
