"""Scenario files: the schema refuses bad input precisely; runs are deterministic; sweeps too;
every shipped scenario passes its own criteria; a scenario made to fail says which criterion broke."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

import assets
from scenarios.runner import run_scenario, scenario_files
from scenarios.schema import ScenarioError, load, parse, with_overrides
from scenarios.supply import supply_profile
from scenarios.sweep import child_seeds, parse_grid, sweep, sweep_points
from twin_cli.cli import main as twin_main

MINIMAL = """
name = "t"
model = "wrist_rig"
duration_s = 0.2
[start]
pose = "zero"
[control]
mode = "none"
"""


@pytest.mark.parametrize(
    "extra, field, value",
    [
        ("colour = 'red'", "colour", "not a known field"),
        ("[supply]\npressure_mpa = 1.4", "supply.pressure_mpa", "1.4"),
        ("[supply]\npressure_mpa = 'high'", "supply.pressure_mpa", "'high'"),
        ("[supply]\nkind = 'sine'", "supply.kind", "'sine'"),
        ("[[targets]]\nangles_deg = { elbow_pitch = 10.0 }", "targets[0].angles_deg.elbow_pitch", "not a known field"),
        ("[[faults]]\nkind = 'supply_lost'\nat_s = 99.0", "faults[0].at_s", "99.0"),
        # at the run's last instant a fault would never act
        ("[[faults]]\nkind = 'supply_lost'\nat_s = 0.2", "faults[0].at_s", "0.2"),
        ("[reality.effects.wrist_pitch]\nleak_area_m2 = -1.0", "reality.effects.wrist_pitch.leak_area_m2", "-1.0"),
        ("[reality.effects.wrist_pitch]\nmagic = 1.0", "reality.effects.wrist_pitch.magic", "not a known field"),
        # a count: 2.5 vanes must be refused, not run
        (
            "[reality.effects.wrist_pitch]\nn_vanes = 2.5",
            "reality.effects.wrist_pitch.n_vanes",
            "= 2.5 is not allowed; allowed: a whole number in 2..12 vanes",
        ),
        ("[operator]\nlatency_s = -1.0", "operator.latency_s", "-1.0"),
        # the model's air in a hose this short diverges (pneumatics/params.py SPEC)
        (
            "[predictor.effects.wrist_pitch]\nhose_length_m = 0.01",
            "predictor.effects.wrist_pitch.hose_length_m",
            "0.3..100",
        ),
    ],
)
def test_bad_fields_are_refused_with_path_field_value_and_allowed(extra, field, value):
    with pytest.raises(ScenarioError) as e:
        parse(MINIMAL + extra, "scenarios/bad.toml")
    message = str(e.value)
    assert message.startswith("scenarios/bad.toml")
    assert field in message and value in message and "allowed" in message


def test_an_unknown_strategy_is_refused():
    with pytest.raises(ScenarioError, match=r"control.strategy = 'psychic' is not allowed; allowed: 'sensorless'"):
        parse(MINIMAL.replace('mode = "none"', 'mode = "none"\nstrategy = "psychic"'), "scenarios/bad.toml")


def test_every_shipped_file_parses_and_nothing_in_it_is_executed():
    files = scenario_files()
    assert len(files) >= 15
    for f in files:
        s = load(f)
        assert s.duration_s > 0 and s.text


def test_random_supply_matches_the_papers_statistics():
    s = load("scenarios/wrist_random_supply.toml").supply
    p = supply_profile(s, 2000.0, np.random.default_rng(3))
    values = np.array([p.value_at(t) for t in np.arange(0, 2000.0, 0.5)]) - 101_325.0
    assert abs(values.mean() - 0.6e6) < 0.01e6
    assert abs(values.var() - 5e9) / 5e9 < 0.1  # clipping at 0.4..0.9 MPa removes < 0.5% of draws
    assert p.value_at(0.1) == p.value_at(0.4) and p.value_at(0.4) != p.value_at(0.6)  # each value held 0.5 s


def test_overrides_are_checked_like_the_file():
    s = load("scenarios/wrist_random_supply.toml")
    assert with_overrides(s, {"supply.mean_mpa": 0.7}).supply.mean_mpa == 0.7
    with pytest.raises(ScenarioError, match="supply.mean_mpa = 3"):
        with_overrides(s, {"supply.mean_mpa": 3})
    with pytest.raises(ScenarioError, match="expected FIELD=VALUE"):
        parse_grid(["supply.mean_mpa"])


def test_child_seeds_are_distinct_and_reproducible():
    a, b = child_seeds(5, 4), child_seeds(5, 4)
    assert a == b and len(set(a)) == 4
    points = sweep_points(load("scenarios/wrist_random_supply.toml"), {"supply.mean_mpa": [0.5, 0.7]}, 3)
    assert len(points) == 6 and len({p["seed"] for p in points}) == 3


def test_same_scenario_and_seed_give_identical_summaries_and_logs():
    s = load("scenarios/wrist_random_supply.toml")
    r1 = run_scenario(s, duration_s=1.5)
    r2 = run_scenario(s, duration_s=1.5)
    assert r1.summary() == r2.summary()
    a1, a2 = r1.telemetry.arrays(), r2.telemetry.arrays()
    for name in a1:
        assert np.array_equal(a1[name], a2[name], equal_nan=True), name
    r3 = run_scenario(s, duration_s=1.5, seed=8)
    assert not np.array_equal(a1["supply_pa"], r3.telemetry.arrays()["supply_pa"])


def test_sweep_on_one_and_two_workers_gives_the_same_results(monkeypatch):
    """Two workers forked from this process after its warm-up, or joblib's own (cold) processes,
    give the 1-worker summaries, in the points' order."""
    import scenarios.sweep

    forked = []
    on_forked = scenarios.sweep._on_forked_workers
    monkeypatch.setattr(scenarios.sweep, "_on_forked_workers", lambda *a: forked.append(a[0]) or on_forked(*a))
    s = load("scenarios/wrist_random_supply.toml")
    kwargs = dict(grid={"supply.mean_mpa": [0.55, 0.65]}, monte_carlo=2, duration_s=0.6, progress=False)
    one = sweep(s, workers=1, **kwargs)
    two = sweep(s, workers=2, **kwargs)
    assert forked == ([2] if scenarios.sweep._can_fork() else [])
    assert one == two and len(one) == 4
    assert sweep(s, workers=2, fork=False, **kwargs) == one


