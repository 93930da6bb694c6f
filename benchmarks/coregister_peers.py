"""Co-registration and change detection beside xdem and py4dgeo, in one run.

**Shifts (xdem).** On synthetic pairs re-surveyed with a known offset (as ``coregister_synth``) and on
the real TTP 2015 → 2019 pair, the shift tdb finds (``auto``, estimated afresh) beside xdem's
``VerticalShift`` and ``NuthKaab`` fitted on the same two surfaces: the grids tdb estimates on,
rebuilt from each version's kept points (1 m). xdem returns the correction that moves the later
DEM onto the earlier one; its negative is the offset tdb reports.

**Changed areas (py4dgeo).** On the TTP pair, M3C2 (Lague et al. 2013) with py4dgeo's defaults
for its level of detection, at core points on a 2 m grid, on each survey's ground points as tdb
classified them (the points its models rest on). A core point counts as changed where
|distance| exceeds M3C2's own level of detection. Both methods are judged per 2 m cell against
the providers' ground classes, as ``benchmarks/epochs.py`` judges tdb.

Peers come from ``pip install -e .[bench]``; a peer that is not installed is skipped.
    python -m benchmarks.coregister_peers [--seeds 1,...,5]
"""

from __future__ import annotations

import argparse
import importlib.util
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import shapely

import tdb
from benchmarks.common import DATA, save
from benchmarks.coregister_synth import offset_pair
from benchmarks.epochs import CELL, against_providers
from ingest.pipeline import ingest, survey
from ingest.readers import read
from queries.changes import detect
from queries.coregister import coregister, estimation_grids
from tdb.raster import Raster

M3C2_CYLINDER = 1.0  # m: radius of the cylinder the distance is measured in (half a 2 m cell)
M3C2_NORMALS = (2.0, 4.0, 6.0)  # m: scales the normal is chosen among (py4dgeo picks per point)


