"""The commanded run on the wrist rig: the plant (twin.plant.Plant on assets/wrist_rig.xml, the
paper's single-joint bench) driven by a command timeline, open loop, as the platform sends it.

`Motion` is the timeline of one run (brake release and a start from rest, a move with the valve
fully open, a direct reversal at a partial opening, braking and holding); `simulate_run` plays a
Motion (or any timeline with `commands` and `total_s`) on the plant, with an optional hidden load
on the rig, and returns the 1 ms command rows with the true angle and chamber pressures;
`write_mcap_run` logs it with the twin's MCAP recorder instead. The one-joint model replays the
same command rows (wrist_rig.one_joint).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

import assets
from pneumatics import JointParams, load_joint_params
from pneumatics.gas import AIR
from twin.mcap_log import McapRecorder
from twin.plant import Plant
from twin.sim import CommandSchedule, run

JOINT = "wrist_pitch"
SAMPLE_PERIOD_S = 0.02  # the reference instrument: 50 Hz (slower than the 1 ms commands)
RIG_INERTIA_KG_M2 = 0.02  # assets/wrist_rig.xml rig_load


@dataclass(frozen=True)
class Motion:
    """Command timeline of one run (times in s). The first move's valve set point is the supply
    itself (fully open, delivering the supply); the reversal's is opening_2 / k_u (a partial
    opening that also regulates the delivered pressure down to it)."""

    direction: int = 1  # first move's direction
    t_release_s: float = 0.1  # brake release + first move starts
    t_move_s: float = 0.5  # duration of the first move (fully open)
    t_reverse_s: float = 0.6  # duration of the reversed move
    opening_2: float = 0.95
    t_hold_s: float = 0.6  # braking + holding
    duration_s: float = 0.0  # 0: the sum of the phases

    def total_s(self) -> float:
        return self.duration_s or self.t_release_s + self.t_move_s + self.t_reverse_s + self.t_hold_s

    def commands(
        self, t_s: np.ndarray, supply_gauge_pa: float, k_u_per_pa: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(direction, valve set point gauge Pa, brake_release) at the given times."""
        t1 = self.t_release_s
        t2 = t1 + self.t_move_s
        t3 = t2 + self.t_reverse_s
        d = np.zeros_like(t_s)
        u = np.zeros_like(t_s)
        b = np.zeros_like(t_s)
        first = (t_s >= t1 - 1e-9) & (t_s < t2 - 1e-9)
        second = (t_s >= t2 - 1e-9) & (t_s < t3 - 1e-9)
        d[first] = self.direction
        u[first] = supply_gauge_pa
        d[second] = -self.direction
        u[second] = self.opening_2 / k_u_per_pa
        b[first | second] = 1.0
        return d, u, b


def wrist_params() -> JointParams:
    """The nominal wrist's parameters (assets/joints: the joint file of JOINT)."""
    return load_joint_params(assets.joint_param_path(JOINT))


def _plant_and_schedule(
    reality: JointParams,
    supply_mpa: float,
    motion: Motion,
    start_rad: float,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
):
    plant = Plant(assets.WRIST_RIG_XML, joint_params={JOINT: reality})
    i = plant.joints.index(JOINT)
    # a hidden angle-dependent load: MuJoCo's own joint spring (passive force -k (q - qpos_spring),
    # qpos_spring = 0 from the model's reference pose), not the replay's law
    plant.model.jnt_stiffness[plant.model.joint(JOINT).id] = rig_spring_nm_per_rad
    # and a hidden static load the same at every angle: MuJoCo's applied joint force, which mj_step
    # keeps (the plant applies its drive as actuator forces), toward negative angles for a positive load
    plant.data.qfrc_applied[plant.model.joint(JOINT).dofadr[0]] = -rig_load_nm
    plant.data.qpos[plant.model.joint(JOINT).qposadr[0]] = start_rad
    mujoco.mj_forward(plant.model, plant.data)
    plant.align_motors()
    plant.set_supply(AIR.p_atm_pa + supply_mpa * 1e6)
    k_u = reality.k_u_per_pa
    n = len(plant.joints)

    def commands_at(t: float) -> np.ndarray:
        d, u, b = motion.commands(np.array([t]), supply_mpa * 1e6, k_u)
        c = np.zeros((n, 3))
        c[i] = (d[0], u[0], b[0])
        return c

    return plant, CommandSchedule(commands_at, n), i


def simulate_run(
    reality: JointParams,
    supply_mpa: float,
    motion: Motion,
    start_rad: float = 0.0,
    log_period_s: float = SAMPLE_PERIOD_S,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
) -> dict[str, np.ndarray]:
    """Run the plant (twin.plant.Plant on the wrist rig) through `motion` (a Motion, or any timeline
    with `commands` and `total_s`); 1 ms command rows and the true angle and chamber pressures every
    `log_period_s` (NaN between samples)."""
    plant, schedule, i = _plant_and_schedule(reality, supply_mpa, motion, start_rad, rig_spring_nm_per_rad, rig_load_nm)
    supply_pa = plant.supply_pa
    tel = run(plant, schedule, motion.total_s(), supply=supply_pa, log_period_s=log_period_s)
    arr = tel.arrays()
    t_cmd = np.round(np.arange(0.0, motion.total_s() + 1e-9, 1e-3), 6)
    d, u, b = motion.commands(t_cmd, supply_mpa * 1e6, reality.k_u_per_pa)
    idx = np.round(np.asarray(arr["time_s"]) / 1e-3).astype(int)
    ok = idx < len(t_cmd)
    sampled = {}
    for out, column in (("angle_rad", "true_angle_rad"), ("p_a_pa", "pressure_a_pa"), ("p_b_pa", "pressure_b_pa")):
        sampled[out] = np.full(t_cmd.shape, np.nan)
        sampled[out][idx[ok]] = np.asarray(arr[column])[ok, i]
    return {
        "time_s": t_cmd,
        "direction": d,
        "brake_released": b,
        "valve_set_gauge_pa": u,
        "supply_pa": np.full(t_cmd.shape, supply_pa),
        **sampled,
    }


def write_mcap_run(
    path: Path, reality: JointParams, supply_mpa: float, motion: Motion | None = None, start_rad: float = 0.0
) -> Path:
    """Run the plant through `motion` and log it with the twin's own MCAP recorder
    (twin.mcap_log.McapRecorder, a sample every 20 ms): a run file the campaign reader accepts."""
    motion = motion or Motion()
    plant, schedule, _ = _plant_and_schedule(reality, supply_mpa, motion, start_rad)
    rec = McapRecorder(path, plant.model, plant.joints, {"scenario_name": "gap synthetic run", "seed": 0})
    try:
        run(plant, schedule, motion.total_s(), recorders=(rec,))
    finally:
        rec.close()
    return Path(path)
