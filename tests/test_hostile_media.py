"""A database on a read-only filesystem and on a full disk (issue 29), on tmpfs mounts the tests
make themselves; skipped cleanly where mounting is not allowed (not root, or no privilege)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

import tdb
from tdb.cli import main
from tests.conftest import digest, two_surveys

BOX = "500000,5500000,500060,5500060"


def _mount(point: Path, size: str) -> None:
    point.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(point)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({done.stderr.decode().strip() or 'not permitted'})")


def _umount(point: Path) -> None:
    subprocess.run(["umount", "-l", str(point)], capture_output=True)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A database of two versions and a survey, on ordinary disk, to copy onto the mounts."""
    if shutil.which("mount") is None:
        pytest.skip("no mount command")
    root = two_surveys(tmp_path_factory.mktemp("media"), seed=6, density=2)
    return root


@pytest.fixture
def read_only(built, tmp_path):
    point = tmp_path / "ro"
    _mount(point, "64m")
    try:
        shutil.copy(built / "park.tdb", point / "park.tdb")
        done = subprocess.run(["mount", "-o", "remount,ro", str(point)], capture_output=True)
        if done.returncode != 0:
            pytest.skip("cannot remount read-only here")
        yield point
    finally:
        _umount(point)


def test_reading_commands_work_on_a_read_only_filesystem(read_only, tmp_path):
    db = str(read_only / "park.tdb")
    before = digest(read_only / "park.tdb")
    for args in (
        ["info", db],
        ["query", "SELECT ditch FROM a", "--db", db, "--out", str(tmp_path / "d.geojson")],
        [
            "aoi",
            "--db",
            db,
            "--version",
            "a",
            "--bbox",
            "500000,5500000,500060,5500060",
            "--out",
            str(tmp_path / "a"),
        ],
        ["diff", "a", "b", "--db", db, "--out", str(tmp_path / "c.geojson")],
        ["check", db],
    ):
        r = CliRunner().invoke(main, args)
        assert r.exit_code == 0, (args, r.output)
        assert "Traceback" not in r.output
    assert digest(read_only / "park.tdb") == before
    assert sorted(p.name for p in read_only.iterdir()) == ["park.tdb"]  # no -wal, no -shm


def test_a_write_to_a_read_only_filesystem_is_one_line_and_changes_nothing(read_only, built):
    db = read_only / "park.tdb"
    before = digest(db)
    for args in (
        ["ingest", str(built / "s.laz"), "--db", str(db), "--version", "c"],
        ["rm", "a", "--db", str(db)],
        ["rename", "a", "z", "--db", str(db)],
    ):
        r = CliRunner().invoke(main, args)
        assert r.exit_code != 0 and "Traceback" not in r.output, (args, r.output)
        errors = [line for line in r.output.splitlines() if line.startswith("tdb: error:")]
        assert len(errors) == 1, r.output
    assert digest(db) == before


@pytest.fixture
def full_disk(built, tmp_path):
    point = tmp_path / "full"
    size = (built / "park.tdb").stat().st_size + 64 * 1024
    _mount(point, f"{size // 1024}k")
    try:
        shutil.copy(built / "park.tdb", point / "park.tdb")
        yield point
    finally:
        _umount(point)


def test_an_ingest_onto_a_full_disk_fails_in_one_line_and_leaves_the_database_as_it_was(full_disk, built):
    db = full_disk / "park.tdb"
    before = digest(db)
    r = CliRunner().invoke(main, ["ingest", str(built / "s.laz"), "--db", str(db), "--version", "c"])
    assert r.exit_code != 0 and "Traceback" not in r.output, r.output
    assert len([line for line in r.output.splitlines() if line.startswith("tdb: error:")]) == 1, r.output
    assert [v.name for v in tdb.open(db, readonly=True).versions()] == ["a", "b"]
    assert digest(db) == before
    # no journal keeps the disk full (SQLite's shared-memory index is a fixed 32 KiB)
    wal = full_disk / "park.tdb-wal"
    assert not wal.exists() or wal.stat().st_size == 0
    assert {p.name for p in full_disk.iterdir()} <= {"park.tdb", "park.tdb-wal", "park.tdb-shm"}


def test_an_output_onto_a_full_disk_fails_in_one_line_and_leaves_no_part(full_disk):
    db = full_disk / "park.tdb"
    filler = full_disk / "filler"
    with filler.open("wb", buffering=0) as f:  # what room the database left
        try:
            while True:
                f.write(b"\0" * 4096)
        except OSError:
            pass
    r = CliRunner().invoke(
        main,
        [
            "aoi",
            "--db",
            str(db),
            "--version",
            "a",
            "--bbox",
            "500000,5500000,500060,5500060",
            "--out",
            str(full_disk / "a"),
        ],
    )
    assert r.exit_code != 0 and "Traceback" not in r.output, r.output
    assert len([line for line in r.output.splitlines() if line.startswith("tdb: error:")]) == 1, r.output
    # no part of the outputs left (a reader's empty journal may stay where no room is left to close it)
    assert {p.name for p in full_disk.iterdir()} <= {"filler", "park.tdb", "park.tdb-wal", "park.tdb-shm"}
    wal = full_disk / "park.tdb-wal"
    assert not wal.exists() or wal.stat().st_size == 0


@pytest.mark.parametrize(
    "args",
    [
        ["query", "SELECT ditch FROM a", "--db", "{db}", "--out", "{ro}/d.geojson"],
        ["query", "SELECT ditch FROM a", "--db", "{db}", "--format", "gpkg", "--out", "{ro}/d.gpkg"],
        ["query", "SELECT ditch FROM a", "--db", "{db}", "--png", "{ro}/d.png"],
        ["diff", "a", "b", "--db", "{db}", "--png", "{ro}/c.png"],
        ["diff", "a", "b", "--db", "{db}", "--dod", "{ro}/c.tif"],
        ["aoi", "--db", "{db}", "--version", "a", "--bbox", BOX, "--out", "{ro}/a"],
        ["ground", "{laz}", "--out", "{ro}/g.laz"],
        ["ground", "{laz}", "--dtm", "{ro}/g.tif"],
        ["synth", "--size", "100", "--density", "1", "--out", "{ro}/s.laz"],
        ["categories", "--atlas", "{ro}/atlas.png"],
    ],
    ids=lambda a: " ".join(a[:2]) + " " + a[-1].rsplit("/", 1)[-1],
)
def test_an_output_into_a_read_only_folder_is_one_line(read_only, built, args):
    argv = [a.format(db=built / "park.tdb", ro=read_only, laz=built / "s.laz") if "{" in a else a for a in args]
    r = CliRunner().invoke(main, argv)
    assert r.exit_code != 0 and "Traceback" not in r.output, r.output
    assert len([line for line in r.output.splitlines() if line.startswith("tdb: error:")]) == 1, r.output
    assert sorted(p.name for p in read_only.iterdir()) == ["park.tdb"]
