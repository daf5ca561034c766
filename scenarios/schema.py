"""The scenario file format: a typed schema, read from TOML as data (nothing in it is executed).

A scenario says where the arm starts, what it carries, what air it gets, what it must do, what
"reality" has that the predictor lacks, what goes wrong and when, and how to judge the run. The
dataclasses below are the schema: each field's type says what it allows (its range, in the unit its
name carries), its default is the one the file may leave out, and pydantic reads the file into them.
A file with an unknown field, a wrong type or a value out of range is refused with its path, the
field (`supply.pressure_mpa`, `criteria[2].max`), the value and what is allowed.

The tables: top level (name, description, model, seed, duration_s), [start], [payload], [supply],
[reality] and [predictor] (with [reality.effects.<joint>]: JointParams fields on top of the arm;
[reality] also holds what the arm really carries and is apart from what the platform is told:
payload mass and centre, brush spring, friction, the cameras' noise),
[control], [operator], and the arrays of tables [[targets]], [[faults]] and [[criteria]].

Beyond each field's own range, the file must agree with the model and with itself (refused
otherwise, before any work): joints named in angles and effects are the model's, start and target
angles inside the joints' ranges of the MJCF, brush targets within the arm's reach, a standoff only
with a brush target, a fault's joint and value as its kind needs them (its row in
scenarios/faults.py), arm-only criteria (brush, contact force, payload drop) not on the rig, a disc
only on the disc criteria, min <= max, a criterion judged against targets only with a target of
that joint and a controller, a max_travel_deg criterion with its joint (each kind's row in
scenarios/criteria.py says what it needs), and a file that is not empty. A shipped scenario may be
named without its path (`load("insulator_cleaning")`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import field
from pathlib import Path
from typing import Annotated

import mujoco
from pydantic import AfterValidator, BeforeValidator, ValidationError
from pydantic.dataclasses import dataclass

import assets
from assets import JOINTS
from pneumatics import JointParams, load_joint_params, paper_model
from pneumatics.as_built import load_as_built
from pneumatics.params import JointParamsSubset, check_related
from scenarios.criteria import CRITERIA
from scenarios.faults import FAULTS
from scenarios.ik import disc_drive_angles, drive_to_qpos, qpos_to_drive
from scenarios.kinds import kind_of
from scenarios.string import MAX_DISCS, discs_of
from twin_plumbing.errors import ParameterError, UserError
from twin_plumbing.fields import (
    FLAG,
    MISSING,
    REAL,
    TABLE,
    TEXT,
    Problem,
    choice,
    first_problem,
    number,
    number_check,
    parse_toml,
    read_toml,
    refuse,
    whole,
)
from twin_plumbing.paths import path_problem

SHIPPED_DIR = Path(__file__).resolve().parent  # the scenario files ship as package data (pyproject.toml)
# who keeps the arm on its task (scenarios/task.py): the predictor alone; the predictor re-referenced
# at the shoulder's end stop after every disc; the operator correcting by eye through the global
# camera (scenarios/operator.py); or, as a bound that breaks the sensorless rule, the same
# controller fed the plant's true angles
STRATEGIES = ("sensorless", "rereference", "operator", "true_angle")
ARMS = ("as_built", "nominal")
# [reality] fields of the arm's scene only (the rig carries no payload, brush or camera), at their defaults
ARM_REALITY = ("payload_mass_ratio", "payload_com_m", "brush_spring_ratio", "camera_noise_px")
# the [supply] fields each kind reads (`scenarios.supply.supply_profile`); steps start from pressure_mpa
SUPPLY_FIELDS = {
    "constant": ("pressure_mpa",),
    "steps": ("steps", "pressure_mpa"),
    "random": ("mean_mpa", "variance_pa2", "hold_s"),
}
ANGLE_DEG = number(-360.0, 360.0, "deg")  # a joint angle; the joint's own range is checked against the MJCF


class ScenarioError(UserError):
    """A scenario file that cannot be run as written."""


def _steps(value: object) -> tuple[tuple[float, float], ...]:
    """[[time_s, pressure_mpa], ...]: numbers, times finite and increasing, pressures 0..1 MPa."""
    if not isinstance(value, (list, tuple)) or not all(
        isinstance(s, (list, tuple))
        and len(s) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in s)
        for s in value
    ):
        raise refuse("is not allowed", "a list of [time_s, pressure_mpa] pairs")
    for k, (t, mpa) in enumerate(value):
        if not (math.isfinite(t) and t >= 0 and 0 <= mpa <= 1.0):
            raise refuse("is not allowed", "time_s >= 0 (finite) and pressure_mpa in 0..1", [t, mpa])
        if k and not t > value[k - 1][0]:
            before = f"(the pair before is at {value[k - 1][0]:g} s)"
            raise refuse("is not allowed", f"time_s increasing from pair to pair {before}", [t, mpa])
    return tuple((float(t), float(mpa)) for t, mpa in value)


def _set_fields(effects: dict[str, JointParamsSubset]) -> dict[str, dict[str, float]]:
    return {joint: table.model_dump(exclude_unset=True) for joint, table in effects.items()}


@dataclass(frozen=True, config=TABLE)
class Start:
    pose: choice("home", "zero") = "home"  # the MJCF's "home" keyframe, or every joint at 0
    angles_deg: dict[str, ANGLE_DEG] = field(default_factory=dict)  # joint -> angle, over the pose


@dataclass(frozen=True, config=TABLE)
class Payload:
    mass_kg: number(0.0, 40.0, "kg") = 20.0  # DESIGN "Sizing": the arm is sized for 20 kg at 1.1 m


@dataclass(frozen=True, config=TABLE)
class Supply:
    kind: choice("constant", "steps", "random") = "constant"
    pressure_mpa: number(0.0, 1.0, "MPa gauge") = 0.6  # constant
    steps: Annotated[tuple[tuple[float, float], ...], BeforeValidator(_steps)] = ()  # [[time_s, pressure_mpa], ...]
    # random (paper Sec. IV: 0.6 MPa mean, 5e9 Pa^2 variance, each value held 0.5 s)
    mean_mpa: number(0.0, 1.0, "MPa gauge") = 0.6
    variance_pa2: number(0.0, 1e11, "Pa^2") = 5e9
    hold_s: number(1e-3, 600.0, "s") = 0.5


@dataclass(frozen=True, config=TABLE)
class Model:
    """The predictor's joint model, or the configuration reality adds to its base arm."""

    hose_loss: FLAG = True
    # joint -> {JointParams field: value}, on top of the joint's parameters
    effects: Annotated[dict[str, JointParamsSubset], AfterValidator(_set_fields)] = field(default_factory=dict)


