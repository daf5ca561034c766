"""Cost of the pneumatic actuators: plant steps per second against bare MuJoCo on the same MJCF.

Both sides step assets/scene.xml's model (the very same MjModel, so the same tendon friction,
armature and damping, hence the same constraint rows). The plant runs `Plant.step` (the air of
every joint, then mj_step, in compiled code); the baseline runs `mujoco.mj_step(m, d, nstep)` with
plain motors at a constant ctrl. Two cases: one joint moving (the others braked and idle: the
usual operation) and all five moving. Moving joints reverse every 0.25 s on both sides so that
nothing rests on an end stop. Measurements alternate plant/baseline over several rounds; each
figure is the median over the rounds with its min-max, the ratio taken within each round.
The goal (DESIGN) is ratio >= 0.8.

Also reported, so that a poor ratio can be traced to the air or to MuJoCo: the air kernel alone
(`pneumatic_step` over all joints, without mj_step) fed the joint motion and commands the plant
recorded in a measured run, so it meets the same flows, branches and pressures; and MuJoCo alone
replaying that run's recorded torques and friction (`replay_steps`: the same trajectory, so the
same constraint work as inside the plant).

The same two cases also run with every hose a line that carries waves (`hose_model = 1`,
pneumatics/line.py: "one_line", "all_line"), and so with the chambers by their energy balance too
(`chamber_heat = 1`: "one_line_heat", "all_line_heat"), so the lines' cost is a ratio measured in the
same run.

With --as-built the same two cases also run with the as-built arm's parameters (the plant of
scenarios and `twin paper`: reducer compliance, leakage, ... from assets/as_built/), so the cost of
reality's extra effects is a ratio measured in the same run.

    PYTHONPATH=. python -m benchmarks.bench_plant [--seconds 2] [--rounds 5] [--as-built] [--cpu-time]
"""

from __future__ import annotations

import argparse
import json
from typing import NamedTuple

import mujoco
import numpy as np

import assets
from benchmarks.stats import clock, spread, use_cpu_time
from pneumatics import load_joint_params
from pneumatics._jit import borrowed, njit
from pneumatics.as_built import load_as_built
from twin.kernel import SUBSTEPS, borrow_plant, pneumatic_step, replay_steps
from twin.plant import Plant

SUPPLY_PA = 101_325.0 + 0.5e6  # the paper's 0.5 MPa gauge
REVERSE_S = 0.25  # moving joints reverse this often


def _moving(case: str, joints: tuple[str, ...]) -> tuple[str, ...]:
    return ("wrist_pitch",) if case == "one" else joints


def _plant_for(case: str, as_built: bool = False, line: bool = False, heat: bool = False) -> Plant:
    params = {j: load_joint_params(assets.joint_param_path(j)) for j in assets.JOINTS}
    if as_built:
        params = {j: load_as_built(p, assets.as_built_path(j)) for j, p in params.items()}
    if line:  # every hose a line that carries waves (pneumatics/line.py)
        params = {j: p._replace(hose_model=1.0) for j, p in params.items()}
    if heat:  # the chambers by their energy balance (pneumatics/chamber.py)
        params = {j: p._replace(chamber_heat=1.0) for j, p in params.items()}
    plant = Plant(assets.SCENE_XML, params)
    plant.set_supply(SUPPLY_PA)
    for j in _moving(case, plant.joints):
        plant.command(j, +1, 0.5e6, True)
    plant.step(200)  # brakes released, valves switched: the steady operating condition
    return plant


def _drive(plant: Plant, moving: tuple[str, ...], direction: int) -> None:
    for j in moving:
        plant.command(j, direction, 0.5e6, True)


def _stretches(plant: Plant, moving, seconds: float):
    """The benchmark's motion: the moving joints driven one way, then the other, every REVERSE_S;
    yields the physics steps of each stretch once its commands are set."""
    chunk = int(round(REVERSE_S / plant.dt))
    for c in range(max(1, int(round(seconds / REVERSE_S)))):
        _drive(plant, moving, +1 if c % 2 == 0 else -1)
        yield chunk


