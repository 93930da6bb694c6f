"""Classes a survey marks unusable (tdb.classes): parsing, and no filter takes them as ground."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pyproj import CRS

from ingest.ground import classify_ground
from tdb.classes import NOISE, excluded, parse_classes, user_classes
from tdb.cloud import from_arrays
from tdb.errors import OptionError


@given(st.lists(st.integers(0, 255), max_size=8))
def test_parse_round_trip(codes):
    assert parse_classes(",".join(map(str, codes))) == tuple(sorted(set(codes)))
    assert parse_classes(codes) == tuple(sorted(set(codes)))


@pytest.mark.parametrize("text", ["seven", "7;18", "256", "-1", "7,,x"])
def test_parse_rejects(text):
    with pytest.raises(OptionError):
        parse_classes(text)


def test_none_and_empty_keep_everything():
    assert parse_classes("none") == parse_classes("") == ()
    assert not excluded(np.array([7, 18, 2], np.uint8), ()).any()
    assert excluded(np.array([7, 18, 2, 65], np.uint8), NOISE).tolist() == [True, True, False, False]


@pytest.fixture(scope="module")
def plane_cloud():
    """A gentle bare plane, 40 × 40 m at 4 points/m²; a random tenth is marked class 7."""
    rng = np.random.default_rng(3)
    n = 6400
    x, y = rng.uniform(0, 40, n), rng.uniform(0, 40, n)
    z = 100 + 0.02 * x + rng.normal(0, 0.02, n)
    cls = np.where(rng.random(n) < 0.1, 7, 2).astype(np.uint8)
    return from_arrays(x, y, z, classification=cls)


@pytest.mark.parametrize("method", ["auto", "sohn", "contour"])
def test_marked_points_are_never_ground(plane_cloud, method):
    marked = plane_cloud.classification == 7
    kept = classify_ground(plane_cloud, method=method)
    assert not kept[marked].any()
    assert kept[~marked].mean() > 0.95
    # the same points are true ground of the plane: with nothing excluded, they are found
    everything = classify_ground(plane_cloud, method=method, exclude=())
    assert everything[marked].mean() > 0.95


def test_too_few_left(plane_cloud):
    from tdb.errors import DegenerateInputError

    every = np.unique(plane_cloud.classification).tolist()
    with pytest.raises(DegenerateInputError):
        classify_ground(plane_cloud, exclude=every)


def test_user_range_classes_are_counted_unless_excluded():
    cls = np.array([2, 65, 65, 66, 7, 200], np.uint8)
    assert user_classes(cls, NOISE) == {"65": 2, "66": 1, "200": 1}
    assert user_classes(cls, (7, 18, 65)) == {"66": 1, "200": 1}
    assert user_classes(np.array([1, 2, 7], np.uint8), ()) == {}


def test_ingest_names_unknown_classes_and_excludes_them_on_request(plane_cloud, tmp_path):
    from click.testing import CliRunner

    from ingest.readers import write_las
    from tdb.cli import main

    cls = plane_cloud.classification.copy()
    cls[:50] = 65  # as IGN LiDAR HD marks its artefacts
    src = tmp_path / "ign.laz"
    write_las(src, replace(plane_cloud, crs=CRS.from_epsg(2154)), classification=cls)
    runner = CliRunner()
    db = str(tmp_path / "a.tdb")
    r = runner.invoke(main, ["ingest", str(src), "--db", db, "--version", "v"])
    assert r.exit_code == 0, r.output
    assert "50 of class 65" in r.stderr
    again = ["ingest", str(src), "--db", db, "--version", "v", "--replace", "--exclude-classes", "7,18,65"]
    r = runner.invoke(main, again)
    assert r.exit_code == 0 and "class 65" not in r.stderr
    import tdb

    stats = tdb.open(db).version("v").stats
    assert stats.excluded_points == int(np.isin(cls, (7, 18, 65)).sum())
