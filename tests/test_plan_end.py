"""Criteria judged at the plan's end: the task's time and no contact after it, on synthetic
telemetry (the judge's arithmetic) and as the scenario checker takes them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from assets import JOINTS
from scenarios.criteria import judge
from scenarios.schema import ScenarioError, compiled_model, parse

ARM = 'model = "arm"\nduration_s = 20.0\n[[targets]]\nangles_deg = { base_yaw = 10.0 }\n'
CRITERIA = '[[criteria]]\nkind = "task_time_s"\nmax = 15.0\n[[criteria]]\nkind = "contact_after_plan_n"\nmax = 5.0\n'


def telemetry(force_at_s: float) -> dict[str, np.ndarray]:
    """20 s at 50 Hz, the brush pressing 20 N for 1 s from `force_at_s`."""
    t = np.arange(0.0, 20.0, 0.02)
    force = np.where((t >= force_at_s) & (t < force_at_s + 1.0), 20.0, 0.0)
    return {"time_s": t, "brush_force_n": force}


def verdicts(force_at_s: float, finished_s: float, reached: list[bool] | None = None) -> dict[str, tuple]:
    s = parse(ARM + CRITERIA, "x.toml")
    got = judge(s, telemetry(force_at_s), JOINTS, (), compiled_model("arm"), reached=reached, finished_s=finished_s)
    return {v.kind: (v.value, v.passed, v.judged) for v in got}


def test_a_touch_after_the_plan_ends_fails_and_one_before_it_does_not():
    after = verdicts(force_at_s=12.0, finished_s=10.0)
    assert after["contact_after_plan_n"] == (20.0, False, True)
    assert after["task_time_s"] == (10.0, True, True)
    before = verdicts(force_at_s=5.0, finished_s=10.0)
    assert before["contact_after_plan_n"] == (0.0, True, True)


def test_a_plan_never_finished_fails_both_and_a_run_cut_short_judges_neither():
    never = verdicts(force_at_s=5.0, finished_s=math.nan)
    for kind in ("task_time_s", "contact_after_plan_n"):
        value, passed, judged = never[kind]
        assert math.isnan(value) and not passed and judged
    slow = verdicts(force_at_s=5.0, finished_s=16.0)
    assert slow["task_time_s"] == (16.0, False, True)
    cut = verdicts(force_at_s=5.0, finished_s=math.nan, reached=[False])
    assert not cut["task_time_s"][2] and not cut["contact_after_plan_n"][2]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            'model = "wrist_rig"\nduration_s = 1.0\n[[targets]]\nangles_deg = { wrist_pitch = 10.0 }\n'
            '[[criteria]]\nkind = "task_time_s"\nmax = 5.0\n',
            r"x.toml: criteria\[0\].kind = 'task_time_s' is not allowed; allowed: a criterion the rig",
        ),
        (
            'model = "arm"\n[[criteria]]\nkind = "contact_after_plan_n"\nmax = 5.0\n',
            r"x.toml: criteria\[0\].kind = 'contact_after_plan_n' is not allowed; allowed: a criterion the scenario",
        ),
    ],
)
def test_plan_end_criteria_need_the_arm_and_a_plan(text, message):
    with pytest.raises(ScenarioError, match=message):
        parse(text, "x.toml")
