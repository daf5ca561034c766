"""One pneumatic joint: valves, hoses, chambers, motor, reducer, brake. Pure numerics, no MuJoCo.

This is the model the paper integrates (eq. 5-7), arranged so that the plant (twin/), the angle
predictor (control/), the reference solver in the tests and the gap diagnosis all call the same
functions; they differ only in the parameter row (which effects are on) and in who supplies the
joint's motion: MuJoCo for the plant, a one-joint rigid body for the predictor.

Air path of each motor port (DESIGN, "Where the hose loss bites"):

    supply --[proportional valve, A_in*u]--+                     +--[vane motor chamber]
                                           |--(valve node)--hose--(motor node)
    atmosphere --[exhaust throttle, A_ex]--+

The direction valve connects a port's valve node to the supply or to the exhaust. The hose is
lumped as a pi-section: half its volume at each end, its Darcy-Weisbach resistance between them,
so the resistance acts on the supply and the exhaust path alike and the state stays non-stiff.
With hose_loss = 0 the two nodes are one volume (the paper's model without pressure loss); with the
paper's hose law (hose_law = 1, the predictor's) too, the loss then an algebraic drop of the
supplied port's feed pressure (eq. 5, pneumatics/paper_hose.py).

With hose_model = 1 each hose is a line that carries pressure waves (pneumatics/line.py): its first
node is the valve node, its last the motor node (the chamber's volume joined to its last half
segment). The lines' states follow the joint's N_STATE columns in its state row (`hose_state_size`,
`with_hoses`), and they are advanced once per physics step (`advance_hoses`): in the plant in place
of the ROS2 step, in the one-joint model once per RK4 sub-step, its stages seeing the air move
linearly to where the lines end (a line's many nodes and sub-steps cannot sit inside RK4's stages).
With the chambers' energy balance (chamber_heat = 1) the lines' gas is at the wall's temperature and
each chamber, the line's last node, keeps its own (`advance_hoses`, docs/air_lines.md).

State of a joint (a float64 row, see the S_* columns): four node pressures (Pa, absolute), the
proportional valve's output pressure (Pa, gauge), the brake's engagement, the direction
valve's effective position, pending position and time left until it switches, the motor
side of a non-rigid reducer (pneumatics/reducer.py): its angle and speed on the joint side (motor
angle / ratio, rad; rad/s; with the paper's rigid reducer the motor side is the joint and the
plant does not use those two), and the effective, pending and time-left of the proportional
valve's set point (used only with a set-point dead time, a gap effect), and the air's step in
progress (`advance_air_pair`): its stage (0 none, 1 or 2 physics steps taken), the direction and
supply it began with, the four pressures at its start, its first stage and ROS2's matrices.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pneumatics import params as P
from pneumatics._jit import njit
from pneumatics.brake import brake_feed_gauge_pa, brake_holding_torque, brake_mean, brake_step, brake_target
from pneumatics.chamber import carried_temperature, chamber_energy_rates, chamber_pressure_rate
from pneumatics.friction import coulomb_viscous_torque, reducer_output_torque, stribeck_excess
from pneumatics.gas import AIR, isentropic_temperature
from pneumatics.heat import duct_heat_transfer_coefficient, vane_chamber_heat_transfer_coefficient
from pneumatics.hose import hose_mass_flow_with, hose_volume
from pneumatics.integrators import ROS2_GAMMA, rk4_increment, ros2_increment, ros2_inverse, secant_slope
from pneumatics.line import (
    LR_DX,
    LR_SEGMENTS,
    N_LINE_ROW,
    FarEnd,
    advance_from_port,
    far_end_pressure,
    initial_line_state,
    state_size,
)
from pneumatics.motor import chamber_geometry, vane_torque
from pneumatics.orifice import orifice_mass_flow_between, orifice_mass_flow_with
from pneumatics.paper_hose import paper_source_pressure
from pneumatics.reducer import (
    damping,
    inertia_split,
    is_rigid,
    mode_frequency,
    stiffness,
    substeps_for,
    transmitted_torque,
)
from pneumatics.valves import (
    dead_time_step,
    lag_mean,
    lag_toward,
    proportional_valve_target,
    regulated_pressure,
    solenoid_step,
    valve_opening,
)

(
    S_PA_VALVE,
    S_PA_MOTOR,
    S_PB_VALVE,
    S_PB_MOTOR,
    S_PV,
    S_BRAKE,
    S_DIR,
    S_DIR_PENDING,
    S_DIR_REMAINING,
    S_QM,
    S_OMEGA_M,
    S_PV_SET,
    S_PV_SET_PENDING,
    S_PV_SET_REMAINING,
    S_PAIR,
    S_PAIR_DIR,
    S_PAIR_SUPPLY,
    S_PAIR_START,  # the four node pressures at the air step's start (4 columns, in the S_PA_VALVE.. order)
) = range(18)
S_PAIR_K = S_PAIR_START + 4  # ROS2's first stage, the same four
S_PAIR_MA = S_PAIR_K + 4  # ROS2's (I - g h W)^-1 for port A's (valve node, motor node), row-major: 4 columns
S_PAIR_MB = S_PAIR_MA + 4  # the same for port B
S_PAIR_LEAK = S_PAIR_MB + 4  # g h times the vane leak's coupling of the motor nodes (A's on B, B's on A)
# the four nodes' gas temperatures (K; the energy balance's state, `chamber_heat` = 1: with the
# paper's law they stay at the supply temperature), in the S_PA_VALVE.. order
S_TA_VALVE, S_TA_MOTOR, S_TB_VALVE, S_TB_MOTOR = range(S_PAIR_LEAK + 2, S_PAIR_LEAK + 6)
S_PAIR_T_START = S_TA_VALVE + 4  # the four temperatures at the air step's start
S_PAIR_T_K = S_PAIR_T_START + 4  # ROS2's first stage of the four
S_PAIR_T_M = S_PAIR_T_K + 4  # ROS2's 1 / (1 - g h W) of each temperature's own slope
N_STATE = S_PAIR_T_M + 4

# commands the platform sends to a joint (a float64 row)
C_DIRECTION, C_PV_SET_GAUGE_PA, C_BRAKE_RELEASE = range(3)
N_COMMAND = 3


@njit
def initial_state(
    p_atm_pa: float, brake_engaged: bool = True, theta_rad: float = 0.0, t_k: float = AIR.t_supply_k
) -> np.ndarray:
    """A joint at rest at `theta_rad`: every node at atmospheric pressure and the gas's temperature
    `t_k` (its walls'), valves closed, brake as given, the motor side at the joint's angle (an
    untwisted reducer)."""
    x = np.zeros(N_STATE)
    x[S_PA_VALVE] = x[S_PA_MOTOR] = x[S_PB_VALVE] = x[S_PB_MOTOR] = p_atm_pa
    x[S_TA_VALVE] = x[S_TA_MOTOR] = x[S_TB_VALVE] = x[S_TB_MOTOR] = t_k
    x[S_BRAKE] = 1.0 if brake_engaged else 0.0
    x[S_QM] = theta_rad
    return x


@njit(inline="always")
def effective_supply(
    supply_pa: float, valve_gauge_pa: float, opening: float, direction: float, p_node_pa: float, p: np.ndarray
) -> float:
    """Supply pressure at the valve after the droop of the supply line under the joint's draw.

    The draw is the air the open inlet passes, from the pressure the proportional valve delivers
    (its set point, capped by the supply) into the supplied port's valve node at `p_node_pa` (one
    explicit pass; the gap catalogue's "supply droop under flow"): a stalled motor, its port up to
    the supply, draws nothing and sees no droop; air pushed back from the port does not raise the
    supply. Zero droop for the nominal joint.
    """
    if p[P.DROOP] == 0.0 or direction == 0.0:
        return supply_pa
    return max(p[P.GAS_P_ATM], supply_pa - p[P.DROOP] * inlet_draw(supply_pa, valve_gauge_pa, opening, p_node_pa, p))


@njit(inline="always")
def inlet_draw(supply_pa: float, valve_gauge_pa: float, opening: float, p_node_pa: float, p: np.ndarray) -> float:
    """The air (kg/s) an open inlet draws from the supply line: through the proportional valve's
    `opening` from the pressure it delivers (its set point, capped by the supply) into the supplied
    port's valve node at `p_node_pa`; none pushed back (`effective_supply`, and a line shared by
    several joints)."""
    area = p[P.A_IN] * p[P.COND_SCALE] * opening
    upstream = regulated_pressure(supply_pa, valve_gauge_pa, p[P.GAS_P_ATM])
    return max(0.0, orifice_mass_flow_with(upstream, p_node_pa, area, p[P.CHOKED_FLUX], p[P.GAS_K]))


class AirState(NamedTuple):
    """A joint's air: its four nodes' pressures (Pa, absolute; the valve and the motor end of port A's
    hose, then port B's) and their gas temperatures (K), in that order. The same eight as rates
    (Pa/s, K/s) where a stepper carries their slopes (ROS2's stages, a secant over a sub-step)."""

    pa_valve: float
    pa_motor: float
    pb_valve: float
    pb_motor: float
    ta_valve: float
    ta_motor: float
    tb_valve: float
    tb_motor: float


@njit(inline="always")
def row_air(x: np.ndarray, pressures: int, temperatures: int) -> AirState:
    """The air in a float64 row whose four pressures start at column `pressures` and four
    temperatures at `temperatures` (each in the S_PA_VALVE.. order): a joint's state row
    (S_PA_VALVE, S_TA_VALVE), the air step's start and first stage kept in it, the one-joint
    state (R_PA_VALVE, R_TA_VALVE) and its rates. The one place those columns are read."""
    return AirState(
        x[pressures], x[pressures + 1], x[pressures + 2], x[pressures + 3], x[temperatures],
        x[temperatures + 1], x[temperatures + 2], x[temperatures + 3],
    )  # fmt: skip


@njit(inline="always")
def put_row_air(x: np.ndarray, pressures: int, temperatures: int, a: AirState) -> None:
    """Write the air `a` into a row's columns as `row_air` reads them."""
    x[pressures] = a.pa_valve
    x[pressures + 1] = a.pa_motor
    x[pressures + 2] = a.pb_valve
    x[pressures + 3] = a.pb_motor
    x[temperatures] = a.ta_valve
    x[temperatures + 1] = a.ta_motor
    x[temperatures + 2] = a.tb_valve
    x[temperatures + 3] = a.tb_motor


@njit(inline="always")
def _air_plus(a: AirState, rate: AirState, h: float) -> AirState:
    # the air a moved by h times `rate` (an explicit step, a stage's estimate)
    return AirState(
        a.pa_valve + h * rate.pa_valve, a.pa_motor + h * rate.pa_motor, a.pb_valve + h * rate.pb_valve,
        a.pb_motor + h * rate.pb_motor, a.ta_valve + h * rate.ta_valve, a.ta_motor + h * rate.ta_motor,
        a.tb_valve + h * rate.tb_valve, a.tb_motor + h * rate.tb_motor,
    )  # fmt: skip


@njit(inline="always")
def _air_secant(start: AirState, end: AirState, h: float) -> AirState:
    # the air's mean rate from `start` to `end` over h
    return AirState(
        (end.pa_valve - start.pa_valve) / h, (end.pa_motor - start.pa_motor) / h,
        (end.pb_valve - start.pb_valve) / h, (end.pb_motor - start.pb_motor) / h,
        (end.ta_valve - start.ta_valve) / h, (end.ta_motor - start.ta_motor) / h,
        (end.tb_valve - start.tb_valve) / h, (end.tb_motor - start.tb_motor) / h,
    )  # fmt: skip


class AirRates(NamedTuple):
    """Rates of a joint's four air nodes (valve and motor end of port A's hose, then port B's), the
    motor's volume slope, and ROS2's W (pneumatics/integrators.py): the rates' slopes against the
    state, each flow's slope taken as its secant (`secant_slope`)."""

    dpa_valve: float  # Pa/s
    dpa_motor: float
    dpb_valve: float
    dpb_motor: float
    dta_valve: float  # K/s (0 with the paper's law)
    dta_motor: float
    dtb_valve: float
    dtb_motor: float
    slope: float  # dV_A/dphi at the motor's angle, m^3/rad
    wa00: float  # port A's (valve node, motor node) pressure block of W, row-major
    wa01: float
    wa10: float
    wa11: float
    wb00: float  # port B's
    wb01: float
    wb10: float
    wb11: float
    leak_a: float  # the vane leak's coupling: A's rate against B's pressure
    leak_b: float  # B's against A's
    wt_a_valve: float  # each temperature's rate against itself (<= 0)
    wt_a_motor: float
    wt_b_valve: float
    wt_b_motor: float


@njit(inline="always")
def _air_slopes(f: AirRates) -> AirState:
    # the eight rates of f (Pa/s, K/s) as the air's slope
    return AirState(
        f.dpa_valve, f.dpa_motor, f.dpb_valve, f.dpb_motor, f.dta_valve, f.dta_motor, f.dtb_valve, f.dtb_motor
    )


@njit(inline="always")
def _port_valve_flow(p_node: float, supplied: bool, supply_pa: float, inlet_area: float, p: np.ndarray) -> float:
    # mass flow into a port's valve node from the supply (through the proportional valve) or
    # from the atmosphere (through the exhaust throttle; negative when exhausting)
    flux = p[P.CHOKED_FLUX]  # the air at both ends is taken at supply temperature
    k = p[P.GAS_K]
    if supplied:
        return orifice_mass_flow_with(supply_pa, p_node, inlet_area, flux, k)
    return orifice_mass_flow_with(p[P.GAS_P_ATM], p_node, p[P.A_EX] * p[P.COND_SCALE], flux, k)


@njit(inline="always")
def _hose_flow(p_valve: float, p_motor: float, supply_pa: float, p: np.ndarray) -> float:
    # mass flow valve node -> motor node. Air leaving the motor has expanded from the supply
    # pressure and is colder (paper eq. 2); the hose's mean temperature is T_m = (T_B + T_o)/2
    # with its far end T_o at supply temperature (paper eq. 1).
    t_s = p[P.GAS_T]
    t_mean = t_s
    if p_motor > p_valve and p_motor < supply_pa:
        t_mean = 0.5 * (isentropic_temperature(p_motor, supply_pa, t_s, p[P.POLY_N]) + t_s)
    return hose_mass_flow_with(
        p_valve, p_motor, t_mean, p[P.GAS_R], p[P.HOSE_K_LAMINAR], p[P.HOSE_LAMINAR_LIMIT], p[P.HOSE_K_BLASIUS]
    )


@njit(inline="always")
def _supplied_pressure(
    pa_valve: float, pb_valve: float, direction: float, valve_gauge_pa: float, supply_pa: float, p: np.ndarray
) -> tuple[float, float]:
    # (the pressure the proportional valve delivers, absolute; its inlet's area)
    opening = valve_opening(valve_gauge_pa, p[P.K_U], p[P.DEAD_ZONE])
    supplied_node = pa_valve if direction > 0.0 else pb_valve
    p_s = regulated_pressure(
        effective_supply(supply_pa, valve_gauge_pa, opening, direction, supplied_node, p),
        valve_gauge_pa,
        p[P.GAS_P_ATM],
    )
    if direction != 0.0 and p[P.HOSE_LOSS] == 1.0 and p[P.HOSE_LAW] == P.HOSE_LAW_PAPER:
        # the paper's eq. 5: the supplied port is fed from P_s, the valve's output less the hose's
        # algebraic drop at the fixed flow V; the exhausted port sees P_e = P_o (no drop)
        p_s = paper_source_pressure(
            p_s, p[P.GAS_P_ATM], p[P.GAS_T], p[P.GAS_K], p[P.HOSE_L], p[P.HOSE_D], p[P.HOSE_V_STD]
        )
    return p_s, p[P.A_IN] * p[P.COND_SCALE] * opening


@njit(inline="always")
def one_node_per_port(p: np.ndarray) -> bool:
    """True when each port's valve end and motor end are one air node (the hose's volume lumped
    with the chamber): without the hose's resistance, or with the paper's algebraic law for it
    (eq. 5), which has no flow along the hose to carry."""
    return p[P.HOSE_LOSS] == 0.0 or p[P.HOSE_LAW] == P.HOSE_LAW_PAPER


@njit(inline="always")
def uses_line(p: np.ndarray) -> bool:
    """True when each hose is a line that carries waves (hose_model = 1, pneumatics/line.py): with
    the hose's resistance on the physical law; without it, or with the paper's law, a port is one node."""
    return p[P.HOSE_MODEL] == P.HOSE_MODEL_LINE and not one_node_per_port(p)


@njit(inline="always")
def line_row_of(p: np.ndarray) -> np.ndarray:
    """The joint's hoses' parameter row as lines (`pneumatics.line.line_row`, kept in its params row)."""
    return p[P.LINE_ROW : P.LINE_ROW + N_LINE_ROW]


@njit
def hose_state_size(p: np.ndarray) -> int:
    """How many columns the joint's state row needs after its N_STATE for its two hoses' lines
    (port A's, then port B's; `pneumatics.line.state_size` each): 0 unless `uses_line`."""
    return 2 * state_size(line_row_of(p)) if uses_line(p) else 0


@njit
def with_hoses(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The joint state x (its first N_STATE columns) followed by its hoses' lines, each at rest at
    its port's motor-node pressure (the port's valve node set to it too): the state row a joint
    whose hoses are lines is stepped with (`advance_air_pair`, `single_joint_step`)."""
    out = np.empty(N_STATE + hose_state_size(p))
    out[:N_STATE] = x[:N_STATE]
    if uses_line(p):
        row = line_row_of(p)
        size = state_size(row)
        out[N_STATE : N_STATE + size] = initial_line_state(row, x[S_PA_MOTOR])
        out[N_STATE + size : N_STATE + 2 * size] = initial_line_state(row, x[S_PB_MOTOR])
        out[S_PA_VALVE] = x[S_PA_MOTOR]
        out[S_PB_VALVE] = x[S_PB_MOTOR]
    return out


class HoseStep(NamedTuple):
    """Both hoses as lines after a step (`advance_hoses`): the four end pressures (Pa absolute, in
    the S_PA_VALVE.. order), the mean mass flow into each line at its valve end (kg/s: from the
    supply, or negative to the exhaust and a leak there), the two motor chambers' gas temperatures
    (K; as given with the paper's law) and, with the energy balance, the step's mean heat into the
    joint's air (W: from the chambers' walls and from the lines' walls to gas entering a line from a
    chamber, `pneumatics.line.LineStep`) and the mean work its gas did on the vanes (W)."""

    pa_valve: float
    pa_motor: float
    pb_valve: float
    pb_motor: float
    a_inflow_kg_s: float
    b_inflow_kg_s: float
    ta_motor: float
    tb_motor: float
    heat_w: float
    work_w: float


@njit(inline="always")
def _hose_ends(s: HoseStep, a: AirState) -> AirState:
    # the air after both lines' step from `a`: their ends' pressures and the chambers' temperatures;
    # the valve nodes' gas is the lines', at their walls' temperature, kept as it was
    return AirState(s.pa_valve, s.pa_motor, s.pb_valve, s.pb_motor, a.ta_valve, s.ta_motor, a.tb_valve, s.tb_motor)


@njit
def advance_hoses(
    lines: np.ndarray,
    phi_motor: float,
    omega_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    dt_s: float,
    p: np.ndarray,
    ta_motor: float,
    tb_motor: float,
) -> HoseStep:
    """Advance a joint's two hoses as lines over dt, in place on `lines` (the columns after the joint
    state's N_STATE, `hose_state_size`), the motor turning from phi_motor at omega_motor, its chambers'
    gas at ta_motor, tb_motor (K; used by the energy balance).

    Each line's inlet node is its port's valve node, fed through the proportional valve from the
    pressure it delivers or emptied through the exhaust throttle (the direction valve, as in
    `air_rates`), both held over the step and implicit; a leak in port A's hose (a fault) vents there
    beside it. Its far node is the motor chamber (its volume and rate at the motor's angle and speed;
    the line's own nodes take n = k, the wave speed the gas's). The vane leak A -> B is taken at the
    step's start and held, so the mass one chamber loses the other gains.

    The chamber's law is the row's: the joint's polytropic exponent (chamber_heat = 0), or the energy
    balance (1), the chamber's gas temperature a state: the line's gas is at its wall's temperature,
    the supply's (docs/air_lines.md, "With the chambers' energy balance"), so gas from the line brings
    that gas's enthalpy, gas into the line leaves at the chamber's temperature, and the chamber's wall
    (the vane cell's correlation, half a segment of hose) exchanges heat as in `air_rates`."""
    row = line_row_of(p)
    size = state_size(row)
    la = lines[:size]
    lb = lines[size : 2 * size]
    atm = p[P.GAS_P_ATM]
    flux = p[P.CHOKED_FLUX]
    k = p[P.GAS_K]
    p_s, inlet_area = _supplied_pressure(la[0], lb[0], direction, valve_gauge_pa, supply_pa, p)
    exhaust_area = p[P.A_EX] * p[P.COND_SCALE]
    a_up, a_area = (p_s, inlet_area) if direction > 0.0 else (atm, exhaust_area)
    b_up, b_area = (p_s, inlet_area) if direction < 0.0 else (atm, exhaust_area)
    v_a, v_b, slope = chamber_geometry(
        phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V], p[P.HALF_PITCH_V]
    )
    dv_a = slope * omega_motor
    energy = p[P.CHAMBER_HEAT] != 0.0
    if energy:
        end_a, end_b = _energy_far_ends(la, lb, row, v_a, v_b, dv_a, omega_motor, ta_motor, tb_motor, p)
    else:
        n = p[P.POLY_N]
        m_leak = orifice_mass_flow_with(far_end_pressure(la, row), far_end_pressure(lb, row), p[P.LEAK_A], flux, k)
        end_a = FarEnd(v_a, dv_a, -m_leak, 0.0, 0.0, n, 0.0, 0.0, 0.0)
        end_b = FarEnd(v_b, -dv_a, m_leak, 0.0, 0.0, n, 0.0, 0.0, 0.0)
    sa = advance_from_port(la, row, dt_s, a_up, a_area, atm, p[P.HOSE_LEAK_A], flux, k, end_a)
    sb = advance_from_port(lb, row, dt_s, b_up, b_area, atm, 0.0, flux, k, end_b)
    if energy:
        r = p[P.GAS_R]
        ta_motor, tb_motor = sa.end_rt / r, sb.end_rt / r
    return HoseStep(
        la[0], far_end_pressure(la, row), lb[0], far_end_pressure(lb, row), sa.inlet_flow_kg_s, sb.inlet_flow_kg_s,
        ta_motor, tb_motor, sa.end_heat_w + sa.entry_heat_w + sb.end_heat_w + sb.entry_heat_w,
        sa.end_work_w + sb.end_work_w,
    )  # fmt: skip


@njit(inline="always")
def _energy_far_ends(
    la: np.ndarray,
    lb: np.ndarray,
    row: np.ndarray,
    v_a: float,
    v_b: float,
    dv_a: float,
    omega_motor: float,
    ta_motor: float,
    tb_motor: float,
    p: np.ndarray,
) -> tuple[FarEnd, FarEnd]:
    # `advance_hoses`'s chambers by the energy balance (pneumatics/line.py `FarEnd.gas_rt`, their
    # exponent k): the vane leak at its upstream chamber's temperature (`orifice_mass_flow_between`),
    # each chamber's wall conductance (`_wall_conductance`: its vane cell and the half segment of hose
    # joined to it, past which the last segment's flow at the step's start moves) held over the step
    k = p[P.GAS_K]
    r = p[P.GAS_R]
    pa = far_end_pressure(la, row)
    pb = far_end_pressure(lb, row)
    m_leak = orifice_mass_flow_between(pa, pb, p[P.LEAK_A], ta_motor, tb_motor, r, k)
    rt_leak = r * carried_temperature(m_leak, ta_motor, tb_motor)
    nseg = int(row[LR_SEGMENTS])
    half_wall = 0.5 * math.pi * p[P.HOSE_D] * row[LR_DX]
    ha = _wall_conductance(pa, ta_motor, la[2 * nseg], half_wall, v_a, omega_motor, p) / r
    hb = _wall_conductance(pb, tb_motor, lb[2 * nseg], half_wall, v_b, omega_motor, p) / r
    return (
        FarEnd(v_a, dv_a, -m_leak, 0.0, 0.0, k, r * ta_motor, rt_leak, ha),
        FarEnd(v_b, -dv_a, m_leak, 0.0, 0.0, k, r * tb_motor, rt_leak, hb),
    )


@njit
def hoses_settled(lines: np.ndarray, p: np.ndarray) -> bool:
    """True when both lines are at atmospheric pressure throughout and still (no flow, no unsteady
    wall shear left): with the valves shut and the joint still, nothing can change them."""
    row = line_row_of(p)
    nodes = int(row[LR_SEGMENTS]) + 1  # `pneumatics.line`: N + 1 node pressures first
    size = state_size(row)
    atm = p[P.GAS_P_ATM]
    for line in range(2):
        start = line * size
        for i in range(size):
            v = lines[start + i]
            if (abs(v - atm) >= 1e-6) if i < nodes else (abs(v) >= 1e-12):
                return False
    return True


@njit(inline="always")
def _polytropic_rates(
    a: AirState,
    phi_motor: float,
    omega_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    p: np.ndarray,
) -> AirRates:
    # `air_rates` by the paper's polytropic law (chamber_heat = 0): every flow at the supply
    # temperature, the temperatures' rates 0. The W blocks: a node's rate n/V (R T m_in - p dV/dt)
    # with m_in = sum of g (p_other - p) has the slope -n/V (R T sum g + dV/dt) against its own
    # pressure and n/V R T g against another's.
    pa_valve, pa_motor, pb_valve, pb_motor = a.pa_valve, a.pa_motor, a.pb_valve, a.pb_motor
    r = p[P.GAS_R]
    t_s = p[P.GAS_T]
    n = p[P.POLY_N]
    atm = p[P.GAS_P_ATM]
    p_s, inlet_area = _supplied_pressure(pa_valve, pb_valve, direction, valve_gauge_pa, supply_pa, p)
    m_a_valve = _port_valve_flow(pa_valve, direction > 0.0, p_s, inlet_area, p)
    m_b_valve = _port_valve_flow(pb_valve, direction < 0.0, p_s, inlet_area, p)
    g_a_valve = secant_slope(m_a_valve, (p_s if direction > 0.0 else atm) - pa_valve)
    g_b_valve = secant_slope(m_b_valve, (p_s if direction < 0.0 else atm) - pb_valve)

    v_a, v_b, slope = chamber_geometry(
        phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V], p[P.HALF_PITCH_V]
    )
    dv_a = slope * omega_motor
    m_leak = orifice_mass_flow_with(
        pa_motor, pb_motor, p[P.LEAK_A], p[P.CHOKED_FLUX], p[P.GAS_K]
    )  # A -> B past the vanes
    g_leak = secant_slope(m_leak, pa_motor - pb_motor)
    # a leak in port A's hose (a fault) vents at the hose's valve end
    m_hose_leak = orifice_mass_flow_with(pa_valve, atm, p[P.HOSE_LEAK_A], p[P.CHOKED_FLUX], p[P.GAS_K])
    m_a_valve -= m_hose_leak
    g_a_valve += secant_slope(m_hose_leak, pa_valve - atm)
    half_hose = 0.5 * hose_volume(p[P.HOSE_L], p[P.HOSE_D])
    rt = r * t_s

    if one_node_per_port(p):
        # one node per port: motor chamber + porting + the whole hose
        v_a_node = v_a + 2.0 * half_hose
        v_b_node = v_b + 2.0 * half_hose
        da = chamber_pressure_rate(pa_motor, v_a_node, dv_a, m_a_valve - m_leak, t_s, r, n)
        db = chamber_pressure_rate(pb_motor, v_b_node, -dv_a, m_b_valve + m_leak, t_s, r, n)
        w_a = -n / v_a_node * (rt * (g_a_valve + g_leak) + dv_a)
        w_b = -n / v_b_node * (rt * (g_b_valve + g_leak) - dv_a)
        leak_a, leak_b = n / v_a_node * rt * g_leak, n / v_b_node * rt * g_leak
        return AirRates(
            da, da, db, db, 0.0, 0.0, 0.0, 0.0, slope, w_a, 0.0, 0.0, w_a, w_b, 0.0, 0.0, w_b, leak_a, leak_b, 0.0,
            0.0, 0.0, 0.0,
        )  # fmt: skip

    m_a_hose = _hose_flow(pa_valve, pa_motor, p_s, p)
    m_b_hose = _hose_flow(pb_valve, pb_motor, p_s, p)
    g_a_hose = secant_slope(m_a_hose, pa_valve - pa_motor)
    g_b_hose = secant_slope(m_b_hose, pb_valve - pb_motor)
    n_rt_valve = n * rt / half_hose
    n_a_motor = n / (v_a + half_hose)
    n_b_motor = n / (v_b + half_hose)
    return AirRates(
        chamber_pressure_rate(pa_valve, half_hose, 0.0, m_a_valve - m_a_hose, t_s, r, n),
        chamber_pressure_rate(pa_motor, v_a + half_hose, dv_a, m_a_hose - m_leak, t_s, r, n),
        chamber_pressure_rate(pb_valve, half_hose, 0.0, m_b_valve - m_b_hose, t_s, r, n),
        chamber_pressure_rate(pb_motor, v_b + half_hose, -dv_a, m_b_hose + m_leak, t_s, r, n),
        0.0,
        0.0,
        0.0,
        0.0,
        slope,
        -n_rt_valve * (g_a_valve + g_a_hose),
        n_rt_valve * g_a_hose,
        n_a_motor * rt * g_a_hose,
        -n_a_motor * (rt * (g_a_hose + g_leak) + dv_a),
        -n_rt_valve * (g_b_valve + g_b_hose),
        n_rt_valve * g_b_hose,
        n_b_motor * rt * g_b_hose,
        -n_b_motor * (rt * (g_b_hose + g_leak) - dv_a),
        n_a_motor * rt * g_leak,
        n_b_motor * rt * g_leak,
        0.0,
        0.0,
        0.0,
        0.0,
    )


class _NodeFlows(NamedTuple):
    """A node's flows summed for its energy balance: net mass in (kg/s), sum m T over all of them
    and over the inflows (K kg/s), the outflows (kg/s, <= 0)."""

    mass: float
    temperature_flow: float
    temperature_inflow: float
    outflow: float


@njit(inline="always")
def _node_flows(m1: float, t1: float, m2: float, t2: float, m3: float, t3: float) -> _NodeFlows:
    # up to three flows into a node (+ in), each with its `carried_temperature`
    f_in = (m1 * t1 if m1 > 0.0 else 0.0) + (m2 * t2 if m2 > 0.0 else 0.0) + (m3 * t3 if m3 > 0.0 else 0.0)
    m_out = min(m1, 0.0) + min(m2, 0.0) + min(m3, 0.0)
    return _NodeFlows(m1 + m2 + m3, m1 * t1 + m2 * t2 + m3 * t3, f_in, m_out)


@njit(inline="always")
def _wall_conductance(
    p_pa: float,
    t_k: float,
    hose_flow_kg_s: float,
    hose_area_m2: float,
    cell_volume_m3: float,
    omega_motor: float,
    p: np.ndarray,
) -> float:
    # hA (W/K) between a node's gas and its walls at the supply temperature: `hose_area_m2` of hose
    # wall past which the gas moves at the hose's mean speed (Dittus-Boelter on its bore,
    # pneumatics/heat.py), and `cell_volume_m3` of motor chamber (the vane cell's correlation on the
    # rotor's speed, the cell's wall area per volume), times the row's wall_heat_scale
    scale = p[P.WALL_HEAT]
    if scale == 0.0:
        return 0.0
    r = p[P.GAS_R]
    k = p[P.GAS_K]
    t_w = p[P.GAS_T]
    bore = p[P.HOSE_D]
    speed = hose_flow_kg_s * r * t_k / (p_pa * (0.25 * math.pi * bore * bore))
    ha = duct_heat_transfer_coefficient(speed, p_pa, t_k, t_w, bore, r, k) * hose_area_m2
    if cell_volume_m3 > 0.0:
        h_cell = vane_chamber_heat_transfer_coefficient(omega_motor, p_pa, t_k, t_w, p[P.STATOR], p[P.CELL_D_H], r, k)
        ha += h_cell * p[P.CELL_AREA_PER_V] * cell_volume_m3
    return scale * ha


@njit(inline="always")
def _node_energy(
    p_pa: float, t_k: float, volume: float, dv: float, flows: _NodeFlows, conductance_w_k: float, p: np.ndarray
) -> tuple[float, float, float]:
    # (dp/dt, dT/dt, W's temperature diagonal) of a node by the energy balance, heat hA (T_w - T)
    # from its wall at the supply temperature T_w. The diagonal is the slope of dT/dt against T with
    # the pressure, the flows and hA held and the outflows carrying T,
    # R/(pV) (k F_in - 2 T M_in + 2 (k - 1) T M_out) + (k - 1)/(pV) (hA (T_w - 2 T) - p dV/dt)
    # (F_in the inflows' sum m T, M_in and M_out their and the outflows' mass), clipped at 0: a
    # rising slope is left explicit (ROS2 is second order with any W)
    r = p[P.GAS_R]
    k = p[P.GAS_K]
    t_w = p[P.GAS_T]
    rates = chamber_energy_rates(
        p_pa, t_k, volume, dv, flows.mass, flows.temperature_flow, conductance_w_k * (t_w - t_k), r, k
    )
    m_in = flows.mass - flows.outflow
    slope = (
        r * (k * flows.temperature_inflow - 2.0 * t_k * m_in + 2.0 * (k - 1.0) * t_k * flows.outflow)
        + (k - 1.0) * (conductance_w_k * (t_w - 2.0 * t_k) - p_pa * dv)
    ) / (p_pa * volume)
    return rates.dp_dt_pa_s, rates.dt_dt_k_s, min(slope, 0.0)


@njit(inline="always")
def _energy_rates(
    a: AirState,
    phi_motor: float,
    omega_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    p: np.ndarray,
) -> AirRates:
    # `air_rates` by the energy balance (chamber_heat = 1; pneumatics/chamber.py). Each flow at its
    # upstream side's temperature: the supply's and the atmosphere's the supply temperature, a
    # node's its own (`carried_temperature`); the orifices at the upstream gas's temperature
    # (`orifice_mass_flow_between`), the hose's friction at its two ends' mean. Heat from walls at
    # the supply temperature (`_wall_conductance`). W's pressure blocks as the polytropic law's with
    # n = k and each flow's own carried temperature, k/V R T_i g_i.
    pa_valve, pa_motor, pb_valve, pb_motor = a.pa_valve, a.pa_motor, a.pb_valve, a.pb_motor
    ta_valve, ta_motor, tb_valve, tb_motor = a.ta_valve, a.ta_motor, a.tb_valve, a.tb_motor
    r = p[P.GAS_R]
    k = p[P.GAS_K]
    t_s = p[P.GAS_T]
    atm = p[P.GAS_P_ATM]
    p_s, inlet_area = _supplied_pressure(pa_valve, pb_valve, direction, valve_gauge_pa, supply_pa, p)
    a_source = p_s if direction > 0.0 else atm
    a_area = inlet_area if direction > 0.0 else p[P.A_EX] * p[P.COND_SCALE]
    b_source = p_s if direction < 0.0 else atm
    b_area = inlet_area if direction < 0.0 else p[P.A_EX] * p[P.COND_SCALE]
    m_a_valve = orifice_mass_flow_between(a_source, pa_valve, a_area, t_s, ta_valve, r, k)
    m_b_valve = orifice_mass_flow_between(b_source, pb_valve, b_area, t_s, tb_valve, r, k)
    t_a_valve = carried_temperature(m_a_valve, t_s, ta_valve)
    t_b_valve = carried_temperature(m_b_valve, t_s, tb_valve)
    g_a_valve = secant_slope(m_a_valve, a_source - pa_valve)
    g_b_valve = secant_slope(m_b_valve, b_source - pb_valve)

    v_a, v_b, slope = chamber_geometry(
        phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V], p[P.HALF_PITCH_V]
    )
    dv_a = slope * omega_motor
    # A -> B past the vanes, at the upstream chamber's temperature
    m_leak = orifice_mass_flow_between(pa_motor, pb_motor, p[P.LEAK_A], ta_motor, tb_motor, r, k)
    t_leak = carried_temperature(m_leak, ta_motor, tb_motor)
    g_leak = secant_slope(m_leak, pa_motor - pb_motor)
    # a leak in port A's hose (a fault) vents at the hose's valve end
    m_hose_leak = orifice_mass_flow_between(pa_valve, atm, p[P.HOSE_LEAK_A], ta_valve, t_s, r, k)
    t_hose_leak = carried_temperature(-m_hose_leak, t_s, ta_valve)
    g_hose_leak = secant_slope(m_hose_leak, pa_valve - atm)
    hose_v = hose_volume(p[P.HOSE_L], p[P.HOSE_D])
    hose_wall = math.pi * p[P.HOSE_D] * p[P.HOSE_L]

    if one_node_per_port(p):
        # one node per port: motor chamber + porting + the whole hose, its gas moving at the valve's flow
        v_a_node = v_a + hose_v
        v_b_node = v_b + hose_v
        fa = _node_flows(m_a_valve, t_a_valve, -m_hose_leak, t_hose_leak, -m_leak, t_leak)
        fb = _node_flows(m_b_valve, t_b_valve, m_leak, t_leak, 0.0, 0.0)
        ha = _wall_conductance(pa_motor, ta_motor, m_a_valve, hose_wall, v_a, omega_motor, p)
        hb = _wall_conductance(pb_motor, tb_motor, m_b_valve, hose_wall, v_b, omega_motor, p)
        da, dta, wta = _node_energy(pa_motor, ta_motor, v_a_node, dv_a, fa, ha, p)
        db, dtb, wtb = _node_energy(pb_motor, tb_motor, v_b_node, -dv_a, fb, hb, p)
        w_a = -k / v_a_node * (r * (t_a_valve * g_a_valve + t_hose_leak * g_hose_leak + t_leak * g_leak) + dv_a)
        w_b = -k / v_b_node * (r * (t_b_valve * g_b_valve + t_leak * g_leak) - dv_a)
        leak_a, leak_b = k / v_a_node * r * t_leak * g_leak, k / v_b_node * r * t_leak * g_leak
        return AirRates(
            da, da, db, db, dta, dta, dtb, dtb, slope, w_a, 0.0, 0.0, w_a, w_b, 0.0, 0.0, w_b, leak_a, leak_b, wta,
            wta, wtb, wtb,
        )  # fmt: skip

    half_hose = 0.5 * hose_v
    half_wall = 0.5 * hose_wall
    r_g = p[P.GAS_R]
    m_a_hose = hose_mass_flow_with(
        pa_valve, pa_motor, 0.5 * (ta_valve + ta_motor), r_g, p[P.HOSE_K_LAMINAR], p[P.HOSE_LAMINAR_LIMIT],
        p[P.HOSE_K_BLASIUS],
    )  # fmt: skip
    m_b_hose = hose_mass_flow_with(
        pb_valve, pb_motor, 0.5 * (tb_valve + tb_motor), r_g, p[P.HOSE_K_LAMINAR], p[P.HOSE_LAMINAR_LIMIT],
        p[P.HOSE_K_BLASIUS],
    )  # fmt: skip
    t_a_hose = carried_temperature(m_a_hose, ta_valve, ta_motor)  # into the motor node
    t_b_hose = carried_temperature(m_b_hose, tb_valve, tb_motor)
    g_a_hose = secant_slope(m_a_hose, pa_valve - pa_motor)
    g_b_hose = secant_slope(m_b_hose, pb_valve - pb_motor)
    v_a_motor = v_a + half_hose
    v_b_motor = v_b + half_hose
    fav = _node_flows(m_a_valve, t_a_valve, -m_hose_leak, t_hose_leak, -m_a_hose, t_a_hose)
    fam = _node_flows(m_a_hose, t_a_hose, -m_leak, t_leak, 0.0, 0.0)
    fbv = _node_flows(m_b_valve, t_b_valve, -m_b_hose, t_b_hose, 0.0, 0.0)
    fbm = _node_flows(m_b_hose, t_b_hose, m_leak, t_leak, 0.0, 0.0)
    dav, dtav, wtav = _node_energy(
        pa_valve, ta_valve, half_hose, 0.0, fav,
        _wall_conductance(pa_valve, ta_valve, m_a_hose, half_wall, 0.0, omega_motor, p), p,
    )  # fmt: skip
    dam, dtam, wtam = _node_energy(
        pa_motor, ta_motor, v_a_motor, dv_a, fam,
        _wall_conductance(pa_motor, ta_motor, m_a_hose, half_wall, v_a, omega_motor, p), p,
    )  # fmt: skip
    dbv, dtbv, wtbv = _node_energy(
        pb_valve, tb_valve, half_hose, 0.0, fbv,
        _wall_conductance(pb_valve, tb_valve, m_b_hose, half_wall, 0.0, omega_motor, p), p,
    )  # fmt: skip
    dbm, dtbm, wtbm = _node_energy(
        pb_motor, tb_motor, v_b_motor, -dv_a, fbm,
        _wall_conductance(pb_motor, tb_motor, m_b_hose, half_wall, v_b, omega_motor, p), p,
    )  # fmt: skip
    kr_valve = k * r / half_hose
    k_a_motor = k / v_a_motor
    k_b_motor = k / v_b_motor
    return AirRates(
        dav,
        dam,
        dbv,
        dbm,
        dtav,
        dtam,
        dtbv,
        dtbm,
        slope,
        -kr_valve * (t_a_valve * g_a_valve + t_hose_leak * g_hose_leak + t_a_hose * g_a_hose),
        kr_valve * t_a_hose * g_a_hose,
        k_a_motor * r * t_a_hose * g_a_hose,
        -k_a_motor * (r * (t_a_hose * g_a_hose + t_leak * g_leak) + dv_a),
        -kr_valve * (t_b_valve * g_b_valve + t_b_hose * g_b_hose),
        kr_valve * t_b_hose * g_b_hose,
        k_b_motor * r * t_b_hose * g_b_hose,
        -k_b_motor * (r * (t_b_hose * g_b_hose + t_leak * g_leak) - dv_a),
        k_a_motor * r * t_leak * g_leak,
        k_b_motor * r * t_leak * g_leak,
        wtav,
        wtam,
        wtbv,
        wtbm,
    )


