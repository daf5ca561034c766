"""The notebook API (pneumatic_arm_twin) and the commands around a logged run: a wrist-rig run
logged as MCAP and read back, replayed without --model, plotted by `twin plot`; a sweep's table;
a gap diagnosis that names a hidden effect."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import pneumatic_arm_twin as pat
from gap import GapError
from scenarios.schema import ScenarioError
from twin_cli.cli import main as twin_main
from wrist_rig import commanded_run

SCENARIO = "wrist_closed_loop_60deg"  # the paper's Fig. 23 rig: one joint, 60 deg at 0.5 MPa


@pytest.fixture(scope="module")
def wrist(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("api")
    return tmp, pat.run(SCENARIO, duration_s=1.5, mcap=tmp / "wrist.mcap")


def test_run_gives_the_telemetry_it_logged(wrist):
    tmp, run = wrist
    a = run.arrays()
    assert run.joints == ("wrist_pitch",) and a["true_angle_rad"].shape == (len(a["time_s"]), 1)
    # the wrist really turned toward its 60 deg target (not a run of constants)
    turned = np.degrees(a["true_angle_rad"][-1, 0] - a["true_angle_rad"][0, 0])
    assert 10.0 < turned < 70.0
    assert run.summary["joints"]["wrist_pitch"]["true_final_deg"] == pytest.approx(
        np.degrees(a["true_angle_rad"][-1, 0]), abs=1e-3
    )
    log = pat.read_log(tmp / "wrist.mcap")
    assert log.meta["recovery"]["complete"]
    for name, value in a.items():
        assert np.array_equal(log.arrays()[name], value, equal_nan=True), name
    table = run.table()
    assert {len(v) for v in table.values()} == {len(a["time_s"])}
    np.testing.assert_array_equal(table["true_angle_rad.wrist_pitch"], a["true_angle_rad"][:, 0])
    np.testing.assert_array_equal(table["brush_push_n.z"], a["brush_push_n"][:, 2])
    body = run.bodies[0]
    np.testing.assert_array_equal(table[f"body_quat_wxyz.{body}.w"], a["body_quat_wxyz"][:, 0, 0])


def test_to_dataframe_is_indexed_by_time(wrist):
    _, run = wrist
    df = run.to_dataframe()
    a = run.arrays()
    assert df.index.name == "time_s" and df.shape == (len(a["time_s"]), len(run.table()) - 1)
    np.testing.assert_array_equal(df.index.to_numpy(), a["time_s"])
    t = float(a["time_s"][10])
    assert df.loc[t, "true_angle_rad.wrist_pitch"] == a["true_angle_rad"][10, 0]


def test_replay_of_a_wrist_rig_log_needs_no_model(wrist, tmp_path, capsys):
    import rerun as rr

    tmp, run = wrist
    assert twin_main(["replay", str(tmp / "wrist.mcap"), "--rrd", str(tmp_path / "w.rrd")]) == 0
    paths = {c.entity_path for c in rr.chunk.RrdReader(tmp_path / "w.rrd").stream()}
    assert {f"/world/arm/{b}" for b in run.bodies} <= paths and "/world/scene/bench" in paths


def test_twin_plot_draws_the_angles_of_a_log(wrist, tmp_path, capsys):
    import matplotlib.image as mpimg

    tmp, _ = wrist
    out = tmp_path / "angles.png"
    assert twin_main(["plot", str(tmp / "wrist.mcap"), "--out", str(out)]) == 0
    assert "from the whole file" in capsys.readouterr().out
    img = mpimg.imread(out)
    # one panel (the rig has one joint): the figure is one panel high (2.6 in at 110 dpi)
    assert img.shape[0] == pytest.approx(2.6 * 110, abs=2)
    # the true angle is drawn in black: there are dark pixels in the panel
    assert (img[..., :3].max(axis=-1) < 0.2).sum() > 200
    before = (tmp / "wrist.mcap").read_bytes()
    assert twin_main(["plot", str(tmp / "wrist.mcap"), "--out", str(tmp / "wrist.mcap")]) == 2
    assert (tmp / "wrist.mcap").read_bytes() == before
    assert "--out" in capsys.readouterr().err


def test_twin_plot_checks_out_before_the_work_and_says_where_it_wrote(wrist, tmp_path, capsys):
    """A suffix that is no picture format, a folder, a path under a file: one line each, before
    the log is read; a name without a suffix gets .png, and the path printed is the one written."""
    tmp, _ = wrist
    (tmp_path / "folder").mkdir()
    (tmp_path / "afile").write_text("x")
    cases = [
        ("p.txt", ["--out", "p.txt", ".txt is not a picture format", "allowed:", ".png", ".svg"]),
        ("folder", ["--out", "folder: is a folder"]),
        ("afile/x.png", ["--out", "afile, a file, as if it were a folder"]),
    ]
    for out, needles in cases:
        assert twin_main(["plot", str(tmp / "wrist.mcap"), "--out", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and all(n in err for n in needles), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "folder"]
    assert twin_main(["plot", str(tmp / "wrist.mcap"), "--out", str(tmp_path / "pnoext")]) == 0
    written = tmp_path / "pnoext.png"
    assert capsys.readouterr().out.startswith(f"{written}: ")
    assert written.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_scenario_by_name_path_or_refused():
    assert pat.scenario(SCENARIO).name == SCENARIO
    assert pat.scenario(SCENARIO, **{"supply.pressure_mpa": 0.7}).supply.pressure_mpa == 0.7
    nested = pat.scenario(SCENARIO, {"supply": {"pressure_mpa": 0.7}, "seed": 5})
    assert nested.supply.pressure_mpa == 0.7 and nested.seed == 5
    with pytest.raises(ScenarioError, match="supply.pressure_mpa"):
        pat.scenario(SCENARIO, {"supply": {"pressure_mpa": 1.4}})
    with pytest.raises(ScenarioError, match="shipped: .*insulator_cleaning"):
        pat.scenario("no_such_scenario")


def test_sweep_table_and_csv(tmp_path):
    sw = pat.sweep(SCENARIO, {"supply.pressure_mpa": [0.5, 0.7]}, duration_s=0.6)
    table = sw.table()
    assert table["set.supply.pressure_mpa"] == [0.5, 0.7]
    assert table["wrist_pitch.true_final_deg"] == [s["joints"]["wrist_pitch"]["true_final_deg"] for s in sw.summaries]
    with open(sw.to_csv(tmp_path / "sweep.csv")) as f:
        rows = list(csv.DictReader(f))
    assert [float(r["wrist_pitch.true_final_deg"]) for r in rows] == table["wrist_pitch.true_final_deg"]
    assert [r["final_error_deg[wrist_pitch].passed"] for r in rows] == [
        "" if v is None else str(v)
        for v in table["final_error_deg[wrist_pitch].passed"]  # None: cut short, not judged
    ]


def test_sweep_command_writes_the_table_beside_the_json(tmp_path, capsys):
    out = tmp_path / "s.json"
    path = str(pat.api.shipped_scenario_path(SCENARIO))
    twin_main(
        ["sweep", path, "--set", "supply.pressure_mpa=0.6", "--duration", "0.3", "--workers", "1", "--out", str(out)]
    )
    assert "one row per run in" in capsys.readouterr().out
    summaries = json.loads(out.read_text())
    with open(tmp_path / "s.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(summaries) == 1 and rows[0]["seed"] == str(summaries[0]["seed"])


def test_diagnose_names_a_hidden_leak(tmp_path):
    """A campaign from the plant with a vane leak the twin lacks: the API's diagnosis names it."""

    # in memory: no campaign folder is left on disk
    campaign = pat.synthetic_campaign(
        commanded_run.wrist_params()._replace(leak_area_m2=4e-7), seed=2, pressures_mpa=(0.5, 0.8)
    )
    assert not campaign.folder.exists() and len(campaign.runs) == 4
    d = pat.diagnose(campaign, effects=["vane_leakage", "coulomb_friction"], out=tmp_path / "report")
    assert d.verdict == "explained" and d.effect == "vane_leakage"
    assert d.after_rms_deg < 0.3 * d.before_rms_deg
    assert d.ranking()["name"][0] == "vane_leakage"
    assert (tmp_path / "report" / "report.md").is_file()
    with pytest.raises(GapError, match="not in the catalogue"):
        pat.diagnose(campaign, effects=["no_such_effect"])


