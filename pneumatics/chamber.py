"""A control volume of air: the paper's polytropic pressure rate, and the energy balance.

Polytropic (the paper's eq. 7, third and fourth rows; what the predictor integrates):

    dp/dt = n / V * (R T_s m_in - p dV/dt)

(Richer & Hurmuzlu 2000, eq. 19, with the inflow at supply temperature as in the paper's K_c.)
n = k = 1.4 is the paper's adiabatic assumption 1; 1 <= n < k models heat exchange with the
motor body (DESIGN, "Heat"). With no flow it keeps p V^n constant. Every flow, in or out, is
taken at the supply temperature: a chamber that discharges loses the energy of supply-temperature
air, so the temperature its p and m imply sinks far below any real gas's (about 100 K in the
vessel of docs/air_chambers.md, against a measured low of 256 K).

Energy balance (first law of an open system of ideal gas, internal energy cv T, enthalpy cp T;
e.g. Richer & Hurmuzlu 2000, eq. 11-13, before their polytropic simplification): each flow m_i
(kg/s, + into the volume) carries the enthalpy of the gas it comes from, cp T_i, with T_i the
upstream side's temperature for an inflow and the volume's own T for an outflow
(`carried_temperature`); the heat Q (W) comes in from the wall, and the gas does work p dV/dt.
With the state (p, T), m = p V / (R T):

    dp/dt = k / V (R sum m_i T_i - p dV/dt) + (k - 1) / V Q
    dT/dt = R T / (p V) (k sum m_i T_i - T sum m_i) + (k - 1) T / (p V) (Q - p dV/dt)

State (p, T) rather than (m, T) or (m, U): the flows, the vane torque and the sensors read p, so
the kernels keep their pressure columns and ROS2's pressure blocks of W (pneumatics/joint.py): the
polytropic law is the first row with n = k, every T_i = T_s and Q = 0, and T is one more column
per volume. (m, U) would conserve mass and energy to round-off, but every rate evaluation would
divide back to p.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pneumatics._jit import njit
from pneumatics.gas import AIR, Gas
from pneumatics.heat import vessel_heat_transfer_coefficient
from pneumatics.integrators import rk4_increment
from pneumatics.orifice import orifice_mass_flow_between


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


class ChamberRates(NamedTuple):
    """Rates of a control volume's state (p, T)."""

    dp_dt_pa_s: float
    dt_dt_k_s: float


@njit(inline="always")
def carried_temperature(mass_flow_in_kg_s: float, t_upstream_k: float, t_own_k: float) -> float:
    """Temperature (K) of the gas a flow carries into (m > 0) or out of (m < 0) a volume: the
    other side's gas for an inflow, the volume's own for an outflow."""
    return t_upstream_k if mass_flow_in_kg_s > 0.0 else t_own_k


@njit
def chamber_energy_rates(
    p_pa: float,
    t_k: float,
    volume_m3: float,
    volume_rate_m3_s: float,
    net_mass_flow_kg_s: float,
    temperature_flow_k_kg_s: float,
    heat_in_w: float,
    r: float,
    k: float,
) -> ChamberRates:
    """(dp/dt in Pa/s, dT/dt in K/s) of a volume of ideal gas at p_pa, t_k (module docstring).

    `net_mass_flow_kg_s` is sum m_i over the volume's flows (+ in), `temperature_flow_k_kg_s` is
    sum m_i T_i with each flow's `carried_temperature` (the enthalpy flow is cp times it),
    `heat_in_w` the heat from the wall, h A (T_wall - T). The volume is V (m^3), changing at dV/dt.
    """
    work_rate = p_pa * volume_rate_m3_s
    dp = (k * (r * temperature_flow_k_kg_s - work_rate) + (k - 1.0) * heat_in_w) / volume_m3
    t_over_pv = t_k / (p_pa * volume_m3)
    dt = t_over_pv * (
        r * (k * temperature_flow_k_kg_s - t_k * net_mass_flow_kg_s) + (k - 1.0) * (heat_in_w - work_rate)
    )
    return ChamberRates(dp, dt)


# --- a rigid vessel discharging or filling through an orifice --------------------------------------
class _Vessel(NamedTuple):
    volume_m3: float
    wall_area_m2: float
    orifice_area_m2: float
    t_wall_k: float
    back_pa: float
    t_back_k: float
    length_m: float
    jet_diameter_m: float
    r: float
    k: float


@njit
def _vessel_rates(p_pa: float, t_k: float, v: _Vessel) -> ChamberRates:
    # the one flow, from the surroundings into the vessel (negative: discharging), at the
    # upstream gas's temperature; the wall at t_wall_k
    m_in = orifice_mass_flow_between(v.back_pa, p_pa, v.orifice_area_m2, v.t_back_k, t_k, v.r, v.k)
    h = vessel_heat_transfer_coefficient(p_pa, t_k, v.t_wall_k, m_in, v.length_m, v.jet_diameter_m, v.r, v.k)
    heat = h * v.wall_area_m2 * (v.t_wall_k - t_k)
    t_carried = carried_temperature(m_in, v.t_back_k, t_k)
    return chamber_energy_rates(p_pa, t_k, v.volume_m3, 0.0, m_in, m_in * t_carried, heat, v.r, v.k)


MAX_RELATIVE_CHANGE = 0.02  # of p or T over one RK4 step (`_vessel_run`)