def _time_plant(plant: Plant, start, moving, seconds: float) -> tuple[float, int]:
    plant.restore_state(start)
    steps = 0
    t0 = clock()
    for chunk in _stretches(plant, moving, seconds):
        plant.step(chunk)
        steps += chunk
    return clock() - t0, steps


def _time_bare(
    m: mujoco.MjModel, d: mujoco.MjData, start: np.ndarray, ctrl: np.ndarray, seconds: float
) -> tuple[float, int]:
    mujoco.mj_setState(m, d, start, mujoco.mjtState.mjSTATE_INTEGRATION)
    chunk = int(round(REVERSE_S / m.opt.timestep))
    n_chunks = max(1, int(round(seconds / REVERSE_S)))
    t0 = clock()
    for c in range(n_chunks):
        d.ctrl[:] = ctrl if c % 2 == 0 else -ctrl
        mujoco.mj_step(m, d, chunk)
    return clock() - t0, n_chunks * chunk


class _PlantSteps(NamedTuple):
    """What one measured run of the plant met, physics step by physics step."""

    qpos: np.ndarray  # (steps, nq) at the step's start
    qvel: np.ndarray
    commands: np.ndarray  # (steps, n_joints, N_COMMAND)
    ctrl: np.ndarray  # (steps, n_joints) the joints' torques MuJoCo held over the step
    frictionloss: np.ndarray  # (steps, n_joints) their dry friction


def _record(plant: Plant, start, moving, seconds: float) -> _PlantSteps:
    # the motion `_time_plant` times, one step at a time
    plant.restore_state(start)
    d, m = plant.data, plant.model
    rows: dict[str, list] = {name: [] for name in _PlantSteps._fields}
    for chunk in _stretches(plant, moving, seconds):
        for _ in range(chunk):
            rows["qpos"].append(d.qpos.copy())
            rows["qvel"].append(d.qvel.copy())
            rows["commands"].append(plant.commands.copy())
            plant.step(1, check_warnings=False)
            rows["ctrl"].append(d.ctrl[plant.actuator_ids].copy())
            rows["frictionloss"].append(m.tendon_frictionloss[plant.tendon_ids].copy())
    return _PlantSteps(*(np.array(rows[name]) for name in _PlantSteps._fields))


@njit(cache=False)
def _kernel_only(a, commands, supply_pa, dt, substeps, q, v):
    # as twin/kernel.py's step_plant runs it (the arrays borrowed, without reference counting),
    # each step at the recorded joint motion and commands instead of after an mj_step
    a = borrow_plant(a)
    commands, q, v = borrowed(commands), borrowed(q), borrowed(v)
    for i in range(q.shape[0]):
        a.qpos[:] = q[i]
        a.qvel[:] = v[i]
        pneumatic_step(a, commands[i], supply_pa, dt, substeps)


def _time_kernel(plant: Plant, start, rec: _PlantSteps) -> float:
    # the plant's arrays, MuJoCo's own copied (the kernel writes ctrl and friction, reads qpos, qvel)
    mujoco_copies = {f: getattr(plant.arrays, f).copy() for f in ("qpos", "qvel", "ctrl", "tendon_frictionloss")}

    def run(n: int) -> float:
        a = plant.arrays._replace(air=start.air.copy(), **mujoco_copies)
        t0 = clock()
        _kernel_only(a, rec.commands[:n], plant.supply_pa, plant.dt, SUBSTEPS, rec.qpos[:n], rec.qvel[:n])
        return clock() - t0

    run(10)  # compile
    return run(len(rec.qpos)) / len(rec.qpos)


def _time_replay(plant: Plant, start, rec: _PlantSteps) -> float:
    # MuJoCo alone on the plant's trajectory: its recorded torques and friction, from the same state
    m = plant.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, start.mujoco_state, mujoco.mjtState.mjSTATE_INTEGRATION)
    saved_frictionloss = m.tendon_frictionloss.copy()
    t0 = clock()
    replay_steps(
        m._address,
        d._address,
        d.ctrl,
        m.tendon_frictionloss,
        plant.actuator_ids,
        plant.tendon_ids,
        rec.ctrl,
        rec.frictionloss,
    )
    elapsed = clock() - t0
    m.tendon_frictionloss[:] = saved_frictionloss
    return elapsed / len(rec.ctrl)


