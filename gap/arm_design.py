"""The next runs of the whole arm: which joint to exercise, in which posture, at which speed, to tell
the arm diagnosis's leading candidates apart (or, before any campaign, every two families of the
effects a joint and the arm can take), by the T-optimality criterion of Atkinson & Fedorov that the
one-joint design uses (gap.discrimination, gap.design's DesignCriterion and greedy choice), the responses
being the whole arm's replays (gap.arm_replay) read by the campaign's instrument.

Steps:
1. hypotheses: from an arm diagnosis, each fitted candidate (gap.arm_diagnose's fits: the best and
   its rivals) at its fitted value, read at the diagnosis's latency, free when refitted over its own
   values (`value_grid`: GRID_POINTS across its bounds, its fitted value and the twin's); every two
   a pair to tell apart. Before any campaign: every effect of the joint's catalogue and of the arm
   (gap.arm_effects) at the screen's probe size (gap.arm_diagnose.probe_value: a quarter of the
   way to its bound), free over its family's members and values; every two families a pair;
2. proposals (`library`): one-joint exercises, the others braked, the arm in one of three postures
   (`postures`: the home pose, the base turned away from the string, with the exercised joint's own
   angle where the gravity torque on it is least, most and halfway among the angles the joint can
   lift at the supply; the gravity torque tells a mass or a load from friction), each playing a
   protocol of the one-joint design library (EXERCISES: a fast back-and-forth, both directions,
   and a slow constant-speed run: speed and direction tell Coulomb from viscous friction) at the
   campaign's supply. The departing joint gets every posture and protocol; where an arm-level
   effect is among the hypotheses the other pitch joints get the fast exercise at every posture
   too (a payload or a link loads them all): at most MAX_CANDIDATES runs;
3. the criterion of each pair on the campaign's own runs and each proposal added (samples in
   units of the instrument's noise: the angle of every joint it sees, and the platform's port
   pressures where the campaign has them), the plan chosen greedily (gap.design.choose).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import assets
from gap import protocols
from gap.arm_campaign import JOINTS, PRESSURE_PERIOD_S, ArmCampaign, ArmInstrument, ArmRun
from gap.arm_diagnose import LATENCY_GRID_S, ArmDiagnosis, ReplayedArm, axis_of, gravity_torques, probe_value, twin_of
from gap.arm_effects import ARM_CATALOGUE, JOINT_CATALOGUE, ArmCandidate, ArmSetup, candidate_named, stall_torque_nm
from gap.arm_replay import arm_plant, replay
from gap.design import GRID_POINTS, MAX_PROPOSALS, SEPARATED_FLOORS, Design, DesignCriterion, Pair, choose, family_pairs
from gap.discrimination import Change, Hypothesis, Reading, Response
from pneumatics import JointParams, load_joint_params
from pneumatics.as_built import load_as_built
from pneumatics.gas import AIR

PITCH_JOINTS = ("shoulder_pitch", "elbow_pitch", "wrist_pitch")  # the joints gravity loads
BASE_YAW_DEG = 40.0  # the base turned away from the insulator string (scenarios/arm_protocols/one_joint.toml)
# the exercised joint's own angle scanned at these fractions of its range (assets/arm.xml), 15 % in
# from the stops so that the exercise's moves (tens of degrees) stay clear of them; three kept
# (`postures`): the least, the most and a middle gravity torque among those the joint can lift
POSTURE_SCAN = tuple(np.linspace(0.15, 0.85, 15))
# a posture's gravity torque at most half the joint's stall torque: the joint moves both ways in the
# exercise's moves (its friction and the pressure's build-up take the rest)
HOLD_SHARE = 0.5
# the one-joint design library's exercises the arm's joints play (gap.protocols): fast both ways
# (full opening, 1.6 s of motion), and slow at a partial opening (0.85, under the brake's full release)
EXERCISES = ("back_and_forth", "slow_085")
MAX_CANDIDATES = 12  # proposals a call scores (each replayed once per hypothesis and alternative)
DEFAULT_SUPPLY_MPA = 0.6  # before any campaign: the exercise's supply (scenarios/arm_protocols/one_joint.toml)
BEFORE_GRID_POINTS = 3  # before any campaign: values per member in a family's alternatives (24 effects)


@dataclass(frozen=True)
class Exercise:
    """One proposal's physical description: the exercised joint, its start angle (joint space, deg)
    and the gravity torque on its drive there (N·m), the protocol it plays."""

    joint: str
    angle_deg: float
    gravity_nm: float
    protocol: str

    def label(self) -> str:
        return f"{self.joint} at {self.angle_deg:.0f} deg ({self.gravity_nm:+.0f} N·m gravity), {self.protocol}"


@dataclass(frozen=True)
class ArmPlannedRun:
    """A run of the whole arm as the criterion reads it: its commands (`run`), where the angle
    instrument samples and where the port transducers do (empty: not measured)."""

    name: str
    supply_mpa: float
    run: ArmRun
    angle_times_s: np.ndarray
    pressure_times_s: np.ndarray
    exercise: Exercise | None = None

    @property
    def time_s(self) -> np.ndarray:
        return self.run.time_s


@dataclass(frozen=True)
class ArmReading:
    """The arm's instrument as the criterion reads it: the angle's floor and latency grid
    (discrimination.Reading), the joints it sees, and the port transducers' floor (Pa; None: none)."""

    reading: Reading
    seen: tuple[int, ...]
    floor_pa: float | None