COM_OFFSET_M = number(-0.1, 0.1, "m")  # within the 0.137 m payload block (assets/arm.xml)


@dataclass(frozen=True, config=TABLE)
class Reality(Model):
    # reality's base: the as-built arm (assets/as_built/) or the nominal twin for a self-check (the
    # predictor is always nominal)
    arm: choice(*ARMS) = "as_built"
    # what the arm really is and carries, apart from what the platform is told: the controller's
    # load model takes [payload] mass_kg, the payload's centre where assets/arm.xml puts it, the
    # brush spring's rate and the joints' friction from the files; the operator believes his picture
    # as sharp as its pixels (ARM_REALITY: the fields the rig has not)
    payload_mass_ratio: number(0.5, 2.0) = 1.0  # the payload's true mass over [payload] mass_kg
    payload_com_m: tuple[COM_OFFSET_M, COM_OFFSET_M, COM_OFFSET_M] = (0.0, 0.0, 0.0)  # its centre moved, tool frame
    brush_spring_ratio: number(0.25, 4.0) = 1.0  # the head spring's true rate (and preload) over the MJCF's
    friction_ratio: number(0.0, 5.0) = 1.0  # every joint's true Coulomb, viscous and Stribeck friction over its file's
    camera_noise_px: number(0.0, 10.0, "px") = 0.0  # the cameras' pixel noise: s.d. of each point's place, per frame


