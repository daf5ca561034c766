"""Replay an arm run's logged commands through the whole twin: the five joints' air models driving
MuJoCo's rigid bodies (twin/plant.py's plant, twin/kernel.py's coupling), one compiled call a run.

Why MuJoCo and not Pinocchio's forward dynamics: the plant is MuJoCo, with the brakes and dry
friction as MuJoCo's frictionloss constraints, the end stops, the brush's spring and its contacts
with the insulator string; a Pinocchio replay would need every one of them written again (a second
model, DESIGN rule 2) and its ABA step is no cheaper than MuJoCo's whole step here. Measured on
this machine: 14 us per 0.5 ms physics step of the whole arm with its air (the air's share a
third), so a 60 s run replays in about 1.7 s (benchmarks: `python -m gap.arm_replay`).

Per 1 ms control tick, as `twin.sim.run` drives the plant: the commands of the row in force (held
from one row to the next), the supply of that row (less the shared line's droop under the air every
joint draws, gap.arm_effects), then the plant's physics steps, twin/kernel.py's `step_plant` as
`Plant.step` takes them. The drive angles and the port pressures at the platform (each hose's
valve-end node) are recorded every tick. With
nothing hidden, a twin run's commands replay to its own angles (tests/test_gap_arm.py).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

import assets
from gap.arm_campaign import ArmRun
from gap.arm_effects import ArmSetup, apply_setup, model_defaults
from pneumatics import JointParams
from pneumatics import params as P
from pneumatics._jit import njit
from pneumatics.joint import C_PV_SET_GAUGE_PA, S_DIR, S_PA_VALVE, S_PB_VALVE, S_PV, S_PV_SET, inlet_draw
from pneumatics.valves import valve_opening
from twin.kernel import MJ_STEP_ADDRESS, SUBSTEPS, borrow_plant, step_plant
from twin.model import SimulationError
from twin.plant import Plant

TICK_S = 1e-3  # the platform's control period (twin.sim.CONTROL_PERIOD_S): commands change at most this often


@njit
def shared_draw(x: np.ndarray, params: np.ndarray, supply_pa: float) -> float:
    """The air every joint's open inlet draws from the shared line, kg/s: through each proportional
    valve's opening from the pressure it delivers into the supplied port's valve node (as
    pneumatics.joint.effective_supply does for one joint's own droop: `inlet_draw`)."""
    total = 0.0
    for j in range(x.shape[0]):
        d = x[j, S_DIR]
        if d == 0.0:
            continue
        p = params[j]
        node = x[j, S_PA_VALVE] if d > 0 else x[j, S_PB_VALVE]
        opening = valve_opening(x[j, S_PV], p[P.K_U], p[P.DEAD_ZONE])
        total += inlet_draw(supply_pa, x[j, S_PV], opening, node, p)
    return total


@njit(nogil=True)
def _replay_ticks(
    mj_step_address,
    plant,  # twin/kernel.py's PlantArrays: the air advanced in place
    cmd,  # (n_joints, 3) the plant's commands (written each tick)
    row_time_s,  # (n_rows,)
    row_commands,  # (n_rows, n_joints, 3)
    row_supply_pa,  # (n_rows,)
    valve_is_output,
    droop_pa_s_per_kg,
    dt_s,
    substeps,
    steps_per_tick,
    tick_s,
    angle_out,  # (n_ticks + 1, n_joints) written
    port_out,  # (n_ticks + 1, n_joints, 2) written
):
    a = borrow_plant(plant)
    x, params, drive_map, qpos = a.air, a.params, a.drive_map, a.qpos
    n_joints = x.shape[0]
    row = 0
    n_rows = row_time_s.shape[0]
    atm = params[0, P.GAS_P_ATM]
    for k in range(angle_out.shape[0]):
        for j in range(n_joints):  # the tick's record: the state the tick's commands are issued in
            theta = 0.0
            for term in range(drive_map.shape[1]):
                theta += drive_map[j, term, 2] * qpos[int(drive_map[j, term, 0])]
            angle_out[k, j] = theta
            port_out[k, j, 0] = x[j, S_PA_VALVE]
            port_out[k, j, 1] = x[j, S_PB_VALVE]
        if k == angle_out.shape[0] - 1:
            break
        t = k * tick_s
        while row + 1 < n_rows and row_time_s[row + 1] <= t + 1e-9:
            row += 1
        for j in range(n_joints):
            for c in range(3):
                cmd[j, c] = row_commands[row, j, c]
            if valve_is_output:  # a logged valve output: the valve is where it was logged
                x[j, S_PV] = cmd[j, C_PV_SET_GAUGE_PA]
                x[j, S_PV_SET] = cmd[j, C_PV_SET_GAUGE_PA]
        supply = row_supply_pa[row]
        if droop_pa_s_per_kg > 0.0:
            supply = max(atm, supply - droop_pa_s_per_kg * shared_draw(x, params, supply))
        step_plant(mj_step_address, steps_per_tick, a, cmd, supply, dt_s, substeps)  # Plant.step


def arm_plant(params: dict[str, JointParams], setup: ArmSetup, start_rad: np.ndarray) -> Plant:
    """The plant with `params` and `setup`, at rest at the drive angles `start_rad` (assets.JOINTS
    order), brakes on: where a run of the twin (scenarios.runner.build_plant) starts."""
    plant = Plant(assets.SCENE_XML, joint_params=params, keyframe="home")
    m, d = plant.model, plant.data
    apply_setup(m, setup, model_defaults(m), plant.joints)
    d.qpos[:] = m.key("home").qpos
    d.qvel[:] = 0.0
    set_drive_angles(plant, start_rad)
    mujoco.mj_forward(m, d)
    plant.align_motors()
    return plant


def joint_angles(plant: Plant, drive_rad: np.ndarray) -> tuple[list[int], np.ndarray]:
    """(qpos addresses of the plant's joints, their angles) giving the drive coordinates `drive_rad`
    (the elbow's drive is shoulder + elbow): the drive map's linear equations solved for the
    joints' own coordinates; `drive_rad` (n_joints,) or (rows, n_joints)."""
    m = plant.model
    addresses = [int(m.joint(j).qposadr[0]) for j in plant.joints]
    a = np.zeros((len(addresses), len(addresses)))
    for i in range(len(plant.joints)):
        for q, _, c in plant.drive_map[i]:
            if c != 0.0:
                a[i, addresses.index(int(q))] += c
    return addresses, np.linalg.solve(a, np.asarray(drive_rad).T).T


def set_drive_angles(plant: Plant, drive_rad: np.ndarray) -> None:
    """Set the joints' qpos so that their drive coordinates are `drive_rad` (`joint_angles`)."""
    addresses, q = joint_angles(plant, drive_rad)
    plant.data.qpos[addresses] = q


@dataclass(frozen=True)
class Replay:
    """The twin's drive angles and platform port pressures every TICK_S from the run's start."""

    time_s: np.ndarray  # (m,)
    angle_rad: np.ndarray  # (m, n_joints)
    port_pa: np.ndarray  # (m, n_joints, 2)


def replay(run: ArmRun, params: dict[str, JointParams], setup: ArmSetup, t_end_s: float | None = None) -> Replay:
    """The twin with (`params`, `setup`) driven by the run's logged commands and supply."""
    plant = arm_plant(params, setup, run.start_rad)
    t_end = run.time_s[-1] if t_end_s is None else min(t_end_s, run.time_s[-1])
    n_ticks = int(t_end / TICK_S + 1e-9)
    steps = max(1, round(TICK_S / plant.dt))
    angle = np.empty((n_ticks + 1, len(plant.joints)))
    port = np.empty((n_ticks + 1, len(plant.joints), 2))
    if MJ_STEP_ADDRESS is None:
        raise RuntimeError("the arm replay needs MuJoCo's shared library and compiled code (twin.kernel.MJ_STEP)")
    _replay_ticks(
        MJ_STEP_ADDRESS,
        plant.arrays,
        plant.commands,
        np.ascontiguousarray(run.time_s),
        np.ascontiguousarray(run.commands),
        np.ascontiguousarray(run.supply_pa),
        run.valve_is_output,
        setup.supply_line_droop_pa_s_per_kg,
        plant.dt,
        SUBSTEPS,
        steps,
        TICK_S,
        angle,
        port,
    )
    try:
        plant.check_warnings()
    except SimulationError as e:
        raise SimulationError(f"replaying {run.name}: {e}") from None
    return Replay(np.arange(n_ticks + 1) * TICK_S, angle, port)


def main(duration_s: float = 10.0) -> None:
    """Replay cost per simulated second against the plant's own stepping in the same process."""
    from gap.arm_campaign import JOINTS

    n = int(duration_s / TICK_S) + 1
    t = np.arange(n) * TICK_S
    commands = np.zeros((n, len(JOINTS), 3))
    commands[:, :, 0] = np.where((t // 2) % 2 == 0, 1.0, -1.0)[:, None]
    commands[:, :, 1] = 0.5e6
    commands[:, :, 2] = 1.0
    start = np.array([0.0, math.pi / 2, -math.pi / 6, math.pi / 6, 0.0])
    nan = np.full((n, len(JOINTS)), np.nan)
    run = ArmRun("bench", None, start, t, commands, np.full(n, 101325.0 + 0.6e6), nan, np.stack([nan, nan], 2))
    from pneumatics import load_joint_params

    params = {j: load_joint_params(assets.joint_param_path(j)) for j in JOINTS}
    replay(run, params, ArmSetup(), 0.1)  # compile
    t0 = time.perf_counter()
    replay(run, params, ArmSetup())
    r = time.perf_counter() - t0
    plant = arm_plant(params, ArmSetup(), start)
    t0 = time.perf_counter()
    plant.step(int(duration_s / plant.dt))
    b = time.perf_counter() - t0
    print(
        f"replay {r / duration_s:.3f} s per simulated s; the plant stepping alone {b / duration_s:.3f}; "
        f"ratio {r / b:.2f}"
    )


if __name__ == "__main__":
    main()
