"""Many control ticks of the controller and the plant in one compiled call (DESIGN, "One control tick").

The run loop (control/loop.py) pays Python every tick: the sensors, the controller's tick around
its compiled parts, the plant's step. Most ticks need none of it: the arm at rest, a dwell, a move
(whose stale predicted load it asks of Pinocchio through a callback). `_ticks` runs such ticks back
to back, each one exactly what the Python loop does (the same compiled control_step, predict_step
and plant steps of the air and MuJoCo's mj_step, in the same order, on the same arrays), and
returns to Python on the first tick that needs it:

* the controller says so (control/compiled_tick.py: a step of the plan ends or begins, a
  time-out, a sensor not a number, `done` changed);
* a callback is due: the run's telemetry tick, the task's camera frame, a fault, a supply step,
  the run's end (each tells when, `CompiledTicks.__call__`).

A tick the compiled loop left half done (control_step ran, a time-out) is finished in Python
by `ArmController.finish_tick` and the plant's step. Results are bit-identical to the per-tick loop
(tests/test_compiled_loop.py).
"""

from __future__ import annotations

import ctypes
import math
import sys
from collections.abc import Callable, Sequence

import numpy as np

from control.compiled_tick import MID_TICK, NEEDS_PYTHON, TICKED, controller_tick, end_tick
from pneumatics import joint as J
from pneumatics._jit import NO_JIT, borrowed, njit
from twin.kernel import MJ_STEP, _call_mj_step, _plant_steps
from twin.plant import SUBSTEPS, Plant

# a callback due at time T is handed back to Python from the tick at T - DUE_MARGIN_S on: far above
# the round-off of MuJoCo's summed time (~1e-13 s over an hour) and far below a tick (1 ms), so the
# Python loop, which compares times its own way, sees the tick where the callback acts
DUE_MARGIN_S = 1e-6
CONTROLLED = 3  # `_ticks` stopped after the controller's part of its last tick, before the plant's steps


@njit
def _ticks(
    mj_step_address,
    model_address,
    data_address,
    load_callback_address,  # void f(void*, void*): Python's Pinocchio load at the predicted angles
    callback_failed,  # (1,): set by the callback when it raised
    n_ticks,
    last_unstepped,  # the last tick's physics steps are left to the caller (its `on_tick` comes first)
    steps_per_tick,
    time_s,  # MuJoCo's d.time now
    stop_s,  # no tick at or after this time
    was_done,
    control_result,
    flow,
    step_joints,
    modes,
    moves,
    drives,
    y,
    x,
    params_c,
    g,
    commands_c,
    load_nm,
    inertia,
    valve_gauge_pa,  # (n,) scratch: the sensors
    air,
    commands_p,
    params_p,
    sensor_bias_pa,
    supply_pa,
    drive_map,
    tendon_ids,
    actuator_ids,
    qpos,
    qvel,
    ctrl,
    tendon_frictionloss,
    dt_s,
    substeps,
):
    # returns (ticks run whole, what stopped them, MuJoCo's time at the tick it stopped on, the time
    # of the last tick the controller ran)
    air, commands_p, params_p, valve_gauge_pa = (
        borrowed(air),
        borrowed(commands_p),
        borrowed(params_p),
        borrowed(valve_gauge_pa),
    )
    sensor_bias_pa, drive_map, commands_c = borrowed(sensor_bias_pa), borrowed(drive_map), borrowed(commands_c)
    qpos, qvel, ctrl, tendon_frictionloss = (
        borrowed(qpos),
        borrowed(qvel),
        borrowed(ctrl),
        borrowed(tendon_frictionloss),
    )
    last_tick_s = math.nan
    for k in range(n_ticks):
        if time_s >= stop_s:
            return k, NEEDS_PYTHON, time_s, last_tick_s
        for j in range(air.shape[0]):  # Plant.sensors
            valve_gauge_pa[j] = air[j, J.S_PV] + sensor_bias_pa[j]
        status = controller_tick(
            flow,
            step_joints,
            modes,
            moves,
            drives,
            y,
            x,
            params_c,
            g,
            commands_c,
            load_nm,
            inertia,
            valve_gauge_pa,
            supply_pa,
            was_done,
            control_result,
        )
        if status == MID_TICK and control_result[1] < 0.0:  # the load alone is stale: Pinocchio's, then on
            _call_mj_step(load_callback_address, 0, 0)
            if callback_failed[0] != 0.0:
                return k, NEEDS_PYTHON, time_s, last_tick_s  # the caller raises what failed
            end_tick(flow, y, x, params_c, commands_c, load_nm, inertia, valve_gauge_pa, supply_pa)
            status = TICKED
        if status != TICKED:
            return k, status, time_s, time_s if status == MID_TICK else last_tick_s
        last_tick_s = time_s
        commands_p[:] = commands_c
        if last_unstepped and k == n_ticks - 1:
            return k, CONTROLLED, time_s, last_tick_s
        _plant_steps(  # Plant.step
            mj_step_address,
            steps_per_tick,
            model_address,
            data_address,
            air,
            commands_p,
            params_p,
            drive_map,
            tendon_ids,
            actuator_ids,
            qpos,
            qvel,
            ctrl,
            tendon_frictionloss,
            supply_pa,
            dt_s,
            substeps,
        )
        for _ in range(steps_per_tick):
            time_s += dt_s  # as mj_step advances d.time (checked against it on return)
    return n_ticks, TICKED, time_s, last_tick_s