@njit(inline="always")
def air_rates(
    a: AirState,
    phi_motor: float,
    omega_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    p: np.ndarray,
) -> AirRates:
    """Rates of the four node pressures (Pa/s) and temperatures (K/s), the motor's volume slope and
    ROS2's W (`AirRates`), paper eq. 7 rows 3-4 with the hose on both ports, by the row's chamber
    law: the paper's polytropic one (chamber_heat = 0; the temperatures stay at the supply's) or
    the energy balance (1).

    The air `a`: pressures absolute, temperatures in K, in the order valve node A, motor node A,
    valve node B, motor node B. `direction` +1 pressurises port A (motor turns positive), -1 port B, 0 exhausts
    both. `valve_gauge_pa` is the proportional valve's output pressure P_v: the pressure it
    delivers (capped by the absolute `supply_pa`) and, through u = k_u P_v, its opening (paper
    Sec. IV). What a caller does not use the compiler drops.
    """
    if p[P.CHAMBER_HEAT] == 0.0:
        return _polytropic_rates(a, phi_motor, omega_motor, direction, valve_gauge_pa, supply_pa, p)
    return _energy_rates(a, phi_motor, omega_motor, direction, valve_gauge_pa, supply_pa, p)


@njit(inline="always")
def pressure_rates(
    pa_valve: float,
    pa_motor: float,
    pb_valve: float,
    pb_motor: float,
    phi_motor: float,
    omega_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    p: np.ndarray,
) -> tuple[float, float, float, float]:
    """The four node pressures' rates (Pa/s) of `air_rates`, every node's gas at the supply
    temperature (where the energy balance's gas settles: its walls' temperature)."""
    t_s = p[P.GAS_T]
    r = air_rates(
        AirState(pa_valve, pa_motor, pb_valve, pb_motor, t_s, t_s, t_s, t_s), phi_motor, omega_motor, direction,
        valve_gauge_pa, supply_pa, p,
    )  # fmt: skip
    return r.dpa_valve, r.dpa_motor, r.dpb_valve, r.dpb_motor


