"""The gap of the whole arm: which joint departs, where, which effect, and how far it closes.

Steps (each its own function below):
  1. the nominal twin replays every run's logged commands (gap/arm_replay.py); the instrument's
     latency is the declared one, or the one on LATENCY_GRID_S that fits the nominal replay best;
  2. where: per joint, the residual (measured - twin) of its angle in units of the instrument's
     noise and of its two platform port pressures in units of the transducers' noise; the
     departing joint is the one whose larger channel is furthest out, the gap significant when
     that is over SIGNIFICANT floors. For that joint the residual is broken down as
     gap/where.py does for one joint (phase, supply, direction, speed, ...) and by its posture
     (the gravity torque on it, at the twin's pose);
  3. which: every catalogue effect on the departing joint and every arm-level effect
     (gap/arm_effects.py) is probed on the training runs, shortened to SCREEN_S: one probe replay
     a candidate, its correction (twin with it - nominal twin) scaled to fit the residual best
     (either way, within the bounds) ranks it and says where its value lies; the best TOP are
     fitted together on the training runs (three points around that estimate, then the vertex of
     a parabola: four replays of each training run a candidate) and judged on the withheld runs;
  4. how far: on the withheld runs, per joint, the rms before and after the best candidate.
The runs alternate between training and withheld (every other run withheld).

Verdicts: no significant gap; explained (the best candidate brings every joint under SIGNIFICANT
floors on the withheld runs, or shrinks the gap's misfit there to under EXPLAINED_SHRINK, or,
where neither, shrinks it so up to the runs' knife edges: `knife_edges`); or outside the
catalogue, naming the nearest family (the best candidate's).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import mujoco
import numpy as np
from joblib import delayed

import assets
from gap.arm_campaign import JOINTS, ArmCampaign, ArmRun
from gap.arm_effects import ArmCandidate, ArmSetup, candidates
from gap.arm_replay import TICK_S, Replay, arm_plant, joint_angles, replay
from gap.campaign import MeasuredRun
from gap.jobs import parallel_jobs
from gap.kinds import Family, Verdict
from gap.where import breakdown, labels_of
from pneumatics import JointParams, load_joint_params
from pneumatics.as_built import load_as_built
from pneumatics.gas import AIR

LATENCY_GRID_S = np.round(np.arange(0.0, 0.06 + 1e-9, 0.005), 6)  # as gap/instrument.py's: 0-60 ms
SIGNIFICANT = 2.0  # floors: a channel's rms residual this many times its noise is a gap (gap/verdict.py's rule)
EXPLAINED_SHRINK = 0.1  # a candidate leaving at most this fraction of the misfit on withheld runs explains it
SCREEN_S = 20.0  # the probes replay the training runs' first 20 s (the fits and the judgement replay them whole)
TOP = 3  # candidates fitted after the screen
SECOND_LOOK = 6  # candidates the screen probes again at the value its first probe points at
GRAVITY_BINS_NM = (-100.0, -30.0, -10.0, 10.0, 30.0, 100.0)  # the posture factor's bin edges


@dataclass(frozen=True)
class ReplayedArm:
    """The arm the diagnosis replays (the twin, or the twin with a candidate): each joint's
    parameters and the arm's setup."""

    params: dict[str, JointParams]
    setup: ArmSetup


def twin_of(campaign: ArmCampaign) -> ReplayedArm:
    """campaign.toml's twin: its base arm (as built or nominal), hose switch and payload."""
    base = {j: load_joint_params(assets.joint_param_path(j)) for j in JOINTS}
    if campaign.arm == "as_built":
        base = {j: load_as_built(p, assets.as_built_path(j)) for j, p in base.items()}
    if campaign.hose_loss is not None:
        base = {j: p._replace(hose_loss=1.0 if campaign.hose_loss else 0.0) for j, p in base.items()}
    return ReplayedArm(base, ArmSetup(payload_kg=campaign.payload_kg))


@dataclass(frozen=True)
class JointGap:
    """One joint's residual: rms in rad and Pa, and each in units of its floor."""

    joint: str
    angle_rms_deg: float
    pressure_rms_kpa: float
    angle_floors: float
    pressure_floors: float

    @property
    def floors(self) -> float:
        return max(self.angle_floors, self.pressure_floors)


