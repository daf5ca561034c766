"""A telemetry sample as one row, in compiled code (twin/telemetry.py's `layout`).

`twin.sim.sample` takes a sample in Python: the plant's truth beside the controller's belief. In a
run of compiled ticks (twin/compiled_loop.py) the same values lie in the arrays the ticks work on,
so `fill_row` writes them into a row there, and the run's `on_tick` appends that row whole; only
the brush's contact forces, which MuJoCo gives per contact (`mj_contactForce`), are left to Python,
and only while MuJoCo has a contact at all. The row holds the same numbers `sample` gives, bit for
bit (tests/test_compiled_loop.py compares whole runs).
"""

from __future__ import annotations

import math

import numpy as np

from control.pid import M_TARGET
from pneumatics import joint as J
from pneumatics._jit import borrowed, njit

# the signals of a row, in order (twin.telemetry: "time_s", then SIGNALS); `fill_row` writes them so
ROW_SIGNALS = (
    "time_s",
    "true_angle_rad",
    "predicted_angle_rad",
    "target_angle_rad",
    "pressure_a_pa",
    "pressure_b_pa",
    "valve_gauge_pa",
    "direction",
    "brake_release",
    "brake_engagement",
    "supply_pa",
    "brush_force_n",
    "brush_contact_m",
    "brush_push_n",
    "brush_peak_n",
    "body_pos_m",
    "body_quat_wxyz",
)


@njit
def fill_row(
    row: np.ndarray,  # (width,) written
    time_s: float,
    qpos: np.ndarray,
    drive_map: np.ndarray,  # Plant.drive_map: per joint (qpos address, dof address, coefficient) terms
    y: np.ndarray,  # the predictor's one-joint states
    moves: np.ndarray,  # the controller's moves (M_TARGET: the target)
    air: np.ndarray,
    sensor_bias_pa: np.ndarray,
    commands: np.ndarray,  # the plant's commands, just issued
    supply_pa: float,
    xpos: np.ndarray,
    xquat: np.ndarray,
) -> None:
    """The sample `twin.sim.sample` takes of an ArmController's run, the brush clear of everything
    (no force, no contact point, no push): the caller overwrites those where MuJoCo has contacts."""
    row, qpos, drive_map, y, moves = borrowed(row), borrowed(qpos), borrowed(drive_map), borrowed(y), borrowed(moves)
    air, sensor_bias_pa, commands = borrowed(air), borrowed(sensor_bias_pa), borrowed(commands)
    xpos, xquat = borrowed(xpos), borrowed(xquat)
    n = air.shape[0]
    row[0] = time_s
    k = 1
    for j in range(n):  # Plant.drive_angles: numpy's sum, term by term from the first
        angle = drive_map[j, 0, 2] * qpos[int(drive_map[j, 0, 0])]
        for term in range(1, drive_map.shape[1]):
            angle += drive_map[j, term, 2] * qpos[int(drive_map[j, term, 0])]
        row[k + j] = angle
    k += n
    for j in range(n):
        row[k + j] = y[j, J.R_THETA]
        row[k + n + j] = moves[j, M_TARGET]
        row[k + 2 * n + j] = air[j, J.S_PA_MOTOR]
        row[k + 3 * n + j] = air[j, J.S_PB_MOTOR]
        row[k + 4 * n + j] = air[j, J.S_PV] + sensor_bias_pa[j]
        row[k + 5 * n + j] = commands[j, J.C_DIRECTION]
        row[k + 6 * n + j] = commands[j, J.C_BRAKE_RELEASE]
        row[k + 7 * n + j] = air[j, J.S_BRAKE]
    k += 8 * n
    row[k] = supply_pa
    row[k + 1] = 0.0
    for i in range(3):
        row[k + 2 + i] = math.nan
        row[k + 5 + i] = 0.0
    row[k + 8] = 0.0  # the physics steps' peak force: Python's, from the plant (Plant.take_force_peak)
    k += 9
    for body in range(1, xpos.shape[0]):
        for i in range(3):
            row[k] = xpos[body, i]
            k += 1
    for body in range(1, xquat.shape[0]):
        for i in range(4):
            row[k] = xquat[body, i]
            k += 1
