"""`twin paper --out DIR`: the paper's experiments (Sec. III-IV) run in the twin, side by side
with the paper's figures, into DIR/paper.json, DIR/report.md and PNG plots.

Reality is the as-built wrist (assets/as_built/wrist_pitch.toml: the nominal joint plus what the
real one has, some of it calibrated on the model-validation figures only); the predictor is the
nominal model (assets/joints/wrist_pitch.toml). Every number comes from a run made here:

- model validation, Fig. 10-16 (scenarios/paper_validation.py): 1 s fully open at each supply,
  the as-built plant measured, the nominal model with and without the hose loss predicting from
  the same commands; the joint's speed against supply from the same runs;
- random supply, Fig. 18-19; minimum rotation, Fig. 21; closed against open loop 20-90 deg,
  Fig. 23; closed-loop error against supply, Fig. 20, twice: the arm's loop (it brakes on
  arrival) and Fig. 17's loop as drawn (the PID holds the joint on the valve)
  (control.experiments, on the wrist rig).
These are predictions: nothing in them was fitted to the paper.
"""

from __future__ import annotations

import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr
from tqdm import tqdm

import assets
from control.experiments import (
    closed_vs_open_loop,
    error_against_pressure,
    held_error_against_pressure,
    minimum_rotation_limit,
    random_supply,
    random_supply_moves,
)
from pneumatics.as_built import load_as_built_effects
from scenarios.paper_report import write_plots, write_report
from scenarios.paper_validation import KINDS, OPEN_S, PAPER, PRESSURES_MPA, rig_inertia, validation_run, wrist_models
from twin.plant import Plant
from twin_plumbing.outputs import write_atomic

P_ATM_PA = 101_325.0

PAPER_RANDOM_SUPPLY_MAX_DEG = 4.33  # Fig. 19 (manual operation: 8.35 deg on average)
PAPER_MANUAL_DEG = 8.35
PAPER_MIN_ROTATION_DEG = 20.0  # Fig. 21
PAPER_CLOSED_LOOP_DEG = (1.60, 2.02)  # Fig. 23: final error range over 20-90 deg
PAPER_CLOSED_LOOP_MEAN_DEG = 1.84
PAPER_OPEN_LOOP_DEG = (4.04, 7.18)
PAPER_FIG20_AT_05_DEG = 3.0  # Fig. 20: "limited to the range of -3 ~ 3 deg under 0.5 MPa", growing with pressure
# the motor's maximum-power speed (Sec. III-B: 1UP-NRV-3A, 6000 rpm) at the joint through 1:120
MAX_POWER_JOINT_DEG_S = 6000.0 / 60.0 * 360.0 / 120.0
SPEED_PRESSURES_MPA = (0.3, 0.4) + PRESSURES_MPA
RANDOM_SUPPLY_SEED = 7
# Fig. 23 as Sec. IV sets it: "the rotation angle ... is set to 20, 21, 22 deg, and so on, up to 90 deg"
FIG23_ANGLES_DEG = tuple(range(20, 91))
# Fig. 20 under Fig. 17's loop (8 s holds at four supplies): the same span every 10 deg (the paper
# names no angles for Fig. 20; 71 holds at each supply would cost 20 min)
HELD_ANGLES_DEG = tuple(range(20, 91, 10))
TREND_P = 0.05  # a trend "grows" when Spearman's rank correlation is positive at this significance


def _speeds(t: np.ndarray, angle_deg: np.ndarray) -> tuple[float, float]:
    """(mean speed over the open second's last half, peak speed), deg/s."""
    v = np.gradient(angle_deg, t)
    w = (t > 0.5 * OPEN_S) & (t <= OPEN_S + 1e-9)
    return float(v[w].mean()), float(v[t <= OPEN_S + 1e-9].max())