def bench_plant(seconds: float = 2.0, rounds: int = 5, as_built: bool = False) -> dict:
    """Steps per second of the plant and of bare MuJoCo on the same model, and their ratio; the cases
    "one_line", "all_line" with every hose a line (hose_model = 1), "one_line_heat", "all_line_heat" with
    the chambers' energy balance too (chamber_heat = 1); with `as_built`, also "one_as_built",
    "all_as_built" on the as-built arm."""
    out: dict = {"seconds_simulated_per_measurement": seconds, "rounds": rounds, "goal_ratio": 0.8}
    cases = ("one", "all", "one_line", "all_line", "one_line_heat", "all_line_heat") + (
        ("one_as_built", "all_as_built") if as_built else ()
    )
    for label in cases:
        case = label.split("_")[0]
        plant = _plant_for(case, label.endswith("as_built"), "_line" in label, label.endswith("_heat"))
        moving = _moving(case, plant.joints)
        start = plant.save_state()
        m = plant.model  # the same model: same frictionloss, armature, damping
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, start.mujoco_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        ctrl = np.zeros(m.nu)
        for j in moving:
            i = plant.joints.index(j)
            # enough to overcome the joint's Coulomb friction (the plant's brakes are released)
            ctrl[plant.actuator_ids[i]] = 2.0 * m.tendon_frictionloss[plant.tendon_ids[i]] + 10.0
        bare_start = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
        mujoco.mj_getState(m, d, bare_start, mujoco.mjtState.mjSTATE_INTEGRATION)
        _time_plant(plant, start, moving, REVERSE_S)  # warm-up (compilation)
        rec = _record(plant, start, moving, seconds)
        _time_replay(plant, start, rec), _time_kernel(plant, start, rec)  # warm-up
        plant_s, bare_s, replay_s, kernel_s = [], [], [], []
        steps = 0
        for _ in range(rounds):
            dt_plant, steps = _time_plant(plant, start, moving, seconds)
            saved_frictionloss = m.tendon_frictionloss.copy()
            dt_bare, _ = _time_bare(m, d, bare_start, ctrl, seconds)
            m.tendon_frictionloss[:] = saved_frictionloss
            plant_s.append(dt_plant / steps)
            bare_s.append(dt_bare / steps)
            replay_s.append(_time_replay(plant, start, rec))
            kernel_s.append(_time_kernel(plant, start, rec))
        out[label] = {
            "moving_joints": list(moving),
            "steps": steps,
            "ratio": spread([b / p for p, b in zip(plant_s, bare_s, strict=True)]),
            # the same against MuJoCo on the plant's own trajectory (bench_twin's kind of baseline):
            # the plant's motion costs MuJoCo more constraint work than the baseline's constant torque
            "ratio_to_mujoco_on_plant_motion": spread([r / p for p, r in zip(plant_s, replay_s, strict=True)]),
            "plant_us_per_step": spread([1e6 * t for t in plant_s]),
            "bare_us_per_step": spread([1e6 * t for t in bare_s]),
            # where the plant's step goes: MuJoCo on the plant's own trajectory, and the air
            "mujoco_on_plant_motion_us_per_step": spread([1e6 * t for t in replay_s]),
            "air_kernel_us_per_step": spread([1e6 * t for t in kernel_s]),
        }
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    parser.add_argument("--rounds", type=int, default=5, help="alternating plant/baseline rounds (median, min-max)")
    parser.add_argument(
        "--as-built", action="store_true", help="also the as-built arm's plant (reality of scenarios and twin paper)"
    )
    parser.add_argument(
        "--cpu-time", action="store_true", help="time by CPU time, not the wall clock (a shared machine)"
    )
    args = parser.parse_args(argv)
    if args.cpu_time:
        use_cpu_time()
    print(json.dumps(bench_plant(args.seconds, args.rounds, args.as_built), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
