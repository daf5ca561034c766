"""No input costs a result: every class of bad input is refused before any work with one line
naming the file or flag, the field, the value and what is allowed (exit status 2); finished
results survive a failing output place; SIGTERM stops a run like Ctrl-C; two runs never write
one file; a campaign reads only its own folder; shipped scenarios are found by name.

docs/validation/inputs.md lists each class; each has a test here."""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from logwait import wait_until_logged
from test_scenarios import MINIMAL

from gap.campaign import GapError, load_campaign
from scenarios.schema import SHIPPED_DIR, ScenarioError, load, parse
from twin.mcap_log import LogError, McapWriter, read_mcap
from twin.telemetry import SIGNALS
from twin_cli.cli import build_parser, main
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import OutputLock, check_output, keep_result, publish_folder, write_atomic

ROOT = Path(__file__).resolve().parent.parent
RIG = MINIMAL.replace('mode = "none"', 'mode = "closed_loop"')  # a 0.2 s wrist-rig scenario
ARM = RIG.replace('"wrist_rig"', '"arm"').replace('"zero"', '"home"')


def one_line_error(capsys, *needles: str) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err  # one line, no traceback
    for n in needles:
        assert n in lines[0], (n, lines[0])
    return lines[0]


# --- command-line numbers ----------------------------------------------------------------------
@pytest.mark.parametrize("command", [["run", "S"], ["sweep", "S"]])
@pytest.mark.parametrize(
    "flag, value",
    [
        ("--duration", "nan"),
        ("--duration", "inf"),
        ("--duration", "-1"),
        ("--duration", "0"),
        ("--duration", "ten"),
    ],
)
def test_duration_must_be_a_finite_positive_number(command, flag, value, capsys):
    with pytest.raises(SystemExit) as e:
        main([*command, flag, value])
    assert e.value.code == 2
    one_line_error(capsys, flag, repr(value), "allowed")


@pytest.mark.parametrize(
    "argv, flag, value",
    [
        (["run", "S"], "--camera-fps", "inf"),
        (["run", "S"], "--camera-fps", "nan"),
        (["run", "S"], "--camera-fps", "-2"),
        (["run", "S"], "--camera-fps", "1000"),
        (["run", "S"], "--seed", "-1"),
        (["run", "S"], "--seed", "1.5"),
        (["sweep", "S"], "--workers", "-1"),
        (["sweep", "S"], "--monte-carlo", "-3"),
        (["sweep", "S"], "--monte-carlo", "nan"),
        (["gap", "diagnose", "C", "--out", "D"], "--jobs", "0"),
        (["gap", "diagnose", "C", "--out", "D"], "--jobs", "-1"),
        (["gap", "diagnose", "C", "--out", "D"], "--model-tolerance-deg", "nan"),
        (["gap", "diagnose", "C", "--out", "D"], "--model-tolerance-deg", "-5"),
        (["gap", "diagnose", "C", "--out", "D"], "--model-tolerance-deg", "inf"),
        (["gap", "bench", "--out", "D"], "--jobs", "0"),
    ],
)
def test_every_numeric_flag_refuses_nan_inf_and_out_of_range(argv, flag, value, capsys):
    with pytest.raises(SystemExit) as e:
        main([*argv, flag, value])
    assert e.value.code == 2
    one_line_error(capsys, flag, repr(value), "allowed")


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["run", "S"], "--rrd"),
        (["run", "S"], "--mcap"),
        (["sweep", "S"], "--out"),
        (["paper"], "--out"),
        (["gap", "diagnose", "C"], "--out"),
        (["gap", "bench"], "--out"),
        (["study", "cleaning"], "--out"),
        (["replay", "X.mcap"], "--rrd"),
        (["plot", "X.mcap"], "--out"),
    ],
)
def test_an_empty_output_place_is_refused(argv, flag, capsys):
    """`--out ''` was the working folder: gap diagnose wrote its report there without a word."""
    with pytest.raises(SystemExit) as e:
        main([*argv, flag, ""])
    assert e.value.code == 2
    one_line_error(capsys, flag, "'' is empty; allowed: a file or folder name")


@pytest.mark.parametrize(
    "flag, value, needle",
    [
        ("--strategies", ",", "'' is not a strategy"),  # was every strategy: a whole study started
        ("--strategies", "operator,operator", "'operator' is listed twice"),
        ("--strategies", "pilot", "'pilot' is not a strategy"),
        ("--supplies", "0.5,0.5", "'0.5' is listed twice"),
        ("--supplies", "0.5,nan", "'nan'"),
    ],
)
def test_a_study_refuses_empty_unknown_or_repeated_items(tmp_path, capsys, flag, value, needle):
    assert main(["study", "cleaning", "--out", str(tmp_path / "o"), flag, value]) == 2
    one_line_error(capsys, flag, needle, "allowed")
    assert not (tmp_path / "o").exists()  # refused before any run


