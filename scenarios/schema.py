"""The scenario file format: a typed schema, read from TOML as data (nothing in it is executed).

A scenario says where the arm starts, what it carries, what air it gets, what it must do, what
"reality" has that the predictor lacks, what goes wrong and when, and how to judge the run.
Every field below carries its unit in its name. A file with an unknown field, a wrong type or a
value out of range is refused with its path, the field, the value and what is allowed.

Top level:            name (str), description (str), model ("arm" | "wrist_rig"), seed (int),
                      duration_s (0 < . <= 7200)
[start]               pose ("home" | "zero"), angles_deg {joint: deg} (override; joint angles)
[payload]             mass_kg (0..40)
[supply]              kind ("constant" | "steps" | "random"); pressure_mpa (gauge, 0..1.0);
                      steps [[time_s, pressure_mpa], ...]; mean_mpa, variance_pa2, hold_s (random)
[reality]             arm ("as_built" | "nominal": the as-built arm of assets/as_built/, default, or
                      the predictor's nominal model for a self-check); hose_loss (bool);
                      [reality.effects.<joint>] {JointParams field: value} (on top of the arm)
[predictor]           hose_loss (bool); [predictor.effects.<joint>] {field: value}
[control]             mode ("closed_loop" | "open_loop" | "none"), sequence ("one_after_another" |
                      "together"), min_rotation_deg (0..90), tolerance_deg (0.05..10),
                      move_timeout_s (0.1..600), strategy ("sensorless" | "rereference" |
                      "operator" | "true_angle", scenarios/task.py; arm only)
[operator]            camera_fps (0.5..200), latency_s (0..10), tolerance_m (0.001..0.2), width_px,
                      height_px: the operator's view through the global camera (strategy "operator")
[[targets]]           angles_deg {joint: deg} (drive angles) | brush_at_disc (1..8, the brush on
                      that disc's rim by inverse kinematics), standoff_m (-0.05..0.5: brush face
                      to rim; negative presses, default -0.006) ; dwell_s (0..600)
[[faults]]            kind ("supply_lost" | "hose_leak" | "valve_stuck_open" | "brake_fails" |
                      "sensor_bias"), at_s (0..duration_s), joint (not for supply_lost), value
                      (only hose_leak: area m^2 up to the hose's bore; sensor_bias: Pa, +-1e6; not 0)
[[criteria]]          kind ("final_error_deg" | "max_error_deg" | "brush_on_disc" |
                      "contact_force_n" | "disc_contact_s" | "disc_force_n" | "disc_brushed_m" |
                      "max_drop_m" | "max_travel_deg" | "prediction_error_deg"), joint, max,
                      min (min <= max), disc (brush_on_disc and the disc_* criteria)

Beyond each field's own range, the file must agree with the model and with itself (refused
otherwise, before any work): start and target angles inside the joints' ranges of the MJCF, brush
targets within the arm's reach, arm-only criteria (brush, contact force, payload drop) not on the
rig, a criterion judged against targets only with a target of that joint and a controller, a
max_travel_deg criterion with its joint, and a file that is not empty. A shipped scenario may be
named without its path (`load("insulator_cleaning")`).
"""

from __future__ import annotations

import functools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import mujoco

import assets
from assets import JOINTS
from pneumatics import JointParams, load_joint_params
from pneumatics.params import SPEC
from scenarios.ik import disc_drive_angles, drive_to_qpos, qpos_to_drive
from twin.errors import UserError

SHIPPED_DIR = Path(__file__).resolve().parent  # the scenario files ship as package data (pyproject.toml)
ARM_ONLY_CRITERIA = (
    "brush_on_disc",
    "contact_force_n",
    "disc_contact_s",
    "disc_force_n",
    "disc_brushed_m",
    "max_drop_m",
)  # need the brush, the discs, the payload
TARGET_CRITERIA = ("final_error_deg", "max_error_deg")  # judged against the targets: need one
# a fault's value: (low, high, unit) per kind that has one
FAULT_VALUES = {
    "hose_leak": (
        0.0,
        5.1e-5,
        "m^2",
    ),  # at most the whole bore of the hose: 8 mm the widest (assets/joints/*.toml); per joint below
    "sensor_bias": (-1e6, 1e6, "Pa"),  # +-10 bar: beyond the 0.5-0.8 MPa supply's whole span
}
JOINT_CRITERIA = ("final_error_deg", "max_error_deg", "max_travel_deg", "prediction_error_deg")
DISC_CRITERIA = ("brush_on_disc", "disc_contact_s", "disc_force_n", "disc_brushed_m")  # may name one disc


