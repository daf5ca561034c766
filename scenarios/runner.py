"""Running a scenario: build reality and the controller from the file, run, judge, summarise.

The same scenario and seed give the same summary and the same logs (DESIGN rule 5): every random
draw comes from `np.random.default_rng(scenario.seed)`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

import assets
from control import ArmController
from scenarios import controllers
from scenarios.cleaning import DiscContact, disc_contacts
from scenarios.criteria import CRITERIA, CriterionVerdict, When, as_dicts, judge
from scenarios.faults import FaultEvents
from scenarios.ik import RANGE_MARGIN_RAD, carrier_m, rim_drive_angles, rim_pitches
from scenarios.plan import disc_pitches, expand, reachable_discs
from scenarios.schema import (
    Fault,
    Scenario,
    ScenarioError,
    String,
    joint_params_for,
    load,
    nominal_params,
    reality_params,
)
from scenarios.string import Disc, scene_spec
from scenarios.supply import supply_profile
from scenarios.task import TaskController, platform_string
from twin.model import SimulationError
from twin.plant import Plant
from twin.sim import Recorder, run
from twin.telemetry import Telemetry
from twin_plumbing.checks import DURATION_S, SEED, check_number
from twin_plumbing.errors import ParameterError

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class Progress:
    """How far a run has got: simulated time and the run's length (s), discs done of the plan's."""

    time_s: float
    duration_s: float
    discs_done: int = 0
    discs: int = 0  # discs the plan brushes (0: a plan without discs)


class _ProgressReport:
    """A recorder that writes nothing: at each flush of the run it reports a Progress to `report`."""

    def __init__(self, report: Callable[[Progress], None], duration_s: float, scenario: Scenario, task):
        self.report, self.duration_s, self.task, self.path = report, duration_s, task, None
        by_disc: dict[int, list[int]] = {}
        for k, t in enumerate(scenario.targets):
            if t.brush_at_disc:
                by_disc.setdefault(t.brush_at_disc, []).append(k)
        self.by_disc = by_disc if task is not None else {}

    def write(self, telemetry, start: int) -> None:
        if len(telemetry):
            done = sum(all(self.task.reached[k] for k in ks) for ks in self.by_disc.values())
            now = telemetry.time_at(-1)
            self.report(Progress(time_s=now, duration_s=self.duration_s, discs_done=done, discs=len(self.by_disc)))

    def close(self) -> None:
        pass


@dataclass(kw_only=True)
class Result:
    scenario: Scenario
    telemetry: Telemetry
    verdicts: list[CriterionVerdict]
    targets_rad: list[dict[str, float]]
    error: str = ""
    refusal: str = ""  # the controller refused the plan (e.g. below the minimum rotation): arm left braked
    events: list[str] = field(default_factory=list)  # what the controller reported (arrivals, faults)
    active_target_rad: dict[str, float] | None = (
        None  # per joint, the target in force at the end (None: the plan's last)
    )
    reached: list[bool] | None = None  # per scenario target, finished in time (None: the run was not cut short)
    discs: list[DiscContact] = field(default_factory=list)  # what the brush did to each disc (arm runs)
    finished_s: float = math.nan  # when the plan's last target was finished (NaN: it was not)
    pending_faults: tuple[Fault, ...] = ()  # the faults a run cut short stopped before

    @property
    def passed(self) -> bool:
        """No error, and every criterion judged held; a run cut short before it could judge any of
        its criteria has not passed (nothing was shown to hold)."""
        judged = [v for v in self.verdicts if v.judged]
        return not self.error and (bool(judged) or not self.verdicts) and all(v.passed for v in judged)

    def not_judged(self) -> list[str]:
        """The criteria a run cut short did not reach, as 'kind[subject]' (the sweep table's names)."""
        return [f"{v.kind}[{v.subject}]" for v in self.verdicts if not v.judged]

    def _final_target(self, joint: str, logged: float) -> float:
        """The target in force for `joint` at the end: the controller's own set point as the last
        sample logged it (`logged`), which is what the logs show; where the controller has none
        (NaN: a command schedule), the latest target the plan or the task issued naming it. The
        plan's targets are not always what the controller holds at the end: a refused plan leaves
        the arm held where it stood, a joint no target names is held at its start, and the task
        sends each target in steps and moves its aim between them."""
        if math.isfinite(logged):
            return logged
        if self.active_target_rad is not None:
            return self.active_target_rad.get(joint, math.nan)
        return next((t[joint] for t in reversed(self.targets_rad) if joint in t), math.nan)

    def summary(self) -> dict:
        """What `twin run --json` prints: per joint the final target, true and predicted angles and
        their errors in degrees, and each criterion with whether it held."""
        a = self.telemetry.arrays()
        joints = {}
        for i, j in enumerate(self.telemetry.joints):
            logged = float(a["target_angle_rad"][-1, i]) if len(a["time_s"]) else math.nan
            target = self._final_target(j, logged)
            true = float(a["true_angle_rad"][-1, i]) if len(a["time_s"]) else math.nan
            pred = float(a["predicted_angle_rad"][-1, i]) if len(a["time_s"]) else math.nan
            joints[j] = {
                "target_deg": _deg(target),
                "true_final_deg": _deg(true),
                "predicted_final_deg": _deg(pred),
                "error_deg": _deg(true - target) if math.isfinite(target) else None,
                "prediction_error_deg": _deg(true - pred) if math.isfinite(pred) else None,
            }
        return {
            "scenario": self.scenario.name,
            "path": self.scenario.path,
            "seed": self.scenario.seed,
            # to the microsecond: the plant's clock sums its steps (1.9999999999998352 after 2 s)
            "duration_s": round(float(a["time_s"][-1]), 6) if len(a["time_s"]) else 0.0,
            "passed": self.passed,
            "error": self.error or None,
            "refused": self.refusal or None,
            "controller_events": self.events,
            "joints": joints,
            "criteria": as_dicts(self.verdicts),
            "not_reached": self._not_reached(),
            "not_judged": self.not_judged(),
            "finished_s": None if not math.isfinite(self.finished_s) else round(self.finished_s, 3),
            "discs": [_disc_row(d, self.verdicts) for d in self.discs],
            "faults_not_applied": [
                f"{f.kind}{' ' + f.joint if f.joint else ''} at {f.at_s:g} s" for f in self.pending_faults
            ],
        }

    def _not_reached(self) -> list[str]:
        """The targets the run did not finish (when it was cut short), as 'target N (disc k)'."""
        if self.reached is None:
            return []
        return [
            f"target {i + 1}" + (f" (disc_{t.brush_at_disc})" if t.brush_at_disc else "")
            for i, (t, done) in enumerate(zip(self.scenario.targets, self.reached, strict=False))
            if not done
        ]


def _disc_row(d: DiscContact, verdicts: list[CriterionVerdict]) -> dict:
    """One disc's contact figures and whether its cleaning criteria held (None: not judged)."""
    mine = [v for v in verdicts if CRITERIA[v.kind].when is When.PER_DISC and v.subject == f"disc_{d.disc}"]
    judged = [v for v in mine if v.judged]
    return {
        "disc": d.disc,
        "contact_s": round(d.contact_s, 3),
        "peak_force_n": None if not math.isfinite(d.peak_n) else round(d.peak_n, 2),
        "mean_force_n": None if not math.isfinite(d.mean_n) else round(d.mean_n, 2),
        "brushed_m": round(d.brushed_m, 4),
        "rim_share": round(d.rim_share, 4),
        "top_share": round(d.top_share, 4),
        "cleaned": (all(v.passed for v in judged) if judged else None) if mine else None,
    }


def _deg(x: float):
    return None if x is None or not math.isfinite(x) else round(math.degrees(x), 4)


def model_path(scenario: Scenario) -> Path | mujoco.MjSpec:
    """The rig's MJCF, or the arm's scene with the string where the scenario's [string] puts it
    (built at run time: scenarios/string.py; the scene file's own string when it is the default)."""
    if scenario.model == "wrist_rig":
        return assets.WRIST_RIG_XML
    return assets.SCENE_XML if scenario.string == String() else scene_spec(scenario.string)


def build_plant(scenario: Scenario) -> Plant:
    """Reality: the model, the start pose, the payload, and the effects the plant has."""
    base = reality_params(scenario)
    try:
        plant = Plant(
            model_path(scenario),
            joint_params=joint_params_for(base, scenario.reality, scenario.reality.friction_ratio),
            joints=scenario.joints,
            keyframe="home" if scenario.start_pose == "home" else None,
        )
    except ParameterError as e:  # what only the plant can check (a gear too stiff for its step): the file says where
        raise ScenarioError(f"{scenario.path}: [reality] {e}") from None
    m, d = plant.model, plant.data
    if scenario.model == "arm":
        real = scenario.reality  # what the arm really carries and is; the controller is told [payload]
        m.body("payload").mass[0] = max(scenario.payload_kg * real.payload_mass_ratio, 1e-6)
        payload = m.body("payload")
        payload.ipos[:] += real.payload_com_m
        if any(real.payload_com_m):  # the compiler marked the centre as the body's origin: no longer
            m.body_sameframe[payload.id] = 0
        spring = m.joint("brush_stroke").id  # rate and preload (rate x springref) together
        m.jnt_stiffness[spring] *= real.brush_spring_ratio
    for joint, deg in scenario.start_angles_deg.items():
        d.joint(joint).qpos[0] = math.radians(deg)
    mujoco.mj_forward(m, d)
    if scenario.model == "arm":
        _check_start_clear(scenario, m, d)
    plant.align_motors()
    return plant


def _check_start_clear(scenario: Scenario, m: mujoco.MjModel, d: mujoco.MjData) -> None:
    """Refuse a start with the brush inside the string: the arm parked where the string stands (the
    home pose's brush is 4 cm from the scene file's string; 10 cm closer, it stands 4.6 cm inside
    disc 5, a blow of thousands of newtons at the first step that no crew would start from)."""
    brush = m.geom("brush").id
    for c in d.contact[: d.ncon]:
        if brush in (c.geom1, c.geom2) and c.dist < 0.0:
            other = m.geom(c.geom2 if c.geom1 == brush else c.geom1).name
            raise ScenarioError(
                f"{scenario.path}: [start] the arm's start pose puts the brush {-c.dist * 100:.1f} cm into {other} of "
                "the [string]; allowed: a start pose (start.pose, start.angles_deg) with the brush clear of the string"
            )


def plan(scenario: Scenario, plant: Plant) -> tuple[Scenario, list[Disc], list[dict[str, float]]]:
    """The plan made at run time for the string as the platform sees it (scenarios/plan.py): the
    scenario with its `clean_string` target made into every disc's targets, those discs, and each
    target as drive angles (rad)."""
    discs = platform_string(scenario, plant) if scenario.model == "arm" else []

    def tilts(disc: int, standoff_m: float, pitch: float | None) -> list[float]:
        return rim_pitches(plant.model, discs[disc - 1], standoff_m, pitch)

    pitches: dict[int, float] = {}  # each disc's press pitch where the plan departs from the rim's normal
    if any(t.clean_string for t in scenario.targets):
        pitches = disc_pitches(reachable_discs(len(discs), lambda disc, s: bool(tilts(disc, s, None))), tilts)
    planned = expand(scenario, len(discs), lambda disc, s: bool(tilts(disc, s, pitches.get(disc))))
    if discs and planned is not scenario and not any(t.brush_at_disc for t in planned.targets):
        where = ", ".join(f"{v:.3f}" for v in discs[0].centre_m)
        raise ScenarioError(
            f"{scenario.path}: [string] every disc of the string as the platform sees it (top disc at ({where}) m) "
            "is out of the brush's reach; allowed: a string within the arm's reach (1.1 m from the shoulder at "
            "0.4 m, every joint inside its range)"
        )
    return _clear_of_the_string(planned, plant.model, discs, resolve_targets(planned, plant, discs, pitches))


def _clear_of_the_string(
    scenario: Scenario, model: mujoco.MjModel, discs: list[Disc], targets: list[dict[str, float]]
) -> tuple[Scenario, list[Disc], list[dict[str, float]]]:
    """The plan ended before the first of its fixed targets after the cleaning whose pose puts the
    brush into the string as the platform sees it (the retreat's home pose, with the string 10 cm
    closer: the brush 4.6 cm inside disc 5); the arm is left where the target before it puts it."""
    brushed = [i for i, t in enumerate(scenario.targets) if t.brush_at_disc]
    if not brushed:
        return scenario, discs, targets
    pose: dict[str, float] = {}
    for i, target in enumerate(targets):
        pose.update(target)
        if i > brushed[-1] and _in_the_string(model, pose, discs):
            log.info("plan ends before targets[%d]: its pose puts the brush into the string", i)
            return replace(scenario, targets=scenario.targets[:i]), discs, targets[:i]
    return scenario, discs, targets


def _in_the_string(model: mujoco.MjModel, drive: dict[str, float], discs: list[Disc]) -> bool:
    """Whether the brush's carrier at these drive angles lies within the brush's radius of a disc."""
    tip = carrier_m(model, drive)
    brush = float(model.geom("brush").size[0])
    for disc in discs:
        rel = tip - disc.centre_m
        along = float(rel @ disc.axis)
        if (
            abs(along) <= disc.half_thickness_m + brush
            and np.linalg.norm(rel - along * disc.axis) <= disc.radius_m + brush
        ):
            return True
    return False


def resolve_targets(
    scenario: Scenario, plant: Plant, discs: list[Disc] | None = None, pitches: dict[int, float] | None = None
) -> list[dict[str, float]]:
    """Each target as drive angles in rad (brush_at_disc solved by inverse kinematics on `discs`,
    the string as the platform sees it, None: as `plan` finds it; the tool's pitch from the disc's
    in `pitches`, else along the rim's normal: `plan.disc_pitches`)."""
    if discs is None and any(t.brush_at_disc for t in scenario.targets):
        discs = platform_string(scenario, plant)
    out = []
    pose: dict[str, float] = {}  # each joint's latest target: where the plan has left the arm
    for i, t in enumerate(scenario.targets):
        target = {j: math.radians(v) for j, v in t.angles_deg.items()}
        if t.brush_at_disc:
            pitch = (pitches or {}).get(t.brush_at_disc)
            target = {**_brush_drive(scenario, plant.model, discs, i, t, pitch), **target}
        elif pose and any(s.brush_at_disc for s in scenario.targets[:i]):
            target = _short_of_the_elbow_stop(plant.model, pose, target)
        pose.update(target)
        out.append(target)
    return out


def _short_of_the_elbow_stop(model: mujoco.MjModel, pose: dict[str, float], target: dict[str, float]) -> dict:
    """A shoulder move alone after the brush has worked on the string (the retreat's) carries the
    forearm's pitch (the parallelogram): the elbow joint turns by the shoulder's move. Where the
    pose the string left would put the elbow past its stop, the shoulder goes only as far as
    RANGE_MARGIN_RAD short of it, the margin every planned pose keeps from a stop (scenarios/ik.py)
    (the string 10 cm lower: the retreat's shoulder at 55 deg put the elbow at -152 deg, its stop at
    -150; stopped at 51 deg the brush is still 14 cm back)."""
    if "shoulder_pitch" not in target or "elbow_pitch" in target or "elbow_pitch" not in pose:
        return target
    lo, hi = model.joint("elbow_pitch").range
    forearm = pose["elbow_pitch"]  # drive: the forearm's absolute pitch
    shoulder = min(max(target["shoulder_pitch"], forearm - hi + RANGE_MARGIN_RAD), forearm - lo - RANGE_MARGIN_RAD)
    if shoulder != target["shoulder_pitch"]:
        log.info(
            "shoulder_pitch target %.1f deg limited to %.1f deg: the elbow's stop with the forearm at %.1f deg",
            math.degrees(target["shoulder_pitch"]),
            math.degrees(shoulder),
            math.degrees(forearm),
        )
    return {**target, "shoulder_pitch": shoulder}


def _brush_drive(
    scenario: Scenario, model: mujoco.MjModel, discs: list[Disc], i: int, t, pitch: float | None = None
) -> dict[str, float]:
    """Drive angles putting the brush `t.standoff_m` off the rim of disc `t.brush_at_disc` as the
    platform sees it, the tool at `pitch` (None: along the rim's normal), tilted in 5 deg steps
    where out of range."""
    seen = "the string as the platform sees it"
    if t.brush_at_disc > len(discs):
        raise ScenarioError(
            f"{scenario.path}: targets[{i}].brush_at_disc = {t.brush_at_disc} is not allowed; "
            f"allowed: 1..{len(discs)} (the discs of {seen})"
        )
    disc = discs[t.brush_at_disc - 1]
    try:
        return rim_drive_angles(model, disc, t.standoff_m, pitch)
    except ValueError:
        where = ", ".join(f"{v:.3f}" for v in disc.centre_m)
        raise ScenarioError(
            f"{scenario.path}: [string] disc {t.brush_at_disc} ({seen}, centre at ({where}) m) is out of the "
            f"brush's reach at standoff {t.standoff_m:g} m; allowed: a string within the arm's reach (1.1 m from "
            "the shoulder at 0.4 m, every joint inside its range)"
        ) from None


def run_scenario(
    scenario: Scenario,
    recorders: tuple[Recorder, ...] = (),
    duration_s: float | None = None,
    seed: int | None = None,
    progress: Callable[[Progress], None] | None = None,
) -> Result:
    """Run a scenario (optionally shortened, or with another seed) and judge it; `progress` is
    told how far the run has got every half second of simulated time."""
    if duration_s is not None:
        check_number("duration_s", duration_s, **DURATION_S)
    if seed is not None:
        scenario = replace(scenario, seed=check_number("seed", seed, **SEED))
    rng = np.random.default_rng(scenario.seed)
    plant = build_plant(scenario)
    scenario, discs, targets = plan(scenario, plant)
    predictor = joint_params_for(nominal_params(scenario.joints), scenario.predictor)
    controller, refusal = controllers.build(scenario, plant, predictor, targets)
    task = None
    if scenario.model == "arm" and scenario.control.mode != "none" and not refusal:
        controller.set_targets([])  # the plan was checked whole; the task feeds it one target at a time
        controller = task = TaskController(
            controller, scenario, plant, targets, np.random.default_rng([scenario.seed, 1]), discs
        )  # a stream of its own: the supply's draws stay as they were
    duration = scenario.duration_s if duration_s is None else min(duration_s, scenario.duration_s)
    faults = FaultEvents(scenario.faults)
    supply = faults.supply(supply_profile(scenario.supply, duration, rng))
    error = ""
    telemetry = Telemetry(
        plant.joints,
        tuple(mujoco.mj_id2name(plant.model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(1, plant.model.nbody)),
    )
    log.info("%s: %g s simulated, seed %s, %d recorders", scenario.name, duration, scenario.seed, len(recorders))
    if progress is not None:
        recorders = (*recorders, _ProgressReport(progress, duration, scenario, task))
    try:
        run(plant, controller, duration, supply=supply, events=faults, recorders=recorders, telemetry=telemetry)
    except SimulationError as e:  # a divergence: keep what was logged, report it as a failed run
        error = str(e)
    cut_short = duration < scenario.duration_s
    reached, active = None, None
    if task:
        reached, active = (list(task.reached) if cut_short else None), task.active_target()
    elif cut_short and not refusal and isinstance(controller, ArmController):  # the rig: the plan as a whole
        reached, active = controller.targets_finished(), controller.target_in_force(targets)
    pending = tuple(faults.pending) if cut_short else ()
    arrays = telemetry.arrays()
    finished = task.finished_s[-1] if task and task.reached and task.reached[-1] else math.nan
    verdicts = (
        judge(scenario, arrays, plant.joints, telemetry.bodies, plant.model, targets, reached, pending, finished)
        if len(telemetry)
        else []
    )
    if refusal:  # the arm stayed braked: no error against a target the controller never took counts as met
        verdicts = [replace(v, passed=False) if v.kind == "max_error_deg" else v for v in verdicts]
    events = list(getattr(controller, "events", []))
    discs = disc_contacts(plant.model, arrays) if scenario.model == "arm" and len(telemetry) else []
    return Result(
        scenario=scenario,
        telemetry=telemetry,
        verdicts=verdicts,
        targets_rad=targets,
        error=error,
        refusal=refusal,
        events=events,
        active_target_rad=active,
        reached=reached,
        discs=discs,
        finished_s=finished,
        pending_faults=pending,
    )


def run_file(path: str | Path, **kwargs) -> Result:
    return run_scenario(load(path), **kwargs)


def scenario_files(folder: str | Path | None = None) -> list[Path]:
    """The scenario files shipped in scenarios/ (or another folder), sorted."""
    folder = Path(folder) if folder else Path(__file__).resolve().parent
    return sorted(folder.glob("*.toml"))
