"""What changes over a run at given times, and when it next changes: the run loop's schedules.

The run loop (control/loop.py) hands a plant two kinds of schedule each control tick:

    Schedule        a value of the simulated time (the supply pressure, absolute Pa):
                    `value_at(t)`, and `next_change_s(t)`, the first time after t at which
                    `value_at` may give another value (math.inf: never again)
    EventSchedule   things done to the plant at given times (faults): `apply(plant, t)` does
                    what has come due by t, `due_s(t)` says when it next does anything

Both say when they next need a call, so the compiled ticks (twin/compiled_loop.py) run every tick
in between without Python and hand the tick where one is due back to the Python loop. The loop
checks its schedules against these protocols when it starts (`checked`): a plain function where
a schedule belongs is an error there, never a silent fall back to a slower loop.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Schedule(Protocol):
    """A value of the simulated time that holds between its changes."""

    def value_at(self, t: float) -> float: ...
    def next_change_s(self, t: float) -> float: ...


@runtime_checkable
class EventSchedule(Protocol):
    """Things done to the plant at given times; a call of `apply` before `due_s(t)` does nothing."""

    def apply(self, plant, t: float) -> None: ...
    def due_s(self, t: float) -> float: ...


def checked(schedule, protocol: type, what: str):
    """`schedule` if it implements `protocol` (None passes), else TypeError naming what it lacks."""
    if schedule is None or isinstance(schedule, protocol):
        return schedule
    missing = [m for m in ("value_at", "next_change_s", "apply", "due_s") if hasattr(protocol, m)]
    raise TypeError(
        f"{what}: {schedule!r} is no {protocol.__name__}; allowed: an object with "
        f"{' and '.join(m + '()' for m in missing)} (control/schedule.py)"
    )


class Constant:
    """The same value at every time."""

    def __init__(self, value: float):
        self.value = float(value)

    def value_at(self, t: float) -> float:
        return self.value

    def next_change_s(self, t: float) -> float:
        return math.inf

    def __repr__(self) -> str:
        return f"Constant({self.value!r})"


class Steps:
    """`first` before `times[0]`, then `values[i]` from `times[i]` on."""

    def __init__(self, times: np.ndarray, values: np.ndarray, first: float):
        self.times, self.values, self.first = np.asarray(times, float), np.asarray(values, float), float(first)

    def value_at(self, t: float) -> float:
        i = np.searchsorted(self.times, t, side="right") - 1
        return float(self.values[i]) if i >= 0 else self.first

    def next_change_s(self, t: float) -> float:
        if not len(self.times) or t >= self.times[-1]:
            return math.inf  # constant from here on (asked often: no search)
        return float(self.times[np.searchsorted(self.times, t, side="right")])


class HeldDraws:
    """Values drawn at random, each held `hold_s`: value k from k·hold_s on, drawn in time order
    from `rng` by `draw(rng)` the first time it is asked for (so the draws do not depend on how
    often the value is looked at). A value starts at its nominal time even where a summed clock
    lands a hair before it (1e-9 of a hold)."""

    def __init__(self, rng: np.random.Generator, draw, hold_s: float):
        self.rng, self.draw, self.hold_s = rng, draw, float(hold_s)
        self.values: list[float] = []

    def _index(self, t: float) -> int:
        return int(t / self.hold_s + 1e-9)

    def value_at(self, t: float) -> float:
        k = self._index(t)
        while len(self.values) <= k:
            self.values.append(float(self.draw(self.rng)))
        return self.values[k]

    def next_change_s(self, t: float) -> float:
        # where `_index` reaches the next value (the compiled ticks stop a microsecond before it)
        return (self._index(t) + 1 - 1e-9) * self.hold_s


class Until:
    """`schedule`'s value before `at_s`, `after` from `at_s` on (a supply lost at a fault's time)."""

    def __init__(self, schedule: Schedule, at_s: float, after: float):
        self.schedule, self.at_s, self.after = checked(schedule, Schedule, "Until"), float(at_s), float(after)

    def value_at(self, t: float) -> float:
        return self.after if t >= self.at_s else self.schedule.value_at(t)

    def next_change_s(self, t: float) -> float:
        return math.inf if t >= self.at_s else min(self.at_s, self.schedule.next_change_s(t))


class EveryTick:
    """An event schedule due every tick: `apply(plant, t)` is called each control tick (work that
    depends on the plant's state, such as a shared line's droop; the ticks then run in Python)."""

    def __init__(self, apply):
        self.apply = apply

    def due_s(self, t: float) -> float:
        return t
