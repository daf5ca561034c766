"""What the whole arm's gap diagnosis can add to the twin: the one-joint catalogue on each joint,
and the effects that belong to the arm, not to one joint.

The arm-level effects are fields of `ArmSetup`, applied to the MuJoCo model the replay steps (or,
for the shared supply line, to the supply every joint's valve sees): configuration of the one
plant, never a second model (as gap/effects.py does for a joint).

    payload_kg               the payload's mass (its inertia scaled with it)
    payload_com_m            its centre of mass moved along the tool's axis (body x), m
    upper_arm_mass_scale     the upper arm's mass and inertia x scale (with the parallelogram rod
    forearm_mass_scale       lumped into it, assets/arm.xml), the forearm's likewise
    tilt_x_deg, tilt_y_deg   the arm's mounting tilted about the world x / y axis (the platform on
                             a slope): gravity turned the other way in the arm's frame
    supply_line_droop_pa_s_per_kg  a supply line shared by every joint's valves: the supply they
                             see is the measured one minus k x the air all of them draw
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

import assets
from gap.effects import BY_NAME, INERTIA, LOAD_SPRING, LOAD_TORQUE, Effect
from gap.kinds import Family
from pneumatics import JointParams, load_joint_params
from pneumatics.motor import displacement_per_rad

PAYLOAD_BODY = "payload"  # assets/arm.xml
# the payload's mass and inertia in assets/arm.xml (20 kg, the paper's maximum; diaginertia 0.0626)
MJCF_PAYLOAD_KG = 20.0
LINK_BODIES = {"upper_arm_mass_scale": "upper_arm", "forearm_mass_scale": "forearm"}
GRAVITY_M_S2 = 9.81  # MuJoCo's default |g| (assets/arm.xml sets none)


class ArmSetup(NamedTuple):
    """The arm as one replay (or the plant of a rehearsal) has it beyond its joints' parameters."""

    payload_kg: float = MJCF_PAYLOAD_KG
    payload_com_m: float = 0.0
    upper_arm_mass_scale: float = 1.0
    forearm_mass_scale: float = 1.0
    tilt_x_deg: float = 0.0
    tilt_y_deg: float = 0.0
    supply_line_droop_pa_s_per_kg: float = 0.0
    # a spring about the MuJoCo joint's zero on each joint (gap.effects' angle_load), N·m/rad
    joint_springs_nm_per_rad: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ArmEffect:
    """An effect of the whole arm: a field of ArmSetup, its search bounds (absolute values, or
    offsets from the twin's when `relative`), its family (the part a user would inspect)."""

    name: str
    label: str
    field: str
    low: float
    high: float
    family: Family
    equation: str


# Bounds: the payload 0-40 kg (the paper's 20 kg class, twice over); its centre up to 0.15 m either
# way along the tool (a box of 0.137 m, assets/arm.xml, held off-centre); a link 0.5-2 x its mass
# (the rods lumped in, a counterweight); a slope up to 10 deg (a truck-mounted platform on a verge,
# assumed); a shared line losing up to 2e7 Pa·s/kg (a 1 MPa drop at 0.05 kg/s, all five valves open)
ARM_CATALOGUE: tuple[ArmEffect, ...] = (
    ArmEffect("payload_mass", "payload mass", "payload_kg", 0.0, 40.0, Family.PAYLOAD, "payload mass (kg)"),
    ArmEffect(
        "payload_com",
        "payload centre of mass",
        "payload_com_m",
        -0.15,
        0.15,
        Family.PAYLOAD,
        "offset along the tool (m)",
    ),
    ArmEffect(
        "upper_arm_mass", "upper arm mass", "upper_arm_mass_scale", 0.5, 2.0, Family.LINKS, "upper arm mass x scale"
    ),
    ArmEffect("forearm_mass", "forearm mass", "forearm_mass_scale", 0.5, 2.0, Family.LINKS, "forearm mass x scale"),
    ArmEffect("mounting_tilt_x", "mounting tilt about x", "tilt_x_deg", -10.0, 10.0, Family.MOUNTING, "tilt (deg)"),
    ArmEffect("mounting_tilt_y", "mounting tilt about y", "tilt_y_deg", -10.0, 10.0, Family.MOUNTING, "tilt (deg)"),
    ArmEffect(
        "shared_supply_droop",
        "shared supply line droop",
        "supply_line_droop_pa_s_per_kg",
        0.0,
        2.0e7,
        Family.SUPPLY,
        "p_s' = p_s - k * sum of every joint's inlet flow (Pa·s/kg)",
    ),
)
ARM_BY_NAME = {e.name: e for e in ARM_CATALOGUE}

