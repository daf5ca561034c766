"""PID on the predicted angle (paper Fig. 17) with anti-windup, and the valve/brake sequencing of a move.

The PID's output is a signed proportional-valve set point in gauge Pa: its sign picks the direction
valve (+1 pressurises port A, turning the joint positive), its magnitude (capped at the set point
that opens the valve fully, 1/k_u) the proportional valve. Anti-windup: conditional integration
(the integral stops growing while the output is saturated in the direction of the error) and a
clamp on the integral's contribution.

Move modes of a joint (one integer per joint):
  IDLE     brake engaged, valves shut, nothing to do;
  CLOSED   closed loop toward the target, brake released;
  SETTLE   arrived (|error| < tolerance, predicted speed small): valves shut, brake engaging; once
           the prediction stands still the joint is done, or moves again if the coast carried it
           more than `retry_tolerance` off (at most `max_retries` times);
  OPEN     open loop: valve open for a fixed time (control/open_loop.py), then SETTLE without retry.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pneumatics import params as P
from pneumatics._jit import borrowed, njit
from pneumatics.joint import C_BRAKE_RELEASE, C_DIRECTION, C_PV_SET_GAUGE_PA, R_OMEGA, R_THETA, S_BRAKE, S_DIR

IDLE, CLOSED, SETTLE, OPEN = 0, 1, 2, 3
# per-tick outcome of a joint's move
BUSY, ARRIVED, TIMED_OUT = 0, 1, 2


class PidGains(NamedTuple):
    """Gains and rules of the loop, SI. Defaults tuned on the wrist rig (tests/test_control.py)."""

    kp_pa_per_rad: float = 1.5e6  # full opening (5.1e5 Pa set point) at ~20 deg of error
    ki_pa_per_rad_s: float = 3.0e5  # pushes a joint stalled short of the target on
    kd_pa_s_per_rad: float = 1.5e5  # 0.1 s of predicted speed: brakes the approach (valve lag 0.1 s)
    integral_limit_pa: float = 2.5e5  # anti-windup clamp on ki * integral
    tolerance_rad: float = math.radians(0.5)  # arrival band
    arrival_speed_rad_s: float = math.radians(5.0)  # "predicted speed small"
    retry_tolerance_rad: float = math.radians(1.0)  # re-move if the coast ends farther than this
    max_retries: float = 3.0
    # floor of the set point while moving, as a multiple of the joint's breakaway pressure (the
    # valve pressure whose stall torque equals Coulomb friction plus the predicted load): below
    # it the motor cannot move the joint, the loop would only wind up (0: no floor). A brake fed
    # by the motor's port (pneumatics/brake.py) also floors it at its full-release pressure.
    breakaway_margin: float = 1.2


def gains_row(g: PidGains) -> np.ndarray:
    return np.array(tuple(g), dtype=np.float64)


G_KP, G_KI, G_KD, G_ILIM, G_TOL, G_VARR, G_RETRY, G_MAXRETRY, G_MARGIN = range(9)


@njit
def pid_output(
    error: float, omega: float, integral: float, dt_s: float, g: np.ndarray, pv_full: float
) -> tuple[float, float]:
    """Signed set point (gauge Pa) and the updated integral (rad·s), with conditional integration."""
    ki = g[G_KI]
    u_pd = g[G_KP] * error - g[G_KD] * omega
    new_integral = integral + error * dt_s
    if ki > 0.0:
        lim = g[G_ILIM] / ki
        new_integral = min(lim, max(-lim, new_integral))
    u = u_pd + ki * new_integral
    if abs(u) > pv_full and u * error > 0.0:
        new_integral = integral  # saturated toward the error: stop integrating
        u = u_pd + ki * integral
    return u, new_integral


class Moves(NamedTuple):
    """Each joint's move under way, (n,) arrays that `control_step` advances in place."""

    mode: np.ndarray  # int64 move mode (IDLE, CLOSED, SETTLE, OPEN)
    target: np.ndarray  # target drive angle, rad
    integral: np.ndarray  # PID integral, rad·s
    elapsed: np.ndarray  # time in the current move, s
    timeout: np.ndarray  # time-out of the current move, s
    open_time: np.ndarray  # open-loop valve time, s (OPEN mode)
    open_set_point: np.ndarray  # signed open-loop set point, gauge Pa (OPEN mode)
    retries: np.ndarray  # re-moves so far
    outcome: np.ndarray  # int64 written each tick: BUSY, ARRIVED, TIMED_OUT


class Belief(NamedTuple):
    """What the controller believes of each joint: the predictor's state and what it derives."""

    y: np.ndarray  # (n, N_RIGID) predicted one-joint states
    x: np.ndarray  # (n, N_STATE) the predictor's valve/brake states
    params: np.ndarray  # (n, N_COLUMNS) the predictor's parameter rows (Coulomb friction)
    load_nm: np.ndarray  # (n,) predicted load torque on each drive, N·m
    load_theta: np.ndarray  # (n,) predicted drive angles at which `load_nm` was computed, rad
    torque_per_pa: np.ndarray  # (n,) joint torque per gauge Pa of valve pressure at stall, N·m/Pa
    pv_full: np.ndarray  # (n,) set point of full opening, gauge Pa (the supply)
    breakaway_pa: np.ndarray  # (n, 2) written: valve pressure at which the joint breaks free turning +, -; gauge Pa