CRITERIA = (
    "final_error_deg",
    "max_error_deg",
    "brush_on_disc",
    "contact_force_n",
    "disc_contact_s",
    "disc_force_n",
    "disc_brushed_m",
    "max_drop_m",
    "max_travel_deg",
    "prediction_error_deg",
)
# who keeps the arm on its task (scenarios/task.py): the predictor alone; the predictor re-referenced
# at the shoulder's end stop after every disc; the operator correcting by eye through the global
# camera (scenarios/operator.py); or, as a bound that breaks the sensorless rule, the same
# controller fed the plant's true angles
STRATEGIES = ("sensorless", "rereference", "operator", "true_angle")


class ScenarioError(UserError):
    """A scenario file that cannot be run as written."""


@dataclass(frozen=True)
class Supply:
    kind: str = "constant"
    pressure_mpa: float = 0.6
    steps: tuple[tuple[float, float], ...] = ()
    mean_mpa: float = 0.6
    variance_pa2: float = 5e9
    hold_s: float = 0.5


ARMS = ("as_built", "nominal")


@dataclass(frozen=True)
class Model:
    hose_loss: bool = True
    effects: dict = field(default_factory=dict)  # joint -> {field: value}
    arm: str = "as_built"  # reality's base: the as-built arm or the nominal twin (the predictor is always nominal)


@dataclass(frozen=True)
class Control:
    mode: str = "closed_loop"
    sequence: str = "one_after_another"
    min_rotation_deg: float = 20.0
    tolerance_deg: float = 0.5
    move_timeout_s: float = 20.0
    strategy: str = "sensorless"


@dataclass(frozen=True)
class Operator:
    """The operator watching the global camera (scenarios/operator.py has the sources)."""

    camera_fps: float = 25.0
    latency_s: float = 0.4
    tolerance_m: float = 0.01
    width_px: int = 640
    height_px: int = 480


@dataclass(frozen=True)
class Target:
    angles_deg: dict = field(default_factory=dict)
    brush_at_disc: int = 0
    dwell_s: float = 0.0
    standoff_m: float = -0.006  # brush face to the disc's rim (negative: pressed into it)


@dataclass(frozen=True)
class Fault:
    kind: str
    at_s: float
    joint: str = ""
    value: float = 0.0


@dataclass(frozen=True)
class Criterion:
    kind: str
    joint: str = ""
    max: float = math.inf
    min: float = -math.inf
    disc: int = 0


@dataclass(frozen=True)
class Scenario:
    path: str
    name: str
    description: str = ""
    model: str = "arm"
    seed: int = 0
    duration_s: float = 10.0
    start_pose: str = "home"
    start_angles_deg: dict = field(default_factory=dict)
    payload_kg: float = 20.0
    supply: Supply = Supply()
    reality: Model = Model()
    predictor: Model = Model()
    control: Control = Control()
    operator: Operator = Operator()
    targets: tuple[Target, ...] = ()
    faults: tuple[Fault, ...] = ()
    criteria: tuple[Criterion, ...] = ()
    text: str = ""  # the file as read, stored in logs
    overrides: dict = field(default_factory=dict)  # fields a sweep set on top of the file

    @property
    def joints(self) -> tuple[str, ...]:
        return ("wrist_pitch",) if self.model == "wrist_rig" else JOINTS


