"""The feature-peers section of docs/benchmarks.md (issue 30), from feature_peers.json."""

from __future__ import annotations

from typing import Any

import numpy as np

LABELS = {
    "relief_exact": ("local relief model", "exact bare earth"),
    "relief_tdb_dtm": ("local relief model", "tdb's dense model"),
    "geomorphon_exact": ("GRASS r.geomorphon", "exact bare earth"),
    "geomorphon_tdb_dtm": ("GRASS r.geomorphon", "tdb's dense model"),
}


def _rpf(r: dict[str, float]) -> str:
    p = r["precision"]
    return f"{r['recall']:.3f} / {'–' if not np.isfinite(p) else f'{p:.3f}'} / {r['f1']:.3f}"


def feature_peers_section(
    out: list[str], doc: dict[str, Any] | None, machine: str, densities: list[dict[str, Any]] | None = None
) -> None:
    if doc is None:
        return
    summary, runs = doc["summary"], doc["runs"]
    out += [
        "## Feature queries beside their peers, on rugged scenes",
        "",
        f"`python -m benchmarks.feature_peers` (rugged scenes, {doc['size']:.0f} m, {doc['density']} pulses/m², "
        f"seeds {', '.join(runs)}). Machine: {machine}.",
        "",
        "Recall / precision / F1 by length. tdb's settings were chosen on other scenes (plain seeds 1–10 and "
        "rugged seeds 21–25; the relief's plane rule, the width bounds, the mound and ditch-lip rules on "
        "rugged seeds 21–35 too); "
        "each peer's setting is chosen leave-one-scene-out (held out), and beside it the setting best on all "
        "five (tuned).",
        "",
        "| method | input | ditch, held out | ditch, tuned | ridge, held out | ridge, tuned |",
        "|---|---|---|---|---|---|",
        f"| tdb `SELECT ditch` / `SELECT ridge` | the raw cloud | {_rpf(summary['tdb']['ditch'])} | – | "
        f"{_rpf(summary['tdb']['ridge'])} | – |",
    ]
    for key, (method, given) in LABELS.items():
        if key in summary:
            d, r = summary[key]["ditch"], summary[key]["ridge"]
            out.append(
                f"| {method} | {given} | {_rpf(d['held_out_mean'])} | {_rpf(d['tuned_mean'])} | "
                f"{_rpf(r['held_out_mean'])} | {_rpf(r['tuned_mean'])} |"
            )
    out += [
        "",
        "Per scene (tdb; the peers held out):",
        "",
        "| seed | tdb ditch | tdb ridge | tdb size class | "
        + " | ".join(f"{LABELS[k][0]} on {LABELS[k][1]}: ditch F1 / ridge F1" for k in LABELS if k in summary)
        + " | tdb ditch query s |",
        "|---|---|---|---|" + "---|" * sum(k in summary for k in LABELS) + "---|",
    ]
    for seed, run in runs.items():
        held = [
            (summary[k]["ditch"]["held_out"][seed], summary[k]["ridge"]["held_out"][seed])
            for k in LABELS
            if k in summary
        ]
        peers = [f"{d['f1']:.3f} / {r['f1']:.3f}" for d, r in held]
        t = run["tdb"]
        out.append(
            f"| {seed} | {_rpf(t['ditch'])} | {_rpf(t['ridge'])} | {_rpf(t['ditch_class'])} | "
            + " | ".join(peers)
            + f" | {t['ditch']['query_s']:.2f} |"
        )
    if densities:
        out += [
            "",
            "Other densities (same scenes; the peers on tdb's dense model, held out):",
            "",
            "| pulses/m² | seeds | tdb ditch | tdb ridge | tdb size class | geomorphon ditch | geomorphon ridge "
            "| local relief ditch | local relief ridge |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for d in sorted(densities, key=lambda d: d["density"]):
            s = d["summary"]
            peer = [
                _rpf(s[k][kind]["held_out_mean"]) if k in s else "–"
                for k in ("geomorphon_tdb_dtm", "relief_tdb_dtm")
                for kind in ("ditch", "ridge")
            ]
            tdb = [_rpf(s["tdb"][k]) for k in ("ditch", "ridge", "ditch_class")]
            out.append(f"| {d['density']:g} | {', '.join(d['runs'])} | " + " | ".join(tdb + peer) + " |")
    out += [
        "",
        "The scenes hold natural valleys and spurs that widen downstream, roads on a raised bed with roadside "
        "ditches, field edges, ditches that fade out and ditches under trees (`tdb synth --terrain rugged`). "
        "Recall counts ditches where at least 0.3 m deep (the size class: 0.5 m) and ridges; precision counts "
        "a reported line right within 2 m of any true ditch, or of a ridge or wall. Peers' settings: "
        "`benchmarks/line_peers.py`.",
        "",
    ]


def _fold_picks(held_out: dict[str, dict[str, Any]]) -> str:
    """How many folds chose each setting, the most chosen first ("0.5 in 24, 0.25 in 1")."""
    choices: dict[str, int] = {}
    for v in held_out.values():
        choices[v["setting"]] = choices.get(v["setting"], 0) + 1
    return ", ".join(f"{s} in {n}" for s, n in sorted(choices.items(), key=lambda kv: -kv[1]))


def spread_cv_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    """The least spread of a ditch and a ridge, chosen by leave-one-scene-out."""
    if doc is None:
        return
    out += [
        "## The least spread of a ditch and a ridge (issue 30)",
        "",
        "`python -m benchmarks.spread_cv`: a form's relief read twice as far off, over its relief, at least "
        "the bound (`min_spread`; none: no bound). Chosen by leave-one-scene-out on the plain seeds 1–10 and "
        "the rugged seeds 21–35 (F1 by length per scene, scored as the section above scores); the rugged "
        f"seeds 1–5 are never chosen on. {doc['density']} pulses/m². Machine: {machine}.",
        "",
        "| filter | bound | chosen on: R / P / F1 | never chosen on: R / P / F1 |",
        "|---|---|---|---|",
    ]
    for name in doc["grid"]:
        d = doc[name]
        for setting, r in d["means"].items():
            mark = " (chosen)" if setting == d["tuned"] else ""
            out.append(f"| {name} | {setting}{mark} | {_rpf(r)} | {_rpf(d['never_chosen_on'][setting])} |")
    out.append("")
    for name in doc["grid"]:
        d = doc[name]
        picks = _fold_picks(d["held_out"])
        out.append(
            f"- {name}: chosen on all {d['tuned']}; without each scene {picks} of the folds; held out F1 "
            f"{d['held_out_f1']:.4f} (chosen on all: {d['means'][d['tuned']]['f1']:.4f})."
        )
    ridge = doc["ridge"]
    before, after = ridge["never_chosen_on"]["none"]["f1"], ridge["never_chosen_on"][ridge["tuned"]]["f1"]
    out += [
        f"- Shipped: the ditch's bound 0; the ridge none. The ridge's {ridge['tuned']} gains on the scenes it was "
        f"chosen on and loses on the others (F1 {before:.3f} → {after:.3f}: rugged seed 4 loses a true ridge "
        "that reads under 0.25), so it is not set.",
        "",
    ]


def notch_cv_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    """The widest line the ditch's spread bound lets through, chosen by leave-one-scene-out."""
    if doc is None:
        return
    d = doc["ditch"]
    out += [
        "## The widest ditch the spread bound lets through (issue 30)",
        "",
        "`python -m benchmarks.notch_cv`: a ditch line whose cross-sections read it at most this wide passes "
        "`max_spread` whatever its spread (`notch_width`; none: no line does), as a ditch dug along a valley's "
        "floor. Chosen as the section above chooses, on the same scenes. "
        f"{doc['density']} pulses/m². Machine: {machine}.",
        "",
        "| width m | chosen on: R / P / F1 | never chosen on: R / P / F1 |",
        "|---|---|---|",
    ]
    for setting, r in d["means"].items():
        mark = " (chosen)" if setting == d["tuned"] else ""
        out.append(f"| {setting}{mark} | {_rpf(r)} | {_rpf(d['never_chosen_on'][setting])} |")
    picks = _fold_picks(d["held_out"])
    out += [
        "",
        f"- Chosen on all {d['tuned']}; without each scene {picks} of the folds; held out F1 "
        f"{d['held_out_f1']:.4f} (chosen on all: {d['means'][d['tuned']]['f1']:.4f}; with none: "
        f"{d['means']['none']['f1']:.4f}). Shipped: {d['tuned']} m.",
        "",
    ]


_ARMS_TITLES = {
    "ARM_ANGLE": (
        "The least angle between a junction's arms (issue 30)",
        "`python -m benchmarks.arms_cv`: a group of line tiles is cut where three or more arms of 20 m meet, "
        "headed more than this many degrees apart (`queries.centreline.ARM_ANGLE`)",
        "degrees",
    ),
    "BEND": (
        "Lines cut at acute corners (issue 30)",
        "`python -m benchmarks.arms_cv --grid bend`: a group of line tiles that fails as a whole is cut too "
        "where it turns by more than this many degrees between arms of 20 m that head more than "
        "`ARM_ANGLE` apart (`queries.centreline.BEND`; none: it is not), where one line may run on into "
        "another of another section",
        "turn, degrees",
    ),
}


def arms_cv_section(out: list[str], doc: dict[str, Any] | None, machine: str) -> None:
    """Where a line's tiles are cut into lines judged alone, chosen by leave-one-scene-out."""
    if doc is None:
        return
    title, what, setting = _ARMS_TITLES[doc.get("constant", "ARM_ANGLE")]
    out += [
        f"## {title}",
        "",
        f"{what}. One setting serves the ditch and the ridge filters: chosen by leave-one-scene-out on the mean "
        "of a scene's ditch and ridge F1, on the plain seeds 1–10 and the rugged seeds 21–35; the rugged seeds "
        f"1–5 are never chosen on. {doc['density']} pulses/m². Machine: {machine}.",
        "",
        f"| {setting} | ditch, chosen on: R / P / F1 | ridge, chosen on | ditch, never chosen on | "
        "ridge, never chosen on |",
        "|---|---|---|---|---|",
    ]
    for s, per in doc["means"].items():
        mark = " (chosen)" if s == doc["tuned"] else ""
        never = doc["never_chosen_on"][s]
        out.append(
            f"| {s}{mark} | {_rpf(per['ditch'])} | {_rpf(per['ridge'])} | {_rpf(never['ditch'])} | "
            f"{_rpf(never['ridge'])} |"
        )
    shipped = doc.get("shipped")
    label = "none" if shipped is None else f"{shipped:g}"
    tie = len({round(per["ditch"]["f1"] + per["ridge"]["f1"], 6) for per in doc["means"].values()}) == 1
    out += [
        "",
        f"- Chosen on all {doc['tuned']}; without each scene {_fold_picks(doc['held_out'])} of the folds; held "
        f"out mean F1 {doc['held_out_f1']:.4f} (chosen on all: {doc['tuned_f1']:.4f}). Shipped: {label}"
        + (" (every setting ties on the scenes chosen on; the choice is the grid's first)." if tie else "."),
        "",
    ]
