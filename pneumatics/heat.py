"""Heat between the air in a volume and its wall: transport properties and film coefficients.

The heat flow into the gas is Q = h A (T_wall - T) (W). Two sources of h, each with the
correlation it comes from:

- a vessel (an enclosure of still gas, filled through a jet): natural convection, Nu = 0.13
  Ra^(1/3) (Geankoplis, Transport Processes and Unit Operations, 3rd ed., 1993, eq. 4.7-4 and
  Table 4.7-1, the turbulent branch), plus, while gas flows in, the forced convection of the
  inflow's jet, Nu = 0.56 Re_d^0.67 (Woodfield, Monde & Mitsutake, J. Therm. Sci. Tech. 2(2),
  2007, 180-191, measured on vessels charged with H2, N2 and Ar). This is HydDown's inner
  coefficient (github.com/andr1976/HydDown, src/hyddown/transport.py `Nu`, `h_inside`,
  `h_inside_mixed`; its manual's "Mixed convection"), properties at the film temperature
  (T + T_wall)/2 as there. Departure: HydDown switches to 0.59 Ra^(1/4) below Ra = 1e9, a jump
  of 20 % there, where the vessel's discharge sits (Ra ~ 1e8-1e9): we keep the one continuous law
  (an integrator must not meet a jump in the rates), whose h does not depend on the length.
- a vane motor's chamber (cm^3 cells swept at thousands of rpm): forced convection of a
  turbulent duct flow, Dittus-Boelter Nu = 0.023 Re^0.8 Pr^n (n = 0.4 when the wall heats the gas,
  0.3 when it cools it; Incropera & DeWitt, Fundamentals of Heat and Mass Transfer, 6th ed.,
  eq. 8.60), on the cell's hydraulic diameter 4 V / A and the stator's speed past the gas that
  turns with the cell (|omega| B), the usual reading of it in models of sliding-vane machines; it
  is floored at the laminar duct's Nu = 3.66 (Incropera eq. 8.55) for a motor at rest.

Transport properties of air from Sutherland's laws (White, Viscous Fluid Flow, 3rd ed., 2006,
Tables 1-2 and 1-3): within 2 % of the tables from 200 to 500 K.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from pneumatics._jit import njit
from pneumatics.motor import half_pitch_volume

GRAVITY_M_S2 = 9.80665  # standard gravity
# Sutherland's laws for air (White, Viscous Fluid Flow, 3rd ed., Tables 1-2 and 1-3)
_T_REF_K = 273.0
_MU_REF_PA_S = 1.716e-5
_MU_SUTHERLAND_K = 111.0
_CONDUCTIVITY_REF_W_M_K = 0.0241
_CONDUCTIVITY_SUTHERLAND_K = 194.0

NATURAL_C = 0.13  # Nu = 0.13 Ra^(1/3), Geankoplis Table 4.7-1, turbulent (HydDown transport.Nu)
JET_C, JET_EXPONENT = 0.56, 0.67  # Nu = 0.56 Re_d^0.67, Woodfield et al. 2007 (HydDown h_inside_mixed)
DUCT_C, DUCT_RE_EXPONENT = 0.023, 0.8  # Dittus-Boelter (Incropera eq. 8.60)
LAMINAR_DUCT_NU = 3.66  # fully developed laminar flow, uniform wall temperature (Incropera eq. 8.55)


@njit
def air_viscosity(t_k: float) -> float:
    """Dynamic viscosity of air in Pa s at t_k (Sutherland: 1.716e-5 at 273 K, S = 111 K)."""
    x = t_k / _T_REF_K
    return _MU_REF_PA_S * x * math.sqrt(x) * (_T_REF_K + _MU_SUTHERLAND_K) / (t_k + _MU_SUTHERLAND_K)


@njit
def air_conductivity(t_k: float) -> float:
    """Thermal conductivity of air in W/(m K) at t_k (Sutherland: 0.0241 at 273 K, S = 194 K)."""
    x = t_k / _T_REF_K
    return (
        _CONDUCTIVITY_REF_W_M_K
        * x
        * math.sqrt(x)
        * (_T_REF_K + _CONDUCTIVITY_SUTHERLAND_K)
        / (t_k + _CONDUCTIVITY_SUTHERLAND_K)
    )


@njit
def vessel_heat_transfer_coefficient(
    p_pa: float,
    t_gas_k: float,
    t_wall_k: float,
    inflow_kg_s: float,
    length_m: float,
    jet_diameter_m: float,
    r: float,
    k: float,
) -> float:
    """h in W/(m^2 K) between the gas of a vessel and its wall (HydDown's, module docstring).

    h = (Nu_natural + Nu_jet) k_air / L with Nu_natural = 0.13 Ra^(1/3), Ra = g beta |T_wall - T|
    L^3 rho^2 cp / (mu k_air) (beta = 1/T_film for an ideal gas; so h_natural does not depend on L),
    and Nu_jet = 0.56 Re^0.67, Re = 4 m_in / (pi d mu), while gas flows in (`inflow_kg_s` > 0)
    through a jet of diameter d = `jet_diameter_m`. L = `length_m` is the enclosure's height
    (HydDown: the diameter of a horizontal vessel). Properties at the film temperature and p_pa.
    """
    t_film = 0.5 * (t_gas_k + t_wall_k)
    mu = air_viscosity(t_film)
    conductivity = air_conductivity(t_film)
    cp = k * r / (k - 1.0)
    rho = p_pa / (r * t_film)
    # h_natural = 0.13 k_air (Ra / L^3)^(1/3): L cancels
    ra_per_l3 = GRAVITY_M_S2 / t_film * abs(t_wall_k - t_gas_k) * rho * rho * cp / (mu * conductivity)
    h = NATURAL_C * conductivity * ra_per_l3 ** (1.0 / 3.0)
    if inflow_kg_s > 0.0:
        reynolds = 4.0 * inflow_kg_s / (math.pi * jet_diameter_m * mu)
        h += JET_C * reynolds**JET_EXPONENT * conductivity / length_m
    return h


class VaneCell(NamedTuple):
    """The walls of one vane cell (the gas between two vanes), from the motor's dimensions."""

    area_per_volume_1_m: float  # wall area / cell volume
    hydraulic_diameter_m: float  # 4 V / A


@njit
def vane_cell(stator_radius_m: float, rotor_radius_m: float, vane_length_m: float, n_vanes: float) -> VaneCell:
    """The wall area per volume and hydraulic diameter of one vane cell (one vane pitch).

    A cell of volume V (the volume one pitch sweeps, 2 `half_pitch_volume`) is bounded by the
    stator's and the rotor's arcs, L pitch (B + r), two end plates, 2 V / L, and two vane faces
    of the mean radial gap g = V / (L pitch (B + r) / 2), 2 L g.
    """
    pitch = 2.0 * math.pi / n_vanes
    length = vane_length_m
    volume = 2.0 * half_pitch_volume(stator_radius_m, rotor_radius_m, vane_length_m, n_vanes)
    arcs = length * pitch * (stator_radius_m + rotor_radius_m)
    gap = volume / (0.5 * arcs)
    area = arcs + 2.0 * volume / length + 2.0 * length * gap
    return VaneCell(area / volume, 4.0 * volume / area)


@njit
def duct_heat_transfer_coefficient(
    speed_m_s: float, p_pa: float, t_gas_k: float, t_wall_k: float, hydraulic_diameter_m: float, r: float, k: float
) -> float:
    """h in W/(m^2 K) of gas moving at `speed_m_s` past the walls of a duct (module docstring).

    Dittus-Boelter, Nu = 0.023 Re^0.8 Pr^n with n = 0.4 when the wall heats the gas and 0.3 when
    it cools it, Re = rho |speed| D_h / mu, floored at the laminar duct's Nu = 3.66; properties at
    the film temperature and p_pa. For a hose: its bore and the flow's mean speed m / (rho A).
    """
    t_film = 0.5 * (t_gas_k + t_wall_k)
    mu = air_viscosity(t_film)
    conductivity = air_conductivity(t_film)
    prandtl = k * r / (k - 1.0) * mu / conductivity
    reynolds = p_pa / (r * t_film) * abs(speed_m_s) * hydraulic_diameter_m / mu
    exponent = 0.4 if t_wall_k > t_gas_k else 0.3
    nusselt = LAMINAR_DUCT_NU
    if reynolds > 0.0:  # Re^0.8 Pr^n as one exp of logs, cheaper than two pows (the kernels call it per step)
        nusselt = max(DUCT_C * math.exp(DUCT_RE_EXPONENT * math.log(reynolds) + exponent * math.log(prandtl)), nusselt)
    return nusselt * conductivity / hydraulic_diameter_m


@njit
def vane_chamber_heat_transfer_coefficient(
    omega_rad_s: float,
    p_pa: float,
    t_gas_k: float,
    t_wall_k: float,
    stator_radius_m: float,
    hydraulic_diameter_m: float,
    r: float,
    k: float,
) -> float:
    """h in W/(m^2 K) between the gas of a vane motor's chamber and its walls (module docstring).

    `duct_heat_transfer_coefficient` on the cell's hydraulic diameter (`vane_cell`) and the
    stator's speed past the gas that turns with the cell, |omega| B. The wrist's 1UP motor
    (B 11 mm, D_h 5.7 mm) at 6000 rpm and 0.5 MPa: Re ~ 1.3e4, h ~ 180 W/(m^2 K); at rest
    3.66 k / D_h ~ 16 W/(m^2 K).
    """
    return duct_heat_transfer_coefficient(
        omega_rad_s * stator_radius_m, p_pa, t_gas_k, t_wall_k, hydraulic_diameter_m, r, k
    )


class ChamberWall(NamedTuple):
    """Heat transfer of one chamber: its film coefficient and wall area."""

    h_w_m2_k: float
    wall_area_m2: float


@njit
def vane_chamber_heat_transfer(
    volume_m3: float,
    omega_rad_s: float,
    p_pa: float,
    t_gas_k: float,
    t_wall_k: float,
    stator_radius_m: float,
    rotor_radius_m: float,
    vane_length_m: float,
    n_vanes: float,
    r: float,
    k: float,
) -> ChamberWall:
    """h (W/(m^2 K)) and wall area (m^2) of a vane motor's chamber of volume `volume_m3` (its cells
    and porting, taken with a cell's area per volume) turning at `omega_rad_s` (motor side).

    Dittus-Boelter on the rotor's speed (`vane_chamber_heat_transfer_coefficient`); the kernels,
    which call it every step, keep `vane_cell` of their motor in the parameter row.
    """
    cell = vane_cell(stator_radius_m, rotor_radius_m, vane_length_m, n_vanes)
    h = vane_chamber_heat_transfer_coefficient(
        omega_rad_s, p_pa, t_gas_k, t_wall_k, stator_radius_m, cell.hydraulic_diameter_m, r, k
    )
    return ChamberWall(h, cell.area_per_volume_1_m * volume_m3)
