"""The compiled per-step coupling of the pneumatic joints to MuJoCo.

Glue only: it reads each joint's drive coordinate from MuJoCo's tendon arrays, calls the laws of
pneumatics/ and writes the joint torque into the actuator's ctrl and the brake into the tendon's
frictionloss. One call per physics step for all joints keeps the cost of the air physics to a
fraction of MuJoCo's own step (see benchmarks/).
"""

from __future__ import annotations

import numpy as np

from pneumatics import params as P
from pneumatics._jit import njit
from pneumatics.brake import brake_holding_torque
from pneumatics.friction import stribeck_excess_torque
from pneumatics.joint import S_BRAKE, S_PA_MOTOR, S_PB_MOTOR, advance_discrete, advance_pressures, joint_torque


@njit
def pneumatic_step(
    x: np.ndarray,  # (n_joints, N_STATE) joint states, advanced in place
    commands: np.ndarray,  # (n_joints, N_COMMAND) held over the step
    params: np.ndarray,  # (n_joints, N_COLUMNS)
    tendon_ids: np.ndarray,  # (n_joints,) int: the drive tendon of each joint
    actuator_ids: np.ndarray,  # (n_joints,) int: the motor on that tendon
    ten_length: np.ndarray,  # MuJoCo d.ten_length
    ten_velocity: np.ndarray,  # MuJoCo d.ten_velocity
    ctrl: np.ndarray,  # MuJoCo d.ctrl (written)
    tendon_frictionloss: np.ndarray,  # MuJoCo m.tendon_frictionloss (written)
    supply_pa: float,
    dt_s: float,
    substeps: int,
) -> None:
    """Apply each joint's torque and brake for the coming step, then advance its air over dt."""
    for j in range(x.shape[0]):
        p = params[j]
        t = tendon_ids[j]
        theta = ten_length[t]
        omega = ten_velocity[t]
        torque = joint_torque(x[j, S_PA_MOTOR], x[j, S_PB_MOTOR], p[P.RATIO] * theta, omega, p)
        torque += stribeck_excess_torque(omega, p[P.STRIBECK_EXCESS], p[P.STRIBECK_SPEED], 0.5 * p[P.STRIBECK_SPEED])
        ctrl[actuator_ids[j]] = torque
        # brake is spring-applied: it and the joint's Coulomb friction are one dry-friction limit
        tendon_frictionloss[t] = p[P.COULOMB] + brake_holding_torque(x[j, S_BRAKE], p[P.BRAKE_HOLD])
        advance_discrete(x[j], commands[j], supply_pa, dt_s, p)
        advance_pressures(x[j], theta, omega, supply_pa, dt_s, substeps, p)
