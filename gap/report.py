"""Write a diagnosis to a folder: diagnosis.json, report.md and PNG plots (matplotlib's Agg canvas,
through Figure: no pyplot, no global backend)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from gap.campaign import FIT_WINDOW_S
from gap.campaign_replay import SPREAD_START_DEG
from gap.effects import FAMILY_VARIATIONS, IN_TWIN_VARIATIONS, NOT_IN_CATALOGUE
from gap.instrument import InstrumentFacts
from gap.kinds import Verdict
from gap.result import CandidateSummary, Diagnosis, PressureFloor, to_json

WHERE_PLOTTED = ("phase", "angle_deg", "supply_mpa")  # the factors where.png shows


def write(diag: Diagnosis, out: str | Path) -> dict[str, Path]:
    """diagnosis.json, the four plots and report.md into folder `out`; their paths by kind."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "diagnosis.json", "report": out / "report.md"}
    paths["json"].write_text(json.dumps(to_json(diag), indent=1))
    for kind, plot in (
        ("residual_png", _plot_residual),
        ("where_png", _plot_where),
        ("ranking_png", _plot_ranking),
        ("how_far_png", _plot_how_far),
    ):
        paths[kind] = out / f"{kind.removesuffix('_png')}.png"
        fig = plot(diag)
        fig.tight_layout()
        fig.savefig(paths[kind], dpi=90)
    lines = [
        *_header(diag),
        *_verdict(diag),
        *_families(diag),
        *_where(diag),
        *_which(diag),
        *_how_far(diag),
    ]
    paths["report"].write_text("\n".join(lines) + "\n")
    return paths


# --- plots -----------------------------------------------------------------------------------
def _plot_residual(diag: Diagnosis) -> Figure:
    res = diag.residuals
    fig = Figure(figsize=(8, 4))
    ax = fig.subplots()
    for k, (t, r) in enumerate(zip(res.times, res.before, strict=True)):
        ax.plot(t, np.rad2deg(r), color="tab:red", alpha=0.5, lw=1, label="nominal twin" if k == 0 else None)
    if res.top is not None:
        label = f"+ {diag.which.top.name} (withheld)"
        for k, (t, r) in enumerate(zip(res.times, res.top, strict=True)):
            ax.plot(t, np.rad2deg(r), color="tab:blue", alpha=0.6, lw=1, label=label if k == 0 else None)
    threshold = diag.noise_floor.significance_threshold_deg
    ax.axhspan(-threshold, threshold, color="0.85", label="significance band")
    ax.set_xlabel("time since run start, s")
    ax.set_ylabel("measured - twin, deg")
    ax.legend()
    ax.set_title("residual per run")
    return fig


def _plot_where(diag: Diagnosis) -> Figure:
    fig = Figure(figsize=(11, 3.5))
    axes = fig.subplots(1, 3)
    for ax, factor in zip(axes, WHERE_PLOTTED, strict=True):
        bins = getattr(diag.where, factor)
        ax.bar(list(bins), [b.rms_deg for b in bins.values()], color="tab:red")
        ax.axhline(diag.noise_floor.floor_deg, color="k", ls="--", lw=1, label="floor")
        ax.set_title(f"residual rms by {factor}")
        ax.set_ylabel("deg")
        ax.tick_params(axis="x", rotation=30)
    axes[0].legend()
    return fig


def _plot_ranking(diag: Diagnosis) -> Figure:
    fig = Figure(figsize=(8, 4))
    ax = fig.subplots()
    ranking = diag.which.ranking + diag.which.pairs
    ax.barh([c.name for c in ranking][::-1], [c.heldout_rms_deg for c in ranking][::-1], color="tab:blue")
    ax.axvline(diag.before_rms_deg, color="tab:red", label="nominal twin")
    ax.axvline(diag.noise_floor.significance_threshold_deg, color="k", ls="--", label="significance")
    ax.set_xscale("log")
    ax.set_xlabel("held-out residual rms, deg")
    ax.legend()
    return fig


