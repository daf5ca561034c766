"""The compiled part of one control tick: the PID and sequencing of every joint (`control_step`),
then the predictor over the period (`predict_step`), in one call from Python.

Between the two the controller may need Pinocchio (the load torques at the predicted
configuration) and, on a time-out, its fault handling; both are Python. Pinocchio's answer does
not depend on anything `control_step` changes (it reads the predicted angles, which only the
predictor moves), so the controller asks it before the call whenever a joint moves and hands the
answer in: this call writes it into the load table where `control_step` finds the load stale, at
the point where the two-call tick wrote it (after `control_step` has taken its breakaway pressures
from the old load). Same arithmetic, same order, one call.
"""

from __future__ import annotations

import numpy as np

from control.pid import D_LOAD, D_LOAD_THETA, D_PV_FULL, control_step
from control.predictor import predict_step
from pneumatics._jit import borrowed, njit
from pneumatics.joint import R_THETA


@njit
def control_and_predict(
    modes: np.ndarray,  # control_step's tables and arguments, in place
    moves: np.ndarray,
    drives: np.ndarray,
    y: np.ndarray,
    x: np.ndarray,
    params: np.ndarray,
    g: np.ndarray,
    dt_s: float,
    load_update_rad: float,
    commands: np.ndarray,  # (n, 3) written
    faulted: bool,  # the controller has faulted: the commands are zero
    pv_full_pa: float,  # the set point of full opening this tick (gauge Pa): the supply
    new_load: np.ndarray,  # (n,) load torques at the predicted angles, or empty: no update this tick
    valve_gauge_pa: np.ndarray,  # predict_step's measured inputs
    supply_pa: float,
    load_nm: np.ndarray,  # (n,) the load column of `drives` (what predict_step reads)
    inertia_kg_m2: np.ndarray,
) -> tuple[bool, int, bool]:
    """Every joint's full-opening set point, `control_step`, the new load where it finds the load
    stale, then, unless a joint timed out (the controller must fault first and then call
    `predict_step` itself), `predict_step` over dt. Returns (whether any joint was moving, the
    first joint that timed out or -1, whether the prediction was advanced)."""
    drives = borrowed(drives)
    for j in range(drives.shape[0]):
        drives[j, D_PV_FULL] = pv_full_pa
    moving, timed_out, load_stale = control_step(modes, moves, drives, y, x, params, g, dt_s, load_update_rad, commands)
    commands = borrowed(commands)
    if faulted:
        commands[:, :] = 0.0
    if moving and load_stale and new_load.shape[0] > 0:
        for j in range(new_load.shape[0]):
            drives[j, D_LOAD] = new_load[j]
            drives[j, D_LOAD_THETA] = y[j, R_THETA]
    if timed_out >= 0:
        return moving, timed_out, False
    predict_step(y, x, commands, valve_gauge_pa, supply_pa, load_nm, inertia_kg_m2, params, dt_s)
    return moving, timed_out, True
