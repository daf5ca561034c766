"""How every benchmark reports a figure measured several times: the median and the spread."""

from __future__ import annotations

import statistics
import time

_CLOCK = [time.perf_counter]  # what `clock` reads: the wall clock unless `use_cpu_time`


def clock() -> float:
    """Seconds by the benchmarks' clock (`time.perf_counter`, or the process's CPU time after
    `use_cpu_time`): only differences mean anything."""
    return _CLOCK[0]()


def use_cpu_time() -> None:
    """Time by this process's CPU time (`time.process_time`) instead of the wall clock: on a shared,
    loaded machine the wall clock also counts the time the process waited for a core, unevenly
    between the two sides of a ratio (bench_twin's bare MuJoCo measured 5.4 to 27 us per step in one
    session by the wall clock, 5.3-5.5 by CPU time)."""
    _CLOCK[0] = time.process_time


def spread(values: list[float], digits: int = 3) -> dict[str, float]:
    """{"median", "min", "max"} of repeated measurements, rounded to `digits` significant figures."""
    return {
        "median": _round(statistics.median(values), digits),
        "min": _round(min(values), digits),
        "max": _round(max(values), digits),
    }


def _round(x: float, digits: int) -> float:
    return float(f"{x:.{digits}g}")
