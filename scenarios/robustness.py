"""The cleaning task's robustness study: the shipped scenario with one thing at a time not as planned.

`twin study cleaning --robustness`: `scenarios/insulator_cleaning.toml` (the operator's strategy)
run for each case below, one factor at a time, over child seeds (scenarios/sweep.py). The string
is moved (`[string]`, where the operator must find it in his pictures); the payload, the friction
and the brush spring differ from what the platform is told (`[reality]`); the camera is coarser
(`[operator]`); the supply is at either end of the paper's 0.5-0.8 MPa. Per run, from its summary
(`twin run --json`): the discs cleaned (each judged from MuJoCo's contacts by the scenario's disc
criteria), the largest contact force at the physics rate (the peak over each 0.5 ms step), the
task's time and each disc's coverage (scenarios/cleaning.py: the shares of rim and top face the
brush went over in its force band). Goals (issue 37): >= 95 % of runs clean all the discs, no run
above MAX_FORCE_N, the median task time against the shipped scenario's. A disc the arm cannot
reach from where the platform stands is left out of the plan (scenarios/plan.py), said so by the
operator, and counts as not cleaned; the table says how many, and the goals count the runs with such
a disc apart (`outside_workspace`): the share of the other runs that cleaned every disc beside the
share of all.

Written as `robustness.json` (every run's summary), `robustness.md` (a row per case and the
goals), `robustness.csv` and `robustness.png` (per case the largest force and the task time).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from scenarios.runner import build_plant, plan
from scenarios.schema import ScenarioError, load, with_overrides
from scenarios.study import SCENARIO, cleaned
from scenarios.sweep import child_seeds, sweep

MAX_FORCE_N = 150.0  # no run above this, anywhere (issue 37)
ALL_CLEANED_SHARE = 0.95  # the share of runs that must clean every disc (issue 37)
SHIPPED = "shipped"
CAMERA = {"operator.width_px": 640, "operator.height_px": 480}  # the shipped camera (scenarios/schema.py)

# (label, overrides of the shipped scenario): one factor at a time, at the ends of issue 37's ranges
CASES: tuple[tuple[str, dict], ...] = (
    (SHIPPED, {}),
    # the scene file's string: x 0.75, y 0, top z 1.25 m. 10 cm closer, the arm parked at home would
    # have its brush inside disc 5: the crew parks it swung aside, as the plan's first move puts it
    ("string x -10 cm", {"string.x_m": 0.65, "start.angles_deg.base_yaw": 40.0}),
    ("string x +10 cm", {"string.x_m": 0.85}),
    ("string y -10 cm", {"string.y_m": -0.10}),
    ("string y +10 cm", {"string.y_m": 0.10}),
    ("string z -10 cm", {"string.top_z_m": 1.15}),
    ("string z +10 cm", {"string.top_z_m": 1.35}),
    ("string yaw -10 deg", {"string.yaw_deg": -10.0}),
    ("string yaw +10 deg", {"string.yaw_deg": 10.0}),
    ("payload -10 %", {"reality.payload_mass_ratio": 0.9}),
    ("payload +10 %", {"reality.payload_mass_ratio": 1.1}),
    ("friction +30 %", {"reality.friction_ratio": 1.3}),
    ("spring x0.7", {"reality.brush_spring_ratio": 0.7}),
    ("spring x1.4", {"reality.brush_spring_ratio": 1.4}),
    ("camera 160x120", {"operator.width_px": 160, "operator.height_px": 120}),
    ("camera 320x240", {"operator.width_px": 320, "operator.height_px": 240}),
    ("supply 0.5 MPa", {"supply.pressure_mpa": 0.5}),
    ("supply 0.8 MPa", {"supply.pressure_mpa": 0.8}),
)
LABELS = tuple(label for label, _ in CASES)


@dataclass(frozen=True, kw_only=True)
class RobustnessRow:
    """One case over its seeds."""

    case: str
    runs: int
    all_cleaned: float  # share of runs that cleaned every disc of the string
    passed: float  # share of runs that passed every criterion of the scenario
    peak_force_n: float  # the largest contact force of any run, at the physics rate
    task_time_s: float  # median time the plan was finished (inf: a run never finished it)
    rim_share_min: float  # the least rim coverage of any disc in any run (0..1)
    top_share_min: float  # the least top-face coverage of any disc in any run (0..1)
    refused: bool = False  # the plan cannot be made (the string out of the arm's reach): not run
    out_of_reach: int = 0  # the most discs of a run that the operator said were out of the arm's reach


def cases_named(labels) -> list[tuple[str, dict]]:
    """The CASES with these labels, in CASES' order; ValueError naming an unknown one."""
    unknown = [x for x in labels if x not in LABELS]
    if unknown:
        raise ValueError(f"unknown robustness case {unknown[0]!r}; allowed: {', '.join(LABELS)}")
    return [c for c in CASES if c[0] in labels]