@njit
def joint_torque(pa_motor: float, pb_motor: float, phi_motor: float, omega_joint: float, p: np.ndarray) -> float:
    """Joint-side drive torque in N·m: vane torque through the reducer (eq. 6, 7 row 2).

    `omega_joint` is the speed, joint side, of the gear's input as the motor turns it: the joint's
    speed for the rigid reducer, the motor side's w_m for a non-rigid one (pneumatics/reducer.py);
    its sign picks the forward or back-driving efficiency.

    With `ripple_fraction` > 0 the vane torque carries a ripple at the vane-passing frequency
    (an effect outside the paper's model, used by the gap bench).
    """
    t_motor = vane_torque(pa_motor, pb_motor, phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES])
    return _through_reducer(t_motor, phi_motor, omega_joint, p)


@njit(inline="always")
def _vane_torque_at(pa_motor: float, pb_motor: float, slope: float) -> float:
    # `vane_torque` from the volume slope dV_A/dphi at its angle (`air_rates` has it)
    if pa_motor == pb_motor:
        return 0.0
    return (pa_motor - pb_motor) * slope


@njit(inline="always")
def _rippled(t_motor: float, phi_motor: float, p: np.ndarray) -> float:
    # the vane torque with its ripple at the vane-passing frequency
    if p[P.RIPPLE] != 0.0 and t_motor != 0.0:  # (zero stays zero: an idle motor, every step, without the cos)
        t_motor *= 1.0 + p[P.RIPPLE] * math.cos(p[P.N_VANES] * phi_motor)
    return t_motor


