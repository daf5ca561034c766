"""A design written to a folder: the plan (gap.plan: the runs to play, as campaign files), design.json
(every proposal, what each tells apart), design.md (why each run was chosen) and predicted.png (the
hypotheses' predicted readings of the chosen runs; matplotlib's Agg canvas through Figure)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from gap.design import Design, Proposal
from gap.discrimination import SEPARATED_FLOORS, trajectory
from gap.plan import Header, write_plan

CRITERION = (
    "T-optimality for discriminating between rival models (Atkinson & Fedorov 1975, Biometrika 62(1) 57-70; "
    "several models: Biometrika 62(2) 289-303): the rival hypothesis, refitted over its alternatives and the "
    "instrument's latency, misses the other's predicted readings by T (sum of squares in floors); a run's worth "
    "is the T it adds to the campaign's own runs, per sample, as an rms in floors"
)


def write_design(d: Design, out: Path, header: Header) -> dict[str, Path]:
    """plan/ (campaign.toml and one CSV per run), design.json, design.md and predicted.png in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    paths = {"plan": out / "plan", "json": out / "design.json", "md": out / "design.md"}
    if d.chosen:
        write_plan(d.runs(), header, paths["plan"], f"runs proposed by twin gap design from {d.source}")
        paths["png"] = out / "predicted.png"
        _plot(d).savefig(paths["png"], dpi=90)
    paths["json"].write_text(json.dumps(as_json(d), indent=1))
    paths["md"].write_text("\n".join(markdown(d)) + "\n")
    return paths


def _proposal(p: Proposal) -> dict:
    return {
        "protocol": p.protocol,
        "runs": [r.name for r in p.runs],
        "arm_time_s": p.arm_time_s,
        "score": p.score(),
        "separation_floors": p.separation,
    }


def as_json(d: Design) -> dict:
    return {
        "source": d.source,
        "criterion": CRITERION,
        "separated_at_floors": SEPARATED_FLOORS,
        "floor_deg": d.reading.floor_deg,
        "floor_kpa": d.reading.floor_kpa,
        "latencies_s": d.reading.latencies_s.tolist(),
        "hypotheses": [
            {
                "name": h.name,
                "family": h.family,
                "effects": {e.name: v for e, v in h.effects},
                "latency_s": h.latency_s,
                "alternatives": len(h.alternatives),
            }
            for h in d.hypotheses
        ],
        "pairs": [p.name for p in d.pairs],
        "chosen": [_proposal(p) for p in d.chosen],
        "runs_added": len(d.runs()),
        "arm_time_s": d.arm_time_s(),
        "separation_floors": d.separation,
        "unseparated": d.unseparated,
        "ranking": [_proposal(p) for p in d.ranking],
    }


def why(p: Proposal) -> str:
    """What a proposal tells apart, and by how much, in a sentence."""
    told = sorted(((s, k) for k, s in p.separation.items() if s >= SEPARATED_FLOORS), reverse=True)
    if not told:
        best = max(p.separation.items(), key=lambda x: x[1], default=("nothing", 0.0))
        return f"tells no pair apart alone; nearest {best[0]} at {best[1]:.2f} floors"
    shown = ", ".join(f"{k} ({s:.2f})" for s, k in told[:6])
    more = f" and {len(told) - 6} more" if len(told) > 6 else ""
    return f"tells apart {shown}{more} (floors rms)"


def markdown(d: Design) -> list[str]:
    lines = [
        "# The next runs",
        "",
        f"From {d.source}. Criterion: {CRITERION}. Two hypotheses are told apart at {SEPARATED_FLOORS:g} floor "
        f"(the angle's floor {d.reading.floor_deg:.3f} deg"
        + (f", the chamber pressures' {d.reading.floor_kpa:.2f} kPa" if d.reading.floor_kpa is not None else "")
        + "; the instrument's latency "
        + ("declared" if len(d.reading.latencies_s) == 1 else "fitted, 0-60 ms")
        + ").",
        "",
        "## Hypotheses",
        "",
        *(
            f"- {h.name}: read {h.latency_s * 1e3:.0f} ms late, {len(h.alternatives)} alternatives"
            for h in d.hypotheses
        ),
        "",
        "## The plan",
        "",
    ]
    if not d.chosen:
        lines += ["No run proposed: " + ("no pair to tell apart." if len(d.hypotheses) < 2 else "no gap to explain.")]
    for k, p in enumerate(d.chosen, 1):
        lines += [
            f"{k}. **{p.protocol}** at {', '.join(f'{r.supply_mpa:g}' for r in p.runs)} MPa "
            f"({len(p.runs)} runs, {p.arm_time_s:.1f} s of arm time): {why(p)}."
        ]
    if d.chosen:
        lines += [
            "",
            f"Together: {len(d.runs())} runs, {d.arm_time_s():.1f} s of arm time. Files: `plan/` (campaign.toml "
            "and one CSV per run, commands at 1 ms; play them, fill angle_rad (and p_a_pa, p_b_pa), then copy "
            "the files and their [[runs]] tables into the campaign). ![predicted](predicted.png)",
        ]
    lines += ["", "## Pairs", "", "| pair | separation (floors rms) |", "|---|---|"]
    lines += [
        f"| {k} | {s:.2f}{'' if s >= SEPARATED_FLOORS else ' (not told apart)'} |" for k, s in d.separation.items()
    ]
    if d.unseparated:
        lines += ["", f"Not told apart by the plan: {', '.join(d.unseparated)}."]
    lines += [
        "",
        "## Every proposal",
        "",
        "| protocol | pairs told apart (soft count) | arm time s | |",
        "|---|---|---|---|",
    ]
    lines += [
        f"| {p.protocol} | {p.score():.2f} / {len(p.separation)} | {p.arm_time_s:.1f} | {why(p)} |" for p in d.ranking
    ]
    return lines


def _plot(d: Design) -> Figure:
    """Each chosen proposal's run at its highest supply: every hypothesis's predicted angle (and port
    A's pressure where measured)."""
    pressures = d.reading.floor_kpa is not None
    rows = 2 if pressures else 1
    fig = Figure(figsize=(5.5 * len(d.chosen), 3.2 * rows + 0.25 * len(d.hypotheses)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(rows, len(d.chosen), squeeze=False))
    for col, p in enumerate(d.chosen):
        run = p.runs[-1]
        for h in d.hypotheses:
            t, th, pa, _ = trajectory(d.twin, h.effects, run)
            axes[0, col].plot(t + h.latency_s, np.degrees(th), lw=1.2, label=h.name)
            if pressures:
                axes[1, col].plot(t, pa / 1e3, lw=1.0)
        axes[0, col].set_title(f"{p.protocol} at {run.supply_mpa:g} MPa")
        axes[0, col].set_ylabel("predicted angle as read, deg")
        axes[-1, col].set_xlabel("time, s")
        if pressures:
            axes[1, col].set_ylabel("port A, kPa abs")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=7)
    fig.suptitle(f"hypotheses' predicted readings (floor {d.reading.floor_deg:.2f} deg)", fontsize=9)
    return fig
