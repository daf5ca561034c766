"""The arm diagnosis' judgement of a fit on withheld runs with a knife edge: a joint that only just
beats its friction lets go, or not, for a change of value no fit resolves, and the open-loop
replay carries the difference to the run's end (gap.arm_diagnose.knife_edges, judge)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gap.arm_campaign import JOINTS, ArmRun, HiddenArmEffect, load_arm_campaign
from gap.arm_diagnose import EXPLAINED_SHRINK, judge, knife_edges, residual, twin_of
from gap.arm_effects import candidate_named
from gap.arm_rehearsal import CAMERA, make_arm_campaign
from gap.arm_replay import Replay, replay
from gap.jobs import parallel_jobs
from scenarios.schema import load

POINT_TO_POINT = "scenarios/arm_protocols/point_to_point.toml"
SECONDS = 3.0  # the moves' first seconds: the elbow's first stop (1.9-2.9 s) is on a knife edge at 0.8 MPa


def _run(t: np.ndarray) -> ArmRun:
    n, j = len(t), len(JOINTS)
    nan = np.full((n, j), np.nan)
    return ArmRun("r", Path("r.csv"), np.zeros(j), t, np.zeros((n, j, 3)), np.full(n, 6e5), nan, np.stack([nan] * 2, 2))


def test_a_runs_knife_edge_is_where_a_nudged_replay_first_leaves_it():
    t = np.arange(0.0, 2.0, 0.001)
    at = Replay(t, np.zeros((len(t), len(JOINTS))), np.zeros((len(t), len(JOINTS), 2)))
    noise = math.radians(0.2)
    close = at.angle_rad + 1.9 * noise  # within SIGNIFICANT (2) noises all along: no edge
    apart = at.angle_rad.copy()
    apart[t >= 1.25, 2] = -2.1 * noise  # the elbow 2.1 noises away from 1.25 s on
    samples = np.arange(0.0, 2.0, 1 / 30)
    nudged = [[Replay(t, close, at.port_pa)], [Replay(t, apart, at.port_pa)]]
    assert knife_edges([_run(samples)], [at], nudged[:1], noise) == [len(samples)]
    assert knife_edges([_run(samples)], [at], nudged, noise) == [int(np.searchsorted(samples, 1.25))]


@pytest.fixture(scope="module")
def elbow_friction(tmp_path_factory):
    """Point-to-point moves at 0.7 and 0.8 MPa with the elbow's Coulomb friction at 60 N·m (the
    twin's 30) hidden, through the camera; the 0.8 MPa run is the withheld one."""
    folder = tmp_path_factory.mktemp("elbow")
    reality = HiddenArmEffect(effect="elbow_pitch:coulomb_friction", value=60.0)
    make_arm_campaign(folder, [load(POINT_TO_POINT)], (0.7, 0.8), reality, CAMERA, seed=5, duration_s=SECONDS)
    return load_arm_campaign(folder)


def test_a_fit_a_knife_edge_away_is_judged_up_to_the_edge(elbow_friction):
    """The right effect fitted 0.4 % off (60.25 N·m for 60) leaves more than EXPLAINED_SHRINK of the
    withheld misfit (the elbow stops degrees apart at 2 s, to the run's end), and explains it up to
    the edge; a wrong effect (payload mass) explains it neither way."""
    c = elbow_friction
    twin, withheld, latency = twin_of(c), c.runs[1::2], c.instrument.latency_s
    held = [residual(r, replay(r, twin.params, twin.setup), latency) for r in withheld]
    right, wrong = candidate_named("elbow_pitch:coulomb_friction"), candidate_named("arm:payload_mass")
    with parallel_jobs(1, None) as run_jobs:
        fits, explained = judge(run_jobs, c, twin, withheld, latency, [right, wrong], [(60.25, 0.0), (25.0, 0.0)], held)
        best = fits[0]
        assert best.candidate == right.name
        assert best.withheld_shrink > EXPLAINED_SHRINK  # the knife edge: over the whole run it is not explained
        assert explained, best
        assert best.shrink_before_knife_edges <= EXPLAINED_SHRINK
        assert 1.5 < best.knife_edge_s[0] < SECONDS
        fits, explained = judge(run_jobs, c, twin, withheld, latency, [wrong], [(25.0, 0.0)], held)
        assert not explained, fits[0]
        assert fits[0].knife_edge_s is not None  # judged up to its edges too, and not explained there
