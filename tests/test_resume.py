"""A blocked ingest written block by block: a killed run stores nothing and resumes from its
finished blocks; a version written in parts reads as one written whole."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ingest.blocked as blocked
import tdb
from ingest.blocked import Blocking, ingest_blocked
from ingest.spool import Spool
from ingest.synth import make_scene, write_scene
from tdb.errors import ResumeError
from tdb.tiles import LEVELS

CUT = Blocking(block=48.0, buffer=32.0, workers=1)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    path = tmp_path_factory.mktemp("resume") / "small.laz"
    write_scene(path, make_scene(seed=6, size=100), density=2, seed=6)
    return path


def _model_of(db, version):
    tiles = {lv: sorted(zip(*(a.tolist() for a in db.tiles(version, level=lv)))) for lv in LEVELS}
    x, y, z, n = db.points(version, level=2)
    order = np.lexsort((y, x))
    return tiles, np.column_stack([x, y, z, n])[order]


class Killed(Exception):
    pass


def test_a_killed_ingest_stores_nothing_and_resumes_from_its_finished_blocks(small, tmp_path, monkeypatch):
    ref = tdb.open(tmp_path / "ref.tdb", create=True)
    ingest_blocked(small, ref, version="v", blocking=CUT)
    assert not Spool.beside(ref, "v").path.exists()  # removed once stored

    db = tdb.open(tmp_path / "db.tdb", create=True)
    modelled = []
    real = blocked._one_block

    def dies_at_the_fourth(blk, *args, **kw):
        if len(modelled) == 3:
            raise Killed
        modelled.append(blk.core)
        return real(blk, *args, **kw)

    monkeypatch.setattr(blocked, "_one_block", dies_at_the_fourth)
    with pytest.raises(Killed):
        ingest_blocked(small, db, version="v", blocking=CUT)
    assert db.versions() == []  # the database as it was
    spool = Spool.beside(db, "v")
    assert len(spool.finished()) == 3

    modelled.clear()

    def counted(blk, *args, **kw):
        modelled.append(blk.core)
        return real(blk, *args, **kw)

    monkeypatch.setattr(blocked, "_one_block", counted)
    v = ingest_blocked(small, db, version="v", resume=True, blocking=CUT)
    total = v.params["blocks"]
    assert len(modelled) == total - 3  # only the blocks not finished before
    assert not spool.path.exists()
    a, b = _model_of(ref, "v"), _model_of(db, "v")
    assert a[0] == b[0]
    np.testing.assert_array_equal(a[1], b[1])
    assert db.version("v").stats == ref.version("v").stats


def test_a_store_that_fails_part_way_leaves_no_version_and_resumes(small, tmp_path, monkeypatch):
    from tdb.version_writer import VersionWriter

    db = tdb.open(tmp_path / "db.tdb", create=True)
    real = VersionWriter.add
    parts = []

    def fails_at_the_third(self, **kw):
        if len(parts) == 2:
            raise OSError("disk full")
        parts.append(1)
        real(self, **kw)

    monkeypatch.setattr(VersionWriter, "add", fails_at_the_third)
    with pytest.raises(OSError, match="disk full"):
        ingest_blocked(small, db, version="v", blocking=CUT)
    assert db.versions() == []
    with db.engine.connect() as conn:  # no rows of the parts written before the failure
        assert all(conn.exec_driver_sql(f"SELECT count(*) FROM {t}").scalar() == 0 for t in ("c2", "tdb"))
    monkeypatch.setattr(VersionWriter, "add", real)
    modelled = []
    model = blocked._one_block

    def counted(*a, **kw):
        modelled.append(1)
        return model(*a, **kw)

    # blocks are written as they are modelled: the write failed at the third, so the first three
    # were modelled and kept, and a resumed run models only the others
    monkeypatch.setattr(blocked, "_one_block", counted)
    v = ingest_blocked(small, db, version="v", resume=True, blocking=CUT)
    assert len(modelled) == v.params["blocks"] - 3
    monkeypatch.undo()
    whole = ingest_blocked(small, db, version="in one go", blocking=CUT)
    assert v.stats.reduction.tiles == whole.stats.reduction.tiles
    assert _model_of(db, "v")[0] == _model_of(db, "in one go")[0]


def test_resume_says_why_it_cannot(small, tmp_path, monkeypatch):
    db = tdb.open(tmp_path / "db.tdb", create=True)
    with pytest.raises(ResumeError, match="no unfinished ingest"):
        ingest_blocked(small, db, version="v", resume=True, blocking=CUT)

    def dies(*a, **kw):
        raise Killed

    monkeypatch.setattr(blocked, "_one_block", dies)
    with pytest.raises(Killed):
        ingest_blocked(small, db, version="v", blocking=CUT)
    with pytest.raises(ResumeError, match="blocks differ"):
        ingest_blocked(small, db, version="v", resume=True, blocking=Blocking(block=64.0, buffer=32.0, workers=1))
    from ingest.pipeline import IngestOptions

    with pytest.raises(ResumeError, match="options differ"):
        ingest_blocked(small, db, version="v", resume=True, options=IngestOptions(objects=False), blocking=CUT)
    assert db.versions() == []


@settings(max_examples=15, deadline=None)
@given(cut=st.floats(-300, 2300), seed=st.integers(0, 1000))
def test_a_version_written_in_parts_reads_as_one_written_whole(tmp_path_factory, cut, seed):
    """Pages wider than a part (the 16 m level's are 2048 m) are merged with what earlier parts wrote."""
    rng = np.random.default_rng(seed)
    levels = {}
    for level in LEVELS:
        k = np.arange((2048 // level) ** 2, dtype=np.int64)
        side = 2048 // level
        keep = rng.random(len(k)) < min(0.7, 3000 / len(k))  # pages of every level, few rows
        code = rng.integers(0, 115, keep.sum()).astype(np.uint8)
        levels[level] = ((k % side)[keep] * level - 256, (k // side)[keep] * level, code)
    m = 3000
    points = (
        rng.uniform(-256, 1792, m),
        rng.uniform(0, 2048, m),
        rng.normal(100, 5, m),
        rng.integers(1, 16, m).astype(np.uint8),
    )
    db = tdb.open(tmp_path_factory.mktemp("parts") / "p.tdb", create=True)
    db.write_version("whole", levels=levels, points=points)
    with db.writing("parts") as w:
        for side in (np.less, np.greater_equal):
            w.add(
                levels={lv: tuple(a[side(t[0], cut)] for a in t) for lv, t in levels.items()},
                points=tuple(a[side(points[0], cut)] for a in points),
            )
        w.describe(params={}, stats={})
    box = (-300.0, -10.0, 1800.0, 2100.0)
    for level in LEVELS:
        a, b = db.aoi(box, level=level, version="whole"), db.aoi(box, level=level, version="parts")
        ka = sorted(zip(a.xg.tolist(), a.yg.tolist(), a.code.tolist()))
        kb = sorted(zip(b.xg.tolist(), b.yg.tolist(), b.code.tolist()))
        assert ka == kb, level
        pa = sorted(zip(a.x.tolist(), a.y.tolist(), a.z.tolist()))
        assert pa == sorted(zip(b.x.tolist(), b.y.tolist(), b.z.tolist()))
