"""Many control ticks of the controller and the plant in one compiled call (DESIGN, "One control tick").

The run loop (control/loop.py) pays Python every tick: the sensors, the controller's tick around
its compiled parts, the plant's step. Most ticks need none of it: the arm at rest, a dwell, a move
(whose stale predicted load it asks of Pinocchio through a callback). `_ticks` runs such ticks back
to back, each one exactly what the Python loop does (the same compiled control_step, predict_step
and plant steps of the air and MuJoCo's mj_step, in the same order, on the same arrays), and
returns to Python on the first tick that needs it:

* the controller says so (control/compiled_tick.py: a step of the plan ends or begins, a
  time-out, a sensor not a number, `done` changed);
* a schedule is due (control/schedule.py): a fault, a change of the supply; or the task's camera
  frame while the operator waits for one, the run's end (each tells when, `CompiledTicks.__call__`).

Two things a tick may need of Python it calls without returning, through ctypes callbacks: the
Pinocchio load at the predicted angles, and the run's `on_tick` (the telemetry sample, the
recorders' flush) at the ticks it has work, after the controller's part and before the plant's
steps, where the Python loop calls it. The task's camera takes its frames in the compiled ticks
too (twin/camera_frames.py): a frame is a few world points copied, its picture made when looked at.

A tick the compiled loop left half done (control_step ran, a time-out) is finished in Python
by `ArmController.finish_tick` and the plant's step. Results are bit-identical to the per-tick loop
(tests/test_compiled_loop.py).
"""

from __future__ import annotations

import ctypes
import math
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from control.compiled_tick import MID_TICK, NEEDS_PYTHON, TICKED, borrow_controller, controller_tick, end_tick
from pneumatics import joint as J
from pneumatics._jit import NO_JIT, borrowed, njit
from twin.camera_frames import no_camera, record_frame
from twin.kernel import MJ_STEP_ADDRESS, SUBSTEPS, borrow_plant, call_c_function, step_plant
from twin.sample_row import fill_row

if TYPE_CHECKING:  # the plant hands its compiled ticks out (Plant.ticks_batch): imported by it
    from twin.plant import Plant

# a callback due at time T is handed back to Python from the tick at T - DUE_MARGIN_S on: far above
# the round-off of MuJoCo's summed time (~1e-13 s over an hour) and far below a tick (1 ms), so the
# Python loop, which compares times its own way, sees the tick where the callback acts
DUE_MARGIN_S = 1e-6
# on_tick_args: [the next tick (of this call's) whose `on_tick` has work, the tick calling it, its time]
ON_TICK_NEXT, ON_TICK_K, ON_TICK_T = range(3)
NEVER = 2**53  # a tick no run reaches (exact as a float in on_tick_args)


