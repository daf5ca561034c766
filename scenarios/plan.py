"""The cleaning plan, made at run time for the string as the platform sees it.

A scenario's `clean_string = true` target stands for every disc of the string, top to bottom:
per disc the brush comes in well clear, then just clear of the rim, presses into it for a dwell,
backs off straight and then well clear, and goes on to the next disc. How many discs there are
and where they stand is the platform's view of the string: the operator's sighting in his picture
(scenarios/sighting.py), or, without the operator, the scene file's string (what the crew was told).
The distances are the same for every disc; each has its reason below.
"""

from __future__ import annotations

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


def disc_targets(disc: int, first: bool, last: bool) -> list[Target]:
    """One disc's approach, press and back-off (brush_at_disc targets)."""
    come_in = [Target(brush_at_disc=disc, standoff_m=FIRST_CLEAR_M if first else CLEAR_M)]
    press = [
        Target(brush_at_disc=disc, standoff_m=READY_M),
        Target(brush_at_disc=disc, standoff_m=-PRESS_M, dwell_s=DWELL_S),
        # back off straight first: a long move's joints, turning together at their own speeds,
        # first push the brush further in (a 67 N peak on the way out)
        Target(brush_at_disc=disc, standoff_m=READY_M),
    ]
    # the last disc: the retreat's shoulder move needs the forearm no lower than at the rim
    go_on = [] if last else [Target(brush_at_disc=disc, standoff_m=CLEAR_M)]
    return come_in + press + go_on


def expand(scenario: Scenario, n_discs: int) -> Scenario:
    """The scenario with each `clean_string` target replaced by the plan for `n_discs` discs."""
    if not any(t.clean_string for t in scenario.targets):
        return scenario
    targets: list[Target] = []
    for t in scenario.targets:
        if not t.clean_string:
            targets.append(t)
            continue
        for disc in range(1, n_discs + 1):
            targets.extend(disc_targets(disc, first=disc == 1, last=disc == n_discs))
    return replace(scenario, targets=tuple(targets))
