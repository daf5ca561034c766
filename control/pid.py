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
    # it the motor cannot move the joint, the loop would only wind up (0: no floor).
    breakaway_margin: float = 1.2
    # a brake fed by the motor's port (pneumatics/brake.py) drags below its full-release pressure,
    # so while moving the set point is also floored this far above the *predicted* brake's full
    # release: the real brake's spring is known only to its tolerance (springs and preload +-10 %,
    # assumed: +-0.4 bar at the nominal 4 bar) and the port sits a little under the set point on
    # an approach (the hose's drop at a slow joint's flow). Without it every approach parks the
    # port at the edge of the real brake's drag band, where 0.1 bar of spring moved a 90 deg move
    # by 6 deg (docs/validation/predictor_and_control.md). The nominal brake clears low enough for the floor to
    # fit under a 0.5 MPa supply and its droop (assets/joints/wrist_pitch.toml).
    brake_clear_margin_pa: float = 0.5e5


DEFAULT_GAINS = PidGains()  # immutable: safe as a default argument


def gains_row(g: PidGains) -> np.ndarray:
    return np.array(tuple(g), dtype=np.float64)


G_KP, G_KI, G_KD, G_ILIM, G_TOL, G_VARR, G_RETRY, G_MAXRETRY, G_MARGIN, G_BRAKE_MARGIN = range(10)


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


# columns of the per-joint tables control_step works on (the controller keeps named views of them)
K_MODE, K_OUTCOME = range(2)  # int64 (n, 2): move mode (IDLE, ...); outcome this tick (BUSY, ...)
N_MODES_COLUMNS = 2
# float (n, 7), each joint's move under way: target drive angle (rad), PID integral (rad·s), time in
# the move (s), its time-out (s), the open loop's valve time (s) and signed set point (gauge Pa),
# re-moves so far
M_TARGET, M_INTEGRAL, M_ELAPSED, M_TIMEOUT, M_OPEN_TIME, M_OPEN_SET_POINT, M_RETRIES = range(7)
N_MOVE_COLUMNS = 7
# float (n, 6), what the controller derives for each drive: predicted load torque (N·m) and the
# drive angle it was taken at (rad), stall torque per gauge Pa of valve pressure (N·m/Pa), the set
# point of full opening (gauge Pa, the supply), the breakaway valve pressures turning + and -
# (gauge Pa, written by control_step)
D_LOAD, D_LOAD_THETA, D_TORQUE_PER_PA, D_PV_FULL, D_BREAKAWAY_POS, D_BREAKAWAY_NEG = range(6)
N_DRIVE_COLUMNS = 6


@njit
def control_step(
    modes: np.ndarray,  # (n, N_MODES_COLUMNS) int64, in place
    moves: np.ndarray,  # (n, N_MOVE_COLUMNS), in place
    drives: np.ndarray,  # (n, N_DRIVE_COLUMNS), breakaway pressures written
    y: np.ndarray,  # (n, N_RIGID) predicted one-joint states
    x: np.ndarray,  # (n, N_STATE) the predictor's valve/brake states
    params: np.ndarray,  # (n, N_COLUMNS) the predictor's parameter rows (Coulomb friction)
    g: np.ndarray,  # gains_row
    dt_s: float,
    commands: np.ndarray,  # (n, N_COMMAND) written (C_* columns)
) -> tuple[bool, int]:
    """One control period of every joint's move: the commands to issue now.

    The breakaway pressure of a joint is the valve pressure whose stall torque just overcomes its
    Coulomb friction and the predicted load, turning + and -. Returns (whether any joint was
    moving, the first joint that timed out or -1).
    """
    # the caller holds every array for the whole call: no reference counting (see `borrowed`)
    modes, moves, drives, y, x = borrowed(modes), borrowed(moves), borrowed(drives), borrowed(y), borrowed(x)
    params, g, commands = borrowed(params), borrowed(g), borrowed(commands)
    any_moving = False
    timed_out = -1
    for j in range(modes.shape[0]):
        coulomb = params[j, P.COULOMB]
        load = drives[j, D_LOAD]
        drives[j, D_BREAKAWAY_POS] = max(coulomb + load, 0.0) / drives[j, D_TORQUE_PER_PA]
        drives[j, D_BREAKAWAY_NEG] = max(coulomb - load, 0.0) / drives[j, D_TORQUE_PER_PA]
        modes[j, K_OUTCOME] = BUSY
        if modes[j, K_MODE] != IDLE:
            any_moving = True
            moves[j, M_ELAPSED] += dt_s
            if moves[j, M_ELAPSED] > moves[j, M_TIMEOUT]:
                modes[j, K_MODE] = IDLE
                modes[j, K_OUTCOME] = TIMED_OUT
                if timed_out < 0:
                    timed_out = j
        commands[j, C_DIRECTION], commands[j, C_PV_SET_GAUGE_PA], commands[j, C_BRAKE_RELEASE] = _joint_command(
            modes[j], moves[j], drives[j], y[j], x[j], params[j], g, dt_s
        )
    return any_moving, timed_out


