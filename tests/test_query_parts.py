"""A feature query over an area too wide to read at once goes part by part, with the same matches."""

from __future__ import annotations

from unittest import mock

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import queries.parts
import tdb
from ingest.pipeline import ingest
from ingest.synth import make_scene, sample
from queries.filters import candidates, components
from queries.match import find, resolve
from queries.parts import Candidates, grouped, line_batches, part_boxes, part_candidates, part_side
from queries.run import run
from tdb.blocks import TILES_PER_BLOCK
from tdb.categories import all_categories
from tests.conftest import two_patches

pytestmark = pytest.mark.slow

GAP = 1500.0  # m between the two patches of the second version


@pytest.fixture(scope="module")
def db(tmp_path_factory):
    """Version ``v``: a 300 m scene with ditches, ridges and walls; ``far``: two copies of a 120 m
    one, 1.5 km apart."""
    d = tdb.open(tmp_path_factory.mktemp("parts") / "p.tdb", create=True)
    ingest(sample(make_scene(seed=3, size=300), density=2, seed=3), d, version="v")
    ingest(two_patches(sample(make_scene(seed=5, size=120), density=2, seed=5), GAP), d, version="far")
    return d


def _key(matches):
    # a measure may be NaN (no relief read), which does not sort: compared as text
    return sorted((m.filter, f"{m.measure:.9f}", m.geometry.normalize().wkt, len(m.tiles)) for m in matches)


def _in_parts(part: int, nodes: int = 1000):
    """Parts of ``part`` m, and batches small enough that every group is read on its own."""
    return mock.patch.multiple(queries.parts, PART=part, PART_NODES=nodes)


@pytest.mark.parametrize("name", ["ditch", "ridge", "wall", "embankment"])
def test_a_query_by_parts_matches_the_query_at_once(db, name):
    whole = find(db, "v", name)
    assert whole, f"the scene holds {name} matches"
    seen = []
    with _in_parts(256):
        n = len(part_boxes(db, "v", level=resolve(name).level))
        assert n >= 2  # 300 m over 256 m parts (512 m at level 4: a block)
        parted = find(
            db, "v", name, workers=2, progress=lambda stage, done, total: seen.append((stage, done, total))
        )
        alone = find(db, "v", name, workers=1)
    assert _key(parted) == _key(whole) == _key(alone)  # in two worker processes and in this one
    own = [s for s in seen if not s[0].endswith(("(mounds)", "(ditches)"))]  # a ridge asks for mounds and ditches
    assert ("parts", n, n) in own and own[-1][0] == "batches" and own[-1][1] == own[-1][2] >= 2
    flt = resolve(name)
    assert {s[0] for s in seen} - {s[0] for s in own} == {
        f"batches ({form})" for form, on in (("mounds", flt.max_on_mounds), ("ditches", flt.max_by_ditches)) if on
    }


