"""The predictor's hose loss is the paper's eq. 1-5 as written (issue 34 item 3, DESIGN rule 2).

- the drop against eq. 1-5 written out here in the paper's own units (V m^3/h, d mm, P MPa), its
  implicit P_s solved by scipy's brentq;
- the drop's shape in supply, the issue's 1.00/0.86/0.76/0.67 at 0.5-0.8 MPa;
- the air's rates with the loss are those without it fed from a supply lowered by the hand-computed
  drop (the loss acts on the supplied port's feed alone);
- the paper's experiment at 0.8 MPa: the two predictions are close enough for one reality to meet
  both paper figures (with the physical hose they were not).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import assets
from pneumatics import load_joint_params, paper_model, params_row
from pneumatics.gas import AIR
from pneumatics.joint import pressure_rates
from pneumatics.paper_hose import paper_hose_drop
from pneumatics.params import HOSE_LAW_PAPER
from scenarios.paper_validation import PAPER, rig_inertia, validation_run, wrist_models

WRIST = load_joint_params(assets.joint_param_path("wrist_pitch"))
P_ATM = 101_325.0


def eq5_by_hand(supply_gauge_mpa: float) -> float:
    """The paper's eq. 1-5 in its own units for the wrist's hose: Delta P_i in Pa."""
    p_i = supply_gauge_mpa + 0.101325  # MPa, absolute: the compressor's output P_i
    p_o = 0.101325  # the motor's outlet, the atmosphere; P_B = P_e = P_o (eq. 4)
    lam = 0.316 / 2497.0**0.25  # eq. 3 at the paper's Re
    v = WRIST.hose_standard_flow_m3_s * 3600.0  # m^3/h
    d = WRIST.hose_diameter_m * 1000.0  # mm
    t_s, k, rho_0 = 293.15, 1.4, 1.293

    def residual(p_s: float) -> float:
        t_b = t_s * (p_o / p_s) ** ((k - 1.0) / k)  # eq. 2
        t_m = (t_b + t_s) / 2.0
        return p_s - (p_i - 46756.0 * lam * WRIST.hose_length_m * v**2 * t_m * rho_0 / (d**5 * (p_i + p_o)) * 1e-6)

    p_s = brentq(residual, p_o, p_i, xtol=1e-15)
    return (p_i - p_s) * 1e6


def test_the_constant_of_eq_1_is_darcy_weisbach_in_m3_per_hour_mm_and_mpa() -> None:
    """(8 / pi^2)(P_0 / T_0) lambda V^2 T_m rho_0 / (d^5 P_m) in SI, with V in m^3/h, d in mm, P_m in MPa,
    gives R in Pa/m with the constant 23 200 at 0 degC, 101.325 kPa: the paper's 23 378 is 0.8 % above."""
    si = 8.0 / math.pi**2 * (101_325.0 / 273.15) / 3600.0**2 * 1e-3**-5 / 1e6
    assert si == pytest.approx(23378.0, rel=0.01)
    assert si == pytest.approx(23200.0, abs=1.0)
    # and the 20 degC state (ISO 8778) is 7.5 % off: the paper's standard state is 0 degC
    assert abs(si * 273.15 / 293.15 / 23378.0 - 1.0) > 0.07


@pytest.mark.parametrize("supply_gauge_mpa", [0.5, 0.8])
def test_the_drop_is_eq_1_to_5_as_written(supply_gauge_mpa: float) -> None:
    drop = paper_hose_drop(
        supply_gauge_mpa * 1e6 + P_ATM,
        P_ATM,
        AIR.t_supply_k,
        AIR.k,
        WRIST.hose_length_m,
        WRIST.hose_diameter_m,
        WRIST.hose_standard_flow_m3_s,
    )
    by_hand = eq5_by_hand(supply_gauge_mpa)
    print(f"\n{supply_gauge_mpa} MPa: eq. 5 drop {drop:.2f} Pa, by hand {by_hand:.2f} Pa")
    assert drop == pytest.approx(by_hand, rel=1e-9)
    assert 1e3 < drop < 0.5 * supply_gauge_mpa * 1e6  # a real drop, not more than the supply can give