@dataclass(frozen=True, config=TABLE)
class ControlParams:
    mode: choice("closed_loop", "open_loop", "none") = "closed_loop"
    sequence: choice("one_after_another", "together") = "one_after_another"
    min_rotation_deg: number(0.0, 90.0, "deg") = 20.0  # moves shorter than this are refused
    tolerance_deg: number(0.05, 10.0, "deg") = 0.5
    move_timeout_s: number(0.1, 600.0, "s") = 20.0
    strategy: choice(*STRATEGIES) = "sensorless"  # scenarios/task.py; arm only


@dataclass(frozen=True, config=TABLE)
class OperatorParams:
    """The operator watching the global camera (scenarios/operator.py has the sources)."""

    camera_fps: number(0.5, 200.0, "frames/s") = 25.0
    latency_s: number(0.0, 10.0, "s") = 0.4
    tolerance_m: number(0.001, 0.2, "m") = 0.01
    width_px: whole(16, 8192) = 640
    height_px: whole(16, 8192) = 480


@dataclass(frozen=True, config=TABLE)
class String:
    """Where the insulator string really stands (scenarios/string.py builds the scene from it at run
    time). The defaults are assets/scene.xml's string. Nobody on the platform is told these: the
    operator finds the string in his camera's picture (scenarios/sighting.py)."""

    x_m: number(0.3, 1.3, "m") = 0.75  # the top disc's centre, world (before the yaw below)
    y_m: number(-0.6, 0.6, "m") = 0.0
    top_z_m: number(0.3, 1.7, "m") = 1.25
    yaw_deg: number(-60.0, 60.0, "deg") = 0.0  # the string turned about the arm's base axis (world z)
    tilt_deg: number(-20.0, 20.0, "deg") = 0.0  # its axis leaning from vertical, the bottom towards the arm (+)
    discs: whole(1, MAX_DISCS) = 8
    pitch_m: number(0.1, 0.3, "m") = 0.146  # disc to disc along the axis (U70BL: 146 mm, IEC 60305)


@dataclass(frozen=True, config=TABLE)
class Target:
    angles_deg: dict[str, ANGLE_DEG] = field(default_factory=dict)  # drive angles (scenarios.ik)
    brush_at_disc: whole(0, MAX_DISCS) = 0  # the brush on that disc's rim by inverse kinematics; 0: none
    # the cleaning of every disc of the string, planned at run time for the string as the platform
    # sees it (scenarios/plan.py): this one target becomes each disc's approach, press and back-off
    clean_string: FLAG = False
    dwell_s: number(0.0, 600.0, "s") = 0.0
    standoff_m: number(-0.05, 0.5, "m") = -0.006  # brush face to the disc's rim (negative: pressed into it)


@dataclass(frozen=True, config=TABLE)
class Fault:
    kind: kind_of(FAULTS)  # a row of scenarios.faults.FAULTS
    at_s: number(0.0, math.inf, "s")  # within the run: 0 <= at_s < duration_s
    joint: TEXT = ""  # the joint it strikes: every kind but those that strike the whole arm (supply_lost)
    value: REAL = 0.0  # only for the kinds that take one, in the range and unit of its row; not 0


@dataclass(frozen=True, config=TABLE)
class Criterion:
    kind: kind_of(CRITERIA)  # a row of scenarios.criteria.CRITERIA; min and max in its unit
    joint: TEXT = ""  # the kinds by_joint only; none: every joint it applies to
    max: number(0.0, math.inf) = math.inf
    min: number(-math.inf, math.inf) = -math.inf
    disc: whole(0, MAX_DISCS) = 0  # the kinds by_disc only; 0: every disc


@dataclass(frozen=True, config=TABLE)
class Scenario:
    path: str = "<scenario>"  # not in the file: where it was read from
    name: TEXT = ""  # default: the file's name without .toml
    description: TEXT = ""
    model: choice("arm", "wrist_rig") = "arm"
    seed: whole(0, 2**63 - 1) = 0
    duration_s: number(1e-3, 7200.0, "s") = 10.0
    start: Start = Start()
    payload: Payload = Payload()
    supply: Supply = Supply()
    reality: Reality = Reality()
    predictor: Model = Model()
    control: ControlParams = ControlParams()
    operator: OperatorParams = OperatorParams()
    string: String = String()
    targets: tuple[Target, ...] = ()
    faults: tuple[Fault, ...] = ()
    criteria: tuple[Criterion, ...] = ()
    text: str = ""  # not in the file: the file as read, stored in logs
    overrides: dict = field(default_factory=dict)  # not in the file: fields a sweep set on top of it

    @property
    def joints(self) -> tuple[str, ...]:
        return ("wrist_pitch",) if self.model == "wrist_rig" else JOINTS

    @property
    def start_pose(self) -> str:
        return self.start.pose

    @property
    def start_angles_deg(self) -> dict[str, float]:
        return self.start.angles_deg

    @property
    def payload_kg(self) -> float:
        return self.payload.mass_kg