@njit(inline="always")
def _through_gear(t_rippled: float, omega_joint: float, p: np.ndarray) -> float:
    # the reducer's part of `joint_torque`: the rippled vane torque on the joint side
    return reducer_output_torque(t_rippled, omega_joint, p[P.RATIO], p[P.ETA_F], p[P.ETA_B])


@njit(inline="always")
def _through_reducer(t_motor: float, phi_motor: float, omega_joint: float, p: np.ndarray) -> float:
    # the rest of `joint_torque` from the vane torque: the ripple, the reducer
    return _through_gear(_rippled(t_motor, phi_motor, p), omega_joint, p)


@njit(inline="always")
def _kept(p: np.ndarray, column: int, dt_s: float) -> float:
    # a lag factor the row keeps for steps of dt_s (`params_row`), or -1: the lag computes it
    return p[column] if p[P.LAG_DT] == dt_s else -1.0


@njit
def advance_discrete(x: np.ndarray, command: np.ndarray, supply_pa: float, dt_s: float, p: np.ndarray) -> float:
    """Advance the valves of one joint over dt, in place (exact for held inputs); return the
    proportional valve's output pressure (gauge Pa) averaged over the step, the value a step that
    holds it should use (`lag_mean`; x[S_PV] is its value at the step's end).

    The direction valve's position in x is the one in effect over the step (`solenoid_step`)."""
    supply_gauge = supply_pa - p[P.GAS_P_ATM]
    x[S_DIR], x[S_DIR_PENDING], x[S_DIR_REMAINING] = solenoid_step(
        x[S_DIR], x[S_DIR_PENDING], x[S_DIR_REMAINING], command[C_DIRECTION], p[P.SOLENOID_DELAY], dt_s
    )
    set_point = command[C_PV_SET_GAUGE_PA]
    if p[P.PV_DEAD_TIME] > 0.0:
        x[S_PV_SET], x[S_PV_SET_PENDING], x[S_PV_SET_REMAINING] = dead_time_step(
            x[S_PV_SET], x[S_PV_SET_PENDING], x[S_PV_SET_REMAINING], set_point, p[P.PV_DEAD_TIME], dt_s
        )
        set_point = x[S_PV_SET]
    target = proportional_valve_target(set_point, supply_gauge)
    mean = lag_mean(x[S_PV], target, dt_s, p[P.VALVE_TAU], _kept(p, P.VALVE_MEAN_GAIN, dt_s))
    x[S_PV] = lag_toward(x[S_PV], target, dt_s, p[P.VALVE_TAU], _kept(p, P.VALVE_DECAY, dt_s))
    return mean


@njit
def _brake_target_now(
    command: np.ndarray, supply_pa: float, pa_motor_pa: float, pb_motor_pa: float, p: np.ndarray
) -> float:
    # the engagement the brake tends to with its air from the supply or the driven motor port
    feed = brake_feed_gauge_pa(p[P.BRAKE_FED_BY_MOTOR], supply_pa, pa_motor_pa, pb_motor_pa, p[P.GAS_P_ATM])
    return brake_target(command[C_BRAKE_RELEASE], feed, p[P.BRAKE_START_PA], p[P.BRAKE_RELEASE_PA])


@njit
def brake_over_step(
    x: np.ndarray,
    command: np.ndarray,
    supply_pa: float,
    pa_motor_pa: float,
    pb_motor_pa: float,
    dt_s: float,
    p: np.ndarray,
) -> float:
    """The brake's engagement averaged over the coming dt, toward the target its air gives at the
    step's start: what a step that holds the brake's friction constant should hold (the springs
    engage in ~20 ms, so the value at the step's start would brake a 1 ms step late)."""
    engage = _brake_target_now(command, supply_pa, pa_motor_pa, pb_motor_pa, p)
    return brake_mean(
        x[S_BRAKE],
        engage,
        p[P.BRAKE_TAU_ON],
        p[P.BRAKE_TAU_OFF],
        dt_s,
        _kept(p, P.BRAKE_ON_MEAN_GAIN, dt_s),
        _kept(p, P.BRAKE_OFF_MEAN_GAIN, dt_s),
    )


@njit
def advance_brake(
    x: np.ndarray,
    command: np.ndarray,
    supply_pa: float,
    pa_start_pa: float,
    pb_start_pa: float,
    pa_end_pa: float,
    pb_end_pa: float,
    dt_s: float,
    p: np.ndarray,
) -> None:
    """Advance the brake's engagement over dt, in place, toward the target its air gives.

    The brake's air is the supply or the higher motor-end port pressure (`brake_feed_gauge_pa`):
    the caller passes the motor-node pressures at the step's start and at its end, just
    integrated (the plant's or the predictor's own). The lag follows the mean of the two targets
    (trapezoid): a target taken at one end of the step would bias the engagement by half a step of
    the target's motion while the port fills through the release band, an error of first order.
    """
    start = _brake_target_now(command, supply_pa, pa_start_pa, pb_start_pa, p)
    end = _brake_target_now(command, supply_pa, pa_end_pa, pb_end_pa, p)
    x[S_BRAKE] = brake_step(
        x[S_BRAKE],
        0.5 * (start + end),
        p[P.BRAKE_TAU_ON],
        p[P.BRAKE_TAU_OFF],
        dt_s,
        _kept(p, P.BRAKE_ON_DECAY, dt_s),
        _kept(p, P.BRAKE_OFF_DECAY, dt_s),
    )