class _Tiles:
    """A stand-in database of tiles of random categories (inclined planes facing each other on
    every part edge): only the reads :func:`part_candidates` and :func:`part_boxes` make."""

    def __init__(self, seed: int, level: int) -> None:
        side = 3 * part_side(level) // level
        j, i = np.divmod(np.arange(side * side), side)
        self.xg = (i * level - part_side(level)).astype(np.int64)
        self.yg = (j * level + 7 * level).astype(np.int64)
        self.code = np.random.default_rng(seed).integers(0, len(all_categories()), len(i)).astype(np.uint8)

    def tiles(self, version, *, level, bbox=None, ordered=True):
        x0, y0, x1, y1 = bbox
        # tiles that overlap the box, not those that only touch it
        m = (self.xg + level > x0) & (self.xg < x1) & (self.yg + level > y0) & (self.yg < y1)
        return self.xg[m], self.yg[m], self.code[m]

    def tile_blocks(self, version, *, level, bbox=None):
        side = TILES_PER_BLOCK * level
        keys = np.unique(np.column_stack([self.xg // side, self.yg // side]), axis=0)
        return keys[:, 0], keys[:, 1]


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), level=st.sampled_from([2, 4]), name=st.sampled_from(["ditch", "ridge"]))
def test_the_parts_candidates_are_those_of_the_area_read_at_once(seed, level, name):
    fake, flt = _Tiles(seed, level), resolve(name)
    own, facing = candidates(fake.xg, fake.yg, fake.code, flt, level)
    assert facing.any() or not flt.facing
    parts = part_boxes(fake, "v", level=level)
    assert len(parts) == 12  # 3 × 3 parts of tiles, shifted north by a few tiles
    got = part_candidates(fake, "v", flt, level=level, bbox=None, parts=parts)
    for mine, want in ((got.own, own), (got.facing, facing)):
        assert sorted(zip(got.xg[mine], got.yg[mine])) == sorted(zip(fake.xg[want], fake.yg[want]))


@settings(max_examples=10, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    level=st.sampled_from([2, 4]),
    name=st.sampled_from(["ditch", "ridge", "mound"]),
    share=st.floats(0.05, 0.5),
)
def test_the_groups_found_by_parts_are_those_of_all_candidates_at_once(seed, level, name, share):
    fake, flt = _Tiles(seed, level), resolve(name)
    keep = np.random.default_rng(seed).random(len(fake.xg)) < share
    n = int(keep.sum())
    tiles = Candidates(fake.xg[keep], fake.yg[keep], fake.code[keep], np.ones(n, bool), np.zeros(n, bool))
    whole = components(tiles.xg, tiles.yg, tiles.code, flt, level, accept=np.ones(n, bool))
    parted = grouped(tiles, flt, level=level)
    assert sorted(map(tuple, map(sorted, parted))) == sorted(map(tuple, map(sorted, whole)))
    crossing = [g for g in whole if len(np.unique(tiles.xg[g] // part_side(level))) > 1]
    assert crossing or share < 0.2  # groups run across the parts' edges


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    corner=st.tuples(st.floats(0, 120), st.floats(0, 120)),
    size=st.tuples(st.floats(60, 180), st.floats(60, 180)),
    part=st.sampled_from([256, 512]),
    nodes=st.sampled_from([1000, 2_000_000]),
    level=st.sampled_from([2, 4]),
)
def test_any_box_and_any_parts_give_the_matches_of_the_box_read_at_once(db, corner, size, part, nodes, level):
    x0, y0 = np.asarray(db.version("v").stats.bounds[:2]) + corner
    bbox = (float(x0), float(y0), float(x0 + size[0]), float(y0 + size[1]))
    whole = find(db, "v", "ditch", level=level, bbox=bbox)
    with _in_parts(part, nodes):
        assert _key(find(db, "v", "ditch", level=level, bbox=bbox, workers=1)) == _key(whole)


def test_parts_are_listed_only_where_the_version_holds_tiles(db):
    x0, y0, x1, y1 = db.version("far").stats.bounds
    side = part_side(2)
    box_parts = int(np.ceil(x1 / side) - np.floor(x0 / side)) * int(np.ceil(y1 / side) - np.floor(y0 / side))
    parts = part_boxes(db, "far", level=2)
    assert 2 <= len(parts) < box_parts
    xg, yg, _ = db.tiles("far", level=2)
    for px0, py0, px1, py1 in parts:  # every part holds tiles
        assert np.any((xg >= px0) & (xg < px1) & (yg >= py0) & (yg < py1))


def test_a_whole_version_query_over_a_wide_box_runs_by_parts(db):
    with _in_parts(1024, nodes=4_000_000):  # the box between the patches is over the lattice read at once
        parted = run(db, "SELECT ditch FROM far")
    whole = run(db, "SELECT ditch FROM far")
    assert parted and sorted(map(str, parted)) == sorted(map(str, whole))
    xs = [f["geometry"]["coordinates"][0][0] for f in parted if f["geometry"]["type"] == "LineString"]
    x0 = db.version("far").stats.bounds[0]
    assert min(xs) < x0 + 200 < x0 + GAP < max(xs)  # both patches answered


def test_a_size_class_query_by_parts_measures_the_cross_sections_of_the_query_at_once(db):
    query = "SELECT ditch FROM v WHERE depth >= 0.3 AND width >= 1.0"
    whole = run(db, query)
    assert whole
    lines = [m.geometry for m in find(db, "v", "ditch")]
    with _in_parts(128, nodes=1000):
        batches = list(line_batches(shapely.bounds(lines), level=2, grow=8.0))
        parted = run(db, query)
    assert len(batches) >= 2  # the lines' points read part by part
    assert sorted(np.concatenate([idx for idx, _ in batches]).tolist()) == list(range(len(lines)))
    for idx, (x0, y0, x1, y1) in batches:  # each batch's box holds its lines and their sides
        held = shapely.box(x0 + 8.0, y0 + 8.0, x1 - 8.0, y1 - 8.0).buffer(1e-6)
        assert all(held.contains(lines[k]) for k in idx)
    assert sorted(map(str, parted)) == sorted(map(str, whole))
