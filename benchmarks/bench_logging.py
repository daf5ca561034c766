"""Cost of logging: a run with both logs on (rerun .rrd and MCAP) against the same run with none.

Both sides are `twin run scenarios/insulator_cleaning.toml` cut to the same simulated time (all
five joints under their controllers, the brush against the string), with `--rrd --mcap` and
without; telemetry is collected on both sides (twin.sim.run always samples), so the difference is
what the recorders cost: opening them (the command builds the model for them), the static
geometry, the bulk sends, handing batches to the MCAP writer process, closing (which waits for
that process to write everything). Rounds alternate off/on; each figure is the median with its
min-max over the rounds, the ratio taken within each round; the time spent inside each recorder
is reported too. Goal (issue): ratio <= 1.2.

    PYTHONPATH=. python -m benchmarks.bench_logging [--seconds 60] [--rounds 2]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.stats import spread
from scenarios.recording import open_recorders
from scenarios.runner import run_scenario, scenario_files
from scenarios.schema import load
from twin.sim import CommandSchedule
from twin_plumbing.checks import RECORDING_CAMERA_FPS

SCENARIO = "insulator_cleaning"  # the multi-joint task: all five controllers, contact, moving bodies
SUPPLY_PA = 101_325.0 + 0.6e6  # 0.6 MPa gauge, the paper's mean supply
VALVE_OPEN_GAUGE_PA = 0.52e6  # >= 1/k_u = 5.1e5 Pa gauge: proportional valve fully open


def wrist_schedule(joints: tuple[str, ...]) -> CommandSchedule:
    """Wrist brake released, valve open, direction +1 then -1 every second; others held."""
    w = joints.index("wrist_pitch")

    def commands_at(t: float) -> np.ndarray:
        c = np.zeros((len(joints), 3))
        c[w] = (1.0 if int(t) % 2 == 0 else -1.0, VALVE_OPEN_GAUGE_PA, 1.0)
        return c

    return CommandSchedule(commands_at, len(joints))


class Timed:
    """A recorder wrapped so that the time spent inside it is counted (the noise-free part)."""

    def __init__(self, make, spent: dict, key: str):
        self.spent, self.key = spent, key
        t0 = time.perf_counter()
        self.inner = make()
        spent[key] = spent.get(key, 0.0) + time.perf_counter() - t0

    def write(self, telemetry, start: int) -> None:
        t0 = time.perf_counter()
        self.inner.write(telemetry, start)
        self.spent[self.key] += time.perf_counter() - t0

    def close(self) -> None:
        t0 = time.perf_counter()
        self.inner.close()
        self.spent[self.key] += time.perf_counter() - t0


def timed_run(
    seconds: float,
    out_dir: Path | None,
    spent: dict | None = None,
    scenario_name: str = SCENARIO,
    camera_fps: float = 0.0,
) -> float:
    """Wall time of `twin run SCENARIO [--rrd --mcap --camera-fps N]` cut to `seconds` simulated:
    the recorders opened as the command opens them, the run (plant, five controllers, telemetry),
    the logs closed. `spent` collects the time inside each recorder (open, writes, close)."""
    scenario = load(next(p for p in scenario_files() if p.stem == scenario_name))
    spent = {} if spent is None else spent
    t0 = time.perf_counter()
    recorders: tuple = ()
    if out_dir is not None:
        made = open_recorders(scenario, out_dir / "bench.rrd", out_dir / "bench.mcap", camera_fps)
        spent["open"] = spent.get("open", 0.0) + time.perf_counter() - t0
        recorders = (Timed(lambda: made[0], spent, "rerun"), Timed(lambda: made[1], spent, "mcap"))
    try:
        run_scenario(scenario, recorders, duration_s=seconds)
    finally:
        for r in recorders:
            r.close()
    return time.perf_counter() - t0


def bench_logging(seconds: float = 60.0, rounds: int = 2, camera_fps: float = RECORDING_CAMERA_FPS) -> dict:
    """Run time with both logs on as a ratio to the same run with logging off; and the same with
    the global camera's frames in the recording as well (`twin run`'s default)."""
    timed_run(0.2, None)  # warm-up: numba cache, imports
    with tempfile.TemporaryDirectory() as tmp:
        timed_run(0.2, Path(tmp))
        off, on, cam = [], [], []
        inside = {"open": [], "rerun": [], "mcap": []}
        for _ in range(rounds):
            off.append(timed_run(seconds, None))
            spent: dict = {}
            on.append(timed_run(seconds, Path(tmp), spent))
            for k in inside:
                inside[k].append(spent[k] / off[-1])
            sizes = {p.suffix: p.stat().st_size for p in Path(tmp).iterdir()}
            if camera_fps > 0:
                cam.append(timed_run(seconds, Path(tmp), camera_fps=camera_fps))
                rrd_with_camera = (Path(tmp) / "bench.rrd").stat().st_size
    out = {
        "seconds_simulated": seconds,
        "rounds": rounds,
        "goal_ratio": 1.2,
        "run_s_logging_off": spread(off),
        "run_s_logging_on": spread(on),
        "ratio": spread([b / a for a, b in zip(off, on, strict=True)]),
        # the recorders' own time over the run without logs: the same cost, without the noise of
        # two wall-clock runs (rerun's encoder, the MCAP writer process and the camera process
        # run beside the run, so the wall-clock ratio exceeds 1 + these when cores are few)
        "open_fraction": spread(inside["open"]),
        "rerun_fraction": spread(inside["rerun"]),
        "mcap_fraction": spread(inside["mcap"]),
        "ratio_from_recorder_time": spread([1.0 + sum(f) for f in zip(*inside.values(), strict=True)]),
        "rrd_bytes_per_simulated_s": sizes.get(".rrd", 0) / seconds,
        "mcap_bytes_per_simulated_s": sizes.get(".mcap", 0) / seconds,
    }
    if camera_fps > 0:  # frames rendered offscreen (software GL without a GPU) where a backend works
        out |= {
            "camera_fps": camera_fps,
            "ratio_with_camera": spread([c / a for a, c in zip(off, cam, strict=True)]),
            "rrd_bytes_per_simulated_s_with_camera": rrd_with_camera / seconds,
        }
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per run")
    parser.add_argument("--rounds", type=int, default=3, help="alternating off/on rounds (median, min-max)")
    args = parser.parse_args(argv)
    print(json.dumps(bench_logging(args.seconds, args.rounds), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
