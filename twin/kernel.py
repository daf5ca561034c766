"""The compiled per-step coupling of the pneumatic joints to MuJoCo.

Glue only: it reads each joint's drive coordinate from MuJoCo's tendon arrays, calls the laws of
pneumatics/ and writes the joint torque into the actuator's ctrl and the brake into the tendon's
frictionloss. One call per physics step for all joints keeps the cost of the air physics to a
fraction of MuJoCo's own step (see benchmarks/).
"""

from __future__ import annotations

import ctypes
from typing import NamedTuple

import numpy as np
from llvmlite import ir

from pneumatics._jit import NO_JIT, borrowed, intrinsic, njit, types
from pneumatics.joint import (
    S_PA_MOTOR,
    S_PB_MOTOR,
    advance_air_pair,
    advance_brake,
    advance_discrete,
    advance_motor_side,
    brake_over_step,
    dry_friction_limit,
    finish_air_pair,
    held_motor_side,
)
from pneumatics.reducer import is_rigid

# least RK4 sub-steps per physics step of a non-rigid reducer's motor side (pneumatics/joint.py,
# `advance_motor_side`, which takes more where the gear's mode needs them)
SUBSTEPS = 1


class PlantArrays(NamedTuple):
    """What a physics step of the plant works on, one record for compiled code: MuJoCo's model and
    data (their addresses, for `mj_step`), the joints' air and parameters, how each joint meets
    MuJoCo, MuJoCo's arrays the air reads and writes, and the brush's touch sensor. `Plant.arrays`
    holds the plant's; the commands and the supply, held over a step, are passed beside it."""

    model_address: int
    data_address: int
    air: np.ndarray  # (n_joints, width) joint states (and hose lines), advanced in place
    params: np.ndarray  # (n_joints, N_COLUMNS)
    drive_map: np.ndarray  # (n_joints, k, 3): (qpos address, dof address, coefficient) of each tendon term
    tendon_ids: np.ndarray  # (n_joints,) int: the drive tendon of each joint
    actuator_ids: np.ndarray  # (n_joints,) int: the motor on that tendon
    qpos: np.ndarray  # MuJoCo d.qpos
    qvel: np.ndarray  # MuJoCo d.qvel
    ctrl: np.ndarray  # MuJoCo d.ctrl (written)
    tendon_frictionloss: np.ndarray  # MuJoCo m.tendon_frictionloss (written)
    sensordata: np.ndarray  # MuJoCo d.sensordata: the brush's touch sensor at `force_adr` (-1: none)
    force_adr: int
    force_peak: np.ndarray  # (1,) the largest touch force since it was last taken (`keep_force_peak`)


@njit(inline="always")
def borrow_plant(a: PlantArrays) -> PlantArrays:
    """The record with every array borrowed (`borrowed`): for a caller that holds it for the whole call."""
    return PlantArrays(
        a.model_address,
        a.data_address,
        borrowed(a.air),
        borrowed(a.params),
        borrowed(a.drive_map),
        borrowed(a.tendon_ids),
        borrowed(a.actuator_ids),
        borrowed(a.qpos),
        borrowed(a.qvel),
        borrowed(a.ctrl),
        borrowed(a.tendon_frictionloss),
        borrowed(a.sensordata),
        a.force_adr,
        borrowed(a.force_peak),
    )


@njit(inline="always")
def _drive_coordinate(drive_map: np.ndarray, j: int, qpos: np.ndarray, qvel: np.ndarray) -> tuple[float, float]:
    # joint j's drive angle and speed, summed from qpos/qvel through its fixed tendon's coefficients
    theta = 0.0
    omega = 0.0
    for term in range(drive_map.shape[1]):
        c = drive_map[j, term, 2]
        if c != 0.0:
            theta += c * qpos[int(drive_map[j, term, 0])]
            omega += c * qvel[int(drive_map[j, term, 1])]
    return theta, omega


@njit
def finish_air_pairs(
    x: np.ndarray, params: np.ndarray, drive_map: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, dt_s: float
) -> None:
    """Complete each rigid joint's air step that waits for it (`finish_air_pair`), at the motion
    MuJoCo reached: the end of a run of plant steps leaves every pressure a result, not an estimate."""
    for j in range(x.shape[0]):
        if is_rigid(params[j]):
            theta, omega = _drive_coordinate(drive_map, j, qpos, qvel)
            finish_air_pair(x[j], theta, omega, dt_s, params[j])


