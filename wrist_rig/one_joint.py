"""Replay a run's commands through the one-joint model (paper eq. 7), compiled in one loop.

The model is `pneumatics.joint.single_joint_step` (the predictor's model) driven
by the run's own command rows: per 1 ms step the valves advance with `advance_discrete`
(solenoid delay, proportional valve lag), then the rigid body (with the motor side of a
non-rigid reducer) and the four node pressures take one RK4 step and the brake follows its air.
The whole run is one @njit call, so a run of a few seconds replays in a few ms
and the effect search can afford thousands of replays.

The joint's end stops are the parameter row's (`params_row(..., stops=...)`: its MJCF range, stiff
there, assets/wrist_rig.xml): the one-joint model ends a step that carries the joint past one on it
(`pneumatics.joint.at_the_stops`), so a run that homes against a stop is replayed as the plant and
the rig run it, not as a joint turning on past it; the predictor does the same.
"""

from __future__ import annotations

import numpy as np

from pneumatics import params as P
from pneumatics._jit import njit
from pneumatics.joint import (
    C_BRAKE_RELEASE,
    C_DIRECTION,
    C_PV_SET_GAUGE_PA,
    N_COMMAND,
    R_OMEGA,
    R_PA_MOTOR,
    R_PB_MOTOR,
    R_THETA,
    S_PV,
    advance_discrete,
    initial_rigid_state,
    initial_state,
    single_joint_step,
    with_hoses,
)

DT_S = 1e-3  # integration step: the platform's 1 ms control period (DESIGN: RK4 at 1 ms is within 0.01 deg)


@njit
def _interpolated(times: np.ndarray, values: np.ndarray, t: float, row: int) -> float:
    # values linearly interpolated at t (>= times[row]), held after the last sample
    n = times.shape[0]
    while row + 1 < n and times[row + 1] <= t + 1e-9:
        row += 1
    if row + 1 < n:
        w = (t - times[row]) / (times[row + 1] - times[row])
        return (1.0 - w) * values[row] + w * values[row + 1]
    return values[row]


@njit(inline="always")
def _trajectory(n: int, theta0_rad: float, atm: float):
    """(t, theta, omega, p_a, p_b) of n samples, the first at rest at theta0 and atmospheric pressure."""
    t, th, om, pa, pb = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    t[0], th[0], om[0], pa[0], pb[0] = 0.0, theta0_rad, 0.0, atm, atm
    return t, th, om, pa, pb


@njit(inline="always")
def _hold_command(
    cmd: np.ndarray,
    row: int,
    t: float,
    cmd_time_s: np.ndarray,
    direction: np.ndarray,
    valve_gauge_pa: np.ndarray,
    brake_release: np.ndarray,
) -> int:
    """The row in force at t (zero-order hold, searched from `row` on), its commands written into cmd."""
    n_rows = cmd_time_s.shape[0]
    while row + 1 < n_rows and cmd_time_s[row + 1] <= t + 1e-9:
        row += 1
    cmd[C_DIRECTION] = direction[row]
    cmd[C_PV_SET_GAUGE_PA] = valve_gauge_pa[row]
    cmd[C_BRAKE_RELEASE] = brake_release[row]
    return row


@njit(inline="always")
def _logged_valve(x: np.ndarray, cmd_time_s: np.ndarray, valve_gauge_pa: np.ndarray, t: float, dt_s: float, row: int):
    """The valve output over the step from t as logged: the state ends at the logged value and the
    step holds its mean (trapezoid), as the plant does."""
    x[S_PV] = _interpolated(cmd_time_s, valve_gauge_pa, t + dt_s, row)
    return 0.5 * (_interpolated(cmd_time_s, valve_gauge_pa, t, row) + x[S_PV])


@njit(nogil=True)
def replay_run(
    p: np.ndarray,  # params_row of the twin's joint
    cmd_time_s: np.ndarray,  # (n,) times of the command rows, increasing
    direction: np.ndarray,  # (n,) -1/0/+1
    valve_gauge_pa: np.ndarray,  # (n,) proportional valve set point (or output, see below), gauge Pa
    brake_release: np.ndarray,  # (n,) 0/1
    supply_pa: np.ndarray,  # (n,) absolute supply pressure
    valve_is_output: bool,
    theta0_rad: float,
    inertia_kg_m2: float,
    load_torque_nm: float,
    t_end_s: float,
    dt_s: float,
    load_spring_nm_per_rad: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Twin angle, speed and motor-chamber pressures on a grid t_k = k dt, k = 0..floor(t_end/dt);
    returns (t, theta, omega, p_a, p_b) with the pressures absolute at the motor end of each hose.

    Commands are held from one row to the next (zero-order hold, as the platform sends them).
    With valve_is_output False (a command log) valve_gauge_pa is the proportional valve's set
    point, so the valve's lag, supply cap and dead zone act on it as they do on the real platform.
    With valve_is_output True (the twin's own MCAP log, whose valve_gauge_pa is the valve's OUTPUT
    pressure) the valve state S_PV is set from the logged output, linearly interpolated between log
    samples (it is a continuous state), so the valve lag is not applied a second time; the dead
    zone still acts on it.

    The load on the joint (a torque toward negative angles) is `load_torque_nm +
    load_spring_nm_per_rad * theta` (the static load the same at every angle, and a spring pulling
    back to 0: the gap diagnosis's static_load and angle_load), taken at each step's start and held over it
    (the one-joint model takes its load as a constant per step; over 1 ms the joint turns at most
    ~3 mrad, a 0.3 % change of the load at 1 rad).

    The joint stops at the row's end stops (`pneumatics.joint.at_the_stops`; none by default).
    """
    n_steps = int(t_end_s / dt_s + 1e-9)
    atm = p[P.GAS_P_ATM]
    t_out, th_out, om_out, pa_out, pb_out = _trajectory(n_steps + 1, theta0_rad, atm)
    x = with_hoses(initial_state(atm, True, 0.0, p[P.GAS_T]), p)  # the hoses' lines with hose_model = 1
    y = initial_rigid_state(theta0_rad, atm, p[P.GAS_T])
    cmd = np.zeros(N_COMMAND)
    row = 0
    for k in range(n_steps):
        t = k * dt_s
        load_nm = load_torque_nm + load_spring_nm_per_rad * y[R_THETA]  # opposes the drive: k theta pulls back to 0
        row = _hold_command(cmd, row, t, cmd_time_s, direction, valve_gauge_pa, brake_release)
        s = supply_pa[row]
        valve = advance_discrete(x, cmd, s, dt_s, p)
        if valve_is_output:
            valve = _logged_valve(x, cmd_time_s, valve_gauge_pa, t, dt_s, row)
        single_joint_step(y, x, cmd, valve, s, load_nm, inertia_kg_m2, dt_s, p)
        t_out[k + 1] = (k + 1) * dt_s
        th_out[k + 1] = y[R_THETA]
        om_out[k + 1] = y[R_OMEGA]
        pa_out[k + 1] = y[R_PA_MOTOR]
        pb_out[k + 1] = y[R_PB_MOTOR]
    return t_out, th_out, om_out, pa_out, pb_out
