"""Speed of the controller: one control tick for all five joints (predictor + PID + Pinocchio load)
beside bare MuJoCo mj_step of the scene in the same run, and the whole twin (Plant(SCENE_XML) +
ArmController, no logging) as a multiple of real time. Goals: tick < 20 us, twin >= 50x real time."""

from __future__ import annotations

import json
import math
import time

import mujoco

import assets
from control import ArmController, run_until_done
from twin.plant import Plant


def bench_control(n_ticks: int = 3000, sim_s: float = 3.0) -> dict:
    plant = Plant(assets.SCENE_XML)
    start = dict(zip(plant.joints, plant.drive_angles(), strict=True))
    c = ArmController(start)
    c.set_targets(
        [{"base_yaw": math.radians(60.0), "wrist_pitch": start["wrist_pitch"] - math.radians(40.0)}],
        sequence="together",
    )
    s = plant.sensors()
    c.tick(s)  # compile
    t0 = time.perf_counter()
    for _ in range(n_ticks):
        c.tick(s)
    tick_us = (time.perf_counter() - t0) / n_ticks * 1e6
    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    d = mujoco.MjData(m)
    t0 = time.perf_counter()
    for _ in range(n_ticks):
        mujoco.mj_step(m, d)
    step_us = (time.perf_counter() - t0) / n_ticks * 1e6
    Plant(assets.SCENE_XML).step(
        1
    )  # load the compiled plant once, as the tick was above (`twin bench` runs the plant benchmark first)
    plant = Plant(assets.SCENE_XML)
    c = ArmController(start)
    c.set_targets([{"base_yaw": math.radians(30.0)}, {"wrist_pitch": start["wrist_pitch"] - math.radians(30.0)}])
    t0 = time.perf_counter()
    simulated = run_until_done(c, plant, 101_325.0 + 0.6e6, max_s=sim_s, settle_s=sim_s)
    wall = time.perf_counter() - t0
    return {
        "tick_us": tick_us,
        "mj_step_us": step_us,
        "tick_over_mj_step": tick_us / step_us,
        "twin_real_time_factor": simulated / wall,
        "simulated_s": simulated,
    }


if __name__ == "__main__":
    print(json.dumps(bench_control(), indent=1))
