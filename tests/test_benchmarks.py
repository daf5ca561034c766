"""The speed benchmarks' baseline: bare MuJoCo replaying what the plant gave it is the twin's
own motion (benchmarks/bench_twin.py), so the ratio compares the same physics."""

import json

import numpy as np

from benchmarks.bench_twin import SCENARIO, record_motion, replay
from scenarios.runner import run_scenario
from scenarios.schema import load


def test_bare_mujoco_replay_ends_where_the_twin_ends():
    scenario = load(SCENARIO)
    motion = record_motion(scenario, 0.3)
    assert motion.ctrl.shape == (600, 5) and np.abs(motion.ctrl).max() > 0.0  # the air drove the joints
    _, same = replay(motion)
    assert same
    # the recording stepped one physics step at a time: the same run as the plain one
    plain = run_scenario(scenario, duration_s=0.3).summary()
    assert json.dumps(motion.summary, sort_keys=True) == json.dumps(plain, sort_keys=True)


def test_twin_bench_prints_every_repeated_figure_as_its_median_and_spread():
    """`twin bench` without --json: a figure inside a nested table (the plant's cases, the gap's
    campaigns) reads as `median (min-max)` like the top-level ones, not as a Python dict."""
    from twin_cli.figures import figure_lines

    results = {
        "plant": {
            "rounds": 5,
            "all": {"moving_joints": ["base_yaw"], "ratio": {"median": 0.819, "min": 0.815, "max": 0.833}},
        },
        "gap": {"campaigns": [{"campaign": "none", "fit_stages_s": {"singles": 4.5}}, {"campaign": "lag"}]},
    }
    lines = figure_lines(results)
    assert lines == [
        "plant:",
        "  rounds: 5",
        "  all:",
        "    moving_joints: ['base_yaw']",
        "    ratio: 0.819 (0.815-0.833)",
        "gap:",
        "  campaigns:",
        "    - campaign: none",
        "      fit_stages_s:",
        "        singles: 4.5",
        "    - campaign: lag",
    ]