def _plot_how_far(diag: Diagnosis) -> Figure:
    top, hf = diag.which.top, diag.how_far
    fig = Figure(figsize=(6, 3.5))
    ax = fig.subplots()
    qs = list(hf["before"])
    x = np.arange(len(qs))
    ax.bar(x - 0.2, [hf["before"][q].mean_deg for q in qs], 0.4, label="before", color="tab:red")
    if top is not None:
        ax.bar(x + 0.2, [hf[top.name][q].mean_deg for q in qs], 0.4, label=f"+ {top.name}", color="tab:blue")
    ax.set_xticks(x, [f"{q} MPa" for q in qs])
    ax.set_ylabel("mean |error| on withheld runs, deg")
    ax.legend()
    return fig


# --- report.md -------------------------------------------------------------------------------
def _f(x) -> str:
    return "—" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.3f}"


def _instrument_line(inst: InstrumentFacts) -> str:
    """What the diagnosis found of the reference instrument (declared, estimated, observed)."""
    dec = inst.declared
    how = "(estimated with every fit, nuisance: not an effect of the arm)" if inst.latency_estimated else "(declared)"
    lat = f"latency {inst.latency_s * 1e3:.0f} ms {how}"
    rate = f"{inst.observed_rate_hz:.1f} Hz observed" + (
        f" (declared {dec.rate_hz:g} Hz: **does not match**)"
        if inst.rate_mismatch
        else (f" (declared {dec.rate_hz:g} Hz)" if dec.rate_hz else "")
    )
    off = (
        f"zero offset {inst.offset_deg:.3f} deg from {inst.offset_rest_samples} rest samples before the first "
        "command (taken off)"
        if inst.offset_rest_samples
        else "no rest samples before the first command: zero offset not estimated"
    )
    total = inst.samples + inst.dropped_samples
    return f"Reference instrument: {lat}; {rate}, {inst.dropped_samples} of {total} samples missing; {off}."


def _pressure_line(p: PressureFloor) -> str:
    return (
        f"Chamber pressures measured: the fit weighs them in units of their floor {p.floor_kpa:.1f} kPa "
        f"(transducer noise {p.noise_kpa:.2f} kPa, model tolerance {p.model_tolerance_kpa} kPa); "
        f"nominal twin pressure residual {p.before_rms_kpa:.1f} kPa rms; significant above "
        f"{p.significance_threshold_kpa:.1f} kPa (either channel makes a gap significant). "
        "Candidates are ranked by held-out misfit in units of the floors, angle and pressure together."
    )


def _header(diag: Diagnosis) -> list[str]:
    nf, p = diag.noise_floor, diag.pressure
    lo, hi = diag.before_rms_ci95_deg
    return [
        f"# Sim-to-real gap diagnosis: {diag.campaign}",
        "",
        f"Joint `{diag.joint}`, {len(diag.runs)} runs, validation: {diag.folds}.",
        *([window_line(diag.windowed)] if diag.windowed else []),
        _instrument_line(diag.instrument),
        f"Nominal twin residual {diag.before_rms_deg:.2f} deg rms (95% CI {lo:.2f}..{hi:.2f}); "
        f"noise floor {nf.floor_deg:.2f} deg (measurement noise {nf.measurement_deg:.3f} deg, "
        f"{nf.measurement_from}; from {nf.repeat_pairs} repeat pairs on {nf.repeat_samples} shared samples: "
        f"noise {_f(nf.repeat_noise_deg)} deg, drift between repeats {_f(nf.repeat_drift_deg)} deg rms; "
        f"model tolerance {nf.model_tolerance_deg:.2f} deg, measured per protocol, gap.protocols); "
        f"significant above {nf.significance_threshold_deg:.2f} deg.",
        *([_pressure_line(p)] if p.measured else []),
        "",
        f"## Verdict: **{diag.which.verdict}**",
        "",
    ]


def window_line(windowed: dict[str, float]) -> str:
    """How runs longer than the fit's window were fitted (gap.campaign.FIT_WINDOW_S)."""
    longest = max(windowed.values())
    return (
        f"{len(windowed)} runs are longer than {FIT_WINDOW_S:g} s (up to {longest:.0f} s recorded): each was fitted "
        f"on its first {FIT_WINDOW_S:g} s, from the start campaign.toml declares; the rest of them was not replayed."
    )


