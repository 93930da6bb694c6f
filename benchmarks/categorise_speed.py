"""Categorisation speed (tiles/s, one core) and agreement of the fast search with full L1."""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import DATA, save
from ingest.categorise import categorise
from tdb.categories import templates


def main() -> None:
    rng = np.random.default_rng(0)
    n = 2_000_000
    t = templates(5)
    truth = rng.integers(1, 115, n)
    tiles = (t[truth] * rng.uniform(0.2, 3.0, (n, 1)) + rng.normal(0, 0.03, (n, 25))).astype(np.float32)
    categorise(tiles[:1000], flat_threshold=0.15)
    t0 = time.perf_counter()
    codes = categorise(tiles, flat_threshold=0.15)
    synthetic = n / (time.perf_counter() - t0)
    sub = slice(0, 200_000)
    exact = categorise(tiles[sub], flat_threshold=0.15, exact=True)
    agree = float((exact == codes[sub]).mean())
    # Real tiles: the 2 m tiles of the TTP 2019 dense model.
    real = {}
    path = DATA / "epochs" / "TTP_2019.laz"
    if path.exists():
        from ingest.pipeline import survey
        from ingest.readers import read
        from ingest.tiles import node_grid

        s = survey(read(path))
        tl, _, _ = node_grid(s.dtm, 2).tiles(5)
        tl = tl[~np.isnan(tl).any(axis=1)]
        reps = max(1, 2_000_000 // len(tl))
        big = np.tile(tl, (reps, 1))
        t0 = time.perf_counter()
        rc = categorise(big, flat_threshold=s.flat_threshold)
        real = {
            "tiles": len(big),
            "tiles_per_s": len(big) / (time.perf_counter() - t0),
            "flat_share": float((rc == 0).mean()),
            "agree_with_full_l1": float(
                (categorise(tl, flat_threshold=s.flat_threshold, exact=True) == rc[: len(tl)]).mean()
            ),
        }
    doc = {
        "synthetic_non_flat": {
            "tiles": n,
            "tiles_per_s": synthetic,
            "agree_with_full_l1": agree,
            "self_match": float((codes == truth).mean()),
        },
        "ttp2019_2m_tiles": real,
    }
    print(doc)
    print(save("categorise_speed", doc))


if __name__ == "__main__":
    main()