def have(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def xdem_shift(before: Raster, after: Raster, method: str) -> dict[str, float]:
    """xdem's offset of ``after`` from ``before`` (the negative of its correction), and its seconds."""
    import rasterio.transform
    import xdem

    def dem(r: Raster) -> Any:
        transform = rasterio.transform.from_origin(r.x0, r.y1, r.cell, r.cell)
        data = np.where(np.isfinite(r.data), r.data, -9999.0).astype(np.float32)
        return xdem.DEM.from_array(data, transform, r.crs or "EPSG:32617", nodata=-9999.0)

    ref, tba = dem(before), dem(after)
    coreg = xdem.coreg.NuthKaab() if method == "nuth-kaab" else xdem.coreg.VerticalShift()
    t0 = time.perf_counter()
    coreg.fit(ref, tba)
    seconds = time.perf_counter() - t0
    shift = coreg.meta["outputs"]["affine"]
    return {
        "dx": -float(shift.get("shift_x", 0.0)),
        "dy": -float(shift.get("shift_y", 0.0)),
        "dz": -float(shift.get("shift_z", 0.0)),
        "seconds": seconds,
    }


def shifts(db: tdb.Database, before: str, after: str) -> dict[str, Any]:
    """tdb's shift and each available xdem method's, on the grids tdb estimates on."""
    t0 = time.perf_counter()
    s = coregister(db, before, after, reuse=False)
    out: dict[str, Any] = {"tdb": {"dx": s.dx, "dy": s.dy, "dz": s.dz, "seconds": time.perf_counter() - t0}}
    if have("xdem"):
        first, second = estimation_grids(db, before, after)
        for method in ("vertical", "nuth-kaab"):
            out[f"xdem {method}"] = xdem_shift(first, second, method)
    return out


def synthetic(seed: int, size: float, density: float, workdir: Path) -> dict[str, Any]:
    db, offset, _ = offset_pair(seed, size, density, workdir / f"p{seed}.tdb")
    found = shifts(db, "before", "moved")
    for r in found.values():
        r["horizontal_error_m"] = float(np.hypot(r["dx"] - offset[0], r["dy"] - offset[1]))
        r["vertical_error_m"] = float(abs(r["dz"] - offset[2]))
    return {"offset": offset.tolist(), **found}


def m3c2_changed(clouds: dict[str, Any], grounds: dict[str, np.ndarray]) -> tuple[list[dict], dict[str, Any]]:
    """M3C2 on the two surveys' ground points at core points on a 2 m grid: the cells it finds
    changed (as GeoJSON-like features, for :func:`against_providers`) and its figures."""
    import py4dgeo

    a, b = (clouds[n].xyz[grounds[n]] for n in ("2015", "2019"))
    cells = np.unique(np.floor(a[:, :2] / CELL), axis=0)
    core_xy = (cells + 0.5) * CELL
    # the core points' heights: the earlier survey's lowest ground in the cell (normals need 3-D)
    key = np.floor(a[:, :2] / CELL)
    order = np.lexsort((a[:, 2], key[:, 1], key[:, 0]))
    first = np.r_[True, (np.diff(key[order], axis=0) != 0).any(axis=1)]
    core = np.column_stack([core_xy, a[order][first, 2]])
    t0 = time.perf_counter()
    m3c2 = py4dgeo.M3C2(
        epochs=(py4dgeo.Epoch(a), py4dgeo.Epoch(b)),
        corepoints=core,
        cyl_radius=M3C2_CYLINDER,
        normal_radii=M3C2_NORMALS,
    )
    distance, uncertainty = m3c2.run()
    seconds = time.perf_counter() - t0
    lod = uncertainty["lodetection"]
    changed = np.isfinite(distance) & np.isfinite(lod) & (np.abs(distance) > lod)
    boxes = shapely.box(*(core_xy[changed] - CELL / 2).T, *(core_xy[changed] + CELL / 2).T)
    area = shapely.coverage_union_all(boxes) if len(boxes) else None
    features = [] if area is None else [{"geometry": shapely.geometry.mapping(area)}]
    return features, {
        "core_points": len(core),
        "measured": int(np.isfinite(distance).sum()),
        "changed_core_points": int(changed.sum()),
        "median_lod_m": float(np.nanmedian(lod)),
        "seconds": seconds,
    }


def real_pair() -> dict[str, Any]:
    clouds = {n: read(DATA / "epochs" / f"TTP_{n}.laz") for n in ("2015", "2019")}
    with tempfile.TemporaryDirectory() as tmp:
        db = tdb.open(Path(tmp) / "ttp.tdb", create=True)
        for n, c in clouds.items():
            ingest(c, db, version=n)
        out: dict[str, Any] = {"shifts": shifts(db, "2015", "2019")}
        shift = coregister(db, "2015", "2019")
        out["tdb"] = against_providers(clouds, detect(db, "2015", "2019", shift=shift))
    if have("py4dgeo"):
        grounds = {n: survey(c).ground for n, c in clouds.items()}
        features, figures = m3c2_changed(clouds, grounds)
        out["m3c2"] = {**against_providers(clouds, features), **figures}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--size", type=float, default=300.0)
    parser.add_argument("--density", type=float, default=4.0)
    args = parser.parse_args()
    doc: dict[str, Any] = {"peers": {m: have(m) for m in ("xdem", "py4dgeo")}, "synthetic": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in (int(s) for s in args.seeds.split(",")):
            doc["synthetic"][seed] = synthetic(seed, args.size, args.density, Path(tmp))
            print(seed, doc["synthetic"][seed], flush=True)
    methods = [k for k in next(iter(doc["synthetic"].values())) if k != "offset"]
    doc["synthetic_max_error"] = {
        m: {
            "horizontal_m": max(r[m]["horizontal_error_m"] for r in doc["synthetic"].values()),
            "vertical_m": max(r[m]["vertical_error_m"] for r in doc["synthetic"].values()),
            "seconds_median": float(np.median([r[m]["seconds"] for r in doc["synthetic"].values()])),
        }
        for m in methods
    }
    print(doc["synthetic_max_error"], flush=True)
    doc["ttp"] = real_pair()
    print(doc["ttp"])
    print(save("coregister_peers", doc))


if __name__ == "__main__":
    main()
