"""What a chamber's energy balance costs the compiled kernels, as ratios against the polytropic
pressure rate measured in the same run (pneumatics/chamber.py; docs/air_chambers.md).

Each figure is ns per call of a compiled loop over `calls` chambers whose inputs change every
call (so the compiler can hoist nothing), the median with its min-max over `rounds`, the ratio
taken within each round:
- `polytropic`: `chamber_pressure_rate`, what the joint's kernel calls today per node;
- `energy`: `chamber_energy_rates` (p and T) with each flow's `carried_temperature`;
- `energy_with_vane_heat`: the same plus the vane chamber's film coefficient and the heat flow,
  what a motor chamber of the kernel would call per rate evaluation.

    python -m benchmarks.bench_chamber
"""

from __future__ import annotations

import json
import time

from benchmarks.stats import spread
from pneumatics._jit import njit
from pneumatics.chamber import carried_temperature, chamber_energy_rates, chamber_pressure_rate
from pneumatics.gas import AIR
from pneumatics.heat import vane_cell, vane_chamber_heat_transfer_coefficient

R, K, T_S = AIR.r_j_per_kg_k, AIR.k, AIR.t_supply_k
# the wrist's 1UP motor (assets/joints/wrist_pitch.toml)
STATOR_M, ROTOR_M, VANE_M, VANES = 0.011, 0.009, 0.025, 4.0


@njit
def _polytropic(calls: int) -> float:
    total = 0.0
    for i in range(calls):
        x = 1.0 + 1e-9 * i
        total += chamber_pressure_rate(3e5 * x, 2e-6 * x, 1e-4 * x, 1e-4 - 2e-4 * (i & 1), T_S, R, K)
    return total


@njit
def _energy(calls: int) -> float:
    total = 0.0
    for i in range(calls):
        x = 1.0 + 1e-9 * i
        m = 1e-4 - 2e-4 * (i & 1)
        t = 260.0 * x
        rates = chamber_energy_rates(3e5 * x, t, 2e-6 * x, 1e-4 * x, m, m * carried_temperature(m, T_S, t), 0.0, R, K)
        total += rates.dp_dt_pa_s + rates.dt_dt_k_s
    return total


@njit
def _energy_with_vane_heat(calls: int, area_per_volume: float, hydraulic_diameter: float) -> float:
    total = 0.0
    for i in range(calls):
        x = 1.0 + 1e-9 * i
        m = 1e-4 - 2e-4 * (i & 1)
        p, t, v = 3e5 * x, 260.0 * x, 2e-6 * x
        h = vane_chamber_heat_transfer_coefficient(600.0 * x, p, t, T_S, STATOR_M, hydraulic_diameter, R, K)
        heat = h * area_per_volume * v * (T_S - t)
        rates = chamber_energy_rates(p, t, v, 1e-4 * x, m, m * carried_temperature(m, T_S, t), heat, R, K)
        total += rates.dp_dt_pa_s + rates.dt_dt_k_s
    return total


def bench_chamber(calls: int = 2_000_000, rounds: int = 5) -> dict:
    cell = vane_cell(STATOR_M, ROTOR_M, VANE_M, VANES)
    runs = {
        "polytropic": lambda: _polytropic(calls),
        "energy": lambda: _energy(calls),
        "energy_with_vane_heat": lambda: _energy_with_vane_heat(
            calls, cell.area_per_volume_1_m, cell.hydraulic_diameter_m
        ),
    }
    for run in runs.values():
        run()  # compile
    ns: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            t0 = time.perf_counter()
            run()
            ns[name].append((time.perf_counter() - t0) / calls * 1e9)
    out: dict = {"rounds": rounds, "calls": calls}
    for name, values in ns.items():
        out[f"{name}_ns"] = spread(values)
        if name != "polytropic":
            out[f"{name}_over_polytropic"] = spread([a / b for a, b in zip(values, ns["polytropic"], strict=True)])
    return out


if __name__ == "__main__":
    print(json.dumps(bench_chamber(), indent=1))
