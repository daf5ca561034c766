"""The operator's task as a state machine (scenarios/task.py, docs/task_states.md): each row of its
transition table taken from a state set up by hand, with the operator's look made to see what the
row needs (the real Operator, his `review`/`review_press` answering as constructed), on the shipped
cleaning plan with the real platform controller and plant; the state it moves to and what it does
on the way (the target it sends, where that puts the brush, what the operator says). And the table
itself: every state reachable from the start, the end reachable from every state, every row
tested here, and docs/task_states.md showing the table as the code has it."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scenarios import controllers
from scenarios.ik import BRUSH_HALF_LENGTH_M
from scenarios.plan import CLEAR_M, PRESS_M, READY_M, TOUCH_STANDOFF_M
from scenarios.runner import build_plant, plan
from scenarios.schema import joint_params_for, load, nominal_params
from scenarios.task import MOVES, STOPS_PER_DISC, TRANSITIONS, TaskController
from scenarios.task_states import TaskState, as_text, name_of, reachable

ROOT = Path(__file__).resolve().parents[1]
S = TaskState
T_S = 0.0  # the time the transitions are taken at (the plant's, never stepped)


@pytest.fixture(scope="module")
def shipped():
    """The shipped cleaning scenario planned for the string as the operator finds it: (scenario,
    discs, drive-angle targets)."""
    scenario = load(ROOT / "scenarios" / "insulator_cleaning.toml")
    return plan(scenario, build_plant(scenario))


class Task:
    """A task in `state` at target `k` (the platform at rest, believing the plan's pose at target `at`,
    k unless told), the plan cut after target `last` if told, with what it sends recorded and the
    operator's looks answering as told (`sees`)."""

    def __init__(
        self,
        shipped,
        state: TaskState,
        k: int,
        strategy: str = "operator",
        last: int | None = None,
        at: int | None = None,
    ):
        scenario, discs, targets = shipped
        if last is not None:  # the plan cut after target `last`
            scenario, targets = replace(scenario, targets=scenario.targets[: last + 1]), targets[: last + 1]
        scenario = replace(scenario, control=replace(scenario.control, strategy=strategy))
        self.plant = build_plant(scenario)
        predictor = joint_params_for(nominal_params(scenario.joints), scenario.predictor)
        platform, refusal = controllers.build(scenario, self.plant, predictor, targets)
        assert not refusal
        platform.set_targets([])
        self.task = TaskController(platform, scenario, self.plant, targets, np.random.default_rng(0), discs)
        self.platform, self.scenario, self.targets = platform, scenario, targets
        for target in targets[: max(k if at is None else at, 0) + 1]:  # the pose the plan leaves the arm in at k
            for joint, q in target.items():
                platform.reference(joint, q)
        self.task.state, self.task.k = state, k
        if 0 <= k < len(targets) and state not in MOVES:
            self.task.reached[k] = True
        self.sent: list[tuple[list[dict[str, float]], list[float]]] = []
        set_targets = platform.set_targets

        def recorded(steps, sequence="one_after_another", dwell_s=0.0):
            self.sent.append(([dict(s) for s in steps], list(dwell_s)))
            return set_targets(steps, sequence, dwell_s)

        platform.set_targets = recorded

    def sees(self, verdict: bool | None, implausible: str = "", miss_m: float = 0.0) -> Task:
        """His next look's verdict (Operator.review's, review_press's), as constructed."""
        operator = self.task.operator

        def review(*args, **kwargs):
            operator.implausible, operator.last_miss_m = implausible, miss_m
            return verdict

        operator.review = review
        operator.review_press = operator.review_swing = lambda *args: verdict
        return self

    def fire(self, source: TaskState, when: str, target: TaskState, action: str = "-"):
        """Take one transition and check it was the row (source, when, target, action)."""
        notes = len(self.task._notes)
        row = self.task.fire(T_S)
        assert row is not None, f"no transition from {source}"
        assert (row.source, name_of(row.when), row.target, name_of(row.action)) == (source, when, target, action)
        assert self.task.state is target
        return self.task._notes[notes:]

    def standoff_sent_m(self) -> float:
        """Where the target last sent puts the brush's face off its disc's rim (m), by the scene's
        kinematics (a joint the target leaves out stays where the platform believes it); to a few
        mm: the press's inverse kinematics with the wrist held settles 2 mm off at disc 1."""
        task = self.task
        disc = task.discs[self.scenario.targets[task.k].brush_at_disc - 1]
        rim, normal = disc.rim_facing()
        believed = dict(zip(self.platform.joints, self.platform.predicted_angles().tolist(), strict=True))
        return float((task._tip_m({**believed, **task.issued[task.k]}) - rim) @ normal) - BRUSH_HALF_LENGTH_M

    def disc(self) -> int:
        return self.scenario.targets[self.task.k].brush_at_disc


