"""The design of the next runs (gap.design, gap.discrimination, gap.plan): the criterion against a
direct computation, a run that tells two known hypotheses apart ranked above one that cannot, the
plan's files played on the plant and read back as a campaign, and one design round of the bench."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gap import protocols, synth
from gap.campaign import load_campaign
from gap.campaign_replay import joint_stops, nominal_inertia
from gap.design import DesignCriterion, Pair, alternatives, choose, hypotheses_of, planned_run
from gap.discrimination import Hypothesis, Reading, ReplayedJoint, misfits, response, trajectory
from gap.effects import BY_NAME, CATALOGUE
from gap.kinds import Family, Verdict
from gap.plan import Header, add_runs, play_plan, read_plan, write_plan
from pneumatics import params_row
from wrist_rig import commanded_run
from wrist_rig.one_joint import DT_S, replay_run

P0 = commanded_run.wrist_params()
TWIN = ReplayedJoint(P0, joint_stops(commanded_run.JOINT))
INERTIA = nominal_inertia(commanded_run.RIG_INERTIA_KG_M2, P0)
READING = Reading(0.3, np.array([0.0, 0.02, 0.04]))


def _run(name: str, mpa: float = 0.6, rate_hz: float = 50.0, pressures: bool = False):
    return planned_run(protocols.design_library(mpa)[name], mpa, P0.k_u_per_pa, INERTIA, rate_hz, pressures)


def test_the_criterion_is_the_sum_of_squared_differences_in_floors_computed_directly():
    """discrimination.misfits of one alternative at one latency equals sum((theta_a - theta_b)/floor)^2
    with both angles replayed straight through wrist_rig.one_joint and read at the sample times."""
    run = _run("reversal")
    a, b = ((BY_NAME["coulomb_friction"], 30.0),), ((BY_NAME["viscous_friction"], 8.0),)
    m = misfits(response(TWIN, a, run, READING), 1, [response(TWIN, b, run, READING)])

    def angle(field: str, value: float, latency_s: float) -> np.ndarray:
        row = params_row(P0._replace(**{field: value}), stops=TWIN.stops)
        args = (run.time_s, run.direction, run.valve_gauge_pa, run.brake_released, run.supply_pa, False, 0.0, INERTIA)
        t, th = replay_run(row, *args, 0.0, run.time_s[-1] + DT_S, DT_S, 0.0)[:2]
        return np.interp(run.angle_times_s - latency_s, t, th)

    truth = angle("coulomb_nm", 30.0, 0.02)
    for j, lat in enumerate(READING.latencies_s):
        expect = np.sum(((angle("viscous_nm_s", 8.0, lat) - truth) / math.radians(0.3)) ** 2)
        assert m[0, j] == pytest.approx(expect, rel=1e-9)
    assert m.min() > 10.0  # the two frictions do differ on a reversal


def test_a_run_that_tells_two_hypotheses_apart_ranks_above_one_that_cannot():
    """More Coulomb friction against more viscous friction (free over its values): with the joint held
    by its brake (the `held` protocol, angle only) neither turns, so nothing tells them apart (T = 0);
    a reversal does. The design ranks the reversal first and chooses it alone."""
    coulomb = ((BY_NAME["coulomb_friction"], 30.0),)
    viscous_effect = BY_NAME["viscous_friction"]
    hyps = [
        Hypothesis("coulomb", Family.FRICTION, coulomb, 0.0, (coulomb,)),
        Hypothesis("viscous", Family.FRICTION, ((viscous_effect, 8.0),), 0.0, alternatives([viscous_effect])),
    ]
    crit = DesignCriterion(TWIN, hyps, [Pair("coulomb / viscous", ((0, 1), (1, 0)))], READING)
    cands = [("held", (_run("held"),)), ("reversal", (_run("reversal"),))]
    ranking, chosen, together = choose(crit, cands, None, None)
    by = {p.protocol: p.separation["coulomb / viscous"] for p in ranking}
    assert by["held"] == pytest.approx(0.0, abs=1e-6)
    assert by["reversal"] > 1.0, by
    assert [p.protocol for p in ranking] == ["reversal", "held"]
    assert [p.protocol for p in chosen] == ["reversal"] and together["coulomb / viscous"] == by["reversal"]


def test_the_plan_is_played_from_its_files_and_reads_back_as_a_campaign(tmp_path):
    """A plan of two runs written as files, played on the plant (MuJoCo) from the files alone, reads
    back as a campaign with the plan's commands and the plant's angles (the twin's replay of the same
    commands within the protocols' model tolerance), and joins another campaign."""
    runs = [_run("pulses", 0.5, pressures=True), _run("slow_075", 0.8, pressures=True)]
    header = Header(pressures=True)
    write_plan(runs, header, tmp_path / "plan", "test plan")
    _, entries = read_plan(tmp_path / "plan")
    assert [e.supply_mpa for e in entries] == [0.5, 0.8]
    play_plan(tmp_path / "plan", tmp_path / "played", P0, synth.ENCODER, np.random.default_rng(0), True)
    played = load_campaign(tmp_path / "played")
    assert [r.name for r in played.runs] == ["design_pulses_050", "design_slow_075_080"]
    for r, planned in zip(played.runs, runs, strict=True):
        np.testing.assert_array_equal(r.direction, planned.direction)
        np.testing.assert_array_equal(r.brake_released, planned.brake_released)
        np.testing.assert_allclose(r.valve_gauge_pa, planned.valve_gauge_pa, atol=0.05)
        assert np.isfinite(r.extra["p_a_pa"]).sum() > 10
        t, th = trajectory(TWIN, (), planned)[:2]
        err = np.degrees(r.angle_rad[r.sampled] - np.interp(r.time_s[r.sampled], t, th))
        assert np.sqrt(np.mean(err**2)) < 2 * protocols.worst_tolerance_deg() + 0.1  # encoder noise 0.05 deg
        assert np.ptp(np.degrees(th)) > 5.0  # the run does turn the joint
    base = synth.make_campaign(tmp_path / "base", P0, seed=1, pressures_mpa=(0.5, 0.8), repeats=1)
    joined = load_campaign(add_runs(base, tmp_path / "played", tmp_path / "joined"))
    assert len(joined.runs) == 4 and joined.runs[-1].name == "design_slow_075_080"


def test_one_design_round_on_a_bench_case_keeps_or_improves_its_call(tmp_path):
    """The bench's quick slice's hidden vane leak (camera, chamber pressures, two supplies) with a design
    round: runs proposed, played on the same reality and added; the call after is still right, and the
    round says what it cost."""
    from gap.bench import run_bench

    s = run_bench(tmp_path, quick=True, only="vane_leakage", design_round=True)
    (r,) = s["cases"]
    rnd = r["round"]
    assert r["top1"] and rnd["top1"], (r["top"], rnd["top"], rnd["proposed"])
    assert rnd["runs_added"] == 2 * len(rnd["proposed"]) and rnd["arm_time_s"] > 0
    if rnd["runs_added"]:
        assert len(load_campaign(tmp_path / "rounds" / "vane_leakage" / "campaign").runs) == 4 + rnd["runs_added"]
    assert s["design_round"]["exact_right_after"] == "1/1"


def test_design_without_a_campaign_needs_a_joint_and_an_instrument(tmp_path):
    """`twin gap design --out DIR` with neither a campaign nor --joint is refused in one line naming what
    is allowed, before any work; so is a campaign given with --instrument."""
    from gap.design_cli import run_design
    from twin_plumbing.errors import UserError

    with pytest.raises(UserError, match=r"--joint \(one of base_yaw.*got None\) and --instrument"):
        run_design(None, tmp_path / "out", None, "camera")
    with pytest.raises(UserError, match="--joint, --instrument and --pressures are for before any campaign"):
        run_design(tmp_path, tmp_path / "out", None, "camera")
    assert not (tmp_path / "out").exists()


def _outside_the_catalogue():
    """A diagnosis's verdict as the design reads it (gap.result.Which's fields it uses): a static-friction
    excess (Stribeck, 40 N·m, withheld from the catalogue) hidden on staircases read by a camera, called
    outside the catalogue, nearest family brake; its singles as the bench's diagnosis fitted them, best
    first (value, latency s)."""
    from types import SimpleNamespace

    fitted = [
        ("brake_incomplete_release", 6.874e5, 0.025),
        ("valve_lag", 0.437, 0.0),
        ("coulomb_friction", 35.06, 0.015),
        ("brake_slow_release", 0.1687, 0.0),
        ("supply_droop", 2.826e7, 0.04),
        ("brake_holding", 300.0, 0.06),
        ("brake_slow_engage", 0.03189, 0.06),  # the twin's 20 ms: near nominal, it does almost nothing
        ("viscous_friction", 13.8, 0.035),
    ]
    ranking = [
        SimpleNamespace(name=n, effects=[n], families=[BY_NAME[n].family], fitted_values=[v], latency_s=lat)
        for n, v, lat in fitted
    ]
    which = SimpleNamespace(
        verdict=Verdict.OUTSIDE,
        top=ranking[0],
        rivals=[],
        pairs=[],
        ranking=ranking,
        nearest=SimpleNamespace(family="brake", tied=[]),
        families=[SimpleNamespace(family=f) for f in ("brake", "valve", "friction", "supply")],
    )
    catalogue = tuple(e for e in CATALOGUE if e.name != "stribeck_friction")
    return SimpleNamespace(which=which), catalogue


def test_each_family_is_its_best_member_and_the_call_is_told_from_each_other():
    """Atkinson & Fedorov's several-model design: the best-fitting model taken as true, the others refitted.
    Each leading family is one hypothesis, its best member as fitted, free over its members when refitted;
    the pairs are the called family against each other, so a member fitted near its nominal value (a
    brake engaging at 32 ms for the twin's 20) is no truth of its own."""
    diag, catalogue = _outside_the_catalogue()
    hyps, pairs = hypotheses_of(diag, catalogue)
    assert [h.name for h in hyps] == [
        "brake (brake_incomplete_release = 6.874e+05)",
        "valve (valve_lag = 0.437)",
        "friction (coulomb_friction = 35.06)",
        "supply (supply_droop = 2.826e+07)",
    ]
    assert [h.latency_s for h in hyps] == [0.025, 0.0, 0.015, 0.04]
    assert [p.name for p in pairs] == ["brake / valve", "brake / friction", "brake / supply"]
    assert all(p.directed == ((0, k), (k, 0)) for k, p in enumerate(pairs, 1))
    brake_alts = {e.name for alt in hyps[0].alternatives for e, _ in alt}
    assert brake_alts == {"brake_incomplete_release", "brake_slow_release", "brake_slow_engage", "brake_holding"}
    assert "stribeck_friction" not in {e.name for h in hyps for alt in h.alternatives for e, _ in alt}


def test_the_run_chosen_tells_the_called_family_from_the_others_not_a_member_that_does_nothing():
    """On that diagnosis, at 0.8 MPa read by a 30 Hz camera: back-and-forth moves (their reversals keep the
    brake's shuttle-fed air high while the joint stops and turns, so a dragging brake cannot stand in for
    a static friction there) tell the brake from friction by 1.9 times what the braked rests of
    dwell-then-move do, and are chosen. Each member of a family as a truth of its own chose
    dwell-then-move: a brake member that does almost nothing there set back-and-forth's least separation at
    0.12 floors."""
    diag, catalogue = _outside_the_catalogue()
    hyps, pairs = hypotheses_of(diag, catalogue)
    crit = DesignCriterion(TWIN, hyps, pairs, Reading(0.372, np.array([0.0, 0.02, 0.04, 0.06])))
    cands = [(n, (_run(n, 0.8, rate_hz=30.0),)) for n in ("dwell_then_move", "back_and_forth")]
    ranking, chosen, together = choose(crit, cands, None, 2)
    by = {p.protocol: p.separation for p in ranking}
    assert by["back_and_forth"]["brake / friction"] > 1.5 * by["dwell_then_move"]["brake / friction"], by
    assert min(by["back_and_forth"].values()) > 5.0, by  # every pair told apart, by far more than 1 floor
    assert [p.protocol for p in chosen] == ["back_and_forth"], by
