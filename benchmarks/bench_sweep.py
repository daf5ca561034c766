"""Sweep throughput: scenario-seconds simulated per wall-second on 1 and on 2 local workers, for
the same Monte Carlo sweep (child seeds) of the insulator-cleaning task cut to 20 s a point.

Every sweep is timed whole, start-up included (it is what a user waits for): on 1 worker the
points run in this process; on 2 the workers are forked from it after its warm-up (start-up paid
once, scenarios/sweep.py), and for comparison joblib's own (loky) processes, each starting cold.
The figures are medians over `repeats` interleaved rounds with their min-max; the ratio
2 workers / 1 worker is taken within each round. The Dask cluster's figures are in
benchmarks/bench_dask.py."""

from __future__ import annotations

import json
import os
import time

from joblib.externals.loky import get_reusable_executor

from benchmarks.stats import spread
from scenarios.runner import scenario_files
from scenarios.schema import load
from scenarios.sweep import sweep, warm_up

SCENARIO = next(p for p in scenario_files() if p.stem == "insulator_cleaning")


def timed_sweep(scenario, points: int, duration_s: float, **how) -> tuple[float, float, list[dict]]:
    """(scenario-s per wall-s, CPU cores it got, the summaries) of one Monte Carlo sweep. The cores
    are CPU seconds (this process and its finished workers) per wall second: on a machine shared
    with other work, 2 workers may get far less than 2."""
    cpu0, t0 = _cpu_s(), time.perf_counter()
    results = sweep(scenario, monte_carlo=points, duration_s=duration_s, progress=False, **how)
    wall = time.perf_counter() - t0
    return points * duration_s / wall, (_cpu_s() - cpu0) / wall, results


def start_up(scenario, loky: bool = True) -> dict[str, float]:
    """Wall s of a sweep of 2 points of 2 control ticks on 2 workers: what starting the workers
    costs (forked from this warm process; joblib's loky processes, cold)."""
    out = {}
    for way, how in (("forked", {}), ("loky", {"fork": False}))[: 2 if loky else 1]:
        t0 = time.perf_counter()
        sweep(scenario, monte_carlo=2, workers=2, duration_s=0.002, progress=False, **how)
        out[f"start_up_s_2_{way}_workers"] = round(time.perf_counter() - t0, 2)
        if how:
            get_reusable_executor().shutdown(wait=True)
    return out


def _cpu_s() -> float:
    # os.times: this process's and its finished children's CPU seconds (the children's are 0 on Windows)
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def bench_sweep(points: int = 8, duration_s: float = 20.0, repeats: int = 3, loky: bool = True) -> dict:
    scenario = load(SCENARIO)
    warm_up(scenario)  # this process warm, as it is for the 1-worker sweep and before a fork
    ways = {"1_worker": {"workers": 1}, "2_workers": {"workers": 2}}
    if loky:
        ways["2_loky_workers"] = {"workers": 2, "fork": False}
    rates: dict[str, list[float]] = {w: [] for w in ways}
    cores: dict[str, list[float]] = {w: [] for w in ways}
    results = {}
    for _ in range(repeats):
        for way, how in ways.items():
            rate, used, results[way] = timed_sweep(scenario, points, duration_s, **how)
            rates[way].append(rate)
            cores[way].append(used)
            if not how.get("fork", True):
                get_reusable_executor().shutdown(wait=True)  # cold again next round; no threads left to fork with
    out = {"scenario": SCENARIO.stem, "points": points, "scenario_seconds_each": duration_s, "repeats": repeats}
    out |= start_up(scenario, loky)
    out |= {f"scenario_s_per_wall_s_{w}": spread(r) for w, r in rates.items()}
    # loky's workers outlive the sweep (their CPU time is not this process's children's until reaped)
    out |= {f"cpu_cores_used_{w}": spread(c) for w, c in cores.items() if "loky" not in w}
    for way in ways:
        if way != "1_worker":
            ratios = [r / one for r, one in zip(rates[way], rates["1_worker"], strict=True)]
            out[f"ratio_{way}_over_1"] = spread(ratios)
            out[f"same_results_{way}_and_1"] = _same(results[way], results["1_worker"])
    return out


def _same(a: list[dict], b: list[dict]) -> bool:
    """The summaries equal, NaN equal to NaN (a criterion never judged is NaN in both)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


if __name__ == "__main__":
    print(json.dumps(bench_sweep(), indent=2))
