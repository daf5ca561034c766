"""Supply pressure over time: constant, steps, or random with a seed (paper Fig. 18)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pneumatics import AIR
from scenarios.schema import Supply

MPA = 1e6


def supply_profile(supply: Supply, duration_s: float, rng: np.random.Generator) -> Callable[[float], float]:
    """Absolute supply pressure (Pa) as a function of time.

    Random: a new value every `hold_s`, normal with mean `mean_mpa` (gauge) and variance
    `variance_pa2` (the paper: 0.6 MPa, 5e9 Pa^2, held 0.5 s so that the 0.1 s valve settles),
    clipped at the paper's working range 0.4..0.9 MPa gauge so the brakes keep releasing.
    """
    atm = AIR.p_atm_pa
    if supply.kind == "constant":
        value = atm + supply.pressure_mpa * MPA
        return lambda t: value
    if supply.kind == "steps":
        times = np.array([t for t, _ in supply.steps])
        values = atm + np.array([p for _, p in supply.steps]) * MPA
        first = atm + supply.pressure_mpa * MPA

        def stepped(t: float) -> float:
            i = np.searchsorted(times, t, side="right") - 1
            return float(values[i]) if i >= 0 else first

        return stepped
    n = int(np.ceil(duration_s / supply.hold_s)) + 1
    draws = rng.normal(supply.mean_mpa * MPA, np.sqrt(supply.variance_pa2), size=n)
    values = atm + np.clip(draws, 0.4 * MPA, 0.9 * MPA)
    return lambda t: float(values[min(int(t / supply.hold_s), n - 1)])