# How far from atmospheric pressure a node's air may be for a still joint with its valves shut to be
# at rest (`air_settled`), Pa. Its air then has only a slow tail left: the motor node drains through
# the laminar hose and the exhaust throttle's linear last 1 % of pressure ratio (time constants
# 0.3-0.5 s on the arm's joints), and a joint creeping under its brake below the stick speed (MuJoCo's
# soft friction: 1e-5 rad/s) pumps it and holds it 0.01-0.2 Pa off atmosphere, so it never reaches
# round-off. Air held in the band gives at most `rest_torque_bound`: 0.1 N·m on the shoulder, the
# largest (3e-4 of the 340 N·m it carries), 5.5 mN·m on the wrist; docs/tick_loop.md, "Speed", says
# why 10 Pa and not 0.1 or 1.
REST_BAND_PA = 10.0
# the same for the gas temperature (K): tight, a still warm or cold gas exchanges heat for seconds
REST_BAND_K = 1e-6


@njit(inline="always")
def air_settled(pressures: np.ndarray, temperatures: np.ndarray, p: np.ndarray) -> bool:
    """True when the four nodes' air (their pressures and temperatures, each in the S_PA_VALVE..
    order) is within REST_BAND_PA of atmospheric pressure and REST_BAND_K of its walls'
    temperature: a still joint whose valves are shut has only the slow tail of its air left, which
    the at-rest shortcuts hold (`at_rest`, the predictor's `predictor_at_rest`)."""
    atm = p[P.GAS_P_ATM]
    t_w = p[P.GAS_T]
    for c in range(4):  # noqa: SIM110 (a loop, not all() of a generator: compiled code)
        if abs(pressures[c] - atm) >= REST_BAND_PA or abs(temperatures[c] - t_w) >= REST_BAND_K:
            return False
    return True


@njit
def rest_torque_bound(p: np.ndarray) -> float:
    """The most torque (N·m, joint side) the air of a joint at rest (`air_settled`) can give: its two
    motor nodes REST_BAND_PA either side of atmosphere, at the vane's steepest volume slope (mid-pitch,
    `chamber_geometry` at 0: rho is largest there), the ripple at its crest, through the gear
    back-driven (`reducer_output_torque`, 1 / eta_b)."""
    slope = chamber_geometry(0.0, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V], p[P.HALF_PITCH_V])[2]
    return 2.0 * REST_BAND_PA * slope * (1.0 + abs(p[P.RIPPLE])) * p[P.RATIO] / p[P.ETA_B]


@njit
def at_rest(x: np.ndarray, omega: float, p: np.ndarray) -> bool:
    """True when the joint stands (nearly) still, its air is all at atmosphere and at its walls'
    temperature and its direction valve is closed: nothing can change its air. (A joint moving
    without air still pumps it; warm or cold air at atmosphere still exchanges heat and flows.)"""
    return (
        x[S_DIR] == 0.0
        and abs(omega) < p[P.STICK_SPEED]
        and air_settled(x[S_PA_VALVE : S_PB_MOTOR + 1], x[S_TA_VALVE : S_TB_MOTOR + 1], p)
    )


class _Nodes(NamedTuple):
    # one number per air node, in the S_PA_VALVE.. order (the pressures' part of ROS2's stages, the
    # temperatures' factors)
    a_valve: float
    a_motor: float
    b_valve: float
    b_motor: float


@njit(inline="always")
def _ros2_solve(
    ma: tuple[float, float, float, float],
    mb: tuple[float, float, float, float],
    leak_a: float,
    leak_b: float,
    r: _Nodes,
    one_node: bool,
) -> _Nodes:
    # (I - g h W) k = r for the four node pressures: ma, mb the inverses of port A's and port B's
    # 2 x 2 blocks (`ros2_inverse`, row-major), leak_a, leak_b g h times the vane leak's coupling of
    # the motor nodes (A's rate against B's pressure, B's against A's). Each port solved alone, then
    # the coupling eliminated: k_A = ma r_A + leak_A ma e_m k_Bm, and B the same way. Without the hose
    # loss a port's valve and motor node are one node: both take the motor node's result.
    ua_valve = ma[0] * r.a_valve + ma[1] * r.a_motor
    ua_motor = ma[2] * r.a_valve + ma[3] * r.a_motor
    ub_valve = mb[0] * r.b_valve + mb[1] * r.b_motor
    ub_motor = mb[2] * r.b_valve + mb[3] * r.b_motor
    if leak_a == 0.0 and leak_b == 0.0:  # no vane leak (the nominal joint): the ports apart
        return _Nodes(ua_valve, ua_motor, ub_valve, ub_motor)
    alpha = leak_a * ma[3]
    beta = leak_b * mb[3]
    inv = 1.0 / (1.0 - alpha * beta)
    k_am = (ua_motor + alpha * ub_motor) * inv
    k_bm = (ub_motor + beta * ua_motor) * inv
    if one_node:
        return _Nodes(k_am, k_am, k_bm, k_bm)
    return _Nodes(ua_valve + leak_a * ma[1] * k_bm, k_am, ub_valve + leak_b * mb[1] * k_am, k_bm)


@njit(inline="always")
def air_substeps(dt_s: float, p: np.ndarray) -> int:
    """How many ROS2 steps the joint's air takes over dt_s for its fill to be accurate: 1 for the arm's
    8 m hoses at the plant's and the predictor's steps, more for a short hose (`params.AIR_STEP`)."""
    return max(1, math.ceil(dt_s / p[P.AIR_STEP] - 1e-9))


@njit(inline="always")
def explicit_air_substeps(h: float, p: np.ndarray) -> int:
    """How many ROS2 steps the joint's air takes inside an explicit (RK4) sub-step of h: 0 where RK4's
    stages may take the air's own rates (h within the fill's ROS2 step, `air_substeps`, and the hose's
    own time, `params.HOSE_TIME`, past which an explicit step rings or diverges), else `air_substeps`.
    The one-joint model (`single_joint_rk4`) and a non-rigid reducer's motor side in the plant
    (`advance_motor_side`) then give RK4's stages the air's secant over the sub-step."""
    m = air_substeps(h, p)
    return m if m > 1 or h > p[P.HOSE_TIME] else 0


class Ros2Stage(NamedTuple):
    """ROS2's first stage of a joint's air over a step of h (pneumatics/integrators.py): its slope k1
    and what its second stage solves with again, (I - g h W)^-1 of each port's pressure block
    (row-major), g h times the vane leak's coupling of the motor nodes (A's rate against B's pressure,
    B's against A's) and 1 / (1 - g h W) of each temperature's own slope (the S_TA_VALVE.. order)."""

    k: AirState
    ma: tuple[float, float, float, float]
    mb: tuple[float, float, float, float]
    leak_a: float
    leak_b: float
    mt: _Nodes


@njit(inline="always")
def _ros2_first(f: AirRates, h: float, one_node: bool) -> Ros2Stage:
    # ROS2's first stage, (I - g h W) k1 = f, from the rates f at the step's start: the pressures'
    # blocks solved together (`_ros2_solve`), each temperature by its own slope
    ma = ros2_inverse(f.wa00, f.wa01, f.wa10, f.wa11, h)
    mb = ros2_inverse(f.wb00, f.wb01, f.wb10, f.wb11, h)
    gh = ROS2_GAMMA * h
    leak_a = gh * f.leak_a
    leak_b = gh * f.leak_b
    k = _ros2_solve(ma, mb, leak_a, leak_b, _Nodes(f.dpa_valve, f.dpa_motor, f.dpb_valve, f.dpb_motor), one_node)
    mt_a_valve = 1.0 / (1.0 - gh * f.wt_a_valve)
    mt_a_motor = 1.0 / (1.0 - gh * f.wt_a_motor)
    mt_b_valve = 1.0 / (1.0 - gh * f.wt_b_valve)
    mt_b_motor = 1.0 / (1.0 - gh * f.wt_b_motor)
    slope = AirState(
        k.a_valve, k.a_motor, k.b_valve, k.b_motor, mt_a_valve * f.dta_valve, mt_a_motor * f.dta_motor,
        mt_b_valve * f.dtb_valve, mt_b_motor * f.dtb_motor,
    )  # fmt: skip
    return Ros2Stage(slope, ma, mb, leak_a, leak_b, _Nodes(mt_a_valve, mt_a_motor, mt_b_valve, mt_b_motor))


@njit(inline="always")
def _ros2_second(a: AirState, first: Ros2Stage, g: AirRates, h: float, one_node: bool) -> AirState:
    # ROS2's second stage, (I - g h W) k2 = g - 2 k1 with the first stage's matrices and g the rates at
    # the first stage's estimate a + h k1 one step on, and the step's result from the air `a` at its start
    k = first.k
    r = _Nodes(
        g.dpa_valve - 2.0 * k.pa_valve, g.dpa_motor - 2.0 * k.pa_motor, g.dpb_valve - 2.0 * k.pb_valve,
        g.dpb_motor - 2.0 * k.pb_motor,
    )  # fmt: skip
    k2 = _ros2_solve(first.ma, first.mb, first.leak_a, first.leak_b, r, one_node)
    return AirState(
        a.pa_valve + ros2_increment(h, k.pa_valve, k2.a_valve),
        a.pa_motor + ros2_increment(h, k.pa_motor, k2.a_motor),
        a.pb_valve + ros2_increment(h, k.pb_valve, k2.b_valve),
        a.pb_motor + ros2_increment(h, k.pb_motor, k2.b_motor),
        a.ta_valve + ros2_increment(h, k.ta_valve, first.mt.a_valve * (g.dta_valve - 2.0 * k.ta_valve)),
        a.ta_motor + ros2_increment(h, k.ta_motor, first.mt.a_motor * (g.dta_motor - 2.0 * k.ta_motor)),
        a.tb_valve + ros2_increment(h, k.tb_valve, first.mt.b_valve * (g.dtb_valve - 2.0 * k.tb_valve)),
        a.tb_motor + ros2_increment(h, k.tb_motor, first.mt.b_motor * (g.dtb_motor - 2.0 * k.tb_motor)),
    )


@njit
def _air_ros2(
    a: AirState,
    phi_motor: float,
    omega_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    h: float,
    n: int,
    p: np.ndarray,
) -> AirState:
    """The air `a` after n whole ROS2 steps of h, the motor turning from phi_motor at omega_motor: a
    short hose's air, in the plant (`advance_air_pair`) and the one-joint model (`single_joint_rk4`).
    The same stages as the plant's step over two physics steps (`_ros2_first`, `_ros2_second`), with
    the rates of the second at the step's end."""
    one_node = one_node_per_port(p)
    for i in range(n):
        phi = phi_motor + omega_motor * (i * h)
        first = _ros2_first(air_rates(a, phi, omega_motor, direction, valve_gauge_pa, supply_pa, p), h, one_node)
        g = air_rates(
            _air_plus(a, first.k, h), phi + omega_motor * h, omega_motor, direction, valve_gauge_pa, supply_pa, p
        )
        a = _ros2_second(a, first, g, h, one_node)
    return a


@njit(inline="always")
def _keep_first_stage(x: np.ndarray, a: AirState, first: Ros2Stage) -> None:
    # the air step's start and first stage, kept in a joint's state row for its second (S_PAIR_* columns)
    put_row_air(x, S_PAIR_START, S_PAIR_T_START, a)
    put_row_air(x, S_PAIR_K, S_PAIR_T_K, first.k)
    for c in range(4):
        x[S_PAIR_MA + c] = first.ma[c]
        x[S_PAIR_MB + c] = first.mb[c]
        x[S_PAIR_T_M + c] = first.mt[c]
    x[S_PAIR_LEAK] = first.leak_a
    x[S_PAIR_LEAK + 1] = first.leak_b


@njit(inline="always")
def _kept_first_stage(x: np.ndarray) -> Ros2Stage:
    # the first stage `_keep_first_stage` kept in x
    return Ros2Stage(
        row_air(x, S_PAIR_K, S_PAIR_T_K),
        (x[S_PAIR_MA], x[S_PAIR_MA + 1], x[S_PAIR_MA + 2], x[S_PAIR_MA + 3]),
        (x[S_PAIR_MB], x[S_PAIR_MB + 1], x[S_PAIR_MB + 2], x[S_PAIR_MB + 3]),
        x[S_PAIR_LEAK],
        x[S_PAIR_LEAK + 1],
        _Nodes(x[S_PAIR_T_M], x[S_PAIR_T_M + 1], x[S_PAIR_T_M + 2], x[S_PAIR_T_M + 3]),
    )