def run_robustness(
    cases: list[tuple[str, dict]] | None = None,
    seeds: int = 3,
    workers: int = 0,
    duration_s: float | None = None,
    scenario_path: Path = SCENARIO,
    progress: bool = True,
    finished: dict[int, dict] | None = None,
) -> list[dict]:
    """Every run's summary with its case's label (`case`), in CASES' order then the seeds'. A case
    whose plan cannot be made (the string out of the arm's reach) is not run: each of its seeds
    counts as a failed run that cleaned nothing, its reason in `refused`."""
    chosen = list(CASES) if cases is None else cases
    scenario = load(scenario_path)
    unplanned = {label: _unplannable(scenario, o) for label, o in chosen}
    runnable = [o for label, o in chosen if not unplanned[label]]
    how = {"workers": workers, "duration_s": duration_s, "progress": progress, "finished": finished}
    ran = iter(sweep(scenario, monte_carlo=seeds, cases=runnable, **how) if runnable else [])
    out = []
    for label, o in chosen:
        for seed in child_seeds(scenario.seed, seeds):
            if unplanned[label]:
                out.append(_refused(label, {**o, "seed": seed}, unplanned[label]))
            else:
                out.append({"case": label, **next(ran)})
    return out


def _unplannable(scenario, overrides: dict) -> str:
    """Why the plan cannot be made for the case (its string out of the brush's reach), or ""."""
    case = with_overrides(scenario, overrides)
    try:
        plan(case, build_plant(case))
    except ScenarioError as e:
        return str(e).split(": ", 1)[-1]
    return ""


def _refused(label: str, overrides: dict, why: str) -> dict:
    """A run's summary for a case whose plan cannot be made: nothing cleaned, nothing finished."""
    return {"case": label, "overrides": overrides, "passed": False, "refused": why, "finished_s": None}


def case_of(overrides: dict) -> str:
    """The label of the case whose overrides these are (the seed aside)."""
    mine = {k: v for k, v in overrides.items() if k != "seed"}
    return next(label for label, o in CASES if o == mine)


def largest_force_n(summary: dict) -> float:
    """A run's largest contact force (N): its contact_force_n criterion's value where it has one
    (every contact at the physics rate), else its discs' peaks (0: not run)."""
    criteria = summary.get("criteria", [])
    judged = [c["value"] for c in criteria if c["kind"] == "contact_force_n" and c["value"] is not None]
    peaks = [d["peak_force_n"] for d in summary.get("discs", []) if d["peak_force_n"] is not None]
    return max(judged + peaks, default=0.0)


def discs_out_of_reach(summary: dict) -> int:
    """How many discs the plan left out of a run, the operator saying they are out of the arm's reach
    from where the platform stands (scenarios/task.py); they count as not cleaned."""
    return sum("out of the arm's reach" in e for e in summary.get("controller_events", []))


def outside_workspace(summary: dict) -> bool:
    """The run's string has a disc outside the arm's workspace: one its plan left out (out of the
    arm's reach from where the platform stands, at any tilt of the tool, scenarios/plan.py), or no
    plan at all (no disc within reach). Such a run cannot clean every disc whatever the operator
    does: the goals count it apart, and say so."""
    return bool(summary.get("refused")) or discs_out_of_reach(summary) > 0


def all_cleaned(summary: dict) -> bool:
    """The run cleaned every disc of its string (a run not made cleaned none)."""
    return bool(summary.get("discs")) and cleaned(summary) == len(summary["discs"])


def rows(results: list[dict]) -> list[RobustnessRow]:
    groups: dict[str, list[dict]] = {}
    for r in results:
        groups.setdefault(r["case"], []).append(r)
    out = []
    for case in sorted(groups, key=lambda c: LABELS.index(c) if c in LABELS else len(LABELS)):
        runs = groups[case]
        discs = [d for r in runs for d in r.get("discs", [])]
        out.append(
            RobustnessRow(
                case=case,
                runs=len(runs),
                all_cleaned=float(np.mean([all_cleaned(r) for r in runs])),
                passed=float(np.mean([bool(r["passed"]) for r in runs])),
                peak_force_n=max(largest_force_n(r) for r in runs),
                task_time_s=float(np.median([math.inf if r["finished_s"] is None else r["finished_s"] for r in runs])),
                rim_share_min=min((d["rim_share"] for d in discs), default=0.0),
                top_share_min=min((d["top_share"] for d in discs), default=0.0),
                refused=any(r.get("refused") and "discs" not in r for r in runs),
                out_of_reach=max(discs_out_of_reach(r) for r in runs),
            )
        )
    return out


