"""The compiled ticks (twin/compiled_loop.py) give the per-tick Python loop's results bit for bit.

Each scenario runs twice: once with the compiled ticks switched off (every tick through
control/loop.py's Python loop, the reference), once as `twin run` does; every telemetry array and
the summary must be identical, and the compiled ticks must have run most of the ticks (so the comparison is not one of
the Python loop with itself)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

import twin.compiled_loop
import twin.plant
import twin.sim
from scenarios.runner import run_scenario, scenario_files
from scenarios.schema import load

SCENARIOS = {p.stem: p for p in scenario_files()}


def _with_dwell(scenario):
    # the wrist to 60 deg, a 1 s dwell there (counted down by the compiled ticks), back to 20 deg
    there = replace(scenario.targets[0], dwell_s=1.0)
    back = replace(scenario.targets[0], angles_deg={"wrist_pitch": 20.0})
    return replace(scenario, targets=(there, back), criteria=())


def _run_both(name: str, seconds: float, monkeypatch) -> tuple:
    scenario = (
        _with_dwell(load(SCENARIOS[name[: -len("+dwell")]])) if name.endswith("+dwell") else load(SCENARIOS[name])
    )
    with monkeypatch.context() as m:
        m.setattr(twin.plant, "compiled_ticks", lambda *a, **k: None)
        python = run_scenario(scenario, duration_s=seconds)
    ran = []
    call = twin.compiled_loop.CompiledTicks.__call__

    def counted(self, k, applied_s):
        n = call(self, k, applied_s)
        ran.append(n)
        return n

    with monkeypatch.context() as m:
        m.setattr(twin.compiled_loop.CompiledTicks, "__call__", counted)
        compiled = run_scenario(scenario, duration_s=seconds)
    return python, compiled, sum(ran)


@pytest.mark.parametrize(
    ("name", "seconds"),
    [
        # moves with the predicted load stale every tick (Pinocchio from compiled code), dwells,
        # the operator's camera and looks, arrivals
        ("insulator_cleaning", 8.0),
        # the open loop's valve time, a fault (the supply under the brakes' release) mid-move
        ("wrist_open_loop_60deg", 3.0),
        ("wrist_closed_loop_60deg+dwell", 6.0),
        ("fault_supply_lost", 4.0),
        # a supply drawn at random every 0.5 s (its next draw's time is a schedule's due time)
        ("wrist_random_supply", 3.0),
    ],
)
def test_compiled_ticks_give_the_python_loops_results(name, seconds, monkeypatch):
    python, compiled, compiled_ticks = _run_both(name, seconds, monkeypatch)
    a, b = python.telemetry.arrays(), compiled.telemetry.arrays()
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=True), key
    assert json.dumps(python.summary(), sort_keys=True) == json.dumps(compiled.summary(), sort_keys=True)
    assert python.events == compiled.events
    n_ticks = round(seconds / 1e-3)
    assert compiled_ticks > 0.7 * n_ticks


def test_an_error_in_the_load_from_compiled_code_is_raised(monkeypatch):
    # the load is taken through a ctypes callback, which would print an exception and go on
    from control.controller import ArmController

    def broken(self):
        raise ValueError("pinocchio broke")

    monkeypatch.setattr(ArmController, "update_load", broken)
    with pytest.raises(ValueError, match="pinocchio broke"):
        run_scenario(load(SCENARIOS["insulator_cleaning"]), duration_s=2.0)


def test_an_error_in_on_tick_from_compiled_code_is_raised(monkeypatch):
    # the run's on_tick (telemetry) is called through a ctypes callback too: what it raises ends the
    # run there, with the samples taken before it kept
    samples = []
    on_tick = twin.sim._Recording.on_tick

    def breaks_at_one_second(self, k, t, row=None):
        if t > 1.0 - 1e-6:  # (the tick at 1 s: its time summed by MuJoCo lands within round-off)
            raise ValueError(f"telemetry broke at {t:.3f} s")
        on_tick(self, k, t, row)
        samples.append(len(self.telemetry))

    monkeypatch.setattr(twin.sim._Recording, "on_tick", breaks_at_one_second)
    with pytest.raises(ValueError, match="telemetry broke at 1.000 s"):
        run_scenario(load(SCENARIOS["insulator_cleaning"]), duration_s=2.0)
    assert samples[-1] == 50  # one sample every 20 ms before it


def test_the_papers_experiments_run_compiled_as_the_python_loop(monkeypatch):
    """control/experiments.py's runs (a stop rule of their own, a random supply) through the same
    loop: the plant's compiled ticks give the Python loop's final angles and simulated time."""
    import assets
    from control.experiments import random_supply_moves
    from twin.plant import Plant

    def make():
        return Plant(assets.WRIST_RIG_XML)

    def moves():
        return random_supply_moves(make, targets_deg=(30.0, 0.0), seed=3, max_s_each=3.0)

    with monkeypatch.context() as m:
        m.setattr(twin.plant, "compiled_ticks", lambda *a, **k: None)
        python = moves()
    ran = []
    call = twin.compiled_loop.CompiledTicks.__call__

    def counted(self, k, applied_s):
        ran.append(call(self, k, applied_s))
        return ran[-1]

    with monkeypatch.context() as m:
        m.setattr(twin.compiled_loop.CompiledTicks, "__call__", counted)
        compiled = moves()
    assert compiled == python
    assert sum(ran) > 0.7 * python[1] / 1e-3  # most ticks compiled