def test_an_unreachable_scheduler_is_refused_before_any_run(tmp_path, monkeypatch, capsys):
    import scenarios.sweep
    import twin_plumbing.cluster

    monkeypatch.setattr(twin_plumbing.cluster, "SCHEDULER_TIMEOUT_S", 1.0)
    f = tmp_path / "s.toml"
    f.write_text(RIG)
    ran = []
    monkeypatch.setattr(scenarios.sweep, "_run_point", lambda *a: ran.append(a))
    assert main(["sweep", str(f), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    one_line_error(capsys, "--scheduler tcp://127.0.0.1:9", "allowed")
    assert not ran


def test_a_sweep_grid_that_would_lose_points_is_refused(tmp_path, capsys):
    """A field given twice kept only the last values (one run for two); a grid of seeds with
    --monte-carlo ran every point on the same child seeds: both refused, naming what to give."""
    f = tmp_path / "s.toml"
    f.write_text(RIG)
    out = tmp_path / "sw.json"
    cases = [
        (
            ["--set", "supply.pressure_mpa=0.5", "--set", "supply.pressure_mpa=0.6"],
            ["supply.pressure_mpa is given twice", "allowed", "supply.pressure_mpa=0.5,0.6"],
        ),
        (["--set", "seed=1,2", "--monte-carlo", "1"], ["seed = [1, 2]", "monte_carlo = 1", "allowed: one of them"]),
    ]
    for flags, needles in cases:
        assert main(["sweep", str(f), *flags, "--workers", "1", "--out", str(out)]) == 2
        one_line_error(capsys, *needles)
        assert not out.exists()


@pytest.mark.parametrize("address", ["garbage", "tcp://127.0.0.1:9"])
def test_gap_diagnose_refuses_a_scheduler_that_does_not_answer_before_any_work(tmp_path, monkeypatch, capsys, address):
    """`twin gap diagnose --scheduler` checks the address as `twin sweep --scheduler` does (one
    line, exit 2), before the diagnosis starts, not with a traceback at its fits."""
    import twin_plumbing.cluster

    monkeypatch.setattr(twin_plumbing.cluster, "SCHEDULER_TIMEOUT_S", 1.0)
    out = tmp_path / "out"
    assert main(["gap", "diagnose", str(campaign(tmp_path / "c")), "--out", str(out), "--scheduler", address]) == 2
    one_line_error(capsys, f"--scheduler {address}: no Dask scheduler answers there", "allowed")
    assert not list(out.iterdir()) and sorted(p.name for p in tmp_path.iterdir()) == ["c", "out"]


@pytest.mark.parametrize(
    "only, needle",
    [("nnone_0", "'nnone_0' names no case"), ("", "'' names no case"), ("none_0,,", "'' names no case")],
)
def test_gap_bench_only_must_name_cases(tmp_path, capsys, only, needle):
    """`twin gap bench --only` with a typo ran no case (exit 0, a summary of None) and an empty one
    ran all: refused before any work, with the names and kinds allowed."""
    out = tmp_path / "out"
    assert main(["gap", "bench", "--out", str(out), "--only", only]) == 2
    one_line_error(capsys, f"--only {only!r}", needle, "allowed", "none_0", "single, form, pair, outside, none")
    assert main(["gap", "bench", "--out", str(out), "--quick", "--only", "coulomb"]) == 2
    one_line_error(capsys, "allowed with --quick: vane_leakage, none_1")
    assert not out.exists()


def test_every_argument_has_help_and_there_is_a_version(capsys):
    def walk(parser, where):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                assert action.help, f"{where}: its subcommands have no help"
                for choice in action._choices_actions:
                    assert choice.help, f"{where} {choice.dest}: no help"
                for name, sub in action.choices.items():
                    walk(sub, f"{where} {name}")
            elif action.dest != "help":
                assert action.help, f"{where}: {action.option_strings or action.dest} has no help"

    walk(build_parser(), "twin")
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    out = capsys.readouterr().out.strip()
    assert out.startswith("twin ") and out.split()[1][0].isdigit()


# --- scenario fields ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, field, value",
    [
        ("", "empty scenario", ""),
        ("# only a comment\n", "empty scenario", ""),
        (RIG + "[start.angles_deg]\nwrist_pitch = 350.0", "start.angles_deg.wrist_pitch", "350.0"),
        (RIG + "[[targets]]\nangles_deg = { wrist_pitch = 300.0 }", "targets[0].angles_deg.wrist_pitch", "300.0"),
        (
            ARM + "[[targets]]\nangles_deg = { elbow_pitch = -100.0 }",
            "targets[0] puts joint elbow_pitch at -190.0 deg",
            "elbow_pitch -100.0",
        ),
        (ARM + "[[targets]]\nbrush_at_disc = 1\nstandoff_m = 0.5", "standoff_m = 0.5", "out of the brush's reach"),
        (RIG + "[[criteria]]\nkind = 'final_error_deg'\nmax = 1.0", "criteria[0].kind", "no [[targets]]"),
        (
            RIG
            + "[[targets]]\nangles_deg = { wrist_pitch = 30.0 }\n"
            + "[[criteria]]\nkind = 'max_error_deg'\nmin = 5.0\nmax = 1.0",
            "criteria[0].min",
            "5.0",
        ),
        (
            RIG.replace("closed_loop", "none")
            + "[[targets]]\nangles_deg = { wrist_pitch = 30.0 }\n[[criteria]]\nkind = 'final_error_deg'\nmax = 1.0",
            "criteria[0].kind",
            "'final_error_deg'",
        ),
        (
            RIG.replace("closed_loop", "none") + "[[criteria]]\nkind = 'prediction_error_deg'\nmax = 1.0",
            "criteria[0].kind",
            "'prediction_error_deg'",
        ),
        (RIG + "[[criteria]]\nkind = 'brush_on_disc'\nmax = 0.1", "criteria[0].kind", "'brush_on_disc'"),
        (RIG + "[[criteria]]\nkind = 'max_drop_m'\nmax = 0.1", "criteria[0].kind", "'max_drop_m'"),
        (RIG + "[[criteria]]\nkind = 'max_travel_deg'\nmax = 1.0", "criteria[0].joint", "<missing>"),
        (ARM + "[[criteria]]\nkind = 'contact_force_n'\nmax = 100.0\ndisc = 3", "criteria[0].disc", "3"),
        (
            ARM + "[string]\ndiscs = 4\n[[criteria]]\nkind = 'brush_on_disc'\nmax = 0.1\ndisc = 8",
            "criteria[0].disc",
            "1..4",
        ),
        (ARM + "[[criteria]]\nkind = 'disc_force_n'\nmin = 10.0\ndisc = 9", "criteria[0].disc", "1..8"),
        (RIG + "[supply]\nkind = 'steps'\nsteps = [[inf, 0.5]]", "supply.steps", "inf"),
        (RIG + "[supply]\nkind = 'steps'\nsteps = [[1.0, 0.5], [0.5, 0.6]]", "supply.steps", "[0.5, 0.6]"),
        (
            RIG + "[[faults]]\nkind = 'hose_leak'\nat_s = 0.0\njoint = 'wrist_pitch'\nvalue = -1e-6",
            "faults[0].value",
            "-1e-06",
        ),
        (
            RIG + "[[faults]]\nkind = 'hose_leak'\nat_s = 0.0\njoint = 'wrist_pitch'\nvalue = 1e-4",
            "faults[0].value",
            "0.0001",
        ),
        (
            RIG + "[[faults]]\nkind = 'sensor_bias'\nat_s = 0.0\njoint = 'wrist_pitch'\nvalue = nan",
            "faults[0].value",
            "nan",
        ),
        (
            RIG + "[[faults]]\nkind = 'brake_fails'\nat_s = 0.0\njoint = 'wrist_pitch'\nvalue = 3.0",
            "faults[0].value",
            "3.0",
        ),
        (RIG + "duration = 3.0", "duration", "not a known field"),
        # fields the run would not read
        (RIG + "[payload]\nmass_kg = 40.0", "payload.mass_kg", "40.0"),
        (RIG + "[supply]\nsteps = [[0.0, 0.1]]", "supply.steps", "[[0.0, 0.1]]"),
        (RIG + "[supply]\nkind = 'constant'\nmean_mpa = 0.1", "supply.mean_mpa", "0.1"),
        (RIG + "[supply]\nkind = 'random'\npressure_mpa = 0.5", "supply.pressure_mpa", "0.5"),
        (RIG + "[supply]\nkind = 'steps'\nsteps = [[0.0, 0.5]]\nhold_s = 1.0", "supply.hold_s", "1.0"),
    ],
)
def test_scenarios_inconsistent_with_the_model_or_themselves_are_refused(text, field, value):
    with pytest.raises(ScenarioError) as e:
        parse(text, "scenarios/bad.toml")
    message = str(e.value)
    assert message.startswith("scenarios/bad.toml: ") and "\n" not in message
    assert field in message and value in message and "allowed" in message, message


@pytest.mark.parametrize(
    "table, fields, needles",
    [
        ("reality", "rotor_radius_m = 0.02", ["rotor_radius_m = 0.02", "smaller than stator_radius_m = 0.011"]),
        ("predictor", "rotor_radius_m = 0.02", ["rotor_radius_m = 0.02", "smaller than stator_radius_m"]),
        (
            "reality",
            "brake_release_start_gauge_pa = 9e5",
            ["brake_release_start_gauge_pa = 900000", "must not exceed brake_release_gauge_pa = 400000"],
        ),
        ("reality", "hose_loss = 0.5", ["hose_loss = 0.5", "allowed: 0 or 1"]),
        ("predictor", "brake_fed_by_motor = 0.5", ["brake_fed_by_motor = 0.5", "allowed: 0 or 1"]),
        (
            "reality",
            "reducer_backlash_rad = 0.1\nrotor_inertia_kg_m2 = 0.0",
            ["rotor_inertia_kg_m2 = 0 with a non-rigid reducer", "reducer_backlash_rad = 0.1", "rotor inertia > 0"],
        ),
    ],
)
def test_scenario_effects_must_hold_together_as_a_parameter_file(tmp_path, capsys, table, fields, needles):
    """A scenario's effects on a joint are checked with the parameter file's own cross-field checks
    (pneumatics.params.check_related), before the run, naming the scenario, the table and the field."""
    path = tmp_path / "effects.toml"
    path.write_text(
        RIG + f"[[targets]]\nangles_deg = {{ wrist_pitch = 30.0 }}\n[{table}.effects.wrist_pitch]\n{fields}\n"
    )
    mcap = tmp_path / "run.mcap"
    assert main(["run", str(path), "--mcap", str(mcap)]) == 2
    field = needles[0].split(" =")[0]
    one_line_error(capsys, f"{path}: {table}.effects.wrist_pitch.{field}", *needles)
    assert not mcap.exists()  # refused before any work


def test_a_gear_too_stiff_for_the_plant_names_the_scenario(tmp_path, capsys):
    """What only the plant can check (a gear too stiff for its physics step) named the joint alone:
    the error now says which file and table set it."""
    path = tmp_path / "stiff.toml"
    path.write_text(
        RIG + "[[targets]]\nangles_deg = { wrist_pitch = 30.0 }\n"
        "[reality.effects.wrist_pitch]\nreducer_compliance_rad_per_nm = 1e-9\n"
    )
    assert main(["run", str(path), "--duration", "0.1"]) == 2
    one_line_error(capsys, f"{path}: [reality] wrist_pitch", "reducer_compliance_rad_per_nm = 1e-09", "allowed")


def test_a_plan_the_controller_refuses_cannot_pass_final_error(capsys):
    """A 10 deg move under a 20 deg minimum rotation is refused at run time (the arm stays
    braked): the error against the target asked for is 10 deg, and the criterion fails."""
    from scenarios.runner import run_scenario

    s = parse(
        RIG.replace("duration_s = 0.2", "duration_s = 0.3")
        + "min_rotation_deg = 20.0\n[[targets]]\nangles_deg = { wrist_pitch = 10.0 }\n"
        "[[criteria]]\nkind = 'final_error_deg'\nmax = 1.0\n[[criteria]]\nkind = 'max_error_deg'\nmax = 1.0\n",
        "refused.toml",
    )
    result = run_scenario(s)
    assert result.refusal
    final, worst = result.verdicts
    assert final.value == pytest.approx(10.0, abs=0.5) and not final.passed
    assert not worst.passed and not result.passed


def test_a_scenario_that_is_no_regular_file_is_refused_at_once(tmp_path, capsys):
    """A named pipe as the scenario blocked the command until killed (nobody writes to it), and
    /dev/zero would never end: both are refused in one line before anything is read."""
    fifo = tmp_path / "s.toml"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero")):
        assert main(["run", str(path)]) == 2
        one_line_error(capsys, str(path), "is not a regular file", "allowed")


def test_shipped_scenarios_are_found_by_name_from_any_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    s = load("insulator_cleaning")
    assert Path(s.path) == SHIPPED_DIR / "insulator_cleaning.toml" and s.name == "insulator_cleaning"
    assert load("wrist_min_rotation.toml").model == "wrist_rig"
    # the files are package data of `scenarios`, so a plain (non-editable) install has them
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "*.toml" in package_data["scenarios"]
    (tmp_path / "insulator_cleaning").mkdir()  # a folder of that name here is not a scenario file
    with pytest.raises(ScenarioError, match="cannot be read"):
        load("insulator_cleaning")
    assert main(["run", "no_such_scenario"]) == 2
    one_line_error(capsys, "no_such_scenario", "insulator_cleaning")


# --- campaign fields and files -----------------------------------------------------------------
HEADER = "time_s,direction,brake_released,valve_set_gauge_pa,supply_pa,angle_rad,p_a_pa,p_b_pa"
ROWS = [
    "0.00,0,0,0,601325,0.0,101325,101325",
    "0.02,1,1,400000,601325,,350000,101325",
    "0.04,1,1,400000,601325,0.01,,",
    "0.06,1,1,400000,601325,0.03,360000,110000",
]
TOML = """joint = "wrist_pitch"
hose_length_m = 8.0
[[runs]]
file = "a.csv"
supply_mpa = 0.5
start_deg = { wrist_pitch = 0.0 }
[[runs]]
file = "b.csv"
supply_mpa = 0.5
start_deg = { wrist_pitch = 0.0 }
"""


def campaign(folder: Path, toml: str = TOML, rows: list[str] = ROWS) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "campaign.toml").write_text(toml)
    for name in ("a.csv", "b.csv"):
        (folder / name).write_text("\n".join([HEADER, *rows]) + "\n")
    return folder


