"""The integrators' weights, written once for every stepper of the joint (pneumatics/joint.py).

Each stepper evaluates its own stages (the air with the joint moving as MuJoCo reports, the motor
side of a non-rigid gear, the whole one-joint body); these combine the stage rates into the
step's increment of one state variable.

The plant's air (`joint.advance_air_pair`) is integrated by ROS2, the two-stage Rosenbrock
W-method of Verwer, Spee, Blom and Hundsdorfer ("A second-order Rosenbrock method applied to
photochemical dispersion problems", SIAM J. Sci. Comput. 20(4), 1999, eq. 2.2):

    (I - g h W) k1 = f(t, y)
    (I - g h W) k2 = f(t + h, y + h k1) - 2 k1
    y(t + h) = y + 3/2 h k1 + 1/2 h k2,        g = 1 + 1/sqrt(2)

second order whatever the matrix W (an estimate of the Jacobian: with W = 0 it is Heun's method),
and L-stable when W is the Jacobian, so the air's fast modes (a short hose's two ends evening out,
a valve node at the valve's pressure) are damped in one step instead of ringing.
"""

from __future__ import annotations

import math

from pneumatics._jit import njit

ROS2_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


@njit(inline="always")
def rk4_increment(h: float, k1: float, k2: float, k3: float, k4: float) -> float:
    """Classical Runge-Kutta's increment over a step h from its four stage rates."""
    return h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(inline="always")
def secant_slope(value: float, difference: float) -> float:
    """value / difference, 0 where the difference is 0: a flow's slope against the pressure
    difference that drives it, as the W matrix takes it. The secant, not the tangent: the same for
    a linear law (the laminar hose, the orifice's last 1 % of pressure ratio, where the air is
    stiffest), 1.75 times the tangent on the hose's Blasius branch, above it where the orifice is
    choked (the tangent there is 0) and below it on the orifice's subsonic branch. ROS2 stays
    second order whatever W is (module docstring)."""
    if value == 0.0 or difference == 0.0:
        return 0.0
    return value / difference


@njit(inline="always")
def ros2_inverse(w00: float, w01: float, w10: float, w11: float, h: float) -> tuple[float, float, float, float]:
    """The inverse of ROS2's I - g h W for a 2 x 2 block of W (row-major), over a step h."""
    gh = ROS2_GAMMA * h
    m00 = 1.0 - gh * w00
    m01 = -gh * w01
    m10 = -gh * w10
    m11 = 1.0 - gh * w11
    inv_det = 1.0 / (m00 * m11 - m01 * m10)
    return m11 * inv_det, -m01 * inv_det, -m10 * inv_det, m00 * inv_det


@njit(inline="always")
def ros2_increment(h: float, k1: float, k2: float) -> float:
    """ROS2's increment over a step h from its two stages."""
    return 1.5 * h * k1 + 0.5 * h * k2
