"""Hoses that are lines with chambers by the energy balance (`hose_model = 1` with `chamber_heat = 1`,
pneumatics/joint.py `advance_hoses`, pneumatics/line.py `FarEnd.gas_rt`).

The line's gas is at its wall's temperature (the supply's): gas from the line brings that gas's
enthalpy into a chamber, gas into the line leaves the chamber at the chamber's own temperature and
the line's wall takes or gives the difference (docs/air_lines.md, "With the chambers' energy balance").

Layers (STYLE rule 8):
- conservation: the joint's whole air (both lines, both chambers, the vane leak, a hose leak, walls
  exchanging heat) stores the mass its valve ends passed, and its internal energy changes by the
  enthalpy they passed plus the heat the walls gave, to round-off; a line's chamber whose volume
  moves, less the work its gas did;
- analytic: with adiabatic walls a filled chamber discharging into its line follows the isentrope
  T / T0 = (p / p0)^((k-1)/k) while its gas only leaves it, and a chamber filled from 1 atm ends at
  k T_s p1 / (p1 + (k - 1) p0) less what the line's wall took from gas that flowed back;
- the plant's at-rest shortcut waits for warm chambers at atmosphere to reach the wall;
- whole runs: the plant's exhaust holds for L/c and agrees with `pneumatics.hose.line_response`
  (tests/test_plant_line.py), the closed loop reaches 60 deg, the gap replay holds L/c
  (tests/test_plant_line.py, parametrized over the chamber law).
"""

from __future__ import annotations

import numpy as np
import pytest

import assets
from pneumatics import AIR, load_joint_params, params_row
from pneumatics import joint as J
from pneumatics import params as P
from pneumatics.line import (
    LR_AREA,
    LR_DX,
    LR_N,
    LR_RT,
    LR_SEGMENTS,
    FarEnd,
    advance_from_port,
    initial_line_state,
    line_row,
    state_size,
    stored_mass,
)
from pneumatics.motor import chamber_geometry
from pneumatics.orifice import choked_flux

SUPPLY_05 = AIR.p_atm_pa + 0.5e6  # the paper's 0.5 MPa, gauge
K = AIR.k
R = AIR.r_j_per_kg_k
T_S = AIR.t_supply_k
BOTH = load_joint_params(assets.joint_param_path("wrist_pitch"))._replace(hose_model=1.0, chamber_heat=1.0)
DT = 5e-4  # the plant's physics step, s


def _still_joint(params, phi: float = 0.3):
    # a joint's row, state with its lines and chambers' volumes at phi, the motor held
    p = params_row(params, AIR, DT)
    x = J.with_hoses(J.initial_state(AIR.p_atm_pa), p)
    v_a, v_b, _ = chamber_geometry(phi, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V],
                                   p[P.HALF_PITCH_V])  # fmt: skip
    return p, x, v_a, v_b


def _line_and_chamber(line: np.ndarray, row: np.ndarray, v_chamber: float, t_chamber: float) -> tuple[float, float]:
    """(mass in kg, internal energy p V / (k - 1) in J) of a line and the chamber at its far end: the
    line's nodes count mass as their law does (`stored_mass`, n = k at the line's R T), the far node
    (the chamber and half a segment) at the chamber's temperature."""
    n = int(row[LR_SEGMENTS])
    half_seg = 0.5 * row[LR_AREA] * row[LR_DX]
    line_mass = stored_mass(line, row, 0.0) - half_seg * line[n] / (row[LR_N] * row[LR_RT])
    chamber_mass = line[n] * (half_seg + v_chamber) / (R * t_chamber)
    pv = stored_mass(line, row, v_chamber) * row[LR_N] * row[LR_RT]  # sum p V over every node
    return line_mass + chamber_mass, pv / (K - 1.0)


