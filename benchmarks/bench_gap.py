"""Cost of the gap diagnosis: one `twin gap diagnose` of a 16-run campaign against the whole
catalogue (goal: within 60 s on the 2-core machine), and the speed of the compiled one-joint
replay the effect search is built on, against the plant's (MuJoCo + pneumatics) simulation of the
very same run as the in-run baseline.

The campaign is 4 supplies x 4 repeats (angle and both chamber pressures) from the plant with a hidden vane leak + Coulomb friction
(a pair: the single effects do not explain it, so the pair search runs too, the slow path). The
diagnosis is timed through the command line entry point (reading the files, the fits, the report
and the plots), after a warm-up replay so that loading numba's cache is not counted.

    PYTHONPATH=. python -m benchmarks.bench_gap [--jobs 2] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

import assets
from gap import synth
from gap.campaign import load_campaign
from gap.diagnose import Twin
from gap.replay import DT_S, replay_run
from pneumatics import params_row
from twin.plant import Plant
from twin.sim import CommandSchedule, run

HIDDEN = {"leak_area_m2": 3e-7, "coulomb_nm": 30.0}  # the bench's pair case (gap/bench.py)


def _time_replay(twin: Twin, rounds: int) -> float:
    """Best wall time (s) of one replay of run 0 through the compiled twin."""
    pr = twin.runs[0]
    p = params_row(twin.params)
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(20):
            replay_run(p, *pr.args, pr.run.start_rad, pr.inertia, 0.0, pr.run.time_s[-1], DT_S)
        best = min(best, (time.perf_counter() - t0) / 20)
    return best


def _time_plant(reality, supply_mpa: float, motion: synth.Motion, rounds: int) -> float:
    """Best wall time (s) of the plant simulating the same run (twin.sim.run on the wrist rig)."""
    best = np.inf
    for _ in range(rounds):
        plant = Plant(assets.WRIST_RIG_XML, joint_params={synth.JOINT: reality})
        plant.set_supply(101_325.0 + supply_mpa * 1e6)
        i = plant.joints.index(synth.JOINT)
        n = len(plant.joints)

        def commands_at(t: float) -> np.ndarray:
            d, u, b = motion.commands(np.array([t]), supply_mpa * 1e6, reality.k_u_per_pa)
            c = np.zeros((n, 3))
            c[i] = (d[0], u[0], b[0])
            return c

        t0 = time.perf_counter()
        run(plant, CommandSchedule(commands_at, n), motion.total_s(), log_period_s=synth.SAMPLE_PERIOD_S)
        best = min(best, time.perf_counter() - t0)
    return best


def bench_gap(jobs: int = 2, rounds: int = 3) -> dict:
    from twin.cli import main

    reality = synth.wrist_params()._replace(**HIDDEN)
    with tempfile.TemporaryDirectory() as tmp:
        folder = synth.make_campaign(Path(tmp) / "c16", reality, seed=7, pressures_mpa=synth.PRESSURES_MPA, repeats=4, description="(bench_gap: leak + Coulomb)", chamber_pressures=True)
        campaign = load_campaign(folder)
        twin = Twin(campaign)
        replay_s = _time_replay(twin, rounds)  # also the warm-up
        t0 = time.perf_counter()
        code = main(["gap", "diagnose", str(folder), "--out", str(Path(tmp) / "out"), "--jobs", str(jobs)])
        diag_s = time.perf_counter() - t0
        d = json.loads((Path(tmp) / "out" / "diagnosis.json").read_text())
    plant_s = _time_plant(reality, synth.PRESSURES_MPA[0], synth.Motion(), rounds)
    return {
        "campaign_runs": len(campaign.runs),
        "run_duration_s": synth.Motion().total_s(),
        "diagnose_exit_code": code,
        "diagnose_wall_s": diag_s,
        "diagnose_goal_s": 60.0,
        "verdict": d["which"]["verdict"],
        "top": d["which"]["top"]["name"] if d["which"]["top"] else None,
        "jobs": jobs,
        "replay_s_per_run": replay_s,
        "plant_s_per_run": plant_s,
        "replays_per_s": 1.0 / replay_s,
        "plant_runs_per_s": 1.0 / plant_s,
        "replay_over_plant_speed_ratio": plant_s / replay_s,
    }


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    print(json.dumps(bench_gap(a.jobs, a.rounds), indent=1))
