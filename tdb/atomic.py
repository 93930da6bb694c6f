"""The one way tdb writes a file: next to its destination, then moved into place.

A failure or an interruption part way leaves the destination as it was (absent, or the old
file) and no partial file beside it; a write that cannot be done is a :class:`TdbIOError`.
No output replaces a terrain database: a map or a GeoPackage written onto one is refused.
"""

from __future__ import annotations

import os
import sqlite3
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tdb.errors import InputError, TdbError, TdbIOError

PNG = (".png",)
GEOTIFF = (".tif", ".tiff")
GEOPACKAGE = (".gpkg",)
POINTS = (".las", ".laz")


def check_destination(path: str | os.PathLike[str], suffixes: tuple[str, ...] = (), *, what: str) -> Path:
    """``path`` as an output ``what`` (a PNG picture, a GeoTIFF, ...) may be written to, checked
    before any work: not a directory, not a terrain database, and named with one of ``suffixes``
    (any name where none are given), since readers (QGIS among them) go by the name.

    Raises
    ------
    TdbIOError
        If ``path`` is a directory or a terrain database.
    InputError
        If its name does not end in one of ``suffixes``.
    """
    target = Path(path)
    if target.is_dir():
        raise TdbIOError(f"{target}: a directory; {what} needs a file name")
    if is_terrain_database(target):
        raise TdbIOError(f"{target}: a terrain database; an output never replaces one")
    if suffixes and target.suffix.lower() not in suffixes:
        raise InputError(f"{target}: {what}'s name ends in {' or '.join(suffixes)}")
    return target


@contextmanager
def atomic_path(path: str | os.PathLike[str], *, errors: tuple[type[BaseException], ...] = ()) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; moved onto ``path`` when the block ends well.

    ``errors``: exception types of the writing library (besides ``OSError``) that mean the file
    cannot be written; they become a :class:`TdbIOError` naming ``path``.
    """
    target = check_destination(path, what="an output")
    try:
        fd, name = tempfile.mkstemp(
            prefix=f".{target.stem}.", suffix=f".part{target.suffix}", dir=target.parent or "."
        )
    except OSError as exc:
        raise TdbIOError(f"{target}: cannot write ({exc.strerror or exc})") from None
    os.close(fd)
    tmp = Path(name)
    failures: tuple[type[BaseException], ...] = (OSError, *errors)
    tmp.unlink()  # writers that refuse to overwrite (GDAL drivers) get a fresh name
    try:
        yield tmp
        os.replace(tmp, target)
    except TdbError:
        tmp.unlink(missing_ok=True)
        raise
    except failures as exc:
        tmp.unlink(missing_ok=True)
        detail = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc).splitlines()[0]
        raise TdbIOError(f"{target}: cannot write ({detail})") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def is_terrain_database(path: Path) -> bool:
    """Whether ``path`` is an SQLite file holding tdb's ``meta`` and ``versions`` tables (read only)."""
    from tdb.database import is_database

    if not is_database(path):
        return False
    try:
        con = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
        try:
            names = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            con.close()
    except (OSError, sqlite3.Error):
        return False
    return {"meta", "versions"} <= names


def write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    write_bytes(path, text.encode("utf-8"))
