"""The section of docs/benchmarks.md on the relief missed between returns (benchmarks/lod_cv.py)."""

from __future__ import annotations

from typing import Any


def _cell(m: dict[str, float], by: str) -> str:
    cell = f"{m['recall']:.3f} / {m['precision']:.3f} / {m['f1']:.3f}"
    return f"{cell} / {m['iou']:.3f}" if by == "iou" else cell


_TITLES = {
    "MISSED": (
        "The relief missed between returns, chosen by leave-one-seed-out",
        "each tile's level of detection grown by the factor times κr²/2 (the relief a line between ground "
        "returns misses; 0: no term, 1: what ships)",
        "factor",
        "`python -m benchmarks.lod_cv`",
    ),
    "MIN_RETURNS": (
        "The least ground returns a change rests on, chosen by leave-one-seed-out",
        "a region claimed only where each survey holds at least this many ground returns in it (0: no bound)",
        "least returns",
        "`python -m benchmarks.lod_cv --grid returns`",
    ),
    "CONTOUR": (
        "A change region's outline, chosen by leave-one-seed-out",
        "each claimed region outlined where its change passes this multiple of its level of detection "
        "(1: the level of detection's own contour, what ships)",
        "contour × LoD",
        "`python -m benchmarks.lod_cv --grid contour`",
    ),
}
_MEASURES = {"f1": "Recall / precision / F1 by area", "iou": "Recall / precision / F1 / IoU by area"}


def lod_cv_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    if not doc:
        return
    title, what, setting, command = _TITLES[doc.get("constant", "MISSED")]
    by = doc["by"]
    densities = [f"{d:g}" for d in doc["densities"]]
    out += [
        f"## {title}",
        "",
        f"{command}: the synthetic change pairs of `changes_synth` ({doc['size']:.0f} m scenes) at "
        f"{', '.join(densities)} points/m², {what}. {_MEASURES[by]}, means over seeds; the setting is "
        f"chosen by {by.upper() if by == 'f1' else 'IoU'}, each seed (its three densities) held out in turn. "
        f"Machine: {machine}.",
        "",
        f"| {setting} | "
        + " | ".join(f"{d} points/m², seeds chosen on" for d in densities)
        + " | "
        + " | ".join(f"{d} points/m², never chosen on" for d in densities)
        + " |",
        "|---|" + "---|" * (2 * len(densities)),
    ]
    for f, per in doc["means"].items():
        never = doc["never_chosen_on"][f]
        cells = [_cell(per[d], by) for d in densities] + [_cell(never[d], by) for d in densities]
        mark = " (chosen)" if f == doc["tuned"] else ""
        out.append(f"| {f}{mark} | " + " | ".join(cells) + " |")
    held = ", ".join(f"seed {g}: {h['setting']}" for g, h in doc["held_out"].items())
    name = "F1" if by == "f1" else "IoU"
    out += [
        "",
        f"Chosen on all seeds: {doc['tuned']}, mean {name} {doc['tuned_score']:.3f}; each seed held out "
        f"({held}): held-out mean {name} **{doc['held_out_score']:.3f}**.",
        "",
    ]


def same_ground_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    if not doc:
        return
    variants = ("shipped", "without_least_returns", "without_missed_relief", "without_either")
    variants = tuple(v for v in variants if all(v in r for r in doc["runs"].values()))
    out += [
        "## False change on real surveys: two random halves of one survey",
        "",
        "`python -m benchmarks.same_ground`: each real file split into two random halves of its returns, "
        "both ingested and compared (`auto` co-registration): they saw the same ground at the same time, "
        "so every region reported is false. No setting was chosen on these. False regions, m² (share of "
        "the 2 m tiles): as shipped, without the least ground returns a region needs, without the relief "
        f"missed between returns in the level of detection, and without either. Machine: {machine}.",
        "",
        "| file | returns | a half's pulses/m² | 2 m tiles | "
        + " | ".join(v.replace("_", " ") for v in variants)
        + " |",
        "|---|---|---|---|" + "---|" * len(variants),
    ]
    for name, r in doc["runs"].items():
        cells = []
        for key in variants:
            f = r[key]
            share = 100 * f["area_m2"] / (4.0 * r["tiles"]) if r["tiles"] else float("nan")
            cells.append(f"{f['regions']}, {f['area_m2']:,.0f} m² ({share:.2f} %)")
        out.append(
            f"| {name} | {r['points']:,} | {r['pulses_per_m2']:.2f} | {r['tiles']:,} | " + " | ".join(cells) + " |"
        )
    out.append("")
