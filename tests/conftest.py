"""Shared fixtures: paths to the real data (skipped where absent) and small scenes."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

# CI draws the same examples on every run, so that a red build can be reproduced and a rare draw
# cannot turn a landing red; local runs keep drawing new examples, which is how bugs are found.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def data_file(*parts: str) -> Path:
    """A file under ../shared/data, or a clean skip where the data is not present."""
    path = DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"real data not present: {path}")
    return path


@pytest.fixture(scope="session")
def small_scene():
    from ingest.synth import make_scene

    return make_scene(seed=11, size=120)


@pytest.fixture(scope="session")
def small_cloud(small_scene):
    from ingest.synth import sample

    return sample(small_scene, density=3.0, seed=11)


def two_surveys(root: Path, *, seed: int, density: float) -> Path:
    """``root/s.laz``, a 100 m synthetic survey, and ``root/park.tdb`` holding two surveys of its
    scene (versions a and b); returns ``root``."""
    import tdb
    from ingest.pipeline import ingest
    from ingest.synth import make_scene, sample
    from ingest.synth.writer import write_scene

    scene = make_scene(seed=seed, size=100)
    write_scene(root / "s.laz", scene, density=density, seed=seed)
    db = tdb.open(root / "park.tdb", create=True)
    ingest(sample(scene, density=density, seed=seed), db, version="a")
    ingest(sample(scene, density=density, seed=seed + 1), db, version="b")
    db.close()
    return root


def digest(path: Path) -> str:
    """The SHA-256 of a file's bytes: to show it was left as it was."""
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def two_patches(cloud: Any, gap: float) -> Any:
    """``cloud`` and a copy of it ``gap`` m to the north-east, as one cloud: few points over a
    wide box, as a corridor survey or two sites in one file spread them."""
    import dataclasses

    import numpy as np

    def twice(a: Any) -> Any:
        return np.r_[a, a]

    return dataclasses.replace(
        cloud,
        xyz=np.r_[cloud.xyz, cloud.xyz + np.array([gap, gap, 0.0])],
        classification=twice(cloud.classification),
        return_number=twice(cloud.return_number),
        number_of_returns=twice(cloud.number_of_returns),
        intensity=None,
    )