# The one-joint catalogue's effects a joint of the arm can take. Left out: the hose loss (a switch
# the twin already has on), the rig's inertia scale and static torque (the arm's inertia and loads
# come from its bodies: the link and payload effects above), and the reducer's backlash and
# compliance (a non-rigid gear's mode on the arm's lighter joints is too fast for the plant's
# 0.5 ms step: twin.plant refuses most of their range there).
ARM_JOINT_EXCLUDED = ("hose_loss", "inertia_error", "reducer_backlash", "reducer_compliance")
JOINT_CATALOGUE: tuple[Effect, ...] = tuple(e for n, e in BY_NAME.items() if n not in ARM_JOINT_EXCLUDED)
JOINT_BY_NAME = {e.name: e for e in JOINT_CATALOGUE}

# The one-joint catalogue's bounds are set for the wrist (gap/effects.py). On another joint of the arm
# a torque's bounds are the same share of what that joint's motor can give: the wrist's scaled by the
# joint's stall torque over the wrist's (the shoulder's own Coulomb friction, 60 N·m, was the wrist's
# upper bound; its brake's 1600 N·m five times the wrist's 300). A brake's release pressure keeps the
# wrist's offsets from the joint's own nominal (the others' 3.0 bar lay under the wrist's 3.25 bar).
BOUNDS_JOINT = "wrist_pitch"
TORQUE_FIELDS = frozenset({"coulomb_nm", "stribeck_excess_nm", "viscous_nm_s", LOAD_SPRING, "brake_holding_nm"})
OFFSET_FIELDS = frozenset({"brake_release_gauge_pa"})


def stall_torque_nm(p: JointParams, supply_mpa: float) -> float:
    """The joint's stall torque at a supply: the supply's gauge pressure on the vane motor's
    displacement, through the reducer's ratio and forward efficiency (the sizing rule of
    assets/joints/*.toml, e.g. the elbow's 0.5 MPa x 3.1e-6 x 200 x 0.7 = 217 N·m)."""
    d = displacement_per_rad(p.stator_radius_m, p.rotor_radius_m, p.vane_length_m, p.n_vanes)
    return supply_mpa * 1e6 * d * p.ratio * p.efficiency_forward


@functools.cache
def _nominal(joint: str) -> JointParams:
    return load_joint_params(assets.joint_param_path(joint))


def joint_bounds(effect: Effect, joint: str) -> tuple[float, float]:
    """The search bounds of a one-joint catalogue effect on `joint` of the arm (see above)."""
    if joint == BOUNDS_JOINT:
        return effect.low, effect.high
    if effect.field in TORQUE_FIELDS:
        scale = stall_torque_nm(_nominal(joint), 1.0) / stall_torque_nm(_nominal(BOUNDS_JOINT), 1.0)
        return effect.low * scale, effect.high * scale
    if effect.field in OFFSET_FIELDS:
        shift = getattr(_nominal(joint), effect.field) - getattr(_nominal(BOUNDS_JOINT), effect.field)
        return effect.low + shift, effect.high + shift
    return effect.low, effect.high


@dataclass(frozen=True)
class ArmCandidate:
    """One effect placed in the arm: a joint's catalogue effect (`joint` set) or an arm's."""

    effect: str
    joint: str = ""  # "" for an arm-level effect

    @property
    def name(self) -> str:
        return f"{self.joint}:{self.effect}" if self.joint else f"arm:{self.effect}"

    @property
    def family(self) -> Family:
        return JOINT_BY_NAME[self.effect].family if self.joint else ARM_BY_NAME[self.effect].family

    @property
    def bounds(self) -> tuple[float, float]:
        if self.joint:
            return joint_bounds(JOINT_BY_NAME[self.effect], self.joint)
        e = ARM_BY_NAME[self.effect]
        return e.low, e.high

    @property
    def log(self) -> bool:
        return bool(self.joint) and JOINT_BY_NAME[self.effect].log

    def label(self) -> str:
        e = JOINT_BY_NAME[self.effect] if self.joint else ARM_BY_NAME[self.effect]
        return f"{e.label} ({self.joint})" if self.joint else f"{e.label} (arm)"

    def value_in(self, params: dict[str, JointParams], setup: ArmSetup, joints: tuple[str, ...]) -> float:
        """The effect's value in the twin (params, setup)."""
        if not self.joint:
            return float(getattr(setup, ARM_BY_NAME[self.effect].field))
        field = JOINT_BY_NAME[self.effect].field
        if field == LOAD_SPRING:
            return setup.joint_springs_nm_per_rad[joints.index(self.joint)]
        return float(getattr(params[self.joint], field))

    def apply(
        self, params: dict[str, JointParams], setup: ArmSetup, joints: tuple[str, ...], value: float
    ) -> tuple[dict[str, JointParams], ArmSetup]:
        """(params, setup) with this effect at `value`."""
        if not self.joint:
            return params, setup._replace(**{ARM_BY_NAME[self.effect].field: float(value)})
        field = JOINT_BY_NAME[self.effect].field
        if field == LOAD_SPRING:
            springs = list(setup.joint_springs_nm_per_rad)
            springs[joints.index(self.joint)] = float(value)
            return params, setup._replace(joint_springs_nm_per_rad=tuple(springs))
        if field in (INERTIA, LOAD_TORQUE):
            raise ValueError(f"{self.effect} is not an effect of the arm's joints")
        return {**params, self.joint: params[self.joint]._replace(**{field: float(value)})}, setup