@dataclass(frozen=True)
class Fit:
    candidate: str
    family: Family
    value: float
    train_misfit: float
    withheld_misfit: float
    withheld_shrink: float  # withheld misfit with it / without it
    withheld_after: list[JointGap] = field(default_factory=list)
    # judged up to the withheld runs' knife edges (`knife_edges`), where the misfit over the whole runs fell short
    knife_edge_s: list[float] | None = None  # per withheld run, the time of its knife edge (its end: none)
    shrink_before_knife_edges: float | None = None  # the withheld misfit before them with it / without it


@dataclass
class ArmDiagnosis:
    verdict: Verdict  # no significant gap, explained or outside the catalogue (no tie is called)
    joint: str  # the departing joint ("" when no significant gap)
    effect: str  # the candidate named ("" unless explained)
    family: Family | None  # its family (outside: the nearest; None when no significant gap)
    latency_s: float
    joints: list[JointGap]  # all runs, nominal twin
    withheld_before: list[JointGap]
    withheld_after: list[JointGap]
    where: dict[str, dict[str, dict]]  # the departing joint's breakdown, factor -> bin -> Bin fields
    screen: list[tuple[str, float]]  # every candidate with its screened misfit ratio, best first
    fits: list[Fit]
    training_runs: list[str]
    withheld_runs: list[str]

    def line(self) -> str:
        if not self.verdict.alarm:
            return "no significant gap: every joint within its floors"
        if self.verdict.explained:
            best = self.fits[0]
            before_edges = (
                f"; x{best.shrink_before_knife_edges:.3f} before the runs' knife edges"
                if best.shrink_before_knife_edges is not None
                else ""
            )
            return (
                f"{self.joint} departs; explained by {self.effect} = {best.value:.4g} "
                f"(withheld misfit x{best.withheld_shrink:.3f}{before_edges})"
            )
        return f"{self.joint} departs; outside the catalogue, nearest family {self.family}"

    def as_dict(self) -> dict:
        """The diagnosis as diagnosis.json holds it: no family written "" (as its other texts)."""
        return asdict(self) | {"family": self.family or ""}


def _replays(
    run_jobs, runs: list[ArmRun], twins: list[ReplayedArm], t_end_s: float | None = None
) -> list[list[Replay]]:
    """Every twin's replay of every run, one job a (twin, run)."""
    jobs = [delayed(replay)(r, t.params, t.setup, t_end_s) for t in twins for r in runs]
    out = run_jobs(jobs)
    return [out[i * len(runs) : (i + 1) * len(runs)] for i in range(len(twins))]


@dataclass(frozen=True)
class Residual:
    """One run's residuals at the measured samples, per joint: angle (rad, NaN where no sample),
    port pressures (Pa)."""

    angle: np.ndarray  # (n, J)
    port: np.ndarray  # (n, J, 2)


def _rows_inside(run: ArmRun, rep: Replay) -> int:
    """How many of the run's rows come before the replay's end."""
    return min(len(run.time_s), int(np.searchsorted(run.time_s, rep.time_s[-1] + 1e-9)))


def _angles_at(rep: Replay, t: np.ndarray) -> np.ndarray:
    """The replay's joint angles (rad) at the times `t`, (len(t), J)."""
    return np.stack([np.interp(t, rep.time_s, rep.angle_rad[:, j]) for j in range(len(JOINTS))], 1)


def residual(run: ArmRun, rep: Replay, latency_s: float) -> Residual:
    """measured - twin at the run's rows inside the replay (the twin's angle read `latency_s` late)."""
    n = _rows_inside(run, rep)
    t = run.time_s[:n]
    twin_angle = _angles_at(rep, t - latency_s)
    twin_port = np.stack(
        [np.stack([np.interp(t, rep.time_s, rep.port_pa[:, j, c]) for c in range(2)], 1) for j in range(len(JOINTS))],
        1,
    )
    return Residual(run.angle_rad[:n] - twin_angle, run.port_pa[:n] - twin_port)


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else 0.0


def joint_gaps(residuals: list[Residual], campaign: ArmCampaign) -> list[JointGap]:
    noise_a, noise_p = campaign.instrument.noise_rad(), campaign.pressures.noise_pa
    out = []
    for j, name in enumerate(JOINTS):
        a = _rms(np.concatenate([r.angle[:, j] for r in residuals]))
        p = _rms(np.concatenate([r.port[:, j].ravel() for r in residuals]))
        out.append(
            JointGap(name, math.degrees(a), p / 1e3, a / noise_a if noise_a else 0.0, p / noise_p if noise_p else 0.0)
        )
    return out


