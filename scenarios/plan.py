"""The cleaning plan, made at run time for the string as the platform sees it.

A scenario's `clean_string = true` target stands for every disc of the string, top to bottom:
per disc the brush comes in well clear, then just clear of the rim, presses into it for a dwell,
backs off straight and then well clear, and goes on to the next disc. How many discs there are
and where they stand is the platform's view of the string: the operator's sighting in his picture
(scenarios/sighting.py), or, without the operator, the scene file's string (what the crew was told).
The distances are the same for every disc; each has its reason below. Where the arm cannot reach a
distance for the string found (asked of `reach`: the arm's inverse kinematics with every joint in
its range), the standoff is the largest it reaches below it, in STANDOFF_STEP_M steps: the ready
standoff down to touching distance, the clearance down to the ready standoff; a disc whose press or
touching distance it cannot reach is left out of the plan (the task says so, and the disc counts as
not cleaned).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from scenarios.schema import Scenario, Target

# the first approach of the string, from above it: well clear of the top disc
FIRST_CLEAR_M = 0.15
# between discs: moving the shoulder first swings the brush up to 12 cm towards the string (the
# parallelogram keeps the forearm's pitch), and 0.15 is out of reach at the middle discs
CLEAR_M = 0.12
# just clear of the rim, level with the shed: where the operator places the brush before the press
READY_M = 0.05
# the press: 25 mm into the rim, the head's spring gives ~30 N (800 N/m, 10 N preload, assets/arm.xml)
PRESS_M = 0.025
DWELL_S = 1.0  # held pressed
# a standoff out of the arm's reach is brought in by this much at a time (m): the string 10 cm
# closer folds the arm so far at its middle discs that 12 cm, even 5 cm, is past the shoulder's stop
STANDOFF_STEP_M = 0.01
# the operator's last look before a press is taken with the brush's face this far off the rim (m):
# a press from the plan's 5 cm standoff is a 7.5 cm move, and the as-built arm's error over such a
# move (up to 4 cm high and 10 deg of tilt at disc 1, measured) put the head's side, not its face,
# on the rim's top edge, where the spring takes nothing (100-450 N). From 2 cm the press is 4.5 cm,
# and 2 cm is twice his 1 cm placement tolerance: still clear of the rim when he looks. It is also
# the nearest the plan's ready standoff may be brought in where 5 cm is out of reach
TOUCH_STANDOFF_M = 0.02

# the largest turn of the tool's pitch planned from one disc to the next with the brush nearer the
# string than CLEAR_M at both ends. With the string 10 cm closer discs 3 and 4 are reached only a
# few cm off, disc 3 with the tool 50 deg down, disc 4 with it 45 deg up, and the 95 deg turn
# between them swept the head over disc 4's top edge (201 N); planned at most 45 deg apart (disc 4
# tilted down as disc 3), 32 N. Where one end is at the clearance a large turn passes clear: 75 deg
# between 12 cm standoffs (the scene file's string, discs 3 to 4: 21-36 N), 110 deg from 6 to 12 cm
# (the closer string, discs 4 to 5: 25-35 N over 3 seeds); held to 45 deg there too, discs 5 and 6
# were pressed with the tool 30-45 deg down, at 70-111 N
MAX_TURN_NEAR_RAD = math.radians(45.0)

# (disc, standoff_m) -> whether the arm can put the brush there: the plan's view of the arm's reach
Reach = Callable[[int, float], bool]
# (disc, standoff_m, pitch) -> the tool's absolute pitches (rad) with which the arm puts the brush
# there, every joint in its range, in the order they are tried: from `pitch` (None: along the
# rim's normal) out, 5 deg at a time, up to 45 deg either way (empty: out of reach)
Tilts = Callable[[int, float, float | None], list[float]]


def _everywhere(_disc: int, _standoff_m: float) -> bool:
    return True


def standoff_m(disc: int, wanted_m: float, least_m: float, reach: Reach) -> float | None:
    """The largest standoff from `wanted_m` down to `least_m`, in STANDOFF_STEP_M steps, that the
    arm reaches on `disc` (None: none does)."""
    standoff = wanted_m
    while not reach(disc, standoff):
        if standoff <= least_m + 1e-9:
            return None
        standoff = max(least_m, round(standoff - STANDOFF_STEP_M, 6))
    return standoff


def ready_m(disc: int, reach: Reach) -> float | None:
    """Where the brush stands before the press on `disc`: READY_M, brought in towards touching
    distance where the arm does not reach it (None: not even there, or the press is out of reach)."""
    return standoff_m(disc, READY_M, TOUCH_STANDOFF_M, reach) if reach(disc, -PRESS_M) else None


def disc_targets(disc: int, first: bool, last: bool, reach: Reach | None = None) -> list[Target]:
    """One disc's approach, press and back-off (brush_at_disc targets); `reach` brings a standoff
    out of the arm's reach in (None: every distance is reachable). The disc's press must be reachable
    (`reachable_discs`)."""
    reach = reach or _everywhere
    ready = ready_m(disc, reach)
    clear = standoff_m(disc, CLEAR_M, ready, reach)
    come_in = [Target(brush_at_disc=disc, standoff_m=standoff_m(disc, FIRST_CLEAR_M, ready, reach) if first else clear)]
    press = [
        Target(brush_at_disc=disc, standoff_m=ready),
        Target(brush_at_disc=disc, standoff_m=-PRESS_M, dwell_s=DWELL_S),
        # back off straight first: a long move's joints, turning together at their own speeds,
        # first push the brush further in (a 67 N peak on the way out)
        Target(brush_at_disc=disc, standoff_m=ready),
    ]
    # the last disc: the retreat's shoulder move needs the forearm no lower than at the rim
    go_on = [] if last else [Target(brush_at_disc=disc, standoff_m=clear)]
    return come_in + press + go_on


def reachable_discs(n_discs: int, reach: Reach | None = None) -> list[int]:
    """The discs (1..n) whose ready standoff and press the arm reaches (all, without `reach`)."""
    return [d for d in range(1, n_discs + 1) if ready_m(d, reach or _everywhere) is not None]


def disc_pitches(discs: list[int], tilts: Tilts) -> dict[int, float]:
    """The tool's pitch (rad) each disc is pressed at, where the plan departs from the pitch nearest
    the rim's normal that reaches the press (the discs left out keep that one). The operator aims
    every target of a disc from its press's pitch (scenarios/task.py), each at the first pitch from
    it that the arm reaches; the plan's disc-to-disc move goes from one disc's last target to the
    next one's first. Rule, top to bottom: of the press pitches the arm reaches (the nearest the
    normal first), the first whose disc-to-disc turn is at most MAX_TURN_NEAR_RAD or has the brush
    at least CLEAR_M off at one end; none such: the least turn. A disc's standoffs are then those
    the arm reaches from its pitch (`disc_targets`)."""
    chosen: dict[int, float] = {}

    def reach(disc: int, standoff: float) -> bool:
        return bool(tilts(disc, standoff, chosen.get(disc)))

    def aimed(disc: int, standoff: float, press: float) -> float:
        # as the operator aims it: from the press's pitch (the plan's own where that is out of reach)
        return (tilts(disc, standoff, press) or tilts(disc, standoff, chosen.get(disc)))[0]

    before: tuple[float, float] | None = None  # the previous disc's last target: standoff, pitch
    for disc in discs:
        press = tilts(disc, -PRESS_M, None)
        best: tuple[float, float, tuple[float, float]] | None = None  # turn, press pitch, last target
        for i, pitch in enumerate(press):
            if i:
                chosen[disc] = pitch
            if ready_m(disc, reach) is None:
                continue
            planned = disc_targets(disc, first=disc == discs[0], last=disc == discs[-1], reach=reach)
            come, go = planned[0].standoff_m, planned[-1].standoff_m
            turn = 0.0 if before is None else abs(aimed(disc, come, pitch) - before[1])
            option = (turn, pitch, (go, aimed(disc, go, pitch)))
            if turn <= MAX_TURN_NEAR_RAD or (before is not None and max(before[0], come) >= CLEAR_M):
                best = option
                break
            if best is None or turn < best[0]:
                best = option
        _, pitch, before = best
        chosen.pop(disc, None)
        if pitch != press[0]:
            chosen[disc] = pitch
    return chosen


def expand(scenario: Scenario, n_discs: int, reach: Reach | None = None) -> Scenario:
    """The scenario with each `clean_string` target replaced by the plan for the discs of `n_discs`
    that the arm reaches (`reachable_discs`), top to bottom."""
    if not any(t.clean_string for t in scenario.targets):
        return scenario
    discs = reachable_discs(n_discs, reach)
    targets: list[Target] = []
    for t in scenario.targets:
        if not t.clean_string:
            targets.append(t)
            continue
        for disc in discs:
            targets.extend(disc_targets(disc, first=disc == discs[0], last=disc == discs[-1], reach=reach))
    return replace(scenario, targets=tuple(targets))
