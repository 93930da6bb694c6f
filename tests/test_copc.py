"""COPC files: boxes read by range, and a region of a survey ingested from its points alone."""

from __future__ import annotations

import laspy
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.blocked import Blocking, ingest_blocked
from ingest.pipeline import IngestOptions
from ingest.readers import in_box, read, read_box
from ingest.synth import make_scene, sample
from tdb.cli import main
from tdb.errors import InputError

pytest.importorskip("copclib", reason="copclib writes the COPC files these tests read")

from tests.copc_files import write_copc


@pytest.fixture(scope="module")
def copc_file(tmp_path_factory):
    cloud = sample(make_scene(seed=3, size=200), density=3, seed=3)
    return write_copc(tmp_path_factory.mktemp("copc") / "s.copc.laz", cloud)


def _rows(cloud):
    return {tuple(r) for r in np.round(cloud.xyz, 3).tolist()}


@settings(max_examples=15, deadline=None)
@given(
    x=st.floats(-20, 200),
    y=st.floats(-20, 200),
    w=st.floats(0.5, 150),
    h=st.floats(0.5, 150),
)
def test_a_box_read_by_range_holds_the_points_a_full_scan_finds(copc_file, x, y, w, h):
    whole = read(copc_file)
    # Off the file's 1 cm lattice: a point on an edge may decode a rounding either side of it.
    x0, y0 = whole.xyz[:, 0].min() + x + 0.0005, whole.xyz[:, 1].min() + y + 0.0005
    box = (x0, y0, x0 + round(w, 2), y0 + round(h, 2))
    rec = np.zeros(len(whole.xyz), [("x", "f8"), ("y", "f8")])
    rec["x"], rec["y"] = whole.xyz[:, 0], whole.xyz[:, 1]
    want = whole.xyz[in_box(rec, box)]
    got = read_box(copc_file, box)
    assert _rows(got) == {tuple(r) for r in np.round(want, 3).tolist()}
    assert len(got.xyz) == len(want)


def test_a_box_of_a_copc_file_is_not_read_by_scanning_it(copc_file, monkeypatch):
    def refuse(*_a, **_k):
        raise AssertionError("the whole file was scanned")

    monkeypatch.setattr(laspy.LasReader, "chunk_iterator", refuse)
    whole_xy = laspy.CopcReader.open(copc_file).header.mins
    box = (whole_xy[0] + 10, whole_xy[1] + 10, whole_xy[0] + 40, whole_xy[1] + 30)
    got = read_box(copc_file, box)
    assert len(got.xyz) > 0
    assert (got.xyz[:, 0] >= box[0]).all() and (got.xyz[:, 0] <= box[2]).all()


@pytest.mark.slow
def test_a_region_is_the_same_model_as_that_part_of_the_whole(copc_file, tmp_path):
    db = tdb.open(tmp_path / "r.tdb", create=True)
    whole = ingest_blocked(copc_file, db, version="whole", blocking=Blocking(block=96, workers=1))
    x0, y0, _, _ = whole.stats.bounds
    region = (x0 + 40.0, y0 + 50.0, x0 + 130.0, y0 + 120.0)
    options = IngestOptions(flat_threshold=whole.params["flat_threshold"], density=whole.params["density"])
    part = ingest_blocked(
        copc_file, db, version="part", options=options, blocking=Blocking(block=96, workers=1, region=region)
    )
    bx0, by0, bx1, by1 = part.stats.bounds
    assert bx0 <= region[0] and by0 <= region[1] and bx1 >= region[2] and by1 >= region[3]
    assert bx0 > region[0] - 16 and by1 < region[3] + 16  # widened to whole 16 m tiles only
    xg, yg, code = db.tiles("part", level=2)
    assert (xg >= bx0).all() and (xg + 2 <= bx1).all() and (yg >= by0).all() and (yg + 2 <= by1).all()
    wx, wy, wcode = db.tiles("whole", level=2)
    ref = dict(zip(zip(wx.tolist(), wy.tolist()), wcode.tolist()))
    same = np.mean([ref.get(k) == c for k, c in zip(zip(xg.tolist(), yg.tolist()), code.tolist())])
    assert same >= 0.99


def test_a_region_away_from_the_survey_is_one_clear_error(copc_file, tmp_path):
    db = tdb.open(tmp_path / "r.tdb", create=True)
    with pytest.raises(InputError, match="does not meet the survey"):
        ingest_blocked(copc_file, db, version="v", blocking=Blocking(region=(0.0, 0.0, 10.0, 10.0)))
    assert db.versions() == []


def test_the_command_line_ingests_a_region(copc_file, tmp_path):
    lo = laspy.CopcReader.open(copc_file).header.mins
    bbox = f"{lo[0] + 20},{lo[1] + 20},{lo[0] + 84},{lo[1] + 68}"
    out = CliRunner().invoke(
        main, ["ingest", str(copc_file), "--db", str(tmp_path / "c.tdb"), "--version", "v", "--bbox", bbox]
    )
    assert out.exit_code == 0, out.output
    v = tdb.open(tmp_path / "c.tdb").version("v")
    assert v.stats.bounds[2] - v.stats.bounds[0] <= 64 + 32


def test_a_classified_copy_of_a_copc_file_is_a_plain_laz_of_the_same_points(copc_file, tmp_path):
    from ingest.readers import is_copc, write_classified

    cloud = read(copc_file)
    classes = np.where(np.arange(len(cloud)) % 2 == 0, 2, 5).astype(np.uint8)
    out = tmp_path / "classified.laz"
    write_classified(out, cloud, classes)
    with laspy.open(out) as reader:
        assert not is_copc(reader.header)  # its index would point at pages the copy moved
    back = read(out)
    assert np.array_equal(back.xyz, cloud.xyz) and np.array_equal(back.classification, classes)