def misfit(residuals: list[Residual], campaign: ArmCampaign) -> float:
    """The sum over joints of each channel's mean square residual in units of its floor squared."""
    return sum(g.angle_floors**2 + g.pressure_floors**2 for g in joint_gaps(residuals, campaign))


def fit_latency(campaign: ArmCampaign, runs: list[ArmRun], reps: list[Replay]) -> float:
    """The declared latency, or the grid's that fits the nominal twin's angles best."""
    if campaign.instrument.latency_s is not None:
        return campaign.instrument.latency_s
    costs = [
        sum(_rms(residual(r, p, lat).angle) ** 2 for r, p in zip(runs, reps, strict=True)) for lat in LATENCY_GRID_S
    ]
    return float(LATENCY_GRID_S[int(np.argmin(costs))])


def gravity_torques(joint: str, twin: ReplayedArm, start_rad: np.ndarray, drive_rad: np.ndarray) -> np.ndarray:
    """The gravity torque on `joint`'s drive (N·m, holding the arm up is positive) at each row of
    drive angles (the twin's pose): MuJoCo's bias force at rest (`qfrc_bias` with no velocity,
    by its recursive Newton-Euler pass after the kinematics: what mj_forward gives, without the
    contacts and constraints it solves besides) on the joints' own coordinates, carried to the
    drives' by virtual work: the drives' torques tau with A^T tau = bias, A the drive map (drive
    angles = A q; the elbow's drive is shoulder + elbow, so moving the shoulder's drive with the
    elbow's held keeps the forearm's pitch, as the parallelogram does). Equal to the slope of the
    arm's potential energy along the drive angle (tests/test_gap_arm_design.py)."""
    plant = arm_plant(twin.params, twin.setup, start_rad)
    m, d = plant.model, plant.data
    dofs = [int(m.joint(j).dofadr[0]) for j in plant.joints]
    a = np.zeros((len(plant.joints), len(dofs)))
    for i in range(len(plant.joints)):
        for _, dof, c in plant.drive_map[i]:
            if c != 0.0:
                a[i, dofs.index(int(dof))] += c
    i_joint = plant.joints.index(joint)
    addresses, q = joint_angles(plant, drive_rad)
    d.qvel[:] = 0.0
    bias = np.empty(m.nv)
    out = np.empty(len(q))
    for k, row in enumerate(q):
        d.qpos[addresses] = row
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_rne(m, d, 0, bias)
        out[k] = np.linalg.solve(a.T, bias[dofs])[i_joint]
    return out


def where(
    joint: str, twin: ReplayedArm, runs: list[ArmRun], reps: list[Replay], residuals: list[Residual], latency_s: float
) -> dict[str, dict[str, dict]]:
    """The departing joint's angle residual broken down by gap/where.py's factors and by posture."""
    j = JOINTS.index(joint)
    labels, res = [], []
    for run, rep, r in zip(runs, reps, residuals, strict=True):
        n = len(r.angle)
        sampled = np.isfinite(r.angle[:, j])
        ts = run.time_s[:n][sampled]
        angle = np.interp(ts, rep.time_s, rep.angle_rad[:, j])
        speed = np.gradient(rep.angle_rad[:, j], rep.time_s)
        one = MeasuredRun(
            name=run.name,
            path=run.path,
            supply_mpa=(float(np.mean(run.supply_pa)) - AIR.p_atm_pa) / 1e6,
            start_rad=float(run.start_rad[j]),
            time_s=run.time_s[:n],
            direction=run.commands[:n, j, 0],
            brake_released=run.commands[:n, j, 2],
            valve_gauge_pa=run.commands[:n, j, 1],
            supply_pa=run.supply_pa[:n],
            angle_rad=run.angle_rad[:n, j],
        )
        lab = labels_of(one, ts, angle, np.interp(ts, rep.time_s, speed))
        poses = _angles_at(rep, ts)
        g = gravity_torques(joint, twin, run.start_rad, poses)
        edges = np.digitize(g, GRAVITY_BINS_NM)
        names = [f"<{GRAVITY_BINS_NM[0]:g}"] + [
            f"{a:g}..{b:g}" for a, b in zip(GRAVITY_BINS_NM[:-1], GRAVITY_BINS_NM[1:], strict=True)
        ]
        names.append(f">{GRAVITY_BINS_NM[-1]:g}")
        lab["gravity_torque_nm"] = np.array([names[e] for e in edges], dtype=object)
        labels.append(lab)
        res.append(r.angle[:, j][sampled])
    merged = {f: np.concatenate([lab[f] for lab in labels]) for f in labels[0]}
    residual_rad = np.concatenate(res)
    out = {
        f: {k: asdict(v) for k, v in bins.items()} for f, bins in breakdown(merged, residual_rad).by_factor().items()
    }
    out["gravity_torque_nm"] = _bins(merged["gravity_torque_nm"], residual_rad)
    return out