@njit
def advance_air_pair(
    x: np.ndarray,
    theta: float,
    omega: float,
    valve_gauge_pa: float,
    supply_pa: float,
    dt_s: float,
    p: np.ndarray,
) -> float:
    """Advance the four node pressures over one physics step of dt, in place, as one half of a
    ROS2 step over two (pneumatics/integrators.py); return the joint torque to hold over the step
    (`joint_torque` at the angle `theta`, speed `omega`, from the pressures in x on entry).

    A step begins with ROS2's first stage at the pressures, angle and speed of its start, the
    proportional valve's output at `valve_gauge_pa` (its mean over the physics step, from
    `advance_discrete`), and leaves x at the first stage's estimate one physics step on. The
    next physics step moves x on by the same estimate, and `finish_air_pair`, at the angle and
    speed MuJoCo reached two physics steps from the start and the valve's output there, takes
    the second stage and puts x at the step's result. The torque is explicit, from the pressures
    in x at each physics step's start, like MuJoCo's own semi-implicit Euler. A step whose
    second half meets another direction or supply (a valve switching, a supply step) ends there,
    at the first stage's estimate, and a new one begins.

    One rate evaluation a physics step, where Heun's method takes two; the
    pressures' W matrix (the flows' slopes, the vane leak's coupling of the chambers with them)
    keeps the air's fast modes damped (a short or wide hose, a large leak), where Heun's explicit
    stages rang (tests/test_plant.py holds the plant to LSODA and to the flows' balance).

    Hoses that are lines (`uses_line`) are advanced over each physics step instead (`advance_hoses`,
    on the columns after N_STATE), the torque again from the pressures at the step's start.
    """
    ratio = p[P.RATIO]
    direction = x[S_DIR]
    if uses_line(p):
        return _advance_air_lines(x, theta, omega, valve_gauge_pa, supply_pa, dt_s, p)
    if x[S_PAIR] == 1.0 and x[S_PAIR_DIR] == direction and x[S_PAIR_SUPPLY] == supply_pa:
        # the second physics step: the first stage's estimate carried on to the step's end
        a = row_air(x, S_PA_VALVE, S_TA_VALVE)
        torque = joint_torque(a.pa_motor, a.pb_motor, ratio * theta, omega, p)
        put_row_air(x, S_PA_VALVE, S_TA_VALVE, _air_plus(a, row_air(x, S_PAIR_K, S_PAIR_T_K), dt_s))
        x[S_PAIR] = 2.0
        return torque
    x[S_PAIR] = 0.0
    if at_rest(x, omega, p):
        return joint_torque(x[S_PA_MOTOR], x[S_PB_MOTOR], ratio * theta, omega, p)
    a = row_air(x, S_PA_VALVE, S_TA_VALVE)
    if air_substeps(2.0 * dt_s, p) > 1:
        # a short hose: its fill is faster than one ROS2 step over two physics steps follows, so the
        # air takes whole ROS2 steps inside this one (`air_substeps`), the joint turning at omega
        torque = joint_torque(a.pa_motor, a.pb_motor, ratio * theta, omega, p)
        n = air_substeps(dt_s, p)
        put_row_air(
            x, S_PA_VALVE, S_TA_VALVE,
            _air_ros2(a, ratio * theta, ratio * omega, direction, valve_gauge_pa, supply_pa, dt_s / n, n, p),
        )  # fmt: skip
        return torque
    # ROS2's first stage over two physics steps, kept for the second (`finish_air_pair`), and its
    # estimate one physics step on
    f = air_rates(a, ratio * theta, ratio * omega, direction, valve_gauge_pa, supply_pa, p)
    first = _ros2_first(f, 2.0 * dt_s, one_node_per_port(p))
    _keep_first_stage(x, a, first)
    put_row_air(x, S_PA_VALVE, S_TA_VALVE, _air_plus(a, first.k, dt_s))
    x[S_PAIR_DIR] = direction
    x[S_PAIR_SUPPLY] = supply_pa
    x[S_PAIR] = 1.0
    return _through_reducer(_vane_torque_at(a.pa_motor, a.pb_motor, f.slope), ratio * theta, omega, p)


@njit(inline="always")
def _advance_air_lines(
    x: np.ndarray, theta: float, omega: float, valve_gauge_pa: float, supply_pa: float, dt_s: float, p: np.ndarray
) -> float:
    # `advance_air_pair` for hoses that are lines: the torque from the pressures at the step's start,
    # then both lines over the step (`advance_hoses`), their ends copied into the four node pressures
    # and the chambers' temperatures; nothing for a still joint with shut valves whose lines are at
    # rest at atmosphere and whose chambers' gas is at its walls' temperature
    ratio = p[P.RATIO]
    x[S_PAIR] = 0.0
    a = row_air(x, S_PA_VALVE, S_TA_VALVE)
    torque = joint_torque(a.pa_motor, a.pb_motor, ratio * theta, omega, p)
    lines = x[N_STATE:]
    if (
        x[S_DIR] == 0.0
        and abs(omega) < p[P.STICK_SPEED]
        and hoses_settled(lines, p)
        and (p[P.CHAMBER_HEAT] == 0.0 or air_settled(x[S_PA_VALVE : S_PB_MOTOR + 1], x[S_TA_VALVE : S_TB_MOTOR + 1], p))
    ):
        return torque
    s = advance_hoses(
        lines, ratio * theta, ratio * omega, x[S_DIR], valve_gauge_pa, supply_pa, dt_s, p, a.ta_motor, a.tb_motor
    )
    put_row_air(x, S_PA_VALVE, S_TA_VALVE, _hose_ends(s, a))
    return torque


@njit
def finish_air_pair(x: np.ndarray, theta: float, omega: float, dt_s: float, p: np.ndarray) -> None:
    """Complete the air's step that `advance_air_pair` took two physics steps ago, in place, at the
    joint's angle and speed now and the proportional valve's output now (x[S_PV]): ROS2's second
    stage. Nothing if no step waits for it; the same result whenever it is called before the next
    physics step (the plant calls it at the end of its steps, the next step at its start)."""
    if x[S_PAIR] != 2.0:
        return
    ratio = p[P.RATIO]
    estimate = row_air(x, S_PA_VALVE, S_TA_VALVE)
    g = air_rates(estimate, ratio * theta, ratio * omega, x[S_PAIR_DIR], x[S_PV], x[S_PAIR_SUPPLY], p)
    start = row_air(x, S_PAIR_START, S_PAIR_T_START)
    put_row_air(
        x, S_PA_VALVE, S_TA_VALVE, _ros2_second(start, _kept_first_stage(x), g, 2.0 * dt_s, one_node_per_port(p))
    )
    x[S_PAIR] = 0.0


class GearDrive(NamedTuple):
    """A non-rigid reducer's motor side driven by its vanes (`motor_side_drive`)."""

    drive: float  # the vane torque through the gear, joint side (N·m)
    held: bool  # whether the gear's own friction holds the motor still


@njit
def motor_side_drive(
    pa_motor: float, pb_motor: float, phi_motor: float, w_m: float, slide_m: float, tau_t: float, p: np.ndarray
) -> GearDrive:
    """The drive of a non-rigid reducer's motor side (pneumatics/reducer.py): the vane torque
    through the gear, joint side (N·m), and whether the gear's own friction holds the motor still.

    The efficiency the gear applies depends on which way the motor turns against its torque
    (`joint_torque`: eta_f forward, 1/eta_b back-driven), so the gear is a dry friction on the
    motor side, and it gets Karnopp's rule like the joint: sliding in direction `slide_m` (+1/-1),
    or, with `slide_m` 0, at the motor's speed w_m; below the stick speed the motor stays put while
    the spring's torque tau_t lies between what the gear passes forward and back-driven.
    """
    t_motor = vane_torque(pa_motor, pb_motor, phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES])
    return _motor_side_drive_of(_rippled(t_motor, phi_motor, p), w_m, slide_m, tau_t, p)


@njit(inline="always")
def _motor_side_drive_of(t_rippled: float, w_m: float, slide_m: float, tau_t: float, p: np.ndarray) -> GearDrive:
    # `motor_side_drive` from the motor's rippled vane torque (one geometry and one ripple for the
    # up to three efficiencies tried)
    if slide_m != 0.0:
        return GearDrive(_through_gear(t_rippled, slide_m, p), False)
    if abs(w_m) >= p[P.STICK_SPEED]:
        return GearDrive(_through_gear(t_rippled, w_m, p), False)
    forward = _through_gear(t_rippled, 1.0, p)
    if forward > tau_t:
        return GearDrive(forward, False)
    backward = _through_gear(t_rippled, -1.0, p)
    if backward < tau_t:
        return GearDrive(backward, False)
    return GearDrive(tau_t, True)


@njit
def stop_or_turn(
    q: float, w_before: float, w_after: float, slide: float, drive_jump: float, inertia: float, h: float
) -> tuple[float, float]:
    """(angle, speed) of a body after a sub-step of h in which its speed crossed zero while its dry
    friction was held sliding in the direction `slide`.

    The crossing is placed where the speed, linear in time over the sub-step, passes zero. Past it
    the held friction pushed the body the wrong way: the angle gives back what it gained there
    (half the end speed times the time after the crossing), and the speed is corrected by
    `drive_jump` (the net drive after the turn minus the net drive held; for the joint twice its
    dry friction, plus the change of the gear's efficiency) over that time. If no speed is left in
    the reversed direction, friction stopped the body at the crossing; otherwise it turned round.
    """
    after = h * abs(w_after) / (abs(w_before) + abs(w_after))
    q -= 0.5 * w_after * after
    turned = w_after + drive_jump / inertia * after
    if slide * turned < 0.0:
        return q + 0.5 * turned * after, turned
    return q, 0.0


class HeldMotorSide(NamedTuple):
    """A non-rigid reducer's motor side at rest (`held_motor_side`)."""

    at_rest: bool
    torque: float  # what the gear passes to the joint with the motor held (N·m)


@njit
def held_motor_side(x: np.ndarray, theta: float, omega: float, p: np.ndarray) -> HeldMotorSide:
    """Whether a non-rigid reducer's motor side and air are at rest, to be held over the coming step
    (the plant's shortcut beside `advance_motor_side`), and the torque the gear then passes to the
    joint at its angle `theta` and speed `omega`: the spring's and the damper's on the held motor.

    At rest: the joint's air at rest (`at_rest`: valves shut, the joint still, the air in the rest
    band), the motor held by its gear's friction at the last step's end (speed exactly 0, Karnopp's
    rule in `advance_motor_side`), and the gear's torque within `rest_torque_bound`. The integrated
    motor stays held while the gear's torque lies between what the vanes' torque passes forward and
    back-driven, and their air gives at most `rest_torque_bound`: so the integrated gear's torque is
    within the bound too, the held one's differs from it by at most twice the bound, and a joint
    creeping into its held motor (MuJoCo's soft brake) leaves the shortcut once it has wound the
    gear past the bound."""
    ratio = p[P.RATIO]
    j_m = ratio * ratio * p[P.ROTOR_J]
    k = stiffness(p[P.BACKLASH], p[P.COMPLIANCE])
    torque = transmitted_torque(x[S_QM] - theta, -omega, 0.5 * p[P.BACKLASH], k, damping(k, j_m))
    return HeldMotorSide(x[S_OMEGA_M] == 0.0 and at_rest(x, omega, p) and abs(torque) <= rest_torque_bound(p), torque)


class _MotorSide(NamedTuple):
    # what `advance_motor_side` integrates: the joint's air and a non-rigid reducer's motor side
    air: AirState
    q_m: float  # the motor side's angle, joint side (motor angle / ratio, rad)
    w_m: float  # its speed (rad/s)


class _MotorSideRates(NamedTuple):
    # the rates of a `_MotorSide` and the torque the gear transmits (N·m), whose integral is the impulse
    air: AirState
    dq_m: float
    dw_m: float
    torque: float


class _MotorSideInputs(NamedTuple):
    # what `advance_motor_side` holds over its step: the joint's speed (rad/s), the direction valve, the
    # proportional valve's output (gauge Pa), the supply (Pa), the gear's stiffness (N·m/rad), damping
    # (N·m·s/rad) and half backlash (rad), the motor side's inertia (kg·m^2)
    omega: float
    direction: float
    valve: float
    supply_pa: float
    k: float
    c: float
    half_gap: float
    j_motor: float


