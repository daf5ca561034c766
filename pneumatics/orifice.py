"""Mass flow through a restriction: the standard orifice of the paper (Sec. III-B, ref. [19]).

The paper writes the flow function with two typos: the critical pressure ratio is
(2/(k+1))^(k/(k-1)) = 0.528 for air (not "0.258"/"2058"), and the subsonic branch needs a square
root, 3.864 * sqrt(Pr^(2/k) - Pr^((k+1)/k)), for it to equal 1 at the critical ratio (3.864 is
C2/C1 below). We use the corrected form (Richer & Hurmuzlu, J. Dyn. Sys. 122(3), 2000, eq. 6-8).

Departure from the paper: for Pr above LINEAR_RATIO the flow is linearised to zero at Pr = 1.
The exact law has an infinite slope there, which makes any explicit integrator chatter around
equal pressures; the linear zone is the usual fix and changes the flow only in the last 1% of
the pressure ratio.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from pneumatics._jit import njit

LINEAR_RATIO = 0.99  # pressure ratio above which the flow is linearised (see module docstring)


class _Constants(NamedTuple):
    # the flow law's numbers for a gas with ratio of specific heats k
    c1: float  # C1 of the choked flow
    c2_c1: float  # C2 / C1
    pr_crit: float  # the critical pressure ratio
    f_lin: float  # f at LINEAR_RATIO


def _constants_of(k: float) -> _Constants:
    # `_Constants` of a gas with ratio of specific heats k
    c1 = math.sqrt(k * (2.0 / (k + 1.0)) ** ((k + 1.0) / (k - 1.0)))
    c2_c1 = math.sqrt(2.0 * k / (k - 1.0)) / c1
    pr_crit = (2.0 / (k + 1.0)) ** (k / (k - 1.0))
    f_lin = c2_c1 * math.sqrt(LINEAR_RATIO ** (2.0 / k) - LINEAR_RATIO ** ((k + 1.0) / k))
    return _Constants(c1, c2_c1, pr_crit, f_lin)


_AIR_K = 1.4
_AIR_CONSTANTS = _constants_of(_AIR_K)  # computed once: the plant calls the flow laws ~10^5 times a second
_constants_jit = njit(_constants_of)


@njit
def _constants(k: float) -> _Constants:
    if k == _AIR_K:
        return _AIR_CONSTANTS
    return _constants_jit(k)


@njit
def critical_pressure_ratio(k: float) -> float:
    """Downstream/upstream ratio below which the orifice is choked: (2/(k+1))^(k/(k-1))."""
    return _constants(k).pr_crit


@njit
def flow_function(pressure_ratio: float, k: float) -> float:
    """Normalised flow f(Pr) of the paper: 1 when choked, falling to 0 at Pr = 1.

    f = 1 for Pr <= Pr_crit; f = (C2/C1) sqrt(Pr^(2/k) - Pr^((k+1)/k)) above it (3.864 for
    k = 1.4), linearised to 0 above LINEAR_RATIO. Continuous everywhere.
    """
    pr = pressure_ratio
    c = _constants(k)
    c2_c1, pr_crit, f_lin = c.c2_c1, c.pr_crit, c.f_lin
    if pr <= pr_crit:
        return 1.0
    if pr >= 1.0:
        return 0.0
    if pr > LINEAR_RATIO:
        return f_lin * (1.0 - pr) / (1.0 - LINEAR_RATIO)
    x = math.exp(math.log(pr) / k)  # Pr^(1/k): Pr^(2/k) = x^2 and Pr^((k+1)/k) = Pr x
    return c2_c1 * math.sqrt(x * x - pr * x)


@njit
def choked_flux(t_up_k: float, r: float, k: float) -> float:
    """C1 / sqrt(R T_u) in s/m: choked mass flow per unit area and per Pa of upstream pressure
    (0.0404 s·K^0.5/m / sqrt(T_u) for air). A number of the gas alone at the supply temperature:
    the kernels keep it in the parameter row (`params_row`)."""
    return _constants(k).c1 / math.sqrt(r * t_up_k)


@njit
def orifice_mass_flow(p_up_pa: float, p_down_pa: float, area_m2: float, t_up_k: float, r: float, k: float) -> float:
    """Signed mass flow in kg/s from the `up` side to the `down` side of an orifice.

    m = A p_u C1 / sqrt(R T_u) f(p_d/p_u), with C1 = sqrt(k (2/(k+1))^((k+1)/(k-1))) (choked flow
    per unit area, 0.0404 s·K^0.5/m for air when R is folded in). `area_m2` is the effective area
    (discharge coefficient times geometric area). Negative when p_down > p_up.
    """
    return orifice_mass_flow_with(p_up_pa, p_down_pa, area_m2, choked_flux(t_up_k, r, k), k)


@njit
def orifice_mass_flow_between(
    p_a_pa: float, p_b_pa: float, area_m2: float, t_a_k: float, t_b_k: float, r: float, k: float
) -> float:
    """Signed mass flow in kg/s from side a to side b, each side with its own gas temperature: the
    flow is `orifice_mass_flow` of the gas on the upstream (higher-pressure) side, at its temperature.
    """
    t_up_k = t_a_k if p_a_pa >= p_b_pa else t_b_k
    return orifice_mass_flow_with(p_a_pa, p_b_pa, area_m2, choked_flux(t_up_k, r, k), k)


@njit
def orifice_mass_flow_with(p_up_pa: float, p_down_pa: float, area_m2: float, choked_flux_s_m: float, k: float) -> float:
    """`orifice_mass_flow` with the upstream gas's `choked_flux` passed in (the kernels keep it)."""
    if area_m2 <= 0.0:
        return 0.0
    if p_up_pa >= p_down_pa:
        sign = 1.0
        pu = p_up_pa
        pd = p_down_pa
    else:
        sign = -1.0
        pu = p_down_pa
        pd = p_up_pa
    return sign * area_m2 * pu * choked_flux_s_m * flow_function(pd / pu, k)