@njit
def _joint_command(
    mode: np.ndarray, move: np.ndarray, drive: np.ndarray, y: np.ndarray, x: np.ndarray, p: np.ndarray, g, dt_s
) -> tuple[float, float, float]:
    # (direction, set point, brake release) of one joint this tick, its mode moved on in place
    direction = 0.0
    set_point = 0.0
    release = 0.0
    theta = y[R_THETA]
    omega = y[R_OMEGA]
    error = move[M_TARGET] - theta
    m = mode[K_MODE]
    if m == CLOSED:
        if abs(error) < g[G_TOL]:  # in the band: brake now (a joint still coasting is caught by it)
            mode[K_MODE] = SETTLE
            m = SETTLE
        else:
            direction, set_point = _closed_loop_command(error, omega, move, drive, p, g, dt_s)
            release = 1.0
    elif m == OPEN:
        if move[M_ELAPSED] < move[M_OPEN_TIME]:
            direction = 1.0 if move[M_OPEN_SET_POINT] > 0.0 else -1.0
            set_point = abs(move[M_OPEN_SET_POINT])
            release = 1.0
        else:
            mode[K_MODE] = SETTLE
            m = SETTLE
            move[M_RETRIES] = g[G_MAXRETRY]  # the operator's open loop does not correct
    # SETTLE: valves shut, brake on; wait for the predicted joint to stand and the brake to hold
    if m == SETTLE and omega == 0.0 and x[S_DIR] == 0.0 and x[S_BRAKE] > 0.95:
        if abs(error) > g[G_RETRY] and move[M_RETRIES] < g[G_MAXRETRY]:
            move[M_RETRIES] += 1.0
            mode[K_MODE] = CLOSED
            move[M_INTEGRAL] = 0.0
        else:
            mode[K_MODE] = IDLE
            mode[K_OUTCOME] = ARRIVED
    return direction, set_point, release


@njit
def _closed_loop_command(
    error: float, omega: float, move: np.ndarray, drive: np.ndarray, p: np.ndarray, g: np.ndarray, dt_s: float
) -> tuple[float, float]:
    # (direction, set point) of the PID, floored at the breakaway pressure and, for a brake fed by
    # the motor's port, clear of the brake's drag band; the integral in place
    direction = 0.0
    set_point = 0.0
    pv_full = drive[D_PV_FULL]
    u, move[M_INTEGRAL] = pid_output(error, omega, move[M_INTEGRAL], dt_s, g, pv_full)
    if u != 0.0:
        direction = 1.0 if u > 0.0 else -1.0
        set_point = min(abs(u), pv_full)
        breakaway = drive[D_BREAKAWAY_POS] if direction > 0.0 else drive[D_BREAKAWAY_NEG]
        brake_clear = p[P.BRAKE_FED_BY_MOTOR] * (p[P.BRAKE_RELEASE_PA] + g[G_BRAKE_MARGIN])
        floor = max(g[G_MARGIN] * breakaway, brake_clear)
        set_point = max(set_point, min(floor, pv_full))
    return direction, set_point
