"""Friction in the joint: Coulomb, viscous and Stribeck laws, and the reducer (paper eq. 6, 7).

The paper's eq. 7 has -C_s S(x2) - C_f x2: Coulomb friction C_s with the sign function S and
viscous friction C_f. On the plant side MuJoCo applies the Coulomb part as the drive tendon's
`frictionloss` (a constraint, so sticking is exact) and the viscous part as its `damping`, with
the same numbers; the predictor integrates `coulomb_viscous_torque` below, whose stick rule
(Karnopp, J. Dyn. Sys. 107(1), 1985) plays the role of the constraint. A Stribeck excess (an
effect, off by default) raises that dry-friction limit near zero speed, on both sides alike
(`stribeck_excess`, pneumatics.joint.dry_friction_limit).
"""

from __future__ import annotations

import math

from pneumatics._jit import njit


@njit
def coulomb_viscous_torque(
    speed_rad_s: float, drive_torque_nm: float, coulomb_nm: float, viscous_nm_s: float, stick_speed_rad_s: float
) -> float:
    """Friction torque in N·m (Karnopp): opposes the motion, or the drive while stuck.

    While |speed| < stick_speed the joint sticks unless the net drive exceeds the Coulomb level;
    sticking friction cancels the drive exactly.
    """
    if abs(speed_rad_s) < stick_speed_rad_s:
        if abs(drive_torque_nm) <= coulomb_nm:
            return -drive_torque_nm
        return -math.copysign(coulomb_nm, drive_torque_nm)
    return -math.copysign(coulomb_nm, speed_rad_s) - viscous_nm_s * speed_rad_s


@njit
def stribeck_excess(speed_rad_s: float, breakaway_excess_nm: float, stribeck_speed_rad_s: float) -> float:
    """By how much, in N·m, the dry-friction limit exceeds the Coulomb level at this speed.

    (F_s - F_c) exp(-(w/w_s)^2): the Stribeck curve's excess (Armstrong-Helouvry, Automatica 30(7),
    1994). It belongs to the dry-friction limit, not to the drive: a joint at rest holds up to the
    static level F_s (Karnopp's rule, or MuJoCo's friction constraint, at zero speed), and a sliding
    joint feels F_c plus this excess. Not a drive torque smoothed across zero (tanh(w / 0.5 w_s)):
    that is zero at rest, so a joint whose drive lay between the two levels would creep on instead
    of holding (tests/test_joint_stops.py, tests/test_plant.py).
    """
    if breakaway_excess_nm == 0.0:
        return 0.0
    x = speed_rad_s / stribeck_speed_rad_s
    return breakaway_excess_nm * math.exp(-x * x)


@njit
def reducer_output_torque(
    motor_torque_nm: float,
    joint_speed_rad_s: float,
    ratio: float,
    efficiency_forward: float,
    efficiency_backward: float,
) -> float:
    """Joint-side torque in N·m of a reducer, paper eq. 6 (M_o = i M_i) with efficiencies.

    The paper's eq. 6 is ideal; a strain-wave gear loses power: when the motor drives the load
    (torque and joint speed agree) the output is eta_f i M_i; when the load drives the motor the
    load must supply i M_i / eta_b.
    """
    if motor_torque_nm * joint_speed_rad_s >= 0.0:
        return efficiency_forward * ratio * motor_torque_nm
    return ratio * motor_torque_nm / efficiency_backward
