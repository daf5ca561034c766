"""`twin bench`: every speed benchmark, each a ratio against a baseline measured in the same run
(bare MuJoCo, logging off, one worker), repeated figures as median with min-max. `twin` is the
whole cleaning scenario against bare MuJoCo stepping the same motion. `quick` shortens each for a
smoke run."""

from __future__ import annotations

from benchmarks.bench_control import bench_control
from benchmarks.bench_force_rate import bench_force_rate
from benchmarks.bench_gap import bench_gap
from benchmarks.bench_logging import bench_logging
from benchmarks.bench_plant import bench_plant
from benchmarks.bench_sweep import bench_sweep
from benchmarks.bench_twin import bench_twin


def run_all(quick: bool = False, finished: dict | None = None) -> dict:
    """Every benchmark's figures by name; `finished`, if given, is filled as each one ends (what a
    `twin bench` stopped by Ctrl-C or SIGTERM prints)."""
    finished = {} if finished is None else finished
    if quick:
        benches = {
            "twin": lambda: bench_twin(seconds=1.0, rounds=1),
            "plant": lambda: bench_plant(seconds=0.3, rounds=1),
            "force_rate": lambda: bench_force_rate(steps=500, rounds=3),
            "control": lambda: bench_control(n_ticks=300, rounds=1),
            "logging": lambda: bench_logging(seconds=1.0, rounds=1),
            "sweep": lambda: bench_sweep(points=2, duration_s=0.5, repeats=1),
            "gap": lambda: bench_gap(jobs=2, rounds=1),
        }
    else:
        benches = {
            "twin": bench_twin,
            "plant": bench_plant,
            "force_rate": bench_force_rate,
            "control": bench_control,
            "logging": bench_logging,
            "sweep": bench_sweep,
            "gap": bench_gap,
        }
    for name, bench in benches.items():
        finished[name] = bench()
    return finished
