"""The campaign's replay: the nominal twin of one campaign, each run prepared for comparison (the
instrument's offset taken off, the twin's inertia for its load), repeats grouped to share one
replay, and the fit's objective (angle and weighted pressure residuals at every latency of the
instrument's grid) with catalogue effects added. Also the campaign's folds (how runs are withheld).
"""

from __future__ import annotations

import functools
import math
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

import assets
from control.arm_model import ArmModel
from gap import instrument, where
from gap.campaign import Campaign, MeasuredRun
from gap.effects import Effect, Rig
from gap.instrument import Nuisance
from gap.stats import residual_vector
from pneumatics import JointParams, load_joint_params, params_row
from wrist_rig.one_joint import DT_S, replay_run

# The twin's own spread on a run (CampaignReplay.spread): how far its angle moves when the run starts this much
# further or nearer along the joint, 6 degrees of the vane motor's turn at the wrist's ratio 120.
# The twin takes the motor's angle as ratio x the joint's, so the phase of the vanes' torque ripple
# is only known to the twin's own precision: the replay's disagreement with the plant on the
# protocols, 0.016-0.15 deg rms (gap.protocols.TOLERANCE_DEG). On most runs the shift moves the
# twin by about itself. On a run whose drive only just beats the friction (a stall, a breakaway,
# a Stribeck fold) the moment the joint lets go, and all after it, hangs on a fraction of a N·m:
# measured on a held-out back-and-forth campaign with Coulomb friction at 30 N·m (nominal 15),
# the 0.6 MPa run moved 1.95 deg for this shift, the other supplies 0.05-0.35 deg, and the plant
# stood 1.96 deg from the located-event reference there while the replay stood 0.013 deg from it
# (the plant's end of motion 0.034 deg off, through the ripple, 0.85 N·m less breakaway torque)
SPREAD_START_DEG = 0.05


@dataclass
class Prepared:
    run: MeasuredRun
    args: tuple  # cmd arrays for replay
    ts: np.ndarray  # sample times
    meas: np.ndarray  # measured angle at ts, less the instrument's offset
    inertia: float  # the twin's joint-side inertia for this run's load (kg·m^2)
    tp: np.ndarray  # times of the pressure samples (empty: the run measured no chamber pressure)
    pmask: np.ndarray  # (2, len(tp)) bool: which of p_a, p_b was measured at each time
    pmeas: np.ndarray  # measured chamber pressures (Pa), flattened over pmask


class Readout(NamedTuple):
    """A run's samples of a twin trajectory: the twin's angle at the run's angle-sample times less
    each latency of the instrument's grid (n_latency x samples, rad) and its chamber pressures where
    the run measured them (Pa, flattened over the run's pmask)."""

    angle: np.ndarray
    pressure: np.ndarray


# Readouts kept for residual vectors (ReplayMemo): the single fits' rows are read again at other
# latencies by the family call (gap.members.at_fold_latencies). Measured: 0.22 MB a row on a
# campaign of 16 runs of 1.6-3.1 s at 13 latencies, ~600 rows kept (130 MB); past the budget the
# oldest go and are replayed again when asked for
READOUT_BUDGET_BYTES = 256 * 2**20


class ReplayMemo:
    """The replays a diagnosis has made, by their inputs (the parameter row's bytes, the rig, the
    group of runs): per run its objective at every latency (a few numbers: all kept) and, where
    asked for, its readouts (`Readout`: kept up to READOUT_BUDGET_BYTES, the least recently used
    dropped first). The replay is deterministic, so a remembered replay is the replay's own bits:
    the pair search's full fit meets the screen's grid and search again, the family call the single
    fits' rows. Shared by threads; a copy sent to a Dask worker starts empty."""

    def __init__(self, budget_bytes: int = READOUT_BUDGET_BYTES):
        self.budget_bytes = budget_bytes
        self._sses: dict[tuple, dict[int, np.ndarray]] = {}
        self._readouts: OrderedDict[tuple, dict[int, Readout]] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()

    def __reduce__(self):
        return ReplayMemo, (self.budget_bytes,)

    def get(self, key: tuple, readouts: bool):
        """(per run its objective, per run its readout) of the replay `key`; (None, None) where not
        remembered (with `readouts`: where its readouts are not)."""
        with self._lock:
            sses = self._sses.get(key)
            if not readouts:
                return sses, None
            got = self._readouts.get(key)
            if got is None:
                return None, None
            self._readouts.move_to_end(key)
            return sses, got

    def put(self, key: tuple, sses: dict[int, np.ndarray], readouts: dict[int, Readout] | None) -> None:
        with self._lock:
            self._sses[key] = sses
            if readouts is None or key in self._readouts:
                return
            self._readouts[key] = readouts
            self._bytes += sum(r.angle.nbytes + r.pressure.nbytes for r in readouts.values())
            while self._bytes > self.budget_bytes and self._readouts:
                _, old = self._readouts.popitem(last=False)
                self._bytes -= sum(r.angle.nbytes + r.pressure.nbytes for r in old.values())


