"""The diagnosis: where the twin departs from measured runs, which catalogue effect explains it, and
how far the gap shrinks on runs withheld from the fit.

Steps (each a plain function of the campaign):
1. the reference instrument's nuisance first (gap.instrument): its zero offset from the rest
   samples, its latency (declared, or fitted with every candidate, the nominal twin included);
   replay every run through the nominal twin (wrist_rig.one_joint; repeats share one replay) -> residual
   = measured - twin, in angle and, where the campaign measured them, chamber pressures;
2. where (gap.where): break the angle residual down by motion phase, supply, direction, load,
   angle, speed and time since start, beside a floor of the instrument's noise and the drift
   between repeats (gap.noise, from samples both repeats have) and the twin's own model tolerance
   (measured per protocol, gap.protocols);
3. which: for each catalogue effect, fit its one bounded parameter on training runs and score it
   on withheld runs (leave one supply pressure out; alternating split when there is one pressure):
   a grid, refined around each fold's best point and then around the best on all runs, every
   value replayed once on all runs so that the folds share the replays (`_zoom`, `_vertex`). The
   objective and the ranking count angle and pressure samples each in units of its own floor.
   When no single effect brings the gap to the floor, the pairs of the PAIR_POOL best singles are
   pre-screened by adding their corrections (no replay, `superposed_sse`), the PAIR_SCREEN best
   and every pair of the best single screened by replay in-sample (`screened_pairs`,
   `screen_pair`) and the best N_PAIRS_CV fitted on all runs by a Nelder-Mead search that
   follows the valley of two effects acting alike, refitted per fold from there
   (`_valley_search`) and scored on withheld runs; a verdict and a family call by the
   rules of gap.verdict (a pair counts only with both effects off nominal and a clear margin;
   the family by each family's own corrections on withheld runs, read at the instrument latency
   each fold's training runs choose with the family (gap.members), ties told apart by the
   where-profile, gap.family);
4. how far: per pressure, mean and max |error| on withheld runs before and after each effect, with
   bootstrap confidence intervals over runs.
"""

from __future__ import annotations

import contextlib
import functools
import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np
from joblib import Parallel, delayed, parallel_config
from scipy.optimize import minimize
from tqdm import tqdm

import assets
from control.arm_model import ArmModel
from gap import instrument, verdict, where
from gap.campaign import Campaign, GapError, MeasuredRun
from gap.effects import BY_NAME, CATALOGUE, Effect, Rig
from gap.instrument import Nuisance
from gap.members import at_fold_latencies, family_members
from gap.noise import RepeatNoise, repeat_noise
from gap.protocols import worst_tolerance_deg, worst_tolerance_kpa
from gap.result import (
    CandidateSummary,
    Diagnosis,
    NoiseFloor,
    PressureError,
    PressureFloor,
    Residuals,
    Timing,
    TwinFacts,
    Which,
)
from gap.stats import bootstrap_ci, normalised_rms, residual_vector, rms_ci_deg, rms_deg, rms_kpa
from pneumatics import JointParams, load_joint_params, params_row
from twin_plumbing.cluster import dask_client
from wrist_rig.one_joint import DT_S, replay_run

# The angle's model tolerance (below it a residual is no gap): twice the worst replay-vs-plant rms
# over the protocol library (gap.protocols, measured per protocol), not one motion's.
MODEL_TOLERANCE_DEG = worst_tolerance_deg()
# The same for the motor-chamber pressures, where a campaign measured them.
MODEL_TOLERANCE_KPA = worst_tolerance_kpa()
SIGNIFICANCE = 2.0  # a gap is significant above SIGNIFICANCE x floor, floor = sqrt(noise^2 + drift^2/2 + tol^2)
# The twin's own spread on a run (Twin.spread): how far its angle moves when the run starts this much
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
N_PAIRS_CV = 3  # pairs given the full cross-validated fit after the in-sample screen
# pairs are formed from the best PAIR_POOL singles (28 pairs, not the 210 of all 21): a pair's
# members each explain part of its gap, so each is expected to rank high alone; a pair of two
# low-ranked singles is not searched. Counted: the full screen was ~70 % of the replays of a
# diagnosis with the pair stage
PAIR_POOL = 8
# of those 28, the replayed screen sees every pair of the best single (the member most likely to be
# one of two effects at work) and the PAIR_SCREEN whose corrections, simply added, fit best
# (superposed_sse: no replay). Adding corrections ignores how two effects interact: a vane leak and
# more Coulomb friction both take torque, and near a stall they take more together than apart. With
# the sum alone, two held-out campaigns of that pair (the paper's 60-degree moves, a
# camera; back-and-forth moves, a camera) ranked it 6th and 7th, unscreened, while its replayed
# screen was 8-10 times lower than any screened pair's: a wrong pair or a single was called
PAIR_SCREEN = 5


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


