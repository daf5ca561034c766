"""What the controller and the operator report during a run, as timed events for the logs.

Controllers keep their reports as lines "t = 12.345 s: text" in lists they only append to (the
platform's `events`; a task's notes and its operator's looks). `EventTail` hands the recorders the
lines added since it last looked, parsed into `Event`s: rerun shows them as a text log, the MCAP
holds them as foxglove.Log, both at the simulated time the line names.

A controller names its lists with `event_lists()` -> [(source, [line, ...]), ...]; one without it
but with an `events` list reports as "controller".
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass, replace

_TIMED = re.compile(r"^t = ([-+0-9.eE]+) s: (.*)$", re.DOTALL)


class EventLevel(enum.Enum):
    """How much an event matters; the values are rerun's text-log levels."""

    INFO = "INFO"
    WARN = "WARN"
    ERROR = "ERROR"


# words that mark a report as a warning or an error (the controller's own wording, control/controller.py)
_ERROR_WORDS = ("refused",)
_WARN_WORDS = ("fault, ", "brakes engaged", "not reached", "leaves the disc unpressed")


@dataclass(frozen=True)
class Event:
    time_s: float  # simulated time the report names, s (NaN: the line names none)
    source: str  # who reported it: "controller", "operator"
    level: EventLevel
    text: str  # the report without its time


def parse(line: str, source: str = "controller") -> Event:
    """An event from a report line "t = 12.345 s: text" (a line without a time keeps its text, NaN time)."""
    match = _TIMED.match(line)
    time_s, text = (float(match.group(1)), match.group(2)) if match else (float("nan"), line)
    lowered = text.lower()
    if any(w in lowered for w in _ERROR_WORDS):
        level = EventLevel.ERROR
    elif any(w in lowered for w in _WARN_WORDS):
        level = EventLevel.WARN
    else:
        level = EventLevel.INFO
    return Event(time_s, source, level, text)


def event_lists(controller) -> list[tuple[str, list[str]]]:
    """A controller's report lists and their sources (see the module's docstring)."""
    named = getattr(controller, "event_lists", None)
    if callable(named):
        return named()
    lines = getattr(controller, "events", None)
    return [("controller", lines)] if isinstance(lines, list) else []


class EventTail:
    """The reports a controller added since the last call of `new`, oldest first."""

    def __init__(self, controller):
        self.controller = controller
        self._seen: dict[int, int] = {}  # lines already handed on, per list

    def new(self, now_s: float) -> list[Event]:
        """The new reports; one whose line names no time is placed at `now_s`."""
        out = []
        for k, (source, lines) in enumerate(event_lists(self.controller)):
            start = self._seen.get(k, 0)
            for line in lines[start:]:
                e = parse(line, source)
                out.append(e if e.time_s == e.time_s else replace(e, time_s=now_s))  # NaN != NaN
            self._seen[k] = len(lines)
        return sorted(out, key=lambda e: e.time_s)