def first(shipped, kind: str) -> int:
    """The index of the plan's first target of a kind (disc 1's): come in, approach, press, back off."""
    ts = shipped[0].targets
    disc_1 = [k for k, t in enumerate(ts) if t.brush_at_disc == 1]
    return {"come in": disc_1[0], "approach": disc_1[1], "press": disc_1[2], "back off": disc_1[3]}[kind]


# -- one case per row: (source, condition) -> the case -------------------------------------------
def start(shipped):
    t = Task(shipped, S.START, -1)
    t.fire(S.START, "always", S.GOING_ON)
    assert t.task.k == -1 and not t.sent  # nothing sent until it goes on


def going_on_plan_done(shipped):
    t = Task(shipped, S.GOING_ON, len(shipped[2]) - 1)
    t.fire(S.GOING_ON, "plan_done", S.FINISHED, "finish")
    assert t.task.k == len(shipped[2]) and not t.sent
    t.task.compiled_camera()  # its frames taken in compiled code
    assert t.task.compiled_ticks(T_S)[1] == math.inf  # finished: nothing more is due


def going_on_back_off_after_press(shipped):
    k = first(shipped, "press")
    t = Task(shipped, S.GOING_ON, k)
    notes = t.fire(S.GOING_ON, "back_off_after_press", S.BACKING_OUT, "back_out_of_press")
    assert t.task.k == k + 1
    assert notes == [f"t = 0.000 s: disc_1: operator backs out to {TOUCH_STANDOFF_M * 100:.0f} cm, wrist held"]
    assert t.standoff_sent_m() == pytest.approx(TOUCH_STANDOFF_M, abs=5e-3)


def going_on_always(shipped):
    t = Task(shipped, S.GOING_ON, -1)
    t.fire(S.GOING_ON, "always", S.MOVING, "next_target")
    assert t.task.k == 0 and t.sent == [([shipped[2][0]], [0.0])]  # the plan's first target as planned
    assert not t.task.reached[0]


def moving_press(shipped):
    k = first(shipped, "press")
    t = Task(shipped, S.MOVING, k)
    t.fire(S.MOVING, "press_to_look_at", S.LOOKING_AT_PRESS)
    assert t.task.reached[k] and t.task.finished_s[k] == T_S and not t.sent


def moving_pose(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.MOVING, k)
    t.fire(S.MOVING, "pose_to_look_at", S.LOOKING)
    assert t.task.reached[k] and not t.sent
    t.task.compiled_camera()  # its frames taken in compiled code
    # the task now only waits for his picture: the compiled ticks may run until he can have one
    assert t.task.compiled_ticks(T_S)[1] == t.task.operator.review_due_s(T_S) > T_S


def moving_pose_before_the_turn_back(shipped):
    """The plan's last but one target (the shoulder raised with the arm turned 40 deg aside), the
    last turning it back into the camera's plane: he looks before the turn (Operator.review_swing)."""
    k = len(shipped[2]) - 2
    t = Task(shipped, S.MOVING, k)
    t.fire(S.MOVING, "pose_to_look_at", S.LOOKING)
    assert t.task._is_before_swing_back(k) and not t.task._is_before_swing_back(k - 1)
    seen = []
    t.task.operator.review = lambda *args, **kwargs: pytest.fail("the pitches are foreshortened this far aside")
    t.task.operator.review_swing = lambda now, done, platform, yaw_to: seen.append(yaw_to) or True
    t.fire(S.LOOKING, "moved", S.MOVING, "go_again")
    assert seen == [0.0] and t.sent[-1][0] == [shipped[2][k]]  # the shoulder's raise sent again


