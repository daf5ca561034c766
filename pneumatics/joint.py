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
With hose_loss = 0 the two nodes are one volume (the paper's model without pressure loss).

State of a joint (a float64 row, see the S_* columns): four node pressures (Pa, absolute), the
proportional valve's output pressure (Pa, gauge), the brake's engagement, the direction
valve's effective position, pending position and time left until it switches, and the same three
for the proportional valve's set point (used only with a set-point dead time, a gap effect).
"""

from __future__ import annotations

import math

import numpy as np

from pneumatics import params as P
from pneumatics._jit import njit
from pneumatics.brake import brake_feed_gauge_pa, brake_step, brake_target
from pneumatics.chamber import chamber_pressure_rate
from pneumatics.friction import coulomb_viscous_torque, reducer_output_torque, stribeck_excess_torque
from pneumatics.gas import isentropic_temperature
from pneumatics.hose import hose_mass_flow, hose_volume
from pneumatics.motor import chamber_geometry, vane_torque
from pneumatics.orifice import orifice_mass_flow
from pneumatics.valves import dead_time_step, lag_toward, proportional_valve_target, regulated_pressure, solenoid_step, valve_opening

S_PA_VALVE, S_PA_MOTOR, S_PB_VALVE, S_PB_MOTOR, S_PV, S_BRAKE, S_DIR, S_DIR_PENDING, S_DIR_REMAINING, S_PV_SET, S_PV_SET_PENDING, S_PV_SET_REMAINING = range(12)
N_STATE = 12

# commands the platform sends to a joint (a float64 row)
C_DIRECTION, C_PV_SET_GAUGE_PA, C_BRAKE_RELEASE = range(3)
N_COMMAND = 3


def initial_state(p_atm_pa: float, brake_engaged: bool = True) -> np.ndarray:
    """A joint at rest: every node at atmospheric pressure, valves closed, brake as given."""
    x = np.zeros(N_STATE)
    x[S_PA_VALVE] = x[S_PA_MOTOR] = x[S_PB_VALVE] = x[S_PB_MOTOR] = p_atm_pa
    x[S_BRAKE] = 1.0 if brake_engaged else 0.0
    return x


@njit
def effective_supply(supply_pa: float, opening: float, direction: float, p: np.ndarray) -> float:
    """Supply pressure at the valve after the droop of the supply line under the joint's draw.

    The draw is estimated as the choked flow through the open inlet (one explicit pass; the gap
    catalogue's "supply droop under flow"). Zero droop for the nominal joint.
    """
    if p[P.DROOP] == 0.0 or direction == 0.0:
        return supply_pa
    area = p[P.A_IN] * p[P.COND_SCALE] * opening
    m_max = orifice_mass_flow(supply_pa, 0.0, area, p[P.GAS_T], p[P.GAS_R], p[P.GAS_K])
    return max(p[P.GAS_P_ATM], supply_pa - p[P.DROOP] * m_max)


@njit
def _port_valve_flow(p_node: float, supplied: bool, supply_pa: float, inlet_area: float, p: np.ndarray) -> float:
    # mass flow into a port's valve node from the supply (through the proportional valve) or
    # from the atmosphere (through the exhaust throttle; negative when exhausting)
    r = p[P.GAS_R]
    k = p[P.GAS_K]
    if supplied:
        return orifice_mass_flow(supply_pa, p_node, inlet_area, p[P.GAS_T], r, k)
    return orifice_mass_flow(p[P.GAS_P_ATM], p_node, p[P.A_EX] * p[P.COND_SCALE], p[P.GAS_T], r, k)


@njit
def _hose_flow(p_valve: float, p_motor: float, supply_pa: float, p: np.ndarray) -> float:
    # mass flow valve node -> motor node. Air leaving the motor has expanded from the supply
    # pressure and is colder (paper eq. 2); the hose's mean temperature is T_m = (T_B + T_o)/2
    # with its far end T_o at supply temperature (paper eq. 1).
    t_s = p[P.GAS_T]
    t_mean = t_s
    if p_motor > p_valve and p_motor < supply_pa:
        t_mean = 0.5 * (isentropic_temperature(p_motor, supply_pa, t_s, p[P.POLY_N]) + t_s)
    return hose_mass_flow(p_valve, p_motor, t_mean, p[P.HOSE_L], p[P.HOSE_D], p[P.GAS_R], p[P.GAS_MU])


@njit
def pressure_rates(pa_valve: float, pa_motor: float, pb_valve: float, pb_motor: float, phi_motor: float, omega_motor: float, direction: float, valve_gauge_pa: float, supply_pa: float, p: np.ndarray) -> tuple[float, float, float, float]:
    """Rates (Pa/s) of the four node pressures, paper eq. 7 rows 3-4 with the hose on both ports.

    `direction` +1 pressurises port A (motor turns positive), -1 port B, 0 exhausts both.
    `valve_gauge_pa` is the proportional valve's output pressure P_v: the pressure it delivers
    (capped by the absolute `supply_pa`) and, through u = k_u P_v, its opening (paper Sec. IV).
    """
    r = p[P.GAS_R]
    t_s = p[P.GAS_T]
    n = p[P.POLY_N]
    opening = valve_opening(valve_gauge_pa, p[P.K_U], p[P.DEAD_ZONE])
    p_s = regulated_pressure(effective_supply(supply_pa, opening, direction, p), valve_gauge_pa, p[P.GAS_P_ATM])
    inlet_area = p[P.A_IN] * p[P.COND_SCALE] * opening
    m_a_valve = _port_valve_flow(pa_valve, direction > 0.0, p_s, inlet_area, p)
    m_b_valve = _port_valve_flow(pb_valve, direction < 0.0, p_s, inlet_area, p)

    v_a, v_b, slope = chamber_geometry(phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V])
    dv_a = slope * omega_motor
    m_leak = orifice_mass_flow(pa_motor, pb_motor, p[P.LEAK_A], t_s, r, p[P.GAS_K])  # A -> B past the vanes
    # a leak in port A's hose (a fault) vents at the hose's valve end
    m_a_valve -= orifice_mass_flow(pa_valve, p[P.GAS_P_ATM], p[P.HOSE_LEAK_A], t_s, r, p[P.GAS_K])
    half_hose = 0.5 * hose_volume(p[P.HOSE_L], p[P.HOSE_D])

    if p[P.HOSE_LOSS] == 0.0:
        # one node per port: motor chamber + porting + the whole hose
        da = chamber_pressure_rate(pa_motor, v_a + 2.0 * half_hose, dv_a, m_a_valve - m_leak, t_s, r, n)
        db = chamber_pressure_rate(pb_motor, v_b + 2.0 * half_hose, -dv_a, m_b_valve + m_leak, t_s, r, n)
        return da, da, db, db

    m_a_hose = _hose_flow(pa_valve, pa_motor, p_s, p)
    m_b_hose = _hose_flow(pb_valve, pb_motor, p_s, p)
    return (
        chamber_pressure_rate(pa_valve, half_hose, 0.0, m_a_valve - m_a_hose, t_s, r, n),
        chamber_pressure_rate(pa_motor, v_a + half_hose, dv_a, m_a_hose - m_leak, t_s, r, n),
        chamber_pressure_rate(pb_valve, half_hose, 0.0, m_b_valve - m_b_hose, t_s, r, n),
        chamber_pressure_rate(pb_motor, v_b + half_hose, -dv_a, m_b_hose + m_leak, t_s, r, n),
    )


@njit
def joint_torque(pa_motor: float, pb_motor: float, phi_motor: float, omega_joint: float, p: np.ndarray) -> float:
    """Joint-side drive torque in N·m: vane torque through the reducer (eq. 6, 7 row 2).

    With `ripple_fraction` > 0 the vane torque carries a ripple at the vane-passing frequency
    (an effect outside the paper's model, used by the gap bench).
    """
    t_motor = vane_torque(pa_motor, pb_motor, phi_motor, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES])
    if p[P.RIPPLE] != 0.0:
        t_motor *= 1.0 + p[P.RIPPLE] * math.cos(p[P.N_VANES] * phi_motor)
    return reducer_output_torque(t_motor, omega_joint, p[P.RATIO], p[P.ETA_F], p[P.ETA_B])


@njit
def advance_discrete(x: np.ndarray, command: np.ndarray, supply_pa: float, dt_s: float, p: np.ndarray) -> None:
    """Advance the valves of one joint over dt, in place (exact for held inputs)."""
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
    x[S_PV] = lag_toward(x[S_PV], target, dt_s, p[P.VALVE_TAU])


@njit
def advance_brake(x: np.ndarray, command: np.ndarray, supply_pa: float, pa_motor_pa: float, pb_motor_pa: float, dt_s: float, p: np.ndarray) -> None:
    """Advance the brake's engagement over dt, in place, toward the target its air gives now.

    The brake's air is the supply or the higher motor-end port pressure (`brake_feed_gauge_pa`):
    the caller passes the motor-node pressures it has just integrated over the step (the plant's
    or the predictor's own), so the brake follows them without a step's lag.
    """
    feed = brake_feed_gauge_pa(p[P.BRAKE_FED_BY_MOTOR], supply_pa, pa_motor_pa, pb_motor_pa, p[P.GAS_P_ATM])
    engage = brake_target(command[C_BRAKE_RELEASE], feed, p[P.BRAKE_START_PA], p[P.BRAKE_RELEASE_PA])
    x[S_BRAKE] = brake_step(x[S_BRAKE], engage, p[P.BRAKE_TAU_ON], p[P.BRAKE_TAU_OFF], dt_s)


@njit
def at_rest(x: np.ndarray, omega: float, p: np.ndarray) -> bool:
    """True when the joint stands (nearly) still, its air is all at atmosphere and its direction valve is
    closed: nothing can change its pressures. (A joint moving without air still pumps it.)"""
    atm = p[P.GAS_P_ATM]
    return (
        x[S_DIR] == 0.0
        and abs(omega) < p[P.STICK_SPEED]
        and abs(x[S_PA_VALVE] - atm) < 1e-6
        and abs(x[S_PA_MOTOR] - atm) < 1e-6
        and abs(x[S_PB_VALVE] - atm) < 1e-6
        and abs(x[S_PB_MOTOR] - atm) < 1e-6
    )


@njit
def advance_pressures(x: np.ndarray, theta: float, omega: float, supply_pa: float, dt_s: float, substeps: int, p: np.ndarray) -> None:
    """Integrate the four node pressures over dt with the joint moving at constant speed, in place.

    Heun's method (explicit trapezoid) in `substeps` sub-steps; the motor angle advances with
    the joint inside the step so that the quarter-turn chamber switching is resolved.
    """
    if at_rest(x, omega, p):
        return
    valve = x[S_PV]
    direction = x[S_DIR]
    ratio = p[P.RATIO]
    h = dt_s / substeps
    w_m = ratio * omega
    a_v = x[S_PA_VALVE]
    a_m = x[S_PA_MOTOR]
    b_v = x[S_PB_VALVE]
    b_m = x[S_PB_MOTOR]
    for i in range(substeps):
        phi0 = ratio * (theta + omega * i * h)
        k1 = pressure_rates(a_v, a_m, b_v, b_m, phi0, w_m, direction, valve, supply_pa, p)
        k2 = pressure_rates(a_v + h * k1[0], a_m + h * k1[1], b_v + h * k1[2], b_m + h * k1[3], phi0 + w_m * h, w_m, direction, valve, supply_pa, p)
        a_v += 0.5 * h * (k1[0] + k2[0])
        a_m += 0.5 * h * (k1[1] + k2[1])
        b_v += 0.5 * h * (k1[2] + k2[2])
        b_m += 0.5 * h * (k1[3] + k2[3])
    x[S_PA_VALVE] = a_v
    x[S_PA_MOTOR] = a_m
    x[S_PB_VALVE] = b_v
    x[S_PB_MOTOR] = b_m


# --- the joint as a one-degree-of-freedom body: the paper's eq. 7 in full -------------------
# Rigid state of the one-joint model: angle (rad), speed (rad/s), then the four node pressures.
R_THETA, R_OMEGA, R_PA_VALVE, R_PA_MOTOR, R_PB_VALVE, R_PB_MOTOR = range(6)
N_RIGID = 6


@njit
def single_joint_rates(y: np.ndarray, direction: float, valve_gauge_pa: float, supply_pa: float, load_torque_nm: float, inertia_kg_m2: float, brake_engagement: float, p: np.ndarray, out: np.ndarray) -> None:
    """Time derivative of the one-joint state y (paper eq. 7), written into `out`.

    J dw/dt = T_drive - T_load + T_friction, with T_drive from `joint_torque`, the load torque
    (gravity and payload on this joint; the predictor takes it from Pinocchio) and Coulomb +
    viscous friction by Karnopp's rule, the engaged part of the brake adding to the Coulomb level.
    `inertia_kg_m2` is the joint-side inertia including the reflected rotor.
    """
    theta = y[R_THETA]
    omega = y[R_OMEGA]
    phi = p[P.RATIO] * theta
    drive = joint_torque(y[R_PA_MOTOR], y[R_PB_MOTOR], phi, omega, p) - load_torque_nm
    drive += stribeck_excess_torque(omega, p[P.STRIBECK_EXCESS], p[P.STRIBECK_SPEED], 0.5 * p[P.STRIBECK_SPEED])
    coulomb = p[P.COULOMB] + brake_engagement * p[P.BRAKE_HOLD]
    friction = coulomb_viscous_torque(omega, drive, coulomb, p[P.VISCOUS], p[P.STICK_SPEED])
    if abs(omega) < p[P.STICK_SPEED] and abs(drive) <= coulomb:
        out[R_THETA] = 0.0  # stuck: Karnopp's rule holds the joint still
        out[R_OMEGA] = 0.0
    else:
        out[R_THETA] = omega
        out[R_OMEGA] = (drive + friction) / inertia_kg_m2
    rates = pressure_rates(y[R_PA_VALVE], y[R_PA_MOTOR], y[R_PB_VALVE], y[R_PB_MOTOR], phi, p[P.RATIO] * omega, direction, valve_gauge_pa, supply_pa, p)
    out[R_PA_VALVE] = rates[0]
    out[R_PA_MOTOR] = rates[1]
    out[R_PB_VALVE] = rates[2]
    out[R_PB_MOTOR] = rates[3]


@njit
def single_joint_rk4(y: np.ndarray, direction: float, valve_gauge_pa: float, supply_pa: float, load_torque_nm: float, inertia_kg_m2: float, brake_engagement: float, dt_s: float, p: np.ndarray) -> None:
    """One classical Runge-Kutta step of `single_joint_rates` over dt, in place (the paper
    integrates its predictor with Runge-Kutta, Sec. III-B)."""
    k1 = np.empty(N_RIGID)
    k2 = np.empty(N_RIGID)
    k3 = np.empty(N_RIGID)
    k4 = np.empty(N_RIGID)
    tmp = np.empty(N_RIGID)
    single_joint_rates(y, direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement, p, k1)
    for i in range(N_RIGID):
        tmp[i] = y[i] + 0.5 * dt_s * k1[i]
    single_joint_rates(tmp, direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement, p, k2)
    for i in range(N_RIGID):
        tmp[i] = y[i] + 0.5 * dt_s * k2[i]
    single_joint_rates(tmp, direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement, p, k3)
    for i in range(N_RIGID):
        tmp[i] = y[i] + dt_s * k3[i]
    single_joint_rates(tmp, direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement, p, k4)
    omega_before = y[R_OMEGA]
    for i in range(N_RIGID):
        y[i] += dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    if omega_before * y[R_OMEGA] < 0.0:
        # the speed crossed zero inside the step: friction brought the joint to rest there. Restart
        # from rest so Karnopp's rule decides; otherwise a braked joint (115 N·m on 0.164 kg·m^2:
        # 0.7 rad/s per 1 ms step, far outside the stick window) chatters through zero and creeps.
        y[R_OMEGA] = 0.0
    if abs(y[R_OMEGA]) < p[P.STICK_SPEED]:
        # Karnopp: a joint that has come to rest and is not pushed past friction stays put
        single_joint_rates(y, direction, valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, brake_engagement, p, tmp)
        if tmp[R_THETA] == 0.0:
            y[R_OMEGA] = 0.0


@njit
def single_joint_step(y: np.ndarray, x: np.ndarray, command: np.ndarray, valve_gauge_pa: float, supply_pa: float, load_torque_nm: float, inertia_kg_m2: float, dt_s: float, p: np.ndarray) -> None:
    """The one-joint model over dt after its valves have advanced (`advance_discrete`): the rigid
    body and the air by RK4 (`single_joint_rk4`) with the brake held, then the brake toward what
    its air gives at the step's end (`advance_brake`). In place on y and x."""
    single_joint_rk4(y, x[S_DIR], valve_gauge_pa, supply_pa, load_torque_nm, inertia_kg_m2, x[S_BRAKE], dt_s, p)
    advance_brake(x, command, supply_pa, y[R_PA_MOTOR], y[R_PB_MOTOR], dt_s, p)