class Twin:
    """The nominal twin of one campaign and how to replay a run with an effect added.

    The reference instrument's nuisance (gap.instrument) is part of every comparison: its offset
    is taken off the readings once, and its latency is a shift of the twin's angle in time,
    searched on `latencies` with each fit (one latency for the campaign's one instrument)."""

    def __init__(self, campaign: Campaign, nuisance: Nuisance | None = None):
        self.campaign = campaign
        self.nuisance = nuisance or instrument.estimate(campaign)
        self.latencies = self.nuisance.latencies_s
        self.params = nominal_params(campaign)
        self.inertia = nominal_inertia(campaign.rig_inertia_kg_m2, self.params)
        self.stops = joint_stops(campaign.joint)
        self.runs = [prepare(r, self.params, self.nuisance.offset_rad) for r in campaign.runs]
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
        # the fit's weight on squared pressure residuals, (angle floor / pressure floor)^2 in
        # rad^2/Pa^2: both channels count in units of their own floor (set by `diagnose`)
        self.pressure_weight = 0.0
        self.ref_latency_s = 0.0  # the nominal twin's latency: residual vectors are read at it (set by `diagnose`)
        self.gap_vector = np.zeros(0)  # the nominal twin's residual vector at it (set by `diagnose`)
        self.n_replays = 0

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

    def replay(self, params: JointParams, rig: Rig, g: int, start_shift_rad: float = 0.0) -> tuple[np.ndarray, ...]:
        """(t, theta, omega, p_a, p_b) of the twin through group g's commands (from the runs' start
        angle moved by `start_shift_rad`)."""
        rep = self.runs[self.groups[g][0]]
        self.n_replays += 1  # for the report's cost line (threads may miss a count: it is a statistic)
        return replay_run(
            params_row(params, stops=self.stops),
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
        traj = {g: self.replay(p, s, g) for g in dict.fromkeys(self.group_of[k] for k in ks)}
        return [(k, traj[self.group_of[k]]) for k in ks]

    def spread(self, effects) -> np.ndarray:
        """Per run, the twin's own spread with `effects` (rad): the rms over the run's angle samples
        of how far the twin's angle moves, the shift itself taken off, when the run starts
        SPREAD_START_DEG further or nearer along the joint (the larger of the two)."""
        p, rig = apply_effects(self.params, effects)
        shift = math.radians(SPREAD_START_DEG)
        out = np.zeros(len(self.runs))
        for g, ks in enumerate(self.groups):
            t, th = self.replay(p, rig, g)[:2]
            moved = [self.replay(p, rig, g, s)[1] - s for s in (shift, -shift)]
            for k in ks:
                ts = self.runs[k].ts
                base = np.interp(ts, t, th)
                out[k] = max(math.sqrt(np.mean((np.interp(ts, t, m) - base) ** 2)) if ts.size else 0.0 for m in moved)
        return out

    def _pressure_residual(self, pr: Prepared, t, pa, pb) -> np.ndarray:
        return pr.pmeas - np.stack([np.interp(pr.tp, t, pa), np.interp(pr.tp, t, pb)])[pr.pmask]

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

    def _residual_rows(self, trajs):
        """Per (k, trajectory): the angle residual at every latency of the grid (n_latency x samples)
        and the chamber-pressure residual."""
        for k, (t, th, _, pa, pb) in trajs:
            pr = self.runs[k]
            ang = pr.meas[None, :] - np.interp(pr.ts[None, :] - self.latencies[:, None], t, th)
            yield k, ang, self._pressure_residual(pr, t, pa, pb)

    def run_sses(self, effects, ks) -> np.ndarray:
        """The fit's objective per run k in `ks` and latency of the grid, shape (len(ks), n_latency):
        squared angle residuals plus weighted squared pressure residuals."""
        return self.run_sses_and_residual(effects, ks)[0]

    def run_sses_and_residual(self, effects, ks) -> tuple[np.ndarray, np.ndarray]:
        """`run_sses`, and the residual of runs `ks` at the reference latency (`ref_latency_s`) as one
        vector: angle (rad) then pressure (Pa) x sqrt(pressure_weight), so that its squared norm is
        the objective (the family call and the pair screen work on these vectors, no replay)."""
        out = np.empty((len(ks), len(self.latencies)))
        angles, pressures = [], []
        i_ref = self.latency_index(self.ref_latency_s)
        for i, (_, ang, pres) in enumerate(self._residual_rows(self._each_run(effects, ks))):
            out[i] = np.sum(ang**2, axis=1) + self.pressure_weight * np.sum(pres**2)
            angles.append(ang[i_ref])
            pressures.append(pres)
        return out, residual_vector(angles, pressures, self.pressure_weight)

    def residual_vectors(self, effects, ks, indices) -> dict[int, np.ndarray]:
        """The residual vector of runs `ks` (as `run_sses_and_residual`'s) at each latency of the grid
        whose index is in `indices`, from one replay."""
        rows = list(self._residual_rows(self._each_run(effects, ks)))
        pressures = [pres for _, _, pres in rows]
        return {i: residual_vector([ang[i] for _, ang, _ in rows], pressures, self.pressure_weight) for i in indices}

    def latency_index(self, latency_s: float) -> int:
        """The index of the grid's latency nearest `latency_s`."""
        return int(np.argmin(np.abs(self.latencies - latency_s)))

    def fold_residuals(self, effects, train, test) -> tuple[float, dict[int, tuple[np.ndarray, np.ndarray]]]:
        """The latency that fits runs `train` best with `effects`, and the residuals of runs `test` at
        it (as `residuals_with`), from one replay of their groups."""
        rows = list(self._residual_rows(self._each_run(effects, list(dict.fromkeys([*train, *test])))))
        w = self.pressure_weight
        sse = sum(np.sum(ang**2, axis=1) + w * np.sum(pres**2) for k, ang, pres in rows if k in train)
        i = int(np.argmin(sse))
        return float(self.latencies[i]), {k: (ang[i], pres) for k, ang, pres in rows if k in test}

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


def _grid(e: Effect, n: int = 8) -> np.ndarray:
    if e.discrete_value is not None:
        return np.array([e.discrete_value])
    if e.log:
        lo = e.low if e.low > 0 else e.high / 100.0
        g = np.geomspace(lo, e.high, n)
        return np.concatenate([[0.0], g]) if e.low == 0 else g
    return np.linspace(e.low, e.high, n + 1)


@dataclass
class Candidate:
    name: str  # effect name, or "a+b" for a pair
    effects: list[str]
    fold_values: list[list[float]]  # per fold, fitted value of each effect
    full_values: list[float]  # fitted on all runs
    heldout: list[np.ndarray] = field(default_factory=list)  # per run: withheld angle residual (rad)
    heldout_p: list[np.ndarray] = field(
        default_factory=list
    )  # per run: withheld pressure residual (Pa; empty where not measured)
    fold_latencies: list[float] = field(default_factory=list)  # per fold, the instrument latency fitted with it (s)
    latency_s: float = 0.0  # fitted with the full values on all runs
    # singles only: the values replayed, each one's residual vector over all runs
    # (Twin.run_sses_and_residual) and its objective per run at every latency of the grid, and the
    # residual vector at the full value
    grid_values: np.ndarray | None = None
    grid_residuals: np.ndarray | None = None
    grid_sses: np.ndarray | None = None
    full_residual: np.ndarray | None = None
    spread: np.ndarray | None = None  # per run, the twin's own spread at the full values (Twin.spread; when asked)


def fit_single(twin: Twin, e: Effect, folds) -> Candidate:
    """Effect e's parameter fitted on each fold's training runs and on all runs, scored on each
    fold's withheld runs. Every replay covers all runs, so the folds share them: a grid, then
    ZOOM_LEVELS refinements inside the bracket of each fold's best point (`_zoom`), then per fold
    the vertex of the parabola through its best point and their neighbours (`_vertex`)."""
    n = len(twin.runs)
    every = list(range(n))
    subsets = [list(train) for train, _ in folds] + [every]
    xs, sses, vecs = _zoom(twin, e, _grid(e), subsets)
    heldout: list = [None] * n
    heldout_p: list = [None] * n
    fold_values, fold_lat = [], []
    for train, test in folds:
        v = _vertex(xs, sses[:, train].sum(axis=1).min(axis=1))
        lat, res = twin.fold_residuals([(e, v)], train, test)
        fold_values.append([v])
        fold_lat.append(lat)
        for k, r in res.items():
            heldout[k], heldout_p[k] = r
    full = _vertex(xs, sses.sum(axis=1).min(axis=1))
    full_sse, full_vec = twin.run_sses_and_residual([(e, full)], every)
    return Candidate(
        e.name,
        [e.name],
        fold_values,
        [full],
        heldout,
        heldout_p,
        fold_lat,
        float(twin.latencies[int(np.argmin(full_sse.sum(axis=0)))]),
        grid_values=xs,
        grid_residuals=vecs,
        grid_sses=sses,
        full_residual=full_vec,
    )


ZOOM_LEVELS = 3  # refinements of the grid around each fold's best point (the folds share the replays)
ZOOM_POINTS = 4  # new points per refinement, evenly inside the bracket of the best point's neighbours


def _zoom(twin: Twin, e: Effect, grid: np.ndarray, subsets: list[list[int]]):
    """Effect e on `grid`, refined around the best point of each subset of runs once, then
    ZOOM_LEVELS - 1 times around the last subset's (all runs): (values ascending, SSE per value, run
    and latency, residual vector per value). Each value is replayed once on all runs; brackets the
    subsets share cost one set of points."""
    every = list(range(len(twin.runs)))
    xs = list(grid)
    evals = [twin.run_sses_and_residual([(e, v)], every) for v in xs]
    if e.discrete_value is not None:
        return np.asarray(xs), np.array([s for s, _ in evals]), np.array([r for _, r in evals])
    tol = 1e-9 * (e.high - e.low)
    for level in range(ZOOM_LEVELS):
        if level == 1:  # the folds agree where the effect fits; where it does not, precision is moot
            subsets = subsets[-1:]
        order = np.argsort(xs)
        xa, sa = np.asarray(xs)[order], np.array([evals[i][0] for i in order])
        new: list[float] = []
        for idx in subsets:
            j = int(np.argmin(sa[:, idx].sum(axis=1).min(axis=1)))
            lo, hi = xa[max(j - 1, 0)], xa[min(j + 1, len(xa) - 1)]
            for v in np.linspace(lo, hi, ZOOM_POINTS + 2)[1:-1]:
                if min(abs(v - x) for x in [*xs, *new]) > tol:
                    new.append(float(v))
        xs += new
        evals += [twin.run_sses_and_residual([(e, v)], every) for v in new]
    order = np.argsort(xs)
    return (
        np.asarray(xs)[order],
        np.array([evals[i][0] for i in order]),
        np.array([evals[i][1] for i in order]),
    )


def _vertex(xs: np.ndarray, s: np.ndarray) -> float:
    """The minimum of the parabola through the best of the points (xs ascending, values s) and
    its two neighbours, kept between them; the best point itself at an end of the range."""
    j = int(np.argmin(s))
    if j == 0 or j == len(xs) - 1:
        return float(xs[j])
    (x0, x1, x2), (y0, y1, y2) = xs[j - 1 : j + 2], s[j - 1 : j + 2]
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    if den == 0.0:
        return float(x1)
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    return float(np.clip(x1 - 0.5 * num / den, x0, x2))


# A pair's two parameters are searched by Nelder-Mead in grid-index coordinates (a logarithmic grid
# searched logarithmically) from the best local minima of a coarse 2-D grid. Two effects that act alike
# (leak vs friction) leave a narrow curved valley: a pattern search on halving steps from the grid
# stops on its wall, in-sample worse than the pair's better member alone (on the bench's staircase
# leak + Coulomb pair: 0.136 against the leak's 0.049 and 0.0004 at the true values), while the
# simplex turns along the valley. Budgets of replays per search, counted on that case:
PAIR_EVALS = 60  # the search on all runs (the screen on distinct runs, the full fit)
FOLD_EVALS = 20  # each fold's refit on its training runs, from the full fit's point
FOLD_STEP = 0.1  # its initial simplex, in grid steps: a fold's optimum lies near all runs'
SEARCH_XTOL = 0.01  # in grid steps
PAIR_STARTS = 2  # the search starts from the grid's best local minima, at most this many (`_grid_starts`)


def _valley_search(
    twin: Twin, ea: Effect, eb: Effect, ga: np.ndarray, gb: np.ndarray, runs: list[int], start, step: float, evals: int
) -> tuple[tuple[float, float], float]:
    """Nelder-Mead over the pair's grid-index coordinates (clipped to the grid) from `start`, its
    objective the SSE of `runs` at their best latency; returns (the point, its SSE)."""
    hi = np.array([len(ga) - 1, len(gb) - 1], dtype=float)
    seen: dict[tuple[float, float], float] = {}

    def sse(u) -> float:
        key = tuple(float(x) for x in np.clip(u, 0.0, hi))
        if key not in seen:
            seen[key] = float(twin.run_sses(_pair_at(ea, eb, ga, gb, key), runs).sum(axis=0).min())
        return seen[key]

    u0 = np.clip(np.asarray(start, dtype=float), 0.0, hi)
    simplex = [
        u0,
        u0 + [step if u0[0] + step <= hi[0] else -step, 0.0],
        u0 + [0.0, step if u0[1] + step <= hi[1] else -step],
    ]
    minimize(
        sse,
        u0,
        method="Nelder-Mead",
        options={"initial_simplex": simplex, "maxfev": evals, "xatol": SEARCH_XTOL, "fatol": 0.0},
    )
    best = min(seen, key=seen.get)  # every point tried, the start included
    return best, seen[best]


def _grid_starts(sse: np.ndarray, cols: list[int], n: int = PAIR_STARTS) -> list[tuple[float, float]]:
    """The grid's local minima over runs `cols` (no lower point among its 8 neighbours), best first,
    at most `n`: the starts of the valley search. Two effects acting alike can leave two basins
    (more leak and less friction, or the reverse, both near the data); the grid's best point lies
    in the wrong one as often as not, and the simplex does not cross the ridge between them."""
    s = sse[:, :, cols].sum(axis=2).min(axis=2)
    padded = np.pad(s, 1, constant_values=np.inf)
    neighbours = np.stack(
        [padded[1 + di : 1 + di + s.shape[0], 1 + dj : 1 + dj + s.shape[1]] for di in (-1, 0, 1) for dj in (-1, 0, 1)]
    )
    minima = np.argwhere(s <= neighbours.min(axis=0))
    order = np.argsort(s[minima[:, 0], minima[:, 1]], kind="stable")[:n]
    return [(float(minima[k, 0]), float(minima[k, 1])) for k in order]


def _multi_start_search(
    twin: Twin, ea: Effect, eb: Effect, ga: np.ndarray, gb: np.ndarray, runs: list[int], sse: np.ndarray, cols
) -> tuple[tuple[float, float], float]:
    """The valley search from each of the grid's best local minima (`_grid_starts` over `cols`),
    the best point found."""
    found = [_valley_search(twin, ea, eb, ga, gb, runs, u, 0.5, PAIR_EVALS) for u in _grid_starts(sse, cols)]
    return min(found, key=lambda x: x[1])


def _pair_at(ea: Effect, eb: Effect, ga: np.ndarray, gb: np.ndarray, u: tuple[float, float]):
    """The pair's effects at grid-index coordinates u (piecewise linear between grid points)."""
    return [
        (ea, float(np.interp(u[0], np.arange(len(ga)), ga))),
        (eb, float(np.interp(u[1], np.arange(len(gb)), gb))),
    ]


def screen_pair(twin: Twin, a: Candidate, b: Candidate, runs: list[int], n_grid: int = 5) -> float:
    """In-sample SSE of a pair on `runs`: a coarse 2-D grid, then the valley search from its best
    local minima (`_multi_start_search`), so that the ranking does not depend on where the grid happens to
    fall (a grid, not refits from the singles' values alone: an effect fitted alone can be far
    from its value in the pair, having soaked up the other)."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    ga, gb, sse = pair_grid(twin, a, b, runs, n_grid)
    return _multi_start_search(twin, ea, eb, ga, gb, runs, sse, list(range(len(runs))))[1]


def pair_grid(
    twin: Twin, a: Candidate, b: Candidate, runs: list[int] | None = None, n_grid: int = 5
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SSE of every run on a coarse 2-D grid of the pair's parameters: (grid_a, grid_b,
    sse[i, j, run, latency]).
    A grid rather than coordinate descent from the singles' values: a single effect's value,
    fitted alone, can be far from its value in the pair (it soaks up the other effect)."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    ga, gb = _grid(ea, n_grid), _grid(eb, n_grid)
    runs = list(range(len(twin.runs))) if runs is None else runs
    sse = np.array([[twin.run_sses([(ea, va), (eb, vb)], runs) for vb in gb] for va in ga])
    return ga, gb, sse


def fit_pair(
    twin: Twin, a: Candidate, b: Candidate, folds, grid: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> Candidate:
    """Both effects fitted together on all runs (the 2-D grid on all runs, then the valley search
    from its best local minima, `_multi_start_search`) and refitted on each fold's training runs from there,
    scored on each fold's withheld runs; the reported values are those fitted on all runs."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    n = len(twin.runs)
    every = list(range(n))
    ga, gb, sse = grid
    full, _ = _multi_start_search(twin, ea, eb, ga, gb, every, sse, every)
    per_fold = [_valley_search(twin, ea, eb, ga, gb, list(tr), full, FOLD_STEP, FOLD_EVALS)[0] for tr, _ in folds]
    heldout: list = [None] * n
    heldout_p: list = [None] * n
    fold_values, fold_lat = [], []
    for (train, test), u in zip(folds, per_fold, strict=True):
        (_, va), (_, vb) = _pair_at(ea, eb, ga, gb, u)
        lat, res = twin.fold_residuals([(ea, va), (eb, vb)], train, test)
        fold_values.append([va, vb])
        fold_lat.append(lat)
        for k, r in res.items():
            heldout[k], heldout_p[k] = r
    (_, va), (_, vb) = _pair_at(ea, eb, ga, gb, full)
    lat = twin.latency_of([(ea, va), (eb, vb)], every)
    return Candidate(f"{a.name}+{b.name}", [a.name, b.name], fold_values, [va, vb], heldout, heldout_p, fold_lat, lat)


def repeat_groups(twin: Twin) -> list[list[int]]:
    groups: dict[tuple, list[int]] = {}
    for k, pr in enumerate(twin.runs):
        groups.setdefault(pr.run.signature(), []).append(k)
    return list(groups.values())


def angle_noise(twin: Twin) -> RepeatNoise:
    """Angle noise and drift (rad) of the reference instrument, from repeated runs."""
    return repeat_noise(repeat_groups(twin), lambda k: (twin.runs[k].ts, twin.runs[k].meas))


def pressure_noise(twin: Twin) -> RepeatNoise:
    """Chamber-pressure noise and drift (Pa) of the transducers (port A), from repeated runs."""
    return repeat_noise(
        repeat_groups(twin),
        lambda k: (twin.runs[k].tp[twin.runs[k].pmask[0]], twin.runs[k].pmeas[: int(twin.runs[k].pmask[0].sum())]),
    )


def where_labels(twin: Twin) -> dict[str, np.ndarray]:
    """Every angle sample's label per factor of the breakdown (gap.where), from the nominal twin."""
    per_run = []
    for g, ks in enumerate(twin.groups):
        t, th, om, _, _ = twin.replay(twin.params, Rig(), g)
        for k in ks:
            pr = twin.runs[k]
            per_run.append((k, where.labels_of(pr.run, pr.ts, np.interp(pr.ts, t, th), np.interp(pr.ts, t, om))))
    return where.concat_labels([lab for _, lab in sorted(per_run, key=lambda x: x[0])])


# --- the whole diagnosis ---------------------------------------------------------------------
@dataclass
class Floors:
    """What a residual is measured against: the instrument's noise, the repeats' drift and the
    twin's own model tolerance, in angle and (where measured) chamber pressure."""

    noise_deg: float
    noise: RepeatNoise  # from repeats (rad)
    tolerance_deg: float
    floor_deg: float
    threshold_deg: float
    noise_p: RepeatNoise  # from repeats (Pa)
    floor_kpa: float
    threshold_kpa: float

    def above(self, angle_deg: float, pressure_kpa: float | None) -> bool:
        """Is a residual of these rms values above the significance threshold in either channel, the
        angle or (where measured) the chamber pressures? Each channel is tested against its own
        floor: pooled into one misfit, a gap seen in one channel would be diluted by the other's
        samples (pressures are sampled more often than angles), and a gap the pressures show
        clearly would be no gap while the angle stays under its threshold."""
        return angle_deg > self.threshold_deg or (pressure_kpa is not None and pressure_kpa > self.threshold_kpa)

    def score(self, c: Candidate) -> float:
        """Held-out misfit in units of the floors, angle and (where measured) chamber pressure
        together: the ranking's key. Without pressures it is the angle rms over its floor."""
        return normalised_rms(c.heldout, c.heldout_p, self.floor_deg, self.floor_kpa)


def floors_of(twin: Twin, model_tolerance_deg: float) -> Floors:
    nz = angle_noise(twin)
    declared = twin.campaign.instrument.noise_deg
    noise_deg = declared if declared is not None else (0.0 if math.isnan(nz.sigma) else math.degrees(nz.sigma))
    drift_deg = 0.0 if math.isnan(nz.drift) else math.degrees(nz.drift)
    # a run departs from its repeats' mean by drift/sqrt(2): no effect fitted to all can explain that
    floor = math.sqrt(noise_deg**2 + drift_deg**2 / 2.0 + model_tolerance_deg**2)
    nzp = pressure_noise(twin)
    sp = (0.0 if math.isnan(nzp.sigma) else nzp.sigma / 1e3) ** 2 + (
        0.0 if math.isnan(nzp.drift) else nzp.drift / 1e3
    ) ** 2 / 2.0
    floor_kpa = math.sqrt(sp + MODEL_TOLERANCE_KPA**2)
    return Floors(
        noise_deg, nz, model_tolerance_deg, floor, SIGNIFICANCE * floor, nzp, floor_kpa, SIGNIFICANCE * floor_kpa
    )


@contextlib.contextmanager
def _parallel(n_jobs: int, scheduler: str | None):
    """joblib's Parallel on local threads (the compiled replay releases the GIL), or on a Dask
    cluster at `scheduler` (as `twin sweep --scheduler`), one client for every stage of the fits."""
    if not scheduler:
        yield lambda jobs: Parallel(n_jobs=n_jobs, backend="threading")(jobs)
        return

    def run(jobs):
        with parallel_config(backend="dask"):
            return Parallel()(jobs)

    with dask_client(scheduler):
        yield run


@dataclass
class Fits:
    """The candidates, each sorted by held-out score, and the wall time of their stages."""

    singles: list[Candidate]
    pairs: list[Candidate]
    skipped: list[str]  # catalogue effects already in the nominal twin
    timing: Timing


def fit_candidates(twin: Twin, catalogue, fl: Floors, significant: bool, run_jobs, progress: bool) -> Fits:
    """Step 3's fits: every single effect, then, when no single brings a significant gap under the
    threshold, the pair stage (`_pair_stage`)."""
    # effects already in the nominal twin at their catalogue value are not candidates
    effects = [
        e for e in catalogue if not (e.discrete_value is not None and e.value_of(twin.params) == e.discrete_value)
    ]
    folds = folds_of(twin.campaign)
    start = time.perf_counter()
    with _progress(len(effects), "gap: effects", progress):
        singles: list[Candidate] = run_jobs(delayed(fit_single)(twin, e, folds) for e in effects)
    singles.sort(key=fl.score)
    t_singles = time.perf_counter()
    pairs: list[Candidate] = []
    if significant and singles and fl.above(rms_deg(singles[0].heldout), rms_kpa(singles[0].heldout_p)):
        pairs = _pair_stage(twin, singles, folds, run_jobs, progress)
        pairs.sort(key=fl.score)
    t_pairs = time.perf_counter()
    timing = Timing(t_singles - start, t_pairs - t_singles, t_pairs - start)
    return Fits(singles, pairs, [e.name for e in catalogue if e not in effects], timing)


def nominal_residuals(twin: Twin, latency_s: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per run, the nominal twin's angle and pressure residuals, the instrument `latency_s` late."""
    res = twin.residuals_with([], range(len(twin.runs)), latency_s).values()
    return [a for a, _ in res], [p for _, p in res]


def check_finite(campaign: Campaign, angle: list[np.ndarray], pressure: list[np.ndarray]) -> None:
    """Refuse (GapError) a campaign whose nominal twin's replay is not finite (its model values put
    the replay where its 1 ms step diverges): never a verdict computed from NaN."""
    for run, a, p in zip(campaign.runs, angle, pressure, strict=True):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(p))):
            raise GapError(
                f"{campaign.folder / 'campaign.toml'}: the nominal twin's replay of {run.path.name} is not finite "
                f"(hose_length_m = {campaign.hose_length_m}, the run's rig_inertia_kg_m2 = {run.rig_inertia_kg_m2} "
                f"and payload_kg = {run.payload_kg}); allowed: values whose replay stays finite"
            )


