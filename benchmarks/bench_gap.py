"""Cost of the gap diagnosis: `twin gap diagnose` of 16-run campaigns against the whole catalogue
(goal: each within 60 s on the 2-core machine; median and max reported, with the machine's load),
and the speed of the compiled one-joint replay the effect search is built on, against the plant's
(MuJoCo + pneumatics) simulation of the very same run as the in-run baseline.

Each campaign is 16 runs at 4 supplies (angle and both chamber pressures) from the plant (CAMPAIGNS:
a hidden vane leak + Coulomb friction, a pair, so the pair search runs too, the slow path; no
effect read by a camera; a slow valve on a staircase: 4 repeats of one protocol; and the pair again
on 4 protocols once each, 16 distinct runs, the costliest). Each diagnosis is timed as `twin gap
diagnose` runs it (gap.run.run_diagnose: reading the files, the fits, the report and the plots),
after a warm-up replay so that loading numba's cache is not counted.

    PYTHONPATH=. python -m benchmarks.bench_gap [--jobs 2] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import assets
from gap import protocols, synth
from gap.campaign import load_campaign
from gap.campaign_replay import CampaignReplay
from gap.run import run_diagnose
from pneumatics import params_row
from twin.plant import Plant
from twin.sim import CommandSchedule, run
from wrist_rig import commanded_run
from wrist_rig.one_joint import DT_S, replay_run

HIDDEN = {"leak_area_m2": 3e-7, "coulomb_nm": 30.0}  # the bench's pair case (gap/bench.py)


def _time_replay(replay: CampaignReplay, rounds: int) -> float:
    """Best wall time (s) of one replay of run 0 through the compiled twin."""
    pr = replay.runs[0]
    p = params_row(replay.params)
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(20):
            replay_run(p, *pr.args, pr.run.start_rad, pr.inertia, 0.0, pr.run.time_s[-1], DT_S)
        best = min(best, (time.perf_counter() - t0) / 20)
    return best


def _time_plant(reality, supply_mpa: float, motion: commanded_run.Motion, rounds: int) -> float:
    """Best wall time (s) of the plant simulating the same run (twin.sim.run on the wrist rig)."""
    best = np.inf
    for _ in range(rounds):
        plant = Plant(assets.WRIST_RIG_XML, joint_params={commanded_run.JOINT: reality})
        plant.set_supply(101_325.0 + supply_mpa * 1e6)
        i = plant.joints.index(commanded_run.JOINT)
        n = len(plant.joints)

        def commands_at(t: float, i: int = i, n: int = n) -> np.ndarray:
            d, u, b = motion.commands(np.array([t]), supply_mpa * 1e6, reality.k_u_per_pa)
            c = np.zeros((n, 3))
            c[i] = (d[0], u[0], b[0])
            return c

        t0 = time.perf_counter()
        run(plant, CommandSchedule(commands_at, n), motion.total_s(), log_period_s=commanded_run.SAMPLE_PERIOD_S)
        best = min(best, time.perf_counter() - t0)
    return best


# the 16-run campaigns timed: (name, hidden JointParams fields, protocols, repeats, instrument); the
# pair cases need the pair stage (the slow path), the others meet the other protocols and the
# camera. The first three repeat one protocol 4 times at each supply (4 replays of the twin serve
# 16 runs); the last runs 4 protocols once each, 16 distinct runs, the costliest 16-run campaign
MIXED = ("reversal", "stop_and_go", "staircase", "back_and_forth")
CAMPAIGNS = (
    ("leak+coulomb, reversal, encoder", HIDDEN, ("reversal",), 4, synth.ENCODER),
    ("none, stop-and-go, camera", {}, ("stop_and_go",), 4, replace(synth.CAMERA, latency_s=0.025)),
    ("valve lag, staircase, encoder", {"valve_time_constant_s": 0.3}, ("staircase",), 4, synth.ENCODER),
    ("leak+coulomb, 4 protocols once (16 distinct runs), encoder", HIDDEN, MIXED, 1, synth.ENCODER),
)


def bench_gap(jobs: int = 2, rounds: int = 3) -> dict:
    p0 = commanded_run.wrist_params()
    timings = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, hidden, protos, repeats, inst) in enumerate(CAMPAIGNS):
            motion = {q: [protocols.library(q)[proto] for proto in protos] for q in synth.PRESSURES_MPA}
            folder = synth.make_campaign(
                Path(tmp) / f"c16_{i}",
                p0._replace(**hidden),
                seed=7 + i,
                pressures_mpa=synth.PRESSURES_MPA,
                repeats=repeats,
                motion=motion,
                instrument=inst,
                description=f"(bench_gap: {name})",
                chamber_pressures=True,
            )
            campaign = load_campaign(folder)
            if i == 0:
                replay_s = _time_replay(CampaignReplay(campaign, pressure_weight=0.0), rounds)  # also the warm-up
            t0 = time.perf_counter()
            run_diagnose(folder, Path(tmp) / f"out{i}", jobs=jobs)
            wall = time.perf_counter() - t0
            d = json.loads((Path(tmp) / f"out{i}" / "diagnosis.json").read_text())
            timings.append(
                {
                    "campaign": name,
                    "runs": len(campaign.runs),
                    "diagnose_wall_s": wall,
                    "verdict": d["which"]["verdict"],
                    "top": d["which"]["top"]["name"] if d["which"]["top"] else None,
                    "pair_stage": bool(d["which"]["pairs"]),
                    # where the time goes: replays of the one-joint twin, and the fit stages' wall time
                    "replays": d["replays"],
                    "fit_stages_s": d["timing_s"],
                    "load_1min": os.getloadavg()[0],
                }
            )
    reality = p0._replace(**HIDDEN)
    plant_s = _time_plant(reality, synth.PRESSURES_MPA[0], commanded_run.Motion(), rounds)
    walls = [t["diagnose_wall_s"] for t in timings]
    return {
        "campaigns": timings,
        "diagnose_wall_s_median": float(np.median(walls)),
        "diagnose_wall_s_max": float(np.max(walls)),
        "diagnose_goal_s": 60.0,
        "load_1min_at_end": os.getloadavg()[0],
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