def test_the_joints_air_keeps_its_mass_and_energy_budget_to_round_off() -> None:
    """Fill, reverse and exhaust with the vane leak, a leak in port A's hose and walls at 3x their
    correlations, the motor held: the air stored changes by the mass the valve ends passed, and its
    internal energy by cp T_s times that mass (the line's gas is at the supply temperature at the valve
    ends) plus the heat the walls gave (`HoseStep.heat_w`), to round-off."""
    params = BOTH._replace(leak_area_m2=2e-6, hose_leak_area_m2=0.2e-6, wall_heat_scale=3.0)
    p, x, v_a, v_b = _still_joint(params)
    lines = x[J.N_STATE :]
    row = J.line_row_of(p)
    size = state_size(row)
    ta, tb = T_S, T_S

    def stored() -> tuple[float, float]:
        ma, ua = _line_and_chamber(lines[:size], row, v_a, ta)
        mb, ub = _line_and_chamber(lines[size:], row, v_b, tb)
        return ma + mb, ua + ub

    mass0, energy0 = stored()
    passed = moved = heat = 0.0
    coldest, hottest = T_S, T_S
    cp_ts = K / (K - 1.0) * R * T_S
    for direction, steps in ((+1.0, 600), (-1.0, 600), (0.0, 600)):
        for _ in range(steps):
            s = J.advance_hoses(lines, 0.3, 0.0, direction, 0.5e6, SUPPLY_05, DT, p, ta, tb)
            ta, tb = s.ta_motor, s.tb_motor
            passed += DT * (s.a_inflow_kg_s + s.b_inflow_kg_s)
            moved += DT * (abs(s.a_inflow_kg_s) + abs(s.b_inflow_kg_s))
            heat += DT * s.heat_w
            assert s.work_w == 0.0  # the motor held
            coldest, hottest = min(coldest, ta, tb), max(hottest, ta, tb)
    mass1, energy1 = stored()
    mass_error = abs(mass1 - mass0 - passed)
    energy_error = abs(energy1 - energy0 - cp_ts * passed - heat)
    print(
        f"\nmass passed {moved * 1e3:.4f} g, off by {mass_error:.2e} kg; energy passed {cp_ts * moved:.1f} J, "
        f"wall heat {heat:.2f} J, off by {energy_error:.2e} J; chambers {coldest:.1f}-{hottest:.1f} K"
    )
    assert moved > 1e-4  # air did move (kg)
    assert hottest - T_S > 5.0 and T_S - coldest > 5.0  # the chambers' gas did heat and cool
    assert abs(heat) > 1e-3 * cp_ts * moved  # the walls did exchange heat
    assert mass_error < 1e-12 * moved
    assert energy_error < 1e-12 * cp_ts * moved


def test_with_adiabatic_walls_a_chamber_fills_and_discharges_as_its_energy_balance_says() -> None:
    """Adiabatic walls (wall_heat_scale = 0), no leaks, the motor held. Filled from 1 atm through the
    8 m line to 0.5 MPa: every kg the chamber took came from the line at the supply temperature, so its
    gas ends at k T_s p1 / (p1 + (k - 1) p0) (the chamber's node: the chamber and half a segment), less
    what the line's wall took from gas that flowed back (`entry` heat, accounted here). Then exhausted:
    gas only leaves it (until the wave's first reflection brings some back), so its temperature
    follows the isentrope from where it stood."""
    params = BOTH._replace(wall_heat_scale=0.0)
    p, x, v_a, _ = _still_joint(params)
    lines = x[J.N_STATE :]
    row = J.line_row_of(p)
    n = int(row[LR_SEGMENTS])
    v_node = v_a + 0.5 * row[LR_AREA] * row[LR_DX]
    ta, tb = T_S, T_S
    p0 = lines[n]
    took = 0.0  # heat the line's wall gave gas leaving the chamber (<= 0 when it is warmer)
    for _ in range(4000):
        s = J.advance_hoses(lines, 0.3, 0.0, +1.0, 0.5e6, SUPPLY_05, DT, p, ta, tb)
        ta, tb = s.ta_motor, s.tb_motor
        took += DT * s.heat_w
    p1 = lines[n]
    # the chamber's node: U1 - U0 = cp T_s m_in + took, m_in = p1 V / (R T1) - p0 V / (R T_s)
    # => p1 V / (k-1) = p0 V / (k-1) + k/(k-1) T_s (p1 V / T1 - p0 V / T_s) + took
    t_expected = K * T_S * p1 / (p1 + (K - 1.0) * p0 - (K - 1.0) * took / v_node)
    t_no_backflow = K * T_S * p1 / (p1 + (K - 1.0) * p0)
    print(f"\nfilled to {p1 / 1e5:.3f} bar: T {ta:.3f} K, expected {t_expected:.3f} K "
          f"({t_no_backflow:.2f} K without backflow, {took:.3f} J to the line's wall); port B {tb:.3f} K")  # fmt: skip
    assert ta == pytest.approx(t_expected, rel=1e-9)
    # the wave overshoots the valve's level and warm gas flows back into the line: measured 6 K cooler
    assert took < 0.0 and t_no_backflow - 10.0 < ta < t_no_backflow
    assert tb == pytest.approx(T_S, abs=1e-9)  # port B's line and chamber stood at the atmosphere
    p_start, t_start = lines[n], ta
    worst = 0.0
    steps = 0
    while lines[2 * n] <= 0.0 and steps < 400:  # until gas first flows back into the chamber
        s = J.advance_hoses(lines, 0.3, 0.0, 0.0, 0.0, SUPPLY_05, DT, p, ta, tb)
        ta = s.ta_motor
        steps += 1
        isentrope = t_start * (lines[n] / p_start) ** ((K - 1.0) / K)
        worst = max(worst, abs(ta - isentrope))
    print(f"exhaust over {steps * DT * 1e3:.1f} ms to {lines[n] / 1e5:.3f} bar, {ta:.2f} K: isentrope within "
          f"{worst:.2e} K")  # fmt: skip
    # measured: 31.5 ms (the first reflection brings gas back), 6.01 -> 5.52 bar, 378.4 -> 369.3 K
    assert lines[n] < 0.95 * p_start and ta < t_start - 5.0
    assert worst < 0.05  # K; measured 0.027: the outflow at the sub-step's starting temperature, first order


