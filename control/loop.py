"""The one run loop of a controller and a plant (DESIGN, "One control tick").

    supply.value_at(t) -> plant;  events.apply(plant, t);  controller.tick(plant.sensors()) -> plant.commands;
    on_tick(k, t);  plant.step x steps_per_tick

Every closed-loop run goes through `run_ticks`: the scenarios (twin/sim.py's `run`, with telemetry
and recorders as its `on_tick`), the paper's experiments (control/experiments.py) and the gap's
rehearsals (gap/arm_rehearsal.py). A plant that can (twin.plant.Plant) hands the loop its
compiled ticks (`SteppedPlant.ticks_batch`, twin/compiled_loop.py): the ticks between the
schedules' due times, the controller's plan changes and the run's end run there, controller tick,
air and mj_step in one compiled call. The Python loop below runs the rest and is the reference
the compiled ticks are held to, bit for bit (tests/test_compiled_loop.py).

It lives here, below twin/, because the paper's experiments run the controller against any plant,
the controller's own model included, and control/ must not import twin/.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

from control.schedule import EventSchedule, Schedule, checked

# a batch of compiled ticks: batch(k, applied_s) runs ticks k, k+1, ... and says how many (0: none)
Batch = Callable[[int, float], int]


class SteppedPlant(Protocol):
    """What the loop needs of a plant (twin.plant.Plant is one)."""

    commands: np.ndarray

    @property
    def time(self) -> float: ...
    def sensors(self): ...
    def set_supply(self, supply_pa: float) -> None: ...
    def step(self, n: int = 1, check_warnings: bool = True) -> None: ...
    def ticks_batch(
        self,
        controller,
        steps_per_tick: int,
        ticks_left: Callable[[int], int],
        due_s: Sequence[Callable[[float], float]],
        on_tick: Callable[..., None] | None,
        next_tick: Callable[[int], int] | None,
        sample_row: np.ndarray | None,
    ) -> Batch | None:
        """The compiled ticks of this plant and `controller` (None: every tick in Python)."""


class TickingController(Protocol):
    def tick(self, sensors) -> np.ndarray: ...


class StopRule(Protocol):
    """When the run ends: `keep_going(k)` before tick k (ticks before k have run), and how many
    ticks from k on surely run (`ticks_left(k)`: compiled ticks run at most that many)."""

    def keep_going(self, k: int) -> bool: ...
    def ticks_left(self, k: int) -> int: ...


class Ticks:
    """Stop after `n` ticks."""

    def __init__(self, n: int):
        self.n = int(n)

    def keep_going(self, k: int) -> bool:
        return k < self.n

    def ticks_left(self, k: int) -> int:
        return self.n - k


def run_ticks(
    controller: TickingController,
    plant: SteppedPlant,
    steps_per_tick: int,
    until: int | StopRule,
    supply: Schedule | None = None,
    events: EventSchedule | None = None,
    on_tick: Callable[..., None] | None = None,
    check_warnings: bool = True,
    next_tick: Callable[[int], int] | None = None,
    sample_row: np.ndarray | None = None,
) -> int:
    """Control ticks k = 0, 1, ... until `until` (a number of ticks or a StopRule); returns the
    number of ticks run.

    Each tick, at the plant's time t: the supply is set to `supply.value_at(t)`, `events.apply(plant,
    t)` applies faults (control/schedule.py: each checked here to be what it claims), the
    controller is handed the plant's sensors and its commands go to the plant, `on_tick(k, t)` sees
    the state the commands were issued in (telemetry), then the plant steps `steps_per_tick`
    physics steps (`check_warnings` passed on).

    Where the plant has compiled ticks (`ticks_batch`), the ticks that need none of the above in
    Python run there, exactly as this loop would run them: from the tick after one run here, up to
    the schedules' next change after it (`next_change_s`, `due_s` of the time they were applied),
    `until`'s `ticks_left`, or a tick the controller needs Python for. `on_tick` is then called from
    the compiled ticks at the ticks `next_tick(k)` names (None: every tick), handed `sample_row`
    (twin/sample_row.py) filled with the tick's telemetry when given.
    """
    stop = Ticks(until) if isinstance(until, int) else until
    supply = checked(supply, Schedule, "the run's supply")
    events = checked(events, EventSchedule, "the run's events")
    due = ([] if supply is None else [supply.next_change_s]) + ([] if events is None else [events.due_s])
    batch = plant.ticks_batch(controller, steps_per_tick, stop.ticks_left, due, on_tick, next_tick, sample_row)
    supply_at = None if supply is None else supply.value_at
    apply_events = None if events is None else events.apply
    # the loop's own cost is paid every tick: its calls bound once, not looked up each time
    sensors, tick, step, commands, keep_going = (
        plant.sensors,
        controller.tick,
        plant.step,
        plant.commands,
        stop.keep_going,
    )
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
