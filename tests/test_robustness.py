"""The cleaning coverage (each disc's rim and top face brushed in the force band) against
independent geometry, and the robustness study's machinery on a tiny study (2 runs, seconds)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import assets
from scenarios import robustness
from scenarios.cleaning import BAND_N, CAP_RADIUS_M, disc_contacts
from twin_cli.cli import main as twin_main


@pytest.fixture(scope="module")
def scene() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))


def _telemetry(points: np.ndarray, force: np.ndarray) -> dict[str, np.ndarray]:
    t = 0.02 * np.arange(len(points))
    return {"time_s": t, "brush_force_n": force, "brush_contact_m": points, "brush_peak_n": force}


def test_the_rim_coverage_is_the_arc_swept_in_the_force_band(scene):
    """Disc 3's rim (shell radius R) gone over from -30 to +30 deg of azimuth at 30 N covers the
    60 deg arc plus half the face's chord angle at each end; the same sweep out of the band
    (70 N, and 10 N) covers nothing."""
    g = scene.geom("disc_3")
    radius, b = float(g.size[0]), float(scene.geom("brush").size[0])
    a = np.radians(np.linspace(-30.0, 30.0, 200))
    points = g.pos + radius * np.column_stack([-np.cos(a), np.sin(a), np.zeros_like(a)])  # the rim facing the arm
    expected = (math.radians(60.0) + 2 * math.asin(b / radius)) / (2 * math.pi)
    covered = disc_contacts(scene, _telemetry(points, np.full(len(a), 30.0)))[2]
    assert covered.rim_share == pytest.approx(expected, rel=0.01)
    assert covered.top_share == 0.0
    for force in (BAND_N[1] + 15.0, BAND_N[0] - 5.0):
        assert disc_contacts(scene, _telemetry(points, np.full(len(a), force)))[2].rim_share == 0.0


def test_the_top_coverage_is_the_annulus_under_the_face(scene):
    """Contacts on disc 5's top face along a quarter turn at 9 cm from the axis, in band: the share
    of the annulus (cap edge to rim) under the face's disc around them, against a Monte Carlo of
    the annulus (uniform points, an independent count)."""
    g = scene.geom("disc_5")
    radius, half, b = float(g.size[0]), float(g.size[1]), float(scene.geom("brush").size[0])
    a = np.radians(np.linspace(0.0, 90.0, 120))
    local = np.column_stack([0.09 * np.cos(a), 0.09 * np.sin(a)])
    # the disc's frame (scenarios/string.py, Disc.frame) is the world's for the scene file's string
    points = g.pos + np.column_stack([local[:, 0], local[:, 1], np.full(len(a), half)])
    got = disc_contacts(scene, _telemetry(points, np.full(len(a), 30.0)))[4]
    rng = np.random.default_rng(0)
    r = np.sqrt(rng.uniform(CAP_RADIUS_M**2, radius**2, 200_000))
    th = rng.uniform(0, 2 * np.pi, r.size)
    mc = np.stack([r * np.cos(th), r * np.sin(th)], axis=1)
    under = np.zeros(r.size, dtype=bool)
    for p in local[::4]:
        under |= np.sum((mc - p) ** 2, axis=1) <= b * b
    assert got.top_share == pytest.approx(under.mean(), abs=0.01)
    assert 0.2 < got.top_share < 0.5 and got.rim_share == 0.0


def test_a_tiny_robustness_study(tmp_path):
    """Two cases, one seed, 3 s runs: the shipped scenario runs; a string 55 cm farther cannot be
    planned (every disc out of the arm's reach) and counts as a failed run that cleaned nothing.
    The table, the goals, the CSV and the plot are written."""
    cases = [*robustness.cases_named(["shipped"]), ("string x +55 cm", {"string.x_m": 1.3})]
    results = robustness.run_robustness(cases, seeds=1, workers=1, duration_s=3.0, progress=False)
    assert [r["case"] for r in results] == ["shipped", "string x +55 cm"]
    assert "out of the brush's reach" in results[1]["refused"] and "discs" not in results[1]
    assert len(results[0]["discs"]) == 8  # run: its 8 discs judged (none cleaned in 3 s)
    rows = robustness.write(results, tmp_path)
    assert [(r.case, r.refused, r.all_cleaned) for r in rows] == [
        ("shipped", False, 0.0),
        ("string x +55 cm", True, 0.0),
    ]
    figures = robustness.goals(results)
    assert figures["runs"] == 2 and figures["all_cleaned"] == 0.0
    assert figures["within_reach_runs"] == 1 and figures["all_cleaned_within_reach"] == 0.0
    assert math.isinf(figures["shipped_task_time_s"])  # 3 s: the plan not finished
    text = (tmp_path / "robustness.md").read_text()
    assert "| string x +55 cm | 1 | 0% | 0% | out of reach: not run |" in text
    assert "1 of the 2 runs have a disc outside the arm's workspace" in text
    assert "of the other 1, 0% cleaned every disc" in text
    assert (tmp_path / "robustness.png").stat().st_size > 1000
    assert (tmp_path / "robustness.csv").read_text().splitlines()[0].startswith("case,runs,all_cleaned")


def test_an_unknown_robustness_case_is_refused_in_one_line(tmp_path, capsys):
    assert (
        twin_main(["study", "cleaning", "--robustness", "--cases", "shipped,moon", "--out", str(tmp_path / "o")]) == 2
    )
    err = capsys.readouterr().err
    assert "--cases: unknown robustness case 'moon'; allowed: shipped, string x -10 cm" in err
    assert not (tmp_path / "o").exists()


def test_the_coverage_criteria_judge_each_disc_by_its_share(scene):
    """disc_rim_share >= 0.8 and disc_top_share >= 0.8 in a scenario: disc 3's rim gone over all
    round and its top face ring by ring, in band, passes both; disc 2's rim half round fails the
    rim's, the others fail both (untouched)."""
    from dataclasses import replace

    from scenarios.criteria import judge
    from scenarios.schema import Criterion, load

    scenario = replace(
        load("insulator_cleaning"),
        criteria=(Criterion(kind="disc_rim_share", min=0.8), Criterion(kind="disc_top_share", min=0.8)),
    )
    g3, g2 = scene.geom("disc_3"), scene.geom("disc_2")
    radius, half = float(g3.size[0]), float(g3.size[1])
    a = np.radians(np.arange(0.0, 360.0, 2.0))
    ring = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    top = np.concatenate([g3.pos + r * ring + [0, 0, half] for r in (0.06, 0.10)])
    points = np.concatenate([g3.pos + radius * ring, top, g2.pos + radius * ring[: len(a) // 2]])
    verdicts = judge(scenario, _telemetry(points, np.full(len(points), 30.0)), (), (), scene)
    passed = {(v.kind, v.subject): v.passed for v in verdicts}
    assert passed[("disc_rim_share", "disc_3")] and passed[("disc_top_share", "disc_3")]
    assert not passed[("disc_rim_share", "disc_2")] and not passed[("disc_top_share", "disc_2")]
    assert not any(passed[(k, "disc_5")] for k in ("disc_rim_share", "disc_top_share"))


def test_runs_with_a_disc_outside_the_arms_workspace_are_counted_apart():
    """A run whose plan left a disc out (the operator's "out of the arm's reach" at the start, the
    disc judged not cleaned) and a case refused whole are outside the workspace; the share of the
    other runs that cleaned every disc is given beside the share of all (1 of 1 against 1 of 3)."""
    disc = {"peak_force_n": 30.0, "rim_share": 0.1, "top_share": 0.0, "cleaned": True}
    force = [{"kind": "contact_force_n", "value": 30.0}]
    clean = {"case": "a", "passed": True, "finished_s": 120.0, "discs": [disc, disc], "criteria": force}
    out = ["t = 0.000 s: disc_1: out of the arm's reach from where the platform stands: not cleaned"]
    left_out = {**clean, "case": "b", "passed": False, "discs": [{**disc, "cleaned": False}, disc]}
    left_out["controller_events"] = out
    refused = {"case": "c", "passed": False, "refused": "no disc within reach", "finished_s": None}
    runs = [clean, left_out, refused]
    assert [robustness.outside_workspace(r) for r in runs] == [False, True, True]
    figures = robustness.goals(runs)
    assert figures["within_reach_runs"] == 1 and figures["all_cleaned_within_reach"] == 1.0
    assert figures["all_cleaned"] == pytest.approx(1 / 3)
    text = robustness.table(robustness.rows(runs), figures)
    assert "2 of the 3 runs have a disc outside the arm's workspace" in text and "of the other 1, 100%" in text
    everywhere = robustness.table(robustness.rows([clean]), robustness.goals([clean]))
    assert "outside the arm's workspace" not in everywhere  # said only where there is such a run
