"""A 1-hour simulated insulator-cleaning cycle (the task repeated back to back), logging off, with
the process's resident memory sampled as it runs. The run's own record (the telemetry columns
that the criteria and logs read, 50 samples per simulated second) grows by design; everything
else must not. Prints RSS over time, the telemetry's size, and the growth that is not telemetry.

    python -m benchmarks.long_run [--hours 1.0]
"""

from __future__ import annotations

import argparse
import json
import os
import threading
import time
import tomllib

import numpy as np

from scenarios.runner import run_scenario, scenario_files
from scenarios.schema import load, parse_doc

PAGE = os.sysconf("SC_PAGE_SIZE")


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE


def long_cleaning(hours: float = 1.0) -> dict:
    base = load(next(p for p in scenario_files() if p.stem == "insulator_cleaning"))
    doc = tomllib.loads(base.text)
    one_cycle_s = 65.0  # measured: the plan takes ~60 s at 0.6 MPa
    cycles = int(hours * 3600 / one_cycle_s) + 1
    doc["targets"] = doc["targets"] * cycles
    doc["duration_s"] = hours * 3600
    doc["criteria"] = [c for c in doc["criteria"] if c["kind"] == "contact_force_n"]
    scenario = parse_doc(doc, f"{base.path} x{cycles}", base.text)

    samples: list[tuple[float, int]] = []
    done = threading.Event()

    def sample():
        t0 = time.perf_counter()
        while not done.wait(2.0):
            samples.append((time.perf_counter() - t0, rss_bytes()))

    rss0 = rss_bytes()
    thread = threading.Thread(target=sample, daemon=True)
    t0 = time.perf_counter()
    thread.start()
    result = run_scenario(scenario)
    done.set()
    thread.join()
    wall = time.perf_counter() - t0
    rss1 = rss_bytes()
    tel = result.telemetry.arrays()
    tel_bytes = sum(a.nbytes for a in tel.values())
    # growth between the first and last quarter of the run, per simulated hour, minus the record
    n = len(samples)
    q = max(1, n // 4)
    early = np.median([s for _, s in samples[:q]])
    late = np.median([s for _, s in samples[-q:]])
    # the record grows at a steady rate (one sample per 20 ms simulated, the sim runs at a steady
    # pace): its share of the growth between the two quarters' medians, by wall time
    t_early, t_late = np.median([t for t, _ in samples[:q]]), np.median([t for t, _ in samples[-q:]])
    record_between = tel_bytes * (t_late - t_early) / wall
    return {
        "simulated_s": float(tel["time_s"][-1]),
        "cycles_planned": cycles,
        "wall_s": round(wall, 1),
        "real_time_factor": round(float(tel["time_s"][-1]) / wall, 1),
        "rss_start_mb": round(rss0 / 1e6, 1),
        "rss_end_mb": round(rss1 / 1e6, 1),
        "rss_early_quarter_mb": round(early / 1e6, 1),
        "rss_late_quarter_mb": round(late / 1e6, 1),
        "telemetry_mb": round(tel_bytes / 1e6, 1),
        "growth_not_telemetry_mb": round((rss1 - rss0 - tel_bytes) / 1e6, 1),  # includes one-time set-up
        "growth_between_quarters_mb": round((late - early) / 1e6, 1),
        "record_growth_between_quarters_mb": round(record_between / 1e6, 1),
        "other_growth_between_quarters_mb": round((late - early - record_between) / 1e6, 1),
        "passed": result.passed,
        "error": result.error,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    args = ap.parse_args(argv)
    print(json.dumps(long_cleaning(args.hours), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