def edit_row(k: int, column: str, value: str) -> list[str]:
    rows = [r.split(",") for r in ROWS]
    rows[k][HEADER.split(",").index(column)] = value
    return [",".join(r) for r in rows]


def test_a_good_small_campaign_loads(tmp_path):
    c = load_campaign(campaign(tmp_path / "c"))
    assert len(c.runs) == 2 and c.runs[0].extra["p_a_pa"][1] == 350000


@pytest.mark.parametrize(
    "toml, rows, needles",
    [
        (TOML + "colour = 'red'\n", ROWS, ["campaign.toml", "colour is not a known field", "allowed"]),
        (
            TOML.replace("supply_mpa = 0.5\n", "supply_mpa = 0.5\nsuply = 1\n", 1),
            ROWS,
            ["[[runs]] #1", "suply is not a known field"],
        ),
        (TOML + "[twin]\nhose_los = true\n", ROWS, ["[twin] hose_los is not a known field"]),
        (TOML.split('[[runs]]\nfile = "b.csv"')[0], ROWS, ["1 [[runs]]", "at least 2"]),
        (TOML, edit_row(3, "time_s", "3600.06"), ["a.csv", "time_s jumps from 0.04 to 3600.06", "allowed"]),
        (TOML, edit_row(2, "time_s", "0.01"), ["a.csv:4", "time_s = 0.01 does not increase", "allowed"]),
        (
            TOML,
            [f"{k * 0.5:.1f},0,0,0,601325,0.0,," for k in range(1300)],
            ["a.csv:1203", "time_s = 600.5 is 600.5 s after the first row", "allowed: runs of at most 600 s"],
        ),
        (TOML, edit_row(1, "p_a_pa", "-5000"), ["a.csv:3", "p_a_pa = -5000", "allowed: absolute Pa above 0"]),
        (TOML, edit_row(1, "supply_pa", "-1"), ["a.csv:3", "supply_pa = -1", "allowed"]),
        (
            TOML.replace("supply_mpa = 0.5", "supply_mpa = 0.8", 1),
            ROWS,
            ["supply_mpa = 0.8", "averages 0.500 MPa", "allowed"],
        ),
        (
            TOML,
            edit_row(2, "angle_rad", "1e6"),
            ["a.csv", "angle_rad = 1e+06", "outside wrist_pitch's range", "allowed"],
        ),
        (
            TOML.replace("wrist_pitch = 0.0", "wrist_pitch = 350.0", 1),
            ROWS,
            ["start_deg.wrist_pitch = 350.0", "allowed: -90.0..90.0 deg"],
        ),
    ],
)
def test_bad_campaigns_are_refused_with_file_field_value_and_allowed(tmp_path, toml, rows, needles):
    folder = campaign(tmp_path / "c", toml, rows)
    with pytest.raises(GapError) as e:
        load_campaign(folder)
    message = str(e.value)
    assert "\n" not in message
    for n in needles:
        assert n in message, (n, message)