NOT_IN_FILE = ("path", "text", "overrides")
FILE_KEYS = tuple(k for k in Scenario.__pydantic_fields__ if k not in NOT_IN_FILE)


def _dotted(loc: tuple[str | int, ...]) -> str:
    """`targets[0].angles_deg.wrist_pitch` from pydantic's ('targets', 0, 'angles_deg', 'wrist_pitch')."""
    out = ""
    for key in loc:
        if isinstance(key, int):
            out += f"[{key}]"
        elif key != "[key]":
            out += f".{key}" if out else key
    return out


def _fail(path: str, dotted: str, value: object, allowed: str, why: str = "is not allowed") -> ScenarioError:
    """The one-line refusal: `<file>: <field> = <value> is not allowed; allowed: <what>`."""
    if why == "is not a known field":
        return ScenarioError(f"{path}: {dotted} is not a known field; allowed: {allowed}")
    shown = MISSING if value is MISSING else repr(value)  # a missing field reads `= <missing>`
    return ScenarioError(f"{path}: {dotted} = {shown} is not allowed; allowed: {allowed}")


def _refusal(path: str, p: Problem) -> ScenarioError:
    allowed = ", ".join(FILE_KEYS) if len(p.loc) == 1 and p.why == "is not a known field" else p.allowed
    return _fail(path, _dotted(p.loc), p.value, allowed, p.why)


def parse(text: str, path: str = "<scenario>") -> Scenario:
    """A Scenario from TOML text; ScenarioError names the path, the field, the value and what is allowed."""
    return parse_doc(parse_toml(text, path, ScenarioError), path, text)


def with_overrides(scenario: Scenario, overrides: dict[str, object]) -> Scenario:
    """The scenario with dotted fields set (`supply.pressure_mpa`, `seed`, ...), checked again.

    Used by sweeps; an override that names no field or breaks a range is refused like a file.
    """
    doc = parse_toml(scenario.text, scenario.path, ScenarioError)
    for dotted, value in overrides.items():
        table = doc
        *parents, leaf = dotted.split(".")
        for key in parents:
            table = table.setdefault(key, {})
            if not isinstance(table, dict):
                raise ScenarioError(f"{scenario.path}: {dotted} cannot be set by a sweep (not a table field)")
        table[leaf] = value
    where = f"{scenario.path} with " + ", ".join(f"{k}={v!r}" for k, v in overrides.items())
    return parse_doc(doc, where, scenario.text, overrides)


def parse_doc(doc: dict, path: str, text: str, overrides: dict | None = None) -> Scenario:
    """A Scenario from an already-parsed TOML document (see `parse`)."""
    if not doc:
        raise ScenarioError(
            f"{path}: an empty scenario (no field at all); "
            "allowed: a file that says what to run (see the shipped scenarios/*.toml)"
        )
    for key in NOT_IN_FILE:
        if key in doc:
            raise _fail(path, key, doc[key], ", ".join(FILE_KEYS), "is not a known field")
    try:
        scenario = Scenario(
            **{"name": Path(path).stem, **doc, "path": path, "text": text, "overrides": dict(overrides or {})}
        )
    except ValidationError as e:
        raise _refusal(path, first_problem(e, Scenario)) from None
    check_consistency(scenario, doc)
    check_against_model(scenario)
    return scenario


def _given(doc: dict, array: str, i: int, key: str) -> bool:
    """Whether the file sets `key` in the i-th [[array]] table (not just its default)."""
    return key in doc[array][i]


