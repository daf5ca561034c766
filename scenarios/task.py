"""The task on top of the platform's controller: a scenario's targets fed one at a time, each one's
finish noted, and a strategy that may act between them (scenario field `control.strategy`).

    sensorless   the predictor alone (the paper's platform as it is)
    rereference  after the back-off from each disc, the shoulder is driven open loop into its upper
                 end stop (the MJCF's range, a stop the platform knows) and its predicted angle set
                 to it; only where the elbow stays in its range with the shoulder there (the string's
                 upper discs), since the parallelogram keeps the forearm's pitch
    operator     the operator corrects the brush's aim by the global camera (scenarios/operator.py),
                 closes in to TOUCH_STANDOFF_M and looks again before each press, looks at the
                 press (the head's stroke) and, where it is off, backs out to TOUCH_STANDOFF_M and
                 presses again by what he saw, backs out to
                 TOUCH_STANDOFF_M (wrist held, out of the rim first) before the plan's back-off; he also
                 clears the platform's faults (a move not finished in time) and goes on
    true_angle   a bound, not a way to run the arm: the same controller handed the plant's true
                 angles every tick (it breaks the sensorless rule on purpose)

Whatever the strategy, the platform's load model is told the rim each disc target works at (the
plan's, moved by the operator's aim), so that its predictor meets the head spring's reaction where
the true arm does (ArmController.expect_press).

The task is a state machine (scenarios/task_states.py, drawn in docs/task_states.md): its state
(`TaskController.state`: moving to a target, closing in, the operator looking, backing out of a
press, ...) and the target under way (`k`); each state's behaviour (`BEHAVIOURS`: a move's arrival
noted, a look taken) and the rows of `TRANSITIONS` (from-state, condition, to-state, action), each
a small method. The task is asked at each tick the platform is at rest (done, not faulted), and
takes the transitions due then one after another while the arm stays at rest.

The task controller is what the run loop ticks (twin/sim.py's Controller protocol). It hands the
platform's controller only the sensors; the operator sees only the camera's frames; the bound alone
reads the plant.
"""

from __future__ import annotations

import contextlib
import logging
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from control import ArmController, MotionRefused
from pneumatics.joint import C_BRAKE_RELEASE, C_DIRECTION, C_PV_SET_GAUGE_PA
from scenarios.ik import carrier_m, drive_to_qpos, joint_out_of_range, rim_target, tool_drive_angles
from scenarios.operator import GlobalCamera, Operator
from scenarios.plan import CLEAR_M, TOUCH_STANDOFF_M
from scenarios.schema import Scenario
from scenarios.string import Disc, believed_discs
from scenarios.task_states import AT_REST, TaskState, Transition, name_of, rows_from
from twin.plant import Plant

log = logging.getLogger(__name__)

STOP_JOINT = "shoulder_pitch"  # the joint whose error grows (docs/validation/predictor_and_control.md)
STOP_DRIVE_S = 1.0  # open-loop drive into the stop: this long ...
STOP_DRIVE_S_PER_RAD = (
    6.0  # ... plus this per rad to go (the shoulder turns ~10 deg/s at 0.5 MPa, measured in the cleaning run)
)
STOP_SETTLE_S = 0.3  # brake applied before the angle is taken (brake engagement ~0.1 s, assets/joints)
ELBOW_MARGIN_RAD = math.radians(5.0)  # keep the elbow this far inside its range at the stop
# he presses from touching distance only if he saw the face within this of where it should stand (m):
# the head's 25 mm press then stays inside its 50 mm stroke, and the face's edge (45 mm radius) on the
# rim (10 mm half-thickness) with room for the press's own error
PRESS_MISS_M = 0.02
# how many times a disc he stops at a look he does not believe and comes in again from clear of the
# string before he leaves it unpressed: a coarse picture (160x120, a pixel 2.5 cm at the string)
# misreads a joint by a few degrees more often than once a disc, and each time costs ~4 s
STOPS_PER_DISC = 2
# the base yaw within which he reads the arm's pitches off the global view (its plane is the arm's at
# yaw 0): at 15 deg a 45 deg pitch is read 1 deg steep (tan scaled by 1/cos 15 deg)
READABLE_YAW_RAD = math.radians(15.0)


def scenario_camera(scenario: Scenario, plant: Plant) -> GlobalCamera:
    """The operator's cameras in the scene, as sharp as [reality] makes them (the same pictures of
    the string each time it is built)."""
    return GlobalCamera(plant.model, plant.data, scenario.operator, scenario.reality.camera_noise_px, scenario.seed)


def platform_string(scenario: Scenario, plant: Plant) -> list[Disc]:
    """The string as the platform sees it: the operator finds it in his camera's picture
    (scenarios/sighting.py); without him, the platform knows only where the scene file puts it."""
    if scenario.control.strategy == "operator":
        return scenario_camera(scenario, plant).sight_string().discs
    return list(believed_discs())


@dataclass
class _StopDrive:
    """An open-loop drive of one joint into its stop, then a settle with the brake on."""

    joint: int
    stop_rad: float
    drive_until_s: float
    settle_until_s: float


