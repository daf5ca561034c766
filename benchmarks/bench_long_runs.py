"""Cost of long campaign runs: `twin gap diagnose` of 16 runs of 600 s at 1 kHz rows, against the
same 16 runs at their own length (~10.5 s each) diagnosed in the same session, the baseline.

The campaign: 4 supplies x 4 protocols of the motion library (gap.protocols), each run by the plant
(twin.plant on the wrist rig) through the protocol and then braked at rest to 10.5 s, read by the
encoder; the long campaign repeats each file's rows, time shifted, to 600 s (a logger left
running). The diagnosis fits each run on its first FIT_WINDOW_S seconds (gap.campaign), all of it
the plant's, so both campaigns should cost about the same: the ratio says how far the long files'
reading and checking add to it. Peak memory is the process's (ru_maxrss), with the long campaign
diagnosed last.

    PYTHONPATH=. python -m benchmarks.bench_long_runs [--jobs 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gap import synth
from gap.campaign import load_campaign
from gap.protocols import library
from gap.run import run_diagnose
from wrist_rig import commanded_run

PRESSURES_MPA = (0.5, 0.6, 0.7, 0.8)
PROTOCOLS = ("paper_60", "staircase", "back_and_forth", "stop_and_go")
SIMULATED_S = 10.5  # each run's plant simulation: its protocol, then braked at rest
LONG_S = 600.0  # the longest run a campaign takes (gap.campaign.MAX_RUN_DURATION_S)


def short_campaign(folder: Path) -> Path:
    """16 runs from the plant, each its protocol then at rest to SIMULATED_S, 1 ms rows."""
    motion = {
        p: [
            dataclasses.replace(m, tail_s=m.tail_s + SIMULATED_S - m.total_s())
            for m in (library(p)[name] for name in PROTOCOLS)
        ]
        for p in PRESSURES_MPA
    }
    return synth.make_campaign(
        folder, commanded_run.wrist_params(), seed=3, pressures_mpa=PRESSURES_MPA, repeats=1, motion=motion
    )


def long_campaign(short: Path, folder: Path) -> Path:
    """`short`'s campaign with each run file's rows repeated, time shifted, to just under LONG_S."""
    shutil.copytree(short, folder)
    for f in sorted(folder.glob("*.csv")):
        head, *rows = f.read_text().splitlines()
        t = np.array([float(r.split(",", 1)[0]) for r in rows])
        period = t[-1] + 1e-3
        repeats = int((LONG_S - 0.1 - t[-1]) // period) + 1
        lines = [head]
        for k in range(repeats):
            lines += [f"{x + k * period:.3f},{r.split(',', 1)[1]}" for x, r in zip(t, rows, strict=True)]
        f.write_text("\n".join(lines) + "\n")
    return folder


def timed_diagnosis(campaign: Path, out: Path, jobs: int) -> tuple[float, float]:
    """(seconds to load the campaign, seconds `twin gap diagnose` takes on it)."""
    t0 = time.perf_counter()
    load_campaign(campaign)
    loaded = time.perf_counter() - t0
    t0 = time.perf_counter()
    run_diagnose(campaign, out, jobs=jobs)
    return loaded, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        short = short_campaign(tmp / "short")
        long = long_campaign(short, tmp / "long")
        rows = sum(1 for _ in (long / "run_050_a_1.csv").open()) - 1
        short_load, short_s = timed_diagnosis(short, tmp / "short_out", args.jobs)
        long_load, long_s = timed_diagnosis(long, tmp / "long_out", args.jobs)
    figures = {
        "runs": 16,
        "long_run_rows": rows,
        "short_diagnosis_s": round(short_s, 1),
        "long_diagnosis_s": round(long_s, 1),
        "long_over_short": round(long_s / short_s, 2),
        "long_load_s": round(long_load, 2),
        "short_load_s": round(short_load, 2),
        "peak_memory_mb": _peak_memory_mb(),
        "load_average": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None,
    }
    print(json.dumps(figures, indent=1))


def _peak_memory_mb() -> int | None:
    """This process's peak resident memory in MB; None where the `resource` module is missing (Windows)."""
    if sys.platform == "win32":
        return None
    import resource  # Unix only: imported where it exists

    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)


if __name__ == "__main__":
    main()
