"""`tdb info` facts and unit handling on every real file in ../shared/data."""

from __future__ import annotations

import laspy
import numpy as np
import pytest

from ingest.readers import read
from ingest.summary import summarize
from tdb.units import to_metres, units_of
from tests.conftest import data_file

LAS = [
    "Topography.laz",
    "MixedConifer.laz",
    "Megaplot.laz",
    "hexbin-crop.las",
    "append-bug.laz",
    "autzen_trim.laz",
    "4_6_crop.las",
    "file_with_both_wkt_and_geotiff_vlrs.las",
]
FEET = {
    "autzen_trim.laz": 0.3048,
    "4_6_crop.las": 1200 / 3937,
    "file_with_both_wkt_and_geotiff_vlrs.las": 1200 / 3937,
}
EPSG = {
    "Topography.laz": 2949,
    "MixedConifer.laz": 26912,
    "Megaplot.laz": 26917,
    "hexbin-crop.las": 32642,
    "append-bug.laz": 2154,
    "4_6_crop.las": 2903,
}
# Densities per occupied 2 m cell as the data README gives them.
DENSITY = {
    ("las", "MixedConifer.laz"): 4.7,
    ("las", "append-bug.laz"): 10.8,
    ("epochs", "TTP_2015.laz"): 1.06,
    ("epochs", "TTP_2019.laz"): 3.03,
    ("isprs", "samp11-utm.laz"): 0.93,
    ("isprs", "samp51-utm.laz"): 0.29,
}
ALL = (
    [("las", f) for f in LAS]
    + [("epochs", "TTP_2015.laz"), ("epochs", "TTP_2019.laz")]
    + [("isprs", f"samp{s}-utm.laz") for s in (11, 21, 22, 24, 31, 41, 51, 52, 54, 61)]
)


@pytest.mark.parametrize("folder,name", ALL)
def test_counts_and_classes_match_laspy(folder, name):
    path = data_file(folder, name)
    info = summarize(read(path))
    las = laspy.read(path)
    assert info["points"] == len(las.points) == las.header.point_count
    cls, counts = np.unique(np.asarray(las.classification), return_counts=True)
    assert sorted(int(k.split()[0]) for k in info["classification"]) == cls.tolist()
    assert sum(info["classification"].values()) == counts.sum()
    assert info["bounds"][0] == pytest.approx(las.header.mins[0], abs=1e-3)
    assert info["bounds"][5] == pytest.approx(las.header.maxs[2], abs=1e-3)


@pytest.mark.parametrize("name", sorted(EPSG))
def test_epsg(name):
    assert summarize(read(data_file("las", name)))["epsg"] == EPSG[name]


@pytest.mark.parametrize("name", LAS)
def test_units(name):
    units = units_of(read(data_file("las", name)).crs)
    if name in FEET:
        assert units.horizontal_factor == pytest.approx(FEET[name], rel=1e-9)
        assert units.vertical_factor == pytest.approx(FEET[name], rel=1e-9)
        assert "foot" in units.horizontal
    else:
        assert units.metric


@pytest.mark.parametrize("name", sorted(FEET))
def test_feet_converted_to_metres(name):
    raw = read(data_file("las", name))
    metric = to_metres(raw)
    np.testing.assert_allclose(metric.xyz, raw.xyz * FEET[name], rtol=1e-12)
    assert units_of(metric.crs).metric
    assert "converted_from" in metric.meta


@pytest.mark.parametrize("key", sorted(DENSITY))
def test_density_matches_data_readme(key):
    info = summarize(read(data_file(*key)))
    assert info["density_per_m2"] == pytest.approx(DENSITY[key], rel=0.02)


def test_density_in_metres_for_feet_file():
    # 4_6_crop is in US feet: a density per square foot would be ~11x smaller.
    info = summarize(read(data_file("las", "4_6_crop.las")))
    assert 3 < info["density_per_m2"] < 20
