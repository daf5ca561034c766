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
