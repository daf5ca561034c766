"""Supply pressure over time: constant, steps, or random with a seed (paper Fig. 18), as the run
loop's schedules (control/schedule.py): each says when its value next changes."""

from __future__ import annotations

import numpy as np

from control.experiments import random_supply
from control.schedule import Constant, Schedule, Steps
from pneumatics import AIR
from scenarios.schema import Supply

MPA = 1e6


def supply_profile(supply: Supply, duration_s: float, rng: np.random.Generator) -> Schedule:
    """Absolute supply pressure (Pa) as a schedule of time, for every kind the schema allows.

    Random: a new value every `hold_s`, normal with mean `mean_mpa` (gauge) and variance
    `variance_pa2`, drawn from `rng` and clipped as the paper's experiments do
    (control.experiments.random_supply, where the clipping's source is).
    """
    atm = AIR.p_atm_pa
    if supply.kind == "constant":
        return Constant(atm + supply.pressure_mpa * MPA)
    if supply.kind == "steps":
        times = np.array([t for t, _ in supply.steps])
        values = atm + np.array([p for _, p in supply.steps]) * MPA
        return Steps(times, values, atm + supply.pressure_mpa * MPA)
    if supply.kind == "random":
        return random_supply(rng, supply.mean_mpa * MPA, supply.variance_pa2, supply.hold_s, atm)
    raise ValueError(f"[supply] kind = {supply.kind!r}; allowed: constant, steps, random")
