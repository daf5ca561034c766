"""The angle predictor (paper Sec. III-IV, eq. 7 with the hose loss of eq. 5), one control tick at a time.

Per joint the predictor integrates the one-joint model `pneumatics.joint.single_joint_step` (RK4,
the paper's integrator) over the control period from what the operator's platform really has:

* the commands the controller issued, run through the predictor's own copy of the valves and the
  brake (`advance_discrete`, `advance_brake`): the direction valve's switching delay and the
  brake's engagement are what the predictor believes from its command history and its own
  predicted port pressures (a brake fed by the motor, pneumatics/brake.py);
* the measured supply pressure;
* the proportional valve's pressure sensor P_v: the motor's input pressure and, through
  u = k_u P_v, the valve's opening (paper Sec. IV; `pressure_rates` does both);
* the load torque on the joint (gravity and payload at the predicted configuration, from Pinocchio,
  control/arm_model.py) and the joint-side inertia.

It calls the same functions as the plant; it differs from the plant only by its JointParams.
"""

from __future__ import annotations

import numpy as np

from pneumatics import params as P
from pneumatics._jit import borrowed, njit
from pneumatics.joint import (
    C_BRAKE_RELEASE,
    C_DIRECTION,
    R_OMEGA,
    R_OMEGA_M,
    R_PA_VALVE,
    R_PB_MOTOR,
    R_QM,
    R_TA_VALVE,
    R_TB_MOTOR,
    R_THETA,
    S_BRAKE,
    S_DIR,
    advance_discrete,
    air_settled,
    single_joint_step,
)
from pneumatics.reducer import is_rigid


@njit
def predictor_at_rest(y: np.ndarray, x: np.ndarray, command: np.ndarray, p: np.ndarray) -> bool:
    """True when nothing can change the joint's prediction this tick: standing still (a non-rigid
    reducer's motor too, inside its gap), brake fully engaged and commanded so, no direction valve
    open or pending, all air at atmosphere and at its walls' temperature."""
    return (
        y[R_OMEGA] == 0.0
        and (
            is_rigid(p) or (y[R_OMEGA_M] == 0.0 and abs(y[R_QM] - y[R_THETA]) <= 0.5 * p[P.BACKLASH])
        )  # a gear's motor may swing or unwind
        and x[S_DIR] == 0.0
        and command[C_DIRECTION] == 0.0
        and command[C_BRAKE_RELEASE] == 0.0
        and x[S_BRAKE] >= 0.999999
        and air_settled(y[R_PA_VALVE : R_PB_MOTOR + 1], y[R_TA_VALVE : R_TB_MOTOR + 1], p)
    )


@njit
def predict_step(
    y: np.ndarray,  # (n, N_RIGID) one-joint states, advanced in place
    x: np.ndarray,  # (n, N_STATE) the predictor's valve/brake states (pneumatics.joint S_* columns), in place
    commands: np.ndarray,  # (n, N_COMMAND) the commands just issued (C_* columns), held over dt
    valve_gauge_pa: np.ndarray,  # (n,) measured proportional-valve pressures, gauge Pa
    supply_pa: float,  # measured supply, absolute Pa
    load_nm: np.ndarray,  # (n,) load torque on each drive, N·m
    inertia_kg_m2: np.ndarray,  # (n,) joint-side inertia incl. reflected rotor
    params: np.ndarray,  # (n, N_COLUMNS) the predictor's parameter rows
    dt_s: float,
) -> None:
    """Advance every joint's prediction over one control period (in place)."""
    # the caller holds every array for the whole call: no reference counting (see `borrowed`)
    y, x, commands, valve_gauge_pa = borrowed(y), borrowed(x), borrowed(commands), borrowed(valve_gauge_pa)
    load_nm, inertia_kg_m2, params = borrowed(load_nm), borrowed(inertia_kg_m2), borrowed(params)
    for j in range(y.shape[0]):
        p = params[j]
        if predictor_at_rest(y[j], x[j], commands[j], p):
            continue
        advance_discrete(x[j], commands[j], supply_pa, dt_s, p)
        single_joint_step(y[j], x[j], commands[j], valve_gauge_pa[j], supply_pa, load_nm[j], inertia_kg_m2[j], dt_s, p)