def diagnose(
    campaign: Campaign,
    catalogue: tuple[Effect, ...] = CATALOGUE,
    model_tolerance_deg: float | None = None,
    n_jobs: int = 2,
    progress: bool = True,
    seed: int = 0,
    scheduler: str | None = None,
) -> Diagnosis:
    """The diagnosis of `campaign` (see the module docstring for its steps)."""
    tolerance = MODEL_TOLERANCE_DEG if model_tolerance_deg is None else model_tolerance_deg
    # the cluster first: a scheduler that does not answer is refused before any work
    with _parallel(n_jobs, scheduler) as run_jobs:
        twin = Twin(campaign)
        rng = np.random.default_rng(seed)
        fl = floors_of(twin, tolerance)
        if twin.has_pressure:  # each channel counts in units of its own floor
            twin.pressure_weight = (math.radians(fl.floor_deg) / (fl.floor_kpa * 1e3)) ** 2
        nominal_latency = twin.latency_of([], range(len(twin.runs)))
        twin.ref_latency_s = nominal_latency
        twin.gap_vector = twin.run_sses_and_residual([], list(range(len(twin.runs))))[1]
        before, before_p = nominal_residuals(twin, nominal_latency)
        check_finite(campaign, before, before_p)
        before_rms, before_kpa = rms_deg(before), rms_kpa(before_p)
        significant = fl.above(before_rms, before_kpa)
        fits = fit_candidates(twin, catalogue, fl, significant, run_jobs, progress)
        folds = folds_of(campaign)
        corrections = at_fold_latencies(twin, family_members(twin, fits.singles, catalogue), folds, run_jobs)

    judge = verdict.Judge(twin, fl, before_rms, fl.score, rng, before_kpa)
    call = judge.call(significant, fits.singles, fits.pairs)
    labels = where_labels(twin)
    family = judge.family_call(
        fits.singles,
        labels,
        twin.gap_vector,
        folds,
        corrections,
        among=verdict.families_of([call.top.name, *call.rivals]) if call.verdict == "ambiguous" else None,
    )
    # the instrument as best understood: the latency fitted with the answer (with the nominal twin
    # alone a latency soaks up part of any gap that makes the twin run ahead); the nominal twin's
    # residual, its breakdown and how far are reported at it
    latency = call.top.latency_s if call.top is not None else nominal_latency
    return result_of(judge, fits, call, family, labels, latency, rng)


