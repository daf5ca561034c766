"""How far a run tells two hypotheses about the joint apart: the T-optimality criterion of Atkinson &
Fedorov for discriminating between rival models, read by the campaign's instrument.

A hypothesis is the nominal twin with some catalogue effects at given values, read by the instrument
`latency_s` late; its rival may take any of its `alternatives` (its members at the values of a grid)
and any latency of the instrument's grid, the nuisance the diagnosis fits too. For a set of runs
the criterion is

    T(truth -> rival) = min over the rival's alternatives a and latencies tau of
                        sum over samples [(y_truth - y_a,tau) / floor]^2

(Atkinson, A. C. & Fedorov, V. V. (1975), "The design of experiments for discriminating between two
rival models", Biometrika 62(1), 57-70: the lack of fit of the rival model, refitted, to the
responses the true model predicts; their T-optimum maximises it. With several models, Atkinson &
Fedorov (1975), "Optimal design: experiments for discriminating between several models", Biometrika
62(2), 289-303). Samples count in units of their channel's floor (the diagnosis's: the instrument's
noise with the twin's model tolerance, angle and, where measured, chamber pressures), so T is the
non-centrality of the rival's misfit, the statistic the diagnosis's own ranking reads. Responses
are the one-joint twin's replays (wrist_rig.one_joint), the model the diagnosis fits; no measurement enters.

A pair is told apart by a set of runs when the rival, refitted, still misses the truth by more than
SEPARATED_FLOORS floors rms over the samples of the runs (`separation_floors`), both ways round.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gap.campaign_replay import apply_effects
from gap.effects import Effect
from gap.kinds import Family
from pneumatics import JointParams, params_row
from wrist_rig.one_joint import DT_S, replay_run

# The diagnosis tells a candidate from a rival when the rival's held-out score (rms in floors, noise
# counting 1) is more than 10 % above its own (gap.verdict.Judge.rivals_of): sqrt(1 + d^2) > 1.1, a
# mean squared difference d^2 > 0.21 floors^2 over all the campaign's runs. A proposal of n runs
# added to a campaign of N with no difference on the old runs needs d^2 > 0.21 (N + n) / n on the new
# ones: 0.63 (d = 0.8) for 4 runs added to 8. The design asks 1 floor rms on the runs it adds.
SEPARATED_FLOORS = 1.0


Change = tuple[tuple[Effect, float], ...]  # effects added to the nominal twin, each at a value


@dataclass(frozen=True)
class Hypothesis:
    """What may be wrong with the joint: `effects` at their values, read `latency_s` late;
    `alternatives`: the changes it may take when refitted (its own effects, or its family's members,
    over a grid of values), the rival's freedom in the criterion."""

    name: str
    family: Family
    effects: Change
    latency_s: float
    alternatives: tuple[Change, ...]


@dataclass(frozen=True)
class Reading:
    """The instrument as the criterion reads it: the angle's floor (deg) and its latency grid (s), the
    chamber pressures' floor (kPa; None where not measured)."""

    floor_deg: float
    latencies_s: np.ndarray
    floor_kpa: float | None = None


@dataclass(frozen=True)
class PlannedRun:
    """A run's commands (1 ms rows) and where its instruments sample: `angle_times_s` (the reference
    instrument's samples), `pressure_times_s` (empty: no chamber-pressure transducer)."""

    name: str
    supply_mpa: float
    time_s: np.ndarray
    direction: np.ndarray
    valve_gauge_pa: np.ndarray
    brake_released: np.ndarray
    supply_pa: np.ndarray
    angle_times_s: np.ndarray
    pressure_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    valve_is_output: bool = False
    start_rad: float = 0.0
    inertia_kg_m2: float = 0.0


@dataclass(frozen=True)
class ReplayedJoint:
    """The joint the hypotheses change, as the one-joint model replays it: the nominal twin's
    parameters and end stops."""

    params: JointParams
    stops: tuple[float, float]


def trajectory(twin: ReplayedJoint, change: Change, run: PlannedRun) -> tuple[np.ndarray, ...]:
    """(t, theta, p_a, p_b) of the twin with `change` through `run`'s commands."""
    p, rig = apply_effects(twin.params, change)
    t_end = max(float(run.time_s[-1]), *run.angle_times_s[-1:], *run.pressure_times_s[-1:])
    t, th, _, pa, pb = replay_run(
        params_row(p, stops=twin.stops),
        run.time_s,
        run.direction,
        run.valve_gauge_pa,
        run.brake_released,
        run.supply_pa,
        run.valve_is_output,
        run.start_rad,
        run.inertia_kg_m2 * rig.inertia_scale,
        rig.load_torque_nm,
        t_end + DT_S,
        DT_S,
        rig.load_spring_nm_per_rad,
    )
    return t, th, pa, pb


@dataclass(frozen=True)
class Response:
    """A change's predicted readings of one run in floors: the angle at every latency of the grid
    (latencies x samples) and the chamber pressures (2 x pressure samples, empty if not measured)."""

    angle: np.ndarray
    pressure: np.ndarray


def response(twin: ReplayedJoint, change: Change, run: PlannedRun, reading: Reading) -> Response:
    t, th, pa, pb = trajectory(twin, change, run)
    ts = run.angle_times_s
    angle = np.interp(ts[None, :] - reading.latencies_s[:, None], t, th) / math.radians(reading.floor_deg)
    pressure = np.zeros((2, 0))
    if reading.floor_kpa is not None and run.pressure_times_s.size:
        tp = run.pressure_times_s
        pressure = np.stack([np.interp(tp, t, pa), np.interp(tp, t, pb)]) / (reading.floor_kpa * 1e3)
    return Response(angle, pressure)


def misfits(truth: Response, truth_latency: int, rivals: list[Response]) -> np.ndarray:
    """Per rival response and latency of the grid, the sum of squared differences (in floors) from
    the truth's readings at its latency index: (rivals x latencies)."""
    y = truth.angle[truth_latency]
    out = np.empty((len(rivals), truth.angle.shape[0]))
    for i, r in enumerate(rivals):
        out[i] = np.sum((r.angle - y[None, :]) ** 2, axis=1) + np.sum((r.pressure - truth.pressure) ** 2)
    return out


def samples(run: PlannedRun, reading: Reading) -> int:
    """The samples a run gives the criterion: its angle samples and, where measured, both ports'."""
    return run.angle_times_s.size + (2 * run.pressure_times_s.size if reading.floor_kpa is not None else 0)


def separation_floors(t_criterion: float, n_samples: int) -> float:
    """The rival's refitted misfit as an rms in floors over the runs' samples."""
    return math.sqrt(max(t_criterion, 0.0) / n_samples) if n_samples else 0.0


def latency_index(reading: Reading, latency_s: float) -> int:
    return int(np.argmin(np.abs(reading.latencies_s - latency_s)))
