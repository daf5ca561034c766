"""Pressure loss in the long air hoses between the platform and the arm (paper eq. 1-5).

The paper's eq. 1 is Darcy-Weisbach, dp = lambda (L/d) rho v^2 / 2, written with the standard
volume flow and folded constants; here it is written with the mass flow, so its constants need no
unit bookkeeping: with v = m / (rho A), dp = 8 lambda L m^2 / (pi^2 rho d^5).

lambda is Blasius' 0.316 Re^-0.25 (paper eq. 3) for turbulent flow. Departure from the paper:
below Re ~ 1189, where Blasius' lambda would fall under the laminar 64/Re, we take 64/Re
(Hagen-Poiseuille). lambda = max(64/Re, Blasius) is continuous and gives a finite slope of flow
against pressure at zero flow, which keeps the integration stable; at the paper's Re = 2497 the
two agree with the paper.
"""

from __future__ import annotations

import math

from pneumatics._jit import njit

BLASIUS_LAMINAR_RE = (64.0 / 0.316) ** (1.0 / 0.75)  # Re at which 64/Re = 0.316 Re^-0.25 (~1189)


@njit
def reynolds_number(mass_flow_kg_s: float, diameter_m: float, mu_pa_s: float) -> float:
    """Re = rho v d / mu = 4 |m| / (pi d mu) for a round hose."""
    return 4.0 * abs(mass_flow_kg_s) / (math.pi * diameter_m * mu_pa_s)


@njit
def friction_factor(reynolds: float) -> float:
    """Darcy friction factor: Blasius 0.316 Re^-0.25 (paper eq. 3), laminar 64/Re below ~1187."""
    if reynolds <= 0.0:
        return math.inf
    return max(64.0 / reynolds, 0.316 * reynolds**-0.25)


@njit
def hose_pressure_drop(
    mass_flow_kg_s: float,
    p_mean_pa: float,
    t_mean_k: float,
    length_m: float,
    diameter_m: float,
    r: float,
    mu_pa_s: float,
) -> float:
    """Pressure drop in Pa along a hose carrying `mass_flow_kg_s` (signed like the flow), eq. 1-4.

    The gas density is taken at the mean pressure and mean temperature of the hose, as in the
    paper's P_m = (P_i + P_o)/2 and T_m = (T_B + T_o)/2.
    """
    if mass_flow_kg_s == 0.0:
        return 0.0
    rho = p_mean_pa / (r * t_mean_k)
    lam = friction_factor(reynolds_number(mass_flow_kg_s, diameter_m, mu_pa_s))
    dp = 8.0 * lam * length_m * mass_flow_kg_s * mass_flow_kg_s / (math.pi**2 * rho * diameter_m**5)
    return dp if mass_flow_kg_s > 0.0 else -dp


@njit
def blasius_coefficient(length_m: float, diameter_m: float, mu_pa_s: float) -> float:
    """The part of the Blasius branch that depends on the hose and the gas only (SI units):
    8 * 0.316 (4 / (pi d mu))^-0.25 L, so that dp = it / (pi^2 rho d^5) * m^1.75. The kernels read
    it from the parameter row (`params_row`) rather than take a power every call."""
    return 8.0 * 0.316 * (4.0 / (math.pi * diameter_m * mu_pa_s)) ** -0.25 * length_m


@njit
def hose_mass_flow(
    p_in_pa: float, p_out_pa: float, t_mean_k: float, length_m: float, diameter_m: float, r: float, mu_pa_s: float
) -> float:
    """Signed mass flow in kg/s through a hose from the pressure at its two ends: eq. 1-4 inverted.

    Exact inverse of `hose_pressure_drop` with the density at (p_in + p_out)/2: on the laminar
    branch dp = 128 mu L m / (pi rho d^4), on the Blasius branch dp is proportional to m^1.75;
    the branch is picked by the Reynolds number of the result.
    """
    blasius = blasius_coefficient(length_m, diameter_m, mu_pa_s)
    return hose_mass_flow_with(p_in_pa, p_out_pa, t_mean_k, length_m, diameter_m, r, mu_pa_s, blasius)


@njit
def hose_mass_flow_with(
    p_in_pa: float,
    p_out_pa: float,
    t_mean_k: float,
    length_m: float,
    diameter_m: float,
    r: float,
    mu_pa_s: float,
    blasius_coefficient_: float,
) -> float:
    """`hose_mass_flow` with the hose's `blasius_coefficient` passed in (the kernels keep it)."""
    dp = p_in_pa - p_out_pa
    if dp == 0.0:
        return 0.0
    rho = 0.5 * (p_in_pa + p_out_pa) / (r * t_mean_k)
    adp = abs(dp)
    # laminar: m = pi rho d^4 dp / (128 mu L)
    m = math.pi * rho * diameter_m**4 * adp / (128.0 * mu_pa_s * length_m)
    if reynolds_number(m, diameter_m, mu_pa_s) > BLASIUS_LAMINAR_RE:
        # Blasius: dp = 8 * 0.316 (4 m/(pi d mu))^-0.25 L m^2 / (pi^2 rho d^5)
        coef = blasius_coefficient_ / (math.pi**2 * rho * diameter_m**5)
        m = (adp / coef) ** (1.0 / 1.75)
    return m if dp > 0.0 else -m


@njit
def hose_volume(length_m: float, diameter_m: float) -> float:
    """Internal volume of a round hose in m^3."""
    return 0.25 * math.pi * diameter_m**2 * length_m
