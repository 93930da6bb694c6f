"""``make demo``: the main job end to end on a bundled synthetic scene.

Run as ``python -m tdb.demo --out out``. Each step prints what it made and where.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def step(title: str) -> float:
    print(f"\n== {title}")
    return time.perf_counter()


def done(t0: float, what: str) -> None:
    print(f"   {what}  ({time.perf_counter() - t0:.1f} s)")


def run(out: Path, *, seed: int = 7, size: float = 400.0, density: float = 4.0) -> None:
    from ingest.readers import read
    from ingest.summary import format_summary, summarize
    from ingest.synth import apply_changes, changes_truth, make_scene, scene_truth, write_scene
    from ingest.synth.truth import write_json

    out.mkdir(parents=True, exist_ok=True)
    t = step(f"synthetic scene: {size:.0f} m square, {density} pulses/m², seed {seed}")
    scene = make_scene(seed=seed, size=size)
    n1 = write_scene(out / "survey_2020.laz", scene, density=density, seed=seed)
    write_json(out / "truth.geojson", scene_truth(scene))
    later, changes = apply_changes(scene, seed=seed)
    n2 = write_scene(out / "survey_2024.laz", later, density=density, seed=seed + 1)
    write_json(out / "changes.geojson", changes_truth(changes, scene.crs))
    done(
        t,
        f"{out / 'survey_2020.laz'} ({n1:,} points), {out / 'survey_2024.laz'} ({n2:,} points), "
        f"truth.geojson, changes.geojson",
    )

    t = step("what the first survey holds (tdb info)")
    print("   " + format_summary(summarize(read(out / "survey_2020.laz"))).replace("\n", "\n   "))
    done(t, "read back")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("out"), help="folder for everything the demo makes")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    from tdb.errors import TdbError

    try:
        run(args.out, seed=args.seed)
    except TdbError as exc:
        print(f"demo: error: {exc}", file=sys.stderr)
        return 1
    print(f"\nAll outputs are in {args.out.resolve()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