@njit
def _motor_side_rates(
    y: _MotorSide, theta: float, slide_m: float, inputs: _MotorSideInputs, p: np.ndarray
) -> _MotorSideRates:
    # rates of y, the joint at theta, the gear's friction held sliding in `slide_m` (0: Karnopp's rule)
    ratio = p[P.RATIO]
    phi = ratio * y.q_m
    tau_t = transmitted_torque(y.q_m - theta, y.w_m - inputs.omega, inputs.half_gap, inputs.k, inputs.c)
    r = air_rates(y.air, phi, ratio * y.w_m, inputs.direction, inputs.valve, inputs.supply_pa, p)
    # `motor_side_drive`, from the geometry the rates took at the same angle
    t_rippled = _rippled(_vane_torque_at(y.air.pa_motor, y.air.pb_motor, r.slope), phi, p)
    drive, stuck = _motor_side_drive_of(t_rippled, y.w_m, slide_m, tau_t, p)
    dq, dw = (0.0, 0.0) if stuck else (y.w_m, (drive - tau_t) / inputs.j_motor)
    return _MotorSideRates(_air_slopes(r), dq, dw, tau_t)


@njit
def _motor_side_stage(
    y0: _MotorSide,
    rates: _MotorSideRates,
    c: float,
    theta: float,
    slide_m: float,
    inputs: _MotorSideInputs,
    p: np.ndarray,
) -> _MotorSideRates:
    # `_motor_side_rates` at the state y0 + c * rates: an RK4 stage
    y = _MotorSide(_air_plus(y0.air, rates.air, c), y0.q_m + c * rates.dq_m, y0.w_m + c * rates.dw_m)
    return _motor_side_rates(y, theta, slide_m, inputs, p)


@njit(inline="always")
def _held_air_rates(rates: _MotorSideRates, secant: AirState, held: bool) -> _MotorSideRates:
    # `_motor_side_rates` with the air's rates replaced by its secant over the sub-step, when the air is
    # not RK4's own (hoses that are lines; a short hose's ROS2 steps, `explicit_air_substeps`)
    if not held:
        return rates
    return _MotorSideRates(secant, rates.dq_m, rates.dw_m, rates.torque)


@njit(inline="always")
def _air_rk4(a: AirState, k1: AirState, k2: AirState, k3: AirState, k4: AirState, h: float) -> AirState:
    # the air a after a classical Runge-Kutta step of h from its four stage rates
    return AirState(
        a.pa_valve + rk4_increment(h, k1.pa_valve, k2.pa_valve, k3.pa_valve, k4.pa_valve),
        a.pa_motor + rk4_increment(h, k1.pa_motor, k2.pa_motor, k3.pa_motor, k4.pa_motor),
        a.pb_valve + rk4_increment(h, k1.pb_valve, k2.pb_valve, k3.pb_valve, k4.pb_valve),
        a.pb_motor + rk4_increment(h, k1.pb_motor, k2.pb_motor, k3.pb_motor, k4.pb_motor),
        a.ta_valve + rk4_increment(h, k1.ta_valve, k2.ta_valve, k3.ta_valve, k4.ta_valve),
        a.ta_motor + rk4_increment(h, k1.ta_motor, k2.ta_motor, k3.ta_motor, k4.ta_motor),
        a.tb_valve + rk4_increment(h, k1.tb_valve, k2.tb_valve, k3.tb_valve, k4.tb_valve),
        a.tb_motor + rk4_increment(h, k1.tb_motor, k2.tb_motor, k3.tb_motor, k4.tb_motor),
    )


@njit
def advance_motor_side(
    x: np.ndarray,
    theta: float,
    omega: float,
    valve_gauge_pa: float,
    supply_pa: float,
    dt_s: float,
    substeps: int,
    p: np.ndarray,
) -> float:
    """Integrate a non-rigid reducer's motor side and the four node pressures over dt, in place,
    with the joint advancing linearly (theta + omega t) over the step and the valve's output held
    at `valve_gauge_pa` (as in `advance_air_pair`); return the torque the gear transmitted to the
    joint, averaged over the step (N·m: its impulse / dt).

    The plant's path for a non-rigid reducer (pneumatics/reducer.py): MuJoCo moves the joint side,
    this the motor side, J_m dw_m/dt = tau_drive - tau_t with J_m = ratio^2 J_rotor. The
    chambers follow the motor's own angle (ratio q_m). Classical RK4 in at least `substeps`
    sub-steps, more where the gear's mode (motor against the moving joint, sqrt(k / J_m)) needs
    them, with the gear's friction held in one direction over each (`motor_side_drive`,
    `stop_or_turn`); the impulse is integrated with the same weights as the motor's momentum.
    Hoses that are lines (`uses_line`) are advanced once over the step (`advance_hoses`, the motor
    turning at its starting speed), RK4's stages seeing the pressures move linearly to their ends.
    A short hose's air (`explicit_air_substeps`: faster than a sub-step follows, or than an explicit
    step stays stable in) takes its own ROS2 steps over each sub-step (`_air_ros2`, the motor turning
    at the sub-step's starting speed), RK4's stages seeing it move linearly to ROS2's result, as in
    the one-joint model (`single_joint_rk4`).
    """
    ratio = p[P.RATIO]
    j_m = ratio * ratio * p[P.ROTOR_J]
    k = stiffness(p[P.BACKLASH], p[P.COMPLIANCE])
    half = 0.5 * p[P.BACKLASH]
    stick = p[P.STICK_SPEED]
    n = substeps_for(dt_s, mode_frequency(k, j_m, 0.0), substeps)
    h = dt_s / n
    direction = x[S_DIR]
    inputs = _MotorSideInputs(omega, direction, valve_gauge_pa, supply_pa, k, damping(k, j_m), half, j_m)
    y = _MotorSide(row_air(x, S_PA_VALVE, S_TA_VALVE), x[S_QM], x[S_OMEGA_M])
    impulse = 0.0
    # hoses that are lines: advanced once over the step, the motor turning at its starting speed, and
    # RK4's stages see the four pressures move linearly to where the lines end (`single_joint_rk4`)
    line = uses_line(p)
    # a short hose: the air takes its own ROS2 steps over each sub-step, the motor turning at the
    # sub-step's starting speed, and RK4's stages see it move linearly to where they end
    m = 0 if line else explicit_air_substeps(h, p)
    held = line or m > 0
    ends = y.air
    if line:
        hs = advance_hoses(
            x[N_STATE:], ratio * y.q_m, ratio * y.w_m, direction, valve_gauge_pa, supply_pa, dt_s, p,
            y.air.ta_motor, y.air.tb_motor,
        )  # fmt: skip
        ends = _hose_ends(hs, y.air)
    secant = _air_secant(y.air, ends, dt_s)
    for i in range(n):
        th0 = theta + omega * (i * h)
        th1 = theta + omega * ((i + 0.5) * h)
        th2 = theta + omega * ((i + 1) * h)
        w0 = y.w_m
        s = _slide_direction(w0, p)
        if m > 0:
            ends = _air_ros2(y.air, ratio * y.q_m, ratio * y.w_m, direction, valve_gauge_pa, supply_pa, h / m, m, p)
            secant = _air_secant(y.air, ends, h)
        k1 = _held_air_rates(_motor_side_rates(y, th0, s, inputs, p), secant, held)
        k2 = _held_air_rates(_motor_side_stage(y, k1, 0.5 * h, th1, s, inputs, p), secant, held)
        k3 = _held_air_rates(_motor_side_stage(y, k2, 0.5 * h, th1, s, inputs, p), secant, held)
        k4 = _held_air_rates(_motor_side_stage(y, k3, h, th2, s, inputs, p), secant, held)
        # ROS2's result where it took the air, not its secant's rounding
        air = ends if m > 0 else _air_rk4(y.air, k1.air, k2.air, k3.air, k4.air, h)
        q = y.q_m + rk4_increment(h, k1.dq_m, k2.dq_m, k3.dq_m, k4.dq_m)
        w = y.w_m + rk4_increment(h, k1.dw_m, k2.dw_m, k3.dw_m, k4.dw_m)
        impulse += rk4_increment(h, k1.torque, k2.torque, k3.torque, k4.torque)
        a_m, b_m = air.pa_motor, air.pb_motor
        if s != 0.0 and s * w < 0.0:
            phi = ratio * q
            q, w = stop_or_turn(
                q, w0, w, s, joint_torque(a_m, b_m, phi, -s, p) - joint_torque(a_m, b_m, phi, s, p), j_m, h
            )
        if abs(w) < stick:
            tau_t = transmitted_torque(q - th2, w - omega, half, k, inputs.c)
            if motor_side_drive(a_m, b_m, ratio * q, w, 0.0, tau_t, p).held:
                w = 0.0
        y = _MotorSide(air, q, w)
    # the lines' ends, not their secant's rounding
    put_row_air(x, S_PA_VALVE, S_TA_VALVE, ends if line else y.air)
    x[S_QM] = y.q_m
    x[S_OMEGA_M] = y.w_m
    return impulse / dt_s


# --- the joint as a one-degree-of-freedom body: the paper's eq. 7 in full -------------------
# Rigid-body state of the one-joint model: angle (rad), speed (rad/s), the four node pressures,
# then the motor side of the reducer on the joint side (motor angle / ratio, rad; rad/s): with
# the paper's rigid reducer it is slaved to the joint (q_m = theta, w_m = w); then the four nodes'
# gas temperatures (K; constant, the supply's, with the paper's chamber law).
R_THETA, R_OMEGA, R_PA_VALVE, R_PA_MOTOR, R_PB_VALVE, R_PB_MOTOR, R_QM, R_OMEGA_M = range(8)
R_TA_VALVE, R_TA_MOTOR, R_TB_VALVE, R_TB_MOTOR = range(8, 12)
N_RIGID = 12


@njit
def initial_rigid_state(theta_rad: float, p_atm_pa: float, t_k: float = AIR.t_supply_k) -> np.ndarray:
    """One-joint state (R_* columns) at rest at `theta_rad`, air at atmosphere and at the gas's
    temperature `t_k` (its walls'), reducer untwisted: where the predictor (control/) and the replay
    of a run (gap/) start."""
    y = np.zeros(N_RIGID)
    y[R_THETA] = theta_rad
    y[R_QM] = theta_rad
    y[R_PA_VALVE] = y[R_PA_MOTOR] = y[R_PB_VALVE] = y[R_PB_MOTOR] = p_atm_pa
    y[R_TA_VALVE] = y[R_TA_MOTOR] = y[R_TB_VALVE] = y[R_TB_MOTOR] = t_k
    return y


@njit
def dry_friction_limit(brake_engagement: float, speed_rad_s: float, p: np.ndarray) -> float:
    """Joint-side dry friction in N·m at the joint's speed: Coulomb plus the Stribeck excess
    (`friction.stribeck_excess`: the static level at rest) plus the engaged part of the
    spring-applied brake."""
    return (
        p[P.COULOMB]
        + stribeck_excess(speed_rad_s, p[P.STRIBECK_EXCESS], p[P.STRIBECK_SPEED])
        + brake_holding_torque(brake_engagement, p[P.BRAKE_HOLD])
    )


@njit
def _slide_direction(speed: float, p: np.ndarray) -> float:
    # +1/-1 for a body sliding, 0 inside Karnopp's stick window
    return 0.0 if abs(speed) < p[P.STICK_SPEED] else math.copysign(1.0, speed)


class _BodyInputs(NamedTuple):
    # what the one-joint model holds over a step (`single_joint_rates`' arguments): the direction
    # valve's position, the proportional valve's output (gauge Pa), the supply (Pa, absolute), the load
    # torque (N·m), the joint-side inertia with the reflected rotor (kg·m^2), the brake's engagement
    direction: float
    valve_gauge_pa: float
    supply_pa: float
    load_torque_nm: float
    inertia_kg_m2: float
    brake_engagement: float


