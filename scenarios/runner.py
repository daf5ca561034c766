"""Running a scenario: build reality and the controller from the file, run, judge, summarise.

The same scenario and seed give the same summary and the same logs (DESIGN rule 5): every random
draw comes from `np.random.default_rng(scenario.seed)`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

import assets
from control import ArmController
from pneumatics.params import ParameterError
from scenarios import controllers
from scenarios.cleaning import DiscContact, disc_contacts
from scenarios.criteria import DISC_KINDS, Verdict, as_dicts, judge
from scenarios.faults import fault_events
from scenarios.ik import disc_drive_angles
from scenarios.schema import (
    Fault,
    Scenario,
    ScenarioError,
    joint_params_for,
    load,
    nominal_params,
    reality_params,
)
from scenarios.supply import supply_profile
from scenarios.task import TaskController
from twin.checks import DURATION_S, SEED, check_number
from twin.model import SimulationError
from twin.plant import Plant
from twin.sim import Recorder, run
from twin.telemetry import Telemetry


@dataclass
class Result:
    scenario: Scenario
    telemetry: Telemetry
    verdicts: list[Verdict]
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

    def _final_target(self, joint: str) -> float:
        if self.active_target_rad is not None:
            return self.active_target_rad.get(joint, math.nan)
        return next((t[joint] for t in reversed(self.targets_rad) if joint in t), math.nan)

    def summary(self) -> dict:
        """What `twin run --json` prints: per joint the final target, true and predicted angles and
        their errors in degrees, and each criterion with whether it held."""
        a = self.telemetry.arrays()
        joints = {}
        for i, j in enumerate(self.telemetry.joints):
            target = self._final_target(j)
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


def _disc_row(d: DiscContact, verdicts: list[Verdict]) -> dict:
    """One disc's contact figures and whether its cleaning criteria held (None: not judged)."""
    mine = [v for v in verdicts if v.kind in DISC_KINDS and v.subject == f"disc_{d.disc}"]
    judged = [v for v in mine if v.judged]
    return {
        "disc": d.disc,
        "contact_s": round(d.contact_s, 3),
        "peak_force_n": None if not math.isfinite(d.peak_n) else round(d.peak_n, 2),
        "mean_force_n": None if not math.isfinite(d.mean_n) else round(d.mean_n, 2),
        "brushed_m": round(d.brushed_m, 4),
        "cleaned": (all(v.passed for v in judged) if judged else None) if mine else None,
    }


def _deg(x: float):
    return None if x is None or not math.isfinite(x) else round(math.degrees(x), 4)


def model_path(scenario: Scenario) -> Path:
    return assets.WRIST_RIG_XML if scenario.model == "wrist_rig" else assets.SCENE_XML


def build_plant(scenario: Scenario) -> Plant:
    """Reality: the model, the start pose, the payload, and the effects the plant has."""
    base = reality_params(scenario)
    try:
        plant = Plant(
            model_path(scenario),
            joint_params=joint_params_for(base, scenario.reality),
            joints=scenario.joints,
            keyframe="home" if scenario.start_pose == "home" else None,
        )
    except ParameterError as e:  # what only the plant can check (a gear too stiff for its step): the file says where
        raise ScenarioError(f"{scenario.path}: [reality] {e}") from None
    m, d = plant.model, plant.data
    if scenario.model == "arm":
        m.body("payload").mass[0] = max(scenario.payload_kg, 1e-6)
    for joint, deg in scenario.start_angles_deg.items():
        d.joint(joint).qpos[0] = math.radians(deg)
    mujoco.mj_forward(m, d)
    plant.align_motors()
    return plant


def resolve_targets(scenario: Scenario, plant: Plant) -> list[dict[str, float]]:
    """Each target as drive angles in rad (brush_at_disc solved by inverse kinematics)."""
    out = []
    for t in scenario.targets:
        target = {j: math.radians(v) for j, v in t.angles_deg.items()}
        if t.brush_at_disc:
            target = {**disc_drive_angles(plant.model, t.brush_at_disc, t.standoff_m), **target}
        out.append(target)
    return out


def run_scenario(
    scenario: Scenario,
    recorders: tuple[Recorder, ...] = (),
    duration_s: float | None = None,
    seed: int | None = None,
) -> Result:
    """Run a scenario (optionally shortened, or with another seed) and judge it."""
    if duration_s is not None:
        check_number("duration_s", duration_s, **DURATION_S)
    if seed is not None:
        scenario = replace(scenario, seed=check_number("seed", seed, **SEED))
    rng = np.random.default_rng(scenario.seed)
    plant = build_plant(scenario)
    targets = resolve_targets(scenario, plant)
    predictor = joint_params_for(nominal_params(scenario.joints), scenario.predictor)
    controller, refusal = controllers.build(scenario, plant, predictor, targets)
    task = None
    if scenario.model == "arm" and scenario.control.mode != "none" and not refusal:
        controller.set_targets([])  # the plan was checked whole; the task feeds it one target at a time
        controller = task = TaskController(
            controller, scenario, plant, targets, np.random.default_rng([scenario.seed, 1])
        )  # a stream of its own: the supply's draws stay as they were
    duration = scenario.duration_s if duration_s is None else min(duration_s, scenario.duration_s)
    supply = supply_profile(scenario.supply, duration, rng)
    faults, _ = fault_events(scenario.faults)
    error = ""
    telemetry = Telemetry(
        plant.joints,
        tuple(mujoco.mj_id2name(plant.model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(1, plant.model.nbody)),
    )
    try:
        run(plant, controller, duration, supply_pa_at=supply, events=faults, recorders=recorders, telemetry=telemetry)
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
    verdicts = (
        judge(scenario, arrays, plant.joints, telemetry.bodies, plant.model, targets, reached, pending)
        if len(telemetry)
        else []
    )
    if refusal:  # the arm stayed braked: no error against a target the controller never took counts as met
        verdicts = [replace(v, passed=False) if v.kind == "max_error_deg" else v for v in verdicts]
    events = list(getattr(controller, "events", []))
    discs = disc_contacts(plant.model, arrays) if scenario.model == "arm" and len(telemetry) else []
    finished = task.finished_s[-1] if task and task.reached and task.reached[-1] else math.nan
    return Result(
        scenario,
        telemetry,
        verdicts,
        targets,
        error,
        refusal,
        events,
        active,
        reached,
        discs,
        finished,
        pending,
    )


def run_file(path: str | Path, **kwargs) -> Result:
    return run_scenario(load(path), **kwargs)


def scenario_files(folder: str | Path | None = None) -> list[Path]:
    """The scenario files shipped in scenarios/ (or another folder), sorted."""
    folder = Path(folder) if folder else Path(__file__).resolve().parent
    return sorted(folder.glob("*.toml"))