@njit
def pneumatic_step(
    a: PlantArrays,  # the air advanced in place, MuJoCo's ctrl and tendon friction written
    commands: np.ndarray,  # (n_joints, N_COMMAND) held over the step
    supply_pa: float,
    dt_s: float,
    substeps: int,
) -> None:
    """Apply each joint's torque and brake for the coming step, then advance its air over dt.

    The drive angle and speed are summed from qpos/qvel through the fixed tendon's coefficients:
    d.ten_length/ten_velocity after mj_step still describe the step before.

    A joint with a non-rigid reducer (pneumatics/reducer.py) has its motor side here, not in
    MuJoCo (whose drive tendon then carries no rotor armature): the motor side and the air are
    integrated over the step with the joint advancing linearly at the speed MuJoCo reports, and
    ctrl gets the torque the gear transmitted, averaged over the step: the joint receives the
    impulse the spring delivered, integrated with the same weights as the motor's loss of it.
    """
    x, params, qpos, qvel, tendon_frictionloss = a.air, a.params, a.qpos, a.qvel, a.tendon_frictionloss
    for j in range(x.shape[0]):
        p = params[j]
        t = a.tendon_ids[j]
        theta, omega = _drive_coordinate(a.drive_map, j, qpos, qvel)
        rigid = is_rigid(p)
        if rigid:
            finish_air_pair(x[j], theta, omega, dt_s, p)  # the air's step that ended with the last physics step
        pa_start = x[j, S_PA_MOTOR]
        pb_start = x[j, S_PB_MOTOR]
        valve = advance_discrete(x[j], commands[j], supply_pa, dt_s, p)
        # brake is spring-applied: it, the joint's Coulomb friction and the Stribeck excess are one
        # dry-friction limit, held by MuJoCo over the step at the brake's mean over it and the
        # excess at the step's starting speed (the static level at rest)
        tendon_frictionloss[t] = dry_friction_limit(
            brake_over_step(x[j], commands[j], supply_pa, pa_start, pb_start, dt_s, p), omega, p
        )
        if rigid:
            # the torque MuJoCo holds over the step, from the pressures at its start (explicit, like
            # MuJoCo's own semi-implicit Euler; a mid-step torque was tried and was no closer to LSODA)
            torque = advance_air_pair(x[j], theta, omega, valve, supply_pa, dt_s, p)
        else:
            held = held_motor_side(x[j], theta, omega, p)
            torque = (
                held.torque
                if held.at_rest
                else advance_motor_side(x[j], theta, omega, valve, supply_pa, dt_s, substeps, p)
            )
        a.ctrl[a.actuator_ids[j]] = torque
        advance_brake(x[j], commands[j], supply_pa, pa_start, pb_start, x[j, S_PA_MOTOR], x[j, S_PB_MOTOR], dt_s, p)


def _mujoco_library() -> ctypes.CDLL | None:
    """The shared library the mujoco package loaded (the same one `mujoco.mj_step` runs), or None."""
    from pathlib import Path

    import mujoco

    for path in sorted(Path(mujoco.__file__).parent.glob("libmujoco.so*")) + sorted(
        Path(mujoco.__file__).parent.glob("libmujoco*.dylib")
    ):
        try:
            lib = ctypes.CDLL(str(path))
            lib.mj_step  # noqa: B018 - a library without it is not MuJoCo's
        except (OSError, AttributeError):
            continue
        return lib
    return None


def _mujoco_step_function(lib: ctypes.CDLL | None):
    """MuJoCo's C `mj_step(const mjModel*, mjData*)` as a ctypes function numba can call, or None.

    Calling it from compiled code lets a whole run of physics steps, air and rigid bodies, go by
    without returning to Python (`step_plant`). It is the same library the mujoco package loads,
    so results are bit-identical to `mujoco.mj_step` (tests/test_plant.py).
    """
    if lib is None:
        return None
    fn = lib.mj_step
    fn.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    fn.restype = None
    return fn