def _bins(labels: np.ndarray, residual_rad: np.ndarray) -> dict[str, dict]:
    res = np.degrees(residual_rad)
    return {
        str(b): {
            "rms_deg": float(np.sqrt(np.mean(res[labels == b] ** 2))),
            "mean_deg": float(np.mean(res[labels == b])),
            "max_abs_deg": float(np.max(np.abs(res[labels == b]))),
            "n": int((labels == b).sum()),
        }
        for b in sorted(set(labels), key=str)
    }


@dataclass(frozen=True)
class Axis:
    """The coordinate a candidate's value is searched on: log(value) where the catalogue spaces it
    logarithmically and its low bound is above 0, the value itself otherwise."""

    lo: float
    hi: float
    log: bool

    def x(self, value: float) -> float:
        return math.log(value) if self.log else value

    def value(self, x: float) -> float:
        return float(np.clip(math.exp(x) if self.log else x, self.lo, self.hi))

    @property
    def x_lo(self) -> float:
        return self.x(self.lo)

    @property
    def x_hi(self) -> float:
        return self.x(self.hi)


def axis_of(c: ArmCandidate) -> Axis:
    lo, hi = c.bounds
    return Axis(lo, hi, c.log and lo > 0)


def probe_value(c: ArmCandidate, twin: ReplayedArm) -> float | None:
    """The screen's probe: a quarter of the way from the twin's value towards the upper bound (a
    catalogue effect is mostly more of something: friction, leakage, lag), towards the lower one
    where the twin is at the upper; log-spaced where the effect is. None: nowhere to move."""
    lo, hi = c.bounds
    now = c.value_in(twin.params, twin.setup, JOINTS)
    for bound in (hi, lo):
        if abs(bound - now) > 1e-12 * max(1.0, abs(bound)):
            if c.log and now > 0 and bound > 0:
                return float(now * (bound / now) ** 0.25)
            return float(now + 0.25 * (bound - now))
    return None


def _with(twin: ReplayedArm, c: ArmCandidate, value: float) -> ReplayedArm:
    params, setup = c.apply(twin.params, twin.setup, JOINTS, value)
    return ReplayedArm(params, setup)


@dataclass(frozen=True)
class Screened:
    """A candidate's screen: the misfit ratio its probe's correction leaves, scaled to fit the
    residual, and the value that scale points at (the fit starts there)."""

    candidate: ArmCandidate
    ratio: float
    estimate: float


def _shortened(rep: Replay, t_end_s: float) -> Replay:
    """The first `t_end_s` of a replay: what a replay stopped there gives (the same ticks, bit for bit)."""
    n = int(t_end_s / TICK_S + 1e-9) + 1
    return Replay(rep.time_s[:n], rep.angle_rad[:n], rep.port_pa[:n])


