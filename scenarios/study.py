"""The cleaning study: the insulator-cleaning task under each strategy, supply pressure and seed.

One sweep (scenarios/sweep.py) of `scenarios/insulator_cleaning.toml` over `control.strategy` x
`supply.pressure_mpa` x child seeds. Per run: discs cleaned out of 8 (each judged from MuJoCo's
contacts: pressed long enough, force in the band, face on the rim), the peak force on each disc,
the rim brushed, when the plan was finished, and the joints' final errors. Written as
`study.json` (every run's summary), `study.csv` and `study.md` (a row per strategy and supply)
and `study.png` (discs cleaned and time to finish against supply).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scenarios.schema import STRATEGIES, load
from scenarios.sweep import sweep

SCENARIO = Path(__file__).resolve().parent / "insulator_cleaning.toml"
SUPPLIES_MPA = (0.5, 0.6, 0.7, 0.8)  # the paper's working range


@dataclass(frozen=True, kw_only=True)
class Row:
    """One strategy at one supply, over its seeds."""

    strategy: str
    supply_mpa: float
    runs: int
    cleaned_min: int
    cleaned_mean: float
    peak_force_n: float  # largest peak force on any disc, over the runs
    brushed_m: float  # mean rim brushed per run, all discs
    finished_s: float  # mean time the plan was finished (NaN: some run did not finish)
    final_error_deg: float  # mean of the largest |final error| over the joints


def run_study(
    strategies=STRATEGIES,
    supplies_mpa=SUPPLIES_MPA,
    seeds: int = 2,
    workers: int = 0,
    duration_s: float | None = None,
    scenario_path: Path = SCENARIO,
    progress: bool = True,
    finished: dict[int, dict] | None = None,
) -> list[dict]:
    """Every run's summary (sweep order: strategy, supply, seed); `finished` as sweep's."""
    grid = {"control.strategy": list(strategies), "supply.pressure_mpa": list(supplies_mpa)}
    how = {"workers": workers, "duration_s": duration_s, "progress": progress, "finished": finished}
    return sweep(load(scenario_path), grid, monte_carlo=seeds, **how)


def cleaned(summary: dict) -> int:
    return sum(bool(d["cleaned"]) for d in summary["discs"])


def rows(results: list[dict]) -> list[Row]:
    groups: dict[tuple[str, float], list[dict]] = {}
    for r in results:
        key = (r["overrides"]["control.strategy"], float(r["overrides"]["supply.pressure_mpa"]))
        groups.setdefault(key, []).append(r)
    out = []
    for (strategy, mpa), runs in groups.items():
        n = [cleaned(r) for r in runs]
        peaks = [d["peak_force_n"] for r in runs for d in r["discs"] if d["peak_force_n"] is not None]
        finished = [r["finished_s"] for r in runs]
        errors = [max(abs(j["error_deg"]) for j in r["joints"].values() if j["error_deg"] is not None) for r in runs]
        out.append(
            Row(
                strategy=strategy,
                supply_mpa=mpa,
                runs=len(runs),
                cleaned_min=min(n),
                cleaned_mean=float(np.mean(n)),
                peak_force_n=max(peaks) if peaks else math.nan,
                brushed_m=float(np.mean([sum(d["brushed_m"] for d in r["discs"]) for r in runs])),
                finished_s=float(np.mean(finished)) if all(f is not None for f in finished) else math.nan,
                final_error_deg=float(np.mean(errors)),
            )
        )
    return out


def table(study_rows: list[Row]) -> str:
    """A markdown table, one line per strategy and supply."""
    lines = [
        "| strategy | supply MPa | runs | discs cleaned (min / mean of 8) | largest peak force N | rim brushed m "
        "| plan finished s | largest final error deg |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in study_rows:
        finished = "not finished" if math.isnan(r.finished_s) else f"{r.finished_s:.1f}"
        peak = "-" if math.isnan(r.peak_force_n) else f"{r.peak_force_n:.0f}"
        lines.append(
            f"| {r.strategy} | {r.supply_mpa:g} | {r.runs} | {r.cleaned_min} / {r.cleaned_mean:.2f} | {peak} | "
            f"{r.brushed_m:.2f} | {finished} | {r.final_error_deg:.2f} |"
        )
    return "\n".join(lines)


def plot(study_rows: list[Row], path: Path) -> None:
    fig = Figure(figsize=(10, 4))
    ax1, ax2 = fig.subplots(1, 2)
    for strategy in dict.fromkeys(r.strategy for r in study_rows):
        mine = sorted((r for r in study_rows if r.strategy == strategy), key=lambda r: r.supply_mpa)
        x = [r.supply_mpa for r in mine]
        ax1.plot(x, [r.cleaned_mean for r in mine], "o-", label=strategy)
        ax2.plot(x, [r.finished_s for r in mine], "o-", label=strategy)
    ax1.set(
        xlabel="supply (MPa gauge)",
        ylabel="discs cleaned (mean over seeds)",
        ylim=(-0.3, 8.3),
        title="discs cleaned of 8",
    )
    ax2.set(xlabel="supply (MPa gauge)", ylabel="s", title="plan finished (missing: not finished)")
    ax1.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def rows_table(study_rows: list[Row]) -> dict[str, list]:
    """The rows as columns named by Row's fields (units in the names' comments of Row)."""
    return {f.name: [getattr(r, f.name) for r in study_rows] for f in fields(Row)}


def write_csv(study_rows: list[Row], path: Path) -> None:
    """A row per strategy and supply, a column per Row field (NaN written as empty)."""
    columns = rows_table(study_rows)
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(columns)
        for r in zip(*columns.values(), strict=True):
            out.writerow(["" if isinstance(v, float) and math.isnan(v) else v for v in r])


def write(results: list[dict], out: Path) -> list[Row]:
    """study.json, study.csv, study.md and study.png in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "study.json").write_text(json.dumps(results, indent=2))
    study_rows = rows(results)
    (out / "study.md").write_text("# Cleaning study\n\n" + table(study_rows) + "\n")
    write_csv(study_rows, out / "study.csv")
    plot(study_rows, out / "study.png")
    return study_rows