@dataclass
class ArmDesign:
    """The design (gap.design.Design: hypotheses, pairs, proposals ranked, the plan and what it tells
    apart) with the arm's own: the twin, the instrument, and the exercise of each proposal."""

    design: Design
    twin: ReplayedArm
    instrument: ArmInstrument
    arm_reading: ArmReading
    departing: str  # the joint the diagnosis names ("" before any campaign)
    payload_kg: float
    arm: str = "as_built"
    hose_loss: bool | None = None
    exercises: dict[str, Exercise] = field(default_factory=dict)  # proposal name -> its exercise


def changed(twin: ReplayedArm, change: Change) -> tuple[dict[str, JointParams], ArmSetup]:
    """The twin's (params, setup) with each (candidate, value) of `change`."""
    params, setup = twin.params, twin.setup
    for c, v in change:
        params, setup = c.apply(params, setup, JOINTS, v)
    return params, setup


def arm_response(twin: ReplayedArm, change: Change, run: ArmPlannedRun, ar: ArmReading) -> Response:
    """A change's predicted readings of `run` in floors: every seen joint's angle at each latency of
    the grid (latencies x samples of all seen joints) and every joint's two ports (2 x joints rows)."""
    rep = replay(run.run, *changed(twin, change))
    r = ar.reading
    ts = run.angle_times_s[None, :] - r.latencies_s[:, None]
    angle = np.concatenate([np.interp(ts, rep.time_s, rep.angle_rad[:, j]) for j in ar.seen], axis=1)
    pressure = np.zeros((0, 0))
    if ar.floor_pa is not None and run.pressure_times_s.size:
        tp = run.pressure_times_s
        rows = [np.interp(tp, rep.time_s, rep.port_pa[:, j, c]) for j in range(len(JOINTS)) for c in (0, 1)]
        pressure = np.stack(rows) / ar.floor_pa
    return Response(angle / math.radians(r.floor_deg), pressure)


def arm_samples(run: ArmPlannedRun, ar: ArmReading) -> int:
    ports = 2 * len(JOINTS) * run.pressure_times_s.size if ar.floor_pa is not None else 0
    return run.angle_times_s.size * len(ar.seen) + ports


def value_grid(c: ArmCandidate, twin: ReplayedArm, n: int, extra: tuple[float, ...] = ()) -> list[float]:
    """`n` values of candidate `c` across its bounds (log-spaced where the catalogue says), the twin's
    own value and `extra`, sorted and distinct."""
    axis = axis_of(c)
    grid = [axis.value(x) for x in np.linspace(axis.x_lo, axis.x_hi, n)]
    own = c.value_in(twin.params, twin.setup, JOINTS)
    return sorted({float(v) for v in (*grid, own, *extra)})


