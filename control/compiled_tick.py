"""One control tick of the platform's controller in compiled code, for ticks that need nothing else.

`ArmController.tick` is Python around two compiled calls (control_step, predict_step). Most ticks
of a run do nothing in Python but read the sensors, count a dwell down and pass arrays along: the
arm at rest, a dwell, a move whose predicted load is still fresh. `controller_tick` does such a
tick whole, calling the same control_step and predict_step, so a loop in compiled code
(twin/compiled_loop.py) can run many ticks without returning to Python; it says when a tick needs
Python instead:

    NEEDS_PYTHON  before anything was changed: the tick must be run by `ArmController.tick`
                  (a sensor not a number, a step of the plan ended or begins, the dwell over,
                  the supply below the brakes' release, `done` changed);
    MID_TICK      control_step has run and asks for Python (the predicted load is stale, so
                  Pinocchio; a move timed out): `ArmController.finish_tick` does the rest, or,
                  for the load alone, `ArmController.update_load` and `end_tick`;
    TICKED        the tick is done: commands written, the prediction advanced.

The controller's scalars the tick reads or changes live in one float array (`FLOW_*` columns),
which `ArmController` keeps as the truth of those values.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from control import pid
from control.pid import IDLE, control_step
from control.predicted_load import advance_load
from control.predictor import predict_step
from pneumatics._jit import borrowed, njit

TICKED, NEEDS_PYTHON, MID_TICK = 0, 1, 2
# columns of the controller's flow array: the dwell still to wait (s); 1.0 while a step of the plan
# is under way; 1.0 while plan steps are waiting; 1.0 when faulted; the lowest supply gauge (Pa) a
# brake can lift at; the period (s); atmosphere (Pa)
FLOW_DWELL, FLOW_STEPPING, FLOW_PLAN, FLOW_FAULTED, FLOW_BRAKE_RELEASE, FLOW_DT, FLOW_ATM = range(7)
N_FLOW = 7


@njit
def is_done(flow: np.ndarray, modes: np.ndarray) -> bool:
    """`ArmController.done`: no plan, no step, no dwell left, every joint idle."""
    if flow[FLOW_PLAN] != 0.0 or flow[FLOW_STEPPING] != 0.0 or flow[FLOW_DWELL] > 0.0:
        return False
    idle = 0
    for j in range(modes.shape[0]):
        idle += modes[j, pid.K_MODE] == IDLE
    return idle == modes.shape[0]


@njit
def _needs_python(flow, modes, step_joints, supply_pa, valve_gauge_pa) -> bool:
    # the tick's Python parts that would do more than the compiled tick does (ArmController.tick)
    if not math.isfinite(supply_pa):
        return True
    for j in range(valve_gauge_pa.shape[0]):
        if not math.isfinite(valve_gauge_pa[j]):
            return True
    faulted = flow[FLOW_FAULTED] != 0.0
    busy = flow[FLOW_PLAN] != 0.0 or flow[FLOW_STEPPING] != 0.0
    if busy and not faulted and supply_pa - flow[FLOW_ATM] < flow[FLOW_BRAKE_RELEASE]:
        return True  # a fault
    if faulted:
        return False  # the plan is not sequenced while faulted
    if flow[FLOW_STEPPING] != 0.0:
        busy_joints = 0
        for j in range(step_joints.shape[0]):
            busy_joints += step_joints[j] and modes[j, pid.K_MODE] != IDLE
        return busy_joints == 0  # the step is over (its arrivals are noted, the next one taken) or goes on
    return flow[FLOW_DWELL] <= 0.0 and flow[FLOW_PLAN] != 0.0  # the next step begins


class ControllerArrays(NamedTuple):
    """What `controller_tick` works on, one record for compiled code (`ArmController.compiled_state`
    makes it; the controller keeps the arrays, but for `flow`, made from its scalars)."""

    flow: np.ndarray  # (N_FLOW,) the controller's scalars, FLOW_DWELL written
    step_joints: np.ndarray  # (n,) bool: the joints of the step under way
    modes: np.ndarray  # control/pid.py's tables
    moves: np.ndarray
    drives: np.ndarray
    y: np.ndarray  # the prediction (control/predictor.py)
    x: np.ndarray
    params: np.ndarray
    g: np.ndarray
    commands: np.ndarray  # (n, 3) written
    load_nm: np.ndarray
    inertia_kg_m2: np.ndarray
    load_base: np.ndarray  # the load's tangent (control/predicted_load.py: advance_load's arrays)
    load_slope: np.ndarray
    c_inv: np.ndarray
    load_bound: np.ndarray


@njit(inline="always")
def borrow_controller(c: ControllerArrays) -> ControllerArrays:
    # every array without its reference count (`borrowed`): the caller holds them for the whole call
    return ControllerArrays(
        borrowed(c.flow),
        borrowed(c.step_joints),
        borrowed(c.modes),
        borrowed(c.moves),
        borrowed(c.drives),
        borrowed(c.y),
        borrowed(c.x),
        borrowed(c.params),
        borrowed(c.g),
        borrowed(c.commands),
        borrowed(c.load_nm),
        borrowed(c.inertia_kg_m2),
        borrowed(c.load_base),
        borrowed(c.load_slope),
        borrowed(c.c_inv),
        borrowed(c.load_bound),
    )


@njit
def controller_tick(
    c: ControllerArrays,
    valve_gauge_pa: np.ndarray,  # (n,) measured
    supply_pa: float,  # measured, absolute
    was_done: bool,  # `done` when the compiled ticks began: a change needs Python (the task acts on it)
    control_result: np.ndarray,  # (3,) written on MID_TICK: control_step's (moving, timed out, stale)
) -> int:
    """One tick of `ArmController.tick` where it needs no Python (see the module's docstring)."""
    c = borrow_controller(c)
    flow, step_joints, modes, moves, drives = c.flow, c.step_joints, c.modes, c.moves, c.drives
    y, x, params, g, commands = c.y, c.x, c.params, c.g, c.commands
    valve_gauge_pa = borrowed(valve_gauge_pa)
    if is_done(flow, modes) != was_done or _needs_python(flow, modes, step_joints, supply_pa, valve_gauge_pa):
        return NEEDS_PYTHON
    dt = flow[FLOW_DT]
    drives[:, pid.D_PV_FULL] = max(supply_pa - flow[FLOW_ATM], 0.0)
    faulted = flow[FLOW_FAULTED] != 0.0
    if not faulted and flow[FLOW_STEPPING] == 0.0 and flow[FLOW_DWELL] > 0.0:
        flow[FLOW_DWELL] -= dt
    moving, timed_out = control_step(modes, moves, drives, y, x, params, g, dt, commands)
    load_stale = moving and advance_load(drives, y, c.load_base, c.load_slope, c.c_inv, c.load_bound)
    if moving and (load_stale or timed_out >= 0):
        control_result[0], control_result[1], control_result[2] = moving, timed_out, load_stale
        return MID_TICK
    end_tick(c, valve_gauge_pa, supply_pa)
    return TICKED


@njit
def end_tick(c: ControllerArrays, valve_gauge_pa, supply_pa) -> None:
    """The tick after control_step where no time-out needs Python (`ArmController.finish_tick`,
    the load already taken): a fault's commands, the prediction's step."""
    if c.flow[FLOW_FAULTED] != 0.0:
        c.commands[:] = 0.0
    predict_step(c.y, c.x, c.commands, valve_gauge_pa, supply_pa, c.load_nm, c.inertia_kg_m2, c.params, c.flow[FLOW_DT])
