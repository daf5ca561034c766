"""Supply pressure over time: constant, steps, or random with a seed (paper Fig. 18)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from control.experiments import random_supply
from pneumatics import AIR
from scenarios.schema import Supply

MPA = 1e6


def supply_profile(supply: Supply, duration_s: float, rng: np.random.Generator) -> Callable[[float], float]:
    """Absolute supply pressure (Pa) as a function of time.

    Random: a new value every `hold_s`, normal with mean `mean_mpa` (gauge) and variance
    `variance_pa2`, drawn from `rng` and clipped as the paper's experiments do
    (control.experiments.random_supply, where the clipping's source is).
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
    return random_supply(rng, supply.mean_mpa * MPA, supply.variance_pa2, supply.hold_s, atm)
