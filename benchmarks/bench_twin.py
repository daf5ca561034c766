"""Speed of the whole twin on a whole scenario run, against bare MuJoCo stepping the same scene
through the same motion, both measured in the same run.

The twin: `run_scenario` of the insulator-cleaning task (plant, controller, the operator and the
task, telemetry; logging off), timed whole, set-up and judging included. The baseline: MuJoCo
alone on the same model from the same initial state, each physics step given the ctrl (joint
torques) and tendon friction (brakes) the plant's air gave it in that run, recorded once
beforehand: the same motion, the same contacts, the same constraint rows, without the air, the
controller or anything else. That it is the same motion is checked: the replay must end in the
twin's final qpos bit for bit. Rounds alternate twin and baseline; every figure is the median
over the rounds with its min-max, the ratio taken within each round.

    PYTHONPATH=. python -m benchmarks.bench_twin [--seconds S] [--rounds 3] [--cpu-time]
"""

from __future__ import annotations

import argparse
import copy
import json
from dataclasses import dataclass

import mujoco
import numpy as np

import scenarios.runner
from benchmarks.stats import clock, spread, use_cpu_time
from scenarios.runner import run_scenario, scenario_files
from scenarios.schema import Scenario, load
from twin.kernel import replay_steps
from twin.plant import Plant

SCENARIO = next(p for p in scenario_files() if p.stem == "insulator_cleaning")
STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclass
class RecordedMotion:
    """What the plant gave MuJoCo over a run: the model and MuJoCo state at the first step, and
    per physics step the actuators' ctrl and the drive tendons' friction; the final qpos; the run's
    summary (`twin run --json`'s)."""

    model: mujoco.MjModel
    start: np.ndarray
    actuator_ids: np.ndarray
    tendon_ids: np.ndarray
    ctrl: np.ndarray
    frictionloss: np.ndarray
    final_qpos: np.ndarray
    summary: dict


def record_motion(scenario: Scenario, duration_s: float) -> RecordedMotion:
    """Run the scenario once with its plant stepping one physics step at a time (the same
    results: the kernel's state lives in the arrays) and record what each step was given."""
    plants, start, ctrl, friction = [], [], [], []
    build = scenarios.runner.build_plant

    def recording_plant(s: Scenario) -> Plant:
        plant = build(s)
        plants.append(plant)

        def step(n: int = 1, check_warnings: bool = True) -> None:
            if not start:
                buf = np.empty(mujoco.mj_stateSize(plant.model, STATE))
                mujoco.mj_getState(plant.model, plant.data, buf, STATE)
                start.append((copy.deepcopy(plant.model), buf))
            for _ in range(n):
                Plant.step(plant, 1, check_warnings=False)
                ctrl.append(plant.data.ctrl[plant.actuator_ids].copy())
                friction.append(plant.model.tendon_frictionloss[plant.tendon_ids].copy())
            if check_warnings:
                plant.check_warnings()

        plant.step = step
        plant.allow_compiled_ticks = False  # every step through `step`, recorded
        return plant

    scenarios.runner.build_plant = recording_plant
    try:
        summary = run_scenario(scenario, duration_s=duration_s).summary()
    finally:
        scenarios.runner.build_plant = build
    plant, (model, state) = plants[0], start[0]
    return RecordedMotion(
        model,
        state,
        plant.actuator_ids,
        plant.tendon_ids,
        np.array(ctrl),
        np.array(friction),
        plant.data.qpos.copy(),
        summary,
    )


def replay(motion: RecordedMotion) -> tuple[float, bool]:
    """(wall s, ended in the twin's final qpos) of bare MuJoCo stepping the recorded motion."""
    m = motion.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, motion.start, STATE)
    args = (m._address, d._address, d.ctrl, m.tendon_frictionloss, motion.actuator_ids, motion.tendon_ids)
    t0 = clock()
    replay_steps(*args, motion.ctrl, motion.frictionloss)
    wall = clock() - t0
    return wall, bool(np.array_equal(d.qpos, motion.final_qpos))


def bench_twin(seconds: float | None = None, rounds: int = 3) -> dict:
    """The whole twin against bare MuJoCo on the cleaning scenario (`seconds`: cut short; None:
    the scenario's whole duration)."""
    scenario = load(SCENARIO)
    duration = scenario.duration_s if seconds is None else seconds
    run_scenario(scenario, duration_s=0.01)  # imports and compiled kernels loaded
    motion = record_motion(scenario, duration)
    simulated = len(motion.ctrl) * motion.model.opt.timestep
    twin_s, bare_s, same = [], [], []
    for _ in range(rounds):
        t0 = clock()
        run_scenario(scenario, duration_s=duration)
        twin_s.append(clock() - t0)
        wall, ended_same = replay(motion)
        bare_s.append(wall)
        same.append(ended_same)
    return {
        "scenario": SCENARIO.stem,
        "simulated_s": round(simulated, 3),
        "rounds": rounds,
        "twin_real_time_factor": spread([simulated / w for w in twin_s]),
        "bare_mujoco_real_time_factor": spread([simulated / w for w in bare_s]),
        "twin_over_bare_mujoco_speed": spread([b / t for t, b in zip(twin_s, bare_s, strict=True)]),
        "twin_us_per_physics_step": spread([w / len(motion.ctrl) * 1e6 for w in twin_s]),
        "bare_mj_step_us": spread([w / len(motion.ctrl) * 1e6 for w in bare_s]),
        "bare_replay_is_the_same_motion": all(same),
    }


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=None)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cpu-time", action="store_true", help="time by CPU time, not the wall clock (a shared machine)")
    a = ap.parse_args()
    if a.cpu_time:
        use_cpu_time()
    print(json.dumps(bench_twin(a.seconds, a.rounds), indent=1))