def moving_stop(shipped):
    k = first(shipped, "back off")
    t = Task(shipped, S.MOVING, k, strategy="rereference")
    t.fire(S.MOVING, "stop_to_drive_into", S.STOP_DRIVE, "start_stop_drive")
    stop = t.task._stop
    assert t.platform.joints[stop.joint] == "shoulder_pitch"
    assert stop.stop_rad == pytest.approx(float(t.platform.arm.joint_upper[stop.joint]))
    assert stop.drive_until_s > T_S + 1.0 and stop.settle_until_s == pytest.approx(stop.drive_until_s + 0.3)
    assert t.task.compiled_ticks(T_S)[0] is None  # the stop drive is ticked in Python
    commands = t.task.tick(t.plant.sensors())  # driving: the shoulder's valve open, its brake released
    assert commands[stop.joint].any() and not np.delete(commands, stop.joint, axis=0).any()


def moving_always(shipped):
    """A target not looked at (the plan's first, a base yaw), or a back-off with the shoulder's stop
    out of the elbow's range (rereference at the bottom disc): the task goes on."""
    t = Task(shipped, S.MOVING, 0)
    t.fire(S.MOVING, "always", S.GOING_ON)
    assert t.task.reached[0]
    last_back_off = max(
        k for k, s in enumerate(shipped[0].targets) if s.brush_at_disc and k > 0 and t.task._is_back_off(k)
    )
    t = Task(shipped, S.MOVING, last_back_off, strategy="rereference")
    t.fire(S.MOVING, "always", S.GOING_ON)


def looking_seen_on_the_rim(shipped):
    """The brush seen on disc 1's rim at the 5 cm approach (Operator.on_rim): he draws it straight
    out along the rim's normal by what he saw, its height and the tool's pitch kept."""
    k = first(shipped, "approach")
    t = Task(shipped, S.LOOKING, k).sees(True)
    t.task.operator.on_rim, t.task.operator.draw_out_m = "brush seen 2.0 cm past the rim", 0.07
    here = dict(zip(t.platform.joints, t.platform.predicted_angles().tolist(), strict=True))
    notes = t.fire(S.LOOKING, "seen_on_the_rim", S.DRAWING_OUT, "draw_out")
    assert notes == ["t = 0.000 s: disc_1: operator draws the brush 7.0 cm straight out"]
    sent = t.sent[-1][0][-1]
    assert set(sent) == {"shoulder_pitch", "elbow_pitch", "wrist_pitch"}
    _, normal = t.task.discs[0].rim_facing()
    moved = t.task._tip_m({**here, **sent}) - t.task._tip_m(here)
    assert moved == pytest.approx(0.07 * normal, abs=2e-3)
    assert sent["elbow_pitch"] + sent["wrist_pitch"] == pytest.approx(here["elbow_pitch"] + here["wrist_pitch"])


def drawing_out(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.DRAWING_OUT, k)
    t.fire(S.DRAWING_OUT, "always", S.LOOKING)
    assert t.task.reached[k] and not t.sent  # at rest: he looks again


def looking_not_believed_clear_of_string(shipped):
    k = first(shipped, "come in")  # 15 cm off disc 1: clear of the string
    t = Task(shipped, S.LOOKING, k).sees(True, implausible="elbow seen 25 deg off")
    notes = t.fire(S.LOOKING, "not_believed_clear_of_string", S.MOVING, "stop_and_go_again")
    assert notes == ["t = 0.000 s: disc_1: operator stops (elbow seen 25 deg off), clear of the string"]
    assert t.standoff_sent_m() == pytest.approx(shipped[0].targets[k].standoff_m, abs=5e-3)
    assert not t.task._stopped_on  # not a stop that counts


def looking_not_believed(shipped):
    t = Task(shipped, S.LOOKING, first(shipped, "approach")).sees(True, implausible="elbow seen 25 deg off")
    notes = t.fire(S.LOOKING, "not_believed", S.RETREATING, "stop_and_retreat")
    assert notes == [
        "t = 0.000 s: disc_1: operator stops (elbow seen 25 deg off), backs off to 12 cm "
        "and comes in again to look afresh"
    ]
    assert t.standoff_sent_m() == pytest.approx(CLEAR_M, abs=5e-3) and t.task._stopped_on == [1]


