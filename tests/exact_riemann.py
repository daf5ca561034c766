"""The exact solution of the Riemann problem of an ideal gas (a shock tube without friction), the
reference the line's gas dynamics is checked against (tests/test_line.py).

E. F. Toro, Riemann Solvers and Numerical Methods for Fluid Dynamics, 3rd ed., Springer 2009,
ch. 4: the star pressure from Newton's iteration on f(p) = f_L(p) + f_R(p) + u_R - u_L = 0
(sec. 4.3.1, eq. 4.5-4.9), then the solution sampled along x / t (sec. 4.5, fig. 4.14). Written
here, not taken from a library: no maintained Python package ships it (Toro's own is Fortran).
"""

from __future__ import annotations

import math

import numpy as np


def _f_and_slope(p: float, rho: float, pk: float, c: float, k: float) -> tuple[float, float]:
    # Toro eq. 4.6-4.7 and their derivatives (eq. 4.37): a shock above pk, a rarefaction below
    if p > pk:
        a = 2.0 / ((k + 1.0) * rho)
        b = (k - 1.0) / (k + 1.0) * pk
        root = math.sqrt(a / (p + b))
        return (p - pk) * root, root * (1.0 - 0.5 * (p - pk) / (b + p))
    ratio = p / pk
    return 2.0 * c / (k - 1.0) * (ratio ** ((k - 1.0) / (2.0 * k)) - 1.0), ratio ** (-(k + 1.0) / (2.0 * k)) / (rho * c)


def star_state(left: tuple[float, float, float], right: tuple[float, float, float], k: float) -> tuple[float, float]:
    """(p*, u*) between a left and a right state (rho, u, p): Newton from the two-rarefaction
    guess (Toro eq. 4.46) to a relative change below 1e-12."""
    rl, ul, pl = left
    rr, ur, pr = right
    cl, cr = math.sqrt(k * pl / rl), math.sqrt(k * pr / rr)
    z = (k - 1.0) / (2.0 * k)
    p = ((cl + cr - 0.5 * (k - 1.0) * (ur - ul)) / (cl / pl**z + cr / pr**z)) ** (1.0 / z)
    for _ in range(100):
        fl, dl = _f_and_slope(p, rl, pl, cl, k)
        fr, dr = _f_and_slope(p, rr, pr, cr, k)
        new = max(p - (fl + fr + ur - ul) / (dl + dr), 1e-6 * p)
        if abs(new - p) < 1e-12 * p:
            p = new
            break
        p = new
    fl, _ = _f_and_slope(p, rl, pl, cl, k)
    fr, _ = _f_and_slope(p, rr, pr, cr, k)
    return p, 0.5 * (ul + ur) + 0.5 * (fr - fl)


def sample(
    left: tuple[float, float, float], right: tuple[float, float, float], k: float, xi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rho, u, p) of the exact solution at the speeds xi = x / t (Toro sec. 4.5)."""
    p_star, u_star = star_state(left, right, k)
    out = np.empty((3, xi.size))
    g1 = (k - 1.0) / (k + 1.0)
    for n, s in enumerate(xi):
        side = 1.0 if s <= u_star else -1.0  # left of the contact, or the right seen mirrored
        rho, u, p = left if side > 0 else right
        u, s_, us = side * u, side * s, side * u_star
        c = math.sqrt(k * p / rho)
        if p_star > p:  # shock
            speed = u - c * math.sqrt((k + 1.0) / (2.0 * k) * p_star / p + (k - 1.0) / (2.0 * k))
            state = (rho, u, p) if s_ <= speed else (rho * (p_star / p + g1) / (g1 * p_star / p + 1.0), us, p_star)
        else:  # rarefaction: head, fan, tail
            c_star = c * (p_star / p) ** ((k - 1.0) / (2.0 * k))
            if s_ <= u - c:
                state = (rho, u, p)
            elif s_ >= us - c_star:
                state = (rho * (p_star / p) ** (1.0 / k), us, p_star)
            else:
                cf = 2.0 / (k + 1.0) * (c + 0.5 * (k - 1.0) * (u - s_))
                uf = 2.0 / (k + 1.0) * (c + 0.5 * (k - 1.0) * u + s_)
                state = (rho * (cf / c) ** (2.0 / (k - 1.0)), uf, p * (cf / c) ** (2.0 * k / (k - 1.0)))
        out[:, n] = state[0], side * state[1], state[2]
    return out[0], out[1], out[2]