def test_the_gap_packages_functions_are_not_shadowed_by_their_modules():
    # a user's earlier `import gap.diagnose` (or the package's own) must not turn `from gap import
    # diagnose` into the module: it did while gap/__init__ imported the functions on use
    import gap.bench
    import gap.diagnose
    import gap.synth
    from gap import diagnose, make_campaign, run_bench

    assert all(callable(f) for f in (diagnose, make_campaign, run_bench)), (diagnose, make_campaign, run_bench)
    assert gap.diagnose is diagnose


def test_study_in_memory_as_a_dataframe_and_its_csv(tmp_path):
    """The cleaning study from Python: a row per strategy and supply, as a DataFrame, and the CSV
    `twin study` writes beside its JSON holds the same rows."""
    from scenarios.study import write

    st = pat.study(["sensorless"], [0.6], seeds=1, workers=1, duration_s=1.0)
    df = st.to_dataframe()
    assert list(df["strategy"]) == ["sensorless"] and list(df["supply_mpa"]) == [0.6]
    assert df["runs"].iloc[0] == len(st.summaries) == 1
    write(st.summaries, tmp_path)
    with open(tmp_path / "study.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["strategy"], float(r["supply_mpa"]), int(r["cleaned_min"])) for r in rows] == [
        ("sensorless", 0.6, int(df["cleaned_min"].iloc[0]))
    ]
