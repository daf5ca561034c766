"""The explicit integrators' weights, written once for every stepper of the joint (pneumatics/joint.py).

Each stepper evaluates its own stages (the air alone with the joint moving at a given speed, the
motor side of a non-rigid gear, the whole one-joint body); these combine the stage rates into the
step's increment of one state variable.
"""

from __future__ import annotations

from pneumatics._jit import njit


@njit(inline="always")
def rk4_increment(h: float, k1: float, k2: float, k3: float, k4: float) -> float:
    """Classical Runge-Kutta's increment over a step h from its four stage rates."""
    return h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(inline="always")
def heun_increment(h: float, k1: float, k2: float) -> float:
    """Heun's method's (the explicit trapezoid's) increment over a step h from its two stage rates."""
    return 0.5 * h * (k1 + k2)
