"""Ground filter accuracy on the ten ISPRS reference samples, all methods in one run.

python -m benchmarks.ground_isprs [--methods "tdb auto,pysmrf"] [--out docs/ground_isprs.json]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks.common import save
from benchmarks.ground_methods import methods
from ingest.ground.evaluate import accuracy
from ingest.readers import read

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "isprs"
SAMPLES = ["11", "21", "22", "24", "31", "41", "51", "52", "54", "61"]


def run(names: list[str]) -> dict[str, dict[str, dict[str, float]]]:
    table: dict[str, dict[str, dict[str, float]]] = {}
    available = methods()
    for name in names:
        table[name] = {}
        for s in SAMPLES:
            cloud = read(DATA / f"samp{s}-utm.laz")
            t0 = time.perf_counter()
            ground = available[name](cloud.xyz)
            row = accuracy(cloud.classification == 2, ground).as_dict()
            row["seconds"] = time.perf_counter() - t0
            table[name][s] = row
            print(f"{name:12s} samp{s}: total {row['total']:6.2f} %  kappa {row['kappa']:6.1f} %", flush=True)
        keys = ("type1", "type2", "total", "kappa")
        table[name]["mean"] = {k: float(np.mean([table[name][s][k] for s in SAMPLES])) for k in keys}
    return table


def markdown(table: dict[str, dict[str, dict[str, float]]]) -> str:
    names = list(table)
    lines = ["| sample | " + " | ".join(f"{n} total / κ" for n in names) + " |", "|---|" + "---|" * len(names)]
    for s in [*SAMPLES, "mean"]:
        cells = [f"{table[n][s]['total']:.2f} / {table[n][s]['kappa']:.1f}" for n in names]
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    lines.append(
        "| mean Type I / II | "
        + " | ".join(f"{table[n]['mean']['type1']:.2f} / {table[n]['mean']['type2']:.2f}" for n in names)
        + " |"
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--methods", default=",".join(methods()))
    parser.add_argument(
        "--out", type=Path, default=Path(__file__).resolve().parent / "results" / "ground_isprs.json"
    )
    args = parser.parse_args()
    table = run([m.strip() for m in args.methods.split(",")])
    print(markdown(table))
    print(save("ground_isprs", table, path=args.out))


if __name__ == "__main__":
    main()
