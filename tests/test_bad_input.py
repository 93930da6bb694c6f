"""Bad values are refused before any work, in one clear line, and nothing is stored."""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner

import tdb
from ingest.pipeline import IngestOptions, ingest
from tdb.cli import main
from tdb.errors import InputError, VersionExistsError
from tests.conftest import two_patches


@pytest.mark.parametrize("resolution", [3.0, 0.3, 0.0, -0.5, math.nan, math.inf, 0.7])
def test_a_resolution_off_the_node_lattice_is_refused(resolution):
    with pytest.raises(InputError, match="resolution"):
        IngestOptions(resolution=resolution)


@pytest.mark.parametrize("resolution", [0.5, 0.25, 0.125])
def test_resolutions_that_divide_the_node_spacing_are_taken(resolution):
    assert IngestOptions(resolution=resolution).resolution == resolution


@pytest.mark.parametrize("threshold", [-1.0, math.nan, math.inf])
def test_a_flat_threshold_must_be_a_height_range(threshold):
    with pytest.raises(InputError, match="flat threshold"):
        IngestOptions(flat_threshold=threshold)


@pytest.mark.parametrize("name", ["", "   ", "a\nb", "tab\there", "x" * 201, "\x00"])
def test_a_version_name_must_be_visible_text(tmp_path, small_cloud, name):
    db = tdb.open(tmp_path / "n.tdb", create=True)
    with pytest.raises(InputError, match="name"):
        ingest(small_cloud, db, version=name)
    assert db.versions() == []


def test_the_command_line_says_it_in_one_line_and_stores_nothing(tmp_path, small_cloud):
    from ingest.synth import make_scene
    from ingest.synth.writer import write_scene

    path = tmp_path / "s.laz"
    write_scene(path, make_scene(seed=2, size=100), density=1, seed=2)
    db_path = tmp_path / "c.tdb"
    for args in (
        ["ingest", str(path), "--db", str(db_path), "--version", " "],
        ["ingest", str(path), "--db", str(db_path), "--version", "v", "--resolution", "3"],
        ["ingest", str(path), "--db", str(db_path), "--version", "v", "--flat-threshold", "nan"],
    ):
        r = CliRunner().invoke(main, args)
        assert r.exit_code != 0
        lines = [line for line in r.output.splitlines() if line.strip()]
        assert lines and lines[-1].startswith("tdb: error:") and "Traceback" not in r.output, r.output
    assert not db_path.exists() or tdb.open(db_path).versions() == []


def test_an_ingest_of_a_name_another_ingest_took_meanwhile_says_so(tmp_path, small_cloud, monkeypatch):
    """The name is checked before the work and again in the writing transaction: an ingest of the
    same name that committed in between is a VersionExistsError, not a raw constraint error."""
    db = tdb.open(tmp_path / "r.tdb", create=True)
    ingest(small_cloud, db, version="v")
    monkeypatch.setattr(tdb.database.Database, "versions", lambda self: [])  # the first check misses it
    with pytest.raises(VersionExistsError):
        ingest(small_cloud, db, version="v")


def test_info_as_json_holds_no_nan(tmp_path, small_cloud):
    """A version whose figures hold a NaN (a noise that could not be measured) is valid JSON."""
    import dataclasses
    import json

    db = tdb.open(tmp_path / "j.tdb", create=True)
    v = ingest(small_cloud, db, version="v")
    stats = dataclasses.replace(v.stats, noise_m=math.nan)
    with db.engine.begin() as conn:
        from tdb import schema

        conn.execute(schema.versions.update().values(stats=json.dumps(stats.to_json())))
    db.close()
    r = CliRunner().invoke(main, ["info", str(tmp_path / "j.tdb"), "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.output, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert doc["versions"][0]["stats"]["noise_m"] is None


def test_an_extent_the_machine_cannot_hold_whole_is_refused_before_any_work(tmp_path, small_cloud, monkeypatch):
    """Two patches 5 km apart, on a machine of 1 GiB: a whole model's grids would span the box
    between them (about 11 GiB), so it is refused at once, and nothing is stored, rather than the
    process being killed by the system once the memory is gone."""
    from ingest import block_size
    from ingest.objects import survey_objects
    from tdb.errors import Remedy

    monkeypatch.setattr(block_size, "physical_bytes", lambda: 2**30)
    wide = two_patches(small_cloud, 5_000.0)
    db = tdb.open(tmp_path / "w.tdb", create=True)
    with pytest.raises(InputError, match="block by block") as info:
        ingest(wide, db, version="v")
    assert info.value.remedy is Remedy.BLOCKS
    assert db.versions() == []
    # trees and point classes (tdb trees, tdb classify) need the dense model over the extent too
    with pytest.raises(InputError, match="block by block") as info:
        survey_objects(wide)
    assert info.value.remedy is Remedy.BLOCKS


def test_the_ground_of_an_extent_too_wide_to_filter_whole_is_found_block_by_block(small_cloud, monkeypatch):
    """Where the filter's grids over the extent would not fit, the points are filtered block by
    block, as a blocked ingest filters them: the ground found whole, but for a few points."""
    import numpy as np

    from ingest import block_lattice, block_size
    from ingest.ground import classify_ground

    wide = two_patches(small_cloud, 700.0)
    whole = classify_ground(wide)
    cut = []
    monkeypatch.setattr(block_lattice, "block_side", lambda *a, **k: (cut.append(1), 128.0)[1])
    monkeypatch.setattr(block_size, "physical_bytes", lambda: 2**25)  # 32 MiB: the 0.8 km² box does not fit
    blocks = classify_ground(wide)
    assert cut  # it went block by block
    assert np.mean(blocks == whole) >= 0.995
    assert blocks.sum() == pytest.approx(whole.sum(), rel=0.01)
    # the provider's own classes need no grid
    assert (classify_ground(wide, method="classified") == (wide.classification == 2)).all()


def test_the_ground_command_filters_a_wide_extent_block_by_block(tmp_path, small_cloud, monkeypatch):
    from ingest import block_size
    from ingest.readers import read, write_las

    monkeypatch.setattr(block_size, "physical_bytes", lambda: 2**30)
    src = tmp_path / "wide.laz"
    write_las(src, two_patches(small_cloud, 5_000.0))
    r = CliRunner().invoke(main, ["ground", str(src), "--out", str(tmp_path / "g.laz")])
    assert r.exit_code == 0, r.output
    out = read(tmp_path / "g.laz")
    assert len(out) == 2 * len(small_cloud) and (out.classification == 2).mean() > 0.3
