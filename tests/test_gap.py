"""Gap diagnosis: the paper's hose-loss case, recovery of a hidden parameter, no false alarm,
malformed campaigns, and the command line. Campaigns are generated from the plant (MuJoCo +
pneumatics) with the effect hidden in its parameters, written to disk and read back."""

from __future__ import annotations

import json
import re
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from gap import synth
from gap.campaign import GapError, load_campaign
from gap.diagnose import diagnose
from gap.effects import BY_NAME, CATALOGUE
from gap.kinds import Verdict
from wrist_rig import commanded_run

FAST = tuple(
    e
    for e in CATALOGUE
    if e.name
    in ("hose_loss", "vane_leakage", "coulomb_friction", "viscous_friction", "conductance_error", "supply_droop")
)


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    root = tmp_path_factory.mktemp("gap")
    p0 = commanded_run.wrist_params()
    return {
        # the paper's protocol: at each supply the wrist turns 60 deg at full opening, then holds
        "paper": synth.make_campaign(root / "paper", p0, seed=1, twin_hose_loss=False, motion=synth.paper_motions(p0)),
        "leak": synth.make_campaign(root / "leak", p0._replace(leak_area_m2=4e-7), seed=2, pressures_mpa=(0.5, 0.8)),
        "none": synth.make_campaign(root / "none", p0, seed=3, pressures_mpa=(0.5, 0.8)),
    }