def looking_not_believed_again_before_press(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.LOOKING, k).sees(True, implausible="wrist seen 22 deg off")
    t.task._stopped_on = [1] * STOPS_PER_DISC
    notes = t.fire(S.LOOKING, "not_believed_again_before_press", S.GOING_ON, "leave_unpressed_not_believed")
    assert notes == ["t = 0.000 s: disc_1: operator leaves the disc unpressed (wrist seen 22 deg off again)"]
    assert t.task.k == k + 1 and not t.sent  # past the press: the next taken up is the back-off
    t.fire(S.GOING_ON, "back_off_after_press", S.BACKING_OUT, "back_out_of_press")
    assert t.task.k == k + 2


def looking_not_believed_again(shipped):
    k = first(shipped, "back off")  # 5 cm off: near the string, no press to come
    t = Task(shipped, S.LOOKING, k).sees(True, implausible="wrist seen 22 deg off")
    t.task._stopped_on = [1] * STOPS_PER_DISC
    assert t.fire(S.LOOKING, "not_believed_again", S.GOING_ON) == []
    assert t.task.k == k and not t.sent


def looking_moved(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.LOOKING, k).sees(True)
    assert t.fire(S.LOOKING, "moved", S.MOVING, "go_again") == []
    assert t.standoff_sent_m() == pytest.approx(READY_M, abs=5e-3) and len(t.sent[0][0]) == 1
    assert not t.task.reached[k]


def looking_placed_to_close_in(shipped):
    t = Task(shipped, S.LOOKING, first(shipped, "approach")).sees(False, miss_m=0.005)
    notes = t.fire(S.LOOKING, "placed_to_close_in", S.CLOSING_IN, "close_in")
    assert notes == ["t = 0.000 s: disc_1: operator closes in to 2 cm before the press"]
    assert t.standoff_sent_m() == pytest.approx(TOUCH_STANDOFF_M, abs=5e-3)


def looking_placed(shipped):
    k = first(shipped, "come in")
    t = Task(shipped, S.LOOKING, k).sees(False)
    assert t.fire(S.LOOKING, "placed", S.GOING_ON) == []
    assert t.task.k == k and not t.sent


def closing_in(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.CLOSING_IN, k)
    t.fire(S.CLOSING_IN, "always", S.LOOKING_CLOSE)
    assert t.task.reached[k] and not t.sent


def looking_close_not_believed(shipped):
    t = Task(shipped, S.LOOKING_CLOSE, first(shipped, "approach")).sees(True, implausible="seen 5.0 cm aside")
    t.fire(S.LOOKING_CLOSE, "not_believed", S.RETREATING, "stop_and_retreat")
    assert t.standoff_sent_m() == pytest.approx(CLEAR_M, abs=5e-3) and t.task._stopped_on == [1]


def looking_close_not_believed_again(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.LOOKING_CLOSE, k).sees(True, implausible="seen 5.0 cm aside")
    t.task._stopped_on = [1] * STOPS_PER_DISC
    notes = t.fire(S.LOOKING_CLOSE, "not_believed_again", S.GOING_ON, "leave_unpressed_not_believed")
    assert notes == ["t = 0.000 s: disc_1: operator leaves the disc unpressed (seen 5.0 cm aside again)"]
    assert t.task.k == k + 1


def looking_close_moved(shipped):
    t = Task(shipped, S.LOOKING_CLOSE, first(shipped, "approach")).sees(True)
    assert t.fire(S.LOOKING_CLOSE, "moved", S.CLOSING_IN, "go_again") == []
    assert t.standoff_sent_m() == pytest.approx(TOUCH_STANDOFF_M, abs=5e-3)


def looking_close_placed_off_again(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.LOOKING_CLOSE, k).sees(False, miss_m=0.03)
    t.task._came_in_again = {1}
    notes = t.fire(S.LOOKING_CLOSE, "placed_off_for_press_again", S.GOING_ON, "leave_unpressed_off")
    assert notes == ["t = 0.000 s: disc_1: operator leaves the disc unpressed (seen 3.0 cm off again)"]
    assert t.task.k == k + 1 and not t.sent