def hypotheses_of(diag: ArmDiagnosis, twin: ReplayedArm) -> tuple[list[Hypothesis], list[Pair]]:
    """Each fitted candidate of the diagnosis at its value, free over its own values; every two a pair."""
    hyps = []
    for f in diag.fits:  # best first (on the withheld runs)
        c = candidate_named(f.candidate)
        alts = tuple(((c, v),) for v in value_grid(c, twin, GRID_POINTS, (f.value,)))
        hyps.append(Hypothesis(f"{f.candidate} = {f.value:.4g}", c.family, ((c, f.value),), diag.latency_s, alts))
    pairs = [
        Pair(f"{a.name} / {b.name}", ((i, k), (k, i))) for i, a in enumerate(hyps) for k, b in enumerate(hyps) if i < k
    ]
    return hyps, pairs


def catalogue_hypotheses(joint: str, twin: ReplayedArm, latency_s: float) -> tuple[list[Hypothesis], list[Pair]]:
    """Every effect `joint` and the arm can take at the screen's probe size, free over its family's
    members and values; every two families a pair (gap.design.family_pairs)."""
    cands = [ArmCandidate(e.name, joint) for e in JOINT_CATALOGUE] + [ArmCandidate(e.name) for e in ARM_CATALOGUE]
    sized = [(c, v) for c in cands if (v := probe_value(c, twin)) is not None]
    families = list(dict.fromkeys(c.family for c, _ in sized))
    alts = {
        f: tuple(((c, v),) for c, _ in sized if c.family == f for v in value_grid(c, twin, BEFORE_GRID_POINTS))
        for f in families
    }
    hyps = [Hypothesis(f"{c.name} = {v:.4g}", c.family, ((c, v),), latency_s, alts[c.family]) for c, v in sized]
    return hyps, family_pairs(hyps, families)


def home_pose(params: dict[str, JointParams], setup: ArmSetup) -> tuple[object, np.ndarray]:
    """The plant at the home keyframe with the base turned BASE_YAW_DEG (the one-joint exercise's
    start) and its joint-space qpos."""
    plant = arm_plant(params, setup, np.zeros(len(JOINTS)))
    plant.data.qpos[:] = plant.model.key("home").qpos
    plant.data.joint("base_yaw").qpos[0] = math.radians(BASE_YAW_DEG)
    return plant, plant.data.qpos.copy()


def postures(joint: str, twin: ReplayedArm, supply_mpa: float) -> list[tuple[float, np.ndarray, float]]:
    """(joint angle deg, start drive angles, gravity torque N·m) of the exercise's postures: the home
    pose with `joint` at one of POSTURE_SCAN fractions of its range, among those where the gravity
    torque on it is at most HOLD_SHARE of its stall torque at the supply (the joint lifts its load
    there: a posture it cannot hold is no exercise a platform should play), the one of least
    gravity torque, the one of most, and the one nearest halfway between them."""
    plant, home = home_pose(twin.params, twin.setup)
    lo, hi = plant.model.joint(joint).range
    limit = HOLD_SHARE * stall_torque_nm(twin.params[joint], supply_mpa)
    found = []
    for frac in POSTURE_SCAN:
        plant.data.qpos[:] = home
        q = lo + frac * (hi - lo)
        plant.data.joint(joint).qpos[0] = q
        start = plant.drive_angles()
        g = float(gravity_torques(joint, twin, start, start[None, :])[0])
        if abs(g) <= limit:
            found.append((math.degrees(q), start, g))
    if not found:
        return []
    least, most = min(found, key=lambda x: x[2]), max(found, key=lambda x: x[2])
    middle = min(found, key=lambda x: abs(x[2] - 0.5 * (least[2] + most[2])))
    return list({id(x): x for x in (least, middle, most)}.values())


