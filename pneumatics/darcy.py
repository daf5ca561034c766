"""Darcy-Weisbach friction of air in a round hose (paper eq. 1-4), the law both hose models use.

The paper's eq. 1 is Darcy-Weisbach, dp = lambda (L/d) rho v^2 / 2, written with the standard
volume flow and folded constants; here it is written with the mass flow, so its constants need no
unit bookkeeping: with v = m / (rho A), dp = 8 lambda L m^2 / (pi^2 rho d^5).

lambda is Blasius' 0.316 Re^-0.25 (paper eq. 3) for turbulent flow. Departure from the paper:
below Re ~ 1189, where Blasius' lambda would fall under the laminar 64/Re, we take 64/Re
(Hagen-Poiseuille). lambda = max(64/Re, Blasius) is continuous and gives a finite slope of flow
against pressure at zero flow, which keeps the integration stable; at the paper's Re = 2497 the
two agree with the paper.

The lumped hose (pneumatics/joint.py, a pi-section) and the line with gas inertia
(pneumatics/line.py) both take their wall friction from here.
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
def hose_constants(length_m: float, diameter_m: float, mu_pa_s: float) -> tuple[float, float, float]:
    """The hose's and the gas's part of `hose_mass_flow`, (k_laminar, laminar_limit, k_blasius) in
    SI units, so that with the density rho of the hose's air and the drop dp:

    laminar  m = k_laminar rho dp,           k_laminar = pi d^4 / (128 mu L) (Hagen-Poiseuille);
    the branch turns where Re = 4 m / (pi d mu) reaches BLASIUS_LAMINAR_RE: at laminar_limit (kg/s);
    Blasius  m = (k_blasius rho dp)^(1/1.75), k_blasius = pi^2 d^5 / (8 * 0.316 (4 / (pi d mu))^-0.25 L).

    They depend on the hose and the gas only: the kernels keep them in the parameter row (`params_row`).
    """
    d = diameter_m
    k_laminar = math.pi * d**4 / (128.0 * mu_pa_s * length_m)
    laminar_limit = BLASIUS_LAMINAR_RE * math.pi * d * mu_pa_s / 4.0
    k_blasius = math.pi**2 * d**5 / (8.0 * 0.316 * (4.0 / (math.pi * d * mu_pa_s)) ** -0.25 * length_m)
    return k_laminar, laminar_limit, k_blasius


@njit
def hose_mass_flow(
    p_in_pa: float, p_out_pa: float, t_mean_k: float, length_m: float, diameter_m: float, r: float, mu_pa_s: float
) -> float:
    """Signed mass flow in kg/s through a hose from the pressure at its two ends: eq. 1-4 inverted.

    Exact inverse of `hose_pressure_drop` with the density at (p_in + p_out)/2: on the laminar
    branch dp = 128 mu L m / (pi rho d^4), on the Blasius branch dp is proportional to m^1.75;
    the branch is picked by the Reynolds number of the result (`hose_constants`).
    """
    k_laminar, laminar_limit, k_blasius = hose_constants(length_m, diameter_m, mu_pa_s)
    return hose_mass_flow_with(p_in_pa, p_out_pa, t_mean_k, r, k_laminar, laminar_limit, k_blasius)


@njit
def hose_mass_flow_with(
    p_in_pa: float, p_out_pa: float, t_mean_k: float, r: float, k_laminar: float, laminar_limit: float, k_blasius: float
) -> float:
    """`hose_mass_flow` with the hose's `hose_constants` passed in (the kernels keep them).

    The Blasius branch's power x^(1/1.75) is taken as exp(log(x) / 1.75), cheaper than pow: within
    2.3e-15 (relative) of the exact x^(4/7) for flows from the laminar limit of the 4 mm hoses
    (6.8e-5 kg/s) to 0.1 kg/s, against pow's 6.6e-16 (5000 flows, against 50-digit decimals; log's
    one-ulp error, scaled by |log x| / 1.75 < 10, dominates).
    """
    dp = p_in_pa - p_out_pa
    if dp == 0.0:
        return 0.0
    rho = 0.5 * (p_in_pa + p_out_pa) / (r * t_mean_k)
    adp = abs(dp)
    m = k_laminar * rho * adp
    if m > laminar_limit:
        m = math.exp(math.log(k_blasius * rho * adp) * (1.0 / 1.75))
    return m if dp > 0.0 else -m


@njit(inline="always")
def hose_resistance_with(
    mass_flow_kg_s: float, rho_kg_m3: float, k_laminar: float, laminar_limit: float, k_blasius: float
) -> float:
    """The drop per unit of flow, dp / m in Pa·s/kg, of a hose carrying `mass_flow_kg_s` (either
    sign) in gas of density rho: the secant of `hose_mass_flow_with`'s law, with the same
    `hose_constants`. Laminar 1 / (k_laminar rho) up to the laminar limit (also at zero flow, where
    it is the law's slope); Blasius |m|^0.75 / (k_blasius rho) above it (`hose_resistance_of`).
    The lines with gas inertia (pneumatics/line.py, gas_line.py) take their wall friction from it,
    linearly implicit in the flow.
    """
    return hose_resistance_of(abs(mass_flow_kg_s), 1.0 / rho_kg_m3, 1.0 / k_laminar, laminar_limit, 1.0 / k_blasius)


@njit(inline="always")
def hose_resistance_of(
    flow_abs_kg_s: float, rho_inv: float, inv_k_laminar: float, laminar_limit: float, inv_k_blasius: float
) -> float:
    """`hose_resistance_with` from |m|, 1 / rho and the reciprocals of the `hose_constants` (a
    caller that steps many segments keeps them and divides once per segment), without a branch
    (both laws taken, one kept: a loop over segments stays straight). The Blasius power |m|^0.75 is
    taken as sqrt(|m| sqrt(|m|)): two correctly rounded roots, within a few ulps of the exact power
    and several times cheaper than exp(0.75 log |m|).
    """
    blasius = math.sqrt(flow_abs_kg_s * math.sqrt(flow_abs_kg_s)) * inv_k_blasius
    return rho_inv * (inv_k_laminar if flow_abs_kg_s <= laminar_limit else blasius)


@njit
def hose_volume(length_m: float, diameter_m: float) -> float:
    """Internal volume of a round hose in m^3."""
    return 0.25 * math.pi * diameter_m**2 * length_m