def goals(results: list[dict]) -> dict[str, float]:
    """The study's figures against its goals: the share of runs that cleaned every disc, the largest
    force of any run, the median task time over all runs and the shipped case's."""
    times = [math.inf if r["finished_s"] is None else r["finished_s"] for r in results]
    shipped = [t for r, t in zip(results, times, strict=True) if r["case"] == SHIPPED]
    within = [r for r in results if not outside_workspace(r)]
    return {
        "runs": len(results),
        "all_cleaned": float(np.mean([all_cleaned(r) for r in results])),
        # the runs whose every disc the arm can reach, and the share of them that cleaned every disc
        "within_reach_runs": len(within),
        "all_cleaned_within_reach": float(np.mean([all_cleaned(r) for r in within])) if within else math.nan,
        "peak_force_n": max(largest_force_n(r) for r in results),
        "task_time_s": float(np.median(times)),
        "shipped_task_time_s": float(np.median(shipped)) if shipped else math.nan,
    }


def _time(s: float) -> str:
    return "not finished" if math.isinf(s) else "-" if math.isnan(s) else f"{s:.1f}"


def table(study_rows: list[RobustnessRow], figures: dict[str, float]) -> str:
    """A markdown table, one line per case, and the goals under it."""
    lines = [
        "| case | runs | all discs cleaned | passed | largest force N | median task time s "
        "| least rim coverage | least top coverage | discs out of reach |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in study_rows:
        force = f"**{r.peak_force_n:.0f}**" if r.peak_force_n > MAX_FORCE_N else f"{r.peak_force_n:.0f}"
        if r.refused:
            force = "out of reach: not run"
        lines.append(
            f"| {r.case} | {r.runs} | {r.all_cleaned:.0%} | {r.passed:.0%} | {force} | {_time(r.task_time_s)} "
            f"| {r.rim_share_min:.0%} | {r.top_share_min:.0%} | {r.out_of_reach} |"
        )
    f = figures
    lines += [
        "",
        f"All {f['runs']} runs: {f['all_cleaned']:.0%} cleaned every disc (goal >= {ALL_CLEANED_SHARE:.0%}); "
        f"largest force {f['peak_force_n']:.0f} N (goal <= {MAX_FORCE_N:.0f} N); median task time "
        f"{_time(f['task_time_s'])} s against the shipped scenario's {_time(f['shipped_task_time_s'])} s.",
    ]
    outside = f["runs"] - f["within_reach_runs"]
    if outside:
        within = (
            "no other runs"
            if not f["within_reach_runs"]
            else (f"of the other {f['within_reach_runs']}, {f['all_cleaned_within_reach']:.0%} cleaned every disc")
        )
        lines.append(
            f"{outside} of the {f['runs']} runs have a disc outside the arm's workspace (out of its reach from "
            f"where the platform stands, at any tilt of the tool: counted as not cleaned above); {within}."
        )
    return "\n".join(lines)


def plot(study_rows: list[RobustnessRow], figures: dict[str, float], path: Path) -> None:
    """Per case: the largest force (the MAX_FORCE_N goal marked) and the median task time (the
    shipped scenario's marked); a case with a run that left a disc uncleaned in red."""
    fig = Figure(figsize=(8, 0.22 * len(study_rows) + 1.2))
    ax1, ax2 = fig.subplots(1, 2, sharey=True)
    y = np.arange(len(study_rows))
    colour = ["tab:blue" if r.all_cleaned == 1.0 else "tab:red" for r in study_rows]
    ax1.barh(y, [r.peak_force_n for r in study_rows], color=colour)
    ax1.axvline(MAX_FORCE_N, color="k", lw=1, ls="--")
    for k, r in enumerate(study_rows):
        if r.peak_force_n == 0.0:  # no bar to see: say why
            why = "out of reach: not run" if r.refused else "nothing touched"
            ax1.text(5.0, k, why, va="center", fontsize=6, color="tab:red")
    finite = [r.task_time_s if math.isfinite(r.task_time_s) else 0.0 for r in study_rows]
    ax2.barh(y, finite, color=colour)
    ax2.axvline(figures["shipped_task_time_s"], color="k", lw=1, ls="--")
    ax1.set_yticks(y, [r.case for r in study_rows], fontsize=7)
    ax1.invert_yaxis()
    ax1.set(xlabel="largest contact force, N (- - 150 N)")
    ax2.set(xlabel="median task time, s (- - shipped; 0: not finished)")
    ax1.set_title("red: a run left a disc uncleaned", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=72)


def write(results: list[dict], out: Path) -> list[RobustnessRow]:
    """robustness.json, .md, .csv and .png in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "robustness.json").write_text(json.dumps(results, indent=2))
    study_rows, figures = rows(results), goals(results)
    (out / "robustness.md").write_text("# Cleaning robustness study\n\n" + table(study_rows, figures) + "\n")
    with open(out / "robustness.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([x.name for x in fields(RobustnessRow)])
        for r in study_rows:
            w.writerow([getattr(r, x.name) for x in fields(RobustnessRow)])
    plot(study_rows, figures, out / "robustness.png")
    return study_rows
