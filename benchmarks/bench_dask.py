"""What the cluster path costs: the sweep of benchmarks/bench_sweep.py (8 cleaning runs of 20 s,
child seeds) on a local Dask cluster (a scheduler and 2 worker processes of 1 thread on this
machine, `twin sweep --scheduler`'s path: joblib's Dask backend) beside joblib's local workers.

Timed per sweep, scenario-s per wall-s, medians over `repeats` interleaved rounds with min-max:
the local sweep on 1 worker (this process, warm) and on 2 forked workers, interleaved; then the
Dask sweep on a cluster started after them (the cluster's start-up is reported apart: a user starts it once), its
first sweep (workers cold: imports and compiled kernels loaded per worker) apart from the later
ones (warm). Results must equal the local ones.

    PYTHONPATH=. python -m benchmarks.bench_dask [--points 8] [--seconds 20] [--repeats 2]
"""

from __future__ import annotations

import argparse
import json
import time

from benchmarks.bench_sweep import SCENARIO, _same, timed_sweep
from benchmarks.stats import spread
from scenarios.schema import load
from scenarios.sweep import warm_up


def bench_dask(points: int = 8, duration_s: float = 20.0, repeats: int = 2) -> dict:
    from dask.distributed import LocalCluster  # the [cluster] extra

    scenario = load(SCENARIO)
    warm_up(scenario)
    out = {"scenario": SCENARIO.stem, "points": points, "scenario_seconds_each": duration_s, "repeats": repeats}
    rates: dict[str, list[float]] = {"1_worker": [], "2_workers": [], "dask_2_workers": []}
    results = {}
    # the local sweeps first: a cluster's client leaves threads in this process, and forking
    # beside them is refused (scenarios/sweep.py), so the local 2 workers would be loky's
    for _ in range(repeats):
        for way, how in (("1_worker", {"workers": 1}), ("2_workers", {"workers": 2})):
            rate, _, results[way] = timed_sweep(scenario, points, duration_s, **how)
            rates[way].append(rate)
    t0 = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        out["cluster_start_s"] = round(time.perf_counter() - t0, 2)
        dask = {"scheduler": cluster.scheduler_address}
        cold, _, first = timed_sweep(scenario, points, duration_s, **dask)
        out["dask_first_sweep_scenario_s_per_wall_s"] = round(cold, 2)
        for _ in range(repeats):
            rate, _, results["dask_2_workers"] = timed_sweep(scenario, points, duration_s, **dask)
            rates["dask_2_workers"].append(rate)
    out |= {f"scenario_s_per_wall_s_{w}": spread(r) for w, r in rates.items()}
    for way in ("2_workers", "dask_2_workers"):
        out[f"ratio_{way}_over_1_worker_of_medians"] = _ratio(rates[way], rates["1_worker"])
    out["same_results_dask_and_1"] = _same(results["dask_2_workers"], results["1_worker"]) and _same(
        first, results["1_worker"]
    )
    return out


def _ratio(a: list[float], b: list[float]) -> float:
    return round(spread(a)["median"] / spread(b)["median"], 3)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=8)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--repeats", type=int, default=2)
    a = ap.parse_args()
    print(json.dumps(bench_dask(a.points, a.seconds, a.repeats), indent=1))
