"""The open-loop baseline (paper Fig. 23, "no feedback"): what an operator does by hand.

Open the valve for the time a nominal model says the move takes, then shut it and brake. The time
comes from simulating the one-joint model with the nominal parameters (the same
`single_joint_step` / `advance_discrete` the predictor uses) from rest until the angle reaches the
target; the coast after the valve shuts is not anticipated, as by an operator with a stopwatch.
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
    R_THETA,
    advance_discrete,
    initial_rigid_state,
    initial_state,
    single_joint_step,
)


@njit
def _duration(
    y: np.ndarray,
    x: np.ndarray,
    target: float,
    set_point: float,
    supply_pa: float,
    load_nm: float,
    inertia: float,
    dt_s: float,
    max_s: float,
    p: np.ndarray,
) -> float:
    start = y[R_THETA]
    sign = 1.0 if target > start else -1.0
    cmd = np.zeros(N_COMMAND)
    cmd[C_DIRECTION] = sign
    cmd[C_PV_SET_GAUGE_PA] = set_point
    cmd[C_BRAKE_RELEASE] = 1.0  # the brake released while the valve is open
    t = 0.0
    while t < max_s:
        valve = advance_discrete(x, cmd, supply_pa, dt_s, p)
        single_joint_step(y, x, cmd, valve, supply_pa, load_nm, inertia, dt_s, p)  # the valve as the model believes it
        t += dt_s
        if sign * (y[R_THETA] - target) >= 0.0:
            return t
    return -1.0


def open_loop_duration(
    params_row: np.ndarray,
    start_rad: float,
    target_rad: float,
    set_point_gauge_pa: float,
    supply_pa: float,
    load_nm: float = 0.0,
    inertia_kg_m2: float = 0.164,
    dt_s: float = 1e-3,
    max_s: float = 60.0,
) -> float:
    """Valve-open time (s) after which the nominal one-joint model, started at rest with its brake
    engaged, reaches `target_rad`. ValueError if it does not within `max_s` (too little air)."""
    y = initial_rigid_state(start_rad, params_row[P.GAS_P_ATM], params_row[P.GAS_T])
    x = initial_state(params_row[P.GAS_P_ATM], True, 0.0, params_row[P.GAS_T])
    t = _duration(
        y,
        x,
        float(target_rad),
        float(set_point_gauge_pa),
        float(supply_pa),
        float(load_nm),
        float(inertia_kg_m2),
        float(dt_s),
        float(max_s),
        params_row,
    )
    if t < 0.0:
        raise ValueError(
            f"open loop: the nominal model does not reach {np.degrees(target_rad):.1f} deg "
            f"from {np.degrees(start_rad):.1f} deg "
            f"within {max_s:g} s at supply {(supply_pa - params_row[P.GAS_P_ATM]) / 1e6:.3f} MPa gauge"
        )
    return t