def result_of(
    judge: verdict.Judge,
    fits: Fits,
    call: verdict.Call,
    family: verdict.FamilyCall,
    labels: dict[str, np.ndarray],
    latency_s: float,
    rng: np.random.Generator,
) -> Diagnosis:
    """The typed result, with the nominal twin's residual at `latency_s` (the bootstrap intervals
    draw from `rng` in the order: how far, before, top, ranking, pairs)."""
    twin, fl = judge.twin, judge.floors
    campaign = twin.campaign
    before, before_p = nominal_residuals(twin, latency_s)
    before_rms = rms_deg(before)
    how_far = {"before": error_by_pressure(campaign, before, rng)}
    for c in fits.singles + fits.pairs:
        how_far[c.name] = error_by_pressure(campaign, c.heldout, rng)
    before_ci = rms_ci_deg(before, rng)
    top = call.top
    which = Which(
        verdict=call.verdict,
        top=summarise(top, judge, before_rms, rng) if top is not None else None,
        rivals=call.rivals,
        pairs_refused=call.pairs_refused,
        # the family-level answer where no one candidate is (gap.verdict.Judge.family_call): outside the
        # catalogue, among every family; ambiguous, among the families of the candidates that explain
        nearest=family if call.verdict in ("outside the catalogue", "ambiguous") else None,
        families=family.evidence,
        ranking=[summarise(c, judge, before_rms, rng) for c in fits.singles],
        pairs=[summarise(c, judge, before_rms, rng) for c in fits.pairs],
        skipped_already_in_twin=fits.skipped,
    )
    return Diagnosis(
        campaign=str(campaign.folder),
        joint=campaign.joint,
        runs=[r.name for r in campaign.runs],
        windowed={r.name: r.recorded_s for r in campaign.runs if r.recorded_s is not None},
        twin=TwinFacts(twin.params.hose_loss, twin.inertia),
        folds="leave one supply pressure out" if len(supplies(campaign)) > 1 else "alternating split",
        instrument=instrument.describe(campaign.instrument, twin.nuisance, latency_s, campaign.runs),
        noise_floor=noise_floor_of(fl, campaign),
        pressure=pressure_floor_of(fl, before_p) if twin.has_pressure else PressureFloor(False),
        before_rms_deg=before_rms,
        before_rms_ci95_deg=before_ci,
        where=where.breakdown(labels, np.concatenate(before)),
        which=which,
        how_far=how_far,
        replays=twin.n_replays,
        timing_s=fits.timing,
        residuals=Residuals(before, top.heldout if top is not None else None, [pr.ts for pr in twin.runs]),
    )


