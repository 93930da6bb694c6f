"""The finished blocks of a blocked ingest, kept on disk until the version is stored.

Each block's result is written to its own file as the block finishes, so the ingest holds one
block in memory at a time, and a run that is killed or fails can be resumed: the blocks already
finished are read back rather than modelled again. The directory lies beside an SQLite
database (``.NAME.ingest-KEY`` where NAME is the file's name and KEY the version's hash), or in
the temporary directory for a server database, and is removed once the version is committed.

A run is resumed only if it is the same run: the same source files (path, size, modification
time), the same blocks and the same settings, recorded in the directory's ``manifest.json``.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import shutil
import tempfile
from pathlib import Path
from typing import Any

from tdb.atomic import write_bytes, write_text
from tdb.database import Database
from tdb.errors import ResumeError

MANIFEST = "manifest.json"


class Spool:
    """The directory of one ingest's finished blocks (see the module's description)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    @classmethod
    def beside(cls, db: Database, version: str) -> Spool:
        """Where an ingest of ``version`` into ``db`` keeps its finished blocks."""
        url = db.engine.url
        key = hashlib.sha1(f"{url.render_as_string(hide_password=True)}\n{version}".encode()).hexdigest()[:16]
        if url.get_backend_name() == "sqlite" and url.database and url.database != ":memory:":
            file = Path(url.database)
            return cls(file.parent / f".{file.name}.ingest-{key}")
        return cls(Path(tempfile.gettempdir()) / f"tdb-ingest-{key}")

    def start(self, run: dict[str, Any]) -> None:
        """A fresh run described by ``run`` (JSON): what an earlier, unfinished one left is discarded."""
        self.remove()
        self.path.mkdir(parents=True)
        write_text(self.path / MANIFEST, json.dumps({"run": run, "settings": {}}, default=str, sort_keys=True))

    def resume(self, run: dict[str, Any]) -> dict[str, Any]:
        """The settings an unfinished run of ``run`` recorded (:meth:`record`).

        Raises
        ------
        ResumeError
            If no run was left unfinished, or it was another run (other files, blocks or settings).
        """
        manifest = self.path / MANIFEST
        if not manifest.exists():
            raise ResumeError("no unfinished ingest of this version into this database to resume")
        found = json.loads(manifest.read_text())
        wanted = json.loads(json.dumps(run, default=str, sort_keys=True))
        for part in ("source", "blocks", "options"):
            if found["run"].get(part) != wanted.get(part):
                raise ResumeError(f"cannot resume: the {part} differ from the unfinished run's; ingest afresh")
        return dict(found["settings"])

    def record(self, settings: dict[str, Any]) -> None:
        """Keep the settings this run resolved (measured from its points), for a resumed run."""
        manifest = self.path / MANIFEST
        found = json.loads(manifest.read_text())
        found["settings"] = settings
        write_text(manifest, json.dumps(found, default=str, sort_keys=True))

    def put(self, k: int, result: Any) -> None:
        """Keep block ``k``'s result (None for a block that held nothing to model)."""
        write_bytes(self._file(k), pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))

    def get(self, k: int) -> Any:
        # Only files this module wrote, in a directory it made, are read back.
        return pickle.loads(self._file(k).read_bytes())

    def finished(self) -> list[int]:
        """The blocks whose results are kept, in order."""
        return sorted(int(p.stem[5:]) for p in self.path.glob("block*.pkl"))

    def remove(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)

    def _file(self, k: int) -> Path:
        return self.path / f"block{k}.pkl"