def check_consistency(s: Scenario, doc: dict) -> None:
    """What the fields must hold together: the model's joints, a plan for the strategy, targets
    and faults and criteria as their kinds need them (ScenarioError on the first that does not)."""
    _check_joint_names(s)
    _check_effects(s)
    _check_read(s, doc)
    if s.supply.kind == "steps" and not s.supply.steps:
        raise _fail(s.path, "supply.steps", [], "at least one [time_s, pressure_mpa] pair when kind = 'steps'")
    if s.control.strategy != "sensorless" and s.model != "arm":
        raise _fail(
            s.path,
            "control.strategy",
            s.control.strategy,
            "'sensorless' with model = 'wrist_rig' (the others work on the arm's cleaning task)",
        )
    for i, t in enumerate(s.targets):
        _check_target(s, i, t, _given(doc, "targets", i, "standoff_m"))
    for i, f in enumerate(s.faults):
        _check_fault(s, i, f, _given(doc, "faults", i, "value"))
    for i, c in enumerate(s.criteria):
        _check_criterion(s, i, c, _given(doc, "criteria", i, "disc"))


def _check_joint_names(s: Scenario) -> None:
    """Angles and effects name joints of the scenario's model."""
    tables = {"start.angles_deg": s.start.angles_deg}
    tables |= {f"targets[{i}].angles_deg": t.angles_deg for i, t in enumerate(s.targets)}
    tables |= {"reality.effects": s.reality.effects, "predictor.effects": s.predictor.effects}
    for where, table in tables.items():
        for joint in table:
            if joint not in s.joints:
                raise _fail(s.path, f"{where}.{joint}", None, ", ".join(s.joints), "is not a known field")


def _check_read(s: Scenario, doc: dict) -> None:
    """Refuse a field the run would not read: the payload on the rig, a [supply] field its kind ignores."""
    if s.model != "arm" and "payload" in doc:
        for key, value in doc["payload"].items():
            raise _fail(s.path, f"payload.{key}", value, "no [payload] with model = 'wrist_rig' (the rig carries none)")
    for key in ARM_REALITY:
        if s.model != "arm" and key in doc.get("reality", {}):
            rig = f"no reality.{key} with model = 'wrist_rig' (the rig has none)"
            raise _fail(s.path, f"reality.{key}", doc["reality"][key], rig)
    if s.model != "arm" and "string" in doc:
        for key, value in doc["string"].items():
            raise _fail(s.path, f"string.{key}", value, "no [string] with model = 'wrist_rig' (the rig has none)")
    for key, value in doc.get("supply", {}).items():
        read = SUPPLY_FIELDS[s.supply.kind]
        if key != "kind" and key not in read:
            allowed = f"the fields kind = {s.supply.kind!r} reads ({', '.join(read)}); it does not read {key}"
            raise _fail(s.path, f"supply.{key}", value, allowed)


def _check_effects(s: Scenario) -> None:
    """Each joint's parameters with the effects on it hold together as a parameter file's must
    (pneumatics.params.check_related: a rotor inside its stator, ...), on the base they apply to."""
    for table, model in (("reality", s.reality), ("predictor", s.predictor)):
        joints = tuple(model.effects)
        if not joints:
            continue
        base = reality_params(s, joints) if table == "reality" else nominal_params(joints)
        ratio = s.reality.friction_ratio if table == "reality" else 1.0
        for joint, params in joint_params_for(base, model, ratio).items():
            try:
                check_related(params, _effect_at(s.path, f"{table}.effects.{joint}"))
            except ParameterError as e:
                raise ScenarioError(str(e)) from None


def _effect_at(path: str, table: str):
    """Where an effect is written in a scenario file, for a message: `<file>: <table>.<field>`."""
    return lambda field: f"{path}: {table}.{field}"