class _Reader:
    """Pulls typed, range-checked values out of one TOML table, naming the path of each."""

    def __init__(self, path: str, table: dict, where: str, allowed: set[str]):
        self.path, self.table, self.where = path, table, where
        unknown = sorted(set(table) - allowed)
        if unknown:
            raise ScenarioError(
                f"{path}: {self._name(unknown[0])} is not a known field; allowed: {', '.join(sorted(allowed))}"
            )

    def _name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def fail(self, key: str, value, allowed: str):
        raise ScenarioError(f"{self.path}: {self._name(key)} = {value!r} is not allowed; allowed: {allowed}")

    def number(self, key: str, default, low: float, high: float, unit: str = ""):
        if key not in self.table and default is not None:
            return float(default)  # an unset bound may be infinite
        value = self.table.get(key, default)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
            or not low <= value <= high
        ):
            self.fail(key, value, f"a number in {low:g}..{high:g}{' ' + unit if unit else ''}")
        return float(value)

    def integer(self, key: str, default, low: int, high: int):
        value = self.table.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            self.fail(key, value, f"a whole number in {low}..{high}")
        return value

    def choice(self, key: str, default, options: tuple[str, ...]):
        value = self.table.get(key, default)
        if value is None:
            self.fail(key, "<missing>", " | ".join(repr(o) for o in options))
        if value not in options:
            self.fail(key, value, " | ".join(repr(o) for o in options))
        return value

    def text(self, key: str, default=""):
        value = self.table.get(key, default)
        if not isinstance(value, str):
            self.fail(key, value, "a string")
        return value

    def boolean(self, key: str, default: bool):
        value = self.table.get(key, default)
        if not isinstance(value, bool):
            self.fail(key, value, "true or false")
        return value

    def table_of(self, key: str) -> dict:
        value = self.table.get(key, {})
        if not isinstance(value, dict):
            self.fail(key, value, "a table")
        return value

    def array_of_tables(self, key: str) -> list[dict]:
        value = self.table.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            self.fail(key, value, "an array of tables [[...]]")
        return value


def _joint_angles(path: str, where: str, table: dict, joints: tuple[str, ...]) -> dict:
    r = _Reader(path, table, where, set(joints))
    return {j: r.number(j, None, -360.0, 360.0, "deg") for j in table}


def _model(path: str, where: str, table: dict, joints: tuple[str, ...]) -> Model:
    r = _Reader(path, table, where, {"hose_loss", "effects"} | ({"arm"} if where == "reality" else set()))
    effects = {}
    er = _Reader(path, r.table_of("effects"), f"{where}.effects", set(joints))
    for joint, fields in er.table.items():
        fr = _Reader(path, er.table_of(joint), f"{where}.effects.{joint}", set(SPEC))
        effects[joint] = {f: fr.number(f, None, SPEC[f].low, SPEC[f].high, SPEC[f].unit) for f in fields}
    arm = r.choice("arm", "as_built", ARMS) if where == "reality" else "nominal"
    return Model(hose_loss=r.boolean("hose_loss", True), effects=effects, arm=arm)


