"""Parameters of one pneumatic joint: a frozen record, its allowed ranges, and the TOML reader.

A joint's parameter file (assets/joints/<joint>.toml) has one table per part: [motor],
[reducer], [hose], [valves], [brake], [friction] and [effects] (the optional effects of the gap
catalogue, all off by default). Every field must be present in the file (except [effects]
fields, which default to JointParams' "off" values), be a number, and lie within its range in
SPEC; a table may also name its part (`model`, `note`: text). Anything else is refused with the
file, the field, the value and what is allowed. The file's schema (`ParameterFile`) is built from
SPEC and JointParams, so each range and each default is written once. Each number in the files
says where it comes from.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from pydantic import BaseModel, Field, ValidationError, create_model
from pydantic_core import PydanticCustomError

from pneumatics.gas import AIR, Gas
from pneumatics.heat import vane_cell
from pneumatics.hose import hose_constants, hose_mass_flow_with, hose_volume
from pneumatics.line import LINE_ROW_FIELDS, N_LINE_ROW, PLANT_BAND_HZ, line_row, segments_for, wave_speed
from pneumatics.motor import half_pitch_volume
from pneumatics.orifice import choked_flux
from pneumatics.valves import lag_factors
from twin_plumbing.errors import ParameterError
from twin_plumbing.fields import (
    MISSING,
    TABLE,
    TEXT,
    Problem,
    first_problem,
    number,
    number_check,
    read_toml,
)


class JointParams(NamedTuple):
    """Everything the pneumatic model of one joint needs, in SI units (frozen)."""

    # [motor] vane air motor
    stator_radius_m: float
    rotor_radius_m: float
    vane_length_m: float
    n_vanes: float
    dead_volume_m3: float  # porting volume of each motor port
    rotor_inertia_kg_m2: float  # rotor + wave generator, motor side
    # the law of the air in every node (motor chambers and hose ends): 1, the energy balance, each
    # node's gas temperature a state, heat to its wall (pneumatics/chamber.py, heat.py); 0, the
    # paper's polytropic law with polytropic_n, every flow at the supply temperature (eq. 7)
    chamber_heat: float
    # [reducer]
    ratio: float  # motor angle / joint angle
    efficiency_forward: float
    efficiency_backward: float
    # [hose] one hose per motor port, platform to arm
    hose_length_m: float
    hose_diameter_m: float
    hose_loss: float  # 1: the hose's resistance is modelled (paper eq. 1-5); 0: not (volume only)
    # which law the resistance follows (with hose_loss = 1): 0, the physical hose, Darcy-Weisbach on the
    # flow each port's hose carries (a pi-section, pneumatics/darcy.py); 1, the paper's eq. 1-5 as
    # written, an algebraic drop on the supplied port at the fixed flow hose_standard_flow_m3_s
    # (pneumatics/paper_hose.py), each port's hose volume lumped with its chamber. `paper_model` sets 1
    hose_law: float
    hose_standard_flow_m3_s: float  # V of the paper's eq. 1 (m^3/s at 0 degC, 101.325 kPa); read with hose_law = 1
    # [valves]
    inlet_area_m2: float  # effective area of the supply path at full opening
    exhaust_area_m2: float  # effective area of the exhaust path (with its speed throttle)
    k_u_per_pa: float  # opening per gauge Pa of proportional-valve pressure (paper k_u)
    valve_time_constant_s: float  # proportional valve response (paper: 0.1 s)
    solenoid_delay_s: float  # direction valve switching delay
    # [brake]
    brake_holding_nm: float
    brake_release_gauge_pa: float  # full release: the lining is clear from this feed pressure on
    brake_release_start_gauge_pa: float  # the lining begins to lift (the springs' preload)
    brake_fed_by_motor: (
        float  # 1: air from the motor's pressurised port at the arm; 0: the supply (pneumatics/brake.py)
    )
    brake_engage_time_constant_s: float
    brake_release_time_constant_s: float
    # [friction] joint side
    coulomb_nm: float
    viscous_nm_s: float
    stick_speed_rad_s: float  # predictor's Karnopp window
    # [effects] the gap catalogue's optional effects; defaults are "off"
    leak_area_m2: float = 0.0  # vane leakage between the chambers
    stribeck_excess_nm: float = 0.0  # static minus Coulomb friction
    stribeck_speed_rad_s: float = 0.05
    valve_dead_zone: float = 0.0  # fraction of the valve stroke before the port opens
    conductance_scale: float = 1.0  # real valve conductance / nominal
    polytropic_n: float = 1.4  # the paper's law (chamber_heat = 0): 1.4 adiabatic (paper); lower: heat exchange
    ripple_fraction: float = 0.0  # torque ripple amplitude with motor angle, fraction of torque
    supply_droop_pa_s_per_kg: float = 0.0  # supply pressure lost per kg/s drawn
    hose_leak_area_m2: float = 0.0  # a leak to atmosphere in port A's hose (a fault)
    valve_set_dead_time_s: float = 0.0  # the proportional valve's set point takes effect this late
    # the energy balance's (chamber_heat = 1) walls exchange this multiple of their correlations' heat
    # (the vane cell's and the hose's film coefficients, pneumatics/heat.py): 0 adiabatic
    wall_heat_scale: float = 1.0
    # the reducer's transmission (pneumatics/reducer.py). The nominal twin keeps the paper's rigid
    # reducer (eq. 6: M_o = i M_i, both 0). A size-17 strain-wave gear (the wrist's LHS-17-120)
    # is far from rigid, though: Harmonic Drive's CSF-17 catalogue gives a torsional stiffness
    # K1 ~ 3.4e3 N·m/rad at low torque rising to K3 ~ 5.7e3 N·m/rad (compliance ~ 2e-4 rad/N·m),
    # and near-zero backlash (strain-wave gears are sold as backlash-free; what is left is of the
    # order of an arc-minute of lost motion, ~3e-4 rad).
    reducer_backlash_rad: float = 0.0  # total lost motion between the flanks, joint side
    reducer_compliance_rad_per_nm: float = 0.0  # joint-side torsional compliance 1/k; 0: rigid
    # [hose] what each hose (supply and exhaust side of both ports) is: 0, the lumped pi-section (half
    # its volume at each end, Darcy-Weisbach between); 1, a line with gas inertia and wall friction
    # that carries pressure waves (pneumatics/line.py; docs/air_lines.md, "In the plant"), with the
    # hose's resistance (hose_loss = 1) on the physical law (hose_law = 0); else the port is one node
    # as with the pi-section. The plant and the gap replay only: the predictor keeps the paper's
    # model (`paper_model` sets 0). Last with a default, so a file written before it reads as 0
    hose_model: float = 0.0


@dataclass(frozen=True)
class FieldSpec:
    section: str
    low: float
    high: float
    unit: str
    whole: bool = False  # a count (4 or 4.0, not 2.5)


# allowed ranges: physically possible values with room for every real motor of this class
SPEC: dict[str, FieldSpec] = {
    "stator_radius_m": FieldSpec("motor", 1e-3, 0.2, "m"),
    "rotor_radius_m": FieldSpec("motor", 1e-3, 0.2, "m"),
    "vane_length_m": FieldSpec("motor", 1e-3, 0.5, "m"),
    "n_vanes": FieldSpec("motor", 2, 12, "vanes", whole=True),
    "dead_volume_m3": FieldSpec("motor", 1e-8, 1e-2, "m^3"),
    "rotor_inertia_kg_m2": FieldSpec("motor", 0.0, 1.0, "kg·m^2"),
    "chamber_heat": FieldSpec("motor", 0.0, 1.0, "0 or 1"),
    "ratio": FieldSpec("reducer", 1.0, 10_000.0, "-"),
    "efficiency_forward": FieldSpec("reducer", 0.05, 1.0, "-"),
    "efficiency_backward": FieldSpec("reducer", 0.05, 1.0, "-"),
    # from 0.3 m (a valve mounted at the motor): a short hose's air moves faster than the plant's and
    # the predictor's steps, and the kernels then sub-step it by ROS2 (`air_step_s`, `hose_time_s`
    # below; docs/air_lines.md, "Short hoses"). Below 0.3 m the pi-section stops being a hose: its
    # L/c (0.9 ms) is under the control period. The arm's hoses are 8 m.
    "hose_length_m": FieldSpec("hose", 0.3, 100.0, "m"),
    "hose_diameter_m": FieldSpec("hose", 1e-3, 0.05, "m"),
    "hose_loss": FieldSpec("hose", 0.0, 1.0, "0 or 1"),
    "hose_law": FieldSpec("hose", 0.0, 1.0, "0 or 1"),
    # to 0.1 m^3/s (360 m^3/h): beyond the largest vane motors' consumption
    "hose_standard_flow_m3_s": FieldSpec("hose", 0.0, 0.1, "m^3/s"),
    "inlet_area_m2": FieldSpec("valves", 1e-8, 1e-3, "m^2"),
    "exhaust_area_m2": FieldSpec("valves", 1e-8, 1e-3, "m^2"),
    "k_u_per_pa": FieldSpec("valves", 1e-8, 1e-4, "1/Pa"),
    "valve_time_constant_s": FieldSpec("valves", 0.0, 5.0, "s"),
    "solenoid_delay_s": FieldSpec("valves", 0.0, 1.0, "s"),
    "brake_holding_nm": FieldSpec("brake", 0.0, 1e5, "N·m"),
    "brake_release_gauge_pa": FieldSpec("brake", 0.0, 1.0e6, "Pa"),
    "brake_release_start_gauge_pa": FieldSpec("brake", 0.0, 1.0e6, "Pa"),
    "brake_fed_by_motor": FieldSpec("brake", 0.0, 1.0, "0 or 1"),
    "brake_engage_time_constant_s": FieldSpec("brake", 0.0, 1.0, "s"),
    "brake_release_time_constant_s": FieldSpec("brake", 0.0, 1.0, "s"),
    "coulomb_nm": FieldSpec("friction", 0.0, 1e4, "N·m"),
    "viscous_nm_s": FieldSpec("friction", 0.0, 1e4, "N·m·s/rad"),
    "stick_speed_rad_s": FieldSpec("friction", 1e-6, 1.0, "rad/s"),
    # to 1e-5 m^2 (twice the valve's inlet: a motor leaking more does not turn): above it the air
    # leaking A -> B evens the two chambers out faster than the predictor's 1 ms RK4 follows.
    # Measured on the wrist stalled at its stop at 0.8 MPa, 1 s: at 3e-5 its B chamber 20 kPa off the
    # plant at 1/8 of its step. The plant (ROS2, the leak in its W) settles within 0.07 kPa of where
    # the flows balance up to 1e-4 (tests/test_plant.py); an explicit Heun step was 160 kPa off at 1e-4
    "leak_area_m2": FieldSpec("effects", 0.0, 1e-5, "m^2"),
    "stribeck_excess_nm": FieldSpec("effects", 0.0, 1e4, "N·m"),
    "stribeck_speed_rad_s": FieldSpec("effects", 1e-4, 10.0, "rad/s"),
    "valve_dead_zone": FieldSpec("effects", 0.0, 0.9, "-"),
    "conductance_scale": FieldSpec("effects", 0.05, 10.0, "-"),
    "polytropic_n": FieldSpec("effects", 1.0, 1.4, "-"),
    "ripple_fraction": FieldSpec("effects", 0.0, 0.9, "-"),
    "supply_droop_pa_s_per_kg": FieldSpec("effects", 0.0, 1e9, "Pa·s/kg"),
    "hose_leak_area_m2": FieldSpec("effects", 0.0, 1e-4, "m^2"),
    "valve_set_dead_time_s": FieldSpec("effects", 0.0, 1.0, "s"),
    # 0 (adiabatic walls) to 10 times the correlations: a film coefficient from a correlation is
    # good to tens of percent, and the vane cell's has not been checked on such a motor
    # (docs/air_chambers.md); the range leaves an order of magnitude either way of it
    "wall_heat_scale": FieldSpec("effects", 0.0, 10.0, "-"),
    # 0.2 rad (11 deg) of lost motion and 0.1 rad/N·m (10 N·m/rad, 500x softer than a size-17
    # strain-wave gear) are far beyond any reducer in service: room for worn or badly fitted gears
    "reducer_backlash_rad": FieldSpec("effects", 0.0, 0.2, "rad"),
    "reducer_compliance_rad_per_nm": FieldSpec("effects", 0.0, 0.1, "rad/(N·m)"),
    "hose_model": FieldSpec("hose", 0.0, 1.0, "0 or 1"),
}
assert list(SPEC) == list(JointParams._fields), "SPEC and JointParams must list the same fields"

SECTIONS = ("motor", "reducer", "hose", "valves", "brake", "friction", "effects")
# metadata keys a section may carry besides numbers (names of the parts, e.g. model = "1UP-NRV-3A")
TEXT_KEYS = ("model", "note")
_CHECKS = {name: number_check(spec.low, spec.high, spec.unit, spec.whole) for name, spec in SPEC.items()}


def _section_table(section: str) -> type[BaseModel]:
    """The schema of one [section]: its JointParams fields (required unless JointParams gives a
    default, i.e. the [effects]) and the text keys."""
    numbers = {
        name: (number(spec.low, spec.high, spec.unit, spec.whole), JointParams._field_defaults.get(name, ...))
        for name, spec in SPEC.items()
        if spec.section == section
    }
    texts = {key: (TEXT | None, None) for key in TEXT_KEYS}
    return create_model(f"{section}_table", __config__=TABLE, **numbers, **texts)


_TABLES = {section: _section_table(section) for section in SECTIONS}
# a parameter file: one table per section; [effects] may be left out (all off)
ParameterFile = create_model(
    "ParameterFile",
    __config__=TABLE,
    **{s: (t, Field(default_factory=t) if s == "effects" else ...) for s, t in _TABLES.items()},
)


# any subset of JointParams fields, each in its range (a scenario's effects on one joint)
JointParamsSubset = create_model(
    "JointParamsSubset",
    __config__=TABLE,
    **{name: (number(spec.low, spec.high, spec.unit, spec.whole), None) for name, spec in SPEC.items()},
)


def check_value(source: str, field: str, value: object) -> float:
    """`value` as a float if it is allowed for `field`, else ParameterError naming source and field."""
    check, allowed = _CHECKS[field]
    try:
        return check(value)
    except PydanticCustomError as e:
        why = e.context["why"] if e.context else "is not allowed"
        raise ParameterError(_message(source, Problem((SPEC[field].section, field), value, why, allowed))) from None


def _message(source: str, p: Problem) -> str:
    """The one-line refusal of a parameter file: `<file>: [section] field = value <why>; allowed: ...`."""
    if len(p.loc) == 1:
        if p.why == "is not a known field":
            return f"{source}: unknown table [{p.loc[0]}]; allowed: {', '.join(SECTIONS)}"
        return f"{source}: [{p.loc[0]}] = {p.value!r} {p.why}; allowed: {p.allowed}"
    where = f"{source}: [{p.loc[0]}] {p.loc[1]}"
    if p.value is MISSING or p.why == "is not a known field":
        return f"{where} {p.why}; allowed: {p.allowed}"
    shown = f"{p.value:g}" if p.why == "is outside the allowed range" else repr(p.value)
    return f"{where} = {shown} {p.why}; allowed: {p.allowed}"


def validated(params: JointParams, source: str = "<parameters>") -> JointParams:
    """Check every field of `params` and the relations between them."""
    for field, value in zip(JointParams._fields, params, strict=True):
        check_value(source, field, value)
    return check_related(params, in_file(source))


def in_file(source: str) -> Callable[[str], str]:
    """Where a field is written in a parameter file, for a message: `<file>: [motor] rotor_radius_m`."""
    return lambda field: f"{source}: [{SPEC[field].section}] {field}"


def check_related(params: JointParams, field_at: Callable[[str], str]) -> JointParams:
    """Check what the fields must hold together: a rotor inside its stator, a brake that lifts
    before it is clear, a body for the motor side of a non-rigid reducer, switches that are 0 or 1.

    `field_at(field)`: where the field is written, for the message (`in_file` for a parameter file;
    a scenario's effects table names its own place). ParameterError on the first that fails."""
    if params.rotor_radius_m >= params.stator_radius_m:
        raise ParameterError(
            f"{field_at('rotor_radius_m')} = {params.rotor_radius_m:g} must be smaller than "
            f"stator_radius_m = {params.stator_radius_m:g}"
        )
    if params.brake_release_start_gauge_pa > params.brake_release_gauge_pa:
        raise ParameterError(
            f"{field_at('brake_release_start_gauge_pa')} = {params.brake_release_start_gauge_pa:g} "
            f"must not exceed brake_release_gauge_pa = {params.brake_release_gauge_pa:g} "
            "(the lining lifts before it is clear)"
        )
    if (
        params.reducer_backlash_rad > 0.0 or params.reducer_compliance_rad_per_nm > 0.0
    ) and params.rotor_inertia_kg_m2 == 0.0:
        raise ParameterError(
            f"{field_at('rotor_inertia_kg_m2')} = 0 with a non-rigid reducer "
            f"(reducer_backlash_rad = {params.reducer_backlash_rad:g}, "
            f"reducer_compliance_rad_per_nm = {params.reducer_compliance_rad_per_nm:g}); "
            "allowed: a rotor inertia > 0 (the motor side is a body of its own)"
        )
    for field in ("hose_loss", "hose_law", "brake_fed_by_motor", "chamber_heat", "hose_model"):
        value = getattr(params, field)
        if value not in (0.0, 1.0):
            raise ParameterError(f"{field_at(field)} = {value:g}; allowed: 0 or 1")
    return params


def load_joint_params(path: str | Path) -> JointParams:
    """Read and check one joint's parameter file."""
    path = Path(path)
    doc, _ = read_toml(path, ParameterError, "parameter file")
    try:
        tables = ParameterFile.model_validate(doc)
    except ValidationError as e:
        raise ParameterError(_message(str(path), first_problem(e, ParameterFile))) from None
    params = JointParams(**{name: getattr(getattr(tables, spec.section), name) for name, spec in SPEC.items()})
    return check_related(params, in_file(str(path)))


# numbers the kernels need at every call that depend on the parameters alone, kept in the row
# after the gas's fields (computed once by the laws' own functions: the same operations, the
# same bits as computing them in the call)
DERIVED = (
    "half_pitch_volume_m3",
    "hose_k_laminar",
    "hose_laminar_limit_kg_s",
    "hose_k_blasius",
    "choked_flux_s_m",
    # the motor's vane cell (`heat.vane_cell`): its wall area per volume, its hydraulic diameter
    "cell_area_per_volume_1_m",
    "cell_hydraulic_diameter_m",
    # the longest step of the air's ROS2 for its fill to be accurate, and the hose's own time, under
    # which an explicit step of the one-joint model diverges (`_air_times`)
    "air_step_s",
    "hose_time_s",
    # the lags' factors for steps of lag_dt_s (`valves.lag_factors`; NaN: a row for no one step)
    "lag_dt_s",
    "valve_decay",
    "valve_mean_gain",
    "brake_engage_decay",
    "brake_engage_mean_gain",
    "brake_release_decay",
    "brake_release_mean_gain",
    # with hose_model = 1, each hose's parameter row as a line (`pneumatics.line.line_row`, its columns
    # named by LINE_ROW_FIELDS); zeros with the pi-section
    *("line_" + f for f in LINE_ROW_FIELDS),
)


def _derived(params: JointParams, gas: Gas, dt_s: float) -> dict[str, float]:
    # the DERIVED columns' values, by name
    k_laminar, laminar_limit, k_blasius = hose_constants(params.hose_length_m, params.hose_diameter_m, gas.mu_pa_s)
    cell = vane_cell(params.stator_radius_m, params.rotor_radius_m, params.vane_length_m, params.n_vanes)
    air_step, hose_time = _air_times(params, gas)
    values = {
        "half_pitch_volume_m3": half_pitch_volume(
            params.stator_radius_m, params.rotor_radius_m, params.vane_length_m, params.n_vanes
        ),
        "hose_k_laminar": k_laminar,
        "hose_laminar_limit_kg_s": laminar_limit,
        "hose_k_blasius": k_blasius,
        "choked_flux_s_m": choked_flux(gas.t_supply_k, gas.r_j_per_kg_k, gas.k),
        "cell_area_per_volume_1_m": cell.area_per_volume_1_m,
        "cell_hydraulic_diameter_m": cell.hydraulic_diameter_m,
        "air_step_s": air_step,
        "hose_time_s": hose_time,
        "lag_dt_s": dt_s,
    }
    for lag, tau in (
        ("valve", params.valve_time_constant_s),
        ("brake_engage", params.brake_engage_time_constant_s),
        ("brake_release", params.brake_release_time_constant_s),
    ):
        decay, gain = lag_factors(dt_s, tau) if math.isfinite(dt_s) else (math.nan, math.nan)
        values[f"{lag}_decay"] = decay
        values[f"{lag}_mean_gain"] = gain
    values.update(zip(("line_" + f for f in LINE_ROW_FIELDS), _line_row(params, gas), strict=True))
    return values


def _line_row(params: JointParams, gas: Gas) -> tuple[float, ...]:
    # a hose's row as a line (hose_model = 1): wave speed from the gas, c = sqrt(k R T), so the line's
    # nodes take n = k (a step's front is adiabatic, pneumatics/line.py); its segments `segments_for`
    # the plant's band, PLANT_BAND_HZ
    if params.hose_model != HOSE_MODEL_LINE:
        return (0.0,) * N_LINE_ROW
    c = wave_speed(gas.t_supply_k, gas.r_j_per_kg_k, gas.k)
    return tuple(
        line_row(
            params.hose_length_m,
            params.hose_diameter_m,
            gas.t_supply_k,
            gas.r_j_per_kg_k,
            gas.k,
            gas.mu_pa_s,
            segments_for(params.hose_length_m, c, PLANT_BAND_HZ),
        )
    )


# The pressure and the step ratio `_air_times` reads its times at: the paper's lowest supply, 0.5 MPa gauge
# (the ratios hardly move with it), and ROS2 steps of at most 1/8 of the fill's time: measured on the
# wrist rig filling a 0.3 m x 4 mm hose (tests/test_plant.py against LSODA), steps of 1/5 of it left
# 2.2 % of the chamber pressure, 1/11 0.75 %; the arm's 8 m hoses (fill 36 ms) keep one step per 1 ms
AIR_TIMES_PA = 101_325.0 + 0.5e6
AIR_STEPS_PER_FILL = 8.0


def _air_times(params: JointParams, gas: Gas) -> tuple[float, float]:
    """(air_step_s, hose_time_s) of a joint: its air's time scales, from its parameters alone.

    The fill's time: a hose end (half the hose's volume) filled through the slower of the valve's
    choked inlet and the hose at the flow (the inlet's, or less if the hose carries less at half the
    pressure), V / (k R T g) with g their conductance per Pa (the inlet's
    A * choked flux; the hose's secant on its Blasius or laminar branch, `hose_constants`). ROS2 takes
    steps of at most 1/AIR_STEPS_PER_FILL of it: its error goes as (h / tau)^2, and its W damps the
    faster modes, not their accuracy.
    The hose's time: the two ends evening out through the hose at that flow, V / (2 k R T g_hose). An
    explicit step (the one-joint model's RK4) longer than it rings and diverges (a 0.5 m x 4 mm hose
    at 1 ms, a 50 mm bore from 0.5 m, a 1 mm bore from 1 m); the kernels then take the air by ROS2.
    Without the hose loss the hose's two ends are one node: its time does not bound the step."""
    half = 0.5 * hose_volume(params.hose_length_m, params.hose_diameter_m)
    krt = gas.k * gas.r_j_per_kg_k * gas.t_supply_k
    inlet = params.inlet_area_m2 * params.conductance_scale * choked_flux(gas.t_supply_k, gas.r_j_per_kg_k, gas.k)
    k_laminar, laminar_limit, k_blasius = hose_constants(params.hose_length_m, params.hose_diameter_m, gas.mu_pa_s)
    r_t = gas.r_j_per_kg_k * gas.t_supply_k
    # the flow: the inlet's, or what the hose carries at a drop of half the pressure if that is less
    flow = min(
        inlet * AIR_TIMES_PA,
        hose_mass_flow_with(
            AIR_TIMES_PA, 0.5 * AIR_TIMES_PA, gas.t_supply_k, gas.r_j_per_kg_k, k_laminar, laminar_limit, k_blasius
        ),
    )
    rho = AIR_TIMES_PA / r_t
    drop = flow / (k_laminar * rho) if flow <= laminar_limit else flow**1.75 / (k_blasius * rho)
    hose = flow / drop
    if params.hose_loss == 0.0 or params.hose_law == HOSE_LAW_PAPER:
        return 2.0 * half / (krt * inlet) / AIR_STEPS_PER_FILL, math.inf
    return half / (krt * min(inlet, hose)) / AIR_STEPS_PER_FILL, half / (2.0 * krt * hose)


# where the joint stops: its drive angle's end stops (rad), a property of the arm, not of the air
# (the MJCF's joint range, `control.arm_model.ArmModel.drive_stops`): the one-joint model ends a
# step that carries it past one on it (`pneumatics.joint.at_the_stops`). None: -inf, inf
STOPS = ("stop_low_rad", "stop_high_rad")


def params_row(
    params: JointParams,
    gas: Gas = AIR,
    dt_s: float = math.nan,
    stops: tuple[float, float] = (-math.inf, math.inf),
) -> np.ndarray:
    """The flat float64 row the compiled kernels read: the joint's fields, then the gas's, then
    the DERIVED numbers (the row is built only here, so they always match the fields), then the
    drive's end STOPS.

    `dt_s`: the step its user takes (the plant's physics step, the predictor's tick), for which
    the row keeps the valve's and the brake's lag factors; a kernel stepping by another dt
    computes them itself (`pneumatics.joint.advance_discrete`), to the same bits.
    `stops`: (low, high) of the drive angle in rad, for the one-joint model (the predictor, the gap
    replay); the plant's joints stop at MuJoCo's joint limits instead."""
    low, high = stops
    if not low < high:
        raise ValueError(f"end stops {stops!r}: the low stop must be below the high one")
    derived = _derived(params, gas, dt_s)
    assert derived.keys() == set(DERIVED), "params._derived: one value per DERIVED column"
    return np.array(
        tuple(params) + tuple(gas) + tuple(derived[name] for name in DERIVED) + (low, high), dtype=np.float64
    )


# column of each field in `params_row` (compile-time constants for the kernels)
_COLUMNS = {
    name: i for i, name in enumerate(JointParams._fields + tuple("gas_" + f for f in Gas._fields) + DERIVED + STOPS)
}
# each column named by its field (no positional slices: a field added anywhere moves nothing)
STATOR = _COLUMNS["stator_radius_m"]
ROTOR = _COLUMNS["rotor_radius_m"]
VANE_L = _COLUMNS["vane_length_m"]
N_VANES = _COLUMNS["n_vanes"]
DEAD_V = _COLUMNS["dead_volume_m3"]
ROTOR_J = _COLUMNS["rotor_inertia_kg_m2"]
CHAMBER_HEAT = _COLUMNS["chamber_heat"]
RATIO = _COLUMNS["ratio"]
ETA_F = _COLUMNS["efficiency_forward"]
ETA_B = _COLUMNS["efficiency_backward"]
HOSE_L = _COLUMNS["hose_length_m"]
HOSE_D = _COLUMNS["hose_diameter_m"]
HOSE_LOSS = _COLUMNS["hose_loss"]
HOSE_LAW = _COLUMNS["hose_law"]
HOSE_V_STD = _COLUMNS["hose_standard_flow_m3_s"]
A_IN = _COLUMNS["inlet_area_m2"]
A_EX = _COLUMNS["exhaust_area_m2"]
K_U = _COLUMNS["k_u_per_pa"]
VALVE_TAU = _COLUMNS["valve_time_constant_s"]
SOLENOID_DELAY = _COLUMNS["solenoid_delay_s"]
BRAKE_HOLD = _COLUMNS["brake_holding_nm"]
BRAKE_RELEASE_PA = _COLUMNS["brake_release_gauge_pa"]
BRAKE_START_PA = _COLUMNS["brake_release_start_gauge_pa"]
BRAKE_FED_BY_MOTOR = _COLUMNS["brake_fed_by_motor"]
BRAKE_TAU_ON = _COLUMNS["brake_engage_time_constant_s"]
BRAKE_TAU_OFF = _COLUMNS["brake_release_time_constant_s"]
COULOMB = _COLUMNS["coulomb_nm"]
VISCOUS = _COLUMNS["viscous_nm_s"]
STICK_SPEED = _COLUMNS["stick_speed_rad_s"]
LEAK_A = _COLUMNS["leak_area_m2"]
STRIBECK_EXCESS = _COLUMNS["stribeck_excess_nm"]
STRIBECK_SPEED = _COLUMNS["stribeck_speed_rad_s"]
DEAD_ZONE = _COLUMNS["valve_dead_zone"]
COND_SCALE = _COLUMNS["conductance_scale"]
POLY_N = _COLUMNS["polytropic_n"]
RIPPLE = _COLUMNS["ripple_fraction"]
DROOP = _COLUMNS["supply_droop_pa_s_per_kg"]
HOSE_LEAK_A = _COLUMNS["hose_leak_area_m2"]
PV_DEAD_TIME = _COLUMNS["valve_set_dead_time_s"]
WALL_HEAT = _COLUMNS["wall_heat_scale"]
BACKLASH = _COLUMNS["reducer_backlash_rad"]
COMPLIANCE = _COLUMNS["reducer_compliance_rad_per_nm"]
GAS_R = _COLUMNS["gas_r_j_per_kg_k"]
GAS_K = _COLUMNS["gas_k"]
GAS_T = _COLUMNS["gas_t_supply_k"]
GAS_P_ATM = _COLUMNS["gas_p_atm_pa"]
GAS_MU = _COLUMNS["gas_mu_pa_s"]
HALF_PITCH_V = _COLUMNS["half_pitch_volume_m3"]
HOSE_K_LAMINAR = _COLUMNS["hose_k_laminar"]
HOSE_LAMINAR_LIMIT = _COLUMNS["hose_laminar_limit_kg_s"]
HOSE_K_BLASIUS = _COLUMNS["hose_k_blasius"]
CHOKED_FLUX = _COLUMNS["choked_flux_s_m"]
CELL_AREA_PER_V = _COLUMNS["cell_area_per_volume_1_m"]
CELL_D_H = _COLUMNS["cell_hydraulic_diameter_m"]
AIR_STEP = _COLUMNS["air_step_s"]
HOSE_TIME = _COLUMNS["hose_time_s"]
LAG_DT = _COLUMNS["lag_dt_s"]
VALVE_DECAY = _COLUMNS["valve_decay"]
VALVE_MEAN_GAIN = _COLUMNS["valve_mean_gain"]
BRAKE_ON_DECAY = _COLUMNS["brake_engage_decay"]
BRAKE_ON_MEAN_GAIN = _COLUMNS["brake_engage_mean_gain"]
BRAKE_OFF_DECAY = _COLUMNS["brake_release_decay"]
BRAKE_OFF_MEAN_GAIN = _COLUMNS["brake_release_mean_gain"]
LINE_ROW = _COLUMNS["line_segments"]  # the first of the line row's N_LINE_ROW columns
assert [_COLUMNS["line_" + f] for f in LINE_ROW_FIELDS] == list(range(LINE_ROW, LINE_ROW + N_LINE_ROW))
HOSE_MODEL = _COLUMNS["hose_model"]
STOP_LOW = _COLUMNS["stop_low_rad"]
STOP_HIGH = _COLUMNS["stop_high_rad"]
N_COLUMNS = len(_COLUMNS)


# `hose_law`: the physical hose, the paper's eq. 1-5
HOSE_LAW_PHYSICAL = 0.0
HOSE_LAW_PAPER = 1.0
# `hose_model`: the lumped pi-section, the line that carries waves (pneumatics/line.py)
HOSE_MODEL_PI = 0.0
HOSE_MODEL_LINE = 1.0


def paper_model(params: JointParams) -> JointParams:
    """The paper's model of the same joint (eq. 1-7): its chambers' polytropic law, every flow at the
    supply temperature, no heat to the walls (chamber_heat = 0, with the joint's polytropic_n:
    1.4, the paper's adiabatic assumption 1, unless set). What the controller's predictor integrates
    (DESIGN rule 2: the predictor is the paper's model; the plant and the gap replay the best
    physics; beyond that they differ only in configuration).

    The hose is the lumped pi-section whatever the joint's `hose_model` (the line that carries waves is
    the plant's and the gap replay's physics, not the paper's). The hose law is the joint's own
    (`hose_law`): the shipped files keep the pi-section on the real flow (0), and the paper's eq. 1-5 as
    written (1: an algebraic drop on the supplied port at a fixed standard flow) is chosen per joint
    where wanted, e.g. `[predictor.effects.wrist_pitch] hose_law = 1` in a scenario. Not forced here:
    its drop does not follow the flow, so near a target, where the loop's set point sits at the
    breakaway floor, it takes the predicted port under breakaway and the arm's small moves stall in the
    prediction while the real joint runs (the cleaning task then fails); docs/predictor_hose_law.md has
    the measurements."""
    return params._replace(chamber_heat=0.0, hose_model=HOSE_MODEL_PI)