def summarise(c: Candidate, judge: verdict.Judge, before_rms: float, rng: np.random.Generator) -> CandidateSummary:
    """Candidate c as reported; its shrink against the nominal twin's rms `before_rms`."""
    lo, hi = rms_ci_deg(c.heldout, rng)
    effects = [BY_NAME[x] for x in c.effects]
    heldout_rms = rms_deg(c.heldout)
    explains = judge.explains(c)  # first: it asks for the twin's spread where the rms alone is over the bar
    return CandidateSummary(
        name=c.name,
        effects=c.effects,
        labels=[e.label for e in effects],
        families=[e.family for e in effects],
        fields=[e.field for e in effects],
        nominal_values=[e.value_of(judge.twin.params) for e in effects],
        fitted_values=c.full_values,
        fold_values=c.fold_values,
        at_bound=verdict.at_bounds(c),
        off_nominal=verdict.off_nominal(c, judge.twin.params),
        latency_s=c.latency_s,
        heldout_rms_deg=heldout_rms,
        heldout_pressure_rms_kpa=rms_kpa(c.heldout_p),
        score_in_floors=judge.score(c),
        heldout_rms_ci95_deg=(lo, hi),
        shrink=heldout_rms / before_rms if before_rms > 0 else math.nan,
        explains=explains,
        heldout_beyond_spread_deg=judge.beyond_spread_deg(c) if c.spread is not None else None,
        spread_deg=np.degrees(c.spread).tolist() if c.spread is not None else None,
    )