def exercise_run(
    joint: str, start_rad: np.ndarray, protocol: protocols.Protocol, supply_mpa: float, k_u_per_pa: float
) -> ArmRun:
    """`protocol`'s commands (gap.protocols) on `joint` at 1 ms, every other joint braked and closed,
    from rest at `start_rad`."""
    t = np.round(np.arange(0.0, protocol.total_s() + 1e-9, 1e-3), 6)
    d, u, b = protocol.commands(t, supply_mpa * 1e6, k_u_per_pa)
    commands = np.zeros((len(t), len(JOINTS), 3))
    j = JOINTS.index(joint)
    commands[:, j, 0], commands[:, j, 1], commands[:, j, 2] = d, u, b
    nan = np.full((len(t), len(JOINTS)), np.nan)
    supply = np.full(len(t), AIR.p_atm_pa + supply_mpa * 1e6)
    return ArmRun("", None, start_rad, t, commands, supply, nan, np.stack([nan, nan], axis=2))


def planned(name: str, run: ArmRun, supply_mpa: float, rate_hz: float, pressures: bool, ex=None) -> ArmPlannedRun:
    """A run sampled by the instrument every 1/rate_hz and, where measured, the ports every 20 ms."""
    t_end = float(run.time_s[-1])
    ts = np.round(np.arange(0.0, t_end + 1e-9, 1.0 / rate_hz), 6)
    tp = np.round(np.arange(0.0, t_end + 1e-9, PRESSURE_PERIOD_S), 6) if pressures else np.zeros(0)
    return ArmPlannedRun(name, supply_mpa, run, ts, tp, ex)


def library(
    twin: ReplayedArm, joints: list[str], fast_only: list[str], supply_mpa: float, rate_hz: float, pressures: bool
) -> tuple[list[tuple[str, tuple[ArmPlannedRun, ...]]], dict[str, Exercise]]:
    """The proposals: each joint of `joints` at each posture playing each exercise (only the first,
    fast, for those in `fast_only`), one run each, at most MAX_CANDIDATES."""
    out, exercises = [], {}
    for joint in joints:
        k_u = twin.params[joint].k_u_per_pa
        for angle_deg, start, g in postures(joint, twin, supply_mpa):
            for name in EXERCISES[:1] if joint in fast_only else EXERCISES:
                proto = protocols.design_library(supply_mpa)[name]
                label = f"{joint}_{name}_at_{angle_deg:+.0f}deg".replace("+", "p").replace("-", "m")
                ex = Exercise(joint, angle_deg, g, name)
                run = exercise_run(joint, start, proto, supply_mpa, k_u)
                run.name = label
                out.append((label, (planned(label, run, supply_mpa, rate_hz, pressures, ex),)))
                exercises[label] = ex
    return out[:MAX_CANDIDATES], exercises


def base_runs(campaign: ArmCampaign, seen: tuple[int, ...], pressures: bool) -> list[ArmPlannedRun]:
    """The campaign's own runs as the criterion reads them: their commands and sample times."""
    out = []
    for r in campaign.runs:
        angle_rows = np.isfinite(r.angle_rad[:, list(seen)]).any(axis=1)
        port_rows = np.isfinite(r.port_pa.reshape(len(r.time_s), -1)).any(axis=1)
        supply = (float(np.mean(r.supply_pa)) - AIR.p_atm_pa) / 1e6
        tp = r.time_s[port_rows] if pressures else np.zeros(0)
        out.append(ArmPlannedRun(r.name, supply, r, r.time_s[angle_rows], tp))
    return out


def _criterion(twin: ReplayedArm, hyps, pairs, ar: ArmReading, n_jobs: int) -> DesignCriterion:
    return DesignCriterion(
        twin,
        hyps,
        pairs,
        ar.reading,
        n_jobs,
        respond=lambda change, run: arm_response(twin, change, run, ar),
        count=lambda run: arm_samples(run, ar),
    )


def campaign_supply(campaign: ArmCampaign) -> float:
    """The supply the proposals play at: the campaign's runs' median, to 0.05 MPa."""
    s = np.median([(float(np.mean(r.supply_pa)) - AIR.p_atm_pa) / 1e6 for r in campaign.runs])
    return round(float(s) * 20.0) / 20.0


