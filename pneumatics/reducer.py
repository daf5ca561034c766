"""The reducer's transmission: rigid (paper eq. 6), or a torsional spring with backlash.

The paper's eq. 6 is a rigid reducer, M_o = i M_i, and the nominal twin keeps it. A real
strain-wave gear twists under load (its flexspline is the spring) and a worn or badly fitted one
has lost motion. With either on (`reducer_backlash_rad` > 0 or `reducer_compliance_rad_per_nm`
> 0) the motor is a body of its own, described on the joint side of the gear: its angle
q_m = motor angle / ratio, its speed w_m, and its inertia J_m = ratio^2 J_rotor. With the
twist d = q_m - theta (theta the joint angle) and the half gap b/2 the gear transmits

    tau_t = k dz(d, b/2) + c (w_m - w)    while the flanks touch (|d| > b/2), else 0,

with dz the dead zone (0 inside the gap, d -+ b/2 outside). The motor side obeys
J_m dw_m/dt = tau_drive - tau_t, tau_drive being the vane torque through the reducer with its
efficiencies (pneumatics.joint.joint_torque at the motor side's angle and speed); the joint side
receives tau_t in place of tau_drive. Friction and the brake stay on the joint side.

Numbers (each with its source):

* k = 1 / reducer_compliance_rad_per_nm. With backlash but no compliance the flanks still need a
  contact stiffness: CONTACT_STIFFNESS_NM_PER_RAD, the size-17 strain-wave gear's own (the
  wrist's LHS-17-120; Harmonic Drive's CSF-17 catalogue, K3 ~ 5.7e3 N·m/rad above its knee torque).
* c is the gear's structural damping, a property of the gear and not of what it drives, so it is
  set from the gear's own mode: the motor side against a locked output (how a catalogue measures
  torsional stiffness), sqrt(k / J_m), with damping ratio GEAR_DAMPING_RATIO = 0.03 (assumed:
  steel drive trains are damped a few percent; no catalogue gives a value). The two-mass mode of
  motor and load then has the damping ratio 0.03 sqrt(1 + J_m / J_j): 0.086 on the wrist rig
  (J_m = 0.144, J_j = 0.02 kg·m^2), 0.03-0.05 where the load is heavier than the rotor.
* Where backlash is on, the damping only ever pushes the flanks apart (tau_t keeps the sign of the
  contact): touching flanks cannot pull. Without backlash the gear is one elastic body, a linear
  spring-damper.
* Stiffnesses above MAX_STIFFNESS_NM_PER_RAD are taken as it: 175x the size-17 gear's K3, a twist
  below 0.07 mrad under the wrist's 69 N·m stall, far below what any reference instrument of the
  gap diagnosis sees (0.05 deg); it keeps the number of integration sub-steps bounded when a fit
  probes compliances near zero.
"""

from __future__ import annotations

import math

import numpy as np

from pneumatics import params as P
from pneumatics._jit import njit

CONTACT_STIFFNESS_NM_PER_RAD = 5.7e3  # Harmonic Drive CSF-17 catalogue, K3 (the wrist's size-17 gear)
MAX_STIFFNESS_NM_PER_RAD = 1.0e6  # see the module docstring: stiffer is invisible and unresolvable
GEAR_DAMPING_RATIO = 0.03  # assumed: the gear's mode against a locked output (module docstring)
MIN_JOINT_SHARE = 0.1  # the joint side keeps at least this share of a one-joint model's inertia
MAX_PHASE_PER_STEP = 0.5  # rad of the transmission's mode per integration step (RK4: phase error ~ 2e-4 per step)


@njit
def is_rigid(p: np.ndarray) -> bool:
    """True for the paper's rigid reducer (eq. 6): neither backlash nor compliance."""
    return p[P.BACKLASH] == 0.0 and p[P.COMPLIANCE] == 0.0


@njit
def stiffness(backlash_rad: float, compliance_rad_per_nm: float) -> float:
    """Joint-side torsional stiffness k in N·m/rad of a non-rigid reducer (module docstring)."""
    k = 1.0 / compliance_rad_per_nm if compliance_rad_per_nm > 0.0 else CONTACT_STIFFNESS_NM_PER_RAD
    return min(k, MAX_STIFFNESS_NM_PER_RAD)


@njit
def damping(stiffness_nm_per_rad: float, motor_inertia_kg_m2: float) -> float:
    """Structural damping c in N·m·s/rad: GEAR_DAMPING_RATIO of the gear's mode against a locked output."""
    return 2.0 * GEAR_DAMPING_RATIO * math.sqrt(stiffness_nm_per_rad * motor_inertia_kg_m2)


@njit
def dead_zone(x: float, half_width: float) -> float:
    """0 inside [-half_width, half_width], x -+ half_width outside."""
    if x > half_width:
        return x - half_width
    if x < -half_width:
        return x + half_width
    return 0.0


@njit
def transmitted_torque(
    twist_rad: float, twist_rate_rad_s: float, half_gap_rad: float, stiffness_nm_per_rad: float, damping_nm_s: float
) -> float:
    """Torque in N·m the gear passes from motor to joint at twist q_m - theta and its rate."""
    if half_gap_rad == 0.0:
        return stiffness_nm_per_rad * twist_rad + damping_nm_s * twist_rate_rad_s
    if twist_rad > half_gap_rad:
        return max(stiffness_nm_per_rad * (twist_rad - half_gap_rad) + damping_nm_s * twist_rate_rad_s, 0.0)
    if twist_rad < -half_gap_rad:
        return min(stiffness_nm_per_rad * (twist_rad + half_gap_rad) + damping_nm_s * twist_rate_rad_s, 0.0)
    return 0.0


@njit
def inertia_split(total_kg_m2: float, motor_reflected_kg_m2: float) -> tuple[float, float]:
    """(J_m, J_j): a one-joint model's joint-side inertia including the reflected rotor, split into
    the motor side (ratio^2 J_rotor) and the rest. A total that leaves the joint side less than
    MIN_JOINT_SHARE of it (an inertia scale far below 1 in a fit) is split in that proportion, so
    the two always add up to the total."""
    joint = total_kg_m2 - motor_reflected_kg_m2
    if joint < MIN_JOINT_SHARE * total_kg_m2:
        joint = MIN_JOINT_SHARE * total_kg_m2
    return total_kg_m2 - joint, joint


@njit
def mode_frequency(stiffness_nm_per_rad: float, motor_inertia_kg_m2: float, inv_joint_inertia: float) -> float:
    """Undamped angular frequency (rad/s) of the two-mass mode, sqrt(k (1/J_m + 1/J_j));
    inv_joint_inertia = 0 for a joint whose motion is given (the gear's locked-output mode)."""
    return math.sqrt(stiffness_nm_per_rad * (1.0 / motor_inertia_kg_m2 + inv_joint_inertia))


@njit
def substeps_for(dt_s: float, omega_rad_s: float, at_least: int) -> int:
    """Sub-steps over dt so that each advances the mode by at most MAX_PHASE_PER_STEP rad."""
    n = int(math.ceil(dt_s * omega_rad_s / MAX_PHASE_PER_STEP))
    return max(n, at_least)