def screen(
    run_jobs,
    campaign: ArmCampaign,
    twin: ReplayedArm,
    runs: list[ArmRun],
    latency_s: float,
    cands: list[ArmCandidate],
    nominal: list[Replay] | None = None,
    joint: str | None = None,
) -> list[Screened]:
    """Each candidate ranked without a fit, on `runs` shortened to SCREEN_S, best first: one probe
    replay (`probe_value`), its correction (twin with it - nominal) scaled to fit the residual
    best, either way (to first order the correction of a step the other way is the same, negated),
    as far as the bounds allow; then the best SECOND_LOOK once more, probed at the value the first
    scale points at (an effect far from linear, dry friction, is ranked by what it does there),
    each ranked by the better of its looks.
    `joint`: the departing joint (step 1). Its own channels are where the gap is furthest out, and
    where an effect's correction is scaled without the others' noise: a joint near its breakaway
    elsewhere in the arm (stalling or not at a small change) blurs the whole residual's scale, and
    an effect of the whole arm (a mounting tilt) is then probed again only a quarter of the way to
    its value. So the SECOND_LOOK best by the departing joint's channels alone are probed again too,
    at the value their scale there points at; every look is ranked on the whole residual.
    `nominal`: the nominal twin's replays of `runs` (any length), or None to replay them here."""
    probes = [(c, v) for c in cands if (v := probe_value(c, twin)) is not None]
    if nominal is None:
        reps = _replays(run_jobs, runs, [twin] + [_with(twin, c, v) for c, v in probes], SCREEN_S)
        nominal, reps = reps[0], reps[1:]
    else:
        reps = _replays(run_jobs, runs, [_with(twin, c, v) for c, v in probes], SCREEN_S)
        nominal = [_shortened(p, SCREEN_S) for p in nominal]
    weights = _weights(campaign)
    base_res = [residual(r, p, latency_s) for r, p in zip(runs, nominal, strict=True)]
    base = _stack(base_res, weights)
    own = None if joint is None else JOINTS.index(joint)
    base_own = None if own is None else _stack(base_res, weights, own)

    def looks(c: ArmCandidate, v: float, rp: list[Replay]) -> tuple[Screened, Screened | None]:
        """(the whole residual's look, the departing joint's) at the probe `v`."""
        res = [residual(r, p, latency_s) for r, p in zip(runs, rp, strict=True)]
        whole = _scaled(base, base - _stack(res, weights), c, twin, v)
        if own is None:
            return whole, None
        return whole, _scaled(base_own, base_own - _stack(res, weights, own), c, twin, v)

    first = [looks(c, v, rp) for (c, v), rp in zip(probes, reps, strict=True)]
    wholes = sorted((w for w, _ in first), key=lambda s: s.ratio)
    owns = sorted((o for _, o in first if o is not None), key=lambda s: s.ratio)
    again: dict[tuple[str, float], ArmCandidate] = {}
    for s in wholes[:SECOND_LOOK] + owns[:SECOND_LOOK]:
        if s.estimate != s.candidate.value_in(twin.params, twin.setup, JOINTS):
            again.setdefault((s.candidate.name, s.estimate), s.candidate)
    reps = _replays(run_jobs, runs, [_with(twin, c, v) for (_, v), c in again.items()], SCREEN_S)
    best = {s.candidate.name: s for s in wholes}
    for ((name, v), c), rp in zip(again.items(), reps, strict=True):
        # each candidate by the best of its looks on the whole residual (first-order guesses; the fits decide)
        best[name] = min(best[name], looks(c, v, rp)[0], key=lambda x: x.ratio)
    return sorted(best.values(), key=lambda s: s.ratio)


def _scaled(base: np.ndarray, corr: np.ndarray, c: ArmCandidate, twin: ReplayedArm, probe: float) -> Screened:
    """The probe's correction `corr` (what the effect at `probe` adds to the twin, in the residual's
    units) scaled to fit the residual `base` best, the value it points at kept inside the bounds."""
    axis = axis_of(c)
    x_now, x_probe = axis.x(c.value_in(twin.params, twin.setup, JOINTS)), axis.x(probe)
    scale = float(base @ corr) / float(corr @ corr) if float(corr @ corr) > 0 else 0.0
    x_est = float(np.clip(x_now + scale * (x_probe - x_now), axis.x_lo, axis.x_hi))
    scale = (x_est - x_now) / (x_probe - x_now)  # the scale of the value kept inside the bounds
    left = base - scale * corr
    return Screened(c, float(left @ left) / (float(base @ base) or 1.0), axis.value(x_est))


def _weights(campaign: ArmCampaign) -> tuple[float, float]:
    return 1.0 / campaign.instrument.noise_rad(), 1.0 / campaign.pressures.noise_pa


def _stack(residuals: list[Residual], weights: tuple[float, float], joint: int | None = None) -> np.ndarray:
    """Every residual sample (or one joint's, `joint` its index) in units of its floor, NaN (not
    sampled) as 0, as one vector."""
    pick = slice(None) if joint is None else slice(joint, joint + 1)
    parts = []
    for r in residuals:
        parts += [
            np.nan_to_num(r.angle[:, pick].ravel()) * weights[0],
            np.nan_to_num(r.port[:, pick].ravel()) * weights[1],
        ]
    return np.concatenate(parts)


STEP = 0.25  # the fit's first points: the screen's estimate and this fraction of its move either side
MIN_STEP = 0.05  # ... and at least this fraction of the search range


