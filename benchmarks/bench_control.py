"""Speed of the controller: one control tick for all five joints (predictor + PID + Pinocchio load)
beside bare MuJoCo mj_step of the scene, alternating over `rounds`, each figure the median with its
min-max (the ratio within each round). Goal: tick < 20 us. The whole twin's speed is
benchmarks/bench_twin.py's (the cleaning scenario whole, against bare MuJoCo on the same motion)."""

from __future__ import annotations

import json
import math
import time

import mujoco

import assets
from benchmarks.stats import spread
from control import ArmController
from twin.plant import Plant


def bench_control(n_ticks: int = 3000, rounds: int = 5) -> dict:
    plant = Plant(assets.SCENE_XML)
    start = dict(zip(plant.joints, plant.drive_angles(), strict=True))
    c = ArmController(start)
    c.set_targets(
        [{"base_yaw": math.radians(60.0), "wrist_pitch": start["wrist_pitch"] - math.radians(40.0)}],
        sequence="together",
    )
    s = plant.sensors()
    c.tick(s)  # compile
    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    d = mujoco.MjData(m)
    tick_us, step_us = [], []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(n_ticks):
            c.tick(s)
        tick_us.append((time.perf_counter() - t0) / n_ticks * 1e6)
        t0 = time.perf_counter()
        for _ in range(n_ticks):
            mujoco.mj_step(m, d)
        step_us.append((time.perf_counter() - t0) / n_ticks * 1e6)
    return {
        "rounds": rounds,
        "tick_us": spread(tick_us),
        "mj_step_us": spread(step_us),
        "tick_over_mj_step": spread([t / s for t, s in zip(tick_us, step_us, strict=True)]),
    }


if __name__ == "__main__":
    print(json.dumps(bench_control(), indent=1))