def _check_target(s: Scenario, i: int, t: Target, standoff_given: bool) -> None:
    where = f"targets[{i}]"
    if t.clean_string:
        if s.model != "arm":
            raise _fail(s.path, f"{where}.clean_string", True, "only with model = 'arm' (the rig has no brush)")
        if t.brush_at_disc or t.angles_deg or standoff_given:
            raise _fail(
                s.path, f"{where}.clean_string", True, "alone in its target (the plan places the brush on every disc)"
            )
        return
    if not t.angles_deg and not t.brush_at_disc:
        raise _fail(
            s.path,
            f"{where}.angles_deg",
            {},
            "angles_deg for at least one joint, brush_at_disc, or clean_string = true",
        )
    if t.brush_at_disc and s.model != "arm":
        raise _fail(s.path, f"{where}.brush_at_disc", t.brush_at_disc, "only with model = 'arm' (the rig has no brush)")
    if standoff_given and not t.brush_at_disc:
        raise _fail(s.path, f"{where}.standoff_m", t.standoff_m, "only with brush_at_disc")


def _check_fault(s: Scenario, i: int, f: Fault, value_given: bool) -> None:
    where, kind = f"faults[{i}]", FAULTS[f.kind]
    if not kind.whole_arm and f.joint not in s.joints:
        raise _fail(s.path, f"{where}.joint", f.joint, " | ".join(s.joints))
    if kind.value:
        _check_fault_value(s.path, where, f, value_given)
    elif value_given:
        with_value = ", ".join(name for name, k in FAULTS.items() if k.value)
        raise _fail(
            s.path, f"{where}.value", f.value, f"no value for kind = {f.kind!r} (a value only with {with_value})"
        )
    if kind.whole_arm and f.joint:
        raise _fail(s.path, f"{where}.joint", f.joint, f"no joint for kind = {f.kind!r} ({kind.whole_arm})")
    if f.at_s >= s.duration_s:  # a fault at the run's very end would never act
        raise _fail(
            s.path, f"{where}.at_s", f.at_s, f"a number from 0 up to, not at, {s.duration_s:g} s (the run's end)"
        )


def _check_fault_value(path: str, where: str, f: Fault, given: bool) -> None:
    """The fault's value within its kind's range (and its joint's limit, e.g. a leak up to the whole
    bore of the hose), not 0."""
    kind = FAULTS[f.kind]
    check, allowed = number_check(*kind.value)
    if not given:
        raise _fail(path, f"{where}.value", MISSING, allowed)
    try:
        check(f.value)
    except ValueError:
        raise _fail(path, f"{where}.value", f.value, allowed) from None
    if f.value == 0.0:
        raise _fail(path, f"{where}.value", f.value, f"a {f.kind} other than 0 (0 is no fault)")
    if kind.value_limit:
        high, allowed = kind.value_limit(f.joint)
        if f.value > high:
            raise _fail(path, f"{where}.value", f.value, allowed)


def _check_criterion(s: Scenario, i: int, c: Criterion, disc_given: bool) -> None:
    where, joint_names, kind = f"criteria[{i}]", " | ".join(s.joints), CRITERIA[c.kind]
    if c.joint and c.joint not in s.joints:
        raise _fail(s.path, f"{where}.joint", c.joint, joint_names)
    if c.joint and not kind.by_joint:
        by_joint = ", ".join(name for name, k in CRITERIA.items() if k.by_joint)
        raise _fail(s.path, f"{where}.joint", c.joint, f"no joint for kind = {c.kind!r} (a joint only with {by_joint})")
    if kind.joint_required and not c.joint:
        raise _fail(s.path, f"{where}.joint", MISSING, joint_names)
    if kind.arm_only and s.model != "arm":
        rig = ", ".join(name for name, k in CRITERIA.items() if not k.arm_only)
        raise _fail(
            s.path,
            f"{where}.kind",
            c.kind,
            f"a criterion the rig can be judged by ({rig}); {c.kind} needs model = 'arm'",
        )
    if disc_given and not kind.by_disc:
        by_disc = " | ".join(repr(name) for name, k in CRITERIA.items() if k.by_disc)
        raise _fail(s.path, f"{where}.disc", c.disc, f"only with kind = {by_disc}")
    if c.disc > s.string.discs:
        raise _fail(
            s.path,
            f"{where}.disc",
            c.disc,
            f"1..{s.string.discs} (the discs of the scenario's [string]; 0: every disc)",
        )
    if c.min > c.max:
        raise _fail(s.path, f"{where}.min", c.min, f"min <= max (max = {c.max:g})")
    if kind.needs_controller or kind.needs_targets:
        _needs_a_plan(s, where, c)