class TaskController:
    """Feeds `targets` (drive angles per scenario target) to `controller` one by one, as the state
    machine TRANSITIONS says (docs/task_states.md): `state` is where the task stands, `k` the target
    under way."""

    def __init__(
        self,
        controller: ArmController,
        scenario: Scenario,
        plant: Plant,
        targets: list[dict[str, float]],
        rng: np.random.Generator,
        discs: list[Disc] | None = None,
    ):
        self.controller, self.scenario = controller, scenario
        self.targets = targets
        self.issued: list[dict[str, float]] = [dict(t) for t in targets]  # as sent (with the operator's aim)
        self.reached: list[bool] = [False] * len(targets)
        self.finished_s: list[float] = [math.nan] * len(targets)
        self.k = -1  # the target under way
        self.state = TaskState.START
        self.strategy = scenario.control.strategy
        self.model = plant.model
        # the string the plan was made for, as the platform sees it (the operator's sighting, or the
        # scene file's string): where the task places the brush and expects the rim's reaction
        self.discs = list(discs) if discs is not None else platform_string(scenario, plant)
        self._plant = plant if self.strategy == "true_angle" else None  # the bound's only window on the truth
        self.camera = scenario_camera(scenario, plant) if self.strategy == "operator" else None
        self.operator = Operator(plant.model, self.camera, scenario.operator, rng) if self.camera else None
        self._review_from_s = math.nan  # when the arm came to rest at target k: his look is of a picture after it
        self._seen: bool | None = None  # the verdict of his latest look (Operator.review, review_press)
        self._why = ""  # ... and why he does not believe it ('': he does)
        self._came_in_again: set[int] = set()  # discs on which he backed off from touching distance once
        self._stopped_on: list[int] = []  # the disc of each time he stopped and backed off to CLEAR_M
        self._stop: _StopDrive | None = None  # the stop drive under way (STOP_DRIVE)
        self._notes: list[str] = []
        self._commands = np.zeros_like(controller.commands)
        self._kinematics = mujoco.MjData(plant.model)  # scratch: where a move would take the brush
        self._camera_compiled = False  # the run loop's compiled ticks take the camera's frames (`compiled_camera`)
        self._notes.extend(self._out_of_reach())

    def _out_of_reach(self) -> list[str]:
        """What he says of the discs of the string he found that the plan leaves out: out of the arm's
        reach from where the platform stands (scenarios/plan.py), so not cleaned."""
        pressed = {t.brush_at_disc for t in self.scenario.targets if t.brush_at_disc and t.standoff_m < 0}
        if not pressed:
            return []
        return [
            f"t = 0.000 s: disc_{k}: out of the arm's reach from where the platform stands: not cleaned"
            for k in range(1, len(self.discs) + 1)
            if k not in pressed
        ]

    # -- Controller protocol -------------------------------------------------------------------
    def tick(self, sensors) -> np.ndarray:
        t = float(sensors.time_s)
        if self._plant is not None:
            # the angle only: the speed stays the predictor's, whose stick is an exact 0 the arrival
            # logic waits for (MuJoCo's braked joint creeps at ~1e-6 rad/s)
            for j, q, w in zip(
                self.controller.joints, self._plant.drive_angles(), self.controller.predicted_speeds(), strict=True
            ):
                self.controller.reference(j, q, w)
        if self.camera is not None:
            self.camera.capture(t)
        if self.state is not TaskState.STOP_DRIVE:
            if self._fault_to_clear():
                # the operator sees the fault (a move that did not end in time, a refusal), clears it and
                # goes on from where the arm is: the camera tells him whether the brush is where it must be
                self.controller.clear_fault()
            if self._platform_at_rest():
                self._decide(t)
        if self.state is TaskState.STOP_DRIVE:
            return self._drive_into_stop(sensors)
        return self.controller.tick(sensors)

    def _fault_to_clear(self) -> bool:
        """A fault of the platform's that the operator clears: he is there and a target is under way."""
        return (
            self.controller.faulted
            and self.operator is not None
            and self.state not in (TaskState.START, TaskState.FINISHED)
        )

    def _platform_at_rest(self) -> bool:
        """The platform done with what it was sent (not faulted), targets still to come: the task's turn."""
        c = self.controller
        return c.done and not c.faulted and self.state is not TaskState.FINISHED

    def compiled_ticks(self, time_s: float) -> tuple[ArmController | None, float]:
        """(the platform's controller, until when) where the coming ticks would only tick it, as
        `tick` does when nothing is due: no bound reading the plant, no stop drive, no fault for the
        operator to clear, no target to take up (or the operator still waiting for a picture of
        the arm at rest); until the camera's next frame, unless the compiled ticks take its frames
        (`compiled_camera`); while the operator waits for a picture, until he can have seen one.
        (None, ...): `tick` must run (twin/compiled_loop.py)."""
        c = self.controller
        if self._plant is not None or self.state is TaskState.STOP_DRIVE or self._fault_to_clear():
            return None, time_s
        until = math.inf
        if self.camera is not None and not self._camera_compiled:
            until = self.camera.next_frame_s
        if self._platform_at_rest():
            # waiting for the operator's picture: until he can have seen one (the frames are taken
            # in compiled code meanwhile; when they are not, `until` stops at each already)
            until = min(until, self._waiting_until(time_s))
        return c, until

    def compiled_camera(self) -> tuple | None:
        """The camera's `compiled_state` (twin/camera_frames.py), for compiled ticks that take its
        frames from now on (`compiled_ticks` then no longer stops at each frame); None: no camera."""
        if self.camera is None:
            return None
        self._camera_compiled = True
        return self.camera.compiled_state()

    def _waiting_until(self, time_s: float) -> float:
        """Until when the task, the platform at rest, only waits for the operator's picture of the
        arm (`time_s`: it does more now)."""
        if self.state not in LOOKS:
            return time_s
        return self.operator.review_due_s(self._review_from_s)

    def predicted_angles(self) -> np.ndarray:
        return self.controller.predicted_angles()

    def target_angles(self) -> np.ndarray:
        return self.controller.target_angles()

    def event_lists(self) -> list[tuple[str, list[str]]]:
        """The report lists and who made them (twin.events): the platform's, and the operator's
        (his corrections as the task notes them, and his looks)."""
        lists = [("controller", self.controller.events), ("operator", self._notes)]
        return lists + ([("operator", self.operator.log)] if self.operator else [])

    @property
    def events(self) -> list[str]:
        """The platform's events, the re-references and the operator's looks, in time order."""
        merged = self.controller.events + self._notes + (self.operator.log if self.operator else [])
        return sorted(merged, key=_event_time)

    # -- the state machine ---------------------------------------------------------------------
    def _decide(self, t: float) -> None:
        """The platform at rest: take the transitions due now (one after another while the arm is
        at rest, `AT_REST`), until a move is sent or the task waits for a picture."""
        while self.fire(t) and self.state in AT_REST:
            pass

    def fire(self, t: float) -> Transition | None:
        """Do what the state does when asked (`BEHAVIOURS`), then take its first row whose condition
        holds; the row taken (None: none holds, the task stays)."""
        behaviour = BEHAVIOURS.get(self.state)
        if behaviour is not None:
            behaviour(self, t)
        for row in ROWS[self.state]:
            if row.when(self, t):
                log.debug(
                    "t = %.3f s: target %d: %s -> %s (%s; %s)",
                    t,
                    self.k,
                    row.source.name,
                    row.target.name,
                    name_of(row.when),
                    name_of(row.action),
                )
                self.state = row.target
                if row.action is not None:
                    row.action(self, t)
                return row
        return None

    # what a state does when asked
    def _arrive(self, t: float) -> None:
        """The platform has finished the move to target k: noted, and his look is of a picture after now."""
        self.reached[self.k] = True
        self.finished_s[self.k] = t
        self._review_from_s = t

    def _look(self, t: float) -> None:
        """He looks wherever the brush stands clear of a disc (not only before a press: a drift left
        until the next press has by then rammed a disc on the way), at the plan's last pose, and
        before the plan's last turn back from aside of the string (`_is_before_swing_back`)."""
        if self._is_before_swing_back(self.k):
            yaw_to = self.targets[self.k + 1]["base_yaw"]
            self._seen = self.operator.review_swing(t, self._review_from_s, self.controller, yaw_to)
            self._why = ""
            return
        target = self.scenario.targets[self.k]
        self._seen = self.operator.review(
            t,
            self._review_from_s,
            target.brush_at_disc,
            self._standoff_m(self.k) if target.brush_at_disc else math.inf,
            self.controller,
            aim=self._is_approach(self.k),
        )
        self._why = self.operator.implausible if self._seen is not None else ""

    def _look_at_press(self, t: float) -> None:
        """He looks at the press as he looks at every standoff (the head's stroke)."""
        target = self.scenario.targets[self.k]
        self._seen = self.operator.review_press(t, self._review_from_s, target.brush_at_disc, -target.standoff_m)
        self._why = ""

    # conditions
    def _always(self, t: float) -> bool:
        return True

    def _plan_done(self, t: float) -> bool:
        """No target after k."""
        return self.k + 1 >= len(self.targets)

    def _back_off_after_press(self, t: float) -> bool:
        """The next target is the plan's back-off from a press, with the operator: he backs out of the
        press the way he went in, to touching distance with the wrist held, first (the back-off whole,
        7.5 cm, a 16 deg shoulder and 9 deg elbow move at disc 1, let the faster elbow swing the brush
        back onto the rim on the way out: 57 N, as-built, 0.6 MPa)."""
        return self.operator is not None and self._is_back_off(self.k + 1)

    def _press_to_look_at(self, t: float) -> bool:
        return self.operator is not None and self._is_press(self.k)

    def _pose_to_look_at(self, t: float) -> bool:
        return self.operator is not None and self._is_looked_at(self.k)

    def _stop_to_drive_into(self, t: float) -> bool:
        """Rereference, after the back-off from a disc, where the elbow stays in its range with the
        shoulder at its upper stop (the parallelogram holds the forearm's pitch while it turns)."""
        if self.strategy != "rereference" or not self._is_back_off(self.k):
            return False
        c = self.controller
        i, e = c.joints.index(STOP_JOINT), c.joints.index("elbow_pitch")
        elbow_relative = c.predicted_angles()[e] - float(c.arm.joint_upper[i])
        return elbow_relative >= c.arm.joint_lower[e] + ELBOW_MARGIN_RAD

    def _stop_settled(self, t: float) -> bool:
        return t >= self._stop.settle_until_s

    def _seen_on_the_rim(self, t: float) -> bool:
        """His look saw the brush on its disc's rim where target k holds it clear (`Operator.on_rim`,
        up to DRAW_OUTS_PER_DISC times a disc): he draws it straight out before anything else."""
        return bool(self._seen and self.operator.on_rim)

    def _not_believed_clear_of_string(self, t: float) -> bool:
        """A look he does not believe (`Operator.implausible`) with the brush off the string or
        already clear of it: he goes to the target again from where it is."""
        disc = self.scenario.targets[self.k].brush_at_disc
        return bool(self._why) and (not disc or self._standoff_m(self.k) >= CLEAR_M)

    def _not_believed(self, t: float) -> bool:
        """A look he does not believe, near the string, up to STOPS_PER_DISC times on a disc: he backs
        off to CLEAR_M and comes in again, looking at each standoff."""
        disc = self.scenario.targets[self.k].brush_at_disc
        return bool(self._why) and self._stopped_on.count(disc) < STOPS_PER_DISC

    def _not_believed_again_before_press(self, t: float) -> bool:
        """A look he does not believe once more than STOPS_PER_DISC on a disc, a press to come: he
        leaves the disc unpressed."""
        return bool(self._why) and self._is_approach(self.k)

    def _not_believed_again(self, t: float) -> bool:
        """... no press to come: he goes on."""
        return bool(self._why)

    def _moved(self, t: float) -> bool:
        """He reset the platform's belief or moved his aim: the arm is sent there again."""
        return self._seen is True

    def _placed(self, t: float) -> bool:
        """Close enough (or out of looks)."""
        return self._seen is False

    def _placed_to_close_in(self, t: float) -> bool:
        """Placed at an approach further off the rim than TOUCH_STANDOFF_M: he closes in and looks again."""
        return self._seen is False and self._is_approach(self.k) and self._plan_standoff_m() > TOUCH_STANDOFF_M

    def _placed_off_for_press(self, t: float) -> bool:
        """Out of looks at touching distance with the brush further off than the press can take
        (PRESS_MISS_M): he backs off to the plan's standoff and comes in again, once per disc (a press
        aimed by a last look 3.3 cm off rammed disc 8 with 408 N, 0.8 MPa)."""
        return self._seen is False and self.operator.last_miss_m > PRESS_MISS_M

    def _placed_off_for_press_again(self, t: float) -> bool:
        """... a second time on the disc: he leaves it unpressed."""
        disc = self.scenario.targets[self.k].brush_at_disc
        return self._placed_off_for_press(t) and disc in self._came_in_again

    def _press_off(self, t: float) -> bool:
        """The press seen off by more than his tolerance: he presses again."""
        return self._seen is True

    def _pressed_at_last_pose(self, t: float) -> bool:
        """Pressed as planned at the plan's last target, where he looks at the pose the arm is left in."""
        return self._seen is False and self._pose_to_look_at(t)

    # actions
    def _next_target(self, t: float) -> None:
        """The next target; from one disc to the next with the brush nearer the string than the
        clearance, out of the rim first (`_disc_to_disc_near_the_string`)."""
        self.k += 1
        self._send(self.scenario.targets[self.k].dwell_s, pressed=self._disc_to_disc_near_the_string(self.k))

    def _disc_to_disc_near_the_string(self, k: int) -> bool:
        """Target k is on another disc than target k - 1, which held the brush nearer the string than
        the clearance (CLEAR_M: the plan brings a clearance in where the arm does not reach it, 4 cm
        at disc 3 with the string 10 cm closer). All joints together, the faster leads: from disc 3's
        4 cm down to disc 4 the elbow's drop (22 to 7 deg) came first and dragged the head's face,
        tilted 45 deg down, over disc 3's upper rim corner (56-78 N, 7 runs in 10); the joints whose
        own turn draws the brush out of the rim first, then the others (`_out_of_the_rim_first`)."""
        ts = self.scenario.targets
        return bool(
            k >= 1
            and ts[k].brush_at_disc
            and ts[k - 1].brush_at_disc
            and ts[k].brush_at_disc != ts[k - 1].brush_at_disc
            and 0 < ts[k - 1].standoff_m < CLEAR_M
        )

    def _back_out_of_press(self, t: float) -> None:
        self.k += 1
        disc = self.scenario.targets[self.k].brush_at_disc
        self._notes.append(
            f"t = {t:.3f} s: disc_{disc}: operator backs out to {TOUCH_STANDOFF_M * 100:.0f} cm, wrist held"
        )
        self._send(self.scenario.targets[self.k].dwell_s, pressed=True)

    def _finish(self, t: float) -> None:
        self.k += 1

    def _back_off_as_planned(self, t: float) -> None:
        """Out of the press to touching distance: now the plan's back-off, out of the rim first too (2 cm
        off it, joints turning one after another swung the brush back onto disc 1's rim at 153 N under a
        slightly different integration of the air, as-built, 0.6 MPa)."""
        self._send(0.0, pressed=True)

    def _go_again(self, t: float) -> None:
        self._send(0.0)

    def _close_in(self, t: float) -> None:
        disc = self.scenario.targets[self.k].brush_at_disc
        self._notes.append(
            f"t = {t:.3f} s: disc_{disc}: operator closes in to {TOUCH_STANDOFF_M * 100:.0f} cm before the press"
        )
        self._send(0.0)

    def _come_in_again(self, t: float) -> None:
        disc, standoff = self.scenario.targets[self.k].brush_at_disc, self._plan_standoff_m()
        self._came_in_again.add(disc)
        self._notes.append(
            f"t = {t:.3f} s: disc_{disc}: operator backs off to {standoff * 100:.0f} cm "
            f"and comes in again (seen {self.operator.last_miss_m * 100:.1f} cm off)"
        )
        self._send(0.0)

    def _leave_unpressed_off(self, t: float) -> None:
        disc = self.scenario.targets[self.k].brush_at_disc
        self._notes.append(
            f"t = {t:.3f} s: disc_{disc}: operator leaves the disc unpressed "
            f"(seen {self.operator.last_miss_m * 100:.1f} cm off again)"
        )
        self.k += 1  # past the press

    def _stop_and_go_again(self, t: float) -> None:
        disc = self.scenario.targets[self.k].brush_at_disc
        self._notes.append(f"t = {t:.3f} s: disc_{disc}: operator stops ({self._why}), clear of the string")
        self._send(0.0)

    def _stop_and_retreat(self, t: float) -> None:
        """Backing off from a look he does not believe: the joints that draw the brush out of the rim
        first (the elbow's drop that the look asks for, with the others, brought the head down on the
        rim's edge from 5 cm off it)."""
        disc = self.scenario.targets[self.k].brush_at_disc
        self._stopped_on.append(disc)
        self._notes.append(
            f"t = {t:.3f} s: disc_{disc}: operator stops ({self._why}), backs off to {CLEAR_M * 100:.0f} cm "
            "and comes in again to look afresh"
        )
        self._send(0.0, pressed=True)

    def _draw_out(self, t: float) -> None:
        """The brush seen on the rim where it should stand clear: he draws it straight out along the
        rim's normal by what he saw (`Operator.draw_out_m`), the tool's pitch kept, from the pose he
        has just set the platform's belief to. Only the move out is asked of the arm (shoulder, elbow,
        wrist by the arm's kinematics at the believed pose: a belief a few degrees off moves it out
        all the same), so the head leaves the rim along its normal instead of being dragged over its
        edge by the whole pose sent again; at rest he looks again. Out of reach: the target as planned."""
        disc = self.scenario.targets[self.k].brush_at_disc
        _, normal = self.discs[disc - 1].rim_facing()
        here = dict(zip(self.controller.joints, self.controller.predicted_angles().tolist(), strict=True))
        out = self.operator.draw_out_m
        try:
            drive = tool_drive_angles(
                self.model, carrier_m(self.model, here) + out * normal, here["elbow_pitch"] + here["wrist_pitch"]
            )
            target = {j: drive[j] for j in ("shoulder_pitch", "elbow_pitch", "wrist_pitch")}
        except ValueError:
            target = None
        if target is None or joint_out_of_range(self.model, drive_to_qpos({**here, **target})):
            target = self._aimed(self.k)
        self._notes.append(f"t = {t:.3f} s: disc_{disc}: operator draws the brush {out * 100:.1f} cm straight out")
        self._send(0.0, pressed=True, target=target)

    def _come_in_after_retreat(self, t: float) -> None:
        """Backed off from a look he did not believe: in again, to look afresh."""
        self._send(0.0, pressed=True)

    def _leave_unpressed_not_believed(self, t: float) -> None:
        disc = self.scenario.targets[self.k].brush_at_disc
        self._notes.append(f"t = {t:.3f} s: disc_{disc}: operator leaves the disc unpressed ({self._why} again)")
        self.k += 1  # past the press

    def _back_out_to_press_again(self, t: float) -> None:
        """The press seen off: he backs out to touching distance (out of the rim first, wrist held) and
        presses again from there: a corrected press made from inside the first one (shoulder and elbow
        together, the brush on the rim) can lift the head off and swing its side onto the disc's rim
        (682 N seen on disc 1, as-built arm at 0.5 MPa)."""
        disc = self.scenario.targets[self.k].brush_at_disc
        self._notes.append(
            f"t = {t:.3f} s: disc_{disc}: operator backs out to {TOUCH_STANDOFF_M * 100:.0f} cm to press again"
        )
        self._send(0.0, pressed=True)

    def _press_again(self, t: float) -> None:
        """Out of the press to touching distance: the press again, by what he saw, as the first one."""
        self._send(self.scenario.targets[self.k].dwell_s)

    def _send(self, dwell_s: float, pressed: bool = False, target: dict[str, float] | None = None) -> None:
        """Send target k (as the state the task is in places it: `_standoff_m`; or `target`, drive
        angles in its stead), not reached until the platform says so; `pressed`: the brush is in a
        press or at touching distance from the rim now (see `_out_of_the_rim_first`)."""
        k = self.k
        target = self._aimed(k) if target is None else target
        self.issued[k] = target
        self.reached[k] = False
        self.controller.expect_press(*self._expected_surface(k))
        steps = self._out_of_the_rim_first(target) if pressed else [target]
        try:
            self.controller.set_targets(
                steps,
                sequence=self.scenario.control.sequence,
                dwell_s=[0.0] * (len(steps) - 1) + [dwell_s],
            )
        except MotionRefused:
            # the controller noted it; the arm stays braked and the task goes on with the next target
            # (the operator takes back the aim that was refused: the arm did not move)
            if self.operator is not None:
                self.operator.take_back()

    def _out_of_the_rim_first(self, target: dict[str, float]) -> list[dict[str, float]]:
        """A move that starts with the brush pressed into a rim (or at touching distance from it), in
        two steps: first the joints whose own turn draws the brush out of the rim (along its
        normal), then the others. Turning together, the faster joint leads: out of disc 1's press
        the elbow's turn, which alone pushes the brush in, pushed the head to 35 mm (51 N) and, in a
        1 cm shallower press, to 47 mm (47 N) before the shoulder drew it out (as-built, 0.52 MPa).
        The brush then goes no deeper than where it starts or ends."""
        here = dict(zip(self.controller.joints, self.controller.predicted_angles().tolist(), strict=True))
        _, normal = self.discs[self.scenario.targets[self.k].brush_at_disc - 1].rim_facing()
        start = self._tip_m(here) @ normal
        out = {j: q for j, q in target.items() if self._tip_m({**here, j: q}) @ normal > start}
        if not out or len(out) == len(target):
            return [target]
        return [out, target]

    def _tip_m(self, drive: dict[str, float]) -> np.ndarray:
        """Where the brush's tip stands (world) at these drive angles: the scene's kinematics."""
        d = self._kinematics
        for joint, q in drive_to_qpos(drive).items():
            d.joint(joint).qpos[0] = q
        mujoco.mj_kinematics(self.model, d)
        return d.site("brush_tip").xpos.copy()

    def _expected_surface(self, k: int) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The rim target k works at, as the platform's load model should expect it (the plan's
        rim, moved by the operator's aim: where he has placed it in the platform's belief), and
        its normal towards the arm; (None, None) for a target off the string."""
        disc = self.scenario.targets[k].brush_at_disc
        if not disc:
            return None, None
        surface = rim_target(self.discs[disc - 1], 0.0)
        _, normal = self.discs[disc - 1].rim_facing()
        if self.operator is not None:
            surface = surface + self.operator.aim_offset_m
        return surface, normal

    def _standoff_m(self, k: int) -> float:
        """Where target k holds the brush's face off its disc's rim in the state the task is in: at
        touching distance closing in, backing out of a press or out to press again; clear of the
        string retreating; else the plan's."""
        if self.state is TaskState.RETREATING:
            return max(self.scenario.targets[k].standoff_m, CLEAR_M)
        if self.state in AT_TOUCHING_DISTANCE:
            return TOUCH_STANDOFF_M
        return self.scenario.targets[k].standoff_m

    def _plan_standoff_m(self) -> float:
        return self.scenario.targets[self.k].standoff_m

    def _aimed(self, k: int) -> dict[str, float]:
        """Target k as sent: the plan's, aimed by the operator where he looks (a joint he left where
        it stands kept there, `Operator.hold`)."""
        aimed = self._aimed_plan(k)
        return self.operator.hold(aimed) if self.operator is not None else aimed

    def _aimed_plan(self, k: int) -> dict[str, float]:
        t = self.scenario.targets[k]
        nominal = self.targets[k]
        if self.operator is not None and k == len(self.targets) - 1 and not t.brush_at_disc:
            # the plan's last target with the operator: the whole pose the plan leaves the arm in
            # (each joint's latest target), so that what he corrects at his look there is moved back
            return {j: q for target in self.targets for j, q in target.items()}
        if self.operator is None or not t.brush_at_disc:
            return dict(nominal)
        standoff = self._standoff_m(k)
        tilt = self._press_tilt(k)
        tip = rim_target(self.discs[t.brush_at_disc - 1], standoff)
        if standoff <= TOUCH_STANDOFF_M:  # at touching distance (his corrections there) and the press
            wrist = float(self.controller.predicted_angles()[self.controller.joints.index("wrist_pitch")])
            with contextlib.suppress(ValueError):  # out of reach with the wrist where it is: the full aim
                held = {j: q for j, q in nominal.items() if j != "wrist_pitch"}
                return {**held, **self.operator.pressed(tip, wrist, tilt), **t.angles_deg}
        try:
            return {
                **nominal,
                **self.operator.aimed(tip, tilt),
                **t.angles_deg,
            }
        except ValueError:
            return dict(nominal)  # the aim is out of reach: go where the plan says

    def _press_tilt(self, k: int) -> float:
        """The tool's absolute pitch (elbow + wrist drive, the parallelogram) of the plan's press on
        target k's disc, for every target on that disc: the operator sets the brush's tilt while it is
        well clear and comes in along the tool's axis (a tilt changed at the rim, 10-17 deg of wrist at
        disc 1 for a 1.4 cm correction, swung the head's side under the rim: 218 N). The target's own
        tilt where its disc has no press."""
        ts = self.scenario.targets
        disc = ts[k].brush_at_disc
        press = min(
            (i for i in range(len(ts)) if ts[i].brush_at_disc == disc and self._is_press(i)),
            key=lambda i: abs(i - k),
            default=k,
        )
        plan = self.targets[press]
        return plan["elbow_pitch"] + plan["wrist_pitch"]

    def _is_approach(self, k: int) -> bool:
        """A target standing off a disc, followed by a press on the same disc."""
        ts = self.scenario.targets
        return bool(
            ts[k].brush_at_disc
            and ts[k].standoff_m > 0
            and k + 1 < len(ts)
            and ts[k + 1].brush_at_disc == ts[k].brush_at_disc
            and ts[k + 1].standoff_m < 0
        )

    def _is_press(self, k: int) -> bool:
        """A target pressing the brush into a disc's rim."""
        t = self.scenario.targets[k]
        return bool(t.brush_at_disc and t.standoff_m < 0)

    def _is_looked_at(self, k: int) -> bool:
        """A target the operator looks at the arm after: every one holding the brush clear of a disc,
        and the plan's last (the pose the arm is left in: a drift over the retreat, 4 deg of shoulder
        in the shipped run, would stay), where the arm stands in the global view's plane: turned out of
        it, the pitches he reads off the picture are foreshortened (the plan ending swung aside by
        40 deg, he set the wrist 8-11 deg off by them)."""
        last = k == len(self.targets) - 1 and abs(self._aimed_plan(k).get("base_yaw", 0.0)) <= READABLE_YAW_RAD
        return self._is_standoff(k) or last or self._is_before_swing_back(k)

    def _is_before_swing_back(self, k: int) -> bool:
        """Target k is the plan's last but one, the arm turned aside of the camera's plane, and the
        last turns it back (its base yaw alone) into that plane, where the string is: he looks from
        both views that the brush will pass clear of the string (`Operator.review_swing`)."""
        last = len(self.targets) - 1
        if self.operator is None or k != last - 1 or set(self.targets[last]) != {"base_yaw"}:
            return False
        yaw = {j: q for target in self.targets[: k + 1] for j, q in target.items()}.get("base_yaw", 0.0)
        return abs(yaw) > READABLE_YAW_RAD >= abs(self.targets[last]["base_yaw"])

    def _is_standoff(self, k: int) -> bool:
        """A target holding the brush clear of a disc (in the camera's plane: base yaw at zero)."""
        t = self.scenario.targets[k]
        return bool(t.brush_at_disc and t.standoff_m > 0 and not t.angles_deg)

    def _is_back_off(self, k: int) -> bool:
        """A target standing off a disc right after a press on it."""
        ts = self.scenario.targets
        return bool(
            k >= 1
            and ts[k].brush_at_disc
            and ts[k].standoff_m > 0
            and ts[k - 1].brush_at_disc == ts[k].brush_at_disc
            and ts[k - 1].standoff_m < 0
        )

    # -- re-referencing at a known stop -----------------------------------------------------------
    def _start_stop_drive(self, t: float) -> None:
        c = self.controller
        i = c.joints.index(STOP_JOINT)
        stop = float(c.arm.joint_upper[i])
        drive_s = STOP_DRIVE_S + STOP_DRIVE_S_PER_RAD * max(stop - c.predicted_angles()[i], 0.0)
        self._stop = _StopDrive(i, stop, t + drive_s, t + drive_s + STOP_SETTLE_S)

    def _drive_into_stop(self, sensors) -> np.ndarray:
        """The stop drive's commands this tick (the joint driven open loop, then braked to settle),
        the platform's controller ticked alongside; settled, the task goes on (`_re_reference`)."""
        s, t = self._stop, float(sensors.time_s)
        c = self.controller
        self.controller.tick(sensors)  # keeps predicting (with its valves shut: its prediction is reset below)
        self._commands[:] = 0.0
        if t < s.drive_until_s:
            self._commands[s.joint, C_DIRECTION] = 1.0
            self._commands[s.joint, C_PV_SET_GAUGE_PA] = max(float(sensors.supply_pa) - c.gas.p_atm_pa, 0.0)
            self._commands[s.joint, C_BRAKE_RELEASE] = 1.0
        else:
            self.fire(t)
        return self._commands

    def _re_reference(self, t: float) -> None:
        """Settled at the stop: the joint's predicted angle set to it."""
        s, c = self._stop, self.controller
        before = math.degrees(c.predicted_angles()[s.joint])
        c.reference(c.joints[s.joint], s.stop_rad)
        self._notes.append(
            f"t = {t:.3f} s: {c.joints[s.joint]} re-referenced at its stop {math.degrees(s.stop_rad):.2f} deg "
            f"(predicted {before:.2f} deg)"
        )
        self._stop = None

    # -- what the run reached ------------------------------------------------------------------
    def active_target(self) -> dict[str, float]:
        """Per joint, the target in force at the end: the latest issued target naming it."""
        out: dict[str, float] = {}
        for k in range(0, min(self.k, len(self.issued) - 1) + 1):
            out.update(self.issued[k])
        return out


