"""Write a diagnosis to a folder: diagnosis.json, report.md and PNG plots (matplotlib Agg)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from gap.effects import NOT_IN_CATALOGUE


def _clean(x):
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items() if not k.startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def _f(x) -> str:
    return "—" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.3f}"


def _instrument_line(inst: dict) -> str:
    """What the diagnosis found of the reference instrument (declared, estimated, observed)."""
    dec = inst["declared"]
    lat = f"latency {inst['latency_s'] * 1e3:.0f} ms " + (
        "(estimated with every fit, nuisance: not an effect of the arm)" if inst["latency_estimated"] else "(declared)"
    )
    rate = f"{inst['observed_rate_hz']:.1f} Hz observed" + (
        f" (declared {dec['rate_hz']:g} Hz: **does not match**)"
        if inst["rate_mismatch"]
        else (f" (declared {dec['rate_hz']:g} Hz)" if dec["rate_hz"] else "")
    )
    off = (
        f"zero offset {inst['offset_deg']:.3f} deg from {inst['offset_rest_samples']} rest samples before the first command (taken off)"
        if inst["offset_rest_samples"]
        else "no rest samples before the first command: zero offset not estimated"
    )
    return f"Reference instrument: {lat}; {rate}, {inst['dropped_samples']} of {inst['samples'] + inst['dropped_samples']} samples missing; {off}."


def write(diag: dict, out: str | Path) -> dict[str, Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "diagnosis.json", "report": out / "report.md"}
    paths["json"].write_text(json.dumps(_clean(diag), indent=1))

    res = diag["_residuals"]
    fig, ax = plt.subplots(figsize=(8, 4))
    for k, (t, r) in enumerate(zip(res["times"], res["before"])):
        ax.plot(t, np.rad2deg(r), color="tab:red", alpha=0.5, lw=1, label="nominal twin" if k == 0 else None)
    if res["top"] is not None:
        for k, (t, r) in enumerate(zip(res["times"], res["top"])):
            ax.plot(
                t,
                np.rad2deg(r),
                color="tab:blue",
                alpha=0.6,
                lw=1,
                label=f"+ {diag['which']['top']['name']} (withheld)" if k == 0 else None,
            )
    ax.axhspan(
        -diag["noise_floor"]["significance_threshold_deg"],
        diag["noise_floor"]["significance_threshold_deg"],
        color="0.85",
        label="significance band",
    )
    ax.set_xlabel("time since run start, s")
    ax.set_ylabel("measured - twin, deg")
    ax.legend()
    ax.set_title("residual per run")
    fig.tight_layout()
    paths["residual_png"] = out / "residual.png"
    fig.savefig(paths["residual_png"], dpi=90)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(11, 3.5))
    for ax, factor in zip(axes, ("phase", "angle_deg", "supply_mpa")):
        b = diag["where"][factor]
        ax.bar(list(b), [v["rms_deg"] for v in b.values()], color="tab:red")
        ax.axhline(diag["noise_floor"]["floor_deg"], color="k", ls="--", lw=1, label="floor")
        ax.set_title(f"residual rms by {factor}")
        ax.set_ylabel("deg")
        ax.tick_params(axis="x", rotation=30)
    axes[0].legend()
    fig.tight_layout()
    paths["where_png"] = out / "where.png"
    fig.savefig(paths["where_png"], dpi=90)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4))
    ranking = diag["which"]["ranking"] + diag["which"]["pairs"]
    ax.barh([c["name"] for c in ranking][::-1], [c["heldout_rms_deg"] for c in ranking][::-1], color="tab:blue")
    ax.axvline(diag["before_rms_deg"], color="tab:red", label="nominal twin")
    ax.axvline(diag["noise_floor"]["significance_threshold_deg"], color="k", ls="--", label="significance")
    ax.set_xscale("log")
    ax.set_xlabel("held-out residual rms, deg")
    ax.legend()
    fig.tight_layout()
    paths["ranking_png"] = out / "ranking.png"
    fig.savefig(paths["ranking_png"], dpi=90)
    plt.close(fig)

    top = diag["which"]["top"]
    hf = diag["how_far"]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    qs = list(hf["before"])
    x = np.arange(len(qs))
    ax.bar(x - 0.2, [hf["before"][q]["mean_deg"] for q in qs], 0.4, label="before", color="tab:red")
    if top is not None:
        ax.bar(x + 0.2, [hf[top["name"]][q]["mean_deg"] for q in qs], 0.4, label=f"+ {top['name']}", color="tab:blue")
    ax.set_xticks(x, [f"{q} MPa" for q in qs])
    ax.set_ylabel("mean |error| on withheld runs, deg")
    ax.legend()
    fig.tight_layout()
    paths["how_far_png"] = out / "how_far.png"
    fig.savefig(paths["how_far_png"], dpi=90)
    plt.close(fig)

    nf = diag["noise_floor"]
    w = diag["which"]
    lines = [
        f"# Sim-to-real gap diagnosis: {diag['campaign']}",
        "",
        f"Joint `{diag['joint']}`, {len(diag['runs'])} runs, validation: {diag['folds']}.",
        _instrument_line(diag["instrument"]),
        f"Nominal twin residual {diag['before_rms_deg']:.2f} deg rms (95% CI {diag['before_rms_ci95_deg'][0]:.2f}..{diag['before_rms_ci95_deg'][1]:.2f}); "
        f"noise floor {nf['floor_deg']:.2f} deg (measurement noise {nf['measurement_deg']:.3f} deg, {nf['measurement_from']}; from {nf['repeat_pairs']} repeat pairs on {nf['repeat_samples']} shared samples: noise {_f(nf['repeat_noise_deg'])} deg, drift between repeats {_f(nf['repeat_drift_deg'])} deg rms; "
        f"model tolerance {nf['model_tolerance_deg']:.2f} deg, measured per protocol, gap.protocols); "
        f"significant above {nf['significance_threshold_deg']:.2f} deg.",
        *(
            [
                f"Chamber pressures measured: the fit weighs them in units of their floor {diag['pressure']['floor_kpa']:.1f} kPa (transducer noise {diag['pressure']['noise_kpa']:.2f} kPa, model tolerance {diag['pressure']['model_tolerance_kpa']} kPa); nominal twin pressure residual {diag['pressure']['before_rms_kpa']:.1f} kPa rms. Candidates are ranked by held-out misfit in units of the floors, angle and pressure together."
            ]
            if diag.get("pressure", {}).get("measured")
            else []
        ),
        "",
        f"## Verdict: **{w['verdict']}**",
        "",
    ]
    if w.get("nearest"):
        nb = w["nearest"]
        how = (
            f"its best member's correction matches the gap's where-pattern ({nb['where_match']:.2f}) and fits the withheld runs best of the families that do"
            if nb["by_where"]
            else f"no family's correction matches the gap's where-pattern well; this one comes closest ({nb['where_match']:.2f})"
        )
        lines += [
            f"No catalogue entry or pair explains the gap. Nearest family: **{nb['family']}** ({how}). The unmodelled effect may be another form of it, or something not catalogued.",
            "",
        ]
    elif top is not None:
        vals = ", ".join(
            f"{f} = {v:.4g} (nominal {n:.4g})" + (f" **on its catalogue bound ({b})**" if b else "")
            for f, v, n, b in zip(top["fields"], top["fitted_values"], top["nominal_values"], top["at_bound"])
        )
        lines += [
            f"Best: **{top['name']}** ({' + '.join(top['labels'])}): {vals}; held-out rms {top['heldout_rms_deg']:.2f} deg, shrink {top['shrink']:.2f}.",
            "",
        ]
        if any(top["at_bound"]):
            lines += [
                "A fitted value on a catalogue bound: the true value may lie beyond it, or the effect stands in for another.",
                "",
            ]
    if w.get("pairs_refused"):
        lines += [
            "Pairs that do not count: " + "; ".join(f"{r['pair']} ({r['why']})" for r in w["pairs_refused"]) + ".",
            "",
        ]
    if w["rivals"]:
        lines += [f"Rivals that fit the withheld runs as well: {', '.join(w['rivals'])}.", ""]
    lines += [
        "## Families (where-pattern match of each family's best member, and its held-out misfit)",
        "",
        "| family | best member | where match | misfit in floors | shrink |",
        "|---|---|---|---|---|",
    ]
    lines += [
        f"| {x['family']} | {x['best']} | {x['where_match']:.2f} | {x['score_in_floors']:.2f} | {x['shrink']:.3f} |"
        for x in w["families"]
    ]
    lines += ["", "## Where", "", "![where](where.png) ![residual](residual.png)", ""]
    for factor, bins in diag["where"].items():
        lines += [
            f"**{factor}**: " + "; ".join(f"{k}: {v['rms_deg']:.2f} deg rms (n={v['n']})" for k, v in bins.items()),
            "",
        ]
    lines += [
        "## Which (held-out misfit per candidate, best first)",
        "",
        "| candidate | held-out rms deg (95% CI) | held-out pressure rms kPa | misfit in floors | shrink | fitted (on a bound: !) | instrument latency s |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in w["ranking"] + w["pairs"]:
        kpa = "—" if c["heldout_pressure_rms_kpa"] is None else f"{c['heldout_pressure_rms_kpa']:.1f}"
        lines.append(
            f"| {c['name']} | {c['heldout_rms_deg']:.3f} ({c['heldout_rms_ci95_deg'][0]:.3f}..{c['heldout_rms_ci95_deg'][1]:.3f}) | {kpa} | {c['score_in_floors']:.2f} | {c['shrink']:.3f} | "
            + ", ".join(
                f"{f}={v:.4g}" + (" !" if b else "") for f, v, b in zip(c["fields"], c["fitted_values"], c["at_bound"])
            )
            + f" | {c['latency_s']:.3f} |"
        )
    if w["skipped_already_in_twin"]:
        lines += ["", f"Already in the nominal twin (not candidates): {', '.join(w['skipped_already_in_twin'])}."]
    lines += [
        "",
        "Not yet in the catalogue: " + "; ".join(NOT_IN_CATALOGUE) + ".",
        "",
        "## How far (withheld runs, mean / max |error| deg per supply)",
        "",
        "![how far](how_far.png) ![ranking](ranking.png)",
        "",
    ]
    qs = list(hf["before"])
    lines += ["| model | " + " | ".join(f"{q} MPa" for q in qs) + " |", "|---|" + "---|" * len(qs)]
    for name, table in hf.items():
        lines.append(
            f"| {name} | "
            + " | ".join(
                f"{table[q]['mean_deg']:.2f} / {table[q]['max_deg']:.2f} (CI {table[q]['mean_ci95_deg'][0]:.2f}..{table[q]['mean_ci95_deg'][1]:.2f})"
                for q in qs
            )
            + " |"
        )
    paths["report"].write_text("\n".join(lines) + "\n")
    return paths