def _nearest(nb) -> str:
    """Why the family call chose its family (gap.verdict.FamilyCall), in words."""
    least = min(x.heldout_shrink for x in nb.evidence)
    own = next(x.heldout_shrink for x in nb.evidence if x.family == nb.family)
    held_out = (
        f"its own corrections leave {own:.2f} of the gap on the withheld runs, the least any family leaves "
        f"being {least:.2f}"
        if least < 1.0
        else f"but no family's corrections shrink the gap on the withheld runs (the best leaves {least:.2f} "
        "of it): a weak call"
    )
    tied = (
        f"; the withheld runs do not tell it apart from {', '.join(nb.tied)}, and its shapes explain most "
        f"of the gap's where-profile among them ({nb.where_match:.0%})"
        if nb.tied
        else ""
    )
    return held_out + tied


def _verdict(diag: Diagnosis) -> list[str]:
    w, top, lines = diag.which, diag.which.top, []
    if w.verdict == Verdict.OUTSIDE and w.nearest:
        lines += [
            f"No catalogue entry or pair explains the gap. Nearest family: **{w.nearest.family}** "
            f"({_nearest(w.nearest)}). The unmodelled effect may be another form of it, or something not catalogued.",
            "",
        ]
    elif top is not None:
        vals = ", ".join(
            f"{f} = {v:.4g} (nominal {n:.4g})" + (f" **on its catalogue bound ({b})**" if b else "")
            for f, v, n, b in zip(top.fields, top.fitted_values, top.nominal_values, top.at_bound, strict=True)
        )
        spread = ""
        if top.heldout_beyond_spread_deg is not None:
            edge = [
                f"{r} {x:.2f} deg"
                for r, x in zip(diag.runs, top.spread_deg, strict=True)
                if x > diag.noise_floor.floor_deg
            ]
            spread = (
                f" ({top.heldout_beyond_spread_deg:.2f} deg beyond the twin's own spread: how far its angle moves on "
                f"each run when the run starts {SPREAD_START_DEG:g} deg further or nearer along the joint"
                + (f"; over the floor on {', '.join(edge)}" if edge else "")
                + ")"
            )
        lines += [
            f"Best: **{top.name}** ({' + '.join(top.labels)}): {vals}; "
            f"held-out rms {top.heldout_rms_deg:.2f} deg{spread}, shrink {top.shrink:.2f}.",
            "",
        ]
        if any(top.at_bound):
            lines += [
                "A fitted value on a catalogue bound: the true value may lie beyond it, "
                "or the effect stands in for another.",
                "",
            ]
    if w.pairs_refused:
        lines += ["Pairs that do not count: " + "; ".join(f"{r.pair} ({r.why})" for r in w.pairs_refused) + ".", ""]
    if w.rivals:
        lines += [f"Rivals that fit the withheld runs as well: {', '.join(w.rivals)}.", ""]
    if w.verdict.tied and w.nearest:
        lines += [
            f"Of their families, nearest: **{w.nearest.family}** ({_nearest(w.nearest)}).",
            "",
        ]
    return lines


def _families(diag: Diagnosis) -> list[str]:
    # with chamber pressures, the held-out shrink per channel too: which one the family's corrections fit
    channels = diag.pressure.measured
    columns = ["family", "held-out shrink", *(["angle", "pressures"] if channels else [])]
    columns += ["where match", "latency per fold (ms)", "best member", "misfit in floors", "shrink"]
    return [
        "## Families (the fit of each family's own corrections on withheld runs"
        + (", in all and per channel" if channels else "")
        + "; its where-pattern match; the instrument latency fitted with them per fold; its best member)",
        "",
        "| " + " | ".join(columns) + " |",
        "|---" * len(columns) + "|",
        *(
            f"| {x.family} | {x.heldout_shrink:.3f} |"
            + (_per_channel(x) if channels else "")
            + f" {x.where_match:.2f} | {'/'.join(f'{1e3 * v:.0f}' for v in x.latency_s)} | {x.best} |"
            + f" {_or_dash(x.score_in_floors, 2)} | {_or_dash(x.shrink, 3)} |"
            for x in diag.which.families
        ),
        *_family_variations({x.family for x in diag.which.families}),
    ]


