"""Cost of a hose per physics step: the line with gas inertia (pneumatics/line.py) against the
lumped pi-section it replaces, measured in the same run.

Baseline: the pi-section's work per 0.5 ms step as pneumatics/joint.py does it for one port: the
valve orifice into the valve node, `hose_mass_flow_with` between the two nodes, and the two nodes'
`chamber_pressure_rate` (one explicit update each). Line: `advance_from_orifice` with the same valve
onto an end volume. Both run a fill then an exhaust (the supply switching every 0.1 s), so they meet
the laminar and the Blasius branches, choked and subsonic flow. Each figure is the median of several
rounds (min-max beside it); the ratio is taken within each round.

    PYTHONPATH=. python -m benchmarks.bench_line [--rounds 5] [--seconds 2]
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from benchmarks.stats import spread
from pneumatics import gas_line
from pneumatics._jit import njit
from pneumatics.chamber import chamber_pressure_rate
from pneumatics.gas import AIR
from pneumatics.hose import hose_constants, hose_mass_flow_with, hose_volume
from pneumatics.line import FarEnd, advance_from_orifice, initial_line_state, line_row, segments_for, substeps_for
from pneumatics.orifice import choked_flux, orifice_mass_flow_with

DT = 0.5e-3  # the plant's physics step
BORE = 4.0e-3  # the arm's hoses (DESIGN table)
VALVE_M2 = 5.0e-6  # the DESIGN table's inlet valve area
END_M3 = 2.0e-6  # a vane chamber with its porting
SUPPLY_PA = 7.0e5
SWITCH_STEPS = 200  # the supply switches every 0.1 s
R, K, T, MU, ATM = AIR.r_j_per_kg_k, AIR.k, AIR.t_supply_k, AIR.mu_pa_s, AIR.p_atm_pa
FLUX = choked_flux(T, R, K)


@njit(cache=False)
def _pi_section_steps(length_m: float, steps: int) -> float:
    k_lam, limit, k_bl = hose_constants(length_m, BORE, MU)
    half = 0.5 * hose_volume(length_m, BORE)
    p_valve = p_motor = ATM
    for i in range(steps):
        up = SUPPLY_PA if (i // SWITCH_STEPS) % 2 == 0 else ATM
        m_valve = orifice_mass_flow_with(up, p_valve, VALVE_M2, FLUX, K)
        m_hose = hose_mass_flow_with(p_valve, p_motor, T, R, k_lam, limit, k_bl)
        p_valve += DT * chamber_pressure_rate(p_valve, half, 0.0, m_valve - m_hose, T, R, K)
        p_motor += DT * chamber_pressure_rate(p_motor, half + END_M3, 0.0, m_hose, T, R, K)
    return p_motor


@njit(cache=False)
def _line_steps(row: np.ndarray, steps: int) -> float:
    x = initial_line_state(row, ATM)
    end = FarEnd(END_M3, 0.0, 0.0, 0.0, 0.0)
    for i in range(steps):
        up = SUPPLY_PA if (i // SWITCH_STEPS) % 2 == 0 else ATM
        advance_from_orifice(x, row, DT, up, VALVE_M2, FLUX, K, end)
    return x[int(row[0])]


@njit(cache=False)
def _gas_line_steps(row: np.ndarray, steps: int) -> float:
    x = gas_line.initial_line_state(row, ATM)
    end = gas_line.FarEnd(END_M3, 0.0, 0.0, 0.0, 0.0)
    for i in range(steps):
        up = SUPPLY_PA if (i // SWITCH_STEPS) % 2 == 0 else ATM
        gas_line.advance_from_orifice(x, row, DT, up, VALVE_M2, FLUX, K, end)
    return gas_line.far_end_pressure(x, row)


def _per_step_ns(run, steps: int) -> float:
    t0 = time.perf_counter()
    run(steps)
    return (time.perf_counter() - t0) / steps * 1e9


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    args = parser.parse_args(argv)
    steps = int(args.seconds / DT)
    c = math.sqrt(K * R * T)
    cases = {}
    for length in (0.3, 3.0, 8.0, 30.0):
        for unsteady in (True, False):
            row = line_row(length, BORE, T, R, K, MU, segments_for(length, c), unsteady)
            cases[(length, unsteady)] = row
    _pi_section_steps(8.0, 10)
    for row in cases.values():
        _line_steps(row, 10)  # compile
    report = {}
    for length in (0.3, 3.0, 8.0):  # the finite-amplitude line (pneumatics/gas_line.py), full law
        row = gas_line.line_row(length, BORE, T, R, K, MU, gas_line.segments_for(length, c))
        _gas_line_steps(row, 10)
        base, line, ratio = [], [], []
        for _ in range(args.rounds):
            b = _per_step_ns(lambda n, ln=length: _pi_section_steps(ln, n), steps)
            w = _per_step_ns(lambda n, r=row: _gas_line_steps(r, n), steps)
            base.append(b)
            line.append(w)
            ratio.append(w / b)
        report[f"{length:g} m, finite-amplitude line (gas_line)"] = {
            "segments": int(row[0]),
            "pi_section_ns_per_step": spread(base),
            "line_ns_per_step": spread(line),
            "line_over_pi_section": spread(ratio),
        }
    for (length, unsteady), row in cases.items():
        base, line, ratio = [], [], []
        for _ in range(args.rounds):
            b = _per_step_ns(lambda n, ln=length: _pi_section_steps(ln, n), steps)
            w = _per_step_ns(lambda n, r=row: _line_steps(r, n), steps)
            base.append(b)
            line.append(w)
            ratio.append(w / b)
        report[f"{length:g} m, {'unsteady' if unsteady else 'steady'} friction"] = {
            "segments": int(row[0]),
            "substeps": substeps_for(row, DT),
            "pi_section_ns_per_step": spread(base),
            "line_ns_per_step": spread(line),
            "line_over_pi_section": spread(ratio),
        }
    print(json.dumps(report, indent=2))
    return report


if __name__ == "__main__":
    main()
