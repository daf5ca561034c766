"""Sweep throughput: scenario-seconds simulated per wall-second on 1 and on 2 local workers, for
the same Monte Carlo sweep (child seeds) of the insulator-cleaning task cut to 20 s a point, big
enough that the workers' start-up (~1 s each: imports, compiled kernels from the cache) does not
hide the scaling; start-up is included, as it is what a user waits for. The ratio 2 workers /
1 worker is the figure that travels between machines."""

from __future__ import annotations

import json
import time

from scenarios.runner import scenario_files
from scenarios.schema import load
from scenarios.sweep import sweep

SCENARIO = next(p for p in scenario_files() if p.stem == "insulator_cleaning")


def bench_sweep(points: int = 8, duration_s: float = 20.0) -> dict:
    scenario = load(SCENARIO)
    sweep(scenario, monte_carlo=2, workers=1, duration_s=0.5, progress=False)  # compile caches
    out = {"scenario": SCENARIO.stem, "points": points, "scenario_seconds_each": duration_s}
    results = {}
    for workers in (1, 2):
        t0 = time.perf_counter()
        results[workers] = sweep(scenario, monte_carlo=points, workers=workers, duration_s=duration_s, progress=False)
        wall = time.perf_counter() - t0
        out[f"scenario_s_per_wall_s_{workers}_worker"] = round(points * duration_s / wall, 2)
    out["ratio_2_over_1"] = round(out["scenario_s_per_wall_s_2_worker"] / out["scenario_s_per_wall_s_1_worker"], 2)
    out["same_results_1_and_2_workers"] = results[1] == results[2]
    return out


if __name__ == "__main__":
    print(json.dumps(bench_sweep(), indent=2))