CSV = "\n".join([HEADER, *ROWS]) + "\n"


@pytest.mark.parametrize(
    "data, needles",
    [
        (
            CSV.replace("0.02,", "0.0\xe9,", 1).encode("latin-1"),
            ["a.csv:3: byte 0xe9 is not UTF-8", "allowed: a UTF-8"],
        ),
        (CSV.replace("0.02,", "0.02" + "7" * 140_000 + ",", 1).encode(), ["a.csv:3: not readable as CSV", "allowed"]),
        (
            (HEADER.replace("angle_rad", "p_a_pa") + "\n").encode() + CSV.split("\n", 1)[1].encode(),
            ["a.csv:1: column(s) p_a_pa appear more than once", "allowed"],
        ),
    ],
)
def test_run_files_that_are_no_readable_csv_are_refused_in_one_line(tmp_path, data, needles):
    """A run file in another encoding, with a field beyond the csv module's limit or a column
    twice is refused naming the file, the line and what is allowed (not a traceback; a column
    twice was read silently)."""
    folder = campaign(tmp_path / "c")
    (folder / "a.csv").write_bytes(data)
    with pytest.raises(GapError) as e:
        load_campaign(folder)
    assert "\n" not in str(e.value)
    for n in needles:
        assert n in str(e.value), (n, str(e.value))


def test_run_files_a_bom_a_folder_and_a_file_listed_twice(tmp_path):
    """A byte-order mark (a spreadsheet's UTF-8 export) is read; a run file that is a folder is
    called one; the same file for two runs is refused (one recording would pass for two repeats)."""
    folder = campaign(tmp_path / "c")
    (folder / "a.csv").write_bytes(b"\xef\xbb\xbf" + CSV.encode())
    assert len(load_campaign(folder).runs) == 2
    (folder / "b.csv").unlink()
    (folder / "b.csv").mkdir()
    with pytest.raises(
        GapError, match=r"\[\[runs\]\] #2\): run file .*b\.csv is a folder; allowed: a CSV or \.mcap file"
    ):
        load_campaign(folder)
    (folder / "campaign.toml").write_text(TOML.replace('"b.csv"', '"./a.csv"'))
    with pytest.raises(GapError, match=r"#2\): file = './a.csv' is also \[\[runs\]\] #1's; allowed: a file of its own"):
        load_campaign(folder)