def candidates(joints: tuple[str, ...]) -> list[ArmCandidate]:
    """Every joint effect on every joint, then the arm's."""
    on_joints = [ArmCandidate(e.name, j) for j in joints for e in JOINT_CATALOGUE]
    return on_joints + [ArmCandidate(e.name) for e in ARM_CATALOGUE]


def candidate_named(name: str) -> ArmCandidate:
    """'joint:effect' or 'arm:effect' as an ArmCandidate (ValueError: not one)."""
    where, _, effect = name.partition(":")
    if where == "arm" and effect in ARM_BY_NAME:
        return ArmCandidate(effect)
    if effect in JOINT_BY_NAME:
        return ArmCandidate(effect, where)
    raise ValueError(name)


@dataclass(frozen=True)
class ModelDefaults:
    """The MJCF's own values the setup scales (read once from the model before any change)."""

    payload_mass: float
    payload_inertia: np.ndarray
    payload_ipos: np.ndarray
    link_mass: dict[str, float]
    link_inertia: dict[str, np.ndarray]


def model_defaults(model: mujoco.MjModel) -> ModelDefaults:
    b = model.body(PAYLOAD_BODY)
    return ModelDefaults(
        float(b.mass[0]),
        b.inertia.copy(),
        b.ipos.copy(),
        {n: float(model.body(n).mass[0]) for n in LINK_BODIES.values()},
        {n: model.body(n).inertia.copy() for n in LINK_BODIES.values()},
    )


def apply_setup(model: mujoco.MjModel, setup: ArmSetup, defaults: ModelDefaults, joints: tuple[str, ...]) -> None:
    """Write `setup` into `model` (masses, inertias, the payload's centre, gravity, joint springs);
    `defaults` are the MJCF's values it scales. Call mj_setConst/forward after (the caller's data)."""
    b = model.body(PAYLOAD_BODY)
    mass = max(setup.payload_kg, 1e-6)  # MuJoCo wants a positive mass (scenarios.runner does the same)
    b.mass[0] = mass
    b.inertia[:] = defaults.payload_inertia * mass / defaults.payload_mass
    b.ipos[:] = defaults.payload_ipos + np.array([setup.payload_com_m, 0.0, 0.0])
    if setup.payload_com_m != 0.0:  # the compiler marked the centre as the body's origin: no longer
        model.body_sameframe[b.id] = 0
    for fld, body in LINK_BODIES.items():
        s = getattr(setup, fld)
        model.body(body).mass[0] = defaults.link_mass[body] * s
        model.body(body).inertia[:] = defaults.link_inertia[body] * s
    ax, ay = math.radians(setup.tilt_x_deg), math.radians(setup.tilt_y_deg)
    # the base tilted by ax about x then ay about y: gravity in the base's (world) frame turns back
    g = np.array([0.0, 0.0, -GRAVITY_M_S2])
    rx = np.array([[1, 0, 0], [0, math.cos(ax), math.sin(ax)], [0, -math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0, -math.sin(ay)], [0, 1, 0], [math.sin(ay), 0, math.cos(ay)]])
    model.opt.gravity[:] = ry @ rx @ g
    for j, k in zip(joints, setup.joint_springs_nm_per_rad, strict=False):
        model.jnt_stiffness[model.joint(j).id] = k