@njit
def _ticks(
    mj_step_address,
    plant,  # twin/kernel.py's PlantArrays of the plant
    commands_p,  # the plant's commands (written each tick)
    sensor_bias_pa,
    supply_pa,
    load_callback_address,  # void f(void*, void*): Python's Pinocchio load at the predicted angles
    on_tick_address,  # void f(void*, void*): the run's `on_tick` (telemetry), at the ticks on_tick_args names
    on_tick_args,
    sample_row,  # (width,) or (0,): the telemetry sample `fill_row` writes before each on_tick call
    callback_failed,  # (1,): set by a callback when it raised
    n_ticks,
    steps_per_tick,
    time_s,  # MuJoCo's d.time now
    stop_s,  # no tick at or after this time
    was_done,
    control_result,
    controller,  # control/compiled_tick.py's ControllerArrays of the controller
    valve_gauge_pa,  # (n,) scratch: the sensors
    dt_s,
    substeps,
    camera_clock,  # a scene camera's frames (twin/camera_frames.py): taken at the start of each tick
    camera_rows,
    camera_body_ids,
    camera_site_ids,
    xpos,
    xmat,
    site_xpos,
    xquat,
):
    # returns (ticks run whole, what stopped them, MuJoCo's time at the tick it stopped on, the time
    # of the last tick the controller ran)
    a, c = borrow_plant(plant), borrow_controller(controller)
    air, qpos, drive_map = a.air, a.qpos, a.drive_map
    commands_p, valve_gauge_pa, sensor_bias_pa = (
        borrowed(commands_p),
        borrowed(valve_gauge_pa),
        borrowed(sensor_bias_pa),
    )
    camera_clock, camera_rows, camera_body_ids, camera_site_ids = (
        borrowed(camera_clock),
        borrowed(camera_rows),
        borrowed(camera_body_ids),
        borrowed(camera_site_ids),
    )
    xpos, xmat, site_xpos, on_tick_args = borrowed(xpos), borrowed(xmat), borrowed(site_xpos), borrowed(on_tick_args)
    xquat, sample_row = borrowed(xquat), borrowed(sample_row)
    last_tick_s = math.nan
    for k in range(n_ticks):
        if time_s >= stop_s:
            return k, NEEDS_PYTHON, time_s, last_tick_s
        # the task's frame (a tick handed back below takes it again: no longer due, nothing taken)
        record_frame(camera_clock, camera_rows, camera_body_ids, camera_site_ids, xpos, xmat, site_xpos, time_s)
        for j in range(air.shape[0]):  # Plant.sensors
            valve_gauge_pa[j] = air[j, J.S_PV] + sensor_bias_pa[j]
        status = controller_tick(c, valve_gauge_pa, supply_pa, was_done, control_result)
        if status == MID_TICK and control_result[1] < 0.0:  # the load alone is stale: Pinocchio's, then on
            call_c_function(load_callback_address, 0, 0)
            if callback_failed[0] != 0.0:
                return k, NEEDS_PYTHON, time_s, last_tick_s  # the caller raises what failed
            end_tick(c, valve_gauge_pa, supply_pa)
            status = TICKED
        if status != TICKED:
            return k, status, time_s, time_s if status == MID_TICK else last_tick_s
        last_tick_s = time_s
        commands_p[:] = c.commands
        if k == on_tick_args[ON_TICK_NEXT]:  # the run's telemetry sees the commands issued, then the steps
            on_tick_args[ON_TICK_K], on_tick_args[ON_TICK_T] = k, time_s
            if sample_row.shape[0] > 0:
                fill_row(
                    sample_row,
                    time_s,
                    qpos,
                    drive_map,
                    c.y,
                    c.moves,
                    air,
                    sensor_bias_pa,
                    commands_p,
                    supply_pa,
                    xpos,
                    xquat,
                )
            call_c_function(on_tick_address, 0, 0)
            if callback_failed[0] != 0.0:
                return k, NEEDS_PYTHON, time_s, last_tick_s  # the caller raises what failed
        step_plant(mj_step_address, steps_per_tick, a, commands_p, supply_pa, dt_s, substeps)  # Plant.step
        for _ in range(steps_per_tick):
            time_s += dt_s  # as mj_step advances d.time (checked against it on return)
    return n_ticks, TICKED, time_s, last_tick_s