def looking_close_placed_off(shipped):
    t = Task(shipped, S.LOOKING_CLOSE, first(shipped, "approach")).sees(False, miss_m=0.03)
    notes = t.fire(S.LOOKING_CLOSE, "placed_off_for_press", S.MOVING, "come_in_again")
    assert notes == ["t = 0.000 s: disc_1: operator backs off to 5 cm and comes in again (seen 3.0 cm off)"]
    assert t.standoff_sent_m() == pytest.approx(READY_M, abs=5e-3) and t.task._came_in_again == {1}


def looking_close_placed(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.LOOKING_CLOSE, k).sees(False, miss_m=0.015)  # within PRESS_MISS_M
    assert t.fire(S.LOOKING_CLOSE, "placed", S.GOING_ON) == []
    t.fire(S.GOING_ON, "always", S.MOVING, "next_target")  # the press, as planned
    assert t.task.k == k + 1 and t.standoff_sent_m() == pytest.approx(-PRESS_M, abs=5e-3)


def retreating(shipped):
    k = first(shipped, "approach")
    t = Task(shipped, S.RETREATING, k)
    t.fire(S.RETREATING, "always", S.MOVING, "come_in_after_retreat")
    assert t.standoff_sent_m() == pytest.approx(READY_M, abs=5e-3) and t.sent[0][1][-1] == 0.0


def looking_at_press_off(shipped):
    t = Task(shipped, S.LOOKING_AT_PRESS, first(shipped, "press")).sees(True)
    notes = t.fire(S.LOOKING_AT_PRESS, "press_off", S.OUT_TO_PRESS_AGAIN, "back_out_to_press_again")
    assert notes == ["t = 0.000 s: disc_1: operator backs out to 2 cm to press again"]
    assert t.standoff_sent_m() == pytest.approx(TOUCH_STANDOFF_M, abs=5e-3)


def looking_at_press_last_pose(shipped):
    """A plan ending pressed (cut after disc 1's press): he looks at the pose the arm is left in."""
    k = first(shipped, "press")
    t = Task(shipped, S.LOOKING_AT_PRESS, k, last=k).sees(False)
    t.fire(S.LOOKING_AT_PRESS, "pressed_at_last_pose", S.LOOKING)
    t.fire(S.LOOKING, "placed", S.GOING_ON)
    t.fire(S.GOING_ON, "plan_done", S.FINISHED, "finish")


def looking_at_press_placed(shipped):
    k = first(shipped, "press")
    t = Task(shipped, S.LOOKING_AT_PRESS, k).sees(False)
    assert t.fire(S.LOOKING_AT_PRESS, "placed", S.GOING_ON) == []
    assert t.task.k == k and not t.sent


def out_to_press_again(shipped):
    k = first(shipped, "press")
    t = Task(shipped, S.OUT_TO_PRESS_AGAIN, k)
    t.fire(S.OUT_TO_PRESS_AGAIN, "always", S.MOVING, "press_again")
    assert t.standoff_sent_m() == pytest.approx(-PRESS_M, abs=5e-3)
    assert t.sent[0][1] == [shipped[0].targets[k].dwell_s]  # held pressed for the plan's dwell


def backing_out(shipped):
    k = first(shipped, "back off")
    t = Task(shipped, S.BACKING_OUT, k, at=k - 1)  # from the press
    t.fire(S.BACKING_OUT, "always", S.MOVING, "back_off_as_planned")
    assert t.standoff_sent_m() == pytest.approx(READY_M, abs=5e-3)
    steps = t.sent[0][0]
    assert len(steps) == 2 and set(steps[0]) < set(steps[1])  # out of the rim first, then the rest


def stop_drive(shipped):
    t = Task(shipped, S.MOVING, first(shipped, "back off"), strategy="rereference")
    t.fire(S.MOVING, "stop_to_drive_into", S.STOP_DRIVE, "start_stop_drive")
    stop = t.task._stop
    t.task._stop = replace(stop, drive_until_s=T_S - 0.3, settle_until_s=T_S)  # settled by now
    commands = t.task.tick(t.plant.sensors())
    assert t.task.state is S.GOING_ON and not commands.any()
    assert t.platform.predicted_angles()[stop.joint] == stop.stop_rad
    assert t.task._notes[-1].startswith("t = 0.000 s: shoulder_pitch re-referenced at its stop")


