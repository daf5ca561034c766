"""The finite-amplitude line (pneumatics/gas_line.py, behind `pneumatics.hose.line_response`) against
references it does not contain: the exact Riemann solution of a frictionless shock tube (Sod's and
an air tube at 7:1, tests/exact_riemann.py), mass and energy conservation, the delay L/c of a small
step, a grid four times as fine on finite-amplitude fills and exhausts of 1, 3 and 8 m, and a
measured-looking inlet (noise, a 1.5 ms step, 1-8 bar).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from exact_riemann import sample

from pneumatics import AIR, _jit
from pneumatics.gas_line import (
    FarEnd,
    advance_from_flow,
    advance_from_orifice,
    advance_from_pressure,
    cell_pressures,
    initial_line_state,
    line_row,
    segments_for,
    stored_energy,
    stored_mass,
)
from pneumatics.hose import LINE_RESPONSE_BAND_HZ, LINE_RESPONSE_MIN_CELLS, line_response
from pneumatics.line_series import GAS_LINE, far_end_series
from pneumatics.orifice import choked_flux

R, K, MU, T = AIR.r_j_per_kg_k, AIR.k, AIR.mu_pa_s, AIR.t_supply_k
ATM = AIR.p_atm_pa
C = math.sqrt(K * R * T)
BORE = 4.0e-3  # the arm's hoses (DESIGN table)
DT = 0.5e-3  # the plant's physics step


# --- the gas dynamics against the exact Riemann solution -----------------------------------------
def _shock_tube(left, right, cells: int, t_end: float) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    # a 1 m line without friction nor heat (mu = 0, heat off), closed at the inlet (no flow) and at
    # the far end (its half cell), split at its middle; run until t_end (the waves stay inside)
    row = line_row(1.0, BORE, T, R, K, 0.0, cells, False, False)
    x = initial_line_state(row, ATM)
    dx = 1.0 / (cells - 1)
    centres = np.concatenate(([0.25 * dx], (np.arange(1, cells - 1)) * dx, [1.0 - 0.25 * dx]))
    for i, xc in enumerate(centres):
        rho, u, p = left if xc < 0.5 else right
        x[i], x[cells + i], x[2 * cells + i] = rho, rho * u, p / (K - 1.0) + 0.5 * rho * u * u
    for _ in range(100):
        advance_from_flow(x, row, t_end / 100, 0.0, FarEnd())
    rho = x[:cells]
    u = x[cells : 2 * cells] / rho
    return centres, (rho, u, (K - 1.0) * (x[2 * cells : 3 * cells] - 0.5 * rho * u * u))


SOD = ((1.0, 0.0, 1.0e5), (0.125, 0.0, 1.0e4), 0.6e-3)  # Sod's states in kg/m^3, m/s, Pa; 0.6 ms
AIR_7_TO_1 = ((7.0e5 / (R * T), 0.0, 7.0e5), (ATM / (R * T), 0.0, ATM), 0.6e-3)  # room air at 7:1


@pytest.mark.parametrize(("left", "right", "t_end"), [SOD, AIR_7_TO_1], ids=["sod", "air_7_to_1"])
def test_a_shock_tube_meets_the_exact_riemann_solution(left, right, t_end) -> None:
    errors = []
    for cells in (101, 401):
        centres, model = _shock_tube(left, right, cells, t_end)
        exact = sample(left, right, K, (centres - 0.5) / t_end)
        inner = (centres > 0.05) & (centres < 0.95)
        errors.append([np.mean(np.abs(m - e)[inner]) / np.max(np.abs(e)) for m, e in zip(model, exact, strict=True)])
    errors = np.array(errors)
    # docs/air_lines.md: L1 errors 0.4-1.1 % of each variable's range on 101 cells; shocks and the
    # contact are captured, so the error falls at first order (to 0.1-0.3 % on 401 cells)
    assert np.all(errors[0] < 0.015)
    assert np.all(errors[1] < 0.55 * errors[0])


# --- conservation --------------------------------------------------------------------------------
def test_a_closed_line_keeps_its_mass_and_energy_to_round_off() -> None:
    # a shock tube with friction (its work stays in the gas) and no wall heat: nothing leaves
    row = line_row(8.0, BORE, T, R, K, MU, 60, True, False)
    x = initial_line_state(row, ATM)
    x[:30] *= 7.0
    x[120:150] *= 7.0
    mass0, energy0 = stored_mass(x, row, 5e-6), stored_energy(x, row, 5e-6)
    for _ in range(400):
        advance_from_flow(x, row, DT, 0.0, FarEnd(5e-6, 0.0, 0.0, 0.0, 0.0))
    assert stored_mass(x, row, 5e-6) == pytest.approx(mass0, rel=1e-12)
    assert stored_energy(x, row, 5e-6) == pytest.approx(energy0, rel=1e-12)
    assert np.ptp(cell_pressures(x, row)) < 0.2 * np.ptp(cell_pressures(initial_line_state(row, 7 * ATM), row)) + 1e5


@pytest.mark.parametrize("inlet", ["orifice", "pressure", "flow"])
def test_the_line_holds_the_mass_that_came_in(inlet: str) -> None:
    row = line_row(8.0, BORE, T, R, K, MU, segments_for(8.0, C))
    end_m3 = 10e-6
    x = initial_line_state(row, ATM)
    stored0 = stored_mass(x, row, end_m3)
    came_in = 0.0
    end = FarEnd(end_m3, 0.0, 0.0, 0.0, 0.0)
    for i in range(600):  # 0.3 s: fill, waves, and back out
        if inlet == "orifice":
            step = advance_from_orifice(x, row, DT, 7e5 if i < 300 else ATM, 2e-6, choked_flux(T, R, K), K, end)
        elif inlet == "pressure":
            step = advance_from_pressure(x, row, DT, 5e5 if i else ATM, 5e5 if i < 300 else 2e5, end)
        else:
            step = advance_from_flow(x, row, DT, 3e-3 if i < 300 else -2e-3, end)
        came_in += step.inlet_flow_kg_s * DT
    assert stored0 + came_in == pytest.approx(stored_mass(x, row, end_m3), rel=1e-12)
    assert abs(came_in) > 1e-5  # it did move air


# --- the user's function -------------------------------------------------------------------------
@pytest.mark.parametrize("length_m", [3.0, 8.0])
def test_a_small_step_reaches_the_far_end_after_l_over_c(length_m: float) -> None:
    t = np.arange(0.0, 1.5 * length_m / C, 1e-4)
    far = line_response(length_m, BORE, 0.0, t, np.where(t > 0.0, 3e5 + 1e3, 3e5), T)
    assert np.all(far[t < 0.9 * length_m / C] - 3e5 < 50.0)
    assert t[np.argmax(far - 3e5 >= 500.0)] == pytest.approx(length_m / C, abs=1.0e-3)


def _cells(length_m: float) -> int:
    return max(LINE_RESPONSE_MIN_CELLS, segments_for(length_m, C, LINE_RESPONSE_BAND_HZ))


@pytest.mark.parametrize("length_m", [1.0, 3.0, 8.0])
def test_line_response_is_grid_converged_on_finite_steps(length_m: float) -> None:
    # fills and exhausts of 3 and 7 bar over 2 ms: line_response against the same law on a grid
    # twice as fine (docs/air_lines.md against four times: at most 0.032 bar rms, where a reflected
    # shock sits a cell apart; 10/50/90 % times within 0.5 ms + 1 %)
    t = np.arange(0.0, 0.2, 1e-4)
    fine_row = line_row(length_m, BORE, T, R, K, MU, 2 * _cells(length_m) - 1)
    for p0, p1 in ((ATM, 7e5), (7e5, ATM), (ATM, 3e5), (3e5, ATM)):
        inlet = p0 + (p1 - p0) * np.clip((t - 0.01) / 0.002, 0.0, 1.0)
        model = line_response(length_m, BORE, 0.0, t, inlet, T)
        fine = far_end_series(GAS_LINE, fine_row, 0.0, t, inlet, 0.5e-3)
        assert np.sqrt(np.mean((model - fine) ** 2)) < 0.05e5
        for frac in (0.1, 0.5, 0.9):
            crossing = [t[np.argmax((f - p0 - frac * (p1 - p0)) * np.sign(p1 - p0) >= 0.0)] for f in (model, fine)]
            assert crossing[0] == pytest.approx(crossing[1], abs=0.5e-3 + 0.01 * (crossing[1] - 0.01))


def test_exhaust_holds_for_l_over_c_then_falls_slower_than_a_linear_line() -> None:
    # 8 m, 7 bar to the atmosphere: the far end holds until the expansion's head arrives (L/c), and
    # the finite expansion (its tail slower, the outflow choked) takes longer than the acoustic line
    t = np.arange(0.0, 0.3, 1e-4)
    inlet = 7e5 + (ATM - 7e5) * np.clip((t - 0.01) / 0.002, 0.0, 1.0)
    far = line_response(8.0, BORE, 0.0, t, inlet, T)
    assert np.all(far[t < 0.01 + 0.95 * 8.0 / C] > 0.995 * 7e5)
    half = t[np.argmax(far < 0.5 * (7e5 + ATM))] - 0.01
    assert half > 0.055  # the acoustic line of pneumatics/line.py: 46 ms (docs/air_lines.md)


@pytest.mark.parametrize(("p_high", "length_m"), [(8e5, 0.3), (8e5, 8.0), (1.5e5, 3.0)])
def test_line_response_takes_a_measured_looking_inlet(p_high: float, length_m: float) -> None:
    # a 1.5 ms step in sensor noise (0.01 bar rms) up and back down: finite, never below 0.3 bar,
    # no growth beyond a closed end's doubling, no sample-to-sample ringing beyond the noise's
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 0.3, 1e-4)
    up = np.clip((t - 0.01) / 0.0015, 0.0, 1.0) - np.clip((t - 0.15) / 0.0015, 0.0, 1.0)
    inlet = ATM + (p_high - ATM) * up + rng.normal(0.0, 1e3, t.size)
    far = line_response(length_m, BORE, 1e-6, t, inlet, T)
    assert np.all(np.isfinite(far))
    assert far.min() > 0.3 * ATM and far.max() < 2.0 * p_high
    settled = (t > 0.12) & (t < 0.15)
    assert np.std(np.diff(far[settled])) < 2e3


@pytest.mark.skipif(_jit.NO_JIT or _jit.cache_root() is None, reason="no compiled-code cache folder here")
def test_a_line_response_is_compiled_once_and_kept_in_the_cache() -> None:
    """`line_response` is what a user calls first in a fresh process: its series must be saved to
    numba's cache, or each start compiles it again (seconds) and warns that it cannot cache."""
    t = np.linspace(0.0, 0.01, 5)
    line_response(1.0, BORE, 1e-6, t, np.full(5, 2e5), T)
    assert Path(far_end_series._cache._cache_file._index_path).is_file()