@njit
def _vessel_run(
    sorted_times_s: np.ndarray, p0_pa: float, t0_k: float, v: _Vessel, max_step_s: float
) -> tuple[np.ndarray, np.ndarray]:
    # classical RK4 from t = 0 through the sorted output times, each step at most max_step_s long
    # and short enough that p and T change by at most MAX_RELATIVE_CHANGE at their first stage's
    # rates: a nearly evacuated vessel's gas is renewed in microseconds (m / m_in), a full one's in
    # seconds, and the steps follow
    n = sorted_times_s.size
    p_out = np.empty(n)
    t_out = np.empty(n)
    p, t, now = p0_pa, t0_k, 0.0
    for i in range(n):
        target = sorted_times_s[i]
        while now < target:
            k1 = _vessel_rates(p, t, v)
            h = min(max_step_s, target - now)
            h = min(h, MAX_RELATIVE_CHANGE * p / max(abs(k1.dp_dt_pa_s), 1e-300))
            h = min(h, MAX_RELATIVE_CHANGE * t / max(abs(k1.dt_dt_k_s), 1e-300))
            k2 = _vessel_rates(p + 0.5 * h * k1[0], t + 0.5 * h * k1[1], v)
            k3 = _vessel_rates(p + 0.5 * h * k2[0], t + 0.5 * h * k2[1], v)
            k4 = _vessel_rates(p + h * k3[0], t + h * k3[1], v)
            p += rk4_increment(h, k1[0], k2[0], k3[0], k4[0])
            t += rk4_increment(h, k1[1], k2[1], k3[1], k4[1])
            now = target if h == target - now else now + h
        p_out[i] = p
        t_out[i] = t
    return p_out, t_out


def _positive(name: str, value: float, unit: str, allow_zero: bool = False) -> float:
    """`value` as a float if it is a finite number > 0 (>= 0 with allow_zero), else ValueError."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not math.isfinite(x) or x < 0.0 or (x == 0.0 and not allow_zero):
        allowed = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"vessel_response: {name} = {value!r} is not allowed: a finite number {allowed} ({unit})")
    return x


def _times(times_s: np.ndarray) -> np.ndarray:
    """`times_s` as a 1-D float array of finite times >= 0, else ValueError naming the bad one."""
    try:
        times = np.asarray(times_s, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"vessel_response: times_s = {times_s!r} is not allowed: an array of times (s)") from None
    if times.ndim != 1:
        raise ValueError(
            f"vessel_response: times_s = an array of shape {times.shape} is not allowed: a 1-D array of times (s)"
        )
    bad = np.flatnonzero(~np.isfinite(times) | (times < 0.0))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"vessel_response: times_s[{i}] = {times[i]!r} is not allowed: a finite time >= 0 (s)")
    return times


def vessel_response(
    volume_m3: float,
    wall_area_m2: float,
    orifice_area_m2: float,
    p0_pa: float,
    t0_k: float,
    back_pa: float,
    times_s: np.ndarray,
    *,
    length_m: float | None = None,
    jet_diameter_m: float | None = None,
    max_step_s: float = 0.01,
    gas: Gas = AIR,
) -> tuple[np.ndarray, np.ndarray]:
    """(pressure_pa, gas_temperature_k) of a rigid vessel of air at `times_s` (s from the start).

    The vessel (volume_m3, inner wall area wall_area_m2) starts at p0_pa (absolute) and t0_k and
    is joined through one orifice to surroundings at back_pa (absolute) and t0_k: it discharges when
    p0_pa > back_pa and fills from the surroundings when p0_pa < back_pa. `orifice_area_m2` is the
    effective area, the discharge coefficient times the geometric area (HydDown's vessel: 0.84
    times pi/4 (2.71 mm)^2). The gas follows the energy balance (`chamber_energy_rates`), the
    orifice the standard law at the upstream gas's temperature (`orifice_mass_flow_between`), the
    heat to the wall HydDown's natural and jet convection (`heat.vessel_heat_transfer_coefficient`)
    over the whole wall_area_m2 (0: adiabatic). The wall stays at t0_k: a steel vessel's wall
    holds ~100 times the gas's heat capacity (docs/air_chambers.md: 26 kg of steel, 13 kJ/K,
    against 0.15 kg of air, 0.1 kJ/K: the 6.5 kJ the discharge draws from it cool it by 0.5 K).

    Keyword-only: `length_m`, the enclosure's height for the jet's Nusselt number (HydDown: a
    horizontal vessel's diameter; default 6 V / A, the diameter of a cylinder as long as it is
    wide with this V / A); `jet_diameter_m`, the inflow jet's diameter in its Reynolds number
    (HydDown's D_throat; default: length_m); `max_step_s`, the RK4 step's bound; `gas`.
    Bad arguments raise ValueError naming the argument, its value and what is allowed.
    """
    volume = _positive("volume_m3", volume_m3, "m^3")
    area = _positive("wall_area_m2", wall_area_m2, "m^2", allow_zero=True)
    orifice = _positive("orifice_area_m2", orifice_area_m2, "m^2")
    p0 = _positive("p0_pa", p0_pa, "Pa, absolute")
    t0 = _positive("t0_k", t0_k, "K")
    back = _positive("back_pa", back_pa, "Pa, absolute")
    step = _positive("max_step_s", max_step_s, "s")
    default_length = 6.0 * volume / area if area > 0.0 else volume ** (1.0 / 3.0)
    length = default_length if length_m is None else _positive("length_m", length_m, "m")
    jet = length if jet_diameter_m is None else _positive("jet_diameter_m", jet_diameter_m, "m")
    times = _times(times_s)
    vessel = _Vessel(volume, area, orifice, t0, back, t0, length, jet, gas.r_j_per_kg_k, gas.k)
    order = np.argsort(times, kind="stable")
    p_sorted, t_sorted = _vessel_run(times[order], p0, t0, vessel, step)
    pressure = np.empty_like(times)
    temperature = np.empty_like(times)
    pressure[order] = p_sorted
    temperature[order] = t_sorted
    return pressure, temperature
