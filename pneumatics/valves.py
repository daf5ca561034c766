"""The platform's valves: the proportional valve and the solenoid direction valves.

Proportional valve (paper Sec. IV): a pressure-regulating valve whose output pressure P_v follows
its set point as a first-order lag of 0.1 s (the paper's "response time of the proportional
valve is 0.1 s"), never above the supply. Its pressure sensor is what the platform reads: the
paper feeds it to the model both as the motor's input pressure ("the input pressure P_s is
measured by the pressure sensor installed on the proportional valve") and, through u = k_u P_v
with k_u = 0.1959, as the valve body's opening. The paper gives no unit for k_u; with P_v in bar
(gauge) full opening falls at 5.1 bar, inside the 0.5-0.8 MPa working range, so we take
k_u = 0.1959 / bar = 1.959e-6 / Pa (gauge) and clip u to [0, 1]. A small set point thus means
both a small opening and a low pressure: the motor cannot lift its load on a small command,
which is the paper's explanation of its minimum rotation (Fig. 21).

Solenoid direction valves (paper Fig. 3): 5/3 valves that connect one motor port to the supply
and the other to exhaust, or both to exhaust in the centre position (our assumption: an exhaust
centre, so an idle motor holds no trapped pressure; the brake holds the joint). A command takes
effect after a switching delay.
"""

from __future__ import annotations

import math

from pneumatics._jit import njit


@njit
def lag_factors(dt_s: float, time_constant_s: float) -> tuple[float, float]:
    """(exp(-dt/tau), -expm1(-dt/tau)): what `lag_toward` and `lag_mean` take from dt and tau, for a
    caller that steps by the same dt many times to compute once and pass in (the same bits).
    (0, 1) for tau <= 0 (neither function reads them then)."""
    if time_constant_s <= 0.0:
        return 0.0, 1.0
    return math.exp(-dt_s / time_constant_s), -math.expm1(-dt_s / time_constant_s)


@njit
def lag_toward(value: float, target: float, dt_s: float, time_constant_s: float, decay: float = -1.0) -> float:
    """Exact step of a first-order lag dv/dt = (target - v)/tau over dt (for a constant target).

    `decay`, if given (>= 0), is `lag_factors(dt_s, time_constant_s)[0]`, computed before."""
    if time_constant_s <= 0.0:
        return target
    if value == target:
        # settled (an idle valve or brake, every step): the formula below gives exactly this, + 0.0
        # included (it turns a -0.0 into 0.0 as the formula does), without its exp
        return target + 0.0
    if decay < 0.0:
        decay = math.exp(-dt_s / time_constant_s)
    return target + (value - target) * decay


@njit
def lag_mean(value: float, target: float, dt_s: float, time_constant_s: float, gain: float = -1.0) -> float:
    """Mean over dt of the first-order lag that starts at `value` (exact for a constant target):
    target + (value - target) tau/dt (1 - exp(-dt/tau)). What a step that holds the lagging
    quantity constant should hold it at.

    `gain`, if given (>= 0), is `lag_factors(dt_s, time_constant_s)[1]`, computed before."""
    if time_constant_s <= 0.0 or value == target:
        return target + 0.0
    if gain < 0.0:
        gain = -math.expm1(-dt_s / time_constant_s)
    return target + (value - target) * time_constant_s / dt_s * gain


@njit
def proportional_valve_target(set_point_gauge_pa: float, supply_gauge_pa: float) -> float:
    """Output pressure (gauge, Pa) the proportional valve settles at: its set point, capped by the supply."""
    return max(0.0, min(set_point_gauge_pa, supply_gauge_pa))


@njit
def regulated_pressure(supply_pa: float, p_v_gauge_pa: float, p_atm_pa: float) -> float:
    """Absolute pressure the proportional valve delivers: its output P_v, never above the supply."""
    return min(supply_pa, p_atm_pa + max(0.0, p_v_gauge_pa))


@njit
def valve_opening(p_v_gauge_pa: float, k_u_per_pa: float, dead_zone: float) -> float:
    """Valve body opening u in [0, 1] from the output pressure: u = k_u P_v (paper Sec. IV).

    `dead_zone` (0 for the paper's valve) is the part of the stroke at which the spool has not yet
    uncovered its port (the gap catalogue's valve dead zone).
    """
    u = k_u_per_pa * p_v_gauge_pa
    if dead_zone > 0.0:
        u = (u - dead_zone) / (1.0 - dead_zone)
    return min(1.0, max(0.0, u))


@njit
def _delayed_change(
    effective: float, pending: float, remaining_s: float, command: float, delay_s: float, dt_s: float, restart: bool
) -> tuple[float, float, float]:
    # a commanded change takes effect delay_s later; `restart`: a newer command restarts the delay
    # the state describes the step's start: a change due by then is in effect for the whole step,
    # one still pending counts down through it (a delay on the step grid is met exactly)
    if command != pending:
        if restart or pending == effective:
            remaining_s = delay_s
        pending = command
    if pending != effective:
        if remaining_s <= 1e-12:
            effective = pending
            remaining_s = 0.0
        else:
            remaining_s -= dt_s
    return effective, pending, remaining_s


@njit
def dead_time_step(
    effective: float, pending: float, remaining_s: float, command: float, delay_s: float, dt_s: float
) -> tuple[float, float, float]:
    """Advance a dead time on a command that changes in steps by dt: each change takes effect
    exactly `delay_s` after it (a transport delay) when changes are further apart than the delay.

    State as `solenoid_step`'s. Unlike a solenoid, a new command does not restart a running
    delay: a command that changes faster than the delay is taken up once per delay, at its latest
    value, so a continuously varying set point is still followed. Returns (effective, pending, remaining_s).
    """
    return _delayed_change(effective, pending, remaining_s, command, delay_s, dt_s, False)


@njit
def solenoid_step(
    effective: float, pending: float, remaining_s: float, command: float, delay_s: float, dt_s: float
) -> tuple[float, float, float]:
    """Advance a solenoid valve with a switching delay by dt.

    State: the position in effect, a commanded position still pending, and the time left until it
    takes effect. A new command restarts the delay; returns (effective, pending, remaining_s).
    """
    return _delayed_change(effective, pending, remaining_s, command, delay_s, dt_s, True)