def _needs_a_plan(s: Scenario, where: str, c: Criterion) -> None:
    """A criterion judged against targets or a prediction needs them: without, it would pass on nothing."""
    if s.control.mode == "none":
        raise _fail(
            s.path,
            f"{where}.kind",
            c.kind,
            "a criterion that holds without a controller (control.mode = 'none' moves nothing, predicts nothing): "
            "max_travel_deg, max_drop_m, ...",
        )
    if not CRITERIA[c.kind].needs_targets:
        return
    targeted = {j for t in s.targets for j in (JOINTS if t.brush_at_disc or t.clean_string else t.angles_deg)}
    if not targeted:
        raise _fail(
            s.path,
            f"{where}.kind",
            c.kind,
            "a criterion the scenario can be judged by: it has no [[targets]] to measure an error against",
        )
    if c.joint and c.joint not in targeted:
        raise _fail(s.path, f"{where}.joint", c.joint, f"a joint some target moves ({', '.join(sorted(targeted))})")


@functools.lru_cache(maxsize=2)
def compiled_model(model: str) -> mujoco.MjModel:
    """The MJCF a scenario's plant is built from, compiled once per process (joint ranges, discs)."""
    return mujoco.MjModel.from_xml_path(str(assets.WRIST_RIG_XML if model == "wrist_rig" else assets.SCENE_XML))


def _reachable_standoffs(m: mujoco.MjModel, disc: int) -> str:
    """The standoffs (schema range, 5 mm steps) at which the brush reaches `disc`, as text."""
    ok = []
    for mm in range(-20, 501, 5):
        try:
            disc_drive_angles(m, disc, mm / 1000)
            ok.append(mm / 1000)
        except ValueError:
            pass
    return f"{min(ok):g}..{max(ok):g} m" if ok else "none: the disc is out of reach"


def check_against_model(s: Scenario) -> None:
    """Refuse what the model cannot do: a start or target angle outside a joint's range (from the
    MJCF), a brush target out of the arm's reach. Targets are drive angles: the elbow's is the
    forearm's absolute pitch, so a shoulder target moves the elbow joint (scenarios.ik)."""
    m = compiled_model(s.model)
    source = Path(assets.WRIST_RIG_XML if s.model == "wrist_rig" else assets.ARM_XML).name
    ranges = {j: (math.degrees(m.joint(j).range[0]), math.degrees(m.joint(j).range[1])) for j in s.joints}
    allowed = {j: f"{lo:.1f}..{hi:.1f} deg ({j}'s range in assets/{source})" for j, (lo, hi) in ranges.items()}
    start = _start_qpos(s, m)
    for j, deg in s.start_angles_deg.items():
        if not ranges[j][0] <= deg <= ranges[j][1]:
            raise _fail(s.path, f"start.angles_deg.{j}", deg, allowed[j])
        start[j] = math.radians(deg)
    drive = qpos_to_drive(start)
    for i, t in enumerate(s.targets):
        drive.update(_target_drive(s, m, i, t))
        for j, q in drive_to_qpos(drive).items():
            if j in ranges and not math.radians(ranges[j][0]) - 1e-9 <= q <= math.radians(ranges[j][1]) + 1e-9:
                if j in t.angles_deg and j != "elbow_pitch":
                    raise _fail(s.path, f"targets[{i}].angles_deg.{j}", t.angles_deg[j], allowed[j])
                drives = ", ".join(f"{k} {math.degrees(v):.1f}" for k, v in drive.items())
                raise ScenarioError(
                    f"{s.path}: targets[{i}] puts joint {j} at {math.degrees(q):.1f} deg (drive angles {drives} deg; "
                    f"the elbow's drive angle is the forearm's pitch, shoulder + elbow joint); allowed: {allowed[j]}"
                )


def _start_qpos(s: Scenario, m: mujoco.MjModel) -> dict[str, float]:
    """The joints' start angles (rad) of the scenario's pose: the MJCF's "home" keyframe, or zero."""
    key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home")
    if s.start_pose != "home" or key < 0:
        return dict.fromkeys(s.joints, 0.0)
    return {j: float(m.key_qpos[key][m.joint(j).qposadr[0]]) for j in s.joints}


