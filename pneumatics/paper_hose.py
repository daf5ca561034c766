"""The paper's hose loss as written (eq. 1-5): an algebraic drop on the supplied port, the controller's
predictor's law (DESIGN rule 2, `pneumatics.params.paper_model`).

    R   = 23378 lambda V^2 T_m rho_0 / (d^5 P_m)                       (eq. 1)
    P_m = (P_i + P_o) / 2,  T_m = (T_B + T_o) / 2
    T_B = T_s (P_B / P_s)^((k - 1) / k)                                 (eq. 2)
    lambda = 0.316 / Re^0.25 at the paper's Re = 2497                   (eq. 3)
    P_s = P_i - L_i R,  P_e = P_o                                       (eq. 4, 5)

P_i is the pressure entering the supplied port's hose (the proportional valve's output), P_o the
motor's outlet pressure: its exhaust goes to the atmosphere, and eq. 4 sets the exhausted
chamber's pressure P_B = P_e = P_o. T_o, the hose's far end, is the supply temperature. V is a
fixed standard volume flow (the joint file's `hose_standard_flow_m3_s`), not the flow the motor
draws: the drop does not follow the motor's speed, it falls as the supply rises (the 1/(P_i + P_o)
and the colder T_B), and it is there from the valve's opening on. P_s appears on both sides (eq. 2
takes the motor's source pressure, eq. 5 gives it); we solve the pair.

The plant and the gap replay keep the physical hose (pneumatics/darcy.py through a pi-section, or
pneumatics/line.py): the flow the hose really carries, on both ports.

Units of eq. 1's constant. Darcy-Weisbach, dP/L = lambda rho w^2 / (2 d), with the gas at the hose's
mean state rho = rho_0 (P_m / P_0)(T_0 / T_m) and w = V rho_0 / (rho pi d^2 / 4), is

    R = (8 / pi^2) (P_0 / T_0) lambda V^2 T_m rho_0 / (d^5 P_m)   (SI: Pa/m).

With the standard state P_0 = 101 325 Pa, T_0 = 273.15 K (P_0 / T_0 = 370.95 Pa/K), V in m^3/h
(1/3600^2), d in mm (1e15) and P_m in MPa (1e-6), R in Pa/m:
(8 / pi^2) 370.95 / 3600^2 * 1e15 * 1e-6 = 23 200, 0.8 % under the paper's 23 378 (which
P_0 / T_0 = 373.8 Pa/K would give). We keep the paper's number; eq. 5's 46 756 is 2 x 23 378 with
P_m written out. The state is 0 degC, not ISO 8778's 20 degC (P_0 / T_0 = 345.6 would give 21 600):
V and rho_0 are at 0 degC and 101.325 kPa.
"""

from __future__ import annotations

from pneumatics._jit import njit
from pneumatics.darcy import friction_factor
from pneumatics.gas import isentropic_temperature

PAPER_DARCY_CONSTANT = 23378.0  # eq. 1, R in Pa/m with V in m^3/h, d in mm, P_m in MPa (module docstring)
PAPER_REYNOLDS = 2497.0  # Sec. III-A: "In this paper, Re = 2497"
PAPER_LAMBDA = 0.316 * PAPER_REYNOLDS**-0.25  # eq. 3 (0.0447; `friction_factor` gives the same at this Re)
STANDARD_PRESSURE_PA = 101_325.0  # the standard state of V and rho_0: 0 degC, 101.325 kPa
STANDARD_TEMPERATURE_K = 273.15
STANDARD_DENSITY_KG_M3 = 1.293  # rho_0, dry air at 0 degC, 101.325 kPa (standard tables)
_SOLVE_TOL_PA = 1e-6  # the drop's fixed point to a micropascal (it converges by ~0.1 dP/P_s a pass)
_SOLVE_PASSES = 50

assert abs(friction_factor(PAPER_REYNOLDS) - PAPER_LAMBDA) < 1e-15, "Blasius' branch at the paper's Re"


@njit
def paper_hose_drop(
    p_in_pa: float,
    p_out_pa: float,
    t_supply_k: float,
    k: float,
    length_m: float,
    diameter_m: float,
    standard_flow_m3_s: float,
) -> float:
    """The pressure lost along the supplied port's hose, Delta P_i = L_i R of eq. 4-5 (Pa), P_i =
    `p_in_pa` and P_o = `p_out_pa` absolute, the hose `length_m` x `diameter_m`, V =
    `standard_flow_m3_s` (m^3/s at 0 degC, 101.325 kPa). T_m = (T_B + T_s)/2 with T_B from eq. 2 at
    P_B = P_o and the motor's source pressure P_s = P_i - Delta P_i (taken no lower than P_o).

    It may exceed P_i - P_o: eq. 5 at a flow the hose cannot carry (the caller floors P_s at P_o)."""
    # eq. 5's factor of T_m, in the paper's units: V m^3/h, d mm, P MPa; Pa/K
    v_h = standard_flow_m3_s * 3600.0
    d_mm = diameter_m * 1e3
    per_kelvin = (
        2.0
        * PAPER_DARCY_CONSTANT
        * PAPER_LAMBDA
        * length_m
        * v_h
        * v_h
        * STANDARD_DENSITY_KG_M3
        / (d_mm**5 * (p_in_pa + p_out_pa) * 1e-6)
    )
    if per_kelvin == 0.0:
        return 0.0
    drop = per_kelvin * t_supply_k  # T_m at its warmest; eq. 2 then cools it
    for _ in range(_SOLVE_PASSES):
        p_s = max(p_in_pa - drop, p_out_pa)
        t_m = 0.5 * (isentropic_temperature(p_out_pa, p_s, t_supply_k, k) + t_supply_k)  # eq. 2, T_m
        new = per_kelvin * t_m
        if abs(new - drop) <= _SOLVE_TOL_PA:
            return new
        drop = new
    return drop


@njit(inline="always")
def paper_source_pressure(
    p_in_pa: float,
    p_out_pa: float,
    t_supply_k: float,
    k: float,
    length_m: float,
    diameter_m: float,
    standard_flow_m3_s: float,
) -> float:
    """P_s of eq. 5 (Pa, absolute): `p_in_pa` less `paper_hose_drop`, no lower than P_o."""
    drop = paper_hose_drop(p_in_pa, p_out_pa, t_supply_k, k, length_m, diameter_m, standard_flow_m3_s)
    return max(p_out_pa, p_in_pa - drop)