def test_a_chamber_whose_volume_moves_keeps_its_energy_budget_with_its_work() -> None:
    """The line alone (pneumatics/line.py), 8 m of 4 mm fed from 6 bar, its far end a chamber of 3 cm^3
    whose volume swings by +-1 cm^3 at 5 Hz (a vane chamber turning), walls exchanging heat: over 0.4 s
    the line's and the chamber's internal energy change by the enthalpy the inlet passed plus the walls'
    heat less the work the chamber's gas did (`LineStep.end_work_w`), to round-off; the work is the
    integral of p dV to first order in the step (measured 4.7 % off while the line fills)."""
    row = line_row(8.0, 0.004, T_S, R, K, AIR.mu_pa_s, 10)
    x = initial_line_state(row, AIR.p_atm_pa)
    n = int(row[LR_SEGMENTS])
    flux = choked_flux(T_S, R, K)
    volume, rt = 3e-6, R * T_S
    cp_ts = K / (K - 1.0) * R * T_S
    energy0 = stored_mass(x, row, volume) * K * row[LR_RT] / (K - 1.0)
    enthalpy = heat = work = p_dv = 0.0
    for i in range(800):
        rate = 1e-6 * 2.0 * np.pi * 5.0 * np.cos(2.0 * np.pi * 5.0 * (i + 0.5) * DT)  # m^3/s
        p_start = x[n]
        s = advance_from_port(
            x, row, DT, 6e5, 1e-6, AIR.p_atm_pa, 0.0, flux, K, FarEnd(volume, rate, 0.0, 0.0, 0.0, K, rt, 0.0, 2e-4)
        )
        rt = s.end_rt
        volume += rate * DT
        enthalpy += DT * cp_ts * s.inlet_flow_kg_s
        heat += DT * (s.end_heat_w + s.entry_heat_w)
        work += DT * s.end_work_w
        p_dv += 0.5 * (p_start + x[n]) * rate * DT
    energy1 = stored_mass(x, row, volume) * K * row[LR_RT] / (K - 1.0)
    error = abs(energy1 - energy0 - enthalpy - heat + work)
    print(f"\nenthalpy in {enthalpy:.3f} J, heat {heat:.4f} J, work {work:.5f} J (p dV {p_dv:.5f}), off {error:.1e} J")
    assert abs(heat) > 1e-3 and abs(work) > 1e-4
    assert error < 1e-12 * enthalpy
    # the implicit step's work h dV (k p_new - p) / (k - 1) is p dV to first order: it differs by
    # (p_new - p) / (k - 1) per step, 5 % of the work here while the fill's wave moves the pressure
    # ~1 % a step; 2e-5 of the energy that passed
    assert abs(work - p_dv) < 0.1 * abs(p_dv) and abs(work - p_dv) < 1e-4 * enthalpy


def test_a_still_joint_at_atmosphere_with_warm_chambers_is_not_skipped() -> None:
    """The plant's shortcut for a still joint with shut valves whose lines are at rest at atmosphere
    waits, with the energy balance, for its chambers' gas to reach the wall: warm gas at 1 atm still
    cools (and flows), then the joint is at rest again."""
    p = params_row(BOTH, AIR, DT)
    x = J.with_hoses(J.initial_state(AIR.p_atm_pa), p)
    x[J.S_TA_MOTOR] = 330.0
    J.advance_air_pair(x, 0.0, 0.0, 0.0, SUPPLY_05, DT, p)
    assert x[J.S_TA_MOTOR] < 330.0  # cooled: the step was taken
    for _ in range(40000):  # 20 s
        J.advance_air_pair(x, 0.0, 0.0, 0.0, SUPPLY_05, DT, p)
    print(f"\nafter 20 s: {x[J.S_TA_MOTOR]:.6f} K, {x[J.S_PA_MOTOR]:.3f} Pa")
    assert abs(x[J.S_TA_MOTOR] - T_S) < 1e-3