def prediction_validation() -> tuple[dict, dict]:
    """Fig. 10-16 and the speed against supply: (results, the runs' time series for the plots)."""
    nominal, reality = wrist_models()
    inertia = rig_inertia(nominal)
    runs = {m: validation_run(reality, nominal, m, inertia) for m in SPEED_PRESSURES_MPA}
    errors = {}
    series = {}
    for m in PRESSURES_MPA:
        r = runs[m]
        e = r.errors()
        errors[m] = {k: {**e[k], "paper_mean": PAPER[k]["mean"][m], "paper_max": PAPER[k]["max"][m]} for k in KINDS}
        errors[m]["predictor_gap_mean_deg"] = r.predictor_gap()["mean"]
        errors[m]["paper_pair_unreachable"] = list(r.unreachable())
        errors[m]["paper_gap_bound_deg"] = PAPER["with_hose_loss"]["mean"][m] + PAPER["without_hose_loss"]["mean"][m]
        series[m] = {"time_s": r.time_s.tolist(), "measured_deg": r.measured_deg.tolist()}
        series[m] |= {k: r.predicted_deg[k].tolist() for k in KINDS}
    speed = {}
    for m, r in runs.items():
        real = _speeds(r.time_s, r.measured_deg)
        nom = _speeds(r.time_s, r.predicted_deg["with_hose_loss"])
        speed[m] = {
            "as_built_mean_deg_s": real[0],
            "as_built_peak_deg_s": real[1],
            "nominal_mean_deg_s": nom[0],
            "nominal_peak_deg_s": nom[1],
            "turn_in_1s_deg": float(np.interp(OPEN_S, r.time_s, r.measured_deg)),
        }

    def grows_as_pressure_falls(kind: str) -> bool:
        by_falling = [errors[m][kind]["mean"] for m in sorted(PRESSURES_MPA, reverse=True)]
        return all(b > a for a, b in itertools.pairwise(by_falling))

    results = {
        "errors": errors,
        "without_grows_as_pressure_falls": grows_as_pressure_falls("without_hose_loss"),
        "with_grows_as_pressure_falls": grows_as_pressure_falls("with_hose_loss"),
        "with_smaller_than_without_everywhere": all(
            errors[m]["with_hose_loss"]["mean"] < errors[m]["without_hose_loss"]["mean"] for m in PRESSURES_MPA
        ),
        "speed_against_supply": speed,
        "max_power_joint_deg_s": MAX_POWER_JOINT_DEG_S,
    }
    return results, series


def _rig_factory(reality):
    def make():
        p = Plant(assets.WRIST_RIG_XML, {"wrist_pitch": reality})
        p.set_supply(P_ATM_PA + 0.5e6)
        return p

    return make


def random_supply_run(quick: bool) -> dict:
    """Fig. 18-19: the wrist moved 0 -> 45 -> 0 -> -45 -> 0 deg (twice in full) under a random
    supply; the largest final error of a move."""
    nominal, reality = wrist_models()
    targets = (45.0, 0.0, -45.0, 0.0) * (1 if quick else 2)
    ends: list[float] = []
    errors, t = random_supply_moves(
        _rig_factory(reality), nominal, targets_deg=targets, seed=RANDOM_SUPPLY_SEED, end_times_s=ends
    )
    supply = random_supply(RANDOM_SUPPLY_SEED)  # the same draws the run saw
    times = np.arange(0.0, t, 0.5)
    return {
        "move_end_s": ends,
        "supply_time_s": times.tolist(),
        "supply_gauge_mpa": [(supply.value_at(x) - P_ATM_PA) / 1e6 for x in times],
        "max_error_deg": max(errors),
        "final_errors_deg": errors,
        "duration_s": t,
        "paper_max_error_deg": PAPER_RANDOM_SUPPLY_MAX_DEG,
        "paper_manual_mean_deg": PAPER_MANUAL_DEG,
    }


def _trend(x, y) -> dict:
    """Spearman's rank correlation of y with x, its p-value, and whether y grows (TREND_P)."""
    rho, p = spearmanr(x, y)
    return {"spearman_rho": float(rho), "p_value": float(p), "grows": bool(rho > 0.0 and p < TREND_P)}


def closed_against_open(quick: bool) -> dict:
    """Fig. 23: final error of closed and open loop at 0.5 MPa, 20-90 deg (every 1 deg, as the paper)."""
    nominal, reality = wrist_models()
    angles = (20, 50, 90) if quick else FIG23_ANGLES_DEG
    res = closed_vs_open_loop(_rig_factory(reality), angles_deg=angles, predictor_params=nominal)
    closed = [res[a][0] for a in angles]
    opened = [res[a][1] for a in angles]
    return {
        "angles_deg": list(angles),
        "closed_loop_error_deg": closed,
        "open_loop_error_deg": opened,
        # the open loop's own prediction at its end: where it lands, the valve time was right for the model
        "open_loop_predicted_error_deg": [res[a][2] for a in angles],
        "closed_loop_mean_deg": float(np.mean(closed)),
        "open_loop_mean_deg": float(np.mean(opened)),
        "closed_beats_open_everywhere": all(res[a][0] < res[a][1] for a in angles),
        # paper: "with the increase of the rotation angle, the error of the open-loop control method and
        # close-loop control method will increase": a rank trend over the 71 rotations, not every step
        "open_trend": _trend(angles, opened),
        "closed_trend": _trend(angles, closed),
        "paper_closed_loop_range_deg": list(PAPER_CLOSED_LOOP_DEG),
        "paper_closed_loop_mean_deg": PAPER_CLOSED_LOOP_MEAN_DEG,
        "paper_open_loop_range_deg": list(PAPER_OPEN_LOOP_DEG),
    }


