"""The task's state machine: its states, one transition row, and what can be asked of a table of rows
(the rows leaving a state, the states reachable, the table as text).

The task's own table, its conditions and actions, and what each state does when asked are in
scenarios/task.py; docs/task_states.md draws the machine.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any


class TaskState(enum.Enum):
    """Where the operator's task stands; `k` is the target under way (`TaskController.k`)."""

    START = "start"  # nothing sent yet
    MOVING = "moving"  # the platform taking the arm to target k at the plan's standoff
    CLOSING_IN = "closing in"  # to TOUCH_STANDOFF_M off the rim, before the press that follows approach k
    RETREATING = "retreating"  # back to CLEAR_M off the rim from a look the operator does not believe
    DRAWING_OUT = "drawing out"  # the brush straight out along the rim's normal, seen on it at target k
    BACKING_OUT = "backing out"  # out of the press to TOUCH_STANDOFF_M, wrist held, before back-off k
    OUT_TO_PRESS_AGAIN = "out to press again"  # out of press k, seen off, to TOUCH_STANDOFF_M
    LOOKING = "looking"  # at rest at target k: the operator's look (at the plan's standoff, or the last pose)
    LOOKING_CLOSE = "looking close"  # at rest at TOUCH_STANDOFF_M: his look before the press
    LOOKING_AT_PRESS = "looking at the press"  # pressed at target k: his look at the head's stroke
    STOP_DRIVE = "stop drive"  # the shoulder driven open loop into its stop, then settled (rereference)
    GOING_ON = "going on"  # target k done: the next is taken up
    FINISHED = "finished"  # every target done


# where the task decides at once, the arm at rest: a transition into one of these is followed by the
# next at the same tick; in the others the task waits for the platform's move (or the stop drive)
AT_REST = frozenset(
    {TaskState.START, TaskState.GOING_ON, TaskState.LOOKING, TaskState.LOOKING_CLOSE, TaskState.LOOKING_AT_PRESS}
)

# a condition or an action: called with the task and the time (s)
Condition = Callable[[Any, float], bool]
Action = Callable[[Any, float], None]


@dataclass(frozen=True)
class Transition:
    """One row of the table: from `source`, where `when` holds, to `target`, doing `action` (None:
    nothing). Of a state's rows the first whose condition holds is taken (table order); none holding,
    the task stays and is asked again at the next tick. The action runs with the task in `target`:
    a move it sends is the target state's (its standoff)."""

    source: TaskState
    when: Condition
    target: TaskState
    action: Action | None = None


def rows_from(table: Iterable[Transition]) -> dict[TaskState, tuple[Transition, ...]]:
    """Each state's rows, in table order (a state without rows: an empty tuple)."""
    rows: dict[TaskState, list[Transition]] = {s: [] for s in TaskState}
    for row in table:
        rows[row.source].append(row)
    return {s: tuple(r) for s, r in rows.items()}


def reachable(table: Iterable[Transition], start: TaskState = TaskState.START) -> set[TaskState]:
    """The states the table can lead to from `start` (itself included)."""
    rows = rows_from(table)
    seen, todo = {start}, [start]
    while todo:
        for row in rows[todo.pop()]:
            if row.target not in seen:
                seen.add(row.target)
                todo.append(row.target)
    return seen


def name_of(f: Condition | Action | None) -> str:
    """A condition's or an action's name as the table shows it ('-': no action)."""
    return "-" if f is None else f.__name__.lstrip("_")


def as_text(table: Iterable[Transition]) -> list[str]:
    """The table, a row a line: 'FROM | condition | TO | action' (docs/task_states.md shows it)."""
    return [f"| {r.source.name} | {name_of(r.when)} | {r.target.name} | {name_of(r.action)} |" for r in table]