def test_a_bom_a_pipe_and_an_open_range_say_what_they_are(tmp_path, capsys):
    """A scenario an editor saved with a byte-order mark ("Invalid statement" before; run files
    took one already), a run file that is a pipe ("does not exist" before), and a criterion's
    unbounded max, whose allowed range read "0..inf"."""
    s = tmp_path / "bom.toml"
    s.write_bytes(b"\xef\xbb\xbf" + RIG.encode())
    assert load(s) == parse(RIG, str(s))
    folder = campaign(tmp_path / "c")
    (folder / "b.csv").unlink()
    os.mkfifo(folder / "b.csv")
    with pytest.raises(GapError, match=r"run file .*b\.csv is not a regular file \(a pipe"):
        load_campaign(folder)
    inf = tmp_path / "inf.toml"
    inf.write_text(RIG + '[[criteria]]\nkind = "max_travel_deg"\njoint = "wrist_pitch"\nmax = inf\n')
    assert main(["run", str(inf)]) == 2
    line = one_line_error(capsys, "max = inf", "allowed: a finite number >= 0")
    assert "..inf" not in line


@pytest.mark.parametrize("name", ["../outside.csv", "ABSOLUTE", "link.csv"])
def test_a_campaign_reads_only_files_inside_its_folder(tmp_path, name):
    outside = tmp_path / "outside.csv"
    outside.write_text("\n".join([HEADER, *ROWS]) + "\n")
    folder = campaign(tmp_path / "c")
    (folder / "link.csv").symlink_to(outside)
    name = str(outside) if name == "ABSOLUTE" else name
    (folder / "campaign.toml").write_text(TOML.replace('"b.csv"', json.dumps(name)))
    with pytest.raises(
        GapError, match=r"\(\[\[runs\]\] #2\): file = .* (leaves|leads out of) the campaign folder.*allowed"
    ):
        load_campaign(folder)


def fake_log(path: Path, n: int = 400) -> None:
    """A log in the twin's MCAP format, written by its own writer, of a still wrist (no plant run)."""
    joints, bodies = ("wrist_pitch",), ("rig",)
    a = {"time_s": np.arange(n) * 0.02}
    for name, shape in SIGNALS.items():
        dims = tuple(1 if d == "n" else len(bodies) if d == "b" else d for d in shape)
        a[name] = np.zeros((n, *dims))
    a["supply_pa"][:] = 601325.0
    w = McapWriter(path, joints, bodies, b"", {"seed": 0})
    for start in range(0, n, 50):
        w.write_arrays({k: v[start : start + 50] for k, v in a.items()}, start)
    w.close()