def _pressures_at(pr: Prepared, t: np.ndarray, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """The twin's chamber pressures (Pa) where run `pr` measured them, flattened over its pmask."""
    return np.stack([np.interp(pr.tp, t, pa), np.interp(pr.tp, t, pb)])[pr.pmask]


def nominal_params(campaign: Campaign) -> JointParams:
    p = load_joint_params(assets.joint_param_path(campaign.joint))
    p = p._replace(hose_length_m=campaign.hose_length_m)
    if campaign.twin_hose_loss is not None:
        p = p._replace(hose_loss=campaign.twin_hose_loss)
    return p


@functools.cache
def joint_stops(joint: str) -> tuple[float, float]:
    """(low, high) end stops of the campaign's drive angle in rad, as the predictor has them: its
    joint's range in the arm's MJCF (assets/arm.xml; the wrist rig's is the same) where the drive is
    that joint alone, else none (`control.arm_model.ArmModel.drive_stops`; the elbow's drive sums
    shoulder and elbow, and the one-joint replay does not have the shoulder)."""
    arm = ArmModel(assets.ARM_XML)
    if joint not in arm.joints:
        return -math.inf, math.inf
    low, high = arm.drive_stops()[arm.joints.index(joint)]
    return float(low), float(high)


def nominal_inertia(rig_inertia_kg_m2: float, p: JointParams) -> float:
    """Rig inertia + ratio^2 x rotor inertia (assets/wrist_rig.xml comment)."""
    return rig_inertia_kg_m2 + p.ratio**2 * p.rotor_inertia_kg_m2


def prepared_runs(campaign: Campaign, nuisance: Nuisance) -> list[Prepared]:
    """The campaign's runs prepared for comparison with the nominal twin (`prepare`)."""
    params = nominal_params(campaign)
    return [prepare(r, params, nuisance.offset_rad) for r in campaign.runs]


def prepare(run: MeasuredRun, p: JointParams, offset_rad: float = 0.0) -> Prepared:
    m = run.sampled
    args = (run.time_s, run.direction, run.valve_gauge_pa, run.brake_released, run.supply_pa, run.valve_is_output)
    nan = np.full(run.time_s.shape, np.nan)
    pres = np.stack([run.extra.get("p_a_pa", nan), run.extra.get("p_b_pa", nan)])
    rows = np.isfinite(pres).any(axis=0)
    pmask = np.isfinite(pres[:, rows])
    return Prepared(
        run,
        args,
        run.time_s[m],
        run.angle_rad[m] - offset_rad,
        nominal_inertia(run.rig_inertia_kg_m2, p),
        run.time_s[rows],
        pmask,
        pres[:, rows][pmask],
    )


class CampaignReplay:
    """The nominal twin of one campaign, how to replay its runs with effects added, and the fit's
    objective on them (angle and weighted chamber-pressure residuals).

    The reference instrument's nuisance (gap.instrument) is part of every comparison: its offset
    is taken off the readings once, and its latency is a shift of the twin's angle in time,
    searched on `latencies` with each fit (one latency for the campaign's one instrument)."""

    def __init__(self, campaign: Campaign, *, pressure_weight: float, nuisance: Nuisance | None = None):
        """`pressure_weight`: the fit's weight on squared pressure residuals, rad^2/Pa^2 (the diagnosis
        gives (angle floor / pressure floor)^2, gap.floors.Floors.pressure_weight, so that both
        channels count in units of their own floor; 0 counts the angle alone). `nuisance`: the
        reference instrument's (default: estimated from the campaign, gap.instrument.estimate)."""
        self.campaign = campaign
        self.nuisance = nuisance or instrument.estimate(campaign)
        self.latencies = self.nuisance.latencies_s
        self.params = nominal_params(campaign)
        self.inertia = nominal_inertia(campaign.rig_inertia_kg_m2, self.params)
        self.stops = joint_stops(campaign.joint)
        self.runs = prepared_runs(campaign, self.nuisance)
        # runs with identical commands, start and inertia (repeats) share one replay of the twin
        groups: dict[tuple, list[int]] = {}
        for k, pr in enumerate(self.runs):
            a = pr.args
            key = (*(x.tobytes() for x in a[:5]), a[5], pr.run.start_rad, pr.inertia)
            groups.setdefault(key, []).append(k)
        self.groups = list(groups.values())
        self.group_of = {k: g for g, ks in enumerate(self.groups) for k in ks}
        self.t_end = [max(max([*self.runs[k].ts[-1:], *self.runs[k].tp[-1:], 0.0]) for k in ks) for ks in self.groups]
        self.has_pressure = any(pr.pmeas.size for pr in self.runs)
        self.pressure_weight = pressure_weight
        self.n_replays = 0
        self.memo = ReplayMemo()

    @functools.cached_property
    def ref_latency_s(self) -> float:
        """The nominal twin's latency, the one that fits all runs best: residual vectors are read at it."""
        return self.latency_of([], range(len(self.runs)))

    @functools.cached_property
    def gap_vector(self) -> np.ndarray:
        """The nominal twin's residual vector over all runs at `ref_latency_s` (`run_sses_and_residual`)."""
        return self.run_sses_and_residual([], list(range(len(self.runs))))[1]

    def sample_mask(self, ks) -> np.ndarray:
        """Which entries of a residual vector over all runs (`run_sses_and_residual`) are runs `ks`'."""
        keep = set(ks)
        return np.concatenate(
            [np.full(pr.ts.size + pr.pmeas.size, k in keep) for k, pr in enumerate(self.runs)] or [np.zeros(0, bool)]
        )

    def angle_mask(self) -> np.ndarray:
        """Which entries of a residual vector over all runs are angle samples (the rest: pressures)."""
        return np.concatenate(
            [np.r_[np.ones(pr.ts.size, bool), np.zeros(pr.pmeas.size, bool)] for pr in self.runs] or [np.zeros(0, bool)]
        )

    def trajectory(self, params: JointParams, rig: Rig, g: int, start_shift_rad: float = 0.0) -> tuple[np.ndarray, ...]:
        """(t, theta, omega, p_a, p_b) of the twin through group g's commands (from the runs' start
        angle moved by `start_shift_rad`)."""
        return self._replay(params_row(params, stops=self.stops), rig, g, start_shift_rad)

    def _replay(self, row: np.ndarray, rig: Rig, g: int, start_shift_rad: float = 0.0) -> tuple[np.ndarray, ...]:
        # `trajectory` from the parameter row (made once per set of effects, not once per group)
        rep = self.runs[self.groups[g][0]]
        self.n_replays += 1  # for the report's cost line (threads may miss a count: it is a statistic)
        return replay_run(
            row,
            *rep.args,
            rep.run.start_rad + start_shift_rad,
            rep.inertia * rig.inertia_scale,
            rig.load_torque_nm,
            self.t_end[g] + DT_S,
            DT_S,
            rig.load_spring_nm_per_rad,
        )

    def _each_run(self, effects, ks):
        """(k, twin trajectory of run k's group) for k in ks; one replay per group of repeats."""
        p, s = apply_effects(self.params, effects)
        row = params_row(p, stops=self.stops)
        traj = {g: self._replay(row, s, g) for g in dict.fromkeys(self.group_of[k] for k in ks)}
        return [(k, traj[self.group_of[k]]) for k in ks]

    def _replayed(self, effects, ks, keep: bool) -> list[tuple[int, Readout | None, np.ndarray]]:
        """Per run k in `ks`: (k, the twin with `effects` read at k's samples (`Readout`; None unless
        `keep`), k's objective at every latency of the grid (`_sse`)). One replay per group of
        repeats, none where the memo has the group replayed with the same parameter row and rig
        (`ReplayMemo`). `keep`: the readouts are wanted (for residual vectors), not only the objective."""
        p, rig = apply_effects(self.params, effects)
        row = params_row(p, stops=self.stops)
        out: dict[int, tuple[Readout | None, np.ndarray]] = {}
        for g in dict.fromkeys(self.group_of[k] for k in ks):
            key = (row.tobytes(), *rig, g)
            sses, readouts = self.memo.get(key, keep)
            if sses is None:
                traj = self._replay(row, rig, g)
                readouts = {k: self._readout(k, traj) for k in self.groups[g]}
                sses = {k: self._sse(k, r) for k, r in readouts.items()}
                self.memo.put(key, sses, readouts if keep else None)
            out |= {k: (readouts[k] if keep else None, sses[k]) for k in self.groups[g]}
        return [(k, *out[k]) for k in ks]

    def _readout(self, k: int, traj) -> Readout:
        """Run k's samples of a twin trajectory (t, theta, omega, p_a, p_b)."""
        t, th, _, pa, pb = traj
        pr = self.runs[k]
        angle = np.interp(pr.ts[None, :] - self.latencies[:, None], t, th)
        return Readout(angle, _pressures_at(pr, t, pa, pb))

    def _sse(self, k: int, r: Readout) -> np.ndarray:
        """Run k's objective at every latency of the grid from its readout: its squared angle
        residuals plus its weighted squared chamber-pressure residuals."""
        pr = self.runs[k]
        ang = pr.meas[None, :] - r.angle
        return np.sum(ang**2, axis=1) + self.pressure_weight * np.sum((pr.pmeas - r.pressure) ** 2)

    def _residual(self, k: int, r: Readout, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Run k's (angle residual at the grid's latency i, chamber-pressure residual) from its readout."""
        pr = self.runs[k]
        return pr.meas - r.angle[i], pr.pmeas - r.pressure

    def spread(self, effects) -> np.ndarray:
        """Per run, the twin's own spread with `effects` (rad): the rms over the run's angle samples
        of how far the twin's angle moves, the shift itself taken off, when the run starts
        SPREAD_START_DEG further or nearer along the joint (the larger of the two)."""
        p, rig = apply_effects(self.params, effects)
        shift = math.radians(SPREAD_START_DEG)
        out = np.zeros(len(self.runs))
        for g, ks in enumerate(self.groups):
            t, th = self.trajectory(p, rig, g)[:2]
            moved = [self.trajectory(p, rig, g, s)[1] - s for s in (shift, -shift)]
            for k in ks:
                ts = self.runs[k].ts
                base = np.interp(ts, t, th)
                out[k] = max(math.sqrt(np.mean((np.interp(ts, t, m) - base) ** 2)) if ts.size else 0.0 for m in moved)
        return out

    def _pressure_residual(self, pr: Prepared, t, pa, pb) -> np.ndarray:
        return pr.pmeas - _pressures_at(pr, t, pa, pb)

    def residuals_with(
        self, effects: list[tuple[Effect, float]], ks, latency_s: float
    ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Per run k in `ks`: (measured - twin angle at its angle samples, the twin read
        `latency_s` late; measured - twin chamber pressures where measured)."""
        out = {}
        for k, (t, th, _, pa, pb) in self._each_run(effects, ks):
            pr = self.runs[k]
            out[k] = (pr.meas - np.interp(pr.ts - latency_s, t, th), self._pressure_residual(pr, t, pa, pb))
        return out

    def run_sses(self, effects, ks) -> np.ndarray:
        """The fit's objective per run k in `ks` and latency of the grid, shape (len(ks), n_latency):
        squared angle residuals plus weighted squared pressure residuals."""
        return self._sses_of(self._replayed(effects, ks, keep=False))

    def _sses_of(self, rows) -> np.ndarray:
        out = np.empty((len(rows), len(self.latencies)))
        for i, (_, _, sse) in enumerate(rows):
            out[i] = sse
        return out

    def run_sses_and_residual(self, effects, ks) -> tuple[np.ndarray, np.ndarray]:
        """`run_sses`, and the residual of runs `ks` at the reference latency (`ref_latency_s`) as one
        vector: angle (rad) then pressure (Pa) x sqrt(pressure_weight), so that its squared norm is
        the objective (the family call and the pair screen work on these vectors, no replay)."""
        rows = self._replayed(effects, ks, keep=True)
        return self._sses_of(rows), self._residual_vector(rows, self.latency_index(self.ref_latency_s))

    def _residual_vector(self, rows, i: int) -> np.ndarray:
        res = [self._residual(k, r, i) for k, r, _ in rows]
        return residual_vector([a for a, _ in res], [p for _, p in res], self.pressure_weight)

    def residual_vectors(self, effects, ks, indices) -> dict[int, np.ndarray]:
        """The residual vector of runs `ks` (as `run_sses_and_residual`'s) at each latency of the grid
        whose index is in `indices`, from one replay."""
        rows = self._replayed(effects, ks, keep=True)
        return {i: self._residual_vector(rows, i) for i in indices}

    def latency_index(self, latency_s: float) -> int:
        """The index of the grid's latency nearest `latency_s`."""
        return int(np.argmin(np.abs(self.latencies - latency_s)))

    def fold_residuals(self, effects, train, test) -> tuple[float, dict[int, tuple[np.ndarray, np.ndarray]]]:
        """The latency that fits runs `train` best with `effects`, and the residuals of runs `test` at
        it (as `residuals_with`), from one replay of their groups."""
        rows = self._replayed(effects, list(dict.fromkeys([*train, *test])), keep=True)
        sse = sum(s for k, _, s in rows if k in train)
        i = int(np.argmin(sse))
        return float(self.latencies[i]), {k: self._residual(k, r, i) for k, r, _ in rows if k in test}

    def latency_of(self, effects, idx) -> float:
        """The instrument latency that fits runs `idx` best with `effects` added."""
        return float(self.latencies[int(np.argmin(self.run_sses(effects, idx).sum(axis=0)))])


def apply_effects(params: JointParams, effects) -> tuple[JointParams, Rig]:
    rig = Rig()
    for e, v in effects:
        params, rig = e.apply(params, v, rig)
    return params, rig


def folds_of(campaign: Campaign) -> list[tuple[list[int], list[int]]]:
    """Leave one supply pressure out; with a single pressure, an alternating split (both ways)."""
    pressures = supplies(campaign)
    n = len(campaign.runs)
    if len(pressures) >= 2:
        return [
            (
                [k for k in range(n) if round(campaign.runs[k].supply_mpa, 4) != q],
                [k for k in range(n) if round(campaign.runs[k].supply_mpa, 4) == q],
            )
            for q in pressures
        ]
    even = list(range(0, n, 2))
    odd = list(range(1, n, 2))
    return [(even, odd), (odd, even)] if odd else [(even, even)]


def supplies(campaign: Campaign) -> list[float]:
    """The campaign's supply pressures (MPa, rounded to 4 decimals), ascending."""
    return sorted({round(r.supply_mpa, 4) for r in campaign.runs})


def nominal_residuals(replay: CampaignReplay, latency_s: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per run, the nominal twin's angle and pressure residuals, the instrument `latency_s` late."""
    res = replay.residuals_with([], range(len(replay.runs)), latency_s).values()
    return [a for a, _ in res], [p for _, p in res]


def where_labels(replay: CampaignReplay) -> dict[str, np.ndarray]:
    """Every angle sample's label per factor of the breakdown (gap.where), from the nominal replay."""
    per_run = []
    for g, ks in enumerate(replay.groups):
        t, th, om, _, _ = replay.trajectory(replay.params, Rig(), g)
        for k in ks:
            pr = replay.runs[k]
            per_run.append((k, where.labels_of(pr.run, pr.ts, np.interp(pr.ts, t, th), np.interp(pr.ts, t, om))))
    return where.concat_labels([lab for _, lab in sorted(per_run, key=lambda x: x[0])])