def parse(text: str, path: str = "<scenario>") -> Scenario:
    """A Scenario from TOML text; ScenarioError names the path, the field, the value and what is allowed."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(f"{path}: not valid TOML: {e}") from None
    return parse_doc(doc, path, text)


def with_overrides(scenario: Scenario, overrides: dict[str, object]) -> Scenario:
    """The scenario with dotted fields set (`supply.pressure_mpa`, `seed`, ...), checked again.

    Used by sweeps; an override that names no field or breaks a range is refused like a file.
    """
    doc = tomllib.loads(scenario.text)
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
            f"{path}: an empty scenario (no field at all); allowed: a file that says what to run (see the shipped scenarios/*.toml)"
        )
    top = _Reader(
        path,
        doc,
        "",
        {
            "name",
            "description",
            "model",
            "seed",
            "duration_s",
            "start",
            "payload",
            "supply",
            "reality",
            "predictor",
            "control",
            "operator",
            "targets",
            "faults",
            "criteria",
        },
    )
    model = top.choice("model", "arm", ("arm", "wrist_rig"))
    joints = ("wrist_pitch",) if model == "wrist_rig" else JOINTS
    joint_names = " | ".join(joints)

    start = _Reader(path, top.table_of("start"), "start", {"pose", "angles_deg"})
    supply_r = _Reader(
        path, top.table_of("supply"), "supply", {"kind", "pressure_mpa", "steps", "mean_mpa", "variance_pa2", "hold_s"}
    )
    steps = supply_r.table.get("steps", [])
    if not isinstance(steps, list) or not all(
        isinstance(s, list) and len(s) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in s)
        for s in steps
    ):
        supply_r.fail("steps", steps, "a list of [time_s, pressure_mpa] pairs")
    for k, (t, mpa) in enumerate(steps):
        if not (math.isfinite(t) and t >= 0 and 0 <= mpa <= 1.0):
            supply_r.fail("steps", [t, mpa], "time_s >= 0 (finite) and pressure_mpa in 0..1")
        if k and not t > steps[k - 1][0]:
            supply_r.fail(
                "steps", [t, mpa], f"time_s increasing from pair to pair (the pair before is at {steps[k - 1][0]:g} s)"
            )
    supply = Supply(
        kind=supply_r.choice("kind", "constant", ("constant", "steps", "random")),
        pressure_mpa=supply_r.number("pressure_mpa", 0.6, 0.0, 1.0, "MPa gauge"),
        steps=tuple((float(t), float(p)) for t, p in steps),
        mean_mpa=supply_r.number("mean_mpa", 0.6, 0.0, 1.0, "MPa gauge"),
        variance_pa2=supply_r.number("variance_pa2", 5e9, 0.0, 1e11, "Pa^2"),
        hold_s=supply_r.number("hold_s", 0.5, 1e-3, 600.0, "s"),
    )
    if supply.kind == "steps" and not supply.steps:
        supply_r.fail("steps", [], "at least one [time_s, pressure_mpa] pair when kind = 'steps'")

    ctl = _Reader(
        path,
        top.table_of("control"),
        "control",
        {"mode", "sequence", "min_rotation_deg", "tolerance_deg", "move_timeout_s", "strategy"},
    )
    control = Control(
        mode=ctl.choice("mode", "closed_loop", ("closed_loop", "open_loop", "none")),
        sequence=ctl.choice("sequence", "one_after_another", ("one_after_another", "together")),
        min_rotation_deg=ctl.number("min_rotation_deg", 20.0, 0.0, 90.0, "deg"),
        tolerance_deg=ctl.number("tolerance_deg", 0.5, 0.05, 10.0, "deg"),
        move_timeout_s=ctl.number("move_timeout_s", 20.0, 0.1, 600.0, "s"),
        strategy=ctl.choice("strategy", "sensorless", STRATEGIES),
    )
    if control.strategy != "sensorless" and model != "arm":
        ctl.fail(
            "strategy",
            control.strategy,
            "'sensorless' with model = 'wrist_rig' (the others work on the arm's cleaning task)",
        )
    op = _Reader(
        path, top.table_of("operator"), "operator", {"camera_fps", "latency_s", "tolerance_m", "width_px", "height_px"}
    )
    operator = Operator(
        camera_fps=op.number("camera_fps", 25.0, 0.5, 200.0, "frames/s"),
        latency_s=op.number("latency_s", 0.4, 0.0, 10.0, "s"),
        tolerance_m=op.number("tolerance_m", 0.01, 0.001, 0.2, "m"),
        width_px=op.integer("width_px", 640, 16, 8192),
        height_px=op.integer("height_px", 480, 16, 8192),
    )

    targets = []
    for i, t in enumerate(top.array_of_tables("targets")):
        tr = _Reader(path, t, f"targets[{i}]", {"angles_deg", "brush_at_disc", "dwell_s", "standoff_m"})
        angles = _joint_angles(path, f"targets[{i}].angles_deg", tr.table_of("angles_deg"), joints)
        disc = tr.integer("brush_at_disc", 0, 0, 8)
        if not angles and not disc:
            tr.fail("angles_deg", {}, "angles_deg for at least one joint, or brush_at_disc 1..8")
        if disc and model != "arm":
            tr.fail("brush_at_disc", disc, "only with model = 'arm' (the rig has no brush)")
        standoff = tr.number("standoff_m", -0.006, -0.05, 0.5, "m")
        if "standoff_m" in tr.table and not disc:
            tr.fail("standoff_m", standoff, "only with brush_at_disc")
        targets.append(Target(angles, disc, tr.number("dwell_s", 0.0, 0.0, 600.0, "s"), standoff))

    duration = top.number("duration_s", 10.0, 1e-3, 7200.0, "s")
    faults = []
    for i, f in enumerate(top.array_of_tables("faults")):
        fr = _Reader(path, f, f"faults[{i}]", {"kind", "at_s", "joint", "value"})
        kind = fr.choice("kind", None, ("supply_lost", "hose_leak", "valve_stuck_open", "brake_fails", "sensor_bias"))
        joint = fr.text("joint", "")
        if kind != "supply_lost" and joint not in joints:
            fr.fail("joint", joint, joint_names)
        if kind in FAULT_VALUES:
            value = fr.number("value", None, *FAULT_VALUES[kind])
            if value == 0.0:
                fr.fail("value", value, f"a {kind} other than 0 (0 is no fault)")
            if kind == "hose_leak" and joint in joints and value > _hose_bore_m2(joint):
                fr.fail(
                    "value",
                    value,
                    f"a leak area in 0..{_hose_bore_m2(joint):.3g} m^2 (the whole bore of {joint}'s hose)",
                )
        elif "value" in fr.table:
            fr.fail(
                "value",
                fr.table["value"],
                f"no value for kind = {kind!r} (a value only with {', '.join(FAULT_VALUES)})",
            )
        else:
            value = 0.0
        if kind == "supply_lost" and joint:
            fr.fail("joint", joint, "no joint for kind = 'supply_lost' (the supply feeds every joint)")
        faults.append(Fault(kind, fr.number("at_s", None, 0.0, duration, "s"), joint, value))

    criteria = []
    for i, c in enumerate(top.array_of_tables("criteria")):
        cr = _Reader(path, c, f"criteria[{i}]", {"kind", "joint", "max", "min", "disc"})
        kind = cr.choice("kind", None, CRITERIA)
        joint = cr.text("joint", "")
        if joint and joint not in joints:
            cr.fail("joint", joint, joint_names)
        if joint and kind not in JOINT_CRITERIA:
            cr.fail("joint", joint, f"no joint for kind = {kind!r} (a joint only with {', '.join(JOINT_CRITERIA)})")
        if kind == "max_travel_deg" and not joint:
            cr.fail("joint", "<missing>", joint_names)
        if kind in ARM_ONLY_CRITERIA and model != "arm":
            cr.fail(
                "kind",
                kind,
                f"a criterion the rig can be judged by ({', '.join(k for k in CRITERIA if k not in ARM_ONLY_CRITERIA)}); {kind} needs model = 'arm'",
            )
        if "disc" in cr.table and kind not in DISC_CRITERIA:
            cr.fail("disc", cr.table["disc"], f"only with kind = {' | '.join(map(repr, DISC_CRITERIA))}")
        crit = Criterion(
            kind,
            joint,
            cr.number("max", math.inf, 0.0, math.inf),
            cr.number("min", -math.inf, -math.inf, math.inf),
            cr.integer("disc", 0, 0, 8),
        )
        if crit.min > crit.max:
            cr.fail("min", crit.min, f"min <= max (max = {crit.max:g})")
        if kind in TARGET_CRITERIA or kind == "prediction_error_deg":
            _needs_a_plan(cr, kind, joint, targets, control)
        criteria.append(crit)

    scenario = Scenario(
        path=path,
        name=top.text("name", Path(path).stem),
        description=top.text("description", ""),
        model=model,
        seed=top.integer("seed", 0, 0, 2**63 - 1),
        duration_s=duration,
        start_pose=start.choice("pose", "home", ("home", "zero")),
        start_angles_deg=_joint_angles(path, "start.angles_deg", start.table_of("angles_deg"), joints),
        payload_kg=_Reader(path, top.table_of("payload"), "payload", {"mass_kg"}).number(
            "mass_kg", 20.0, 0.0, 40.0, "kg"
        ),
        supply=supply,
        reality=_model(path, "reality", top.table_of("reality"), joints),
        predictor=_model(path, "predictor", top.table_of("predictor"), joints),
        control=control,
        operator=operator,
        targets=tuple(targets),
        faults=tuple(faults),
        criteria=tuple(criteria),
        text=text,
        overrides=dict(overrides or {}),
    )
    check_against_model(scenario)
    return scenario


def _hose_bore_m2(joint: str) -> float:
    return math.pi / 4 * load_joint_params(assets.joint_param_path(joint)).hose_diameter_m ** 2


def _needs_a_plan(cr: _Reader, kind: str, joint: str, targets: list[Target], control: Control) -> None:
    """A criterion judged against targets or a prediction needs them: without, it would pass on nothing."""
    if control.mode == "none":
        cr.fail(
            "kind",
            kind,
            "a criterion that holds without a controller (control.mode = 'none' moves nothing, predicts nothing): max_travel_deg, max_drop_m, ...",
        )
    if kind not in TARGET_CRITERIA:
        return
    targeted = {j for t in targets for j in (JOINTS if t.brush_at_disc else t.angles_deg)}
    if not targeted:
        cr.fail(
            "kind", kind, "a criterion the scenario can be judged by: it has no [[targets]] to measure an error against"
        )
    if joint and joint not in targeted:
        cr.fail("joint", joint, f"a joint some target moves ({', '.join(sorted(targeted))})")


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

    def allowed(j: str) -> str:
        return f"{ranges[j][0]:.1f}..{ranges[j][1]:.1f} deg ({j}'s range in assets/{source})"

    key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home")
    start = {
        j: float(m.key_qpos[key][m.joint(j).qposadr[0]]) if s.start_pose == "home" and key >= 0 else 0.0
        for j in s.joints
    }
    for j, deg in s.start_angles_deg.items():
        if not ranges[j][0] <= deg <= ranges[j][1]:
            raise ScenarioError(f"{s.path}: start.angles_deg.{j} = {deg!r} is not allowed; allowed: {allowed(j)}")
        start[j] = math.radians(deg)
    drive = qpos_to_drive(start)
    for i, t in enumerate(s.targets):
        if t.brush_at_disc:
            try:
                drive.update(disc_drive_angles(m, t.brush_at_disc, t.standoff_m))
            except ValueError:
                raise ScenarioError(
                    f"{s.path}: targets[{i}] brush_at_disc = {t.brush_at_disc}, standoff_m = {t.standoff_m!r} is out of the brush's reach; "
                    f"allowed: a standoff_m at which the arm reaches disc {t.brush_at_disc} inside its joint ranges ({_reachable_standoffs(m, t.brush_at_disc)})"
                ) from None
        drive.update({j: math.radians(v) for j, v in t.angles_deg.items()})
        for j, q in drive_to_qpos(drive).items():
            if j in ranges and not math.radians(ranges[j][0]) - 1e-9 <= q <= math.radians(ranges[j][1]) + 1e-9:
                if j in t.angles_deg and j != "elbow_pitch":
                    raise ScenarioError(
                        f"{s.path}: targets[{i}].angles_deg.{j} = {t.angles_deg[j]!r} is not allowed; allowed: {allowed(j)}"
                    )
                raise ScenarioError(
                    f"{s.path}: targets[{i}] puts joint {j} at {math.degrees(q):.1f} deg (drive angles {', '.join(f'{k} {math.degrees(v):.1f}' for k, v in drive.items())} deg; "
                    f"the elbow's drive angle is the forearm's pitch, shoulder + elbow joint); allowed: {allowed(j)}"
                )


def shipped_names() -> list[str]:
    return sorted(p.stem for p in SHIPPED_DIR.glob("*.toml"))


def find(name_or_path: str | Path) -> Path:
    """A scenario file: the path as given, else the shipped scenario of that name
    (`insulator_cleaning` or `insulator_cleaning.toml`), wherever the package is installed."""
    path = Path(name_or_path)
    if path.exists() or len(path.parts) != 1 or path.suffix not in ("", ".toml"):
        return path
    shipped = SHIPPED_DIR / f"{path.stem}.toml"
    if shipped.is_file():
        return shipped
    raise ScenarioError(
        f"{path}: no such scenario file; allowed: a path to a scenario file or a shipped scenario's name ({', '.join(shipped_names())})"
    )


def load(path: str | Path) -> Scenario:
    """Read and check a scenario file (a path, or the name of a shipped scenario)."""
    path = find(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such scenario file") from None
    except (UnicodeDecodeError, IsADirectoryError) as e:
        raise ScenarioError(f"{path}: cannot be read as a text file ({e})") from None
    return parse(text, str(path))


def joint_params_for(base: dict[str, JointParams], model: Model) -> dict[str, JointParams]:
    """The joints' parameters with this model's configuration applied (hose loss, effects)."""
    out = {}
    for joint, params in base.items():
        params = params._replace(hose_loss=1.0 if model.hose_loss else 0.0)
        params = params._replace(**model.effects.get(joint, {}))
        out[joint] = params
    return out