def test_a_cut_short_mcap_run_is_refused(tmp_path):
    folder = campaign(tmp_path / "c")
    fake_log(folder / "b.mcap")
    (folder / "campaign.toml").write_text(TOML.replace('"b.csv"', '"b.mcap"'))
    assert len(load_campaign(folder).runs) == 2  # whole, it is a run like any other
    data = (folder / "b.mcap").read_bytes()
    (folder / "b.mcap").write_bytes(data[: len(data) // 2])
    assert not read_mcap(folder / "b.mcap")[1]["recovery"]["complete"]
    with pytest.raises(GapError, match=r"b\.mcap: the log is cut short .* readable\); allowed: a complete log"):
        load_campaign(folder)


def test_replay_model_is_checked_before_mujoco_reads_it(tmp_path, capsys):
    """`twin replay --model` given a scenario, a folder, a missing file: one line each, before
    MuJoCo (whose refusals run over several lines; a folder made it warn of a file over 2 GB)."""
    fake_log(tmp_path / "r.mcap")
    (tmp_path / "s.toml").write_text(RIG)
    (tmp_path / "folder").mkdir()
    (tmp_path / "bad.xml").write_text("<mujoco><bad")
    cases = [
        ("s.toml", "not an .xml file"),
        ("folder", "is not a file"),
        ("nope.xml", "no such file"),
        ("bad.xml", "cannot load the MJCF model"),  # MuJoCo's own words, on one line
    ]
    for model, needle in cases:
        argv = ["replay", str(tmp_path / "r.mcap"), "--rrd", str(tmp_path / "r.rrd"), "--model", str(tmp_path / model)]
        assert main(argv) == 2, model
        one_line_error(capsys, model, needle)
    assert not (tmp_path / "r.rrd").exists()


def test_mujoco_says_its_warnings_but_leaves_no_log_file(tmp_path, monkeypatch, capfd):
    """MuJoCo appends each warning and error to MUJOCO_LOG.TXT in the working folder unless told
    not to: the twin keeps the message on the console and no file where the user stands."""
    from twin.model import load_model

    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    with pytest.raises(ValueError):
        load_model(tmp_path / "folder")  # a folder: MuJoCo warns, then refuses it
    captured = capfd.readouterr()
    assert "WARNING" in captured.out + captured.err
    assert list(tmp_path.iterdir()) == [tmp_path / "folder"]


# --- output places -----------------------------------------------------------------------------
def test_outputs_must_differ_from_inputs_and_each_other_and_be_writable(tmp_path, capsys):
    s = tmp_path / "s.toml"
    s.write_text(RIG)
    afile = tmp_path / "afile"
    afile.write_text("x")
    cases = [
        (
            ["run", str(s), "--rrd", str(tmp_path / "x.log"), "--mcap", str(tmp_path / "x.log")],
            ["--rrd", "is also --mcap"],
        ),
        (["run", str(s), "--mcap", str(s)], ["--mcap", "is an input"]),
        (["run", str(s), "--rrd", str(tmp_path)], ["--rrd", "is a folder"]),
        (["sweep", str(s), "--out", str(afile / "x.json")], ["--out", "afile, a file, as if it were a folder"]),
        (["sweep", str(s), "--out", str(s)], ["--out", "is an input"]),
        (["replay", str(tmp_path / "in.mcap"), "--rrd", str(tmp_path / "in.mcap")], ["--rrd", "is an input"]),
        (["paper", "--out", str(afile)], ["--out", "is a file; allowed: a folder"]),
        (["gap", "diagnose", str(campaign(tmp_path / "c")), "--out", str(tmp_path / "c")], ["--out", "is an input"]),
        (["gap", "diagnose", str(tmp_path / "c"), "--out", str(afile)], ["--out", "is a file"]),
    ]
    for argv, needles in cases:
        assert main(argv) == 2, argv
        one_line_error(capsys, *needles)
    assert s.read_text() == RIG and afile.read_text() == "x"


def test_paths_the_file_system_cannot_look_up_are_refused_in_one_line(tmp_path, capsys):
    """A loop of symbolic links, a name longer than the file system takes, a file used as a folder:
    each ended in a traceback (OSError, or RuntimeError from Path.resolve) where a scenario, an
    output or a campaign's run file was looked up."""
    s = tmp_path / "s.toml"
    s.write_text(RIG)
    (tmp_path / "loop_a.toml").symlink_to("loop_b.toml")
    (tmp_path / "loop_b.toml").symlink_to("loop_a.toml")
    (tmp_path / "l1.rrd").symlink_to("l2.rrd")
    (tmp_path / "l2.rrd").symlink_to("l1.rrd")
    cases = [
        (["run", str(tmp_path / "loop_a.toml")], ["loop_a.toml", "is a loop of symbolic links", "allowed"]),
        (["run", str(tmp_path / ("x" * 300 + ".toml"))], ["has a name longer than the file system takes", "allowed"]),
        (["run", str(s / "x.toml")], [f"passes through {s}, a file, as if it were a folder", "allowed"]),
        (["run", str(s), "--rrd", str(tmp_path / "l1.rrd")], ["--rrd", "is a loop of symbolic links", "allowed"]),
        (["run", str(s), "--mcap", str(tmp_path / ("k" * 300 + ".mcap"))], ["--mcap", "longer than", "allowed"]),
    ]
    for argv, needles in cases:
        assert main(argv) == 2, argv
        one_line_error(capsys, *needles)
    folder = campaign(tmp_path / "c")
    (folder / "b.csv").unlink()
    (folder / "b.csv").symlink_to("x.csv")
    (folder / "x.csv").symlink_to("b.csv")
    with pytest.raises(GapError, match=r"#2\): file = 'b.csv' is a loop of symbolic links; allowed: a file inside"):
        load_campaign(folder)


def test_an_output_name_leaves_room_for_the_files_made_beside_it(tmp_path, capsys):
    """A name the file system takes but the temporary and lock files beside it (its name and up to
    32 bytes more) cannot have: the lock failed with a traceback before the run, and a sweep's temp
    file and every fallback place after all its points had run, losing them."""
    s = tmp_path / "s.toml"
    s.write_text(RIG)
    for argv in (
        ["run", str(s), "--duration", "0.1", "--rrd", str(tmp_path / ("k" * 246 + ".rrd"))],
        ["sweep", str(s), "--duration", "0.1", "--out", str(tmp_path / ("k" * 240 + ".json"))],
        ["gap", "diagnose", str(campaign(tmp_path / "c")), "--out", str(tmp_path / ("r" * 240))],
    ):
        assert main(argv) == 2, argv
        one_line_error(
            capsys, "its name is", f"bytes long; allowed: at most {os.pathconf(tmp_path, 'PC_NAME_MAX') - 32}"
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c", "s.toml"]  # nothing made, nothing run


def test_an_output_replaced_whole_refuses_a_device_or_pipe(tmp_path, capsys):
    """`twin sweep --out /dev/null` (as root) put a file where the device was: an output written by
    replacing the file refuses a device or a pipe; a recording streamed into one keeps it."""
    s = tmp_path / "s.toml"
    s.write_text(RIG)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    assert main(["sweep", str(s), "--duration", "0.1", "--out", str(fifo)]) == 2
    one_line_error(capsys, "--out", "is a device, a pipe or a socket", "allowed: a file")
    assert main(["run", str(s), "--duration", "0.1", "--mcap", "/dev/null"]) == 0
    assert fifo.is_fifo() and Path("/dev/null").is_char_device()


def test_the_sweep_table_beside_out_is_checked_before_the_work(tmp_path, capsys):
    """`twin sweep --out X.json` also writes X.csv: that place is checked first too, so a
    scenario named X.csv is not overwritten by the table, nor a folder X.csv found after the runs."""
    s = tmp_path / "scn.csv"  # a scenario file under a .csv name
    s.write_text(RIG)
    (tmp_path / "d.csv").mkdir()
    cases = [
        (tmp_path / "scn.json", ["--out's table", "scn.csv: is an input"]),
        (tmp_path / "d.json", ["--out's table", "d.csv: is a folder"]),
    ]
    for out, needles in cases:
        assert main(["sweep", str(s), "--workers", "1", "--out", str(out)]) == 2
        one_line_error(capsys, *needles)
        assert not out.exists()
    assert s.read_text() == RIG


def test_a_result_whose_place_fails_after_the_work_is_saved_elsewhere(tmp_path, monkeypatch, capsys):
    """`twin sweep --out` checked fine, then the folder turned into a file while the runs went:
    the summaries go beside it and the user is told where."""
    import scenarios.sweep

    s = tmp_path / "s.toml"
    s.write_text(RIG)
    out = tmp_path / "results" / "sweep.json"
    results = [{"overrides": {}, "passed": True, "value": 1.25}]

    def sweep(*args, **kwargs):
        shutil.rmtree(tmp_path / "results")
        (tmp_path / "results").write_text("in the way")
        return results

    monkeypatch.setattr(scenarios.sweep, "sweep", sweep)
    assert main(["sweep", str(s), "--out", str(out)]) == 2  # kept elsewhere: the place asked for failed
    captured = capsys.readouterr()
    saved = Path(captured.err.strip().split(" instead")[0].split("saved them to ")[1])
    assert saved.parent == tmp_path and json.loads(saved.read_text()) == results
    assert str(saved) in captured.out


def test_a_folder_of_results_arrives_whole_or_is_kept_beside(tmp_path, caplog):
    out = tmp_path / "out"

    def work(folder: Path) -> str:
        (folder / "a.json").write_text("{}")
        return "done"

    assert publish_folder(out, work, "results") == ("done", out)
    assert (out / "a.json").read_text() == "{}" and [p.name for p in tmp_path.iterdir()] == ["out"]

    def work_then_block(folder: Path) -> str:
        (folder / "b.json").write_text("[]")
        (out / "b.json").mkdir()  # the place cannot take the file any more
        (out / "b.json" / "x").write_text("")
        return "done"

    with caplog.at_level("WARNING", logger="twin_plumbing.outputs"):
        result, kept = publish_folder(out, work_then_block, "results")
    assert result == "done" and kept != out and (kept / "b.json").read_text() == "[]"
    assert str(kept) in caplog.text  # the library logs where it kept them; the command line shows it


def test_results_never_replace_a_folder_or_file_this_command_did_not_write(tmp_path, capsys):
    """`twin gap bench --out DIR` writes DIR/campaigns and DIR/bench.json: a DIR that holds the
    user's own of either is refused before any work, and nothing of it is touched. publish_folder
    replaces a subfolder an earlier publish put there, never one the user made."""
    out = tmp_path / "proj"
    (out / "campaigns" / "my_real_rig").mkdir(parents=True)
    (out / "campaigns" / "my_real_rig" / "run1.csv").write_text("precious")
    assert main(["gap", "bench", "--out", str(out), "--only", "none_0", "--jobs", "1"]) == 2
    one_line_error(capsys, f"--out {out}", "campaigns", "allowed: an empty or new folder")
    assert (out / "campaigns" / "my_real_rig" / "run1.csv").read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir()] == ["proj"]  # no staging folder: refused before the work
    other = tmp_path / "other"
    other.mkdir()
    (other / "bench.json").write_text("mine")
    assert main(["gap", "bench", "--out", str(other), "--only", "none_0", "--jobs", "1"]) == 2
    one_line_error(capsys, "bench.json", "allowed")
    assert (other / "bench.json").read_text() == "mine"

    def work(folder: Path) -> str:
        (folder / "campaigns" / "new").mkdir(parents=True)
        return "done"

    ours = tmp_path / "ours"
    assert publish_folder(ours, work, "results", replaces=["campaigns"]) == ("done", ours)
    (ours / "campaigns" / "old").mkdir()
    assert publish_folder(ours, work, "results", replaces=["campaigns"]) == ("done", ours)  # an earlier run's
    assert [p.name for p in (ours / "campaigns").iterdir()] == ["new"]
    with pytest.raises(UserError, match="campaigns"):
        publish_folder(out, work, "results", replaces=["campaigns"])
    result, kept = publish_folder(out, work, "results")  # not named beforehand: kept beside, not replaced
    assert result == "done" and kept != out and (kept / "campaigns" / "new").is_dir()
    assert (out / "campaigns" / "my_real_rig" / "run1.csv").read_text() == "precious"
    assert str(kept) in capsys.readouterr().err


def test_a_log_that_fails_at_the_end_costs_neither_the_summary_nor_the_other_log(tmp_path, monkeypatch, capsys):
    import scenarios.recording

    closed = []
    mcap, rrd = tmp_path / "out.mcap", tmp_path / "out.rrd"

    class Full:
        path = mcap

        def write(self, telemetry, start):
            pass

        def close(self):
            raise LogError("out.mcap: the MCAP writer failed: OSError: [Errno 28] No space left on device")

    class Fine(Full):
        path = rrd

        def close(self):
            closed.append(True)

    monkeypatch.setattr(scenarios.recording, "open_recorders", lambda *a: [Full(), Fine()])
    s = tmp_path / "s.toml"
    s.write_text(RIG)
    assert main(["run", str(s), "--json", "--mcap", str(mcap), "--rrd", str(rrd)]) == 2
    out, err = capsys.readouterr()
    assert json.loads(out)["scenario"] == "t" and closed == [True]
    assert err.strip().endswith("No space left on device")
    assert f"MCAP log: {mcap} NOT written" in err and f"rerun recording: {rrd}\n" in err  # the failed one is said


def test_a_bad_start_time_is_refused_without_a_log_too(tmp_path, capsys):
    s = tmp_path / "s.toml"
    s.write_text(RIG)
    assert main(["run", str(s), "--start-time", "garbage"]) == 2
    one_line_error(capsys, "--start-time 'garbage'", "ISO 8601")
    # 1970 in its own zone but 1969 in UTC: the writer failed after the whole run ("argument out of range")
    assert main(["run", str(s), "--mcap", str(tmp_path / "x.mcap"), "--start-time", "1970-01-01T00:00:00+01:00"]) == 2
    one_line_error(capsys, "--start-time '1970-01-01T00:00:00+01:00'", "before 1970-01-01T00:00:00Z")
    assert not (tmp_path / "x.mcap").exists()


def current_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_atomic_writes_leave_no_half_file(tmp_path):
    f = tmp_path / "r.json"
    write_atomic(f, "old")
    assert f.stat().st_mode & 0o777 == 0o666 & ~current_umask()  # a result file, not a secret
    f.chmod(0o640)
    write_atomic(f, b"new")
    assert f.read_text() == "new" and [p.name for p in tmp_path.iterdir()] == ["r.json"]
    assert f.stat().st_mode & 0o777 == 0o640  # the file it replaces keeps its mode
    d = tmp_path / "d"
    d.mkdir()
    with pytest.raises(OSError):
        write_atomic(d, "x")  # os.replace cannot put a file over a folder: nothing half-written stays
    assert [p.name for p in tmp_path.iterdir() if p.name != "d"] == ["r.json"] and not list(d.iterdir())


def test_two_writers_of_one_file_are_refused(tmp_path):
    f = tmp_path / "run.mcap"
    with OutputLock([f]):
        with (
            pytest.raises(UserError, match="another run is writing this file"),
            OutputLock([tmp_path / "other.rrd", f]),
        ):
            pass
        assert not (tmp_path / ".other.rrd.lock").exists()  # what it took is given back
    with OutputLock([f]):  # free again once the first is done
        pass
    assert not (tmp_path / ".run.mcap.lock").exists()


def test_check_output_refuses_an_unwritable_place(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("")
    with pytest.raises(UserError, match=r"--out .*passes through .*afile, a file, as if it were a folder"):
        check_output(afile / "deeper" / "x.json", "--out")
    check_output(tmp_path / "new" / "x.json", "--out")  # a folder to be made is fine
    assert (tmp_path / "new").is_dir() and not list((tmp_path / "new").iterdir())


def test_keep_result_says_where_when_no_place_works(tmp_path, monkeypatch):
    def fail(place):
        raise OSError(28, "No space left on device")

    with pytest.raises(UserError, match="No space left on device"):
        keep_result(tmp_path / "x.json", fail, "the results")


# --- SIGTERM and concurrent writers, with a real run -------------------------------------------
def rrd_last_time_s(path: Path) -> float:
    """The last time on the recording's timeline, read with rerun's own reader."""
    import rerun as rr

    last = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. rerun's "no footer" warning on a file cut short
        reader = rr.chunk.RrdReader(path)
    for chunk in reader.stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "time" in batch.schema.names:
            t = batch.column("time").cast("int64").to_numpy()
            if len(t):
                last = max(last, float(t.max()) * 1e-9)
    return last


def test_sigterm_finishes_the_logs_like_ctrl_c_and_a_second_writer_is_refused(tmp_path, capsys):
    """`timeout`, systemd and docker stop a run with SIGTERM sent to its process: the run ends
    with exit status 143 and a note, its MCAP is finished (footer) and its .rrd holds as much as
    the MCAP. While it runs, a second run on the same --mcap is refused."""
    text = (
        (ROOT / "scenarios" / "wrist_closed_loop_60deg.toml")
        .read_text()
        .replace("duration_s = 6.0", "duration_s = 600.0")
    )
    scenario = tmp_path / "long.toml"
    scenario.write_text(text)
    mcap, rrd = tmp_path / "run.mcap", tmp_path / "run.rrd"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "twin_cli.cli",
            "run",
            str(scenario),
            "--mcap",
            str(mcap),
            "--rrd",
            str(rrd),
            "--camera-fps",
            "0",
        ],
        cwd=tmp_path,
        env=env,
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
    )
    try:
        wait_until_logged(proc, mcap, 2.0)
        assert main(["run", str(scenario), "--mcap", str(mcap), "--camera-fps", "0"]) == 2
        one_line_error(capsys, str(mcap), "another run is writing this file")
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, err.decode()
    assert "terminated (SIGTERM); the logs written so far are kept" in err.decode()
    arrays, meta = read_mcap(mcap)
    assert meta["recovery"]["complete"] and meta["recovery"]["duration_s"] >= 2.0
    mcap_end = float(arrays["time_s"][-1])
    assert rrd_last_time_s(rrd) >= mcap_end - 1e-6  # the .rrd is not behind its MCAP
    assert not list(tmp_path.glob(".*.lock"))  # the locks went with the run
    assert math.isfinite(mcap_end)


def test_a_signal_met_by_compiled_code_is_still_a_stop():
    """A signal handled as an @njit function boxes its result (numba calls back into Python there)
    comes out as a SystemError chained to the stop: stop_behind finds the stop, which the command
    line turns into exit 143 or 130."""
    import threading

    from pneumatics import params_row
    from twin_plumbing.errors import Terminated
    from twin_plumbing.signals import stop_behind, stop_on_sigterm
    from wrist_rig.commanded_run import wrist_params
    from wrist_rig.one_joint import DT_S, replay_run

    p, n = params_row(wrist_params()), 3
    commands = (np.arange(n) * 1.0, np.zeros(n), np.zeros(n), np.zeros(n), np.full(n, 6e5), False, 0.0, 0.02, 0.0)
    replay_run(p, *commands, 0.01, DT_S)  # compiled before the timer starts
    with stop_on_sigterm():
        threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGTERM)).start()
        with pytest.raises(BaseException) as e:
            replay_run(p, *commands, 600.0, DT_S)  # ~0.3 s in compiled code
    assert isinstance(e.value, SystemError) and isinstance(stop_behind(e.value), Terminated), repr(e.value)
    assert stop_behind(SystemError("no stop behind it")) is None and stop_behind(ValueError()) is None