def _stop_profiler(lib: ctypes.CDLL | None) -> None:
    """Clear MuJoCo's timer callback `mjcb_time`, which the mujoco package installs: with it, each
    mj_step reads the clock at every stage for mjData.timer (MuJoCo's profiler), which the twin
    never reads. It cost 14 % of bare mj_step's time on the cleaning scene's motion (6.3 against
    5.4 us per step, CPU time, six alternating rounds: benchmarks/bench_twin.py's replay). The
    physics does not read the timers: results are bit-identical. Process-wide, like the callback:
    MuJoCo stepped from Python (`mujoco.mj_step`, the benchmarks' bare baselines) runs without it too."""
    if lib is not None:
        ctypes.c_void_p.in_dll(lib, "mjcb_time").value = None


_MUJOCO = _mujoco_library()
_stop_profiler(_MUJOCO)
MJ_STEP = _mujoco_step_function(_MUJOCO)
# its address, handed to compiled code (`step_plant`); None: no compiled MuJoCo step (Plant.step loops in Python)
MJ_STEP_ADDRESS = ctypes.cast(MJ_STEP, ctypes.c_void_p).value if MJ_STEP is not None and not NO_JIT else None


@intrinsic
def call_c_function(typingctx, function_address, model_address, data_address):
    """Call `void f(void*, void*)` at an address known only at run time (MuJoCo's mj_step, a ctypes
    callback).

    The address is an ordinary integer argument, so the code that calls it compiles once and is
    cached on disk like the rest of the physics (a ctypes function held as a global is baked into
    the machine code, and a ctypes function passed as an argument costs ~1 us per call to type).
    """
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):
        fn_address, model, data = args
        ptr = ir.IntType(8).as_pointer()
        fn_type = ir.FunctionType(ir.VoidType(), [ptr, ptr])
        fn = builder.inttoptr(fn_address, fn_type.as_pointer())
        builder.call(fn, [builder.inttoptr(model, ptr), builder.inttoptr(data, ptr)])
        return context.get_dummy_value()

    return sig, codegen


@njit(inline="always")
def keep_force_peak(sensordata: np.ndarray, force_adr: int, force_peak: np.ndarray) -> None:
    """The brush's contact force of the physics step just taken (its touch sensor at `force_adr`,
    computed inside mj_step; -1: none) into `force_peak[0]` if larger: the peak is kept at the
    physics rate, so a blow shorter than a telemetry period is not missed."""
    if force_adr >= 0 and sensordata[force_adr] > force_peak[0]:
        force_peak[0] = sensordata[force_adr]


@njit
def step_plant(mj_step_address, n, a: PlantArrays, commands, supply_pa, dt_s, substeps):
    """n physics steps of the plant with its commands and supply held: each the air
    (`pneumatic_step`), then MuJoCo's `mj_step` (at `mj_step_address`, MJ_STEP_ADDRESS), then the
    brush's peak force kept; then each rigid joint's air step completed (`finish_air_pairs`)."""
    a = borrow_plant(a)  # the caller holds every array for the whole call: no reference counting in the loop
    commands = borrowed(commands)
    for _ in range(n):
        pneumatic_step(a, commands, supply_pa, dt_s, substeps)
        call_c_function(mj_step_address, a.model_address, a.data_address)
        keep_force_peak(a.sensordata, a.force_adr, a.force_peak)
    finish_air_pairs(a.air, a.params, a.drive_map, a.qpos, a.qvel, dt_s)


@njit
def _replay_steps(mj_step_address, model_address, data_address, ctrl, frictionloss, actuator_ids, tendon_ids, c, f):
    """MuJoCo alone, stepping with the recorded ctrl `c` and tendon friction `f` (one row per
    physics step) of the plant's actuators and drive tendons: the plant's motion without its air."""
    ctrl, frictionloss, c, f = borrowed(ctrl), borrowed(frictionloss), borrowed(c), borrowed(f)
    for i in range(c.shape[0]):
        for j in range(actuator_ids.shape[0]):
            ctrl[actuator_ids[j]] = c[i, j]
            frictionloss[tendon_ids[j]] = f[i, j]
        call_c_function(mj_step_address, model_address, data_address)


def replay_steps(model_address, data_address, ctrl, frictionloss, actuator_ids, tendon_ids, c, f) -> None:
    """Bare MuJoCo replaying a plant's recorded torques and friction (benchmarks' baseline)."""
    if MJ_STEP_ADDRESS is None:
        raise RuntimeError("replay_steps needs MuJoCo's shared library and compiled code (twin.kernel.MJ_STEP)")
    _replay_steps(MJ_STEP_ADDRESS, model_address, data_address, ctrl, frictionloss, actuator_ids, tendon_ids, c, f)