S, C = TaskState, TaskController
# The task's transitions (docs/task_states.md draws them): of a state's rows the first whose
# condition holds is taken, its action done with the task in the row's target state.
TRANSITIONS: tuple[Transition, ...] = (
    Transition(S.START, C._always, S.GOING_ON),
    Transition(S.GOING_ON, C._plan_done, S.FINISHED, C._finish),
    Transition(S.GOING_ON, C._back_off_after_press, S.BACKING_OUT, C._back_out_of_press),
    Transition(S.GOING_ON, C._always, S.MOVING, C._next_target),
    Transition(S.MOVING, C._press_to_look_at, S.LOOKING_AT_PRESS),
    Transition(S.MOVING, C._pose_to_look_at, S.LOOKING),
    Transition(S.MOVING, C._stop_to_drive_into, S.STOP_DRIVE, C._start_stop_drive),
    Transition(S.MOVING, C._always, S.GOING_ON),
    Transition(S.LOOKING, C._seen_on_the_rim, S.DRAWING_OUT, C._draw_out),
    Transition(S.LOOKING, C._not_believed_clear_of_string, S.MOVING, C._stop_and_go_again),
    Transition(S.LOOKING, C._not_believed, S.RETREATING, C._stop_and_retreat),
    Transition(S.LOOKING, C._not_believed_again_before_press, S.GOING_ON, C._leave_unpressed_not_believed),
    Transition(S.LOOKING, C._not_believed_again, S.GOING_ON),
    Transition(S.LOOKING, C._moved, S.MOVING, C._go_again),
    Transition(S.LOOKING, C._placed_to_close_in, S.CLOSING_IN, C._close_in),
    Transition(S.LOOKING, C._placed, S.GOING_ON),
    Transition(S.CLOSING_IN, C._always, S.LOOKING_CLOSE),
    Transition(S.LOOKING_CLOSE, C._not_believed, S.RETREATING, C._stop_and_retreat),
    Transition(S.LOOKING_CLOSE, C._not_believed_again, S.GOING_ON, C._leave_unpressed_not_believed),
    Transition(S.LOOKING_CLOSE, C._moved, S.CLOSING_IN, C._go_again),
    Transition(S.LOOKING_CLOSE, C._placed_off_for_press_again, S.GOING_ON, C._leave_unpressed_off),
    Transition(S.LOOKING_CLOSE, C._placed_off_for_press, S.MOVING, C._come_in_again),
    Transition(S.LOOKING_CLOSE, C._placed, S.GOING_ON),
    Transition(S.RETREATING, C._always, S.MOVING, C._come_in_after_retreat),
    Transition(S.DRAWING_OUT, C._always, S.LOOKING),
    Transition(S.LOOKING_AT_PRESS, C._press_off, S.OUT_TO_PRESS_AGAIN, C._back_out_to_press_again),
    Transition(S.LOOKING_AT_PRESS, C._pressed_at_last_pose, S.LOOKING),
    Transition(S.LOOKING_AT_PRESS, C._placed, S.GOING_ON),
    Transition(S.OUT_TO_PRESS_AGAIN, C._always, S.MOVING, C._press_again),
    Transition(S.BACKING_OUT, C._always, S.MOVING, C._back_off_as_planned),
    Transition(S.STOP_DRIVE, C._stop_settled, S.GOING_ON, C._re_reference),
)
ROWS = rows_from(TRANSITIONS)
# what a state does each time the task is asked in it, before its rows are tried: a move's state
# notes the arrival (the task is asked only once the platform is done), a look's state looks
MOVES = (S.MOVING, S.CLOSING_IN, S.RETREATING, S.DRAWING_OUT, S.BACKING_OUT, S.OUT_TO_PRESS_AGAIN)
LOOKS = (S.LOOKING, S.LOOKING_CLOSE, S.LOOKING_AT_PRESS)
BEHAVIOURS = {
    **dict.fromkeys(MOVES, C._arrive),
    S.LOOKING: C._look,
    S.LOOKING_CLOSE: C._look,
    S.LOOKING_AT_PRESS: C._look_at_press,
}
# the states in which a target is placed at TOUCH_STANDOFF_M off its rim (`_standoff_m`)
AT_TOUCHING_DISTANCE = (S.CLOSING_IN, S.LOOKING_CLOSE, S.BACKING_OUT, S.OUT_TO_PRESS_AGAIN)


def _event_time(event: str) -> float:
    """The time of an event line 't = 12.345 s: ...' (stable order for lines without one)."""
    head = event.removeprefix("t = ").split(" s:", 1)[0]
    try:
        return float(head)
    except ValueError:
        return math.inf