@njit
def control_step(
    moves: Moves,  # advanced in place
    belief: Belief,  # breakaway_pa written
    g: np.ndarray,  # gains_row
    dt_s: float,
    load_update_rad: float,  # how far a predicted angle may move before the load is stale, rad
    commands: np.ndarray,  # (n, 3) written
) -> tuple[bool, int, bool]:
    """One control period of every joint's move: the commands to issue now.

    The breakaway pressure of a joint is the valve pressure whose stall torque just overcomes its
    Coulomb friction and the predicted load, turning + and -. Returns (whether any joint was
    moving, the first joint that timed out or -1, whether a predicted angle has moved more than
    `load_update_rad` from `belief.load_theta`).
    """
    # the caller holds every array for the whole call: no reference counting (see `borrowed`)
    mode, target, integral = borrowed(moves.mode), borrowed(moves.target), borrowed(moves.integral)
    elapsed, timeout, retries = borrowed(moves.elapsed), borrowed(moves.timeout), borrowed(moves.retries)
    open_time, open_set_point = borrowed(moves.open_time), borrowed(moves.open_set_point)
    outcome = borrowed(moves.outcome)
    y, x, params = borrowed(belief.y), borrowed(belief.x), borrowed(belief.params)
    load_nm, load_theta = borrowed(belief.load_nm), borrowed(belief.load_theta)
    torque_per_pa, pv_full = borrowed(belief.torque_per_pa), borrowed(belief.pv_full)
    breakaway_pa, g, commands = borrowed(belief.breakaway_pa), borrowed(g), borrowed(commands)
    any_moving = False
    load_stale = False
    timed_out = -1
    for j in range(mode.shape[0]):
        coulomb = params[j, P.COULOMB]
        breakaway_pa[j, 0] = max(coulomb + load_nm[j], 0.0) / torque_per_pa[j]
        breakaway_pa[j, 1] = max(coulomb - load_nm[j], 0.0) / torque_per_pa[j]
        outcome[j] = BUSY
        m = mode[j]
        if m != IDLE:
            any_moving = True
        direction = 0.0
        set_point = 0.0
        release = 0.0
        if m != IDLE:
            elapsed[j] += dt_s
            if elapsed[j] > timeout[j]:
                mode[j] = IDLE
                outcome[j] = TIMED_OUT
                m = IDLE
                if timed_out < 0:
                    timed_out = j
        theta = y[j, R_THETA]
        omega = y[j, R_OMEGA]
        if not abs(theta - load_theta[j]) <= load_update_rad:  # (a NaN counts as moved)
            load_stale = True
        error = target[j] - theta
        if m == CLOSED:
            if abs(error) < g[G_TOL]:  # in the band: brake now (a joint still coasting is caught by it)
                mode[j] = SETTLE
                m = SETTLE
            else:
                u, integral[j] = pid_output(error, omega, integral[j], dt_s, g, pv_full[j])
                if u != 0.0:
                    direction = 1.0 if u > 0.0 else -1.0
                    set_point = min(abs(u), pv_full[j])
                    breakaway = breakaway_pa[j, 0] if direction > 0.0 else breakaway_pa[j, 1]
                    # a brake fed by the motor's port drags below its full-release pressure
                    floor = max(
                        g[G_MARGIN] * breakaway, params[j, P.BRAKE_FED_BY_MOTOR] * params[j, P.BRAKE_RELEASE_PA]
                    )
                    set_point = max(set_point, min(floor, pv_full[j]))
                release = 1.0
        elif m == OPEN:
            if elapsed[j] < open_time[j]:
                direction = 1.0 if open_set_point[j] > 0.0 else -1.0
                set_point = abs(open_set_point[j])
                release = 1.0
            else:
                mode[j] = SETTLE
                m = SETTLE
                retries[j] = g[G_MAXRETRY]  # the operator's open loop does not correct
        if m == SETTLE:
            # valves shut, brake on; wait for the predicted joint to stand and the brake to hold
            if omega == 0.0 and x[j, S_DIR] == 0.0 and x[j, S_BRAKE] > 0.95:
                if abs(error) > g[G_RETRY] and retries[j] < g[G_MAXRETRY]:
                    retries[j] += 1.0
                    mode[j] = CLOSED
                    integral[j] = 0.0
                else:
                    mode[j] = IDLE
                    outcome[j] = ARRIVED
        commands[j, C_DIRECTION] = direction
        commands[j, C_PV_SET_GAUGE_PA] = set_point
        commands[j, C_BRAKE_RELEASE] = release
    return any_moving, timed_out, load_stale
