"""Reduction and vertical error of the kept points, per real file, beside pydelatin.

For each file: default ground filter → 0.5 m dense model → categories → kept 2 m points.
pydelatin gets the same dense model (holes filled by nearest value) and the same number
of points; both surfaces are compared with the dense model at every valid post.
Every file runs with the default excluded classes (ASPRS noise, 7 and 18);
append-bug.laz (IGN LiDAR HD) runs a second time with its own artefact class 65
excluded as well, as a user of that data would ingest it.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import DATA, save
from ingest.pipeline import IngestOptions, survey
from ingest.readers import read
from tdb.classes import NOISE
from tdb.fill import fill_nearest
from tdb.tin import surface_height, triangulate

FILES = [
    ("las", f)
    for f in (
        "Topography.laz",
        "MixedConifer.laz",
        "Megaplot.laz",
        "hexbin-crop.las",
        "append-bug.laz",
        "autzen_trim.laz",
        "4_6_crop.las",
        "file_with_both_wkt_and_geotiff_vlrs.las",
    )
]
FILES += [("epochs", "TTP_2015.laz"), ("epochs", "TTP_2019.laz")]
EXTRA = {"append-bug.laz": (7, 18, 65)}  # file: classes excluded in the second run


def delatin_rmse(dtm: np.ndarray, points: int) -> tuple[float, float]:
    from pydelatin import Delatin

    valid = ~np.isnan(dtm)
    filled = fill_nearest(dtm).astype(np.float32)
    rows, cols = filled.shape
    mesh = Delatin(filled, width=cols, height=rows, max_points=points, max_error=0.0)
    v = mesh.vertices  # (col, rows - 1 - row, z): pydelatin counts rows from the bottom
    tri = triangulate(v[:, :2])
    rr, cc = np.nonzero(valid)
    z, _ = surface_height(tri, v[:, 2], np.column_stack([cc, rows - 1 - rr]).astype(float))
    err = z - dtm[valid]
    good = ~np.isnan(err)
    return float(np.sqrt(np.mean(err[good] ** 2))), float(np.abs(err[good]).max())


def main() -> None:
    rows = {}
    runs = [(folder, name, None) for folder, name in FILES]
    runs += [("las", name, classes) for name, classes in EXTRA.items()]
    for folder, name, classes in runs:
        path = DATA / folder / name
        t0 = time.perf_counter()
        s = survey(read(path), options=IngestOptions(exclude=NOISE if classes is None else classes))
        if classes is not None:
            name = f"{name} (classes {','.join(map(str, classes))} excluded)"
        st = s.model.stats
        assert st is not None
        d_rmse, d_max = delatin_rmse(s.dtm.data, st.kept_level2)
        rows[name] = {
            "dense_posts": st.dense_posts,
            "kept": st.kept_level2,
            "reduction_pct": st.reduction_pct,
            "tdb_rmse_m": st.rmse_m,
            "tdb_max_m": st.max_error_m,
            "delatin_rmse_m": d_rmse,
            "delatin_max_m": d_max,
            "flat_threshold_m": s.flat_threshold,
            "seconds": time.perf_counter() - t0,
        }
        print(name, rows[name], flush=True)
    print(save("reduction", {"files": rows}))


if __name__ == "__main__":
    main()