CASES = {
    (S.START, "always"): start,
    (S.GOING_ON, "plan_done"): going_on_plan_done,
    (S.GOING_ON, "back_off_after_press"): going_on_back_off_after_press,
    (S.GOING_ON, "always"): going_on_always,
    (S.MOVING, "press_to_look_at"): moving_press,
    (S.MOVING, "pose_to_look_at"): lambda shipped: (moving_pose(shipped), moving_pose_before_the_turn_back(shipped)),
    (S.MOVING, "stop_to_drive_into"): moving_stop,
    (S.MOVING, "always"): moving_always,
    (S.LOOKING, "seen_on_the_rim"): looking_seen_on_the_rim,
    (S.DRAWING_OUT, "always"): drawing_out,
    (S.LOOKING, "not_believed_clear_of_string"): looking_not_believed_clear_of_string,
    (S.LOOKING, "not_believed"): looking_not_believed,
    (S.LOOKING, "not_believed_again_before_press"): looking_not_believed_again_before_press,
    (S.LOOKING, "not_believed_again"): looking_not_believed_again,
    (S.LOOKING, "moved"): looking_moved,
    (S.LOOKING, "placed_to_close_in"): looking_placed_to_close_in,
    (S.LOOKING, "placed"): looking_placed,
    (S.CLOSING_IN, "always"): closing_in,
    (S.LOOKING_CLOSE, "not_believed"): looking_close_not_believed,
    (S.LOOKING_CLOSE, "not_believed_again"): looking_close_not_believed_again,
    (S.LOOKING_CLOSE, "moved"): looking_close_moved,
    (S.LOOKING_CLOSE, "placed_off_for_press_again"): looking_close_placed_off_again,
    (S.LOOKING_CLOSE, "placed_off_for_press"): looking_close_placed_off,
    (S.LOOKING_CLOSE, "placed"): looking_close_placed,
    (S.RETREATING, "always"): retreating,
    (S.LOOKING_AT_PRESS, "press_off"): looking_at_press_off,
    (S.LOOKING_AT_PRESS, "pressed_at_last_pose"): looking_at_press_last_pose,
    (S.LOOKING_AT_PRESS, "placed"): looking_at_press_placed,
    (S.OUT_TO_PRESS_AGAIN, "always"): out_to_press_again,
    (S.BACKING_OUT, "always"): backing_out,
    (S.STOP_DRIVE, "stop_settled"): stop_drive,
}


@pytest.mark.parametrize("row", list(CASES), ids=[f"{s.name}-{w}" for s, w in CASES])
def test_each_transition_moves_to_its_state_with_its_action(shipped, row):
    CASES[row](shipped)


def test_every_row_of_the_table_has_its_case():
    rows = [(r.source, name_of(r.when)) for r in TRANSITIONS]
    assert len(set(rows)) == len(rows)  # a state's conditions are named apart
    assert set(rows) == set(CASES)


def test_no_dead_state():
    """Every state is reachable from the start, and the end from every state."""
    assert reachable(TRANSITIONS) == set(TaskState)
    assert all(S.FINISHED in reachable(TRANSITIONS, s) for s in TaskState)


def test_a_look_not_yet_seen_leaves_the_task_where_it_is(shipped):
    """His picture not seen yet (no frame after the arm came to rest): no row is taken; the task
    waits, and the compiled ticks may run until he can have seen one."""
    t = Task(shipped, S.MOVING, first(shipped, "approach"))
    t.fire(S.MOVING, "pose_to_look_at", S.LOOKING)
    assert t.task.fire(T_S) is None and t.task.state is S.LOOKING and not t.sent  # the real look: no frame yet
    t.sees(None)
    assert t.task.fire(T_S) is None and t.task.state is S.LOOKING


def test_the_docs_show_the_table_as_the_code_has_it():
    text = (ROOT / "docs" / "task_states.md").read_text()
    missing = [line for line in as_text(TRANSITIONS) if line not in text]
    assert not missing, missing
