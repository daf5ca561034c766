"""Cost of the whole arm's diagnosis (`twin gap arm-diagnose`, gap/arm_diagnose.py) against the
replay it is built on, measured in the same run: the diagnosis' CPU time in units of one nominal
replay of every run of the campaign (the issue's goal: a 10-run campaign of 60 s runs in 3 minutes
of wall time on 2 cores), with its wall and CPU time and the machine's load.

A campaign to time (10 runs of 60 s, the elbow's Coulomb friction hidden; docs/gap_arm.md):

    twin gap arm-campaign scenarios/insulator_cleaning.toml scenarios/arm_protocols/point_to_point.toml \\
        --out CAMPAIGN --reality "elbow_pitch:coulomb_friction=60" --supplies 0.5,0.55,0.6,0.7,0.8 --duration 60
    PYTHONPATH=. python -m benchmarks.bench_gap_arm CAMPAIGN [--jobs 2]
"""

from __future__ import annotations

import argparse
import os
import time

from gap.arm_campaign import load_arm_campaign
from gap.arm_diagnose import diagnose_arm, twin_of
from gap.arm_replay import replay


def bench_gap_arm(folder: str, jobs: int = 2) -> dict:
    campaign = load_arm_campaign(folder)
    twin = twin_of(campaign)
    replay(campaign.runs[0], twin.params, twin.setup, 0.1)  # numba's cache loaded, not timed
    c0 = time.process_time()
    for r in campaign.runs:
        replay(r, twin.params, twin.setup)
    baseline_cpu = time.process_time() - c0
    load = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    d = diagnose_arm(campaign, jobs)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {
        "runs": len(campaign.runs),
        "simulated_s": float(sum(r.time_s[-1] for r in campaign.runs)),
        "campaign_replay_cpu_s": baseline_cpu,
        "diagnose_wall_s": wall,
        "diagnose_cpu_s": cpu,
        "campaign_replays": cpu / baseline_cpu,
        "load_average_1min": load,
        "verdict": d.line(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("campaign", help="an arm campaign folder")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    r = bench_gap_arm(a.campaign, a.jobs)
    print(
        f"{r['runs']} runs, {r['simulated_s']:.0f} s simulated: diagnosis {r['diagnose_wall_s']:.1f} s wall, "
        f"{r['diagnose_cpu_s']:.1f} s CPU = {r['campaign_replays']:.1f} nominal replays of the campaign "
        f"({r['campaign_replay_cpu_s']:.1f} s CPU each; load {r['load_average_1min']:.1f} on {os.cpu_count()} cores)"
    )
    print(f"  {r['verdict']}")


if __name__ == "__main__":
    main()