def error_vs_pressure(quick: bool) -> dict:
    """Fig. 20: closed-loop final error against the supply (moves of 30, 60, 90 deg from 0)."""
    nominal, reality = wrist_models()
    angles = (60,) if quick else (30, 60, 90)
    pressures = (0.5, 0.8) if quick else PRESSURES_MPA
    res = error_against_pressure(_rig_factory(reality), pressures, angles, nominal)
    means = [float(np.mean(res[m])) for m in pressures]
    return {
        "pressures_mpa": list(pressures),
        "angles_deg": list(angles),
        "errors_deg": {str(m): res[m] for m in pressures},
        "mean_error_deg": means,
        "max_error_deg": [float(np.max(res[m])) for m in pressures],
        "grows_with_pressure": all(b > a for a, b in itertools.pairwise(means)),
        "paper_bound_at_05_deg": PAPER_FIG20_AT_05_DEG,
        "fig17_loop": _held_vs_pressure(quick, nominal, reality, pressures),
    }


def _held_vs_pressure(quick: bool, nominal, reality, pressures) -> dict:
    # Fig. 20 under Fig. 17's loop as drawn (control.experiments.held_on_valve): the PID holds the
    # joint on the valve, 8 s from the move's start, the error the largest over the last 3 s; Fig.
    # 23's span, every 10 deg (over 30/60/90 alone the truth's mean is not monotonic:
    # docs/validation/as_built_and_paper.md)
    angles = (30, 90) if quick else HELD_ANGLES_DEG
    res = held_error_against_pressure(_rig_factory(reality), pressures, angles, nominal)
    true = [float(np.mean([e[0] for e in res[m]])) for m in pressures]
    own = [float(np.mean([e[1] for e in res[m]])) for m in pressures]
    return {
        "angles_deg": list(angles),
        "hold_s": 8.0,
        "window_s": 3.0,
        "true_mean_error_deg": true,
        "predicted_mean_error_deg": own,
        "true_max_error_deg": [float(max(e[0] for e in res[m])) for m in pressures],
        "true_grows_with_pressure": all(b > a for a, b in itertools.pairwise(true)),
        "predicted_grows_with_pressure": all(b > a for a, b in itertools.pairwise(own)),
    }


def minimum_rotation(quick: bool) -> dict:
    """Fig. 21: the smallest commanded rotation from which the loop still adjusts."""
    nominal, reality = wrist_models()
    angles = tuple(range(4, 41, 4)) if quick else tuple(range(2, 41, 2))
    limit = minimum_rotation_limit(_rig_factory(reality), predictor_params=nominal, angles_deg=angles)
    # None (JSON null): not even the largest tested rotation is adjusted
    return {
        "limit_deg": limit if math.isfinite(limit) else None,
        "tested_deg": list(angles),
        "paper_limit_deg": PAPER_MIN_ROTATION_DEG,
    }


def as_built_table() -> list[dict]:
    """The as-built wrist's effects (field, nominal, as-built, source, basis) for the report."""
    nominal, _ = wrist_models()
    return [
        {
            "field": e.field,
            "nominal": getattr(nominal, e.field),
            "as_built": e.value,
            "source": e.source,
            "basis": e.basis,
        }
        for e in load_as_built_effects(assets.as_built_path("wrist_pitch"))
    ]


# the control experiments, in the order they run; each takes `quick`
EXPERIMENTS = {
    "random_supply": random_supply_run,
    "minimum_rotation": minimum_rotation,
    "closed_vs_open_loop": closed_against_open,
    "error_vs_pressure": error_vs_pressure,
}
PARTIAL = "paper.partial.json"  # the experiments finished so far, while the others run


def reproduce(out_dir: str | Path, quick: bool = False, progress: bool = False) -> Path:
    """Run every experiment, write paper.json, report.md and the plots; returns the report's path.
    `quick` shortens the control experiments (fewer angles and supplies), not the validation;
    `progress` shows a bar of the experiments on stderr. After each experiment, PARTIAL holds every
    result so far (marked partial, with the experiments not yet run): what a stopped reproduction
    keeps. It is removed once paper.json is written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with tqdm(
        total=2 + len(EXPERIMENTS), desc="paper", unit="experiment", file=sys.stderr, disable=not progress
    ) as bar:
        bar.set_postfix_str("prediction error")
        validation, series = prediction_validation()
        bar.update()
        bar.set_postfix_str("as built")
        results = {"as_built": as_built_table(), "prediction_error": validation}
        bar.update()
        for name, experiment in EXPERIMENTS.items():
            left = [n for n in EXPERIMENTS if n not in results]
            write_atomic(
                out / PARTIAL, json.dumps({**results, "partial": True, "not_run": left}, indent=2, default=float)
            )
            bar.set_postfix_str(name.replace("_", " "))
            results[name] = experiment(quick)
            bar.update()
    results["quick"] = quick
    (out / "paper.json").write_text(json.dumps({**results, "validation_series": series}, indent=2, default=float))
    (out / PARTIAL).unlink()
    write_plots(results, series, out)
    return write_report(results, out)
