"""Point-cloud input: LAS/LAZ, text, arrays, and every kind of bad input."""

from __future__ import annotations

import numpy as np
import pytest

from ingest.readers import read, write_las
from tdb.cloud import from_arrays
from tdb.errors import DegenerateInputError, FormatError, InputError, TdbError, TdbIOError


def _cloud(n=200, seed=0):
    rng = np.random.default_rng(seed)
    return from_arrays(
        rng.uniform(0, 50, n),
        rng.uniform(0, 50, n),
        rng.normal(100, 1, n),
        classification=rng.choice([1, 2], n),
        crs="EPSG:25832",
    )


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_las_round_trip(tmp_path, suffix):
    cloud = _cloud()
    path = tmp_path / f"c{suffix}"
    write_las(path, cloud)
    back = read(path)
    assert len(back) == len(cloud)
    np.testing.assert_allclose(back.xyz, cloud.xyz, atol=1e-3)
    np.testing.assert_array_equal(back.classification, cloud.classification)
    assert back.crs.to_epsg() == 25832


def test_las_chunked_reading_matches_whole(tmp_path):
    cloud = _cloud(1000)
    write_las(tmp_path / "c.laz", cloud)
    a = read(tmp_path / "c.laz", chunk_size=97)
    b = read(tmp_path / "c.laz", chunk_size=10_000)
    np.testing.assert_array_equal(a.xyz, b.xyz)


def test_text_isprs_labels(tmp_path):
    path = tmp_path / "samp.txt"
    path.write_text("0 0 10 0\n10 0 11 1\n0 10 12 0\n5 5 20 1\n")
    cloud = read(path, labels="isprs")
    assert cloud.classification.tolist() == [2, 1, 2, 1]
    assert read(path).classification.tolist() == [0, 1, 0, 1]


def test_text_three_columns(tmp_path):
    path = tmp_path / "p.xyz"
    path.write_text("0,0,1\n1,0,2\n0,1,3\n")
    assert read(path).z.tolist() == [1, 2, 3]


def test_all_errors_are_tdb_errors():
    for err in (FormatError, InputError, DegenerateInputError, TdbIOError):
        assert issubclass(err, TdbError)
    assert issubclass(TdbIOError, OSError) and issubclass(FormatError, ValueError)


def test_missing_file(tmp_path):
    with pytest.raises(TdbIOError, match="no such file"):
        read(tmp_path / "nope.laz")


def test_directory_is_not_a_file(tmp_path):
    with pytest.raises(TdbIOError, match="not a file"):
        read(tmp_path)


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_truncated_las(tmp_path, suffix):
    path = tmp_path / f"c{suffix}"
    write_las(path, _cloud(5000))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(FormatError):
        read(path)


@pytest.mark.parametrize("name", ["survey.laz", "SURVEY.LAS"])
def test_a_las_name_without_the_signature_is_no_las_file(tmp_path, name):
    """A damaged download or a renamed table: said so, not read as a table of numbers."""
    path = tmp_path / name
    path.write_text("500000 5500000 10\n500001 5500000 11\n500000 5500001 12\n")
    with pytest.raises(FormatError, match=r"not a LAS/LAZ file.*LASF"):
        read(path)


def test_corrupt_las_header(tmp_path):
    path = tmp_path / "bad.las"
    path.write_bytes(b"LASF" + b"\xff" * 300)
    with pytest.raises(FormatError):
        read(path)


def test_corrupt_laz_body(tmp_path):
    path = tmp_path / "c.laz"
    write_las(path, _cloud(5000))
    data = bytearray(path.read_bytes())
    start = len(data) // 2
    data[start : start + 2000] = bytes(np.random.default_rng(1).integers(0, 256, 2000, dtype=np.uint8))
    path.write_bytes(bytes(data))
    with pytest.raises(TdbError):
        read(path)


def test_zero_points_las(tmp_path):
    path = tmp_path / "empty.las"
    import laspy

    laspy.LasData(laspy.LasHeader(point_format=6, version="1.4")).write(str(path))
    with pytest.raises(InputError, match="no points"):
        read(path)


def test_zero_points_text(tmp_path):
    path = tmp_path / "empty.txt"
    path.write_text("# nothing here\n")
    with pytest.raises(InputError, match="no points"):
        read(path)


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_non_finite_coordinates(tmp_path, bad):
    path = tmp_path / "p.txt"
    path.write_text(f"0 0 1\n1 0 2\n0 1 3\n2 2 {bad}\n")
    with pytest.raises(InputError, match="NaN or infinite"):
        read(path)


@pytest.mark.parametrize("row", ["1 2", "1 2 3 4 5"])
def test_wrong_column_count(tmp_path, row):
    path = tmp_path / "p.txt"
    path.write_text("\n".join([row] * 4))
    with pytest.raises(FormatError, match="columns"):
        read(path)


def test_ragged_text(tmp_path):
    path = tmp_path / "p.txt"
    path.write_text("0 0 1\n1 0\n")
    with pytest.raises(FormatError):
        read(path)


def test_binary_garbage_is_not_text(tmp_path):
    path = tmp_path / "p.bin"
    path.write_bytes(b"\x00\x01\x02garbage")
    with pytest.raises(FormatError, match="binary"):
        read(path)


def test_identical_points():
    with pytest.raises(DegenerateInputError, match="same position"):
        from_arrays(np.ones(10), np.ones(10), np.arange(10.0))


def test_collinear_points():
    t = np.linspace(0, 100, 50)
    with pytest.raises(DegenerateInputError, match="one line"):
        from_arrays(3 * t + 5, -2 * t, np.zeros(50))


def test_too_few_points():
    with pytest.raises(DegenerateInputError, match="at least 3"):
        from_arrays([0.0, 1.0], [0.0, 1.0], [0.0, 0.0])


def test_mismatched_arrays():
    with pytest.raises(InputError):
        from_arrays(np.zeros(3), np.zeros(4), np.zeros(3))
