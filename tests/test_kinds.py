"""Fault and criterion kinds as registry rows: every row is a kind the scenario files may use and
the docs list, and a kind added as one row (here, in the test) is checked, applied, judged and
reported with no other change."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from scenarios.criteria import CRITERIA, CriterionKind, Measured, When
from scenarios.faults import FAULTS, FaultKind
from scenarios.kinds import registry
from scenarios.runner import run_scenario
from scenarios.schema import ScenarioError, load, parse
from scenarios.sweep import summary_row
from twin_cli.run_commands import print_summary

DOCS = Path(__file__).resolve().parent.parent / "docs" / "scenario_kinds.md"
RIG = (
    'model = "wrist_rig"\nduration_s = 2.0\n[start]\npose = "zero"\n[[targets]]\nangles_deg = { wrist_pitch = 30.0 }\n'
)
ARM = 'model = "arm"\nduration_s = 2.0\n[[targets]]\nangles_deg = { base_yaw = 30.0 }\n'


def fault_table(name: str, kind: FaultKind) -> str:
    """A [[faults]] table of this kind as its row asks: a joint unless it strikes the whole arm, a
    value inside its range (and its joint's limit) where it takes one."""
    text = f"[[faults]]\nkind = '{name}'\nat_s = 0.5\n"
    if not kind.whole_arm:
        text += "joint = 'wrist_pitch'\n"
    if kind.value:
        high = min(kind.value[1], kind.value_limit("wrist_pitch")[0] if kind.value_limit else math.inf)
        text += f"value = {high / 2!r}\n"
    return text


@pytest.mark.parametrize("name", list(FAULTS))
def test_every_fault_kind_is_a_kind_the_files_may_use_and_the_docs_list(name):
    s = parse(RIG + fault_table(name, FAULTS[name]), "x.toml")
    assert s.faults[0].kind == name
    with pytest.raises(ScenarioError) as e:
        parse(RIG + "[[faults]]\nkind = 'no_such_fault'\nat_s = 0.5\n", "x.toml")
    assert repr(name) in str(e.value)  # the refusal of an unknown kind lists every kind
    assert f"`{name}`" in DOCS.read_text()


@pytest.mark.parametrize("name", list(CRITERIA))
def test_every_criterion_kind_is_a_kind_the_files_may_use_and_the_docs_list(name):
    kind = CRITERIA[name]
    joint = "base_yaw" if kind.arm_only else "wrist_pitch"
    text = (ARM if kind.arm_only else RIG) + f"[[criteria]]\nkind = '{name}'\nmax = 1.0\n"
    s = parse(text + (f"joint = '{joint}'\n" if kind.joint_required else ""), "x.toml")
    assert s.criteria[0].kind == name
    with pytest.raises(ScenarioError) as e:
        parse(RIG + "[[criteria]]\nkind = 'no_such_criterion'\nmax = 1.0\n", "x.toml")
    assert repr(name) in str(e.value)
    assert f"`{name}`" in DOCS.read_text()


def test_a_kind_named_twice_is_refused():
    row = FAULTS["brake_fails"]
    with pytest.raises(ValueError, match="a kind named twice"):
        registry(row, FAULTS["supply_lost"], row)


def _wear_vane_seal(plant, fault) -> None:
    plant.set_joint_params(fault.joint, plant.joint_params[fault.joint]._replace(leak_area_m2=fault.value))


def _final_angle(c, e) -> list[Measured]:
    i = e.joints.index(c.joint)
    return [Measured(c.joint, math.degrees(float(e.arrays["true_angle_rad"][-1, i])))]


# a fault and a criterion the code does not have, each one row
VANE_SEAL_WORN = FaultKind(
    name="vane_seal_worn",
    what="the vanes' seals wear: the air leaks between the chambers through `value` m^2",
    act=_wear_vane_seal,
    value=(0.0, 1e-5, "m^2"),  # pneumatics/params.py's range of leak_area_m2
)
FINAL_ANGLE_DEG = CriterionKind(
    name="final_angle_deg",
    unit="deg",
    what="the true angle of `joint` at the end lies in min..max deg",
    when=When.WHOLE_RUN,
    measure=_final_angle,
    by_joint=True,
    joint_required=True,
)


def test_a_fault_and_a_criterion_added_as_one_row_each_are_checked_applied_judged_and_reported(monkeypatch, capsys):
    """Rows added to the registries: the schema refuses their misuse and names them among the
    allowed, the run applies the fault to the plant (the wrist stops short, its prediction, which
    was not told, does not) and judges the criterion, and the summary, its printout and the sweep's
    table report it."""
    monkeypatch.setitem(FAULTS, VANE_SEAL_WORN.name, VANE_SEAL_WORN)
    monkeypatch.setitem(CRITERIA, FINAL_ANGLE_DEG.name, FINAL_ANGLE_DEG)
    base = load("wrist_closed_loop_60deg").text  # 60 deg reached at 1.25 s
    fault = "[[faults]]\nkind = 'vane_seal_worn'\nat_s = 0.0\njoint = 'wrist_pitch'\n"
    criterion = "[[criteria]]\nkind = 'final_angle_deg'\nmin = 55.0\nmax = 65.0\n"

    refusals = {
        fault: "faults[0].value = <missing> is not allowed; allowed: a number in 0..1e-05 m^2",
        fault + "value = 2e-5\n": "faults[0].value = 2e-05 is not allowed; allowed: a number in 0..1e-05 m^2",
        "[[faults]]\nkind = 'vane_seal_worn'\nat_s = 0.0\nvalue = 2e-6\n": "faults[0].joint = '' is not allowed",
        criterion: "criteria[1].joint = <missing> is not allowed; allowed: wrist_pitch",
        "[[faults]]\nkind = 'brake_fails'\nat_s = 0.0\njoint = 'wrist_pitch'\nvalue = 1.0\n": (
            "a value only with hose_leak, sensor_bias, vane_seal_worn"
        ),
        "[[faults]]\nkind = 'melt'\nat_s = 0.0\n": "'sensor_bias' | 'vane_seal_worn'",
        "[[criteria]]\nkind = 'shine'\n": "'contact_after_plan_n' | 'final_angle_deg'",
    }
    for extra, message in refusals.items():
        with pytest.raises(ScenarioError, match=re.escape(message)):
            parse(base + extra, "x.toml")

    criterion += "joint = 'wrist_pitch'\n"
    healthy = run_scenario(parse(base + criterion, "x.toml"), duration_s=2.0).summary()
    worn = run_scenario(parse(base + fault + "value = 2e-6\n" + criterion, "x.toml"), duration_s=2.0).summary()

    for summary in (healthy, worn):
        angles = summary["joints"]["wrist_pitch"]
        verdict = summary["criteria"][-1]
        assert verdict["kind"] == "final_angle_deg" and verdict["subject"] == "wrist_pitch"
        assert round(verdict["value"], 4) == angles["true_final_deg"] and verdict["limit"] == "55..65"
        assert verdict["judged"] and verdict["passed"] == (55.0 <= verdict["value"] <= 65.0)
    assert healthy["passed"] and healthy["criteria"][-1]["value"] > 55.0
    # the leak across the vanes struck the plant: the wrist stops far short; the controller was not told
    assert worn["criteria"][-1]["value"] < 30.0 and not worn["passed"]
    assert (
        worn["joints"]["wrist_pitch"]["predicted_final_deg"] == healthy["joints"]["wrist_pitch"]["predicted_final_deg"]
    )
    assert summary_row(worn)["final_angle_deg[wrist_pitch].passed"] is False
    print_summary(worn)
    assert "[FAIL] final_angle_deg wrist_pitch:" in capsys.readouterr().out