def supplies(campaign: Campaign) -> list[float]:
    """The campaign's supply pressures (MPa, rounded to 4 decimals), ascending."""
    return sorted({round(r.supply_mpa, 4) for r in campaign.runs})


def error_by_pressure(campaign: Campaign, res: list[np.ndarray], rng: np.random.Generator) -> dict[str, PressureError]:
    """Per supply: mean and max |residual| (deg) over its runs, the mean's bootstrap interval."""
    out = {}
    for q in supplies(campaign):
        ks = [k for k, r in enumerate(campaign.runs) if round(r.supply_mpa, 4) == q]
        vals = [np.rad2deg(np.abs(res[k])) for k in ks]
        allv = np.concatenate(vals)
        out[f"{q:.2f}"] = PressureError(float(allv.mean()), float(allv.max()), bootstrap_ci(vals, rng, 300), len(ks))
    return out


def noise_floor_of(fl: Floors, campaign: Campaign) -> NoiseFloor:
    return NoiseFloor(
        measurement_deg=fl.noise_deg,
        measurement_from="declared" if campaign.instrument.noise_deg is not None else "repeats",
        repeat_noise_deg=math.degrees(fl.noise.sigma),
        repeat_drift_deg=math.degrees(fl.noise.drift),
        repeat_pairs=fl.noise.pairs,
        repeat_samples=fl.noise.samples,
        model_tolerance_deg=fl.tolerance_deg,
        floor_deg=fl.floor_deg,
        significance_threshold_deg=fl.threshold_deg,
    )


