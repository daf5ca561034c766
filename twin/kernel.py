"""The compiled per-step coupling of the pneumatic joints to MuJoCo.

Glue only: it reads each joint's drive coordinate from MuJoCo's tendon arrays, calls the laws of
pneumatics/ and writes the joint torque into the actuator's ctrl and the brake into the tendon's
frictionloss. One call per physics step for all joints keeps the cost of the air physics to a
fraction of MuJoCo's own step (see benchmarks/).
"""

from __future__ import annotations

import ctypes
import functools

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
)
from pneumatics.reducer import is_rigid


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
    x: np.ndarray,  # (n_joints, N_STATE) joint states, advanced in place
    commands: np.ndarray,  # (n_joints, N_COMMAND) held over the step
    params: np.ndarray,  # (n_joints, N_COLUMNS)
    drive_map: np.ndarray,  # (n_joints, k, 3): (qpos address, dof address, coefficient) of each tendon term
    tendon_ids: np.ndarray,  # (n_joints,) int: the drive tendon of each joint
    actuator_ids: np.ndarray,  # (n_joints,) int: the motor on that tendon
    qpos: np.ndarray,  # MuJoCo d.qpos
    qvel: np.ndarray,  # MuJoCo d.qvel
    ctrl: np.ndarray,  # MuJoCo d.ctrl (written)
    tendon_frictionloss: np.ndarray,  # MuJoCo m.tendon_frictionloss (written)
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
    for j in range(x.shape[0]):
        p = params[j]
        t = tendon_ids[j]
        theta, omega = _drive_coordinate(drive_map, j, qpos, qvel)
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
            torque = advance_motor_side(x[j], theta, omega, valve, supply_pa, dt_s, substeps, p)
        ctrl[actuator_ids[j]] = torque
        advance_brake(x[j], commands[j], supply_pa, pa_start, pb_start, x[j, S_PA_MOTOR], x[j, S_PB_MOTOR], dt_s, p)


def _mujoco_step_function():
    """MuJoCo's C `mj_step(const mjModel*, mjData*)` as a ctypes function numba can call, or None.

    Calling it from compiled code lets a whole run of physics steps, air and rigid bodies, go by
    without returning to Python (`plant_steps`). It is the same library the mujoco package loads,
    so results are bit-identical to `mujoco.mj_step` (tests/test_plant.py).
    """
    from pathlib import Path

    import mujoco

    for path in sorted(Path(mujoco.__file__).parent.glob("libmujoco.so*")) + sorted(
        Path(mujoco.__file__).parent.glob("libmujoco*.dylib")
    ):
        try:
            fn = ctypes.CDLL(str(path)).mj_step
        except (OSError, AttributeError):
            continue
        fn.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        fn.restype = None
        return fn
    return None


MJ_STEP = _mujoco_step_function()


@intrinsic
def _call_mj_step(typingctx, function_address, model_address, data_address):
    """Call `void f(void*, void*)` at an address known only at run time (MuJoCo's mj_step).

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
def _plant_steps(
    mj_step_address,
    n,
    model_address,
    data_address,
    x,
    commands,
    params,
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
    sensordata,
    force_adr,
    force_peak,
):
    # the caller holds every array for the whole call: no reference counting in the loop (see `borrowed`)
    x, commands, params, drive_map = borrowed(x), borrowed(commands), borrowed(params), borrowed(drive_map)
    tendon_ids, actuator_ids = borrowed(tendon_ids), borrowed(actuator_ids)
    sensordata, force_peak = borrowed(sensordata), borrowed(force_peak)
    qpos, qvel, ctrl, tendon_frictionloss = (
        borrowed(qpos),
        borrowed(qvel),
        borrowed(ctrl),
        borrowed(tendon_frictionloss),
    )
    for _ in range(n):
        pneumatic_step(
            x,
            commands,
            params,
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
        _call_mj_step(mj_step_address, model_address, data_address)
        keep_force_peak(sensordata, force_adr, force_peak)
    finish_air_pairs(x, params, drive_map, qpos, qvel, dt_s)


if MJ_STEP is not None and not NO_JIT:
    # n physics steps of the plant: the air (`pneumatic_step`), then MuJoCo's `mj_step`
    plant_steps = functools.partial(_plant_steps, ctypes.cast(MJ_STEP, ctypes.c_void_p).value)
else:  # a MuJoCo build without a loadable shared library, or TWIN_NO_JIT=1: Plant.step loops in Python
    plant_steps = None


@njit
def _replay_steps(mj_step_address, model_address, data_address, ctrl, frictionloss, actuator_ids, tendon_ids, c, f):
    """MuJoCo alone, stepping with the recorded ctrl `c` and tendon friction `f` (one row per
    physics step) of the plant's actuators and drive tendons: the plant's motion without its air."""
    ctrl, frictionloss, c, f = borrowed(ctrl), borrowed(frictionloss), borrowed(c), borrowed(f)
    for i in range(c.shape[0]):
        for j in range(actuator_ids.shape[0]):
            ctrl[actuator_ids[j]] = c[i, j]
            frictionloss[tendon_ids[j]] = f[i, j]
        _call_mj_step(mj_step_address, model_address, data_address)


if MJ_STEP is not None and not NO_JIT:
    # bare MuJoCo replaying a plant's recorded torques and friction (benchmarks' baseline)
    replay_steps = functools.partial(_replay_steps, ctypes.cast(MJ_STEP, ctypes.c_void_p).value)
else:
    replay_steps = None