def test_the_drop_falls_as_the_supply_rises_as_the_issue_says() -> None:
    """1.00/0.86/0.76/0.67 of the 0.5 MPa drop at 0.5/0.6/0.7/0.8 MPa (issue 34): the 1/(P_i + P_o)
    of eq. 5 and the colder T_B of eq. 2. By hand, with P_s = P_i in eq. 2 (a drop of a few % moves
    the ratios by less than 0.005)."""

    def shape(g: float) -> float:
        p_i, p_o = g + 0.101325, 0.101325
        t_m = (293.15 * (p_o / p_i) ** (0.4 / 1.4) + 293.15) / 2.0
        return t_m / (p_i + p_o)

    by_hand = [shape(g) / shape(0.5) for g in (0.5, 0.6, 0.7, 0.8)]
    drops = [
        paper_hose_drop(g * 1e6 + P_ATM, P_ATM, AIR.t_supply_k, AIR.k, 8.0, 0.004, WRIST.hose_standard_flow_m3_s)
        for g in (0.5, 0.6, 0.7, 0.8)
    ]
    ratios = [d / drops[0] for d in drops]
    print("\nratios", [round(r, 3) for r in ratios], "by hand", [round(r, 3) for r in by_hand])
    assert ratios == pytest.approx([1.00, 0.86, 0.76, 0.67], abs=0.01)  # the issue gives two digits
    assert ratios == pytest.approx(by_hand, abs=0.005)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_with_the_loss_the_supplied_port_is_fed_from_the_supply_less_the_drop_the_exhausted_one_not(
    direction: float,
) -> None:
    """At 0.8 MPa with the valve fully open, the air's rates by the paper's loss equal those without
    the loss from a supply lowered by eq. 5's drop computed by hand, at any state of the four nodes
    (eq. 5: P_s = P_i - Delta P_i on the supplied port, P_e = P_o on the exhausted one)."""
    eq5 = paper_model(WRIST)._replace(hose_law=HOSE_LAW_PAPER)
    row = params_row(eq5)
    row_without = params_row(eq5._replace(hose_loss=0.0))
    supply = 0.8e6 + P_ATM
    drop = eq5_by_hand(0.8)
    rng = np.random.default_rng(34)
    for _ in range(50):
        pa, pb = rng.uniform(P_ATM, supply, 2)
        phi, omega = rng.uniform(-1.0, 1.0), rng.uniform(-300.0, 300.0)
        state = (pa, pa, pb, pb, phi, omega, direction, 0.8e6)
        with_loss = pressure_rates(*state, supply, row)
        shifted = pressure_rates(*state, supply - drop, row_without)
        without = pressure_rates(*state, supply, row_without)
        assert with_loss == pytest.approx(shifted, rel=1e-9, abs=1e-6)
        fed = 1 if direction > 0 else 3  # the supplied port's motor node
        assert with_loss[fed] < without[fed]
        assert with_loss[4 - fed] == without[4 - fed]  # the exhausted port: no loss


def test_the_papers_pair_at_08_mpa_is_within_reach_of_one_reality_only_under_eq_5() -> None:
    """The paper's 0.8 MPa mean errors, 1.2 deg with the loss and 3.2 deg without, need the two
    predictions within 4.4 deg of each other (a reality's two errors add to at least their
    distance, sample by sample). With eq. 5 as written they are about 1.7 deg apart; with the
    pi-section on the real flow (the shipped predictor) about 13 deg: no reality meets both."""
    nominal, reality = wrist_models()
    bound = PAPER["with_hose_loss"]["mean"][0.8] + PAPER["without_hose_loss"]["mean"][0.8]
    apart = {}
    for law, params in (("eq5", nominal._replace(hose_law=HOSE_LAW_PAPER)), ("pi", nominal)):
        run = validation_run(reality, params, 0.8, rig_inertia(params), plant=False)
        apart[law] = run.predictor_gap()["mean"]
    print(f"\n0.8 MPa: the predictions with and without the loss {apart} deg apart (mean)")
    assert 0.5 < apart["eq5"] < bound < apart["pi"]


def _paper_runs(params, supplies):
    """The paper's validation run at each supply, the as-built wrist as reality, `params` predicting."""
    nominal, reality = wrist_models()
    return {mpa: validation_run(reality, params, mpa, rig_inertia(params), plant=False) for mpa in supplies}


def test_no_as_built_arm_meets_every_paper_figure_within_x2_under_either_sourced_hose_law() -> None:
    """Issue 34 asks both for the paper's eq. 1-5 in the predictor with V from a datasheet and for
    every validation figure within x2, the 0.8 MPa pair included. The two predictions (with and
    without the loss) bound what any reality can score (ValidationRun.out_of_reach_within), and:
    - the pi-section on the real flow puts them 13 deg apart at 0.8 MPa, more than the 8.8 deg the
      paper's 1.2 and 3.2 deg allow at x2;
    - eq. 5 at the sourced V (2.16 m^3/h, the swept volume at the max-power speed, the joint file)
      puts them 2.2 deg apart at 0.7 MPa, less than the 2.7 deg that x2 on 2.0 and 13.4 deg needs;
    - eq. 5 at V = 3 m^3/h (no source: docs/predictor_hose_law.md) would leave every pair within
      reach, so the bound is not vacuous: the figures turn on a number the paper does not give."""
    nominal, _ = wrist_models()
    pi = _paper_runs(nominal, (0.8,))
    assert set(pi[0.8].out_of_reach_within(2.0)) == {"mean", "max"}
    eq5 = nominal._replace(hose_law=HOSE_LAW_PAPER)
    assert eq5.hose_standard_flow_m3_s * 3600.0 == pytest.approx(2.16, abs=0.01)
    sourced = _paper_runs(eq5, (0.7,))
    assert "mean" in sourced[0.7].out_of_reach_within(2.0)
    unsourced = _paper_runs(eq5._replace(hose_standard_flow_m3_s=3.0 / 3600.0), (0.5, 0.6, 0.7, 0.8))
    assert all(r.out_of_reach_within(2.0) == () for r in unsourced.values())