def _first_points(axis: Axis, x_now: float, x_est: float) -> list[float]:
    """Three points around the screen's estimate, inside the bounds."""
    span = axis.x_hi - axis.x_lo
    h = max(STEP * abs(x_est - x_now), MIN_STEP * span)
    centre = float(np.clip(x_est, axis.x_lo + h, axis.x_hi - h)) if span > 2 * h else 0.5 * (axis.x_lo + axis.x_hi)
    return sorted({float(np.clip(centre + k * h, axis.x_lo, axis.x_hi)) for k in (-1, 0, 1)})


def _vertex(axis: Axis, costs: dict[float, float]) -> float:
    """Where the parabola through the three cheapest points has its minimum (inside the bounds and
    at most twice their spread beyond them); where it has none, a spread beyond the cheapest."""
    best = min(costs, key=costs.get)
    if len(costs) < 3:
        return best
    (x0, c0), (x1, c1), (x2, c2) = sorted(sorted(costs.items(), key=lambda p: p[1])[:3])
    spread = x2 - x0
    curvature = ((c2 - c1) / (x2 - x1) - (c1 - c0) / (x1 - x0)) / spread
    if curvature * spread**2 > 1e-9 * (max(c0, c1, c2) - min(c0, c1, c2)):  # a minimum, not a line's rounding
        slope = (c2 - c0) / spread  # the parabola's slope at the middle of x0..x2
        x = 0.5 * (x0 + x2) - slope / (2.0 * curvature)
    else:
        x = best + spread * (1.0 if best >= x1 else -1.0)
    return float(np.clip(x, max(axis.x_lo, x0 - 2 * spread), min(axis.x_hi, x2 + 2 * spread)))


def fit_all(
    run_jobs,
    campaign: ArmCampaign,
    twin: ReplayedArm,
    train: list[ArmRun],
    latency_s: float,
    screened: list[Screened],
    nominal_misfit: float,
) -> list[tuple[float, float]]:
    """(value, training misfit) of each screened candidate, all fitted together (their replays in one
    batch a round): the misfit at the screen's estimate and a step either side, then at the vertex
    of the parabola through the cheapest three (the nominal twin's misfit among them); the cheapest
    point evaluated is the fit."""
    axes = [axis_of(s.candidate) for s in screened]
    x_now = [a.x(s.candidate.value_in(twin.params, twin.setup, JOINTS)) for a, s in zip(axes, screened, strict=True)]
    costs: list[dict[float, float]] = [{} for _ in screened]

    def evaluate(points: list[list[float]]) -> None:
        todo = [(i, x) for i, xs in enumerate(points) for x in xs if x not in costs[i]]
        twins = [_with(twin, screened[i].candidate, axes[i].value(x)) for i, x in todo]
        for (i, x), reps in zip(todo, _replays(run_jobs, train, twins), strict=True):
            costs[i][x] = misfit([residual(r, p, latency_s) for r, p in zip(train, reps, strict=True)], campaign)

    evaluate([_first_points(a, xn, a.x(s.estimate)) for a, xn, s in zip(axes, x_now, screened, strict=True)])
    evaluate([[_vertex(a, {xn: nominal_misfit} | c)] for a, xn, c in zip(axes, x_now, costs, strict=True)])
    best = [min(c, key=c.get) for c in costs]
    return [(a.value(x), c[x]) for a, x, c in zip(axes, best, costs, strict=True)]


# A change of a fitted value far finer than the fits resolve (their steps are at least MIN_STEP of
# the range): 1 % of the value where the catalogue spaces it logarithmically (0.01 in log), 1 % of
# it (of the range's hundredth where it is 0) otherwise. A replay that moves by more than SIGNIFICANT
# floors for it is on a knife edge: measured on point-to-point moves with the elbow's Coulomb
# friction at 60 N·m hidden, the twin at 60 left 0.002 of the withheld misfit, at 60.25 0.14 and at
# 57.5 0.17 (at 57 0.03), all from one run where the elbow stalls 6° apart at 2 s and the wrist,
# carried, 8° apart after it: a fit cannot find a window 0.1 N·m wide, nor a real twin sit in it.
KNIFE_EDGE_STEP = 0.01


def _nudged(c: ArmCandidate, value: float) -> list[float]:
    """`value` moved KNIFE_EDGE_STEP either way (see there), inside the bounds."""
    axis = axis_of(c)
    if axis.log:
        return [axis.value(axis.x(value) + s * KNIFE_EDGE_STEP) for s in (1.0, -1.0)]
    step = KNIFE_EDGE_STEP * (abs(value) or 0.01 * (axis.hi - axis.lo))
    return [axis.value(value + s * step) for s in (1.0, -1.0)]


