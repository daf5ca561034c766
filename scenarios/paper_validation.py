"""The paper's model validation (Sec. III-C, Fig. 10-16) and the fit of the as-built unknowns on it.

Protocol (the paper's, as written): at each supply 0.5-0.8 MPa the wrist is released and its
valve opened fully for 1 s; the measured angle (here: the as-built plant's) is compared with two
predictions driven by the same commands, the nominal model with the hose's pressure loss and
without it (wrist_rig.one_joint: the predictor's own one-joint model). The error is |measured - predicted|
over that 1 s ("in a one second simulation", Sec. III-C): its mean and its max. The run starts at
-85 deg so the move stays inside the wrist's -90..90 deg slewing area (Sec. IV).

`fit_as_built` calibrates the as-built file's "calibrated" effects on these figures only: it
minimises the squared log-ratios of the 16 twin numbers (mean and max, with and without the loss,
four supplies) to the paper's, less those the nominal model puts out of any reality's reach
(`ValidationRun.unreachable`), with the one-joint model standing in for the plant (the same
physics; the plant agrees with it to a few tenths of a degree, tests/test_plant.py).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

import assets
from control.arm_model import ArmModel
from pneumatics import JointParams, load_joint_params, paper_model, params_row
from pneumatics.as_built import load_as_built
from wrist_rig.commanded_run import SAMPLE_PERIOD_S, Motion, simulate_run
from wrist_rig.one_joint import DT_S, replay_run

JOINT = "wrist_pitch"
PRESSURES_MPA = (0.5, 0.6, 0.7, 0.8)
OPEN_S = 1.0  # the valve is fully open for 1 s (Sec. III-C, result 5: "in a one second simulation")
START_DEG = -85.0  # near one end of the slewing area (-90..90 deg, Sec. IV)
MOTION = Motion(t_release_s=0.0, t_move_s=OPEN_S, t_reverse_s=0.0, t_hold_s=0.5)
KINDS = ("with_hose_loss", "without_hose_loss")

# the paper's numbers, Sec. III-C (supply MPa -> deg); "about 40" is the text's own rounding
PAPER = {
    "with_hose_loss": {
        "mean": {0.8: 1.2, 0.7: 2.0, 0.6: 2.2, 0.5: 5.4},
        "max": {0.8: 3.3, 0.7: 4.1, 0.6: 4.3, 0.5: 7.9},
    },
    "without_hose_loss": {
        "mean": {0.8: 3.2, 0.7: 13.4, 0.6: 14.3, 0.5: 22.2},
        "max": {0.8: 6.1, 0.7: 22.3, 0.6: 27.2, 0.5: 40.0},
    },
}


def wrist_models() -> tuple[JointParams, JointParams]:
    """(nominal, as-built) parameters of the wrist: the predictor's (the paper's model of the joint
    file, `paper_model`) and reality's (the joint file's physics with the as-built effects)."""
    nominal = load_joint_params(assets.joint_param_path(JOINT))
    return paper_model(nominal), load_as_built(nominal, assets.as_built_path(JOINT))


def rig_inertia(params: JointParams) -> float:
    """Joint-side inertia of the wrist rig as the predictor takes it: Pinocchio's rig load plus the
    reflected rotor (control/controller.py does the same sum)."""
    arm = ArmModel(assets.WRIST_RIG_XML, (JOINT,), None)
    return float(arm.drive_inertias(np.zeros(1))[0]) + params.ratio**2 * params.rotor_inertia_kg_m2


@dataclass(kw_only=True)
class ValidationRun:
    """One supply's run: time (s), measured angle and the two predictions (deg, from the start),
    on the SAMPLE_PERIOD_S grid up to the end of the hold."""

    supply_mpa: float
    time_s: np.ndarray
    measured_deg: np.ndarray
    predicted_deg: dict[str, np.ndarray]

    def errors(self) -> dict[str, dict[str, float]]:
        """{kind: {"mean", "max"}} of |measured - predicted| over the 1 s the valve is open."""
        w = self.time_s <= OPEN_S + 1e-9
        out = {}
        for kind, pred in self.predicted_deg.items():
            e = np.abs(self.measured_deg[w] - pred[w])
            out[kind] = {"mean": float(e.mean()), "max": float(e.max())}
        return out

    def predictor_gap(self) -> dict[str, float]:
        """{"mean", "max"} of |with - without| over the open second: the two nominal predictions'
        own distance, which no reality changes."""
        w = self.time_s <= OPEN_S + 1e-9
        gap = np.abs(self.predicted_deg[KINDS[0]][w] - self.predicted_deg[KINDS[1]][w])
        return {"mean": float(gap.mean()), "max": float(gap.max())}

    def unreachable(self) -> tuple[str, ...]:
        """The statistics ("mean", "max") whose pair of paper figures at this supply is out of any
        reality's reach: |m - a| + |m - b| >= |a - b| sample by sample, so where the two
        predictions' mean (max) distance exceeds the paper's two mean (max) errors added, no
        measured run meets both."""
        gap = self.predictor_gap()
        return tuple(s for s in ("mean", "max") if gap[s] > sum(PAPER[k][s][self.supply_mpa] for k in KINDS))

    def out_of_reach_within(self, factor: float) -> tuple[str, ...]:
        """The statistics ("mean", "max") for which no reality has both errors (with and without
        the loss) within `factor` of the paper's at this supply, whatever the as-built arm. Sample
        by sample a reality's two errors e1, e2 and the predictions' distance d obey
        |e1 - e2| <= d <= e1 + e2, and so do their means and maxima: both figures are within reach
        only if some e1 in [a / factor, a * factor] and e2 in [b / factor, b * factor] (a, b the
        paper's) are no farther apart than d and add to at least d. `unreachable()` is the upper
        half of this at factor 1."""
        gap = self.predictor_gap()
        out = []
        for stat in ("mean", "max"):
            a, b = (PAPER[k][stat][self.supply_mpa] for k in KINDS)
            nearest = max(b / factor - a * factor, a / factor - b * factor, 0.0)
            if not nearest <= gap[stat] <= (a + b) * factor:
                out.append(stat)
        return tuple(out)


def _commands(mpa: float, k_u: float) -> dict[str, np.ndarray]:
    t = np.round(np.arange(0.0, MOTION.total_s() + 1e-9, DT_S), 6)
    d, u, b = MOTION.commands(t, mpa * 1e6, k_u)
    supply = np.full(t.shape, 101_325.0 + mpa * 1e6)
    return {"time_s": t, "direction": d, "valve_set_gauge_pa": u, "brake_released": b, "supply_pa": supply}


def _replay(params: JointParams, cmd: dict[str, np.ndarray], inertia: float) -> tuple[np.ndarray, np.ndarray]:
    t, th, *_ = replay_run(
        params_row(params),
        cmd["time_s"],
        cmd["direction"],
        cmd["valve_set_gauge_pa"],
        cmd["brake_released"],
        cmd["supply_pa"],
        False,
        math.radians(START_DEG),
        inertia,
        0.0,
        MOTION.total_s(),
        DT_S,
    )
    return t, np.degrees(th) - START_DEG


def validation_run(
    reality: JointParams, nominal: JointParams, mpa: float, inertia: float, plant: bool = True
) -> ValidationRun:
    """The protocol at one supply: reality measured (the MuJoCo plant, or with `plant` False the
    one-joint model), both predictions from the same commands."""
    if plant:
        run = simulate_run(reality, mpa, MOTION, start_rad=math.radians(START_DEG))
        ok = np.isfinite(run["angle_rad"])
        t, measured = run["time_s"][ok], np.degrees(run["angle_rad"][ok]) - START_DEG
        cmd = {k: run[k] for k in ("time_s", "direction", "valve_set_gauge_pa", "brake_released", "supply_pa")}
    else:
        cmd = _commands(mpa, nominal.k_u_per_pa)
        tt, a = _replay(reality, cmd, inertia)
        step = int(round(SAMPLE_PERIOD_S / DT_S))
        t, measured = tt[::step], a[::step]
    preds = {}
    for kind, loss in zip(KINDS, (1.0, 0.0), strict=True):
        tt, a = _replay(nominal._replace(hose_loss=loss), cmd, inertia)
        preds[kind] = np.interp(t, tt, a)
    return ValidationRun(supply_mpa=mpa, time_s=t, measured_deg=measured, predicted_deg=preds)


def misfit(runs: list[ValidationRun]) -> float:
    """Sum of squared log-ratios twin/paper over mean and max, both kinds, every supply; where the
    nominal model puts the paper's pair of a statistic out of reach (`ValidationRun.unreachable`),
    the figure without the loss is left out: no as-built magnitude can meet both, and scoring it
    would pull the magnitudes off the figure of the controller's own model (with the loss)."""
    total = 0.0
    for r in runs:
        skip = {(KINDS[1], stat) for stat in r.unreachable()}
        for kind, stats in r.errors().items():
            for stat, value in stats.items():
                if (kind, stat) not in skip:
                    total += math.log(max(value, 1e-3) / PAPER[kind][stat][r.supply_mpa]) ** 2
    return total


# the calibrated unknowns and their grids: the as-built magnitudes nothing else pins down, the real
# valve/throttle conductance over nominal, the real joint's Coulomb friction, the supply line's
# droop under flow and the real brake's full-release pressure (docs/validation/as_built_and_paper.md)
FIT_GRID = {
    "conductance_scale": (0.8, 0.9, 1.0, 1.1, 1.2, 1.35),
    "coulomb_nm": (6.0, 9.0, 12.0, 15.0, 18.0),
    "supply_droop_pa_s_per_kg": (0.0, 2.5e6, 5.0e6, 1.0e7, 2.0e7),
    # the nominal brake's 4.0 bar +- 0.5 bar: the real spring's tolerance (assets/joints/wrist_pitch.toml)
    "brake_release_gauge_pa": (3.5e5, 3.75e5, 4.0e5, 4.25e5, 4.5e5),
}
# The 16 figures do not pin the four down alone (several points fit within 15 %), so a departure
# from the designer's number costs like a misfit: (ln(value / nominal) / PRIOR_LOG_SIGMA)^2, a
# factor 1.65 as much as one paper figure off by that factor (chosen before the fit; fields whose
# nominal is 0, the droop, carry no prior).
PRIOR_LOG_SIGMA = 0.5


def prior(point: dict[str, float], nominal: JointParams) -> float:
    logs = [math.log(v / getattr(nominal, f)) for f, v in point.items() if getattr(nominal, f) > 0 and v > 0]
    return sum((x / PRIOR_LOG_SIGMA) ** 2 for x in logs)


Point = dict[str, float]


def _reality(chamber_heat: float | None) -> tuple[JointParams, JointParams, float]:
    """(nominal, as-built, rig inertia); `chamber_heat` given: reality's chamber law set to it (0 the
    paper's polytropic law, 1 the energy balance), whatever the joint file says."""
    nominal, reality = wrist_models()
    if chamber_heat is not None:
        reality = reality._replace(chamber_heat=float(chamber_heat))
    return nominal, reality, rig_inertia(nominal)


def one_joint_runs(reality: JointParams, nominal: JointParams, inertia: float) -> list[ValidationRun]:
    """The protocol at the four supplies, the one-joint model standing in for the plant."""
    return [validation_run(reality, nominal, m, inertia, plant=False) for m in PRESSURES_MPA]


def fit_as_built(
    grid: dict[str, tuple[float, ...]] = FIT_GRID, chamber_heat: float | None = None
) -> tuple[Point, float, list[tuple[Point, float]]]:
    """Grid search of the calibrated as-built effects on the validation figures: (best values,
    its score = misfit + prior, every point with its score). The as-built file's other effects
    stay as it has them."""
    nominal, reality, inertia = _reality(chamber_heat)
    scored = []
    for values in itertools.product(*grid.values()):
        point = dict(zip(grid, values, strict=True))
        runs = one_joint_runs(reality._replace(**point), nominal, inertia)
        scored.append((point, misfit(runs) + prior(point, nominal)))
    best = min(scored, key=lambda s: s[1])
    return best[0], best[1], scored


# The continuous search for the energy balance (docs/air_chambers.md, "The refit on the energy
# balance, tried"): the validation error is rough in the magnitudes (a run breaks away or not by a
# few ms), and a grid of 4-6 values a magnitude misses the best points (with the walls at 0.3-3 the
# grids' best scored 8.5, differential evolution 2.9); it searches the logs of the magnitudes, within
# these bounds, on the same misfit + prior. The brake stays within its
# spring's tolerance (FIT_GRID's); the walls' scale (nominal 1: the correlations as they stand,
# pneumatics/heat.py) carries the same prior as the others, a factor e^0.5 = 1.65 costing as much
# as one figure off by it (Dittus-Boelter's own scatter is about 25 %, Incropera Sec. 8.5).
REFINE_BOUNDS = {
    "conductance_scale": (0.8, 1.4),
    "coulomb_nm": (6.0, 20.0),
    "supply_droop_pa_s_per_kg": (1.0e6, 4.0e7),
    "brake_release_gauge_pa": (3.5e5, 4.5e5),
}
WALL_BOUNDS = {"wall_heat_scale": (0.3, 3.0)}
# the vane leak freed as well (assumed 0.02 mm^2 in the as-built file; nominal 0, so no prior)
LEAK_BOUNDS = {"leak_area_m2": (5.0e-9, 1.5e-7)}


def refine_as_built(
    bounds: dict[str, tuple[float, float]] = REFINE_BOUNDS | WALL_BOUNDS,
    chamber_heat: float | None = 1.0,
    seed: int = 1,
) -> tuple[Point, float, list[ValidationRun]]:
    """Differential evolution (scipy, 12 generations of 12 x len(bounds), seeded) of the magnitudes
    in `bounds` on misfit + prior: (best values, its score, its four runs)."""
    from scipy.optimize import differential_evolution  # only this research tool needs it

    nominal, reality, inertia = _reality(chamber_heat)
    names = list(bounds)

    def score(logs: np.ndarray) -> float:
        point = dict(zip(names, np.exp(logs), strict=True))
        return misfit(one_joint_runs(reality._replace(**point), nominal, inertia)) + prior(point, nominal)

    log_bounds = [(math.log(lo), math.log(hi)) for lo, hi in bounds.values()]
    found = differential_evolution(score, log_bounds, maxiter=12, popsize=12, seed=seed, polish=False, tol=1e-6)
    point = {n: float(v) for n, v in zip(names, np.exp(found.x), strict=True)}
    return point, float(found.fun), one_joint_runs(reality._replace(**point), nominal, inertia)


def ratios_table(runs: list[ValidationRun]) -> str:
    """The 16 figures, twin and twin / paper, one line a kind and statistic (0.5/0.6/0.7/0.8 MPa)."""
    lines = []
    for kind in KINDS:
        for stat in ("mean", "max"):
            twin = [r.errors()[kind][stat] for r in runs]
            ratio = [v / PAPER[kind][stat][r.supply_mpa] for v, r in zip(twin, runs, strict=True)]
            lines.append(
                f"{kind} {stat}: "
                + "/".join(f"{v:.2f}" for v in twin)
                + " deg, x"
                + "/".join(f"{x:.2f}" for x in ratio)
            )
    return "\n".join(lines)


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m scenarios.paper_validation", description=__doc__.splitlines()[0])
    ap.add_argument("--energy", action="store_true", help="reality's chambers by the energy balance (chamber_heat 1)")
    ap.add_argument("--refine", action="store_true", help="differential evolution within REFINE_BOUNDS, not the grid")
    ap.add_argument("--free-leak", action="store_true", help="with --refine: the vane leak searched too")
    args = ap.parse_args()
    law = 1.0 if args.energy else None
    if args.refine:
        bounds = REFINE_BOUNDS | (LEAK_BOUNDS if args.free_leak else {}) | WALL_BOUNDS
        point, score, runs = refine_as_built(bounds, law)
        print(f"best {point}, score (misfit + prior) {score:.3f}")
        print(ratios_table(runs))
        return
    point, score, _ = fit_as_built(chamber_heat=law)
    print(f"best {point}, score (misfit + prior) {score:.3f}")


# python -m scenarios.paper_validation [--energy] [--refine [--free-leak]]: the fit, printed
# (docs/validation/as_built_and_paper.md, "The fit"; docs/air_chambers.md for --energy)
if __name__ == "__main__":
    main()
