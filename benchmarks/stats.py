"""How every benchmark reports a figure measured several times: the median and the spread."""

from __future__ import annotations

import statistics


def spread(values: list[float], digits: int = 3) -> dict[str, float]:
    """{"median", "min", "max"} of repeated measurements, rounded to `digits` significant figures."""
    return {
        "median": _round(statistics.median(values), digits),
        "min": _round(min(values), digits),
        "max": _round(max(values), digits),
    }


def _round(x: float, digits: int) -> float:
    return float(f"{x:.{digits}g}")
