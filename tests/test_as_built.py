"""The as-built arm (issue 14): its files, reality built from them, the predictor left nominal, the
vane-passing air loss of the chamber law against an analytic balance, the wrist's gravity load
docs/validation/plant.md quotes, and a slice of `twin paper` on the paper's own protocol."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import assets
from pneumatics import (
    AIR,
    chamber_volumes,
    load_joint_params,
    orifice_mass_flow,
    paper_model,
    params_row,
)
from pneumatics.as_built import SOURCES, load_as_built, load_as_built_effects
from pneumatics.joint import (
    S_DIR,
    S_PA_MOTOR,
    S_PA_VALVE,
    S_PB_MOTOR,
    S_PB_VALVE,
    S_PV,
    advance_air_pair,
    finish_air_pair,
    initial_state,
)
from scenarios import controllers
from scenarios.runner import build_plant, reality_params
from scenarios.schema import ScenarioError, joint_params_for, parse
from twin_plumbing.errors import ParameterError

RIG = """
model = "wrist_rig"
start = { pose = "zero" }
targets = [{ angles_deg = { wrist_pitch = 30.0 } }]
"""


@pytest.mark.parametrize("joint", assets.JOINTS)
def test_every_joint_has_an_as_built_file_whose_every_effect_says_its_source(joint):
    effects = load_as_built_effects(assets.as_built_path(joint))
    nominal = load_joint_params(assets.joint_param_path(joint))
    real = load_as_built(nominal, assets.as_built_path(joint))
    assert effects and all(e.source in SOURCES and len(e.basis) > 20 for e in effects)
    assert real != nominal
    for e in effects:
        assert getattr(real, e.field) == e.value


@pytest.mark.parametrize(
    "text, words",
    [
        ("[effects.magic]\nvalue = 1.0\nsource = 'assumed'\nbasis = 'x'", ("[effects.magic]", "allowed")),
        (
            "[effects.leak_area_m2]\nvalue = -1.0\nsource = 'assumed'\nbasis = 'a guess'",
            ("leak_area_m2", "-1", "allowed"),
        ),
        (
            "[effects.leak_area_m2]\nvalue = 1e-8\nsource = 'folklore'\nbasis = 'a guess'",
            ("leak_area_m2", "'folklore'", "datasheet"),
        ),
        ("[effects.leak_area_m2]\nvalue = 1e-8\nsource = 'assumed'", ("leak_area_m2", "basis", "allowed")),
        ("[motor]\nn_vanes = 4", ("[motor]", "allowed")),
    ],
)
def test_a_bad_as_built_file_is_refused_with_path_field_value_and_allowed(tmp_path, text, words):
    f = tmp_path / "wrist_pitch.toml"
    f.write_text(text)
    with pytest.raises(ParameterError) as e:
        load_as_built(load_joint_params(assets.joint_param_path("wrist_pitch")), f)
    assert str(e.value).startswith(str(f))
    assert all(w in str(e.value) for w in words), str(e.value)


def test_reality_is_the_as_built_arm_by_default_and_the_predictor_stays_nominal():
    s = parse(RIG)
    nominal = load_joint_params(assets.joint_param_path("wrist_pitch"))
    real = load_as_built(nominal, assets.as_built_path("wrist_pitch"))
    plant = build_plant(s)
    assert s.reality.arm == "as_built"
    np.testing.assert_array_equal(plant.params[0], params_row(real, dt_s=plant.dt))  # rows keep lag factors for dt
    controller, refusal = controllers.build(
        s, plant, joint_params_for({"wrist_pitch": nominal}, s.predictor), [{"wrist_pitch": 0.5}]
    )
    assert not refusal
    stops = tuple(controller.arm.drive_stops()[0])  # the rig's +-90 deg: where a prediction stops
    # the predictor: the nominal parameters with the paper's chamber law (DESIGN rule 2)
    np.testing.assert_array_equal(
        controller.params[0], params_row(paper_model(nominal), dt_s=controller.dt, stops=stops)
    )
    assert not np.array_equal(plant.params[0], controller.params[0])


def test_reality_can_be_the_nominal_twin_for_a_self_check():
    s = parse(RIG + '[reality]\narm = "nominal"\n')
    assert reality_params(s) == {"wrist_pitch": paper_model(load_joint_params(assets.joint_param_path("wrist_pitch")))}


@pytest.mark.parametrize(
    "extra, field", [('[reality]\narm = "ideal"', "reality.arm"), ('[predictor]\narm = "as_built"', "predictor.arm")]
)
def test_a_bad_arm_choice_is_refused(extra, field):
    with pytest.raises(ScenarioError) as e:
        parse(RIG + extra, "bad.toml")
    assert field in str(e.value) and "allowed" in str(e.value)


def test_vane_passing_vents_the_pockets_air_as_the_analytic_balance_says():
    """The chamber law (pneumatics/motor.py) resets V_A to the dead volume at each vane passing
    while the node pressures stay: the pocket's air, p_A dV/(R T) at port A's side, leaves the
    model, and B's side gains p_B dV/(R T) from nowhere. With n = 1 the nodes' air is exactly
    p V / (R T), so over a steady run at constant speed
        (mass in at A) - (mass out at B) - (mass stored) = sum over passings (p_A - p_B) dV / (R T),
    which holds here to 1 %. The vented share of what enters A is what docs/validation/air.md quotes.
    (The paper's law, `paper_model`: with n = 1 its nodes stay at the supply temperature.)"""
    p = paper_model(load_joint_params(assets.joint_param_path("wrist_pitch")))._replace(polytropic_n=1.0)
    row = params_row(p)
    r, t_s, atm = AIR.r_j_per_kg_k, AIR.t_supply_k, AIR.p_atm_pa
    supply = atm + 0.6e6
    x = initial_state(atm, brake_engaged=False)
    x[S_DIR] = 1.0
    x[S_PV] = 0.6e6  # fully open, delivering the supply
    pitch = 2.0 * math.pi / p.n_vanes
    w_m = 80.0 * pitch  # 80 passings a second (60 deg/s at the joint)
    omega = w_m / p.ratio
    dt = 1e-5
    va_lo, vb_lo = chamber_volumes(
        -pitch / 2 + 1e-12, p.stator_radius_m, p.rotor_radius_m, p.vane_length_m, p.n_vanes, 0.0
    )
    d_v = vb_lo - va_lo  # one pitch's swept volume
    half_hose = 0.5 * math.pi / 4 * p.hose_diameter_m**2 * p.hose_length_m
    inlet = p.inlet_area_m2 * min(1.0, p.k_u_per_pa * 0.6e6)

    def stored(theta):
        va, vb = chamber_volumes(
            p.ratio * theta, p.stator_radius_m, p.rotor_radius_m, p.vane_length_m, p.n_vanes, p.dead_volume_m3
        )
        return (
            x[S_PA_VALVE] * half_hose
            + x[S_PA_MOTOR] * (va + half_hose)
            + x[S_PB_VALVE] * half_hose
            + x[S_PB_MOTOR] * (vb + half_hose)
        ) / (r * t_s)

    def flows():
        m_in = orifice_mass_flow(supply, x[S_PA_VALVE], inlet, t_s, r, AIR.k)
        m_out = -orifice_mass_flow(atm, x[S_PB_VALVE], p.exhaust_area_m2, t_s, r, AIR.k)
        return m_in, m_out

    def step(theta):  # the air over dt as the plant advances it, the joint turning at omega
        advance_air_pair(x, theta, omega, 0.6e6, supply, dt, row)
        theta += omega * dt
        finish_air_pair(x, theta, omega, dt, row)
        return theta

    theta = 0.0
    for _ in range(int(1.0 / dt)):  # 1 s to a steady state
        theta = step(theta)
    m0 = stored(theta)
    mass_in = mass_out = vented = 0.0
    f0 = flows()
    for _ in range(int(0.5 / dt)):  # 40 passings
        pa, pb, before = x[S_PA_MOTOR], x[S_PB_MOTOR], math.floor(p.ratio * theta / pitch + 0.5)
        theta = step(theta)
        f1 = flows()
        mass_in += 0.5 * dt * (f0[0] + f1[0])
        mass_out += 0.5 * dt * (f0[1] + f1[1])
        f0 = f1
        if math.floor(p.ratio * theta / pitch + 0.5) != before:
            vented += 0.5 * (pa - pb + x[S_PA_MOTOR] - x[S_PB_MOTOR]) * d_v / (r * t_s)
    balance = mass_in - mass_out - (stored(theta) - m0)
    assert balance == pytest.approx(vented, rel=0.01)
    share = vented / mass_in
    print(f"vented share {share:.3f}, p_A {x[S_PA_MOTOR]:.0f} p_B {x[S_PB_MOTOR]:.0f} Pa, in {mass_in:.3e} kg")
    # docs/validation/air.md: most of the air entering at A is vented at the passings (80 % here)
    assert 0.5 < share < 0.95, share
    assert mass_out > 0.0


def test_the_plant_page_quotes_the_wrists_gravity_load_from_the_mjcf():
    """Gravity on the wrist at full reach (its distal mass horizontal) with the 20 kg payload,
    from Pinocchio reading the MJCF, is what docs/validation/plant.md says: 23.0 N·m (the load without the
    wrist's counterbalance spring, which the arm model adds)."""
    from control.arm_model import ArmModel

    arm = ArmModel(assets.ARM_XML, payload_kg=20.0)
    i = arm.joints.index("wrist_pitch")
    home = np.zeros(len(arm.joints))
    loads = []
    for q in np.radians(np.arange(-180.0, 180.0, 0.5)):
        home[i] = q
        loads.append(abs(arm.load_torques(home)[i] - arm.spring_torques(home)[i]))
    assert max(loads) == pytest.approx(23.0, abs=0.05)
    assert "23.0 N·m" in (assets.ASSETS_DIR.parent / "docs" / "validation" / "plant.md").read_text()


@pytest.fixture(scope="module")
def validation():
    from scenarios.paper_validation import PRESSURES_MPA, rig_inertia, validation_run, wrist_models

    nominal, reality = wrist_models()
    inertia = rig_inertia(nominal)
    return {m: validation_run(reality, nominal, m, inertia) for m in (PRESSURES_MPA[0], PRESSURES_MPA[-1])}


def test_paper_validation_on_the_as_built_plant_within_a_factor_2_where_the_nominal_allows(validation):
    """Fig. 10-16 on the paper's protocol (1 s open, same commands for both predictions), the
    as-built plant measured: the model with the hose loss is closer at both ends of the range, its
    errors and the 0.5 MPa errors without the loss are within a factor 2 of the paper's."""
    from scenarios.paper_validation import PAPER

    for m, run in validation.items():
        e = run.errors()
        assert e["with_hose_loss"]["mean"] < e["without_hose_loss"]["mean"], m
        for stat in ("mean", "max"):
            assert 0.5 < e["with_hose_loss"][stat] / PAPER["with_hose_loss"][stat][m] < 2.0, (m, stat, e)
    e05 = validation[0.5].errors()["without_hose_loss"]
    assert 0.5 < e05["mean"] / PAPER["without_hose_loss"]["mean"][0.5] < 2.0, e05
    # the paper's shape: the error without the loss largest at 0.5 MPa (measured 15.8 against 13.9
    # deg at 0.8 MPa; the nominal pair alone grows with the supply, tests/test_gap.py: our reading is
    # that the supply's droop lowers the real port into the brake's band at 0.5 MPa, not probed)
    assert e05["mean"] > validation[0.8].errors()["without_hose_loss"]["mean"]
    # the measured and the predicted runs really turn, and start together
    assert all(
        r.measured_deg[r.time_s <= 1.0][-1] > 30.0 and abs(r.measured_deg[0]) < 1e-9 for r in validation.values()
    )


def _synthetic_run(mpa: float, gap_deg: float):
    """A ValidationRun at `mpa` whose prediction with the loss is the measured run and whose
    prediction without it runs ahead, by up to `gap_deg` at 1 s (a linear ramp: mean half the max)."""
    from scenarios.paper_validation import ValidationRun

    t = np.linspace(0.0, 1.0, 51)
    measured = 60.0 * t
    predicted = {"with_hose_loss": measured.copy(), "without_hose_loss": measured + gap_deg * t}
    return ValidationRun(supply_mpa=mpa, time_s=t, measured_deg=measured, predicted_deg=predicted)


def test_the_fit_leaves_out_only_the_figures_the_nominal_model_puts_out_of_reach():
    """Where the two nominal predictions lie farther apart than the paper's two errors added, the
    figure without the loss leaves the misfit (no reality meets both); elsewhere it counts."""
    from scenarios.paper_validation import PAPER, misfit

    bound = PAPER["with_hose_loss"]["mean"][0.8] + PAPER["without_hose_loss"]["mean"][0.8]  # 4.4 deg
    assert set(_synthetic_run(0.8, 3.0 * bound).unreachable()) == {"mean", "max"}
    assert _synthetic_run(0.8, 0.5 * bound).unreachable() == ()
    # the max pair alone: 0.7 MPa's maxima add to 26.4 deg, its means to 15.4
    assert _synthetic_run(0.7, 28.0).unreachable() == ("max",)
    # out of reach, the error without the loss does not move the misfit; within reach it does
    assert misfit([_synthetic_run(0.8, 3.0 * bound)]) == pytest.approx(misfit([_synthetic_run(0.8, 5.0 * bound)]))
    assert misfit([_synthetic_run(0.8, 0.5 * bound)]) != pytest.approx(misfit([_synthetic_run(0.8, 0.9 * bound)]))


def test_twin_paper_quick_writes_every_figure_with_the_papers_numbers(tmp_path):
    """`twin paper --quick` (control experiments shortened): paper.json holds the validation's mean
    and max beside the paper's, the report shows them, every plot exists, and the control
    experiments, predictions against the as-built wrist, land within a factor 2 of the paper's
    where docs/validation/as_built_and_paper.md says they do."""
    from twin_cli.cli import main as twin_main

    assert twin_main(["paper", "--out", str(tmp_path), "--quick"]) == 0
    r = json.loads((tmp_path / "paper.json").read_text())
    pe = r["prediction_error"]["errors"]
    assert set(pe) == {"0.5", "0.6", "0.7", "0.8"}
    for row in pe.values():
        for kind in ("with_hose_loss", "without_hose_loss"):
            assert row[kind]["max"] >= row[kind]["mean"] > 0.0 and row[kind]["paper_max"] > 0.0
    assert r["prediction_error"]["with_smaller_than_without_everywhere"]
    co = r["closed_vs_open_loop"]
    assert len(co["angles_deg"]) == 3
    # closed beats open at every angle, as in the paper (before the loop's set point was floored clear
    # of the brake's drag band it did not at 20-30 deg: docs/validation/predictor_and_control.md)
    assert all(c < o for c, o in zip(co["closed_loop_error_deg"], co["open_loop_error_deg"], strict=True))
    assert r["random_supply"]["max_error_deg"] < 2 * r["random_supply"]["paper_max_error_deg"]
    mr = r["minimum_rotation"]  # the paper's ~20 deg within a factor 2 (before the brake margin: none)
    assert mr["limit_deg"] in mr["tested_deg"] and 10.0 <= mr["limit_deg"] <= 40.0, mr
    ep = r["error_vs_pressure"]  # Fig. 20: within +-3 deg at 0.5 MPa (its growth with the supply is not met)
    assert ep["pressures_mpa"][0] == 0.5 and ep["max_error_deg"][0] < 3.0, ep
    # Fig. 20 under Fig. 17's loop as drawn (the PID holds the joint on the valve): the paper's trend,
    # the error growing with the supply, within +-3 deg at 0.5 MPa (with the arm's hand-over to the
    # brake it does not grow: docs/validation/as_built_and_paper.md, "What remains off")
    held = ep["fig17_loop"]
    assert held["predicted_grows_with_pressure"] and held["true_grows_with_pressure"], held
    assert held["true_max_error_deg"][0] < 3.0, held
    # the open loop's error is the as-built joint's, not the valve time's: its own prediction lands
    assert max(co["open_loop_predicted_error_deg"]) < 0.5, co
    assert "Minimum rotation, Fig. 21" in (tmp_path / "report.md").read_text()
    assert len(r["error_vs_pressure"]["pressures_mpa"]) == 2
    report = (tmp_path / "report.md").read_text()
    assert f"({pe['0.5']['without_hose_loss']['paper_max']})" in report and "calibrated" in report
    for name in (
        "validation_timeseries",
        "prediction_error",
        "error_vs_angle",
        "speed_vs_supply",
        "random_supply",
        "closed_vs_open_loop",
        "error_vs_pressure",
    ):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000, name
