"""The cost of judging forces at the physics rate: the plant's physics step with the brush's touch
sensor (computed inside each mj_step, its peak kept by the compiled step loop: twin/plant.py)
against the same scene without the sensor (no peak kept), stepped in turn in this process, with the
arm moving in the air and pressed 25 mm into a disc's rim."""

from __future__ import annotations

import time

import mujoco

import assets
from benchmarks.stats import spread
from scenarios.ik import disc_drive_angles, drive_to_qpos
from twin.plant import Plant


def _plant(sensor: bool, pressed: bool) -> Plant:
    spec = mujoco.MjSpec.from_file(str(assets.SCENE_XML))
    if not sensor:
        spec.delete(spec.sensor("brush_touch"))
    plant = Plant(spec)
    if pressed:
        for joint, q in drive_to_qpos(disc_drive_angles(plant.model, 4, -0.025)).items():
            plant.data.joint(joint).qpos[0] = q
        mujoco.mj_forward(plant.model, plant.data)
    plant.commands[:, 0], plant.commands[:, 1], plant.commands[:, 2] = 1.0, 3e5, 1.0  # valves open, brakes off
    plant.set_supply(0.7e6)
    return plant


def bench_force_rate(steps: int = 2000, rounds: int = 7) -> dict:
    """us per physics step without and with the sensor, and their ratio, median (min-max) over
    `rounds` of `steps` steps each, both plants stepped in turn."""
    out = {"steps": steps, "rounds": rounds}
    for case, pressed in (("moving", False), ("pressed", True)):
        plants = {"without": _plant(False, pressed), "with": _plant(True, pressed)}
        times: dict[str, list[float]] = {k: [] for k in plants}
        for p in plants.values():
            p.step(200, check_warnings=False)  # warm: the kernels loaded, the contact made
        for _ in range(rounds):
            for k, p in plants.items():
                t0 = time.perf_counter()
                p.step(steps, check_warnings=False)
                times[k].append((time.perf_counter() - t0) / steps * 1e6)
        out[case] = {
            "without_sensor_us_per_step": spread(times["without"]),
            "with_sensor_us_per_step": spread(times["with"]),
            "ratio": spread([w / o for w, o in zip(times["with"], times["without"], strict=True)]),
        }
    return out