class CompiledTicks:
    """`run_ticks`'s `batch`: from tick k on, the ticks that need no Python, in compiled code.

    due_s: the schedules' (control/schedule.py) `next_change_s` and `due_s`: when each next needs
    the Python loop after the time it was last applied (math.inf: never again); next_tick: the next
    tick index at or after k whose `on_tick` has work (None: every tick); on_tick: the run loop's,
    called on such a tick when its controller part ran compiled (from the compiled ticks);
    ticks_left(k): how many ticks from k on the run surely has (its end).
    A controller with `compiled_camera` hands its camera's frames to the compiled ticks.
    sample_row: a telemetry row (twin/sample_row.py) the compiled ticks fill before each call of
    `on_tick`, which is then handed it as a third argument (None: on_tick(k, t) takes its own).
    """

    def __init__(
        self,
        plant: Plant,
        controller,
        steps_per_tick: int,
        ticks_left: Callable[[int], int],
        due_s: Sequence[Callable[[float], float]] = (),
        next_tick: Callable[[int], int] | None = None,
        on_tick: Callable[..., None] | None = None,
        sample_row: np.ndarray | None = None,
    ):
        self.plant, self.controller, self.steps_per_tick, self.ticks_left = (
            plant,
            controller,
            steps_per_tick,
            ticks_left,
        )
        self.due_s, self.next_tick, self.on_tick = tuple(due_s), next_tick, on_tick
        self._control_result = np.zeros(3)
        self._callback_failed = np.zeros(1)
        self._callback_error: BaseException | None = None
        self._callback_arm = None
        self._load_callback = _CALLBACK(self._update_load)  # kept alive while compiled code may call it
        self._load_callback_address = ctypes.cast(self._load_callback, ctypes.c_void_p).value
        self._on_tick_callback = _CALLBACK(self._call_on_tick)
        self._on_tick_address = ctypes.cast(self._on_tick_callback, ctypes.c_void_p).value
        self._on_tick_args = np.zeros(3)
        self._sample_row = np.zeros(0) if sample_row is None else sample_row
        self._k0 = 0  # the tick the compiled ticks began at
        self._valve_gauge_pa = np.zeros(len(plant.joints))
        # the task's camera, whose frames the compiled ticks take from now on (its `compiled_camera`)
        camera = getattr(controller, "compiled_camera", None)
        d = plant.data
        self._camera = (*((camera() if camera else None) or no_camera()), d.xpos, d.xmat, d.site_xpos)
        self._xquat = d.xquat

    def __call__(self, k: int, applied_s: float) -> int:
        """Run ticks k, k+1, ... in compiled code while none needs Python; how many were run (0:
        tick k needs the Python loop). `applied_s`: the time the run loop last applied the
        schedules (the supply it set then holds until their next change after that time)."""
        plant = self.plant
        if plant._any_stuck or not plant.allow_compiled_ticks:
            return 0
        t = plant.time
        arm, until_s = self.controller.compiled_ticks(t)
        if arm is None:
            return 0
        for due in self.due_s:
            until_s = min(until_s, due(applied_s))
        n_ticks = self.ticks_left(k)
        if n_ticks <= 0 or until_s - DUE_MARGIN_S <= t:
            return 0
        state = arm.compiled_state()
        self._callback_arm, self._k0 = arm, k
        self._on_tick_args[ON_TICK_NEXT] = self._on_tick_due(k) - k
        # an exception raised in the load's callback before its own `try` (Ctrl-C's KeyboardInterrupt
        # at its first line) would be printed and dropped by ctypes: taken from the unraisable hook
        hook, sys.unraisablehook = sys.unraisablehook, self._unraisable
        try:
            ran, status, t_end, last_tick_s = _ticks(
                MJ_STEP_ADDRESS,
                plant.arrays,
                plant.commands,
                plant.sensor_bias_pa,
                plant.supply_pa,
                self._load_callback_address,
                self._on_tick_address,
                self._on_tick_args,
                self._sample_row,
                self._callback_failed,
                n_ticks,
                self.steps_per_tick,
                t,
                until_s - DUE_MARGIN_S,
                arm.done,
                self._control_result,
                state,
                self._valve_gauge_pa,
                plant.dt,
                SUBSTEPS,
                *self._camera,
                self._xquat,
            )
        finally:
            sys.unraisablehook = hook
        if self._callback_error is not None:
            raise self._callback_error
        if t_end != plant.time:
            raise RuntimeError(f"compiled ticks: MuJoCo's time {plant.time!r}, the loop's {t_end!r}")
        if ran == 0 and status == NEEDS_PYTHON:
            return 0
        arm.take_compiled_state(state.flow, last_tick_s, plant.supply_pa)
        if status == MID_TICK:  # tick k + ran: control_step ran, the rest is Python's
            moving, timed_out, stale = self._control_result
            commands = arm.finish_tick(
                (bool(moving), int(timed_out), bool(stale)), self._valve_gauge_pa.copy(), plant.supply_pa
            )
            plant.commands[:] = commands
            if self._on_tick_due(k + ran) == k + ran:
                self.on_tick(k + ran, t_end)
            plant.step(self.steps_per_tick, check_warnings=False)
            ran += 1
        return ran

    def _on_tick_due(self, k: int) -> int:
        """The first tick from k on where `on_tick` has work (NEVER: none)."""
        if self.on_tick is None:
            return NEVER
        return k if self.next_tick is None else self.next_tick(k)

    def _unraisable(self, unraisable) -> None:
        if unraisable.exc_value is not None and self._callback_error is None:
            self._callback_error = unraisable.exc_value
            self._callback_failed[0] = 1.0

    # the callbacks below are called from compiled code (ctypes, which would print and drop an
    # exception): what they raise is noted, and raised by __call__ once the compiled ticks have returned
    def _update_load(self, _a, _b) -> None:
        try:
            self._callback_arm.update_load()
        except BaseException as e:  # noqa: BLE001 - re-raised by __call__
            self._callback_error = e
            self._callback_failed[0] = 1.0

    def _call_on_tick(self, _a, _b) -> None:
        # the run's on_tick at a tick whose controller part ran compiled (commands issued, no step yet)
        try:
            args = self._on_tick_args
            k = self._k0 + int(args[ON_TICK_K])
            if self._sample_row.shape[0]:
                self.on_tick(k, float(args[ON_TICK_T]), self._sample_row)
            else:
                self.on_tick(k, float(args[ON_TICK_T]))
            args[ON_TICK_NEXT] = self._on_tick_due(k + 1) - self._k0
        except BaseException as e:  # noqa: BLE001 - re-raised by __call__
            self._callback_error = e
            self._callback_failed[0] = 1.0


_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)


def compiled_ticks(plant: Plant, controller, steps_per_tick: int, ticks_left, **kwargs) -> CompiledTicks | None:
    """The compiled ticks of this plant and controller (`Plant.ticks_batch`), or None where they
    cannot run (no compiled MuJoCo step, TWIN_NO_JIT, a controller without `compiled_ticks`)."""
    if NO_JIT or MJ_STEP_ADDRESS is None or not hasattr(controller, "compiled_ticks"):
        return None
    return CompiledTicks(plant, controller, steps_per_tick, ticks_left, **kwargs)
