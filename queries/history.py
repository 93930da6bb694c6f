"""Changes over many versions of an area: each changed region's history.

With versions v0, v1, …, vn (in that order), every later version is co-registered against a
reference (default: the first), and each interval vk → vk+1 is compared with the shift between
the two (the difference of their shifts against the reference). Regions that overlap across
intervals are one history: when it first changed, and its height change and kind per interval.
With two versions this is :func:`queries.changes.detect` after co-registration.
"""

from __future__ import annotations

import re
from dataclasses import replace
from itertools import pairwise
from typing import Any

import numpy as np
import shapely

from queries.changes import detect
from queries.coregister import Shift, coregister
from tdb.database import Database
from tdb.geojson import feature
from tdb.options import Coregistration
from tdb.progress import Progress, labelled


def change_history(  # noqa: PLR0913 (the versions, where, how, and how it runs)
    db: Database,
    versions: list[str],
    *,
    level: int = 2,
    bbox: tuple[float, float, float, float] | None = None,
    reference: str | None = None,
    method: str | Coregistration = Coregistration.AUTO,
    progress: Progress | None = None,
    workers: int | None = None,
) -> list[dict[str, Any]]:
    """Changed regions across ``versions`` as GeoJSON features.

    For two versions: :func:`queries.changes.detect`'s regions, each with a ``coregistration``
    of the pair. For more: one feature per history, with ``first_changed`` (the version in which
    it first differs), ``intervals`` (how many intervals it changed in), and per interval ending
    in version v, ``dz_v`` (mean height change, m; 0 where it did not change) and ``kind_v``.
    ``progress`` (:mod:`tdb.progress`) follows each interval's detection, run in ``workers``
    processes where it is read in parts (:func:`queries.changes.detect`).
    """
    ref = reference or versions[0]
    shifts = {
        v: (Shift() if v == ref else coregister(db, ref, v, level=level, bbox=bbox, method=method))
        for v in versions
    }
    per_interval = []
    for before, after in pairwise(versions):
        shift = between(shifts[before], shifts[after])
        report = labelled(progress, f"{before} to {after}")
        found = detect(db, before, after, level=level, bbox=bbox, shift=shift, progress=report, workers=workers)
        per_interval.append((after, found))
    if len(versions) == 2:
        return per_interval[0][1]
    return _histories(per_interval)


def between(first: Shift, second: Shift) -> Shift:
    """The shift of ``second``'s survey from ``first``'s, both given against one reference."""
    return replace(
        second,
        dx=second.dx - first.dx if second.horizontal or first.horizontal else 0.0,
        dy=second.dy - first.dy if second.horizontal or first.horizontal else 0.0,
        dz=second.dz - first.dz,
        sigma_xy=float(np.hypot(np.nan_to_num(first.sigma_xy), np.nan_to_num(second.sigma_xy))),
        sigma_z=float(np.hypot(np.nan_to_num(first.sigma_z), np.nan_to_num(second.sigma_z))),
        nmad=_larger(first.nmad, second.nmad),
        residual_nmad=_larger(first.residual_nmad, second.residual_nmad),
        horizontal=first.horizontal or second.horizontal,
        vertical=first.vertical or second.vertical,
        datum_dz=second.datum_dz - first.datum_dz,
        datum=" and ".join(d for d in (first.datum, second.datum) if d),
    )


def _larger(a: float, b: float) -> float:
    """The larger of two spreads, either of which may be unknown (NaN)."""
    known = [v for v in (a, b) if np.isfinite(v)]
    return max(known) if known else float("nan")


def _histories(per_interval: list[tuple[str, list[dict[str, Any]]]]) -> list[dict[str, Any]]:
    """Regions of all intervals, those that overlap joined into one history."""
    items = [
        (k, shapely.geometry.shape(f["geometry"]), f["properties"])
        for k, (_, fs) in enumerate(per_interval)
        for f in fs
    ]
    parent = list(range(len(items)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    if items:
        geoms = [g for _, g, _ in items]
        a, b = shapely.STRtree(geoms).query(geoms, predicate="intersects")
        # regions that share ground are one history; two that only touch along an edge are not
        shared = shapely.area(shapely.intersection(np.take(geoms, a), np.take(geoms, b))) > 1e-9
        for i, j in zip(a[shared].tolist(), b[shared].tolist()):
            parent[root(i)] = root(j)
    groups: dict[int, list[int]] = {}
    for i in range(len(items)):
        groups.setdefault(root(i), []).append(i)
    names = [name for name, _ in per_interval]
    out = []
    for members in groups.values():
        geom = shapely.union_all([items[i][1] for i in members])
        props: dict[str, Any] = {
            "first_changed": names[min(items[i][0] for i in members)],
            "intervals": len({items[i][0] for i in members}),
            "area": float(geom.area),
        }
        for k, name in enumerate(names):
            mine = [items[i][2] for i in members if items[i][0] == k]
            key = _identifier(name)
            if mine:  # the largest region of this interval names its kind and change
                top = max(mine, key=lambda p: p["area"])
                props[f"dz_{key}"], props[f"kind_{key}"] = top["dz"], top["kind"]
            else:
                props[f"dz_{key}"], props[f"kind_{key}"] = 0.0, "unchanged"
        out.append(feature(geom, props))
    return sorted(out, key=lambda f: (names.index(f["properties"]["first_changed"]), -f["properties"]["area"]))


def _identifier(name: str) -> str:
    """A version name as a part of an attribute name (letters, digits and underscores)."""
    return re.sub(r"\W", "_", name)