def test_sweep_on_a_dask_cluster_gives_the_local_results():
    """`twin sweep --scheduler ADDRESS`: the same points on a Dask cluster (here a local one of
    two worker processes) give the summaries of the local run."""
    distributed = pytest.importorskip("dask.distributed", reason="the cluster extra is not installed")
    s = load("scenarios/wrist_random_supply.toml")
    kwargs = dict(monte_carlo=2, duration_s=0.4, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote = sweep(s, scheduler=cluster.scheduler_address, **kwargs)
    assert remote == sweep(s, workers=1, **kwargs) and len(remote) == 2


def test_a_scenario_made_to_fail_names_the_broken_criterion(capsys):
    text = load("scenarios/wrist_closed_loop_60deg.toml").text
    assert "max = 4.04" in text  # the bound this test breaks (it broke nothing once the file's bound moved)
    text = text.replace("angles_deg = { wrist_pitch = 60.0 }", "angles_deg = { wrist_pitch = 89.0 }").replace(
        "max = 4.04", "max = 0.01"
    )
    s = parse(text, "made_to_fail.toml")
    result = run_scenario(s)
    assert not result.passed
    broken = [v for v in result.verdicts if not v.passed]
    assert broken and broken[0].kind == "final_error_deg" and broken[0].subject == "wrist_pitch"


def test_cli_run_json_and_exit_codes(capsys, tmp_path):
    assert twin_main(["run", "scenarios/fault_valve_stuck_open.toml", "--json", "--duration", "1.0"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["passed"] is True and set(summary["joints"]) >= {"base_yaw", "wrist_pitch"}
    assert summary["criteria"][0]["kind"] == "max_travel_deg"
    bad = tmp_path / "bad.toml"
    bad.write_text(MINIMAL + "[supply]\npressure_mpa = 1.4\n")
    assert twin_main(["run", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "supply.pressure_mpa = 1.4" in err and "Traceback" not in err


@pytest.mark.parametrize("path", scenario_files(), ids=lambda p: p.stem)
def test_every_scenario_passes_its_criteria_and_its_summary_is_what_its_log_shows(path, tmp_path):
    """Each shipped scenario, whole, passes its criteria; its summary's final target, angles and
    error per joint are those its MCAP log shows at the end (the log written by its own run)."""
    from scenarios.recording import close_all, open_recorders
    from twin.mcap_log import read_mcap

    scenario = load(path)
    recorders = open_recorders(scenario, None, tmp_path / "run.mcap", camera_fps=0)
    try:
        result = run_scenario(scenario, recorders=tuple(recorders))
    finally:
        assert close_all(recorders) == {}
    failed = [v for v in result.verdicts if not v.passed]
    assert result.passed, (result.error, failed)
    assert result.verdicts, "a scenario without criteria checks nothing"
    assert all(math.isfinite(v.value) for v in result.verdicts)
    logged, meta = read_mcap(tmp_path / "run.mcap")
    summary = result.summary()
    for i, joint in enumerate(meta["joints"]):
        row = summary["joints"][joint]
        target, true, predicted = (math.degrees(logged[k][-1, i]) for k in ANGLES)
        for field, value, tol in (
            ("target_deg", target, 1e-4),
            ("true_final_deg", true, 1e-4),
            ("predicted_final_deg", predicted, 1e-4),
            ("error_deg", true - target, 2e-4),
        ):
            # the summary says None where the log holds no number (NaN: no set point, no prediction)
            expected = None if math.isnan(value) else pytest.approx(value, abs=tol)
            assert row[field] == expected, (joint, field)


ANGLES = ("target_angle_rad", "true_angle_rad", "predicted_angle_rad")


def test_a_rig_run_cut_short_is_judged_on_the_target_in_force(capsys, tmp_path):
    """`twin run --duration` on the rig (no task controller, the plan fed whole): the target in force
    at the cut, the targets not finished listed, and the final error not judged (as on the arm)."""
    path = tmp_path / "rig.toml"
    path.write_text(load("wrist_random_supply").text)  # 45 deg reached at 1.08 s, held 2 s; then 0 deg
    assert twin_main(["run", str(path), "--json", "--duration", "3"]) == 1  # nothing judged: not a pass
    summary = json.loads(capsys.readouterr().out)
    assert summary["joints"]["wrist_pitch"]["target_deg"] == 45.0
    assert summary["not_reached"] == ["target 1", "target 2", "target 3", "target 4"]
    assert [(c["kind"], c["judged"], c["passed"]) for c in summary["criteria"]] == [("final_error_deg", False, False)]
    assert twin_main(["run", str(path), "--json", "--duration", "4.5"]) == 1
    summary = json.loads(capsys.readouterr().out)
    assert summary["joints"]["wrist_pitch"]["target_deg"] == 0.0 and summary["not_reached"][0] == "target 2"
    path.write_text(load("wrist_closed_loop_60deg").text)  # arrives at 1.25 s
    assert twin_main(["run", str(path), "--duration", "1"]) == 1
    out = capsys.readouterr().out
    assert "[----] final_error_deg" in out and "NOT JUDGED (cut short before any criterion could be judged)" in out
    assert twin_main(["run", str(path), "--json", "--duration", "2"]) == 0  # arrived: judged
    summary = json.loads(capsys.readouterr().out)
    assert summary["duration_s"] == 2.0  # not the plant clock's sum of steps, 1.9999999999998352
    assert summary["not_reached"] == [] and summary["criteria"][0]["judged"] is True


def test_a_diverged_predictor_stops_the_run_and_fails_its_criterion():
    """A predictor whose integration goes to NaN (a NaN hose bore, which no file allows: built through
    the Python API; a 1 cm hose no longer diverges, its air is sub-stepped) stops the run like a
    MuJoCo divergence, and prediction_error_deg, computed on NaN from then on, fails (NaN is no
    pass)."""
    from pneumatics import load_joint_params
    from scenarios import controllers
    from scenarios.criteria import judge
    from scenarios.runner import build_plant, resolve_targets
    from twin.model import SimulationError
    from twin.sim import body_names, run
    from twin.telemetry import Telemetry

    s = parse(
        load("wrist_closed_loop_60deg").text + "[[criteria]]\nkind = 'prediction_error_deg'\nmax = 5.0\n", "nan.toml"
    )
    plant = build_plant(s)
    targets = resolve_targets(s, plant)
    nominal = load_joint_params(assets.joint_param_path("wrist_pitch"))
    controller, _ = controllers.build(s, plant, {"wrist_pitch": nominal._replace(hose_diameter_m=math.nan)}, targets)
    telemetry = Telemetry(plant.joints, body_names(plant))
    with pytest.raises(SimulationError, match=r"the predictor diverged \(non-finite predicted angle of wrist_pitch\)"):
        run(plant, controller, 1.0, telemetry=telemetry)
    assert 0 < len(telemetry) < 50  # stopped within a flush (0.5 s) of the first sample that lost it, the samples kept
    a = telemetry.arrays()
    verdict = judge(s, a, plant.joints, telemetry.bodies, plant.model, targets)[-1]
    assert verdict.kind == "prediction_error_deg" and math.isnan(verdict.value) and not verdict.passed


def test_a_fault_after_the_cut_is_said_and_what_depends_on_it_not_judged(capsys, tmp_path):
    """`twin run --duration` stopping before a fault strikes: the summary says the fault was not
    applied, and the final error (the run's end is after the fault) and what is measured after
    the first fault are not judged, rather than passed or failed on a run without the fault."""
    path = tmp_path / "late_fault.toml"
    path.write_text(
        load("wrist_closed_loop_60deg").text  # 60 deg reached at 1.25 s
        + "[[faults]]\nkind = 'brake_fails'\nat_s = 5.0\njoint = 'wrist_pitch'\n"
        + "[[criteria]]\nkind = 'max_travel_deg'\njoint = 'wrist_pitch'\nmax = 1.0\n"
    )
    assert twin_main(["run", str(path), "--duration", "2"]) == 1  # nothing judged: not a pass
    out = capsys.readouterr().out
    assert "not applied (after the cut, what depends on it not judged): brake_fails wrist_pitch at 5 s" in out
    assert "[----] final_error_deg" in out and "[----] max_travel_deg" in out
    assert twin_main(["run", str(path), "--json", "--duration", "5.5"]) == 0  # struck: judged (no load to move it)
    summary = json.loads(capsys.readouterr().out)
    assert summary["faults_not_applied"] == [] and all(c["judged"] for c in summary["criteria"])


def test_run_shows_progress_on_a_terminal_and_nothing_else(capsys, monkeypatch):
    """On a terminal `twin run` rewrites one line on stderr with simulated time, real-time factor
    and discs done; with --json, or when stderr is not a terminal, it writes none."""
    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    # 1.5 s of the 200 s task judges none of its criteria: NOT JUDGED, exit 1 (README, "Reliability")
    assert twin_main(["run", "insulator_cleaning", "--duration", "1.5"]) == 1
    err = capsys.readouterr().err
    assert re.search(r"\r\s+1\.5 / 1\.5 s simulated, [0-9.]+x real time, discs 0/8", err), err
    assert twin_main(["run", "insulator_cleaning", "--duration", "1.5", "--json"]) == 1
    assert "simulated" not in capsys.readouterr().err
    monkeypatch.setattr("sys.stderr.isatty", lambda: False, raising=False)
    assert twin_main(["run", "insulator_cleaning", "--duration", "1.5"]) == 1
    assert "simulated," not in capsys.readouterr().err
