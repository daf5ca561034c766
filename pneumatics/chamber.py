"""Pressure rate of a control volume of air (paper eq. 7, third and fourth rows).

dp/dt = n / V * (R T_s m_in - p dV/dt)

(Richer & Hurmuzlu 2000, eq. 19, with the inflow at supply temperature as in the paper's K_c.)
n = k = 1.4 is the paper's adiabatic assumption 1; 1 <= n < k models heat exchange with the
motor body (DESIGN, "Heat"). With no flow it keeps p V^n constant.
"""

from __future__ import annotations

from pneumatics._jit import njit


@njit
def chamber_pressure_rate(
    p_pa: float,
    volume_m3: float,
    volume_rate_m3_s: float,
    net_mass_flow_kg_s: float,
    t_supply_k: float,
    r: float,
    n: float,
) -> float:
    """dp/dt in Pa/s of a chamber of volume V (m^3) changing at dV/dt with net inflow m (kg/s)."""
    return n / volume_m3 * (r * t_supply_k * net_mass_flow_kg_s - p_pa * volume_rate_m3_s)