def test_paper_case_names_hose_loss_and_shrinks_error_on_withheld_runs(campaigns):
    # paper Sec. III: without the pipeline loss the model error is 3.2-22.2 deg, with it 1.2-5.4 deg
    d = diagnose(load_campaign(campaigns["paper"]), catalogue=FAST, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "hose_loss"
    before, after = d.how_far["before"], d.how_far["hose_loss"]
    assert set(before) == {"0.50", "0.60", "0.70", "0.80"}
    for q in before:
        assert before[q].mean_deg > 3.0  # the paper's smallest error without the loss is 3.2 deg
        assert after[q].mean_deg < 0.3 * before[q].mean_deg
        assert after[q].mean_deg < 1.2  # the paper's best with the loss (0.8 MPa)
    # The paper's shape (error without the loss largest at 0.5 MPa) is no longer this campaign's: its
    # truth is the nominal wrist plus the hose loss, whose brake now clears at 4.0 bar (issue 14's
    # brake margin) and hardly drags at 0.5 MPa, so the hose's share of the speed alone sets the
    # error, growing with the supply: measured mean 11.6/12.1/13.9/15.9 deg, max 23.3/21.5/23.7/25.6
    # deg at 0.5-0.8 MPa (with the 4.75 bar brake: 22.5/15.0/14.9/15.6 deg). The as-built arm keeps
    # the paper's shape (tests/test_as_built.py).
    qs = ["0.50", "0.60", "0.70", "0.80"]
    mean = [before[q].mean_deg for q in qs]
    assert all(a < b for a, b in zip(mean, mean[1:], strict=False)) and mean[0] > 10.0, mean


def test_hidden_leak_is_found_and_its_area_recovered(campaigns):
    d = diagnose(load_campaign(campaigns["leak"]), catalogue=FAST, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "vane_leakage"
    assert w.top.fitted_values[0] == pytest.approx(4e-7, rel=0.15)
    assert w.top.shrink < 0.3


def test_no_hidden_effect_is_no_significant_gap(campaigns):
    d = diagnose(load_campaign(campaigns["none"]), catalogue=FAST, progress=False)
    assert d.which.verdict == "no significant gap"
    nf = d.noise_floor
    assert nf.repeat_pairs == 2
    assert nf.measurement_deg == pytest.approx(np.rad2deg(synth.NOISE_RAD), rel=0.3)  # the seeded noise


def _by_name(*names):
    return tuple(e for e in CATALOGUE if e.name in names)


@pytest.mark.parametrize(
    "hidden, catalogue, family, declared_hose_m",
    [
        # a slow proportional valve (tau 0.2 s against 0.1 s), the catalogue without valve lag
        (
            {"valve_time_constant_s": 0.2},
            ("valve_dead_time", "valve_set_dead_time", "supply_droop", "coulomb_friction", "conductance_error"),
            "valve",
            None,
        ),
        # Stribeck friction (20 N·m breakaway excess), the catalogue with Coulomb and viscous only.
        # Not 40 N·m: as static friction (55 N·m)
        # it is over the wrist's stall torque at 0.5 MPa, the joint never moves there, and the
        # call is supply droop
        (
            {"stribeck_excess_nm": 20.0, "stribeck_speed_rad_s": 0.2},
            ("coulomb_friction", "viscous_friction", "heat_exchange", "valve_dead_time", "supply_droop"),
            "friction",
            None,
        ),
        # a narrower hose (3 mm bore against the 4 mm the twin is told): the twin already has the
        # hose loss, so no candidate is of the hose family; its family call has the hose switched
        # off and the part at other bores and lengths (gap.effects.IN_TWIN_VARIATIONS). Without
        # them the hose leak, a candidate, took it (leakage)
        (
            {"hose_diameter_m": 0.003},
            ("hose_loss", "hose_leak", "vane_leakage", "coulomb_friction", "conductance_error", "valve_dead_time"),
            "hose",
            None,
        ),
        # hoses 13 m long where campaign.toml says 8: without the hose's variations the valve
        # (conductance) took it, a longer hose fills the motor late as a smaller valve does
        (
            {"hose_length_m": 13.0},
            ("hose_loss", "hose_leak", "vane_leakage", "coulomb_friction", "conductance_error", "valve_lag"),
            "hose",
            8.0,
        ),
    ],
    ids=["valve_lag_as_dead_time", "stribeck_as_coulomb", "narrow_hose", "longer_hose_than_declared"],
)
def test_a_form_outside_the_catalogue_is_called_so_and_given_its_family(
    hidden, catalogue, family, declared_hose_m, tmp_path
):
    """Chamber pressures measured on both ports: the fit weighs them, and a form the catalogue lacks
    is called outside the catalogue with the family of the best candidate's leading effect."""
    folder = synth.make_campaign(
        tmp_path / "c",
        commanded_run.wrist_params()._replace(**hidden),
        seed=7,
        pressures_mpa=(0.5, 0.6, 0.8),
        chamber_pressures=True,
        declared_hose_length_m=declared_hose_m,
    )
    d = diagnose(load_campaign(folder), catalogue=_by_name(*catalogue), progress=False)
    assert d.pressure.measured
    assert d.pressure.noise_kpa == pytest.approx(synth.NOISE_PA / 1e3, rel=0.3)  # the seeded transducer noise
    w = d.which
    assert w.verdict == "outside the catalogue"
    assert w.nearest.family == family
    assert all(c.heldout_pressure_rms_kpa is not None for c in w.ranking)
    # each family's held-out shrink per channel: the whole's is their mean (in squares, weighted by
    # the gap's energy in each), so it lies between them
    for x in w.families:
        a, p = x.heldout_shrink_angle, x.heldout_shrink_pressure
        assert min(a, p) - 1e-12 <= x.heldout_shrink <= max(a, p) + 1e-12, x


def test_a_run_may_carry_its_own_load(campaigns, tmp_path):
    """Per-run payload and rig inertia: the replay uses the run's inertia, and "where" breaks the
    residual down by load. The runs were made on the 0.02 kg·m^2 rig, so the run declared at 2
    kg·m^2 is the one that departs."""
    c = _copy(campaigns["none"], tmp_path / "load")
    toml = c / "campaign.toml"
    toml.write_text(
        toml.read_text().replace(
            'file = "run_050_1.csv"', 'file = "run_050_1.csv"\npayload_kg = 10.0\nrig_inertia_kg_m2 = 2.0', 1
        )
    )
    campaign = load_campaign(c)
    assert [r.payload_kg for r in campaign.runs] == [10.0, 0.0, 0.0, 0.0]
    d = diagnose(campaign, catalogue=_by_name("inertia_error"), progress=False)
    load = d.where.load_kg
    assert set(load) == {"0", "10"}
    assert load["10"].rms_deg > 5.0 * load["0"].rms_deg
    # the declared value is checked like every other number
    toml.write_text(toml.read_text().replace("rig_inertia_kg_m2 = 2.0", "rig_inertia_kg_m2 = -1"))
    with pytest.raises(GapError, match=r"campaign\.toml:\d+ \(\[\[runs\]\] #1\): rig_inertia_kg_m2 = -1; allowed"):
        load_campaign(c)


def test_hidden_reducer_compliance_is_found_and_recovered(tmp_path):
    # a compliant gear (1e-3 rad/N·m, 5x softer than the size-17 gear's 1/K1) hidden in the plant;
    # the catalogue's reducer entries are configuration of the same one-joint model
    folder = synth.make_campaign(
        tmp_path / "compliant",
        commanded_run.wrist_params()._replace(reducer_compliance_rad_per_nm=1e-3),
        seed=4,
        pressures_mpa=(0.5, 0.8),
    )
    catalogue = FAST + tuple(e for e in CATALOGUE if e.family == "reducer")
    assert {e.name for e in catalogue if e.family == "reducer"} == {"reducer_backlash", "reducer_compliance"}
    d = diagnose(load_campaign(folder), catalogue=catalogue, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "reducer_compliance"
    assert w.top.fitted_values[0] == pytest.approx(1e-3, rel=0.1)  # measured: 1.04e-3
    assert w.top.shrink < 0.3


def _copy(src, dst):
    shutil.copytree(src, dst)
    return dst


def test_malformed_campaigns_name_file_line_and_problem(campaigns, tmp_path):
    src = campaigns["none"]
    # missing column
    c = _copy(src, tmp_path / "a")
    f = c / "run_050_1.csv"
    lines = f.read_text().splitlines()
    f.write_text("\n".join([ln.rsplit(",", 1)[0] for ln in lines]) + "\n")
    with pytest.raises(GapError, match=r"run_050_1\.csv:1: missing column\(s\) angle_rad"):
        load_campaign(c)
    # non-monotonic time
    c = _copy(src, tmp_path / "b")
    f = c / "run_050_1.csv"
    lines = f.read_text().splitlines()
    lines[5] = lines[3]
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(GapError, match=r"run_050_1\.csv:6: time_s = .* does not increase"):
        load_campaign(c)
    # unknown joint
    c = _copy(src, tmp_path / "c")
    t = (c / "campaign.toml").read_text().replace('joint = "wrist_pitch"', 'joint = "wrist_yaw"')
    (c / "campaign.toml").write_text(t)
    with pytest.raises(GapError, match=r"campaign\.toml:\d+: joint = 'wrist_yaw' is not a joint"):
        load_campaign(c)
    # missing file
    c = _copy(src, tmp_path / "d")
    (c / "run_080_2.csv").unlink()
    with pytest.raises(
        GapError, match=r"campaign\.toml:\d+ \(\[\[runs\]\] #4\): run file .*run_080_2\.csv does not exist"
    ):
        load_campaign(c)


@pytest.mark.parametrize("hose_m", [0.01, 0.1])
def test_a_hose_too_short_for_the_model_is_refused_with_the_parameter_files_range(campaigns, tmp_path, hose_m):
    """campaign.toml's hose_length_m has the joint parameter file's range (pneumatics.params.SPEC:
    from 0.3 m, where the pi-section stops being a hose): a shorter one is refused when the campaign is
    read, naming the file, the field, the value and what is allowed."""
    c = _copy(campaigns["none"], tmp_path / "c")
    t = (c / "campaign.toml").read_text()
    (c / "campaign.toml").write_text(re.sub(r"hose_length_m = [0-9.]+", f"hose_length_m = {hose_m}", t))
    with pytest.raises(
        GapError, match=rf"campaign\.toml:\d+: hose_length_m = {hose_m}; allowed: a number in 0\.3\.\.100 m"
    ):
        load_campaign(c)


def test_a_nominal_replay_that_is_not_finite_is_refused_not_called_no_gap(campaigns):
    """Whatever puts the nominal twin's replay out of the numbers (a model value the ranges let
    through), the diagnosis refuses the campaign by name rather than give a verdict from NaN."""
    from gap.diagnose import check_finite

    c = load_campaign(campaigns["none"])
    finite = [np.zeros(3) for _ in c.runs]
    check_finite(c, finite, finite)  # finite: no complaint
    diverged = [np.array([0.0, np.nan, np.nan]), *finite[1:]]
    with pytest.raises(
        GapError, match=rf"campaign\.toml: the nominal twin's replay of {c.runs[0].path.name} is not finite"
    ):
        check_finite(c, diverged, finite)


def test_cli_gap_diagnose_writes_json_report_and_plots(campaigns, tmp_path, capsys):
    from twin_cli.cli import main

    out = tmp_path / "out"
    assert main(["gap", "diagnose", str(campaigns["leak"]), "--out", str(out)]) == 0
    d = json.loads((out / "diagnosis.json").read_text())
    assert d["which"]["top"]["name"] == "vane_leakage"
    assert {c["name"] for c in d["which"]["ranking"]} == set(BY_NAME) - {
        "hose_loss"
    }  # hose loss is already in this twin
    report = (out / "report.md").read_text()
    assert report.startswith("# Sim-to-real gap diagnosis")
    # what the hose family's "(in the twin)" corrections are (gap.effects.IN_TWIN_VARIATIONS)
    assert "Already in the nominal twin (not candidates): hose_loss. Its family's corrections" in report
    assert "hose bore x 0.7/0.8/0.9/1.15, hose length x 0.5/1.5/2/3." in report
    # a family's held-out shrink per channel only where chamber pressures are measured
    measured = d["pressure"]["measured"]
    assert d["which"]["families"] and all(("heldout_shrink_angle" in f) == measured for f in d["which"]["families"])
    for png in ("residual.png", "where.png", "ranking.png", "how_far.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"
    # a user error is one line and exit status 2
    assert main(["gap", "diagnose", str(tmp_path / "nowhere"), "--out", str(out)]) == 2
    assert "no such campaign file" in capsys.readouterr().err


def test_cli_gap_diagnose_says_when_the_declared_rate_is_not_the_files(campaigns, tmp_path, capsys):
    """A declared rate_hz far from the rate the run files sample at was only in report.md and
    diagnosis.json: the command says it too."""
    from twin_cli.cli import main

    c = _copy(campaigns["none"], tmp_path / "c")
    (c / "campaign.toml").write_text((c / "campaign.toml").read_text() + "\n[instrument]\nrate_hz = 100000\n")
    assert main(["gap", "diagnose", str(c), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "campaign.toml declares rate_hz = 100000, the run files sample at 50.0 Hz: they do not match" in out
    assert json.loads((tmp_path / "out" / "diagnosis.json").read_text())["instrument"]["rate_mismatch"]


def test_mcap_runs_from_the_plant_are_diagnosed(tmp_path):
    # runs logged by the twin's own MCAP recorder (20 ms samples of commands, valve OUTPUT pressure
    # and true angle) from the plant with a hidden vane leak, put in a campaign folder
    from gap.campaign_replay import CampaignReplay
    from pneumatics import params_row
    from wrist_rig.one_joint import DT_S, replay_run

    p0 = commanded_run.wrist_params()
    folder = tmp_path / "mcap"
    folder.mkdir()
    lines = ['joint = "wrist_pitch"', "hose_length_m = 8.0", "rig_inertia_kg_m2 = 0.02"]
    for mpa in (0.5, 0.8):
        for name, reality in (("leak", p0._replace(leak_area_m2=4e-7)), ("nominal", p0)):
            commanded_run.write_mcap_run(folder / f"{name}_{int(mpa * 100)}.mcap", reality, mpa)
    for mpa in (0.5, 0.8):
        lines += [
            "[[runs]]",
            f'file = "leak_{int(mpa * 100)}.mcap"',
            f"supply_mpa = {mpa}",
            "start_deg = { wrist_pitch = 0.0 }",
        ]
    (folder / "campaign.toml").write_text("\n".join(lines) + "\n")
    d = diagnose(load_campaign(folder), catalogue=FAST, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "vane_leakage"
    assert w.top.fitted_values[0] == pytest.approx(4e-7, rel=0.2)

    # the nominal plant's logs replay within the twin's model tolerance because the logged valve
    # output is imposed on the valve state; taken as a set point it would be lagged a second time
    (folder / "campaign.toml").write_text("\n".join(lines).replace("leak_", "nominal_") + "\n")
    twin = CampaignReplay(load_campaign(folder), pressure_weight=0.0)
    assert all(pr.run.valve_is_output for pr in twin.runs)
    rms = {}
    for as_output in (True, False):
        res = []
        for pr in twin.runs:
            args = pr.args[:5] + (as_output,)
            t, theta, _, _, _ = replay_run(
                params_row(twin.params), *args, pr.run.start_rad, pr.inertia, 0.0, pr.ts[-1] + DT_S, DT_S
            )
            res.append(pr.meas - np.interp(pr.ts, t, theta))
        rms[as_output] = float(np.rad2deg(np.sqrt(np.mean(np.concatenate(res) ** 2))))
    assert rms[True] < 0.5  # MODEL_TOLERANCE_DEG
    assert rms[False] > 1.5 * rms[True]


def test_the_model_tolerance_is_what_the_replay_misses_on_each_protocol_today():
    """The diagnosis's tolerance stands on gap.protocols' per-protocol figures: each must cover the
    replay's disagreement with the plant measured afresh (or the twin calls its own error an
    effect), and none may be stale by more than its rounding (or real gaps hide under it)."""
    from gap import protocols
    from gap.tolerance import measure_tolerance

    measured = measure_tolerance()
    assert set(measured) == set(protocols.TOLERANCE_DEG) == set(protocols.TOLERANCE_KPA)
    for name, m in measured.items():
        assert m["rms_deg"] <= protocols.TOLERANCE_DEG[name] <= m["rms_deg"] + 0.001 + 1e-9, name
        assert m["pressure_rms_kpa"] <= protocols.TOLERANCE_KPA[name] <= m["pressure_rms_kpa"] + 0.01 + 1e-9, name


# --- the reference instrument, the noise floor, the verdict rules, the new families ----------
def test_repeat_noise_uses_only_samples_both_repeats_have_and_tells_drift_from_noise():
    """Two repeats of a stop-and-go motion (2.6 rad/s moves, braked stops every 0.3 s) read by a
    30 Hz, 0.2 deg instrument; the second repeat lost the first frame after each corner (10 of
    90). Interpolating it across a lost corner frame takes the corner for noise; the samples both
    repeats have give the seeded 0.2 deg. A slow 0.5 deg ramp between the repeats is reported as
    drift and leaves the noise estimate alone."""
    from gap.noise import repeat_noise

    rng = np.random.default_rng(5)
    t = np.round(np.arange(0.0, 3.0, 1 / 30), 3)
    moving = (t % 0.6) < 0.3
    truth = np.concatenate([[0.0], np.cumsum(2.6 * moving[:-1] * np.diff(t))])  # rad
    sigma = np.deg2rad(0.2)
    corners = np.nonzero(np.diff(moving.astype(int)))[0] + 1
    lost = np.zeros(len(t), dtype=bool)
    lost[corners] = True  # the first frame after each corner (10 of 90)
    runs = {}
    for k, ramp in enumerate((0.0, np.deg2rad(0.5))):
        keep = ~lost if k == 1 else np.ones(len(t), dtype=bool)
        runs[k] = (t[keep], (truth + ramp * t / 3.0 + rng.normal(0, sigma, len(t)))[keep])
    got = repeat_noise([[0, 1]], lambda k: runs[k])
    assert np.rad2deg(got.sigma) == pytest.approx(0.2, rel=0.2)
    # the ramp's difference is 0.5 t/3 deg: rms 0.5/sqrt(3) = 0.29 deg
    assert np.rad2deg(got.drift) == pytest.approx(0.5 / np.sqrt(3), rel=0.3)
    flat = {k: (tk, vk - np.deg2rad(0.5) * tk / 3.0 * (k == 1)) for k, (tk, vk) in runs.items()}
    assert np.rad2deg(repeat_noise([[0, 1]], lambda k: flat[k]).drift) < 0.1
    # one repeat interpolated across the other's lost frames (the old estimate) is several times off
    (ta, va), (tb, vb) = flat[0], flat[1]
    naive = np.rad2deg(np.sqrt(np.mean((va - np.interp(ta, tb, vb)) ** 2) / 2))
    assert naive > 2.5 * np.rad2deg(got.sigma)


@pytest.fixture(scope="module")
def camera_campaign(tmp_path_factory):
    """No hidden effect, read by a camera: 30 Hz, 0.2 deg, 30 ms late (not declared), 3 % of frames
    dropped; stop-and-go runs (braked stops) at 0.5 and 0.8 MPa."""
    from dataclasses import replace

    from gap import protocols

    inst = replace(synth.CAMERA, latency_s=0.030)
    motion = {q: protocols.STOP_AND_GO for q in (0.5, 0.8)}
    return synth.make_campaign(
        tmp_path_factory.mktemp("gap") / "camera",
        commanded_run.wrist_params(),
        seed=11,
        pressures_mpa=(0.5, 0.8),
        motion=motion,
        instrument=inst,
    )


def test_an_undeclared_camera_latency_is_found_as_nuisance_not_an_effect(camera_campaign, tmp_path):
    from gap.run import verdict_line

    d = diagnose(load_campaign(camera_campaign), catalogue=FAST + _by_name("valve_dead_time"), progress=False)
    inst = d.instrument
    assert inst.latency_estimated and inst.latency_s == pytest.approx(0.030, abs=0.010)
    assert inst.observed_rate_hz == pytest.approx(30.0, rel=0.05) and inst.dropped_samples > 0
    assert d.noise_floor.measurement_deg == pytest.approx(0.2, rel=0.3)  # the seeded camera noise
    assert d.which.verdict == "no significant gap", verdict_line(d)
    # declared, it is used as declared and said so
    c = _copy(camera_campaign, tmp_path / "declared")
    (c / "campaign.toml").write_text(
        (c / "campaign.toml").read_text() + "\n[instrument]\nlatency_s = 0.03\nnoise_deg = 0.2\nrate_hz = 30.0\n"
    )
    campaign = load_campaign(c)
    assert campaign.instrument.latency_s == 0.03
    from gap.campaign_replay import CampaignReplay

    assert list(CampaignReplay(campaign, pressure_weight=0.0).latencies) == [0.03]
    (c / "campaign.toml").write_text((c / "campaign.toml").read_text().replace("latency_s = 0.03", "latency_s = -0.1"))
    with pytest.raises(
        GapError, match=r"campaign\.toml:\d+ \(\[instrument\]\): latency_s = -0.1; allowed: a number in 0..1 s"
    ):
        load_campaign(c)


def test_each_channel_is_tested_against_its_own_floor():
    """A gap under the angle's threshold but three floors in the chamber pressures is significant,
    and a candidate that fits the angle but leaves the pressure gap does not explain it (the angle
    alone decided both before: a 0.02 rad backlash the pressures showed clearly was no gap)."""
    from gap import verdict
    from gap.candidate import Candidate
    from gap.floors import Floors

    # angle floor 0.4 deg, pressure 2.5 kPa
    fl = Floors(
        noise_deg=0.2,
        noise=None,
        tolerance_deg=0.36,
        floor_deg=0.4,
        threshold_deg=0.8,
        noise_p=None,
        floor_kpa=2.5,
        threshold_kpa=5.0,
        pressure_weight=(np.radians(0.4) / 2.5e3) ** 2,
    )
    assert fl.above(0.6, 8.0) and fl.above(0.9, 1.0)
    assert not fl.above(0.6, 4.0) and not fl.above(0.6, None)
    judge = verdict.Judge(None, fl, 0.6, fl.score, np.random.default_rng(0), before_kpa=8.0)
    angle = [np.full(50, np.radians(0.2))]
    fits_both = Candidate("a", ["a"], [], [0.0], angle, [np.full(100, 1.0e3)])
    angle_only = Candidate("b", ["b"], [], [0.0], angle, [np.full(100, 7.0e3)])
    assert judge.explains(fits_both) and not judge.explains(angle_only)


def test_a_replay_is_given_its_pressure_weight_and_cannot_be_made_without_it(tmp_path):
    """The fit's objective counts the chamber pressures by the weight the campaign's replay is given
    at construction (the floors' (angle floor / pressure floor)^2); a replay made without one is
    refused. It used to start at weight 0 until the diagnosis set it: a fit made before fitted the
    angle alone without a word."""
    from gap.campaign_replay import CampaignReplay, prepared_runs
    from gap.floors import MODEL_TOLERANCE_DEG, floors_of
    from gap.instrument import estimate

    reality = commanded_run.wrist_params()._replace(leak_area_m2=4e-7)
    folder = synth.make_campaign(tmp_path / "c", reality, seed=5, pressures_mpa=(0.6,), chamber_pressures=True)
    c = load_campaign(folder)
    with pytest.raises(TypeError, match="pressure_weight"):
        CampaignReplay(c)
    fl = floors_of(c, prepared_runs(c, estimate(c)), MODEL_TOLERANCE_DEG)
    w = fl.pressure_weight
    assert w == pytest.approx((np.radians(fl.floor_deg) / (fl.floor_kpa * 1e3)) ** 2)
    replay = CampaignReplay(c, pressure_weight=w)
    i = replay.latency_index(replay.ref_latency_s)
    ((a, p),) = replay.residuals_with([], [0], float(replay.latencies[i])).values()
    angle_sse, pressure_sse = float(np.sum(a**2)), w * float(np.sum(p**2))
    assert pressure_sse > 0.1 * angle_sse  # the leak shows in the pressures: they weigh in the fit
    assert replay.run_sses([], [0])[0, i] == pytest.approx(angle_sse + pressure_sse, rel=1e-9)
    # the nominal twin's residual vector, read at that latency: its squared norm is the objective
    both = replay.run_sses([], [0, 1])[:, i].sum()
    assert replay.gap_vector @ replay.gap_vector == pytest.approx(both, rel=1e-9)
    # without chamber pressures there is nothing to weigh
    no_pressure = load_campaign(synth.make_campaign(tmp_path / "n", reality, seed=5, pressures_mpa=(0.6,)))
    assert (
        floors_of(no_pressure, prepared_runs(no_pressure, estimate(no_pressure)), MODEL_TOLERANCE_DEG).pressure_weight
        == 0
    )


def test_a_replay_is_made_once_and_remembered_bit_for_bit(campaigns):
    """The diagnosis's replays are remembered by their inputs (gap.campaign_replay.ReplayMemo): the
    same effects asked again, for the objective or for residual vectors at any latency of the grid,
    are not replayed, and what comes back is the replay's own bits; readouts past the memo's budget
    are replayed again; a copy sent to another process starts with an empty memo."""
    import pickle

    from gap.campaign_replay import CampaignReplay, ReplayMemo, apply_effects

    replay = CampaignReplay(load_campaign(campaigns["leak"]), pressure_weight=0.0)
    every = list(range(len(replay.runs)))
    leak = [(BY_NAME["vane_leakage"], 3e-7)]
    assert replay.ref_latency_s >= 0.0  # the nominal twin replayed first (the reference latency)
    before = replay.n_replays + len(replay.groups)
    sses, _ = replay.run_sses_and_residual(leak, every)
    made = replay.n_replays
    assert made == before
    i = len(replay.latencies) - 1  # not the reference latency: read again from what was kept
    got = replay.residual_vectors(leak, every, [i])[i]
    assert np.array_equal(replay.run_sses(leak, every), sses) and replay.n_replays == made
    p, rig = apply_effects(replay.params, leak)
    want = []
    for k, pr in enumerate(replay.runs):
        t, th = replay.trajectory(p, rig, replay.group_of[k])[:2]
        want.append(pr.meas - np.interp(pr.ts - replay.latencies[i], t, th))
    assert np.array_equal(got, np.concatenate(want))  # bit for bit a fresh replay's
    replay.memo = ReplayMemo(budget_bytes=1)  # keeps each run's objective, no readouts
    replay.run_sses_and_residual(leak, every)
    made = replay.n_replays
    replay.run_sses(leak, every)
    assert replay.n_replays == made
    replay.residual_vectors(leak, every, [i])
    assert replay.n_replays == made + len(replay.groups)
    sent = pickle.loads(pickle.dumps(replay))
    sent.run_sses(leak, every)
    assert sent.n_replays == made + 2 * len(replay.groups)


def test_each_verdict_is_one_row_and_reads_back_from_its_text():
    """A verdict is a kind with one row (its text and what it counts as); its text is what
    diagnosis.json, bench.json and the reports carry, and reading that text gives the kind back."""
    rows = {v.value: (v.alarm, v.explained, v.tied, v.names_family) for v in Verdict}
    assert rows == {
        "no significant gap": (False, False, False, False),
        "explained": (True, True, False, False),
        "ambiguous": (True, True, True, True),
        "outside the catalogue": (True, False, False, True),
    }
    for v in Verdict:
        text = json.loads(json.dumps({"verdict": v}))["verdict"]
        assert text == f"{v}" == str(v) == v.value and Verdict(text) is v


def test_a_pair_search_follows_the_narrow_valley_of_two_effects_acting_alike():
    """More leakage and less Coulomb friction move the joint alike: their misfit is a narrow curved
    valley (the shape and scale measured on a leak + Coulomb campaign's staircase runs). The pair's
    screen must reach its floor, not stop on its wall worse than the leak alone at its best value."""
    from gap.candidate import Candidate
    from gap.pair_search import screen_pair

    def sse(leak, coulomb):
        return 0.043 * (coulomb - 30.0 + 6e7 * (leak - 3e-7)) ** 2 + 5e12 * (leak - 3e-7) ** 2 + 4e-4

    class Valley:  # the twin's objective, without replays: per run and latency
        def run_sses(self, effects, runs):
            v = dict((e.name, x) for e, x in effects)
            return np.full((len(runs), 1), sse(v["vane_leakage"], v["coulomb_friction"]) / len(runs))

    leak_alone = min(sse(x, 15.0) for x in np.geomspace(1e-8, 2e-6, 2000))  # Coulomb at its nominal value
    found = screen_pair(Valley(), Candidate("vane_leakage", [], [], []), Candidate("coulomb_friction", [], [], []), [0])
    assert found < 0.1 * leak_alone and found < 2e-3


def test_every_pair_of_the_best_single_is_screened_whatever_their_corrections_added_say():
    """Adding two effects' corrections ignores how they interact; the replayed screen sees every pair
    of the best single, and the PAIR_SCREEN other pairs whose added corrections fit best."""
    from gap.candidate import Candidate
    from gap.pair_search import PAIR_SCREEN, screened_pairs, superposed_sse

    gap = np.linspace(1.0, 2.0, 12)
    rng = np.random.default_rng(3)

    def single(name, off):  # its correction (gap - residual) fits the gap badly by `off`
        return Candidate(name, [name], [], [0.0], grid_residuals=gap + off * rng.normal(size=(3, gap.size)))

    pool = [single("best", 5.0)] + [single(f"s{k}", 0.1 * k) for k in range(1, 8)]
    chosen = screened_pairs(pool, gap)
    names = {(a.name, b.name) for a, b in chosen}
    assert {("best", b.name) for b in pool[1:]} <= names  # its corrections, added, rank it last
    others = sorted(
        ((superposed_sse(a, b, gap), a.name, b.name) for i, a in enumerate(pool) for b in pool[i + 1 :]),
    )
    assert {(a, b) for _, a, b in others[:PAIR_SCREEN]} <= names
    assert len(chosen) == len(names) == len(pool) - 1 + PAIR_SCREEN


def _resting_spring_campaign(folder, protocol: str):
    """A spring of 10 N·m/rad resting at 1 rad hidden in the plant (MuJoCo's joint stiffness and
    applied force: 10 N·m at the joint's zero), `protocol` of gap.protocols at 0.5/0.6/0.8 MPa, read
    by the encoder."""
    from gap import protocols

    return synth.make_campaign(
        folder,
        commanded_run.wrist_params(),
        seed=16,
        pressures_mpa=(0.5, 0.6, 0.8),
        motion={q: protocols.library(q)[protocol] for q in (0.5, 0.6, 0.8)},
        rig_spring_nm_per_rad=10.0,
        rig_load_nm=-10.0,
    )


def test_a_spring_resting_off_the_joints_zero_is_called_load(tmp_path):
    """A spring of 10 N·m/rad resting at 1 rad (MuJoCo's joint stiffness and applied force: 10 N·m at
    the joint's zero) hidden in the plant on back-and-forth runs, diagnosed with the whole
    catalogue, whose angle_load springs rest at the joint's zero. No candidate explains it; the
    family call names the load, whose corrections include a static load the same at every angle
    (gap.effects.FAMILY_VARIATIONS, never a candidate), and the report says it was replayed.
    Without that variation the call was the brake."""
    from gap.report import write

    d = diagnose(load_campaign(_resting_spring_campaign(tmp_path / "offset_spring", "back_and_forth")), progress=False)
    w = d.which
    assert "static_load" not in [c.name for c in w.ranking]
    assert w.verdict == "outside the catalogue" and w.nearest.family == "load", (w.verdict, w.nearest)
    write(d, tmp_path / "out")
    assert (
        "load: angle-independent static load at -40/-20/-10/-5/5/10/20/40"
        in (tmp_path / "out" / "report.md").read_text()
    )


def test_each_family_reads_the_gap_at_its_own_instrument_latency(tmp_path):
    """The same resting spring on staircases read by an encoder (no latency). The nominal twin, run
    ahead by the spring's pull, fits the instrument's latency at 45-60 ms; read there, the load's
    corrections left 0.37 of the gap on withheld runs and the valve's 0.30, and the call was the
    valve. Each family fits the latency with its own corrections on each fold's training runs
    (gap.family.fold_latencies), as every candidate does: the load's at 0 ms leave a tenth of the
    gap, and the call is the load."""
    folder = _resting_spring_campaign(tmp_path / "offset_spring_staircase", "staircase")
    w = diagnose(load_campaign(folder), progress=False).which
    assert w.verdict == "outside the catalogue" and w.nearest.family == "load", (w.verdict, w.nearest)
    load = next(x for x in w.families if x.family == "load")
    assert max(load.latency_s) <= 0.005 and load.heldout_shrink < 0.2, load


def test_a_pair_that_acts_through_its_interaction_is_found(tmp_path):
    """A vane leak and more Coulomb friction, read by a camera on the paper's 60-degree moves: both
    take torque and near a stall take more together than apart, so their corrections, added, rank
    the pair 7th of 28 while its replay fits 10 times better than any other pair's. A screen that
    kept only the five best by the sum called the leak alone (held-out 1.1 deg of 23)."""
    from gap.protocols import library

    camera = synth.SimInstrument("camera_30hz", 30.0, 0.2, 0.017, 0.03, phase_s=0.013)
    folder = synth.make_campaign(
        tmp_path / "leak_coulomb",
        commanded_run.wrist_params()._replace(leak_area_m2=2e-7, coulomb_nm=25.0),
        seed=5119,
        motion={q: library(q)["paper_60"] for q in synth.PRESSURES_MPA},
        instrument=camera,
    )
    w = diagnose(load_campaign(folder), progress=False).which
    assert w.verdict == "explained" and w.top.name == "vane_leakage+coulomb_friction", (w.verdict, w.top.name)
    assert w.top.fitted_values == pytest.approx([2e-7, 25.0], rel=0.1)


def _knife_edge_coulomb_campaign(tmp_path):
    """Coulomb friction at 30 N·m on back-and-forth runs read by a 30 Hz camera: at 0.6 MPa the
    joint's release hangs on a fraction of a N·m (the twin's own spread is large there)."""
    from gap.protocols import library

    camera = synth.SimInstrument("camera_30hz", 30.0, 0.2, 0.021, 0.03, phase_s=0.012)
    folder = synth.make_campaign(
        tmp_path / "coulomb",
        commanded_run.wrist_params()._replace(coulomb_nm=30.0),
        seed=5102,
        motion={q: library(q)["back_and_forth"] for q in synth.PRESSURES_MPA},
        instrument=camera,
    )
    return load_campaign(folder)


def test_what_a_residual_leaves_beyond_each_runs_own_spread():
    from gap.stats import rms_beyond_deg

    r = [np.full(4, np.radians(2.0)), np.full(12, np.radians(0.3)), np.zeros(0)]
    spread = np.radians([1.0, 0.5, 3.0])  # the first run keeps 2^2 - 1^2, the second nothing
    assert rms_beyond_deg(r, spread) == pytest.approx(np.sqrt(4 * 3.0 / 16))
    assert rms_beyond_deg(r, np.zeros(3)) == pytest.approx(np.sqrt((4 * 4.0 + 12 * 0.09) / 16))


def test_a_run_on_a_knife_edge_is_held_to_the_twins_own_spread(tmp_path):
    """Coulomb friction at 30 N·m (nominal 15) on back-and-forth moves, read by a camera: at 0.6 MPa
    the drive peaks only just over the friction after the second reversal, and where the joint lets
    go hangs on a fraction of a N·m, which the vanes' torque ripple sets from the angle: the plant
    stands 1.96 deg from the located-event reference there, the replay 0.013 deg. The twin's spread
    finds that run, and the true effect explains the gap beyond it."""
    from gap.campaign_replay import CampaignReplay

    campaign = _knife_edge_coulomb_campaign(tmp_path)
    spread = np.degrees(CampaignReplay(campaign, pressure_weight=0.0).spread([(BY_NAME["coulomb_friction"], 30.0)]))
    at_06 = np.array([r.supply_mpa == 0.6 for r in campaign.runs])
    assert spread[at_06].min() > 1.0 and spread[~at_06].max() < 0.5, spread
    d = diagnose(campaign, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "coulomb_friction", (w.verdict, w.top.name)
    assert w.top.fitted_values[0] == pytest.approx(30.0, rel=0.05)
    assert w.top.heldout_rms_deg > d.noise_floor.significance_threshold_deg  # the spread made the call
    assert w.top.heldout_beyond_spread_deg < d.noise_floor.significance_threshold_deg
    from gap.report import write

    best = [x for x in write(d, tmp_path / "out")["report"].read_text().splitlines() if x.startswith("Best:")]
    assert "beyond the twin's own spread" in best[0] and "run_060_1" in best[0] and "run_080_1" not in best[0]


def test_a_pair_search_starts_in_every_basin_of_the_grid():
    """Two effects acting alike can leave two basins: a shallow one on a grid point and the true,
    deeper one between grid points, whose nearest grid points read worse than the shallow one's.
    From the grid's best point alone the simplex settles in the shallow basin; the search must
    start from each of the grid's best local minima and reach the deeper one."""
    from gap.candidate import Candidate
    from gap.effects import BY_NAME
    from gap.pair_search import screen_pair
    from gap.single_fits import effect_grid

    ga, gb = effect_grid(BY_NAME["vane_leakage"], 5), effect_grid(BY_NAME["coulomb_friction"], 5)

    def sse(leak, coulomb):  # in grid-index coordinates: basin A on a grid point, basin B between
        i, j = np.interp(leak, ga, np.arange(len(ga))), np.interp(coulomb, gb, np.arange(len(gb)))
        return min(1e-3 + 1e-3 * ((i - 1.0) ** 2 + (j - 4.0) ** 2), 1e-5 + 5e-3 * ((i - 3.3) ** 2 + (j - 2.5) ** 2))

    class TwoBasins:  # the twin's objective, without replays: per run and latency
        def run_sses(self, effects, runs):
            v = dict((e.name, x) for e, x in effects)
            return np.full((len(runs), 1), sse(v["vane_leakage"], v["coulomb_friction"]) / len(runs))

    grid = np.array([[sse(a, b) for b in gb] for a in ga])
    assert np.unravel_index(np.argmin(grid), grid.shape) == (1, 4)  # the grid's best is the shallow basin
    found = screen_pair(
        TwoBasins(), Candidate("vane_leakage", [], [], []), Candidate("coulomb_friction", [], [], []), [0]
    )
    assert found < 1e-4


def test_verdict_rules_refuse_a_pair_at_nominal_flag_bounds_and_name_only_a_family():
    from gap import verdict
    from gap.candidate import Candidate
    from gap.run import verdict_line

    p0 = commanded_run.wrist_params()
    at_nominal = Candidate("vane_leakage+heat_exchange", ["vane_leakage", "heat_exchange"], [], [4e-7, 1.4])
    assert verdict.off_nominal(at_nominal, p0) == [True, False]
    moved = Candidate("vane_leakage+heat_exchange", ["vane_leakage", "heat_exchange"], [], [4e-7, 1.2])
    assert verdict.off_nominal(moved, p0) == [True, True]
    assert verdict.at_bounds(Candidate("coulomb_friction", ["coulomb_friction"], [], [60.0])) == ["high"]
    assert verdict.at_bounds(Candidate("coulomb_friction", ["coulomb_friction"], [], [31.0])) == [None]
    outside = SimpleNamespace(
        before_rms_deg=3.0,
        which=SimpleNamespace(
            verdict=Verdict.OUTSIDE,
            top=SimpleNamespace(name="coulomb_friction"),
            nearest=SimpleNamespace(family="friction"),
        ),
    )
    line = verdict_line(outside)
    assert "friction" in line and "coulomb" not in line


def test_hidden_angle_load_is_found_and_located_by_angle(tmp_path):
    """A spring on the joint (MuJoCo's joint stiffness, 20 N·m/rad about zero) hidden in the plant:
    the catalogue's angle-dependent load (the replay's own law) finds it, and "where" shows the
    gap growing with the angle."""
    from gap import protocols

    folder = synth.make_campaign(
        tmp_path / "spring",
        commanded_run.wrist_params(),
        seed=12,
        pressures_mpa=(0.5, 0.8),
        motion={q: protocols.paper_60(q) for q in (0.5, 0.8)},
        rig_spring_nm_per_rad=20.0,
    )
    d = diagnose(load_campaign(folder), catalogue=FAST + _by_name("angle_load", "inertia_error"), progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "angle_load", w.verdict
    assert w.top.fitted_values[0] == pytest.approx(20.0, rel=0.15)
    by_angle = d.where.angle_deg
    assert by_angle["+30..+60"].rms_deg > 2 * by_angle["+0..+30"].rms_deg


def test_hidden_hose_leak_is_found_and_told_from_the_vane_leak(tmp_path):
    """A 0.3 mm^2 leak to atmosphere in port A's hose (the scenarios' hose_leak fault) hidden in the
    plant: air lost on one side only, so the catalogue's hose leak explains it and the vane leak
    (A -> B), the same family, does not stand in for it; the area is recovered."""
    folder = synth.make_campaign(
        tmp_path / "hose_leak",
        commanded_run.wrist_params()._replace(hose_leak_area_m2=3e-7),
        seed=14,
        pressures_mpa=(0.5, 0.6, 0.8),
    )
    d = diagnose(load_campaign(folder), catalogue=FAST + _by_name("hose_leak"), progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "hose_leak", (w.verdict, w.top.name, w.rivals)
    assert w.top.fitted_values[0] == pytest.approx(3e-7, rel=0.15)


def test_hidden_slow_brake_release_is_found_and_told_from_a_late_valve(tmp_path):
    """The brake's piston fills in 0.4 s (nominal 0.05 s): the lining lets go late at every start.
    A late proportional valve delays the starts too, but it also delays the stops and the pressure
    rise; the catalogue's slow release explains the gap and recovers the time constant."""
    folder = synth.make_campaign(
        tmp_path / "slow_brake",
        commanded_run.wrist_params()._replace(brake_release_time_constant_s=0.4),
        seed=16,
        pressures_mpa=(0.5, 0.6, 0.8),
    )
    catalogue = FAST + _by_name("brake_slow_release", "valve_set_dead_time", "valve_dead_time")
    d = diagnose(load_campaign(folder), catalogue=catalogue, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "brake_slow_release", (w.verdict, w.top.name, w.rivals)
    assert w.top.fitted_values[0] == pytest.approx(0.4, rel=0.15)


def test_hidden_slow_brake_engagement_is_found_and_told_from_a_weak_lining(tmp_path):
    """The brake's springs engage in 0.1 s (nominal 0.02 s): every braked stop of a stop-and-go run
    slides on before the lining bites. A weaker lining slides further too, and a late valve stops
    late; the catalogue's slow engagement explains the gap and recovers the time constant."""
    from gap import protocols

    pressures = (0.5, 0.6, 0.8)
    folder = synth.make_campaign(
        tmp_path / "slow_engage",
        commanded_run.wrist_params()._replace(brake_engage_time_constant_s=0.1),
        seed=19,
        pressures_mpa=pressures,
        motion={q: protocols.library(q)["stop_and_go"] for q in pressures},
    )
    catalogue = FAST + _by_name("brake_slow_engage", "brake_holding", "valve_dead_time", "valve_set_dead_time")
    d = diagnose(load_campaign(folder), catalogue=catalogue, progress=False)
    w = d.which
    assert w.verdict == "explained" and w.top.name == "brake_slow_engage", (w.verdict, w.top.name, w.rivals)
    assert w.top.fitted_values[0] == pytest.approx(0.1, rel=0.15)


def test_a_run_that_homes_against_the_end_stop_is_no_gap(tmp_path):
    """No hidden effect; each run drives the wrist wide open into its +90 deg end stop, holds it
    there, brakes, and drives back (a rig homing against its stop). The replay stops the joint
    where the plant's stop does (wrist_rig.one_joint), so the twin's own motion is no gap; before, the
    replay turned on past the stop and the campaign was a 37 deg "outside the catalogue"."""
    from gap.protocols import Protocol, Segment

    homing = Protocol("homing", (Segment(1.6, +1), Segment(0.3, 0, None, False), Segment(0.8, -1)))
    folder = synth.make_campaign(
        tmp_path / "homing", commanded_run.wrist_params(), seed=21, pressures_mpa=(0.5, 0.8), motion=homing
    )
    campaign = load_campaign(folder)
    assert max(np.nanmax(r.angle_rad) for r in campaign.runs) > np.deg2rad(89.5)  # the runs reach the stop
    d = diagnose(campaign, catalogue=FAST, progress=False)
    assert d.which.verdict == "no significant gap", (d.which.verdict, d.before_rms_deg)


def test_hidden_incomplete_brake_release_is_given_to_the_brake(tmp_path):
    """The brake clears only at 6 bar (nominal 4.0): at 0.5 MPa it drags through every move. Three
    supplies: with two, each fold trains on one, and at 0.5 MPa every release pressure above ~5.7
    bar fits alike (the brake never clears), so a fold's value is not identified there."""
    folder = synth.make_campaign(
        tmp_path / "brake",
        commanded_run.wrist_params()._replace(brake_release_gauge_pa=6.0e5),
        seed=13,
        pressures_mpa=(0.5, 0.6, 0.8),
    )
    d = diagnose(
        load_campaign(folder),
        catalogue=_by_name("coulomb_friction", "vane_leakage", "brake_incomplete_release", "brake_holding"),
        progress=False,
    )
    w = d.which
    assert w.top.families[0] == "brake" and w.verdict in ("explained", "ambiguous"), w.verdict
    assert w.top.fitted_values[0] == pytest.approx(6.0e5, rel=0.1)


def test_bench_slice_over_both_instruments(tmp_path):
    """A slice of `twin gap bench` (gap.bench.QUICK, 2 supplies, the whole catalogue): a hidden vane
    leak read by the camera with chamber pressures on stop-and-go runs, and no hidden effect read
    by the camera (stop-and-go, 35 ms latency undeclared)."""
    from gap.bench import run_bench

    s = run_bench(tmp_path, quick=True)
    by = {r["case"]: r for r in s["cases"]}
    assert set(by) == {"vane_leakage", "none_1"}
    assert by["vane_leakage"]["top1"] and by["vane_leakage"]["instrument"] == "camera_30hz"
    assert by["none_1"]["instrument"] == "camera_30hz"
    assert s["false_alarm_rate"] == 0.0, [(r["case"], r["verdict"], r["top"]) for r in s["cases"]]
    assert by["none_1"]["latency_found_s"] == pytest.approx(by["none_1"]["latency_s"], abs=0.010)
    assert s["diagnose_s_max"] >= s["diagnose_s_median"] > 0
    assert (tmp_path / "bench.json").is_file()


def test_bench_under_a_variant_of_its_settings(tmp_path):
    """`twin gap bench --protocol paper_60 --shift 1 --seeds 5000`: the no-effect case of the quick
    slice on the paper's moves, with the instrument of the case one place along and another seed;
    bench.json says so. A protocol the library lacks is refused before any work."""
    from gap.bench import QUICK, Variant, cases, check_variant, run_bench, setting
    from twin_plumbing.errors import UserError

    i = [c.name for c in cases()].index("none_1")
    _, inst, _ = setting(i + 1, cases()[i], np.random.default_rng(1000 + i))
    s = run_bench(tmp_path, quick=True, only="none_1", variant=Variant("paper_60", 1, 5000))
    (r,) = s["cases"]
    assert "none_1" in QUICK and (r["protocol"], r["instrument"]) == ("paper_60", inst.name)
    assert "paper_60" in (tmp_path / "campaigns" / "none_1" / "campaign.toml").read_text().splitlines()[0]
    assert r["verdict"] == "no significant gap"
    assert json.loads((tmp_path / "bench.json").read_text())["variant"] == {
        "protocol": "paper_60",
        "shift": 1,
        "seeds": 5000,
    }
    with pytest.raises(UserError, match="--protocol 'sine': no such protocol; allowed: paper_60, staircase"):
        check_variant(Variant("sine"))


def test_an_ambiguous_verdict_names_the_nearest_of_its_candidates_families(tmp_path):
    """The bench's valve opening 0.7 times as far per bar (its valve_gain form, the catalogue whole
    but nothing of that law) on the paper's 60 deg moves, read by the encoder: a hose leak and a
    valve dead zone explain it and the withheld runs do not tell them apart. The family call among
    their two families names the valve, and the report and the one-line answer say so. Before it,
    an ambiguous verdict named no family and the call read as the hose leak's, leakage."""
    from gap.bench import Variant, cases, make_case_campaign
    from gap.report import write
    from gap.run import verdict_line

    i = [c.name for c in cases()].index("valve_gain")
    make_case_campaign(cases()[i], i, tmp_path / "c", synth.PRESSURES_MPA, None, Variant("paper_60", 0, 5000))
    d = diagnose(load_campaign(tmp_path / "c"), progress=False)
    w = d.which
    assert w.verdict == "ambiguous" and w.rivals, (w.verdict, w.top.name, w.rivals)
    assert w.nearest.family == "valve"
    assert "valve" in {BY_NAME[e].family for n in [w.top.name, *w.rivals] for e in n.split("+")}
    assert "nearest family: valve" in verdict_line(d)
    write(d, tmp_path / "out")
    assert "Of their families, nearest: **valve**" in (tmp_path / "out" / "report.md").read_text()


def test_a_campaign_may_run_several_protocols_at_each_supply(tmp_path):
    """gap.synth.make_campaign with a list of protocols at a supply: each its own runs, lettered, each
    its own replay of the twin (16 distinct runs are benchmarks/bench_gap.py's costliest campaign)."""
    from gap.campaign_replay import CampaignReplay
    from gap.protocols import library

    folder = synth.make_campaign(
        tmp_path / "mixed",
        commanded_run.wrist_params(),
        seed=4,
        pressures_mpa=(0.5, 0.8),
        repeats=1,
        motion={q: [library(q)["reversal"], library(q)["staircase"]] for q in (0.5, 0.8)},
    )
    c = load_campaign(folder)
    assert [r.name for r in c.runs] == ["run_050_a_1", "run_050_b_1", "run_080_a_1", "run_080_b_1"]
    assert len(CampaignReplay(c, pressure_weight=0.0).groups) == 4
    ends = [r.time_s[-1] for r in c.runs]
    assert ends[0] == ends[2] == pytest.approx(library(0.5)["reversal"].total_s(), abs=0.01)
    assert ends[1] == pytest.approx(library(0.5)["staircase"].total_s(), abs=0.01)


def test_a_dask_cluster_gives_the_local_diagnosis(campaigns):
    """`twin gap diagnose --scheduler ADDRESS`: singles and the pair stage on a Dask cluster (here an
    in-process one of two workers) give the diagnosis of the local threads, value for value. The
    catalogue lacks the hidden leak, so no single explains it and the pair stage runs too."""
    distributed = pytest.importorskip("dask.distributed", reason="the cluster extra is not installed")
    catalogue = _by_name("coulomb_friction", "viscous_friction")
    campaign = load_campaign(campaigns["leak"])
    local = diagnose(campaign, catalogue=catalogue, progress=False)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        remote = diagnose(campaign, catalogue=catalogue, progress=False, scheduler=cluster.scheduler_address)
    assert local.which.pairs, "the pair stage did not run"
    a, b = local.which, remote.which
    assert (a.verdict, a.top.name) == (b.verdict, b.top.name)
    assert [(c.name, c.fitted_values, c.heldout_rms_deg) for c in a.ranking + a.pairs] == [
        (c.name, c.fitted_values, c.heldout_rms_deg) for c in b.ranking + b.pairs
    ]


def test_a_family_does_at_least_what_its_best_member_does_alone():
    """The family's correction is chosen on training runs among every member value and sum of two;
    on withheld runs it can leave more than its best member fitted alone: then the member's counts."""
    from gap.family import FamilyFit, at_least

    angle = np.array([True, True, True, False])
    first, second = np.array([True, True, False, False]), np.array([False, False, True, True])
    folds = [(second, first), (first, second)]  # (training, withheld): every sample withheld once
    fit = FamilyFit(np.array([1.0, 1.0, 1.0, 1.0]), 4.0, 3.0, 2, 0.2)
    assert at_least(fit, np.array([0.5, 0.5, 0.5, 2.0]), folds, angle) is fit  # 4.75 > 4: its own fit stays
    taken = at_least(fit, np.array([0.5, 0.5, 0.5, 1.0]), folds, angle)
    assert (taken.heldout_sse, taken.heldout_sse_angle) == (1.75, 0.75)
    assert taken.heldout.tolist() == [0.5, 0.5, 0.5, 1.0] and (taken.shapes, taken.where_misfit) == (2, 0.2)


def test_a_familys_latency_per_fold_is_where_its_best_replayed_row_fits_the_training_runs():
    """gap.family.fold_latencies: per fold, the latency (index of the instrument's grid) at which the
    family's best row, over all its members, fits the fold's training runs best; a mirrored member's
    opposite correction is its last row."""
    from gap import family

    # rows x runs x latencies: run 0 alone wants latency 1 (a's first row), run 1 alone latency 2
    # (b's row), both runs latency 1 (a's second row: 6, 5, 5.8 over the latencies)
    a = family.Member([[], []], np.zeros((2, 3)), np.array([[[5.0, 1.0, 6.0], [9.0, 9.0, 9.0]], [[3.0, 2.5, 2.9]] * 2]))
    b = family.Member([[]], np.ones((1, 3)), np.array([[[9.0, 9.0, 9.0], [4.0, 2.6, 0.4]]]), mirrored=True)
    assert family.fold_latencies([a, b], [[0], [1], [0, 1]]) == [1, 2, 1]
    assert family.fold_latencies([a], [[1]]) == [1]  # without b: a's second row
    gap = np.array([1.0, 2.0, 3.0])
    assert family.Member([[]], np.ones((1, 3)), np.zeros((1, 1, 1)), mirrored=True).corrections(gap).tolist() == [
        [0.0, 1.0, 2.0],
        [-0.0, -1.0, -2.0],
    ]


def test_family_fit_explains_a_mix_of_its_members_and_not_another_familys():
    """gap.family: a gap that is two of one family's members at once (each at a value of its own,
    far from linear in it, with a little noise) is explained by that family's own corrections on
    withheld samples and by its where-profile; a family whose corrections are orthogonal to it
    explains neither."""
    from gap import family

    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 1.0, 400)
    values = np.linspace(0.1, 1.0, 10)
    shift = np.array([np.sin(2 * np.pi * (t - 0.3 * v)) - np.sin(2 * np.pi * t) for v in values])  # a delay
    ramp = np.array([v**2 * t for v in values])
    other = np.array([v * np.cos(6 * np.pi * t) for v in values])
    gap = shift[6] + ramp[3] + 0.01 * rng.standard_normal(t.size)
    half = t < 0.5
    folds = [(half, ~half), (~half, half)]
    angle = np.ones(t.size, bool)
    bins = np.array([np.abs(t - c) < 0.05 for c in np.linspace(0.05, 0.95, 10)], float)  # a where-profile
    members = {"own": [shift, ramp], "other": [other]}  # one latency: each fold's corrections are the same
    at = family.Corrections(members, {f: [(m, gap)] * 2 for f, m in members.items()}, {f: [0.0, 0.0] for f in members})
    fits = family.family_fits(at, gap, folds, angle, bins)
    assert fits["own"].heldout_sse < 0.01 * fits["other"].heldout_sse
    assert fits["own"].heldout_sse < 0.01 * float(gap @ gap)
    assert fits["own"].where_misfit < 0.05 < 0.9 < fits["other"].where_misfit


def test_a_second_effect_whose_gain_lies_on_a_knife_edge_or_under_the_floor_is_not_earned(tmp_path):
    """Coulomb friction at 30 N·m on back-and-forth moves, read by a camera (the knife-edge campaign
    above), its candidates fitted by the diagnosis's own stages: the pair stage fits Coulomb friction
    with a slow brake release at the twin's own 0.05 s, and the pair's withheld misfit is under
    0.8 times Coulomb's alone and clearly below the pair's without the brake: by the margin and by
    the raw misfit per run it would count. Its gain lies on the 0.6 MPa runs, where the joint's
    release hangs on a fraction of a N·m (the twin's own spread there), and under the floor on the
    others: the drop-one test (gap.verdict.Judge.earned_over) refuses it, against the pair's own fits
    with the brake at its nominal value (gap.verdict.Judge.without)."""
    from gap import instrument, verdict
    from gap.campaign_replay import CampaignReplay, nominal_residuals, prepared_runs
    from gap.diagnose import fit_candidates
    from gap.floors import MODEL_TOLERANCE_DEG, floors_of
    from gap.jobs import parallel_jobs
    from gap.stats import mean_lower_bound, rms_deg, rms_kpa, run_ms

    campaign = _knife_edge_coulomb_campaign(tmp_path)
    nuisance = instrument.estimate(campaign)
    fl = floors_of(campaign, prepared_runs(campaign, nuisance), MODEL_TOLERANCE_DEG)
    replay = CampaignReplay(campaign, pressure_weight=fl.pressure_weight, nuisance=nuisance)
    before, before_p = nominal_residuals(replay, replay.ref_latency_s)
    catalogue = tuple(BY_NAME[n] for n in ("coulomb_friction", "brake_slow_release", "viscous_friction"))
    with parallel_jobs(1, None) as run_jobs:
        fits = fit_candidates(replay, catalogue, fl, True, run_jobs, False)
    judge = verdict.Judge(replay, fl, rms_deg(before), fl.score, np.random.default_rng(0), rms_kpa(before_p))
    coulomb = fits.singles[0]
    pair = next(p for p in fits.pairs if p.name == "coulomb_friction+brake_slow_release")
    assert coulomb.name == "coulomb_friction" and fl.score(pair) < verdict.PAIR_MARGIN * fl.score(coulomb)
    without = judge.without(pair, "brake_slow_release")
    raw = [run_ms(c.heldout, c.heldout_p, fl.floor_deg, fl.floor_kpa) for c in (pair, without, coulomb)]
    for sub in raw[1:]:  # the same test on the raw misfit would count it
        assert mean_lower_bound(sub - raw[0], np.random.default_rng(verdict.EARNED_SEED)) > 0.0, raw
    # against Coulomb's own single fit (its folds at 29.15-30.02 N·m) the brake would be earned: the
    # pair's folds fit Coulomb better, so the model without the brake is also the pair's own fits
    assert judge.earned_over(pair, coulomb) and not judge.earned_over(pair, without)
    assert "brake_slow_release" in judge.pair_counts(pair, coulomb, fits.singles)


def test_a_pair_whose_second_effect_does_not_beat_its_first_alone_on_withheld_runs_does_not_count():
    """The drop-one test (gap.verdict.Judge.earned_over) on withheld residuals, runs the unit: a pair
    that does better than its member alone on one run and worse on the five others is not earned,
    though its misfit over all runs is clearly below the best single's (the margin alone would count
    it); one that does better on every run is."""
    from gap import verdict
    from gap.candidate import Candidate
    from gap.floors import Floors

    def cand(name, values, rms_deg):  # six withheld runs of 50 samples at these rms (deg)
        heldout = [np.full(50, np.radians(x)) for x in rms_deg]
        return Candidate(name, name.split("+"), [], values, heldout, [np.zeros(0)] * 6, spread=np.zeros(6))

    fl = SimpleNamespace(floor_deg=1.0, floor_kpa=1.0, threshold_deg=2.0, threshold_kpa=2.0)
    alone = cand("coulomb_friction", [30.0], [6.0, 2.0, 2.0, 2.0, 2.0, 2.0])
    other = cand("valve_lag", [0.2], [5.0] * 6)
    pair = cand("coulomb_friction+valve_lag", [30.0, 0.2], [0.0] + [2.2] * 5)
    judge = verdict.Judge(
        SimpleNamespace(params=commanded_run.wrist_params()), fl, 10.0, None, np.random.default_rng(0)
    )
    judge.score = lambda c: Floors.score(fl, c)
    judge.beyond_spread_deg = lambda c: 0.0
    judge.without = lambda pair, dropped: None  # no replay here: each member's single fit is its sub-model
    assert judge.score(pair) < verdict.PAIR_MARGIN * judge.score(alone)
    assert not judge.earned_over(pair, alone) and judge.earned_over(pair, other)
    why = judge.pair_counts(pair, alone, [alone, other])
    assert why.startswith("valve_lag is not earned") and "coulomb_friction alone" in why, why
    better = cand(pair.name, pair.full_values, [0.5] * 6)
    assert judge.earned_over(better, alone) and judge.pair_counts(better, alone, [alone, other]) == ""
