"""Supply pressure over time: constant, steps, or random with a seed (paper Fig. 18)."""

from __future__ import annotations

import math
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

    The constant and stepped profiles also tell when their value next changes (`due_s`), so the run
    loop may skip calling them in between (twin/compiled_loop.py).
    """
    atm = AIR.p_atm_pa
    if supply.kind == "constant":
        return _Steps(np.zeros(0), np.zeros(0), atm + supply.pressure_mpa * MPA)
    if supply.kind == "steps":
        times = np.array([t for t, _ in supply.steps])
        values = atm + np.array([p for _, p in supply.steps]) * MPA
        return _Steps(times, values, atm + supply.pressure_mpa * MPA)
    return random_supply(rng, supply.mean_mpa * MPA, supply.variance_pa2, supply.hold_s, atm)


class _Steps:
    """`first` before `times[0]`, then `values[i]` from `times[i]` on (absolute Pa)."""

    def __init__(self, times: np.ndarray, values: np.ndarray, first: float):
        self.times, self.values, self.first = times, values, first

    def __call__(self, t: float) -> float:
        i = np.searchsorted(self.times, t, side="right") - 1
        return float(self.values[i]) if i >= 0 else self.first

    def due_s(self, t: float) -> float:
        """When the value next changes after t (math.inf: never)."""
        if not len(self.times) or t >= self.times[-1]:
            return math.inf  # constant from here on (asked often: no search)
        return float(self.times[np.searchsorted(self.times, t, side="right")])
