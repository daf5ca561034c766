"""The catalogue of candidate effects: each is a JointParams field (or a property of the rig the
joint drives: its inertia, a static load that depends on the angle) with bounds. Adding an effect
to the twin is `params._replace(field=value)`: configuration of the one model in pneumatics/,
never a second model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from gap.kinds import Family
from pneumatics import JointParams

INERTIA = "inertia_scale"  # not a JointParams field: scales the joint-side inertia given to the replay
LOAD_SPRING = "load_spring_nm_per_rad"  # not a JointParams field: a static load -k (theta - 0) on the joint
LOAD_TORQUE = "load_torque_nm"  # not a JointParams field: a static load -tau0 on the joint, the same at every angle


class Rig(NamedTuple):
    """What the replay is told of the rig besides the joint: its inertia scale and static load, the
    torque -(load_torque_nm + load_spring_nm_per_rad * theta) on the joint."""

    inertia_scale: float = 1.0
    load_spring_nm_per_rad: float = 0.0
    load_torque_nm: float = 0.0


NOMINAL_RIG = Rig()  # the rig as the twin has it (an immutable tuple: safe as a default)


@dataclass(frozen=True)
class Effect:
    name: str
    label: str
    field: str  # JointParams field, or INERTIA
    low: float
    high: float
    log: bool = False  # search grid spaced logarithmically (value 0 allowed as the low end)
    discrete_value: float | None = None  # a switch: added with this value, nothing to fit
    family: Family | None = None  # the part of the joint it is in (below)
    equation: str = ""

    def value_of(self, params: JointParams) -> float:
        return getattr(NOMINAL_RIG, self.field) if self.field in Rig._fields else float(getattr(params, self.field))

    def apply(self, params: JointParams, value: float, rig: Rig = NOMINAL_RIG) -> tuple[JointParams, Rig]:
        """(params, rig) with the effect at `value`."""
        if self.field in Rig._fields:
            return params, rig._replace(**{self.field: float(value)})
        return params._replace(**{self.field: float(value)}), rig


# Families are the parts of the joint a user would inspect: the family call (gap.family) names one
# where no catalogue form fits, so it must point at a part, not at a kind of signature. The valves
# are one part, "valve": the direction valve (its solenoid's dead time) and the proportional valve
# (its set point's dead time, its lag, its dead zone) sit together on the operator's platform, and
# the conductance error scales both valves' areas, so the catalogue's laws do not split along them.
# The valves' timing is not a family of its own: a proportional valve opening 0.7 times as far per
# bar is explained by its lag (0.115 s against 0.1 s) as well, and the part is then right though the
# effect differs. Whether timing or opening is off is the effect's name.
#
# Bounds: physically plausible ranges for the wrist class (assets/joints/wrist_pitch.toml values
# are the nominal: coulomb 15 N·m, viscous 3 N·m·s/rad, solenoid 15 ms, valve tau 0.1 s). The leak
# area's grid is logarithmic: a worn vane's gap area spans orders of magnitude.
CATALOGUE: tuple[Effect, ...] = (
    Effect(
        "hose_loss",
        "hose pressure loss",
        "hose_loss",
        0.0,
        1.0,
        discrete_value=1.0,
        family=Family.HOSE,
        equation="Darcy-Weisbach hose resistance on both ports (paper eq. 1-5)",
    ),
    Effect(
        "vane_leakage",
        "vane leakage",
        "leak_area_m2",
        0.0,
        2.0e-6,
        log=True,
        family=Family.LEAKAGE,
        equation="orifice A->B past the vanes, area fitted (m^2)",
    ),
    # a leak to atmosphere in port A's hose (a cut hose, a loose fitting: the scenarios' hose_leak
    # fault), venting at the hose's valve end (pneumatics/joint.py): air lost on one side only,
    # unlike the vane leakage. Up to 2e-6 m^2 (a 1.6 mm hole); the model has port A's hose, so a
    # leak in port B's shows as its mirror image (the moves' directions swapped)
    Effect(
        "hose_leak",
        "hose leak (port A, to atmosphere)",
        "hose_leak_area_m2",
        0.0,
        2.0e-6,
        log=True,
        family=Family.LEAKAGE,
        equation="orifice from port A's hose to atmosphere at its valve end, area fitted (m^2)",
    ),
    Effect(
        "coulomb_friction",
        "Coulomb friction",
        "coulomb_nm",
        0.0,
        60.0,
        family=Family.FRICTION,
        equation="Coulomb level C_s (N·m), Karnopp stick rule",
    ),
    Effect(
        "stribeck_friction",
        "Stribeck friction",
        "stribeck_excess_nm",
        0.0,
        60.0,
        family=Family.FRICTION,
        equation="static-minus-Coulomb excess (N·m), exp(-(w/ws)^2)",
    ),
    Effect(
        "viscous_friction",
        "viscous friction",
        "viscous_nm_s",
        0.0,
        20.0,
        family=Family.FRICTION,
        equation="C_f (N·m·s/rad)",
    ),
    Effect(
        "valve_dead_time",
        "direction valve dead time (solenoid delay)",
        "solenoid_delay_s",
        0.0,
        0.3,
        family=Family.VALVE,
        equation="direction valve switches after a delay (s)",
    ),
    Effect(
        "valve_set_dead_time",
        "proportional valve dead time",
        "valve_set_dead_time_s",
        0.0,
        0.3,
        family=Family.VALVE,
        equation="the proportional valve's set point takes effect after a delay (s)",
    ),
    Effect(
        "valve_lag",
        "valve lag (valve time constant)",
        "valve_time_constant_s",
        0.005,
        0.6,
        log=True,
        family=Family.VALVE,
        equation="proportional valve first-order lag tau (s)",
    ),
    Effect(
        "valve_dead_zone",
        "valve dead zone",
        "valve_dead_zone",
        0.0,
        0.6,
        family=Family.VALVE,
        equation="u' = (u - dz)/(1 - dz)",
    ),
    Effect(
        "conductance_error",
        "valve conductance error",
        "conductance_scale",
        0.3,
        2.5,
        log=True,
        family=Family.VALVE,
        equation="valve areas x scale",
    ),
    Effect(
        "heat_exchange",
        "heat exchange (polytropic exponent)",
        "polytropic_n",
        1.0,
        1.4,
        family=Family.THERMAL,
        equation="chamber law with n in 1..1.4",
    ),
    Effect(
        "supply_droop",
        "supply droop under flow",
        "supply_droop_pa_s_per_kg",
        0.0,
        5.0e7,
        family=Family.SUPPLY,
        equation="p_s' = p_s - k * choked inlet flow (Pa·s/kg)",
    ),
    Effect(
        "inertia_error",
        "payload/inertia error",
        INERTIA,
        0.3,
        3.0,
        log=True,
        family=Family.LOAD,
        equation="joint-side inertia x scale",
    ),
    # a static load that depends on the angle (a cable or hose bundle, a counterbalance spring set
    # wrong): up to 60 N·m/rad, 63 N·m at 60 deg, near the wrist's stall torque at 0.8 MPa (69 N·m)
    Effect(
        "angle_load",
        "angle-dependent static load",
        LOAD_SPRING,
        0.0,
        60.0,
        family=Family.LOAD,
        equation="load torque -k theta (N·m/rad), theta from the joint's zero",
    ),
    # the brake (pneumatics/brake.py): its full-release pressure above nominal (4.0 bar; a weak
    # piston seal or stiffer springs) leaves the lining dragging wherever the motor port's air is
    # under it (low supply, partial openings); up to 9 bar, above every supply: never fully clear
    Effect(
        "brake_incomplete_release",
        "brake incomplete release (full-release pressure)",
        "brake_release_gauge_pa",
        3.25e5,
        9.0e5,
        family=Family.BRAKE,
        equation="engagement (p_full - p_feed)/(p_full - p_start) while released (Pa)",
    ),
    # the brake's piston fills slowly (a restricted or long brake line, a sticking piston): the lining
    # lets go late at every start. Its release time constant, nominal 50 ms, up to 1 s (log)
    Effect(
        "brake_slow_release",
        "brake slow release (release time constant)",
        "brake_release_time_constant_s",
        0.0,
        1.0,
        log=True,
        family=Family.BRAKE,
        equation="engagement lags its target with time constant tau while releasing (s)",
    ),
    # the brake's springs engage slowly (a restricted brake exhaust, a sticking piston): the lining
    # bites late at every stop, so the joint slides on. Its engagement time constant, nominal 20 ms,
    # up to 1 s (log)
    Effect(
        "brake_slow_engage",
        "brake slow engagement (engagement time constant)",
        "brake_engage_time_constant_s",
        0.0,
        1.0,
        log=True,
        family=Family.BRAKE,
        equation="engagement lags its target with time constant tau while engaging (s)",
    ),
    # a worn lining holds and stops with less torque (nominal 100 N·m): a longer slide at every stop
    Effect(
        "brake_holding",
        "brake holding torque",
        "brake_holding_nm",
        20.0,
        300.0,
        family=Family.BRAKE,
        equation="holding and slipping torque of the engaged brake (N·m)",
    ),
    # the reducer (pneumatics/reducer.py): lost motion up to 0.05 rad (3 deg, a badly worn gear;
    # a strain-wave gear has ~3e-4 rad) and compliance up to 2e-3 rad/N·m (7x softer than the
    # size-17 gear's 1/K1 ~ 3e-4); both grids logarithmic, they span orders of magnitude
    Effect(
        "reducer_backlash",
        "reducer backlash",
        "reducer_backlash_rad",
        0.0,
        0.05,
        log=True,
        family=Family.REDUCER,
        equation="dead zone of width b between motor and joint side (rad)",
    ),
    Effect(
        "reducer_compliance",
        "reducer compliance",
        "reducer_compliance_rad_per_nm",
        0.0,
        2.0e-3,
        log=True,
        family=Family.REDUCER,
        equation="torsional spring 1/k between motor and joint side (rad/N·m)",
    ),
)
# Parts the nominal twin already has, varied for the family call only (gap.members.
# in_twin_members), never candidates: the catalogue's switch for such a part (the hose loss,
# on in the twin) gives its family only the correction of switching it off and its opposite, so a
# hose that loses several times what the twin's does would be called leakage (a 3 mm bore for
# 4 mm, on the bench). Keyed by the switch: while it is on, its family also gets the twin with the
# part at these factors of the twin's value. The hose's bore: its loss at a given flow goes as
# d^-4.75 on the Blasius branch (d^-4 laminar; pneumatics/darcy.py, paper eq. 1-4), so 0.7-1.15
# spans about 5.4 to 0.5 times the twin's loss, with 0.5-1.3 times its volume; its length: loss
# and volume both as L, 0.5-3 times (a 13 m hose declared as 8 m was called valve without them).
# Not candidates: a continuous hose member (its resistance, or its length) stands in for a valve
# lag, a lossy gear and a slow brake release.
HOSE_BORE = Effect(
    "hose_bore",
    "hose bore",
    "hose_diameter_m",
    1.0e-3,
    0.05,
    family=Family.HOSE,
    equation="both hoses' inner diameter (m): their loss and their volume",
)
HOSE_LENGTH = Effect(
    "hose_length",
    "hose length",
    "hose_length_m",
    2.0,
    100.0,
    family=Family.HOSE,
    equation="both hoses' length (m): their loss and their volume",
)
IN_TWIN_VARIATIONS: dict[str, tuple[tuple[Effect, tuple[float, ...]], ...]] = {
    "hose_loss": ((HOSE_BORE, (0.7, 0.8, 0.9, 1.15)), (HOSE_LENGTH, (0.5, 1.5, 2.0, 3.0)))
}
# A part of a family varied for the family call only, at these values (not factors: the twin has
# none of it), never a candidate. The static load the same at every angle (a hose or cable bundle's
# pull, a counterbalance set off by a constant): with angle_load it makes the first two terms of any
# static load about the joint's zero, so a spring resting elsewhere is close to a sum of the two. A
# spring of 10 N·m/rad resting at 1 rad (or a 12 N·m load) was called load on 2 of 9 campaigns
# without it, 6 with it (brake and valve otherwise). Not a candidate: on one-way moves (the paper's
# 60 deg) a constant load against the motion is Coulomb friction, and with it a candidate a Coulomb
# friction there was called ambiguous with the load on top (top-1 19/24 on those moves).
# Signed as angle_load's spring at positive angles: positive pulls toward negative angles; up to 40
# N·m either way, 58 % of the wrist's stall torque at 0.8 MPa (69 N·m)
STATIC_LOAD = Effect(
    "static_load",
    "angle-independent static load",
    LOAD_TORQUE,
    -40.0,
    40.0,
    family=Family.LOAD,
    equation="load torque -tau0 (N·m), the same at every angle",
)
FAMILY_VARIATIONS: dict[Family, tuple[tuple[Effect, tuple[float, ...]], ...]] = {
    Family.LOAD: ((STATIC_LOAD, (-40.0, -20.0, -10.0, -5.0, 5.0, 10.0, 20.0, 40.0)),)
}

NOT_IN_CATALOGUE = (
    "torque ripple with motor angle (ripple_fraction exists in pneumatics/ and the bench hides it, "
    "but it is deliberately left out of the catalogue as the bench's outside-catalogue effect)",
)
BY_NAME = {e.name: e for e in CATALOGUE}
