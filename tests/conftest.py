"""Shared fixtures: paths to the real data (skipped where absent) and small scenes."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
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


def thicket(rng: Any, *, cover: str, density: float = 1.0) -> Any:
    """80 m of ground sloping 2 % at ``density`` pulses/m² whose middle 30 m square stands 0.8 m
    higher in what was taken for ground (class 2): left bare (``cover`` "bare", a fill), or under
    crowns (``cover`` "crowns") that stop seven pulses in ten, the rest ending on the
    understorey's top; "none": no higher."""
    from tdb.cloud import from_arrays

    x, y = rng.uniform(0, 80, (2, int(80 * 80 * density))) + np.array([[500_000.0], [6_000_000.0]])
    z = 50 + 0.02 * (x - 500_000) + rng.normal(0, 0.03, len(x))
    on = (np.abs(x - 500_040) < 15) & (np.abs(y - 6_000_040) < 15) & (cover != "none")
    z[on] += 0.8
    cls = np.full(len(x), 2, np.uint8)
    if cover == "crowns":
        crown = on & (rng.random(len(x)) < 0.7)
        z[crown] += rng.uniform(3, 8, crown.sum())
        cls[crown] = 5
    return from_arrays(x, y, z, classification=cls, crs="EPSG:25832")
