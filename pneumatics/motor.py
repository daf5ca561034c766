"""The N-vane air motor: chamber volumes, their rates, and the vane torque.

Wang, Pu & Moore, "Modelling study and servo-control of air motor systems", Int. J. Control
71(3), 1998, and its N-vane form (Luo & Wang, 2008), as used in the paper's eq. 7.

With stator radius B, rotor radius r, eccentricity e = B - r and vane length L, the distance
from the rotor centre to the stator along a vane at motor angle phi is
    rho^2 = B^2 + 2 e B cos(phi) + e^2 cos(2 phi),
and a pressure difference on the exposed vane gives the torque
    T = (p_A - p_B) (L/2) (rho^2 - r^2).
The driving chamber's volume slope dV_A/dphi is the same function, so that the pressures do
exactly the work the torque does (DESIGN, "Torque and volume must agree"). phi is wrapped into
one vane pitch (+-45 deg for 4 vanes): each time a vane passes the port the chamber resets, which
is the paper's j index. The paper's own polynomial for V_A does not give a plausible volume for a
small motor (DESIGN); we integrate the slope instead.
"""

from __future__ import annotations

import math

from pneumatics._jit import njit


@njit
def wrap_motor_angle(phi_rad: float, n_vanes: float) -> float:
    """Motor angle wrapped into one vane pitch, [-pi/n, pi/n)."""
    pitch = 2.0 * math.pi / n_vanes
    return phi_rad - pitch * math.floor(phi_rad / pitch + 0.5)


@njit
def half_pitch_volume(stator_radius_m: float, rotor_radius_m: float, vane_length_m: float, n_vanes: float) -> float:
    """Half the volume one vane pitch sweeps, in m^3: the antiderivative of dV_A/dphi (odd, 0 at
    phi = 0) at the pitch's end, pi/n. A number of the motor alone: the kernels read it from the
    parameter row (`params_row`) rather than take two sines every call."""
    b = stator_radius_m
    r = rotor_radius_m
    e = b - r
    half_l = 0.5 * vane_length_m
    half_pitch = math.pi / n_vanes
    return half_l * (
        (b * b - r * r) * half_pitch + 2.0 * e * b * math.sin(half_pitch) + 0.5 * e * e * math.sin(2.0 * half_pitch)
    )


@njit
def chamber_geometry(
    phi_rad: float,
    stator_radius_m: float,
    rotor_radius_m: float,
    vane_length_m: float,
    n_vanes: float,
    dead_volume_m3: float,
    half_pitch_volume_m3: float,
) -> tuple[float, float, float]:
    """(V_A, V_B, dV_A/dphi) at motor angle phi, in m^3 and m^3/rad.

    dV_A/dphi = (L/2)(rho^2 - r^2); V_A is its integral from the start of the vane pitch
    (-pi/n), where V_A equals the dead volume; V_B is the integral to the pitch's end, so
    V_A + V_B is the same at every angle. `half_pitch_volume_m3` is `half_pitch_volume` of the
    same motor (passed in: it depends on the dimensions only).
    """
    b = stator_radius_m
    r = rotor_radius_m
    e = b - r
    half_l = 0.5 * vane_length_m
    w = wrap_motor_angle(phi_rad, n_vanes)
    s1 = math.sin(w)
    c1 = math.cos(w)
    # rho^2 - r^2 with cos(2w) = 2cos^2(w) - 1, and its antiderivative with sin(2w) = 2 sin(w) cos(w)
    slope = half_l * (b * b + 2.0 * e * b * c1 + e * e * (2.0 * c1 * c1 - 1.0) - r * r)
    mid = half_l * ((b * b - r * r) * w + 2.0 * e * b * s1 + e * e * s1 * c1)
    hi = half_pitch_volume_m3
    # the antiderivative is odd, so its value at -pi/n is -hi
    return dead_volume_m3 + (mid + hi), dead_volume_m3 + (hi - mid), slope


@njit
def swept_area(
    phi_rad: float, stator_radius_m: float, rotor_radius_m: float, vane_length_m: float, n_vanes: float
) -> float:
    """dV_A/dphi in m^3/rad = (L/2)(rho^2 - r^2) at the wrapped motor angle."""
    # the slope is the same whatever the volumes' constants (dead volume, half-pitch volume)
    return chamber_geometry(phi_rad, stator_radius_m, rotor_radius_m, vane_length_m, n_vanes, 0.0, 0.0)[2]


@njit
def chamber_volumes(
    phi_rad: float,
    stator_radius_m: float,
    rotor_radius_m: float,
    vane_length_m: float,
    n_vanes: float,
    dead_volume_m3: float,
) -> tuple[float, float]:
    """Volumes (V_A, V_B) in m^3 of the two motor chambers at motor angle phi.

    V_A grows from `dead_volume_m3` at the start of a vane pitch while V_B shrinks; V_A + V_B is
    the same at every angle. The rates are +-`swept_area` times the motor speed.
    """
    hi = half_pitch_volume(stator_radius_m, rotor_radius_m, vane_length_m, n_vanes)
    v_a, v_b, _ = chamber_geometry(phi_rad, stator_radius_m, rotor_radius_m, vane_length_m, n_vanes, dead_volume_m3, hi)
    return v_a, v_b


@njit
def vane_torque(
    p_a_pa: float,
    p_b_pa: float,
    phi_rad: float,
    stator_radius_m: float,
    rotor_radius_m: float,
    vane_length_m: float,
    n_vanes: float,
) -> float:
    """Motor shaft torque in N·m from the chamber pressures: (p_A - p_B) dV_A/dphi."""
    if p_a_pa == p_b_pa:
        return 0.0  # an idle motor, every step: exactly the product below (dV_A/dphi > 0), without the geometry
    return (p_a_pa - p_b_pa) * swept_area(phi_rad, stator_radius_m, rotor_radius_m, vane_length_m, n_vanes)


def displacement_per_rad(stator_radius_m: float, rotor_radius_m: float, vane_length_m: float, n_vanes: float) -> float:
    """Mean swept volume per motor radian in m^3/rad (a vane pitch's swept volume over its angle)."""
    va_lo, vb_lo = chamber_volumes(
        -math.pi / n_vanes + 1e-12, stator_radius_m, rotor_radius_m, vane_length_m, n_vanes, 0.0
    )
    return (vb_lo - va_lo) / (2.0 * math.pi / n_vanes)


def least_displacement_per_rad(
    stator_radius_m: float, rotor_radius_m: float, vane_length_m: float, n_vanes: float
) -> float:
    """Least volume slope dV_A/dphi over a vane pitch, m^3/rad: the torque per Pa of a stalled motor
    at its worst vane angle (half a pitch from a vane at the port, where rho is shortest; the vane
    torque is (p_A - p_B) times this slope). 0.87 of the mean for the arm's motors."""
    return swept_area(math.pi / n_vanes - 1e-12, stator_radius_m, rotor_radius_m, vane_length_m, n_vanes)