MJ_STEP_ADDRESS = ctypes.cast(MJ_STEP, ctypes.c_void_p).value if MJ_STEP is not None else None


class CompiledTicks:
    """`run_ticks`'s `batch`: from tick k on, the ticks that need no Python, in compiled code.

    due_s: callables of the simulated time giving when each callback (the supply profile, the
    faults) next needs its call (math.inf: never again); next_tick: the next tick index at or after
    k whose `on_tick` has work; on_tick: the run loop's, called here on such a tick when its controller
    part ran compiled; n_ticks: the run's end.
    """

    def __init__(
        self,
        plant: Plant,
        controller,
        steps_per_tick: int,
        n_ticks: int,
        due_s: Sequence[Callable[[float], float]] = (),
        next_tick: Callable[[int], int] | None = None,
        on_tick: Callable[[int, float], None] | None = None,
    ):
        self.plant, self.controller, self.steps_per_tick, self.n_ticks = plant, controller, steps_per_tick, n_ticks
        self.due_s, self.next_tick, self.on_tick = tuple(due_s), next_tick, on_tick
        self._control_result = np.zeros(3)
        self._callback_failed = np.zeros(1)
        self._callback_error: BaseException | None = None
        self._callback_arm = None
        self._load_callback = _LOAD_CALLBACK(self._update_load)  # kept alive while compiled code may call it
        self._load_callback_address = ctypes.cast(self._load_callback, ctypes.c_void_p).value
        self._valve_gauge_pa = np.zeros(len(plant.joints))
        self._plant_arrays = (plant.air, plant.commands, plant.params, plant.sensor_bias_pa)

    def __call__(self, k: int) -> int:
        """Run ticks k, k+1, ... in compiled code while none needs Python; how many were run (0:
        tick k needs the Python loop)."""
        plant = self.plant
        if plant._any_stuck or not plant.compiled_ticks:
            return 0
        t = plant.time
        arm, until_s = self.controller.compiled_ticks(t)
        if arm is None:
            return 0
        # up to the next tick with `on_tick` work: its controller part too, when there is an on_tick
        end = self.n_ticks if self.next_tick is None else min(self.n_ticks, self.next_tick(k))
        with_on_tick = self.on_tick is not None and end < self.n_ticks
        for due in self.due_s:
            until_s = min(until_s, due(t))
        if end + with_on_tick <= k or until_s - DUE_MARGIN_S <= t:
            return 0
        state = arm.compiled_state()
        self._callback_arm = arm
        # an exception raised in the load's callback before its own `try` (Ctrl-C's KeyboardInterrupt
        # at its first line) would be printed and dropped by ctypes: taken from the unraisable hook
        hook, sys.unraisablehook = sys.unraisablehook, self._unraisable
        try:
            ran, status, t_end, last_tick_s = _ticks(
                MJ_STEP_ADDRESS,
                *plant._addresses,
                self._load_callback_address,
                self._callback_failed,
                end + with_on_tick - k,
                with_on_tick,
                self.steps_per_tick,
                t,
                until_s - DUE_MARGIN_S,
                arm.done,
                self._control_result,
                *state,
                self._valve_gauge_pa,
                *self._plant_arrays,
                plant.supply_pa,
                *plant._fixed_arrays,
                plant.dt,
                SUBSTEPS,
            )
        finally:
            sys.unraisablehook = hook
        if self._callback_error is not None:
            raise self._callback_error
        if t_end != plant.time:
            raise RuntimeError(f"compiled ticks: MuJoCo's time {plant.time!r}, the loop's {t_end!r}")
        if ran == 0 and status == NEEDS_PYTHON:
            return 0
        arm.take_compiled_state(state[0], last_tick_s, plant.supply_pa)
        if status == MID_TICK:  # tick k + ran: control_step ran, the rest is Python's
            moving, timed_out, stale = self._control_result
            commands = arm.finish_tick(
                (bool(moving), int(timed_out), bool(stale)), self._valve_gauge_pa.copy(), plant.supply_pa
            )
            plant.commands[:] = commands
            if with_on_tick and k + ran == end:
                self.on_tick(k + ran, t_end)
            plant.step(self.steps_per_tick, check_warnings=False)
            ran += 1
        elif status == CONTROLLED:  # tick k + ran, commands issued: the run's on_tick, then the plant's steps
            self.on_tick(k + ran, t_end)
            plant.step(self.steps_per_tick, check_warnings=False)
            ran += 1
        return ran

    def _unraisable(self, unraisable) -> None:
        if unraisable.exc_value is not None and self._callback_error is None:
            self._callback_error = unraisable.exc_value
            self._callback_failed[0] = 1.0

    def _update_load(self, _a, _b) -> None:
        # called from compiled code (ctypes, which would print and drop an exception): noted, raised
        # by __call__ once the compiled ticks have returned
        try:
            self._callback_arm.update_load()
        except BaseException as e:  # noqa: BLE001 - re-raised by __call__
            self._callback_error = e
            self._callback_failed[0] = 1.0


_LOAD_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)


def compiled_ticks(plant: Plant, controller, steps_per_tick: int, n_ticks: int, **kwargs) -> CompiledTicks | None:
    """The compiled ticks of this plant and controller, or None where they cannot run (no
    compiled MuJoCo step, TWIN_NO_JIT, a controller without `compiled_ticks`)."""
    if NO_JIT or MJ_STEP_ADDRESS is None or not hasattr(controller, "compiled_ticks"):
        return None
    return CompiledTicks(plant, controller, steps_per_tick, n_ticks, **kwargs)