def pressure_floor_of(fl: Floors, before_p: list[np.ndarray]) -> PressureFloor:
    return PressureFloor(
        measured=True,
        noise_kpa=fl.noise_p.sigma / 1e3,
        drift_kpa=fl.noise_p.drift / 1e3,
        model_tolerance_kpa=MODEL_TOLERANCE_KPA,
        floor_kpa=fl.floor_kpa,
        before_rms_kpa=rms_kpa(before_p),
        significance_threshold_kpa=fl.threshold_kpa,
    )


class _progress:
    """A tqdm bar on stderr around a stage (joblib jobs cannot tick it from a Dask worker)."""

    def __init__(self, total: int, desc: str, enabled: bool):
        self.bar = tqdm(total=total, desc=desc, file=sys.stderr, disable=not enabled)

    def __enter__(self):
        return self.bar

    def __exit__(self, *exc):
        self.bar.update(self.bar.total - self.bar.n)
        self.bar.close()


def _pair_stage(twin: Twin, singles: list[Candidate], folds, run_jobs, progress: bool) -> list[Candidate]:
    """Pairs of the PAIR_POOL best singles (`screened_pairs`) screened in-sample (`screen_pair`)
    over one run per distinct command and supply (repeats differ only by measurement noise); the
    best N_PAIRS_CV get the full grid on all runs and the cross-validated fit."""
    combos = screened_pairs(singles[:PAIR_POOL], twin.gap_vector)  # singles come sorted by held-out score
    distinct = sorted({pr.run.signature(): k for k, pr in reversed(list(enumerate(twin.runs)))}.values())
    with _progress(len(combos), "gap: pairs", progress):
        screen = run_jobs(delayed(screen_pair)(twin, a, b, distinct) for a, b in combos)
    order = np.argsort(screen)[:N_PAIRS_CV]
    return run_jobs(delayed(_cv_pair)(twin, combos[i][0], combos[i][1], folds) for i in order)