def _target_drive(s: Scenario, m: mujoco.MjModel, i: int, t: Target) -> dict[str, float]:
    """The drive angles (rad) the i-th target sets: its brush pose by inverse kinematics, then its angles."""
    drive = {}
    if t.brush_at_disc:
        believed = len(discs_of(m))
        if t.brush_at_disc > believed:
            raise _fail(
                s.path,
                f"targets[{i}].brush_at_disc",
                t.brush_at_disc,
                f"1..{believed} (the discs of assets/scene.xml's string, which a target's disc number names; "
                "clean_string = true cleans the string as found)",
            )
        try:
            drive = disc_drive_angles(m, t.brush_at_disc, t.standoff_m)
        except ValueError:
            raise ScenarioError(
                f"{s.path}: targets[{i}] brush_at_disc = {t.brush_at_disc}, standoff_m = {t.standoff_m!r} "
                f"is out of the brush's reach; allowed: a standoff_m at which the arm reaches disc "
                f"{t.brush_at_disc} inside its joint ranges ({_reachable_standoffs(m, t.brush_at_disc)})"
            ) from None
    return drive | {j: math.radians(v) for j, v in t.angles_deg.items()}


def shipped_names() -> list[str]:
    return sorted(p.stem for p in SHIPPED_DIR.glob("*.toml"))


def find(name_or_path: str | Path) -> Path:
    """A scenario file: the path as given, else the shipped scenario of that name
    (`insulator_cleaning` or `insulator_cleaning.toml`), wherever the package is installed."""
    path = Path(name_or_path)
    problem = path_problem(path)
    if problem:
        raise ScenarioError(f"{path}: {problem}; allowed: a path to a scenario file or a shipped scenario's name")
    if path.exists() or len(path.parts) != 1 or path.suffix not in ("", ".toml"):
        return path
    shipped = SHIPPED_DIR / f"{path.stem}.toml"
    if shipped.is_file():
        return shipped
    raise ScenarioError(
        f"{path}: no such scenario file; "
        f"allowed: a path to a scenario file or a shipped scenario's name ({', '.join(shipped_names())})"
    )


def load(path: str | Path) -> Scenario:
    """Read and check a scenario file (a path, or the name of a shipped scenario)."""
    path = find(path)
    doc, text = read_toml(path, ScenarioError, "scenario file")
    return parse_doc(doc, str(path), text)


def nominal_params(joints: tuple[str, ...]) -> dict[str, JointParams]:
    """The joints' parameter files (assets/joints/): the predictor's base, always nominal."""
    return {j: load_joint_params(assets.joint_param_path(j)) for j in joints}


def reality_params(scenario: Scenario, joints: tuple[str, ...] | None = None) -> dict[str, JointParams]:
    """Reality's base parameters per joint (every joint of the scenario's model, or `joints`): the
    as-built arm (nominal + assets/as_built/, with the joint files' physics: the chambers' energy
    balance), or with `[reality] arm = "nominal"` the predictor's own nominal model, the paper's
    (`paper_model` of the joint files: a self-check)."""
    base = nominal_params(scenario.joints if joints is None else joints)
    if scenario.reality.arm == "nominal":
        return {j: paper_model(p) for j, p in base.items()}
    return {j: load_as_built(p, assets.as_built_path(j)) for j, p in base.items()}


def joint_params_for(base: dict[str, JointParams], model: Model, friction_ratio: float = 1.0) -> dict[str, JointParams]:
    """The joints' parameters with this model's configuration applied (hose loss, effects), their
    friction (Coulomb, viscous, Stribeck) then scaled by `friction_ratio` (reality's)."""
    out = {}
    ratio = friction_ratio
    for joint, params in base.items():
        params = params._replace(hose_loss=1.0 if model.hose_loss else 0.0)
        params = params._replace(**model.effects.get(joint, {}))
        params = params._replace(
            coulomb_nm=params.coulomb_nm * ratio,
            viscous_nm_s=params.viscous_nm_s * ratio,
            stribeck_excess_nm=params.stribeck_excess_nm * ratio,
        )
        out[joint] = params
    return out