def design_arm(campaign: ArmCampaign, diag: ArmDiagnosis, n_jobs: int = 1) -> ArmDesign:
    """The next runs for an arm campaign from its diagnosis `diag` (module docstring)."""
    twin = twin_of(campaign)
    inst = campaign.instrument
    seen = tuple(JOINTS.index(j) for j in inst.seen())
    pressures = any(np.isfinite(r.port_pa).any() for r in campaign.runs)
    latencies = np.array([inst.latency_s]) if inst.latency_s is not None else LATENCY_GRID_S
    noise_deg = math.degrees(inst.noise_rad())
    ar = ArmReading(
        Reading(noise_deg, latencies, campaign.pressures.noise_pa / 1e3 if pressures else None),
        seen,
        campaign.pressures.noise_pa if pressures else None,
    )
    hyps, pairs = hypotheses_of(diag, twin) if diag.verdict.alarm else ([], [])
    common = dict(
        twin=twin,
        instrument=inst,
        arm_reading=ar,
        departing=diag.joint,
        payload_kg=campaign.payload_kg,
        arm=campaign.arm,
        hose_loss=campaign.hose_loss,
    )
    if len(hyps) < 2:
        d = Design(hyps, pairs, ar.reading, [], [], {}, [p.name for p in pairs], twin, str(campaign.folder))
        return ArmDesign(d, **common)
    crit = _criterion(twin, hyps, pairs, ar, n_jobs)
    base = crit.sums(base_runs(campaign, seen, pressures))
    arm_level = any(not c.joint for h in hyps for c, _ in h.effects)
    others = [j for j in PITCH_JOINTS if j != diag.joint] if arm_level else []
    cands, exercises = library(twin, [diag.joint, *others], others, campaign_supply(campaign), inst.rate_hz, pressures)
    ranking, chosen, together = choose(crit, cands, base, MAX_PROPOSALS)
    unseparated = [k for k, s in together.items() if s < SEPARATED_FLOORS]
    d = Design(hyps, pairs, ar.reading, ranking, chosen, together, unseparated, twin, str(campaign.folder))
    return ArmDesign(d, exercises=exercises, **common)


def nominal_twin(arm: str = "as_built", payload_kg: float = 20.0) -> ReplayedArm:
    """The twin before any campaign: the arm's joints (as built or nominal) carrying `payload_kg`."""
    base = {j: load_joint_params(assets.joint_param_path(j)) for j in JOINTS}
    if arm == "as_built":
        base = {j: load_as_built(p, assets.as_built_path(j)) for j, p in base.items()}
    return ReplayedArm(base, ArmSetup(payload_kg=payload_kg))


def design_arm_before_campaign(
    joint: str, instrument: ArmInstrument, pressures_noise_pa: float | None = None, n_jobs: int = 1
) -> ArmDesign:
    """The smallest set of exercises of `joint` (each posture and exercise of the library, at
    DEFAULT_SUPPLY_MPA) that tells every two families of the effects the joint and the arm can take
    apart, read by `instrument` (and the platform's port transducers when `pressures_noise_pa`);
    the pairs it cannot tell apart listed."""
    twin = nominal_twin()
    seen = tuple(JOINTS.index(j) for j in instrument.seen())
    latency = instrument.latency_s if instrument.latency_s is not None else 0.0
    latencies = np.array([latency]) if instrument.latency_s is not None else LATENCY_GRID_S
    ar = ArmReading(
        Reading(
            math.degrees(instrument.noise_rad()),
            latencies,
            pressures_noise_pa / 1e3 if pressures_noise_pa is not None else None,
        ),
        seen,
        pressures_noise_pa,
    )
    hyps, pairs = catalogue_hypotheses(joint, twin, latency)
    crit = _criterion(twin, hyps, pairs, ar, n_jobs)
    cands, exercises = library(
        twin, [joint], [], DEFAULT_SUPPLY_MPA, instrument.rate_hz, pressures_noise_pa is not None
    )
    ranking, chosen, together = choose(crit, cands, None, None)
    unseparated = [k for k, s in together.items() if s < SEPARATED_FLOORS]
    d = Design(hyps, pairs, ar.reading, ranking, chosen, together, unseparated, twin, f"the catalogue ({joint}, arm)")
    return ArmDesign(d, twin, instrument, ar, "", twin.setup.payload_kg, exercises=exercises)