def screened_pairs(pool: list[Candidate], gap: np.ndarray) -> list[tuple[Candidate, Candidate]]:
    """The pairs of `pool` (best single first) the replayed screen sees: every pair of the best
    single, and the PAIR_SCREEN pairs whose corrections, simply added, fit `gap` best."""
    combos = [(a, b) for i, a in enumerate(pool) for b in pool[i + 1 :]]
    added = set(np.argsort([superposed_sse(a, b, gap) for a, b in combos], kind="stable")[:PAIR_SCREEN])
    return [c for i, c in enumerate(combos) if c[0] is pool[0] or i in added]


def superposed_sse(a: Candidate, b: Candidate, gap: np.ndarray) -> float:
    """A pair's least misfit over both singles' replayed values with the two corrections simply
    added (no replay): the pre-screen that picks the PAIR_SCREEN pairs the replayed screen sees."""
    da, db = a.grid_residuals - gap, b.grid_residuals - gap  # minus each single's correction
    sse = (
        gap @ gap
        + np.sum(da**2, axis=1)[:, None]
        + np.sum(db**2, axis=1)[None, :]
        + 2.0 * (da @ gap)[:, None]
        + 2.0 * (db @ gap)[None, :]
        + 2.0 * da @ db.T
    )
    return float(sse.min())


def _cv_pair(twin: Twin, a: Candidate, b: Candidate, folds) -> Candidate:
    return fit_pair(twin, a, b, folds, pair_grid(twin, a, b))
