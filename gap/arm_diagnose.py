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
     (gap/arm_effects.py) is probed on the training runs, shortened to SCREEN_S: each probe's
     correction (twin with it - nominal twin) scaled to fit the residual best, so one replay a probe
     ranks it; the best TOP are fitted on the training runs (a bounded scalar search) and judged
     on the withheld runs;
  4. how far: on the withheld runs, per joint, the rms before and after the best candidate.
The runs alternate between training and withheld (every other run withheld).

Verdicts: no significant gap; explained (the best candidate brings every joint under SIGNIFICANT
floors on the withheld runs, or shrinks the gap's misfit there to under EXPLAINED_SHRINK); or
outside the catalogue, naming the nearest family (the best candidate's).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import mujoco
import numpy as np
from joblib import delayed
from scipy.optimize import minimize_scalar

import assets
from gap.arm_campaign import JOINTS, ArmCampaign, ArmRun
from gap.arm_effects import ArmSetup, Candidate, candidates
from gap.arm_replay import Replay, arm_plant, replay, set_drive_angles
from gap.campaign import Run
from gap.diagnose import _parallel
from gap.where import breakdown, labels_of
from pneumatics import JointParams, load_joint_params
from pneumatics.as_built import load_as_built
from pneumatics.gas import AIR

LATENCY_GRID_S = np.round(np.arange(0.0, 0.06 + 1e-9, 0.005), 6)  # as gap/instrument.py's: 0-60 ms
SIGNIFICANT = 2.0  # floors: a channel's rms residual this many times its noise is a gap (gap/verdict.py's rule)
EXPLAINED_SHRINK = 0.1  # a candidate leaving at most this fraction of the misfit on withheld runs explains it
SCREEN_S = 20.0  # the probes replay the training runs' first 20 s (the fits and the judgement replay them whole)
TOP = 3  # candidates fitted after the screen
GRAVITY_BINS_NM = (-100.0, -30.0, -10.0, 10.0, 30.0, 100.0)  # the posture factor's bin edges


@dataclass(frozen=True)
class Twin:
    """The twin the diagnosis replays: each joint's parameters and the arm's setup."""

    params: dict[str, JointParams]
    setup: ArmSetup


def twin_of(campaign: ArmCampaign) -> Twin:
    """campaign.toml's twin: its base arm (as built or nominal), hose switch and payload."""
    base = {j: load_joint_params(assets.joint_param_path(j)) for j in JOINTS}
    if campaign.arm == "as_built":
        base = {j: load_as_built(p, assets.as_built_path(j)) for j, p in base.items()}
    if campaign.hose_loss is not None:
        base = {j: p._replace(hose_loss=1.0 if campaign.hose_loss else 0.0) for j, p in base.items()}
    return Twin(base, ArmSetup(payload_kg=campaign.payload_kg))


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
    family: str
    value: float
    train_misfit: float
    withheld_misfit: float
    withheld_shrink: float  # withheld misfit with it / without it
    withheld_after: list[JointGap] = field(default_factory=list)


@dataclass
class ArmDiagnosis:
    verdict: str  # "no significant gap", "explained", "outside the catalogue"
    joint: str  # the departing joint ("" when no significant gap)
    effect: str  # the candidate named ("" unless explained)
    family: str  # its family (outside: the nearest)
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
        if self.verdict == "no significant gap":
            return "no significant gap: every joint within its floors"
        if self.verdict == "explained":
            best = self.fits[0]
            return (
                f"{self.joint} departs; explained by {self.effect} = {best.value:.4g} "
                f"(withheld misfit x{best.withheld_shrink:.3f})"
            )
        return f"{self.joint} departs; outside the catalogue, nearest family {self.family}"

    def as_dict(self) -> dict:
        return asdict(self)


def _replays(run_jobs, runs: list[ArmRun], twins: list[Twin], t_end_s: float | None = None) -> list[list[Replay]]:
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


def residual(run: ArmRun, rep: Replay, latency_s: float) -> Residual:
    """measured - twin at the run's rows inside the replay (the twin's angle read `latency_s` late)."""
    n = min(len(run.time_s), int(np.searchsorted(run.time_s, rep.time_s[-1] + 1e-9)))
    t = run.time_s[:n]
    twin_angle = np.stack([np.interp(t - latency_s, rep.time_s, rep.angle_rad[:, j]) for j in range(len(JOINTS))], 1)
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


def gravity_torques(joint: str, twin: Twin, start_rad: np.ndarray, drive_rad: np.ndarray) -> np.ndarray:
    """The gravity torque on `joint`'s drive (N·m, holding the arm up is positive) at each row of
    drive angles (the twin's pose)."""
    plant = arm_plant(twin.params, twin.setup, start_rad)
    m, d = plant.model, plant.data
    i = plant.joints.index(joint)
    out = np.empty(len(drive_rad))
    for k, q in enumerate(drive_rad):
        set_drive_angles(plant, q)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        out[k] = sum(c * d.qfrc_bias[int(dof)] for _, dof, c in plant.drive_map[i] if c != 0.0)
    return out


def where(
    joint: str, twin: Twin, runs: list[ArmRun], reps: list[Replay], residuals: list[Residual], latency_s: float
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
        one = Run(
            run.name,
            run.path,
            (float(np.mean(run.supply_pa)) - AIR.p_atm_pa) / 1e6,
            float(run.start_rad[j]),
            run.time_s[:n],
            run.commands[:n, j, 0],
            run.commands[:n, j, 2],
            run.commands[:n, j, 1],
            run.supply_pa[:n],
            run.angle_rad[:n, j],
        )
        lab = labels_of(one, ts, angle, np.interp(ts, rep.time_s, speed))
        poses = np.stack([np.interp(ts, rep.time_s, rep.angle_rad[:, i]) for i in range(len(JOINTS))], 1)
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


def _probe_values(c: Candidate, twin: Twin) -> list[float]:
    """One or two probe values: a quarter of the way from the twin's value to each bound it can move to."""
    lo, hi = c.bounds
    now = c.value_in(twin.params, twin.setup, JOINTS)
    out = []
    for bound in (lo, hi):
        if abs(bound - now) > 1e-12 * max(1.0, abs(bound)):
            if c.log and now > 0 and bound > 0:
                out.append(float(now * (bound / now) ** 0.25))
            else:
                out.append(float(now + 0.25 * (bound - now)))
    return out


def _with(twin: Twin, c: Candidate, value: float) -> Twin:
    params, setup = c.apply(twin.params, twin.setup, JOINTS, value)
    return Twin(params, setup)


def screen(
    run_jobs, campaign: ArmCampaign, twin: Twin, runs: list[ArmRun], latency_s: float, cands: list[Candidate]
) -> list[tuple[Candidate, float]]:
    """Each candidate's best misfit ratio from its probes' corrections scaled to the residual (no
    fit), on `runs` shortened to SCREEN_S; best first."""
    probes = [(c, v) for c in cands for v in _probe_values(c, twin)]
    reps = _replays(run_jobs, runs, [twin] + [_with(twin, c, v) for c, v in probes], SCREEN_S)
    weights = _weights(campaign)
    base = _stack([residual(r, p, latency_s) for r, p in zip(runs, reps[0], strict=True)], weights)
    total = float(base @ base) or 1.0
    best: dict[str, tuple[Candidate, float]] = {}
    for (c, _), rp in zip(probes, reps[1:], strict=True):
        with_it = _stack([residual(r, p, latency_s) for r, p in zip(runs, rp, strict=True)], weights)
        corr = base - with_it  # what the effect adds to the twin, in the residual's units
        scale = max(0.0, float(base @ corr) / float(corr @ corr)) if float(corr @ corr) > 0 else 0.0
        left = base - scale * corr
        ratio = float(left @ left) / total
        if c.name not in best or ratio < best[c.name][1]:
            best[c.name] = (c, ratio)
    return sorted(best.values(), key=lambda x: x[1])


def _weights(campaign: ArmCampaign) -> tuple[float, float]:
    return 1.0 / campaign.instrument.noise_rad(), 1.0 / campaign.pressures.noise_pa


def _stack(residuals: list[Residual], weights: tuple[float, float]) -> np.ndarray:
    """Every residual sample in units of its floor, NaN (not sampled) as 0, as one vector."""
    parts = []
    for r in residuals:
        parts += [np.nan_to_num(r.angle.ravel()) * weights[0], np.nan_to_num(r.port.ravel()) * weights[1]]
    return np.concatenate(parts)


def fit(
    run_jobs, campaign: ArmCampaign, twin: Twin, train: list[ArmRun], latency_s: float, c: Candidate
) -> tuple[float, float]:
    """(value, training misfit) of `c` by a bounded scalar search (log-spaced where the effect is)."""
    lo, hi = c.bounds
    log = c.log and lo > 0
    to_x = (lambda v: math.log(v)) if log else (lambda v: v)
    from_x = (lambda x: math.exp(x)) if log else (lambda x: x)
    cache: dict[float, float] = {}

    def cost(x: float) -> float:
        v = float(np.clip(from_x(x), lo, hi))
        if v not in cache:
            reps = _replays(run_jobs, train, [_with(twin, c, v)])[0]
            cache[v] = misfit([residual(r, p, latency_s) for r, p in zip(train, reps, strict=True)], campaign)
        return cache[v]

    low = to_x(lo if not (c.log and lo == 0) else hi * 1e-3)
    res = minimize_scalar(cost, bounds=(low, to_x(hi)), method="bounded", options={"maxiter": 8, "xatol": 1e-3})
    v = float(np.clip(from_x(res.x), lo, hi))
    return v, cost(to_x(v))


def diagnose_arm(campaign: ArmCampaign, n_jobs: int = 1, scheduler: str | None = None) -> ArmDiagnosis:
    """The whole arm's diagnosis of `campaign` (steps in the module's docstring)."""
    twin = twin_of(campaign)
    runs = campaign.runs
    withheld = runs[1::2]
    train = runs[0::2]
    with _parallel(n_jobs, scheduler) as run_jobs:
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
                "no significant gap", "", "", "", where={}, screen=[], fits=[], withheld_after=before, **common
            )
        joint = worst.joint
        place = where(joint, twin, runs, reps, residuals, latency)
        cands = [c for c in candidates(JOINTS) if c.joint in ("", joint)]
        ranked = screen(run_jobs, campaign, twin, train, latency, cands)
        fits = []
        base_withheld = misfit(held, campaign)
        for c, _ in ranked[:TOP]:
            value, train_cost = fit(run_jobs, campaign, twin, train, latency, c)
            reps_w = _replays(run_jobs, withheld, [_with(twin, c, value)])[0]
            res_w = [residual(r, p, latency) for r, p in zip(withheld, reps_w, strict=True)]
            after = misfit(res_w, campaign)
            fits.append(
                Fit(c.name, c.family, value, train_cost, after, after / base_withheld, joint_gaps(res_w, campaign))
            )
    fits.sort(key=lambda f: f.withheld_misfit)
    best = fits[0]
    explained = best.withheld_shrink <= EXPLAINED_SHRINK or all(g.floors <= SIGNIFICANT for g in best.withheld_after)
    return ArmDiagnosis(
        "explained" if explained else "outside the catalogue",
        joint,
        best.candidate if explained else "",
        best.family,
        where=place,
        screen=[(c.name, ratio) for c, ratio in ranked],
        fits=fits,
        withheld_after=best.withheld_after,
        **common,
    )