def _family_variations(families: set[str]) -> list[str]:
    """The line naming the parts replayed for the family call only (gap.effects.FAMILY_VARIATIONS)."""
    varied = [
        f"{f}: {part.label} at {'/'.join(f'{v:g}' for v in values)} ({part.equation})"
        for f, parts in FAMILY_VARIATIONS.items()
        if f in families
        for part, values in parts
    ]
    return ["", f"Also replayed for the families' fits, never candidates: {'; '.join(varied)}."] if varied else []


def _per_channel(x) -> str:
    """A family's held-out shrink on the angle and on the pressures, as two table cells (set wherever
    chamber pressures are measured: `gap.verdict.Judge._evidence`)."""
    return "".join(f" {_or_dash(v, 3)} |" for v in (x.heldout_shrink_angle, x.heldout_shrink_pressure))


def _where(diag: Diagnosis) -> list[str]:
    lines = ["", "## Where", "", "![where](where.png) ![residual](residual.png)", ""]
    for factor, bins in diag.where.by_factor().items():
        cells = "; ".join(f"{k}: {b.rms_deg:.2f} deg rms (n={b.n})" for k, b in bins.items())
        lines += [f"**{factor}**: {cells}", ""]
    return lines


def _candidate_row(c: CandidateSummary) -> str:
    kpa = "—" if c.heldout_pressure_rms_kpa is None else f"{c.heldout_pressure_rms_kpa:.1f}"
    lo, hi = c.heldout_rms_ci95_deg
    fitted = ", ".join(
        f"{f}={v:.4g}" + (" !" if b else "") for f, v, b in zip(c.fields, c.fitted_values, c.at_bound, strict=True)
    )
    return (
        f"| {c.name} | {c.heldout_rms_deg:.3f} ({lo:.3f}..{hi:.3f}) | {kpa} | {c.score_in_floors:.2f} | "
        f"{c.shrink:.3f} | {fitted} | {c.latency_s:.3f} |"
    )


def _which(diag: Diagnosis) -> list[str]:
    w = diag.which
    lines = [
        "## Which (held-out misfit per candidate, best first)",
        "",
        "| candidate | held-out rms deg (95% CI) | held-out pressure rms kPa | misfit in floors | shrink "
        "| fitted (on a bound: !) | instrument latency s |",
        "|---|---|---|---|---|---|---|",
        *(_candidate_row(c) for c in w.ranking + w.pairs),
    ]
    if w.skipped_already_in_twin:
        lines += ["", f"Already in the nominal twin (not candidates): {', '.join(w.skipped_already_in_twin)}."]
        varied = [
            f"{part.label} x {'/'.join(f'{k:g}' for k in factors)}"
            for name in w.skipped_already_in_twin
            for part, factors in IN_TWIN_VARIATIONS.get(name, ())
        ]
        if varied:
            lines[-1] += f' Its family\'s corrections ("in the twin" above) also replay {", ".join(varied)}.'
    return lines


def _how_far(diag: Diagnosis) -> list[str]:
    hf = diag.how_far
    qs = list(hf["before"])
    lines = [
        "",
        "Not yet in the catalogue: " + "; ".join(NOT_IN_CATALOGUE) + ".",
        "",
        "## How far (withheld runs, mean / max |error| deg per supply)",
        "",
        "![how far](how_far.png) ![ranking](ranking.png)",
        "",
        "| model | " + " | ".join(f"{q} MPa" for q in qs) + " |",
        "|---|" + "---|" * len(qs),
    ]
    for name, table in hf.items():
        cells = " | ".join(
            f"{e.mean_deg:.2f} / {e.max_deg:.2f} (CI {e.mean_ci95_deg[0]:.2f}..{e.mean_ci95_deg[1]:.2f})"
            for e in (table[q] for q in qs)
        )
        lines.append(f"| {name} | {cells} |")
    return lines


def _or_dash(v: float, digits: int) -> str:
    """`v` to `digits` decimals, or a dash where there is none (a family whose only member is in the twin)."""
    return "—" if math.isnan(v) else f"{v:.{digits}f}"