def knife_edges(runs: list[ArmRun], at: list[Replay], nudged: list[list[Replay]], noise_rad: float) -> list[int]:
    """Per run, how many of its rows come before its knife edge: the first sample where a replay of
    the twin nudged (`nudged`, each a replay of every run) leaves the one at the value (`at`) by
    more than SIGNIFICANT times the instrument's noise in any joint's angle (its length: none).
    After it the twin itself cannot say where the arm went: a drive that only just beats the
    friction lets go, or not, for a change of value no fit resolves, and every sample after it
    carries the difference (the replay is open loop). The one-joint diagnosis holds such a run to
    the twin's own spread (gap.verdict.Judge.beyond_spread_deg); the arm's replays, five joints
    each near its breakaway somewhere, part ways once and for good, so the runs are judged up to it."""
    out = []
    for k, (run, rep) in enumerate(zip(runs, at, strict=True)):
        t = run.time_s[: _rows_inside(run, rep)]  # the rows `residual` keeps: the counts cut its residuals
        angle = _angles_at(rep, t)
        worst = np.zeros(len(t))
        for other in nudged:
            worst = np.maximum(worst, np.abs(angle - _angles_at(other[k], t)).max(axis=1))
        over = np.nonzero(worst > SIGNIFICANT * noise_rad)[0]
        out.append(int(over[0]) if over.size else len(t))
    return out


def shrink_before_knife_edges(
    run_jobs,
    campaign: ArmCampaign,
    twin: ReplayedArm,
    runs: list[ArmRun],
    latency_s: float,
    c: ArmCandidate,
    value: float,
    nominal: list[Residual],
    at: list[Replay],
) -> tuple[list[float], float | None]:
    """The candidate `c` at `value` judged on `runs` up to their knife edges (`knife_edges`): the
    times of the edges, and the misfit there with it / the nominal twin's (`nominal`: its residuals
    on the runs) there; None when no joint's gap there is over SIGNIFICANT floors (nothing to judge)."""
    nudged = _replays(run_jobs, runs, [_with(twin, c, v) for v in _nudged(c, value)])
    rows = knife_edges(runs, at, nudged, campaign.instrument.noise_rad())
    times = [float(r.time_s[n - 1]) if n else 0.0 for r, n in zip(runs, rows, strict=True)]
    kept = [k for k, n in enumerate(rows) if n > 0]
    if not kept:
        return times, None

    def cut(res: list[Residual]) -> list[Residual]:
        return [Residual(res[k].angle[: rows[k]], res[k].port[: rows[k]]) for k in kept]

    if max(g.floors for g in joint_gaps(cut(nominal), campaign)) <= SIGNIFICANT:
        return times, None  # the gap does not show before the edges: they cannot judge it
    before = misfit(cut(nominal), campaign)
    after = misfit(cut([residual(r, p, latency_s) for r, p in zip(runs, at, strict=True)]), campaign)
    return times, (after / before if before > 0 else None)


@dataclass(frozen=True)
class Signature:
    """What an effect at a value leaves in a campaign's signals beyond the twin's, noise-free: the twin
    with it replayed against the twin without, at the instruments' own samples, in units of their
    noise."""

    joints: list[JointGap]  # per joint, the difference's rms (angle, ports) in floors
    snr: float  # its norm: the statistic of the best test there is (knowing the effect, its value)

    @property
    def floors(self) -> float:
        return max(g.floors for g in self.joints)

    @property
    def below_floor(self) -> bool:
        """Below the rule of step 1: a joint's measured rms is sqrt(1 + floors^2) of its noise
        (noise and signature add in quadrature), under SIGNIFICANT while floors < sqrt(SIGNIFICANT^2 - 1)."""
        return self.floors < math.sqrt(SIGNIFICANT**2 - 1.0)


def signature(campaign: ArmCampaign, c: ArmCandidate, value: float, latency_s: float, n_jobs: int = 1) -> Signature:
    """The signature of `c` at `value` in `campaign`'s runs (see Signature), the instrument read
    `latency_s` late."""
    twin = twin_of(campaign)
    with parallel_jobs(n_jobs, None) as run_jobs:
        nominal, with_it = _replays(run_jobs, campaign.runs, [twin, _with(twin, c, value)])
    diff = []
    for run, a, b in zip(campaign.runs, nominal, with_it, strict=True):
        ra, rb = residual(run, a, latency_s), residual(run, b, latency_s)
        diff.append(Residual(ra.angle - rb.angle, ra.port - rb.port))
    return Signature(joint_gaps(diff, campaign), float(np.linalg.norm(_stack(diff, _weights(campaign)))))


