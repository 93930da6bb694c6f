"""Change detection over an area too wide to read at once goes part by part, with the same regions."""

from __future__ import annotations

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

import queries.parts
import tdb
from ingest.pipeline import ingest
from ingest.synth import apply_changes, make_scene, sample
from queries.change_parts import MovedTiles, reached
from queries.changes import detect
from queries.coregister import estimation_grids


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """A 300 m scene and its re-survey after a round of changes, as versions a and b."""
    scene = make_scene(seed=9, size=300)
    later, _ = apply_changes(scene, seed=9)
    db = tdb.open(tmp_path_factory.mktemp("change-parts") / "p.tdb", create=True)
    ingest(sample(scene, density=2, seed=9), db, version="a")
    ingest(sample(later, density=2, seed=10), db, version="b")
    return db


def _key(features):
    props = [f["properties"] for f in features]
    return sorted((p["kind"], p["tiles"], round(p["area"], 6), p["dz"]) for p in props)


@pytest.mark.slow
@pytest.mark.parametrize("level", [2, 4])
def test_a_diff_by_parts_finds_the_regions_of_the_diff_at_once(pair, level):
    whole = detect(pair, "a", "b", level=level)
    assert len(whole) >= 2  # several regions, so that the parts have something to agree on
    seen = []
    with mock.patch.multiple(queries.parts, PART=256, PART_NODES=1000):
        parted = detect(pair, "a", "b", level=level, progress=lambda *a: seen.append(a), workers=2)
        alone = detect(pair, "a", "b", level=level, workers=1)
    assert _key(parted) == _key(whole) == _key(alone)  # in two worker processes and in this one
    assert len(seen) > 2 and seen[-1][0] == "parts" and seen[-1][1] == seen[-1][2] >= 2


@pytest.mark.slow
def test_a_diff_by_parts_of_a_box_finds_the_regions_of_the_box_at_once(pair):
    x0, y0 = pair.version("a").stats.bounds[:2]
    box = (x0 + 40.0, y0 + 30.0, x0 + 290.0, y0 + 250.0)
    whole = detect(pair, "a", "b", bbox=box)
    assert whole
    with mock.patch.multiple(queries.parts, PART=256, PART_NODES=1000):
        assert _key(detect(pair, "a", "b", bbox=box, workers=1)) == _key(whole)


@pytest.mark.slow
def test_a_changes_query_tells_its_progress_by_interval(pair):
    from queries.run import run

    whole = run(pair, "SELECT changes FROM a TO b")
    steps = []
    with mock.patch.multiple(queries.parts, PART=256, PART_NODES=1000):
        parted = run(pair, "SELECT changes FROM a TO b", progress=lambda *a: steps.append(a))
    assert {s for s, *_ in steps} == {"parts (a to b)"} and steps[-1][1] == steps[-1][2] >= 2
    assert sorted(map(str, parted)) == sorted(map(str, whole))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), share=st.floats(0.1, 0.6), level=st.sampled_from([2, 4]))
def test_the_seeds_reach_the_moved_tiles_that_touch_them(seed, share, level):
    rng = np.random.default_rng(seed)
    grid = rng.random((30, 40)) < share
    tj, ti = np.nonzero(grid)
    order = rng.permutation(len(ti))
    ti, tj = ti[order], tj[order]
    seeds = rng.choice(len(ti), size=min(3, len(ti)), replace=False) if len(ti) else np.zeros(0, np.intp)
    got = reached((ti * level - 50 * level).astype(np.int64), (tj * level).astype(np.int64), seeds, level)
    labels, _ = ndimage.label(grid, structure=np.ones((3, 3)))
    keep = np.unique(labels[tj[seeds], ti[seeds]])
    assert np.array_equal(got, np.flatnonzero(np.isin(labels[tj, ti], keep)))


@pytest.mark.slow
@mock.patch("queries.coregister.FIT_CELLS", 2000)  # a sample of the blocks, as over a wide area
def test_the_grids_a_shift_is_estimated_on_are_the_same_read_in_parts(pair):
    whole = estimation_grids(pair, "a", "b")
    with mock.patch.multiple(queries.parts, PART=256, PART_NODES=1000):
        parted = estimation_grids(pair, "a", "b")
    for w, p in zip(whole, parted):
        assert (w.x0, w.y1, w.cell, w.shape) == (p.x0, p.y1, p.cell, p.shape)
        assert np.isfinite(w.data).sum() > 1000
        np.testing.assert_array_equal(w.data, p.data)


def test_parts_where_the_versions_share_no_tile_hold_no_moved_tile():
    none = MovedTiles.joined([])
    assert len(none.xg) == 0 and none.dz.shape == (0, 9) and none.layer.shape == (2, 0)
    assert len(reached(none.xg, none.yg, np.zeros(0, np.intp), 2)) == 0
