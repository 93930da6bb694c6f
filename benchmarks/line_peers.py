"""Two simple peers that find ditches and ridges as lines on a dense ground model.

- A local relief model (Hesse 2010): the model minus its mean over a window, thresholded
  below (ditches) or above (ridges), skeletonised (scikit-image).
- Geomorphons (Jasiewicz & Stepinski 2013) from GRASS ``r.geomorphon``: the valley and
  depression forms for ditches, ridge and summit for ridges, skeletonised. Needs GRASS (Debian
  ``grass-core``); :func:`grass_available` says whether it is installed.

Both give their skeletons as line segments between neighbouring skeleton cells, with
skeleton pieces shorter than ``min_length`` dropped: the peers' way of ignoring specks.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio
import shapely
from numpy.typing import NDArray
from scipy import ndimage
from skimage.morphology import skeletonize

from tdb.geotiff import write_geotiff
from tdb.raster import Raster

# r.geomorphon's form codes: a ditch's bottom reads valley or depression, a ridge's crest ridge
# or summit; the wide sets add the forms beside them (hollow, spur), the settings choose
FORMS = {
    ("ditch", False): (9, 10),
    ("ditch", True): (7, 9, 10),
    ("ridge", False): (2, 3),
    ("ridge", True): (2, 3, 5),
}


@dataclass(frozen=True)
class ReliefSetting:
    radius: float  # half the side of the smoothing window (m)
    threshold: float  # local relief a line cell must reach (m)
    min_length: float  # shortest skeleton piece kept (m)


@dataclass(frozen=True)
class GeomorphonSetting:
    search: int  # outer search radius (cells)
    flat: float  # flatness threshold (degrees)
    min_length: float
    wide: bool  # count the forms beside the bottom (crest) too


def relief_settings() -> list[ReliefSetting]:
    return [ReliefSetting(r, t, m) for r in (3.0, 5.0, 8.0, 12.0) for t in (0.1, 0.2, 0.3) for m in (10.0, 20.0)]


def geomorphon_settings() -> list[GeomorphonSetting]:
    return [
        GeomorphonSetting(s, f, m, w)
        for s in (3, 5, 8, 12)
        for f in (0.5, 1.0, 2.0)
        for m in (10.0, 20.0)
        for w in (False, True)
    ]


def _filled(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """No-data cells take their nearest cell's value, so a window never reads NaN."""
    gap = ~np.isfinite(z)
    if not gap.any():
        return z
    idx = ndimage.distance_transform_edt(gap, return_distances=False, return_indices=True)
    return z[tuple(idx)]


def local_relief(dtm: Raster, radius: float) -> NDArray[np.float64]:
    z = _filled(dtm.data)
    size = 2 * max(1, round(radius / dtm.cell)) + 1
    return np.where(np.isfinite(dtm.data), z - ndimage.uniform_filter(z, size=size, mode="nearest"), np.nan)


def relief_lines(dtm: Raster, setting: ReliefSetting, *, kind: str) -> shapely.Geometry:
    """Ditch (``kind`` "ditch") or ridge lines of the local relief model."""
    lrm = local_relief(dtm, setting.radius)
    with np.errstate(invalid="ignore"):
        mask = lrm <= -setting.threshold if kind == "ditch" else lrm >= setting.threshold
    return skeleton_lines(mask, dtm, min_length=setting.min_length)


def skeleton_lines(mask: NDArray[np.bool_], grid: Raster, *, min_length: float) -> shapely.Geometry:
    """The skeleton of ``mask`` as segments joining neighbouring skeleton cells' centres; pieces
    of fewer than ``min_length`` metres of cells are dropped."""
    skel = skeletonize(mask)
    labels, n = ndimage.label(skel, structure=np.ones((3, 3)))
    if n == 0:
        return shapely.MultiLineString()
    cells = np.bincount(labels.ravel(), minlength=n + 1)
    skel &= (cells * grid.cell >= min_length)[labels] & (labels > 0)
    rows, cols = skel.shape
    pad = np.pad(skel, 1)
    at = lambda dr, dc: pad[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols]  # noqa: E731
    links = [
        (0, 1, skel & at(0, 1)),
        (1, 0, skel & at(1, 0)),
        # a diagonal step only where no two straight steps already join the cells
        (1, 1, skel & at(1, 1) & ~at(0, 1) & ~at(1, 0)),
        (1, -1, skel & at(1, -1) & ~at(0, -1) & ~at(1, 0)),
    ]
    parts = []
    for dr, dc, ok in links:
        r, c = np.nonzero(ok)
        x = grid.x0 + (c + 0.5) * grid.cell
        y = grid.y1 - (r + 0.5) * grid.cell
        ends = np.column_stack([x + dc * grid.cell, y - dr * grid.cell])
        parts.append(np.stack([np.column_stack([x, y]), ends], axis=1))
    segments = np.concatenate(parts)
    if len(segments) == 0:
        return shapely.MultiLineString()
    return shapely.line_merge(shapely.multilinestrings(shapely.linestrings(segments)))


def grass_available() -> bool:
    return shutil.which("grass") is not None


def geomorphon_forms(dtm: Raster, settings: list[GeomorphonSetting]) -> dict[tuple[int, float], NDArray[np.int16]]:
    """r.geomorphon's forms of ``dtm`` for each (search, flat) of ``settings``, in one GRASS session."""
    pairs = sorted({(s.search, s.flat) for s in settings})
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        write_geotiff(work / "dem.tif", Raster(_filled(dtm.data), dtm.x0, dtm.y1, dtm.cell, dtm.crs))
        script = ["r.in.gdal input=dem.tif output=dem --quiet", "g.region raster=dem"]
        for k, (search, flat) in enumerate(pairs):
            script += [
                f"r.geomorphon elevation=dem forms=f{k} search={search} skip=0 flat={flat} --quiet --overwrite",
                f"r.out.gdal input=f{k} output=f{k}.tif format=GTiff type=Int16 --quiet --overwrite",
            ]
        (work / "run.sh").write_text("set -e\n" + "\n".join(script) + "\n")
        subprocess.run(
            ["grass", "--tmp-location", "dem.tif", "--exec", "bash", "run.sh"],
            cwd=work,
            check=True,
            capture_output=True,
        )
        out = {}
        for k, pair in enumerate(pairs):
            with rasterio.open(work / f"f{k}.tif") as src:
                out[pair] = src.read(1)
    return out


def geomorphon_lines(
    forms: NDArray[np.int16], dtm: Raster, setting: GeomorphonSetting, *, kind: str
) -> shapely.Geometry:
    return skeleton_lines(np.isin(forms, FORMS[kind, setting.wide]), dtm, min_length=setting.min_length)
