"""The objects sections of docs/benchmarks.md (issue 28), from objects_cv.json and objects_speed.json."""

from __future__ import annotations

from typing import Any

import numpy as np

from benchmarks.common import machine_line
from benchmarks.crown_cv import name as crown_setting_name
from ingest.objects import TreeParams


def _f(value: Any, digits: int = 3) -> str:
    return "–" if value is None or (isinstance(value, float) and not np.isfinite(value)) else f"{value:.{digits}f}"


def _mean(rows: list[dict[str, Any]], *keys: str) -> float:
    values = []
    for r in rows:
        v: Any = r
        for k in keys:
            v = v.get(k) if isinstance(v, dict) else None
        if v is not None and np.isfinite(v):
            values.append(v)
    return float(np.mean(values)) if values else float("nan")


def objects_section(
    out: list[str], doc: dict[str, Any] | None, speed: dict[str, Any] | None, machine: str
) -> None:
    if doc is None:
        return
    cases = doc["cases"]
    out += [
        "## Trees, vegetation and buildings (issue 28)",
        "",
        "`python -m benchmarks.objects_cv`: synthetic scenes (300 m, 2, 8 and 20 pulses/m²) and lidR's "
        "`MixedConifer.laz` (its `treeID` trees). Trees scored: ≥ 5 m high with crowns ≥ 3 m wide, matched "
        "one to one within 1.5 m. The tree settings (smoothing scales, canopy noise, the widest "
        "penetration the crown net fills) are chosen by "
        "leave-one-group-out (a group: one scene seed's three densities, or the forest; a setting's score "
        "the mean over groups of each group's mean F1); *held out* is each "
        "group's F1 with the setting chosen on the others. Seeds 11–14 were never used to choose. The "
        "baseline is a local-maximum filter on a smoothed canopy height model plus a watershed "
        "(scikit-image), on the same ground model, its own setting chosen the same way. "
        f"Chosen: {doc['tuned']}; baseline: {doc['baseline_tuned']}. Machine: {machine}.",
        "",
        "| case | tree F1 | held out | recall | precision | position RMSE m | height RMSE m | crown ⌀ RMSE m "
        "| baseline F1 | building/vegetation correct | footprint IoU mean / min |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, c in cases.items():
        t, b = c["trees"], c["baseline"]
        iou = c.get("footprint_iou")
        out.append(
            f"| {name}{' (never chosen on)' if c['holdout_seed'] else ''} | {_f(t['f1'])} "
            f"| {_f(c['held_out_f1'])} | {_f(t['recall'])} | {_f(t['precision'])} "
            f"| {_f(t['position_rmse'], 2)} | {_f(t['height_rmse'], 2)} "
            f"| {_f(t['diameter_rmse'], 2)} | {_f(b['f1'])} | {_f(c.get('class_accuracy'), 4)} "
            f"| {_f(iou['mean']) + ' / ' + _f(iou['min']) if iou else '–'} |"
        )
    for label, rows in (
        (
            "chosen-on seeds 1–4",
            [c for n, c in cases.items() if c["group"].startswith("seed") and not c["holdout_seed"]],
        ),
        ("never-chosen-on seeds 11–14", [c for c in cases.values() if c["holdout_seed"]]),
    ):
        out.append(
            f"| **mean, {label}** | {_f(_mean(rows, 'trees', 'f1'))} | {_f(_mean(rows, 'held_out_f1'))} "
            f"| {_f(_mean(rows, 'trees', 'recall'))} | {_f(_mean(rows, 'trees', 'precision'))} "
            f"| {_f(_mean(rows, 'trees', 'position_rmse'), 2)} | {_f(_mean(rows, 'trees', 'height_rmse'), 2)} "
            f"| {_f(_mean(rows, 'trees', 'diameter_rmse'), 2)} | {_f(_mean(rows, 'baseline', 'f1'))} "
            f"| {_f(_mean(rows, 'class_accuracy'), 4)} | {_f(_mean(rows, 'footprint_iou', 'mean'))} / "
            f"{_f(min((r['footprint_iou']['min'] for r in rows), default=float('nan')))} |"
        )
    forest = cases.get("MixedConifer")
    if forest:
        out += [
            "",
            f"MixedConifer crown overlap (IoU of matched crowns with the hulls of their `treeID` points): "
            f"{_f(forest.get('crown_overlap'))}.",
        ]
    veg = {k: v for k, v in doc.get("vegetation", {}).items() if v}
    if veg:
        out += [
            "",
            "Real files against their providers' vegetation classes (3, 4, 5), points more than 2 m over "
            "the ground:",
            "",
            "| file | points | called vegetation | called building |",
            "|---|---|---|---|",
        ]
        out += [
            f"| {k} | {v['points']:,} | {100 * v['vegetation']:.2f} % | {100 * v['building']:.2f} % |"
            for k, v in veg.items()
        ]
    if speed:
        s, i = speed["scene"], speed["ingest"]
        out += [
            "",
            "`python -m benchmarks.objects_speed` (medians of five, the ground model given; the ingests "
            "with and without the objects in turns): "
            f"synthetic {s['size_m']:.0f} m at {s['density']:g} pulses/m², {s['points']:,} points: "
            f"**{s['points_per_s'] / 1e6:.2f} M points/s**"
            + "".join(
                f"; {k.split('/')[-1]}: {v['points_per_s'] / 1e6:.2f} M points/s"
                for k, v in speed.items()
                if isinstance(v, dict) and "points_per_s" in v and k != "scene"
            )
            + f". `tdb ingest` of the scene: {i['with_objects']:.1f} s with the objects, "
            f"{i['without_objects']:.1f} s without (**{i['slowdown_pct']:+.1f} %**). Targets: ≥ 1 M points/s; "
            "the objects add at most 20 % to an ingest. "
            f"Machine: {machine_line(speed)}.",
        ]
    out.append("")


def crown_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    """The crown base and the crowns' crossing, chosen together by leave-one-group-out on the
    crown diameter (crown_cv.json)."""
    if doc is None:
        return
    settings, cases = doc["settings"], doc["cases"]
    forest = doc.get("forest") or {}
    shipped = TreeParams()
    default = crown_setting_name({"crown_base": shipped.crown_base, "crossing_area": shipped.crossing_area})
    out += [
        "## A crown's edges, chosen on the crown diameter (issue 28)",
        "",
        "`python -m benchmarks.crown_cv`: the synthetic scenes of the section above (300 m, 2, 8 and 20 "
        "pulses/m²), the other tree settings as shipped. *Base*: a segment's cells lower than the share × its "
        "top are no part of its crown (`TreeParams.crown_base`; None: every cell). *Crossing*: the boundaries "
        "between crowns of at least that many m² move to where their paraboloids cross "
        "(`TreeParams.crossing_area`; None: as climbed). Crown ⌀ RMSE in m, the mean over seeds 1–4 (chosen on) "
        "and over seeds 11–14 (never chosen on) per density; a setting is chosen by leave-one-group-out on "
        f"the mean over each seed's densities. Chosen on all: {doc['tuned']} (shipped: {default}); "
        "held out per seed: "
        + ", ".join(f"{g} {h['setting']} ({_f(h['diameter_rmse'])} m)" for g, h in doc["held_out"].items())
        + f"; their mean {_f(float(np.mean([h['diameter_rmse'] for h in doc['held_out'].values()])))} m. "
        "MixedConifer (lidR's `treeID` trees, no setting chosen on it): tree F1 and crown overlap (IoU). "
        f"Machine: {machine}.",
        "",
    ]
    densities = sorted({n.split("@")[1].strip() for n in cases}, key=lambda d: float(d.split("/")[0]))
    head = [f"{d}: {seeds}" for d in densities for seeds in ("seeds 1–4", "11–14")]
    out += [
        "| setting | " + " | ".join(head) + " | MixedConifer F1 | overlap |",
        "|---|" + "---|" * (len(head) + 2),
    ]
    for s in settings:

        def mean(held: bool, density: str, s: str = s) -> float:
            return float(
                np.mean(
                    [
                        c["settings"][s]["diameter_rmse"]
                        for n, c in cases.items()
                        if (int(c["group"].split()[1]) > 10) == held and n.split("@")[1].strip() == density
                    ]
                )
            )

        cells = [_f(mean(held, d)) for d in densities for held in (False, True)]
        f = forest.get(s)
        extra = [_f(f["f1"]), _f(f["overlap"])] if f else ["–", "–"]
        mark = "**" if s == default else ""
        out.append(f"| {mark}{s}{mark} | " + " | ".join(cells + extra) + " |")
    out.append("")
