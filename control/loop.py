"""The one run loop of a controller and a plant (DESIGN, "One control tick").

    supply.value_at(t) -> plant;  events.apply(plant, t);  controller.tick(plant.sensors()) -> plant.commands;
    on_tick(k, t);  plant.step x steps_per_tick

It lives here, below twin/, because the paper's experiments (control/experiments.py) run the
controller against any plant, the controller's own model included, and control/ must not import
twin/; twin/sim.py's `run` is this loop with telemetry and recorders as its `on_tick`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from control.schedule import EventSchedule, Schedule, checked


class SteppedPlant(Protocol):
    """What the loop needs of a plant (twin.plant.Plant is one)."""

    commands: np.ndarray

    @property
    def time(self) -> float: ...
    def sensors(self): ...
    def set_supply(self, supply_pa: float) -> None: ...
    def step(self, n: int = 1, check_warnings: bool = True) -> None: ...


class TickingController(Protocol):
    def tick(self, sensors) -> np.ndarray: ...


def run_ticks(
    controller: TickingController,
    plant: SteppedPlant,
    steps_per_tick: int,
    keep_going: Callable[[int], bool],
    supply: Schedule | None = None,
    events: EventSchedule | None = None,
    on_tick: Callable[[int, float], None] | None = None,
    check_warnings: bool = True,
    batch: Callable[[int], int] | None = None,
) -> int:
    """Control ticks k = 0, 1, ... while `keep_going(k)`; returns the number of ticks run.

    Each tick, at the plant's time t: the supply is set to `supply.value_at(t)`, `events.apply(plant,
    t)` applies faults (control/schedule.py: each checked here to be what it claims), the
    controller is handed the plant's sensors and its commands go to the plant, `on_tick(k, t)` sees
    the state the commands were issued in (telemetry), then the plant steps `steps_per_tick`
    physics steps (`check_warnings` passed on).

    `batch(k, applied_s)`, where given, runs ticks k, k+1, ... that need none of the above in Python,
    exactly as this loop would (twin/compiled_loop.py), and returns how many it ran (0: tick k is the
    loop's); it stops before `keep_going` would, and before the schedules as applied at the time
    `applied_s` of this loop's last tick change (their `next_change_s(applied_s)`, `due_s(applied_s)`).
    The first tick is always this loop's: the schedules have not been applied before it.
    """
    supply_at = None if supply is None else checked(supply, Schedule, "the run's supply").value_at
    apply_events = None if events is None else checked(events, EventSchedule, "the run's events").apply
    # the loop's own cost is paid every tick: its calls bound once, not looked up each time
    sensors, tick, step, commands = plant.sensors, controller.tick, plant.step, plant.commands
    k = 0
    applied_s = None  # the time of the last tick run here (its supply and events applied)
    while keep_going(k):
        if batch is not None and applied_s is not None:
            ran = batch(k, applied_s)
            if ran:
                k += ran
                continue
        t = applied_s = plant.time
        if supply_at is not None:
            plant.set_supply(supply_at(t))
        if apply_events is not None:
            apply_events(plant, t)
        commands[:] = tick(sensors())
        if on_tick is not None:
            on_tick(k, t)
        step(steps_per_tick, check_warnings)
        k += 1
    return k