def judge(
    run_jobs,
    campaign: ArmCampaign,
    twin: ReplayedArm,
    withheld: list[ArmRun],
    latency_s: float,
    cands: list[ArmCandidate],
    fitted: list[tuple[float, float]],
    held: list[Residual],
) -> tuple[list[Fit], bool]:
    """The fitted candidates (`fitted`: each one's value and training misfit) judged on the withheld
    runs (`held`: the nominal twin's residuals there), best first, and whether the best explains
    the gap: it leaves at most EXPLAINED_SHRINK of the misfit there, or every joint under
    SIGNIFICANT floors, or, where neither, at most EXPLAINED_SHRINK of the misfit up to the runs'
    knife edges (`shrink_before_knife_edges`)."""
    base = misfit(held, campaign)
    judged = _replays(run_jobs, withheld, [_with(twin, c, v) for c, (v, _) in zip(cands, fitted, strict=True)])
    fits = []
    for c, (value, train_cost), reps in zip(cands, fitted, judged, strict=True):
        res = [residual(r, p, latency_s) for r, p in zip(withheld, reps, strict=True)]
        after = misfit(res, campaign)
        fits.append(Fit(c.name, c.family, value, train_cost, after, after / base, joint_gaps(res, campaign)))
    order = sorted(range(len(fits)), key=lambda i: fits[i].withheld_misfit)
    best = fits[order[0]]
    explained = best.withheld_shrink <= EXPLAINED_SHRINK or all(g.floors <= SIGNIFICANT for g in best.withheld_after)
    if not explained:
        times, shrink = shrink_before_knife_edges(
            run_jobs, campaign, twin, withheld, latency_s, cands[order[0]], best.value, held, judged[order[0]]
        )
        best = replace(best, knife_edge_s=times, shrink_before_knife_edges=shrink)
        explained = shrink is not None and shrink <= EXPLAINED_SHRINK
    return [best] + [fits[i] for i in order[1:]], explained


def diagnose_arm(campaign: ArmCampaign, n_jobs: int = 1, scheduler: str | None = None) -> ArmDiagnosis:
    """The whole arm's diagnosis of `campaign` (steps in the module's docstring)."""
    twin = twin_of(campaign)
    runs = campaign.runs
    withheld = runs[1::2]
    train = runs[0::2]
    with parallel_jobs(n_jobs, scheduler) as run_jobs:
        reps = _replays(run_jobs, runs, [twin])[0]
        latency = fit_latency(campaign, runs, reps)
        residuals = [residual(r, p, latency) for r, p in zip(runs, reps, strict=True)]
        gaps = joint_gaps(residuals, campaign)
        held = [residuals[i] for i in range(1, len(runs), 2)]
        before = joint_gaps(held, campaign)
        worst = max(gaps, key=lambda g: g.floors)
        common = dict(latency_s=latency, joints=gaps, withheld_before=before, training_runs=[r.name for r in train])
        common["withheld_runs"] = [r.name for r in withheld]
        if worst.floors <= SIGNIFICANT:
            return ArmDiagnosis(
                Verdict.NO_GAP, "", "", None, where={}, screen=[], fits=[], withheld_after=before, **common
            )
        joint = worst.joint
        place = where(joint, twin, runs, reps, residuals, latency)
        cands = [c for c in candidates(JOINTS) if c.joint in ("", joint)]
        ranked = screen(run_jobs, campaign, twin, train, latency, cands, reps[0::2], joint)
        top = ranked[:TOP]
        fitted = fit_all(run_jobs, campaign, twin, train, latency, top, misfit(residuals[0::2], campaign))
        fits, explained = judge(run_jobs, campaign, twin, withheld, latency, [s.candidate for s in top], fitted, held)
        best = fits[0]
    return ArmDiagnosis(
        Verdict.EXPLAINED if explained else Verdict.OUTSIDE,
        joint,
        best.candidate if explained else "",
        best.family,
        where=place,
        screen=[(s.candidate.name, s.ratio) for s in ranked],
        fits=fits,
        withheld_after=best.withheld_after,
        **common,
    )
