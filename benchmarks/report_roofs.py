"""The section of docs/benchmarks.md on roofs wider than the openings (benchmarks/ground_roofs.py)."""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

_KEYS = ("total", "kappa", "hall_as_ground_pct")  # the three figures of a table cell


def _setting(s: dict[str, float]) -> str:
    return f"step {s['step']:g} m, share {s['min_share']:g}"


def ground_roofs_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    if not doc:
        return
    rows = doc["rows"]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    out += [
        "## Ground filters on roofs wider than the openings",
        "",
        "`python -m benchmarks.ground_roofs`: synthetic 300 m scenes (a tilted, gently rolling plane; "
        "one hall 40–120 m wide, half of them with a higher part; a block round a courtyard; small "
        "houses; trees), scored on every point against the scene's classes. Total error % / κ % / the "
        f"share of the hall's roof points taken for ground %. Machine: {machine}.",
        "",
        "| seed | points/m² | hall m | " + " | ".join(methods) + " |",
        "|---|---|---|" + "---|" * len(methods),
    ]
    by_case: dict[tuple[int, float], dict[str, dict[str, Any]]] = defaultdict(dict)
    for r in rows:
        by_case[(r["seed"], r["density"])][r["method"]] = r
    for (seed, density), case in by_case.items():
        hall = next(iter(case.values()))["hall_m"]
        cells = [_cell(case[m]) for m in methods]
        out.append(f"| {seed} | {density:g} | {hall[0]:.0f} × {hall[1]:.0f} | " + " | ".join(cells) + " |")
    means = [_cell({k: float(np.mean([r[k] for r in rows if r["method"] == m])) for k in _KEYS}) for m in methods]
    out.append("| **mean** | | | " + " | ".join(means) + " |")
    yard = min(r["yard_kept_pct"] for r in rows if r["method"] == methods[0])
    out += ["", f"The courtyard's ground kept by `{methods[0]}` where it keeps least: {yard:.1f} %.", ""]
    site = doc.get("site")
    if site:
        out += [
            f"On the ISPRS site cloud CSite2 (unlabelled) the stage takes {site['left_ground']:,} points "
            f"off the ground, most of them a 60 × 60 m roof 12 m over the street; {site['joined']:,} join "
            "it by the pass the stage adds:",
            "",
            "![CSite2's ground without the roofs stage and with it](images/roofs-csite2.png)",
            "",
        ]
    grid = doc.get("grid")
    if grid:
        held = grid["held_out"]
        held_mean = float(np.mean([h["total"] for h in held.values()]))
        tuned_i = grid["settings"].index(grid["tuned"])
        tuned_mean = float(np.mean([v for k, v in grid["scores"][tuned_i].items() if k != "isprs"]))
        out += [
            "The roofs stage's limits by leave-one-scene-out on these scenes (total error %, mean over "
            "each scene's three densities; ISPRS mean beside it, which cannot choose them):",
            "",
            "| setting | halls | ISPRS |",
            "|---|---|---|",
        ]
        for s, scores in zip(grid["settings"], grid["scores"], strict=True):
            halls = float(np.mean([v for k, v in scores.items() if k != "isprs"]))
            out.append(f"| {_setting(s)} | {halls:.3f} | {scores['isprs']:.3f} |")
        chosen = ", ".join(f"seed {k}: {_setting(h['setting'])}" for k, h in held.items())
        out += [
            "",
            f"Tuned on all scenes: {_setting(grid['tuned'])} ({tuned_mean:.3f} %). Chosen without each "
            f"scene: {chosen}; held out {held_mean:.3f} %.",
            "",
        ]


def _cell(r: dict[str, Any]) -> str:
    return f"{r['total']:.2f} / {r['kappa']:.1f} / {r['hall_as_ground_pct']:.1f}"