@njit
def _rates(
    y: np.ndarray, inputs: _BodyInputs, slide: float, slide_m: float, p: np.ndarray, out: np.ndarray
) -> tuple[bool, bool]:
    # `single_joint_rates` with the joint side's dry friction held sliding in the direction `slide`
    # (+1/-1) and a non-rigid gear's in `slide_m`, or, where 0, by Karnopp's rule at the speed in y.
    # Returns whether Karnopp's rule holds (the joint, the motor) still.
    theta = y[R_THETA]
    omega = y[R_OMEGA]
    ratio = p[P.RATIO]
    rigid = is_rigid(p)
    tau_t = 0.0
    if rigid:
        j_j = inputs.inertia_kg_m2
        phi = ratio * theta
        w_motor = ratio * omega
    else:
        j_m, j_j = inertia_split(inputs.inertia_kg_m2, ratio * ratio * p[P.ROTOR_J])
        k = stiffness(p[P.BACKLASH], p[P.COMPLIANCE])
        phi = ratio * y[R_QM]
        tau_t = transmitted_torque(y[R_QM] - theta, y[R_OMEGA_M] - omega, 0.5 * p[P.BACKLASH], k, damping(k, j_m))
        w_motor = ratio * y[R_OMEGA_M]
    rates = air_rates(
        row_air(y, R_PA_VALVE, R_TA_VALVE), phi, w_motor, inputs.direction, inputs.valve_gauge_pa, inputs.supply_pa, p
    )
    # the motor's vane torque from the geometry the rates took at the same angle (`joint_torque`)
    t_rippled = _rippled(_vane_torque_at(y[R_PA_MOTOR], y[R_PB_MOTOR], rates.slope), phi, p)
    drive = tau_t  # a non-rigid gear's transmitted torque
    if rigid:
        # a joint held sliding keeps its gear's efficiency (forward or back-driven) with its friction
        drive = _through_gear(t_rippled, slide if slide != 0.0 else omega, p)
    drive -= inputs.load_torque_nm
    coulomb = dry_friction_limit(inputs.brake_engagement, omega, p)
    joint_held = False
    if slide != 0.0:
        out[R_THETA] = omega
        out[R_OMEGA] = (drive - slide * coulomb - p[P.VISCOUS] * omega) / j_j
    elif abs(omega) < p[P.STICK_SPEED] and abs(drive) <= coulomb:
        out[R_THETA] = 0.0  # stuck: Karnopp's rule holds the joint still
        out[R_OMEGA] = 0.0
        joint_held = True
    else:
        out[R_THETA] = omega
        out[R_OMEGA] = (drive + coulomb_viscous_torque(omega, drive, coulomb, p[P.VISCOUS], p[P.STICK_SPEED])) / j_j
    motor_held = joint_held
    if rigid:
        out[R_QM] = out[R_THETA]  # the rigid reducer's motor is the joint
        out[R_OMEGA_M] = out[R_OMEGA]
    else:
        motor_drive, motor_held = _motor_side_drive_of(t_rippled, y[R_OMEGA_M], slide_m, tau_t, p)
        if motor_held:
            out[R_QM] = 0.0
            out[R_OMEGA_M] = 0.0
        else:
            out[R_QM] = y[R_OMEGA_M]
            out[R_OMEGA_M] = (motor_drive - tau_t) / j_m
    put_row_air(out, R_PA_VALVE, R_TA_VALVE, _air_slopes(rates))
    return joint_held, motor_held


@njit
def single_joint_rates(
    y: np.ndarray,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    load_torque_nm: float,
    inertia_kg_m2: float,
    brake_engagement: float,
    p: np.ndarray,
    out: np.ndarray,
) -> None:
    """Time derivative of the one-joint state y (paper eq. 7), written into `out`.

    J dw/dt = T_drive - T_load + T_friction, with T_drive from `joint_torque`, the load torque
    (gravity and payload on this joint; the predictor takes it from Pinocchio) and Coulomb +
    viscous friction by Karnopp's rule, the engaged part of the brake adding to the Coulomb level
    (`dry_friction_limit`). `inertia_kg_m2` is the joint-side inertia including the reflected rotor.

    With a non-rigid reducer (pneumatics/reducer.py) the motor side moves on its own,
    J_m dw_m/dt = T_drive - T_t with T_drive at the motor's angle and speed, and the joint side
    gets the transmitted T_t in place of T_drive (Karnopp's rule then decides on T_t); J_m and the
    joint side's J_j split `inertia_kg_m2` (`reducer.inertia_split`). With the rigid reducer the
    motor side's rates are the joint's.
    """
    inputs = _BodyInputs(direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement)
    _rates(y, inputs, _slide_direction(y[R_OMEGA], p), _slide_direction(y[R_OMEGA_M], p), p, out)


@njit(inline="always")
def _held_air(rates: np.ndarray, secant: AirState, held: bool) -> None:
    # an RK4 stage's air rates (R_* columns) replaced by the air's secant over the sub-step
    # (`single_joint_rk4`)
    if held:
        put_row_air(rates, R_PA_VALVE, R_TA_VALVE, secant)


@njit
def single_joint_rk4(
    y: np.ndarray,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
    load_torque_nm: float,
    inertia_kg_m2: float,
    brake_engagement: float,
    dt_s: float,
    p: np.ndarray,
    lines: np.ndarray,
) -> None:
    """Classical Runge-Kutta over dt of `single_joint_rates`, in place (the paper integrates its
    predictor with Runge-Kutta, Sec. III-B), right at every stop.

    Dry friction is where a fixed step lies (DESIGN rule 8): a braked joint (115 N·m on
    0.164 kg·m^2: 0.7 rad/s per 1 ms step) has stages on both sides of zero speed, and friction
    that flips sign between them drives a slowing joint on instead of stopping it. So each body's
    dry friction (the joint's Coulomb + brake; a non-rigid gear's efficiency on the motor side)
    keeps the direction it slides in at the sub-step's start through all four stages; a speed that
    crosses zero inside the sub-step is then set right at the crossing (`stop_or_turn`): stopped
    there, or turned round by what friction leaves. From rest Karnopp's rule decides.

    The rigid reducer takes one sub-step; a non-rigid one as many as its two-mass mode needs
    (`reducer.substeps_for`).

    `lines`: the hoses' lines when they are (`uses_line`; the joint state row's columns after
    N_STATE, advanced in place), else unused (may be empty). A line's nodes and sub-steps cannot sit
    inside RK4's stages: the lines are advanced once per sub-step (`advance_hoses`, the motor
    turning at the sub-step's starting speed) and the stages see the air move linearly to where
    they end, as a short hose's ROS2 steps are; the four node pressures end at the lines' ends.

    Kept whole, as `_rates` and `advance_motor_side` are: split into compiled steps (the sub-step,
    the crossing corrections, Karnopp's hold; inlined or not) the replay of a 20-cycle stop-and-go
    run measured 5-12 % slower a step (2.66-2.75 against 2.80-3.10 µs rigid, best of 7,
    interleaved), for the same bits.
    """
    ratio = p[P.RATIO]
    rigid = is_rigid(p)
    n = 1
    j_m, j_j = inertia_kg_m2, inertia_kg_m2
    if not rigid:
        j_m, j_j = inertia_split(inertia_kg_m2, ratio * ratio * p[P.ROTOR_J])
        n = substeps_for(dt_s, mode_frequency(stiffness(p[P.BACKLASH], p[P.COMPLIANCE]), j_m, 1.0 / j_j), 1)
    h = dt_s / n
    static = dry_friction_limit(brake_engagement, 0.0, p)  # what turns a joint round where its speed crosses zero
    k1 = np.empty(N_RIGID)
    k2 = np.empty(N_RIGID)
    k3 = np.empty(N_RIGID)
    k4 = np.empty(N_RIGID)
    tmp = np.empty(N_RIGID)
    # a short hose's air (`explicit_air_substeps`) rings or diverges in RK4's explicit stages: it takes
    # its own ROS2 steps with the motor turning at the sub-step's starting speed, and the stages see
    # it move linearly to where they end (their air rates the secant), so RK4 gives the body the air's
    # path and the air ROS2's result
    m = explicit_air_substeps(h, p)
    line = uses_line(p)
    air_ros2 = line or m > 0
    inputs = _BodyInputs(direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement)
    secant = AirState(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # the air's secant over a sub-step, when air_ros2
    for _ in range(n):
        w0 = y[R_OMEGA]
        wm0 = y[R_OMEGA_M]
        s = _slide_direction(w0, p)
        s_m = s if rigid else _slide_direction(wm0, p)
        if air_ros2:
            # the air after the sub-step: the lines' ends, or the ROS2 steps' result; the stages take
            # its secant
            start = row_air(y, R_PA_VALVE, R_TA_VALVE)
            if line:
                hs = advance_hoses(
                    lines, ratio * y[R_QM], ratio * y[R_OMEGA_M], direction, valve_gauge_pa, supply_pa, h, p,
                    start.ta_motor, start.tb_motor,
                )  # fmt: skip
                end = _hose_ends(hs, start)
            else:
                end = _air_ros2(
                    start, ratio * y[R_QM], ratio * y[R_OMEGA_M], direction, valve_gauge_pa, supply_pa, h / m, m, p
                )
            secant = _air_secant(start, end, h)
        _rates(y, inputs, s, s_m, p, k1)
        _held_air(k1, secant, air_ros2)
        for i in range(N_RIGID):
            tmp[i] = y[i] + 0.5 * h * k1[i]
        _rates(tmp, inputs, s, s_m, p, k2)
        _held_air(k2, secant, air_ros2)
        for i in range(N_RIGID):
            tmp[i] = y[i] + 0.5 * h * k2[i]
        _rates(tmp, inputs, s, s_m, p, k3)
        _held_air(k3, secant, air_ros2)
        for i in range(N_RIGID):
            tmp[i] = y[i] + h * k3[i]
        _rates(tmp, inputs, s, s_m, p, k4)
        _held_air(k4, secant, air_ros2)
        for i in range(N_RIGID):
            y[i] += rk4_increment(h, k1[i], k2[i], k3[i], k4[i])
        if line:
            put_row_air(y, R_PA_VALVE, R_TA_VALVE, end)  # the lines' ends, not their secant's rounding
        if s != 0.0 and s * y[R_OMEGA] < 0.0:
            jump = 2.0 * s * static
            if rigid:  # the gear's efficiency turns with the joint
                phi = ratio * y[R_THETA]
                jump += joint_torque(y[R_PA_MOTOR], y[R_PB_MOTOR], phi, -s, p) - joint_torque(
                    y[R_PA_MOTOR], y[R_PB_MOTOR], phi, s, p
                )
            y[R_THETA], y[R_OMEGA] = stop_or_turn(y[R_THETA], w0, y[R_OMEGA], s, jump, j_j, h)
        if not rigid and s_m != 0.0 and s_m * y[R_OMEGA_M] < 0.0:
            phi = ratio * y[R_QM]
            jump = joint_torque(y[R_PA_MOTOR], y[R_PB_MOTOR], phi, -s_m, p) - joint_torque(
                y[R_PA_MOTOR], y[R_PB_MOTOR], phi, s_m, p
            )
            y[R_QM], y[R_OMEGA_M] = stop_or_turn(y[R_QM], wm0, y[R_OMEGA_M], s_m, jump, j_m, h)
        if rigid:
            y[R_QM] = y[R_THETA]  # the rigid reducer's motor is the joint
            y[R_OMEGA_M] = y[R_OMEGA]
        if abs(y[R_OMEGA]) < p[P.STICK_SPEED] or abs(y[R_OMEGA_M]) < p[P.STICK_SPEED]:
            # Karnopp: a body that has come to rest and is not pushed past its friction stays put
            joint_held, motor_held = _rates(y, inputs, 0.0, 0.0, p, tmp)
            if joint_held:
                y[R_OMEGA] = 0.0
            if motor_held:
                y[R_OMEGA_M] = 0.0


@njit
def single_joint_step(
    y: np.ndarray,
    x: np.ndarray,
    command: np.ndarray,
    valve_gauge_pa: float,
    supply_pa: float,
    load_torque_nm: float,
    inertia_kg_m2: float,
    dt_s: float,
    p: np.ndarray,
) -> None:
    """The one-joint model over dt after its valves have advanced (`advance_discrete`): the rigid
    body and the air by RK4 (`single_joint_rk4`) with the brake at its mean over the step
    (`brake_over_step`), the joint's end stops (`at_the_stops`), then the brake along what its air
    gave over the step (`advance_brake`). In place on y and x (with its hoses' lines, `with_hoses`)."""
    pa = y[R_PA_MOTOR]
    pb = y[R_PB_MOTOR]
    if x.shape[0] < N_STATE + hose_state_size(p):
        raise ValueError("single_joint_step: the joint's hoses are lines; its state row must hold them (with_hoses)")
    brake = brake_over_step(x, command, supply_pa, pa, pb, dt_s, p)
    single_joint_rk4(y, x[S_DIR], valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake, dt_s, p, x[N_STATE:])
    at_the_stops(y, p)
    advance_brake(x, command, supply_pa, pa, pb, y[R_PA_MOTOR], y[R_PB_MOTOR], dt_s, p)


@njit(inline="always")
def at_the_stops(y: np.ndarray, p: np.ndarray) -> None:
    """An inelastic end stop (the row's STOP_LOW/STOP_HIGH): a step that carried the joint past one
    ends on it, its speed into the stop gone. The rig's stiff joint limits do the same (MuJoCo's
    limit constraint, `solreflimit` 0.001 s: assets/wrist_rig.xml), so a joint driven home against
    its stop is predicted and replayed there, not turning on past it. (The arm's MJCF keeps
    MuJoCo's soft limits, a 20 ms bumper: its joints rest a little past the range under the motor's
    stall torque; docs/validation/plant.md, "End stops".)"""
    if y[R_THETA] > p[P.STOP_HIGH]:
        y[R_THETA] = p[P.STOP_HIGH]
        y[R_OMEGA] = min(y[R_OMEGA], 0.0)
    elif y[R_THETA] < p[P.STOP_LOW]:
        y[R_THETA] = p[P.STOP_LOW]
        y[R_OMEGA] = max(y[R_OMEGA], 0.0)