def test_sigterm_stops_gap_bench_and_keeps_the_cases_it_finished(tmp_path):
    """`twin gap bench` sent SIGTERM after its first case exits 143 without a traceback, and DIR
    holds that case: its campaign and bench.json (the case stopped midway is not kept)."""
    out = tmp_path / "bench"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    command = [sys.executable, "-m", "twin_cli.cli", "gap", "bench", "--out", str(out), "--quick", "--jobs", "1"]
    proc = subprocess.Popen(command, cwd=tmp_path, env=env, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(".bench.partial-*/bench.json")) and proc.poll() is None:
            assert time.monotonic() < deadline, "the first case did not finish"
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    err = err.decode()
    assert proc.returncode == 143 and "Traceback" not in err, err
    assert f"finished so far are in {out}" in err and "terminated (SIGTERM)" in err
    assert [c["case"] for c in json.loads((out / "bench.json").read_text())["cases"]] == ["vane_leakage"]
    assert [p.name for p in (out / "campaigns").iterdir()] == ["vane_leakage"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bench"]  # no staging folder left


def test_the_python_api_checks_its_numbers_too(tmp_path):
    from gap.run import run_diagnose
    from scenarios.runner import run_scenario
    from scenarios.sweep import sweep

    s = parse(RIG, "api.toml")
    for call, needle in [
        (lambda: run_scenario(s, duration_s=math.nan), "duration_s = nan"),
        (lambda: run_scenario(s, seed=-1), "seed = -1"),
        (lambda: sweep(s, monte_carlo=-1), "monte_carlo = -1"),
        (lambda: sweep(s, workers=2.5), "workers = 2.5"),
        (lambda: sweep(s, duration_s=-1.0), "duration_s = -1.0"),
        (lambda: run_diagnose(tmp_path, tmp_path / "out", model_tolerance_deg=math.nan), "model_tolerance_deg = nan"),
        (lambda: run_diagnose(tmp_path, tmp_path / "out", jobs=0), "jobs = 0"),
    ]:
        with pytest.raises(UserError, match=f"^{needle} is not (allowed|a whole number); allowed: "):
            call()


def test_closing_logs_is_not_cut_short_by_a_signal():
    """A signal that arrives while logs are being closed waits until they are closed."""
    from twin_plumbing.errors import Terminated
    from twin_plumbing.signals import shielded, stop_on_sigterm

    finished = []
    with stop_on_sigterm():
        with pytest.raises(Terminated), shielded():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)  # the handler has run by now
            finished.append(True)
        with pytest.raises(KeyboardInterrupt), shielded():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
            finished.append(True)
    assert finished == [True, True]
