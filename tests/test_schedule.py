"""The run loop's schedules (control/schedule.py): every supply kind a scenario allows and the
faults say when they next change, truly; what is not a schedule is refused at the start; a lost
supply is written once a tick."""

from __future__ import annotations

import math
import typing

import numpy as np
import pytest

import assets
from control.loop import run_ticks
from control.schedule import EventSchedule, Schedule
from pneumatics import AIR
from scenarios.faults import FaultEvents
from scenarios.runner import scenario_files
from scenarios.schema import Fault, Supply, load
from scenarios.supply import supply_profile
from twin.plant import Plant
from twin.sim import CommandSchedule, run

SUPPLY_KINDS = typing.get_args(typing.get_type_hints(Supply, include_extras=True)["kind"])[0].__args__


def _supplies() -> dict[str, Supply]:
    return {
        "constant": Supply(kind="constant", pressure_mpa=0.5),
        "steps": Supply(kind="steps", pressure_mpa=0.6, steps=((0.3, 0.4), (0.71, 0.7))),
        "random": Supply(kind="random", hold_s=0.25),
    }


def test_the_supply_kinds_are_the_schemas():
    # a kind added to the schema without a schedule here would fail `supply_profile`
    assert set(_supplies()) == set(SUPPLY_KINDS), SUPPLY_KINDS


@pytest.mark.parametrize("kind", sorted(_supplies()))
def test_each_supply_kind_tells_truly_when_it_next_changes(kind):
    """Sampled every 0.1 ms: the value holds from t until `next_change_s(t)` and (but for a constant)
    differs right after it."""
    profile = supply_profile(_supplies()[kind], 2.0, np.random.default_rng(5))
    assert isinstance(profile, Schedule)
    times = np.arange(0.0, 1.5, 1e-4)
    values = np.array([profile.value_at(t) for t in times])
    changes = 0
    for i, t in enumerate(times[:-1]):
        due = profile.next_change_s(t)
        assert due > t
        held = (times >= t) & (times < due - 1e-6)
        assert (values[held] == values[i]).all(), (kind, t, due)
        if due < times[-1]:
            after = np.flatnonzero(times >= due + 1e-6)[0]
            changes += values[after] != values[i]
    if kind == "constant":
        assert profile.next_change_s(0.0) == math.inf
    else:
        assert changes > 0


def test_faults_are_due_at_their_times_and_a_lost_supply_is_the_supplys_schedule():
    faults = FaultEvents(
        (Fault(kind="brake_fails", at_s=0.4, joint="wrist_pitch"), Fault(kind="supply_lost", at_s=0.25))
    )
    assert isinstance(faults, EventSchedule)
    assert faults.due_s(0.0) == 0.25
    supply = faults.supply(supply_profile(_supplies()["steps"], 2.0, np.random.default_rng(0)))
    assert supply.next_change_s(0.0) == 0.25  # before the steps' first change at 0.3 s
    assert supply.value_at(0.25) == AIR.p_atm_pa and supply.next_change_s(0.25) == math.inf
    assert supply.value_at(0.2) == AIR.p_atm_pa + 0.6e6


class _CountingPlant(Plant):
    """The wrist rig, counting the supply's writes at each plant time."""

    def __init__(self):
        super().__init__(assets.WRIST_RIG_XML)
        self.writes: dict[float, list[float]] = {}

    def set_supply(self, supply_pa: float) -> None:
        self.writes.setdefault(self.time, []).append(supply_pa)
        super().set_supply(supply_pa)


def test_a_lost_supply_is_written_once_a_tick():
    plant = _CountingPlant()
    faults = FaultEvents((Fault(kind="supply_lost", at_s=0.0025),))
    supply = faults.supply(supply_profile(_supplies()["constant"], 1.0, np.random.default_rng(0)))
    hold = CommandSchedule(lambda t: np.zeros((1, 3)), 1)
    assert run_ticks(hold, plant, 2, 6, supply, faults) == 6
    assert len(plant.writes) == 6 and all(len(w) == 1 for w in plant.writes.values()), plant.writes
    supply_pa = AIR.p_atm_pa + 0.5e6
    assert [w[0] for w in plant.writes.values()] == [supply_pa] * 3 + [AIR.p_atm_pa] * 3  # from the 3 ms tick on


def test_a_function_where_a_schedule_belongs_is_refused():
    plant = Plant(assets.WRIST_RIG_XML)
    hold = CommandSchedule(lambda t: np.zeros((1, 3)), 1)
    with pytest.raises(TypeError, match="is no Schedule; allowed: an object with value_at"):
        run(plant, hold, 0.01, supply=lambda t: 6e5)
    with pytest.raises(TypeError, match="is no EventSchedule; allowed: an object with apply"):
        run_ticks(hold, plant, 2, 1, events=lambda plant, t: None)


def test_every_shipped_scenarios_schedules_are_schedules():
    """No shipped scenario's supply or faults can fall back to the per-tick loop: each is a schedule."""
    for path in scenario_files():
        s = load(path)
        faults = FaultEvents(s.faults)
        supply = faults.supply(supply_profile(s.supply, s.duration_s, np.random.default_rng(s.seed)))
        assert isinstance(supply, Schedule) and isinstance(faults, EventSchedule), path.name
