"""The predicted load between Pinocchio's looks: its tangent, and when it is stale.

The predictor needs each drive's load torque at the predicted angles every control tick
(control/arm_model.py: gravity, the joints' springs, the brush head pressed into a surface).
Pinocchio gives it, but from Python: asked every tick of a move it was an eighth of a whole run's
time. Between looks the controller uses the load's first-order Taylor expansion about the angles
of the last look, f(theta) = f0 + (df/dtheta)(theta - theta0), Pinocchio's own derivative
(`ArmModel.load_slope`), and looks again once any predicted drive angle is more than `radius_rad`
from theta0. The expansion's error is second order: over the arm's whole range, ~100 N·m/rad^2
times the square of the distance (tests/test_control.py measures it against Pinocchio's load).

The brush head's press is not smooth (its spring's preload: the load jumps where the head
touches), so the tangent never stands for it: while the head is pressed (or where it may touch
before the next look) the load is stale as soon as an angle moves, as it was without the tangent.
The tool frame is certainly clear of the surface while the chain's reach times the joints' turn
since the last look stays under the clearance found there (`ArmModel.press_clearance_m`); the
press's load is then exactly zero (`ArmModel.press_torques` skips its kinematics by the same
bound).

`bound` holds the three scalars: the radius (rad; 0: stale whenever an angle moved, every tick of
a move), the chain's reach (m per rad of joint turn) and the clearance (m; inf where no press is
expected, -inf where the head may be pressed).
"""

from __future__ import annotations

import numpy as np

from control.pid import D_LOAD, D_LOAD_THETA
from pneumatics._jit import njit
from pneumatics.joint import R_THETA

B_RADIUS, B_REACH, B_CLEARANCE = range(3)
N_BOUND = 3

# the default radius (rad): the tangent's error is then at most ~0.01 N·m on any drive anywhere in
# the arm's range with its 20 kg payload (tests/test_control.py measures it against Pinocchio): a
# 300th of the least Coulomb friction (the tool roll's 3 N·m, assets/joints/) and a 20th of the
# gravity load's change over one tick of a joint at 1 rad/s; such a joint is looked up every ~10 ticks
LOAD_UPDATE_RAD = 0.01


@njit
def advance_load(
    drives: np.ndarray,  # (n, N_DRIVE_COLUMNS): D_LOAD written where fresh; D_LOAD_THETA read
    y: np.ndarray,  # (n, N_RIGID) predicted one-joint states
    base: np.ndarray,  # (n,) the load at D_LOAD_THETA (N·m)
    slope: np.ndarray,  # (n, n) its derivative by the drive angles there (N·m/rad)
    c_inv: np.ndarray,  # (n, n) joint angles from drive angles (ArmModel.C_inv)
    bound: np.ndarray,  # (N_BOUND,)
) -> bool:
    """Whether the load must be looked up again at the predicted angles (stale); if not, the
    tangent's load there is written into D_LOAD. A joint that has not moved keeps the load of the
    last look exactly; a NaN angle counts as moved."""
    n = y.shape[0]
    moved = False
    for j in range(n):
        delta = y[j, R_THETA] - drives[j, D_LOAD_THETA]
        if not abs(delta) <= bound[B_RADIUS]:
            return True
        moved = moved or delta != 0.0
    if not moved:
        for i in range(n):
            drives[i, D_LOAD] = base[i]
        return False
    if bound[B_CLEARANCE] != np.inf:
        turn = 0.0  # the joints' turn since the last look, summed (rad)
        for i in range(n):
            dq = 0.0
            for k in range(n):
                dq += c_inv[i, k] * (y[k, R_THETA] - drives[k, D_LOAD_THETA])
            turn += abs(dq)
        if not bound[B_REACH] * turn < bound[B_CLEARANCE]:
            return True  # the head may touch: the press's load is not the tangent's
    for i in range(n):
        load = base[i]
        for k in range(n):
            load += slope[i, k] * (y[k, R_THETA] - drives[k, D_LOAD_THETA])
        drives[i, D_LOAD] = load
    return False
