"""The spring-applied, air-released joint brake (paper Sec. II: one brake per joint, on the joint side).

The springs apply the brake; air releases it. Where that air comes from is the joint's
configuration (`brake_fed_by_motor`):

* 0, a line of its own from the platform: the brake sees the supply pressure;
* 1, from the motor's pressurised port at the arm, through a shuttle valve (the usual arrangement
  of an air motor with a spring brake: the brake can lift only while the motor is driven). The
  paper's wrist reads this way: in its Fig. 7, valve 2 "controls the air flow into the brake and
  the air motor" alike. The brake then sees the motor-end pressure, after the hose's pressure
  loss, and drags wherever that loss pulls it under its full-release pressure.

The brake's piston lifts the lining once its air force beats the springs' preload (the start
pressure) and clears it at the full-release pressure; in between the lining still presses with
the springs' force less the air's, so the engagement the brake tends to falls linearly from 1 to
0 across that band (a spring's force is linear in its compression). It is released only when it
is told to, and it engages on its own when the air goes. Its engagement e in [0, 1] follows
that target as a first-order lag (the springs are faster than the air that fills the piston),
and it holds up to e times its holding torque; beyond that it slips, with the same torque (dry
friction of the lining).
"""

from __future__ import annotations

from pneumatics._jit import njit
from pneumatics.valves import lag_mean, lag_toward


@njit
def brake_feed_gauge_pa(
    fed_by_motor: float, supply_pa: float, pa_motor_pa: float, pb_motor_pa: float, p_atm_pa: float
) -> float:
    """Gauge pressure reaching the brake: the supply, or the higher motor port (a shuttle valve)."""
    if fed_by_motor > 0.5:
        return max(pa_motor_pa, pb_motor_pa) - p_atm_pa
    return supply_pa - p_atm_pa


@njit
def brake_target(release_command: float, feed_gauge_pa: float, start_gauge_pa: float, full_gauge_pa: float) -> float:
    """Engagement the brake tends to: 1 when not told to release; else 1 below the start pressure,
    0 from the full-release pressure on, linear between (a band of zero width: a step at it)."""
    if release_command <= 0.5 or feed_gauge_pa < start_gauge_pa:
        return 1.0
    if feed_gauge_pa >= full_gauge_pa:
        return 0.0
    return (full_gauge_pa - feed_gauge_pa) / (full_gauge_pa - start_gauge_pa)


@njit(inline="always")
def _lag_of(
    engagement: float,
    target: float,
    engage_tau_s: float,
    release_tau_s: float,
    engage_factor: float,
    release_factor: float,
) -> tuple[float, float]:
    # the time constant toward `target` and its lag factor: the springs engage it; the air releases it
    if target > engagement:
        return engage_tau_s, engage_factor
    return release_tau_s, release_factor


@njit
def brake_step(
    engagement: float,
    target: float,
    engage_tau_s: float,
    release_tau_s: float,
    dt_s: float,
    engage_decay: float = -1.0,
    release_decay: float = -1.0,
) -> float:
    """Engagement after dt, moving toward `target` (`brake_target`). The decays, if given, are
    `lag_factors(dt_s, tau)[0]` of the two time constants (`lag_toward`)."""
    tau, decay = _lag_of(engagement, target, engage_tau_s, release_tau_s, engage_decay, release_decay)
    return lag_toward(engagement, target, dt_s, tau, decay)


@njit
def brake_mean(
    engagement: float,
    target: float,
    engage_tau_s: float,
    release_tau_s: float,
    dt_s: float,
    engage_gain: float = -1.0,
    release_gain: float = -1.0,
) -> float:
    """Engagement averaged over the coming dt while it moves toward `target` (what a step that
    holds the brake's friction constant should hold). The gains, if given, are
    `lag_factors(dt_s, tau)[1]` of the two time constants (`lag_mean`)."""
    tau, gain = _lag_of(engagement, target, engage_tau_s, release_tau_s, engage_gain, release_gain)
    return lag_mean(engagement, target, dt_s, tau, gain)


@njit
def brake_holding_torque(engagement: float, holding_torque_nm: float) -> float:
    """Torque in N·m up to which the brake holds the joint (and with which it slips)."""
    return engagement * holding_torque_nm
