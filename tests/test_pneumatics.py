"""Analytic and property tests of the laws in pneumatics/ (STYLE rule 8, first two layers).

Every expected value below is computed here from a textbook formula or a numerical operation
(quadrature, finite difference, root finding, scipy's ODE solver) that does not call the
function under test, so a wrong law fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq, curve_fit

import assets
from pneumatics import (
    AIR,
    brake_feed_gauge_pa,
    brake_target,
    chamber_pressure_rate,
    chamber_volumes,
    critical_pressure_ratio,
    dead_time_step,
    displacement_per_rad,
    flow_function,
    friction_factor,
    hose_mass_flow,
    hose_pressure_drop,
    isentropic_temperature,
    lag_toward,
    least_displacement_per_rad,
    load_joint_params,
    orifice_mass_flow,
    params_row,
    reducer_output_torque,
    solenoid_step,
    swept_area,
    vane_torque,
)
from pneumatics import params as P
from pneumatics.hose import BLASIUS_LAMINAR_RE, reynolds_number
from pneumatics.joint import (
    N_RIGID,
    R_OMEGA,
    R_OMEGA_M,
    R_PA_MOTOR,
    R_PB_MOTOR,
    R_QM,
    R_THETA,
    S_BRAKE,
    S_PV,
    advance_brake,
    advance_discrete,
    effective_supply,
    initial_rigid_state,
    initial_state,
    single_joint_step,
)
from pneumatics.orifice import LINEAR_RATIO
from pneumatics.reducer import (
    CONTACT_STIFFNESS_NM_PER_RAD,
    MAX_STIFFNESS_NM_PER_RAD,
    damping,
    stiffness,
    transmitted_torque,
)

R, K, T_S, P_ATM, MU = AIR.r_j_per_kg_k, AIR.k, AIR.t_supply_k, AIR.p_atm_pa, AIR.mu_pa_s
WRIST = load_joint_params(assets.joint_param_path("wrist_pitch"))
GEOM = (WRIST.stator_radius_m, WRIST.rotor_radius_m, WRIST.vane_length_m, WRIST.n_vanes)
PITCH = 2.0 * math.pi / WRIST.n_vanes


# --- chamber: a sealed chamber is a polytropic process ------------------------------------------
@pytest.mark.parametrize("n", [1.4, 1.2, 1.0])
def test_sealed_chamber_keeps_p_v_to_the_n_constant(n: float) -> None:
    v0, p0 = 1.0e-4, 3.0e5

    def volume(t: float) -> tuple[float, float]:
        # compressed to 0.4 V0 and expanded to 1.6 V0, twice
        return v0 * (1.0 + 0.6 * math.sin(4.0 * math.pi * t)), v0 * 0.6 * 4.0 * math.pi * math.cos(4.0 * math.pi * t)

    def rhs(t, y):
        v, dv = volume(t)
        return [chamber_pressure_rate(y[0], v, dv, 0.0, T_S, R, n)]

    ts = np.union1d(np.linspace(0.0, 1.0, 101), [0.375])  # 0.375 s: smallest volume
    sol = solve_ivp(rhs, (0.0, 1.0), [p0], method="LSODA", rtol=1e-10, atol=1e-6, t_eval=ts)
    assert sol.success
    v = np.array([volume(t)[0] for t in ts])
    invariant = sol.y[0] * v**n
    assert np.max(np.abs(invariant / (p0 * v0**n) - 1.0)) < 1e-7
    # and it really was compressed: at 0.4 V0 the pressure is 0.4^-n p0
    assert sol.y[0].max() == pytest.approx(p0 * 0.4**-n, rel=1e-3)


def test_inflow_into_a_rigid_chamber_is_isothermal_or_adiabatic_filling() -> None:
    # dp/dt = n R T m / V for a rigid chamber (Richer & Hurmuzlu 2000, eq. 19)
    assert chamber_pressure_rate(2e5, 1e-4, 0.0, 1e-3, T_S, R, 1.4) == pytest.approx(
        1.4 * R * T_S * 1e-3 / 1e-4, rel=1e-12
    )


# --- orifice ------------------------------------------------------------------------------------
@pytest.mark.parametrize("k", [1.4, 1.3, 1.67])
def test_critical_pressure_ratio(k: float) -> None:
    assert critical_pressure_ratio(k) == pytest.approx((2.0 / (k + 1.0)) ** (k / (k - 1.0)), rel=1e-14)


def test_critical_ratio_of_air_is_0_528_not_the_papers_typo() -> None:
    assert critical_pressure_ratio(1.4) == pytest.approx(0.5283, abs=1e-4)


def test_choked_flow_does_not_depend_on_downstream_pressure() -> None:
    p_up, area = 6.0e5, 5.0e-6
    # textbook choked mass flow: A p sqrt(k/(R T)) (2/(k+1))^((k+1)/(2(k-1)))
    choked = area * p_up * math.sqrt(K / (R * T_S)) * (2.0 / (K + 1.0)) ** ((K + 1.0) / (2.0 * (K - 1.0)))
    pr_crit = (2.0 / (K + 1.0)) ** (K / (K - 1.0))
    for ratio in np.linspace(0.0, pr_crit * (1 - 1e-9), 37):
        assert orifice_mass_flow(p_up, ratio * p_up, area, T_S, R, K) == pytest.approx(choked, rel=1e-12)
    # 0.0404 kg K^0.5 / (s m^2 Pa) is the constant Richer & Hurmuzlu quote for air
    assert choked / (area * p_up) * math.sqrt(T_S) == pytest.approx(0.0404, abs=1e-4)


def test_subsonic_flow_is_saint_venant() -> None:
    # m = A p_u sqrt(2k/((k-1) R T) (Pr^(2/k) - Pr^((k+1)/k))) below the linear zone
    p_up, area = 5.0e5, 3.0e-6
    for pr in np.linspace(0.53, LINEAR_RATIO - 1e-6, 23):
        expected = area * p_up * math.sqrt(2.0 * K / ((K - 1.0) * R * T_S) * (pr ** (2.0 / K) - pr ** ((K + 1.0) / K)))
        assert orifice_mass_flow(p_up, pr * p_up, area, T_S, R, K) == pytest.approx(expected, rel=1e-10)


def test_no_flow_at_equal_pressures_or_zero_area() -> None:
    for p in (P_ATM, 3e5, 9e5):
        assert orifice_mass_flow(p, p, 5e-6, T_S, R, K) == 0.0
    assert orifice_mass_flow(6e5, P_ATM, 0.0, T_S, R, K) == 0.0


def test_flow_function_is_continuous_at_the_critical_ratio_and_the_linear_zone() -> None:
    pr_crit = critical_pressure_ratio(K)
    eps = 1e-9
    assert flow_function(pr_crit - eps, K) == 1.0
    assert flow_function(pr_crit + eps, K) == pytest.approx(1.0, abs=1e-6)
    assert flow_function(LINEAR_RATIO - eps, K) == pytest.approx(flow_function(LINEAR_RATIO + eps, K), abs=1e-6)
    assert flow_function(1.0 - eps, K) == pytest.approx(0.0, abs=1e-6)
    # monotone non-increasing over the whole range
    f = np.array([flow_function(pr, K) for pr in np.linspace(0.0, 1.0, 2001)])
    assert np.all(np.diff(f) <= 1e-15)


def test_flow_reverses_when_pressures_swap() -> None:
    for pa, pb in [(6e5, 1.2e5), (6e5, 4e5), (6e5, 5.97e5), (2e5, 1.9999e5)]:
        forward = orifice_mass_flow(pa, pb, 4e-6, T_S, R, K)
        assert forward > 0.0
        assert orifice_mass_flow(pb, pa, 4e-6, T_S, R, K) == -forward


# --- vane motor ---------------------------------------------------------------------------------
ANGLES = np.linspace(-7.0 * math.pi, 7.0 * math.pi, 4001)


def test_chamber_volumes_sum_to_a_constant() -> None:
    sums = np.array([sum(chamber_volumes(phi, *GEOM, WRIST.dead_volume_m3)) for phi in ANGLES])
    assert np.ptp(sums) < 1e-12 * sums[0]
    # the total is both dead volumes plus one pitch's swept volume
    swept = quad(lambda phi: swept_area(phi, *GEOM), -PITCH / 2, PITCH / 2, epsabs=0, epsrel=1e-12)[0]
    assert sums[0] == pytest.approx(2.0 * WRIST.dead_volume_m3 + swept, rel=1e-10)


def test_volumes_stay_between_dead_volume_and_full() -> None:
    for phi in ANGLES:
        v_a, v_b = chamber_volumes(phi, *GEOM, WRIST.dead_volume_m3)
        assert v_a >= WRIST.dead_volume_m3 * (1 - 1e-9) and v_b >= WRIST.dead_volume_m3 * (1 - 1e-9)


def test_swept_area_is_the_derivative_of_chamber_a() -> None:
    h = 1e-6
    for phi in np.linspace(-PITCH / 2 + 1e-3, PITCH / 2 - 1e-3, 51) + 3 * PITCH:
        v_plus = chamber_volumes(phi + h, *GEOM, 0.0)[0]
        v_minus = chamber_volumes(phi - h, *GEOM, 0.0)[0]
        assert swept_area(phi, *GEOM) == pytest.approx((v_plus - v_minus) / (2 * h), rel=1e-6)
        vb_plus = chamber_volumes(phi + h, *GEOM, 0.0)[1]
        vb_minus = chamber_volumes(phi - h, *GEOM, 0.0)[1]
        assert -swept_area(phi, *GEOM) == pytest.approx((vb_plus - vb_minus) / (2 * h), rel=1e-6)


def test_swept_area_is_the_vane_formula() -> None:
    # (L/2)(rho^2 - r^2), rho^2 = B^2 + 2 e B cos(phi) + e^2 cos(2 phi) (DESIGN, "Torque and volume must agree")
    b, r, length, _ = GEOM
    e = b - r
    for phi in np.linspace(-PITCH / 2, PITCH / 2 * 0.999, 17):
        rho2 = b * b + 2 * e * b * math.cos(phi) + e * e * math.cos(2 * phi)
        assert swept_area(phi, *GEOM) == pytest.approx(0.5 * length * (rho2 - r * r), rel=1e-12)


@pytest.mark.parametrize("p_a, p_b", [(6.0e5, 1.5e5), (2.0e5, 7.0e5)])
def test_vane_work_over_a_pitch_equals_pressure_work(p_a: float, p_b: float) -> None:
    lo, hi = -PITCH / 2 + 1e-12, PITCH / 2 - 1e-12
    work = quad(lambda phi: vane_torque(p_a, p_b, phi, *GEOM), lo, hi, epsabs=0, epsrel=1e-12)[0]
    v_lo, v_hi = chamber_volumes(lo, *GEOM, 0.0)[0], chamber_volumes(hi, *GEOM, 0.0)[0]
    assert work == pytest.approx((p_a - p_b) * (v_hi - v_lo), rel=1e-9)


def test_wrist_displacement_is_designs_1_03_cm3_per_rad() -> None:
    # DESIGN starting set: 1.03e-6 m^3/rad (6.45 cm^3/rev) for B, r, L = 11, 9, 25 mm
    assert displacement_per_rad(*GEOM) == pytest.approx(1.03e-6, rel=0.01)


# --- hose ---------------------------------------------------------------------------------------
HOSE = (WRIST.hose_length_m, WRIST.hose_diameter_m)


def _re_to_mass_flow(re: float) -> float:
    return re * math.pi * WRIST.hose_diameter_m * MU / 4.0


@pytest.mark.parametrize("reynolds", [50.0, 600.0, 1100.0, 1300.0, 2497.0, 8000.0, 30000.0])
@pytest.mark.parametrize("p_out", [1.2e5, 5.0e5])
def test_hose_mass_flow_inverts_the_pressure_drop(reynolds: float, p_out: float) -> None:
    m = _re_to_mass_flow(reynolds)
    t_mean = 280.0

    def residual(p_in: float) -> float:
        return p_in - p_out - hose_pressure_drop(m, 0.5 * (p_in + p_out), t_mean, *HOSE, R, MU)

    p_in = brentq(residual, p_out, p_out + 5e6, xtol=1e-9, rtol=1e-15)
    assert hose_mass_flow(p_in, p_out, t_mean, *HOSE, R, MU) == pytest.approx(m, rel=1e-8)
    assert hose_mass_flow(p_out, p_in, t_mean, *HOSE, R, MU) == pytest.approx(-m, rel=1e-8)


def test_hose_drop_is_darcy_weisbach() -> None:
    # dp = lambda (L/d) rho v^2 / 2 with v = m/(rho A), written out independently
    m, p_mean, t = _re_to_mass_flow(2497.0), 4e5, T_S
    rho = p_mean / (R * t)
    v = m / (rho * math.pi * WRIST.hose_diameter_m**2 / 4)
    lam = 0.316 * 2497.0**-0.25
    expected = lam * WRIST.hose_length_m / WRIST.hose_diameter_m * rho * v * v / 2
    assert hose_pressure_drop(m, p_mean, t, *HOSE, R, MU) == pytest.approx(expected, rel=1e-9)
    assert reynolds_number(m, WRIST.hose_diameter_m, MU) == pytest.approx(2497.0, rel=1e-12)
    assert hose_pressure_drop(0.0, p_mean, t, *HOSE, R, MU) == 0.0
    assert hose_mass_flow(p_mean, p_mean, t, *HOSE, R, MU) == 0.0


def test_friction_factor_is_continuous_and_blasius_at_the_papers_reynolds_number() -> None:
    assert friction_factor(2497.0) == pytest.approx(0.316 * 2497.0**-0.25, rel=1e-14)  # paper eq. 3, Re = 2497
    assert friction_factor(2497.0) == pytest.approx(0.0447, abs=1e-4)
    eps = 1e-7
    assert friction_factor(BLASIUS_LAMINAR_RE * (1 - eps)) == pytest.approx(
        friction_factor(BLASIUS_LAMINAR_RE * (1 + eps)), rel=1e-6
    )
    assert friction_factor(500.0) == pytest.approx(64.0 / 500.0, rel=1e-14)  # Hagen-Poiseuille
    assert pytest.approx(0.316 * BLASIUS_LAMINAR_RE**-0.25, rel=1e-12) == 64.0 / BLASIUS_LAMINAR_RE


# --- gas, reducer, valves, brake -----------------------------------------------------------------
def test_isentropic_temperature_is_eq_2() -> None:
    p_s, p_b = 101325.0 + 0.5e6, 2.0e5
    assert isentropic_temperature(p_b, p_s, T_S, 1.4) == pytest.approx(T_S * (p_b / p_s) ** (0.4 / 1.4), rel=1e-14)
    # expansion to the atmosphere from 0.5 MPa gauge: about -90 °C (DESIGN: -30 to -80 °C in the chamber)
    assert isentropic_temperature(P_ATM, p_s, T_S, 1.4) - 273.15 == pytest.approx(-97.0, abs=2.0)
    assert isentropic_temperature(p_b, p_s, T_S, 1.0) == T_S  # isothermal limit


def test_reducer_efficiency_sign_logic() -> None:
    i, ef, eb = 120.0, 0.7, 0.5
    assert reducer_output_torque(0.3, 1.0, i, ef, eb) == pytest.approx(ef * i * 0.3)  # motor drives
    assert reducer_output_torque(-0.3, -1.0, i, ef, eb) == pytest.approx(-ef * i * 0.3)
    assert reducer_output_torque(0.3, 0.0, i, ef, eb) == pytest.approx(ef * i * 0.3)  # at rest: forward
    assert reducer_output_torque(0.3, -1.0, i, ef, eb) == pytest.approx(i * 0.3 / eb)  # load drives the motor
    assert reducer_output_torque(-0.3, 1.0, i, ef, eb) == pytest.approx(-i * 0.3 / eb)
    # power balance when driving: out = eta in
    assert reducer_output_torque(0.3, 1.0, i, ef, eb) * 1.0 == pytest.approx(ef * 0.3 * i * 1.0)


def test_solenoid_switches_after_its_delay() -> None:
    dt, delay = 0.5e-3, 0.015
    state = (0.0, 0.0, 0.0)
    steps = 0
    while state[0] != 1.0:
        state = solenoid_step(*state, 1.0, delay, dt)
        steps += 1
        assert steps < 1000
    # the position returned is the one in effect over the step that starts at the call: the first
    # step with the valve switched starts exactly the delay after the command
    assert (steps - 1) * dt == pytest.approx(delay)
    # a new command restarts the delay; going back before it takes effect cancels it
    state = solenoid_step(*state, -1.0, delay, dt)
    for _ in range(10):
        state = solenoid_step(*state, -1.0, delay, dt)
    assert state[0] == 1.0
    for _ in range(100):
        state = solenoid_step(*state, 1.0, delay, dt)
    assert state == (1.0, 1.0, pytest.approx(state[2])) and state[0] == 1.0
    # zero delay: immediate
    assert solenoid_step(0.0, 0.0, 0.0, -1.0, 0.0, dt)[0] == -1.0


def test_valve_set_point_dead_time_delays_the_exponential_rise_exactly() -> None:
    """A set-point step at t0 reaches the proportional valve after the dead time d, then rises by
    its lag: P_v(t) = P (1 - exp(-(t - t0 - d)/tau)) (analytic); with d = 0 the row is unchanged."""
    from pneumatics import JointParams
    from pneumatics.joint import C_PV_SET_GAUGE_PA, N_COMMAND, S_PV, advance_discrete

    base = WRIST
    d, dt, target, t0 = 0.08, 1e-3, 4.0e5, 0.05
    supply = AIR.p_atm_pa + 6e5

    def trace(params: JointParams) -> np.ndarray:
        p = params_row(params)
        x = initial_state(AIR.p_atm_pa)
        cmd = np.zeros(N_COMMAND)
        out = []
        for k in range(400):
            cmd[C_PV_SET_GAUGE_PA] = target if k * dt >= t0 - 1e-9 else 0.0
            advance_discrete(x, cmd, supply, dt, p)
            out.append(x[S_PV])
        return np.array(out)

    t = (np.arange(400) + 1) * dt
    delayed = trace(base._replace(valve_set_dead_time_s=d))
    expected = np.where(t > t0 + d, target * (1.0 - np.exp(-(t - t0 - d) / base.valve_time_constant_s)), 0.0)
    assert np.max(np.abs(delayed - expected)) < target * dt / base.valve_time_constant_s  # within one step of the rise
    assert delayed[int(round((t0 + d) / dt)) - 2] == 0.0
    assert not np.array_equal(delayed, trace(base))
    # a set point changing every step (a controller's) is still followed: taken up at its latest
    # value once per delay (the change after a take-up starts the next delay), never staler
    x, pending, rem = 0.0, 0.0, 0.0
    taken = []
    for k in range(1000):
        x, pending, rem = dead_time_step(x, pending, rem, float(k), 0.02, 1e-3)
        taken.append(x)
    take_ups = np.flatnonzero(np.diff(taken)) + 1
    assert np.all(np.diff(take_ups) == 20 + 1)
    assert np.all(np.asarray(taken)[take_ups] == take_ups)  # the latest value at each take-up
    assert 1000 - 1 - (20 + 1) < x <= 1000 - 1


def test_lag_toward_is_the_exact_exponential() -> None:
    tau, dt, v = 0.1, 0.5e-3, 0.0
    for _ in range(600):
        v = lag_toward(v, 5e5, dt, tau)
    assert v == pytest.approx(5e5 * (1.0 - math.exp(-600 * dt / tau)), rel=1e-12)
    assert lag_toward(1.0, 3.0, dt, 0.0) == 3.0


def test_brake_releases_only_when_told_and_its_air_can_lift_the_springs() -> None:
    release = 3e5
    assert brake_target(1.0, 5e5, release, release) == 0.0
    assert brake_target(1.0, release, release, release) == 0.0
    assert brake_target(1.0, release - 1.0, release, release) == 1.0  # not enough air: springs hold
    assert brake_target(0.0, 8e5, release, release) == 1.0  # not told: springs hold
    assert brake_target(0.0, 0.0, release, release) == 1.0


def test_brake_lifts_linearly_across_its_band() -> None:
    # the springs' force is linear in their compression: between the preload (start) and full
    # release the lining presses with the springs' force less the air's
    start, full = 3.75e5, 4.75e5
    feeds = np.linspace(start, full, 11)
    targets = np.array([brake_target(1.0, f, start, full) for f in feeds])
    assert targets[0] == 1.0 and targets[-1] == 0.0
    assert np.allclose(targets, (full - feeds) / (full - start), rtol=0, atol=1e-12)
    assert brake_target(1.0, start - 1.0, start, full) == 1.0
    assert brake_target(0.0, full + 1e5, start, full) == 1.0


def test_brake_feed_is_the_supply_or_the_higher_motor_port() -> None:
    atm = 101_325.0
    assert brake_feed_gauge_pa(0.0, atm + 6e5, atm + 1e5, atm + 2e5, atm) == 6e5  # a line of its own
    assert brake_feed_gauge_pa(1.0, atm + 6e5, atm + 1e5, atm + 4e5, atm) == 4e5  # shuttle valve: port B
    assert brake_feed_gauge_pa(1.0, atm + 6e5, atm + 4.5e5, atm + 2e5, atm) == 4.5e5  # port A
    assert brake_feed_gauge_pa(1.0, atm + 6e5, atm, atm, atm) == 0.0  # motor not driven: no air


def test_brake_fed_by_the_motor_follows_the_hose_end_pressure() -> None:
    """The wrist's brake takes its air from the driven port at the arm: while the port still fills
    it stays engaged, and it lifts only as far as the motor-end pressure allows."""
    p = params_row(load_joint_params(assets.joint_param_path("wrist_pitch")))
    atm = p[P.GAS_P_ATM]
    x = initial_state(atm, brake_engaged=True)
    command = np.array([1.0, 5e5, 1.0])
    advance_brake(x, command, atm + 6e5, atm + 2e5, atm, atm + 2e5, atm, 1.0, p)  # 1 s at 0.2 MPa: under the start
    assert x[S_BRAKE] == 1.0
    start, full = p[P.BRAKE_START_PA], p[P.BRAKE_RELEASE_PA]
    assert p[P.BRAKE_FED_BY_MOTOR] == 1.0 and 2e5 < start < full <= 5e5  # inside the paper's 0.5 MPa
    advance_brake(
        x, command, atm + 6e5, atm + 0.5 * (start + full), atm, atm + 0.5 * (start + full), atm, 1.0, p
    )  # mid-band
    assert x[S_BRAKE] == pytest.approx(0.5, abs=1e-6)
    advance_brake(x, command, atm + 6e5, atm + full, atm, atm + full, atm, 1.0, p)
    assert x[S_BRAKE] == pytest.approx(0.0, abs=1e-6)


# --- reducer transmission: a torsional spring with backlash (pneumatics/reducer.py) --------------
def test_transmission_law_is_a_dead_zone_spring_that_never_pulls() -> None:
    k, c, half = 5.0e3, 2.0, 0.01
    assert stiffness(0.0, 1e-3) == pytest.approx(1e3, rel=1e-12)
    assert stiffness(0.02, 0.0) == CONTACT_STIFFNESS_NM_PER_RAD  # flanks with the gear's own stiffness
    assert stiffness(0.0, 1e-12) == MAX_STIFFNESS_NM_PER_RAD
    # without backlash: one elastic body, a linear spring-damper both ways
    assert transmitted_torque(0.003, -0.5, 0.0, k, c) == pytest.approx(k * 0.003 - c * 0.5, rel=1e-12)
    assert transmitted_torque(-0.003, 0.5, 0.0, k, c) == pytest.approx(-(k * 0.003 - c * 0.5), rel=1e-12)
    # inside the gap nothing passes, whatever the speed
    for twist in (-half, -0.5 * half, 0.0, 0.7 * half, half):
        assert transmitted_torque(twist, 3.0, half, k, c) == 0.0
    # on a flank: k times the twist past it, plus damping
    assert transmitted_torque(half + 0.002, 0.1, half, k, c) == pytest.approx(k * 0.002 + c * 0.1, rel=1e-12)
    assert transmitted_torque(-half - 0.002, -0.1, half, k, c) == pytest.approx(-(k * 0.002 + c * 0.1), rel=1e-12)
    # flanks parting fast: the damper cannot make touching flanks pull
    assert transmitted_torque(half + 1e-5, -10.0, half, k, c) == 0.0
    assert transmitted_torque(-half - 1e-5, 10.0, half, k, c) == 0.0


def _one_joint(
    params,
    seconds: float,
    command,
    supply_pa: float,
    y0: np.ndarray | None = None,
    inertia: float = 0.164,
    dt: float = 1e-3,
) -> np.ndarray:
    """The one-joint model (pneumatics.joint.single_joint_step, as the predictor and the gap
    replay run it) under commands held from t = command(t); the state at every step."""
    p = params_row(params)
    y = y0.copy() if y0 is not None else initial_rigid_state(0.0, P_ATM)
    x = initial_state(P_ATM, brake_engaged=True)
    n = int(round(seconds / dt))
    out = np.empty((n + 1, N_RIGID))
    out[0] = y
    for k in range(n):
        c = np.asarray(command(k * dt), dtype=float)
        advance_discrete(x, c, supply_pa, dt, p)
        single_joint_step(y, x, c, x[S_PV], supply_pa, 0.0, inertia, dt, p)
        out[k + 1] = y
    return out


RIG_J = 0.02  # kg·m^2, the wrist rig's load (assets/wrist_rig.xml); the rotor adds ratio^2 J_rotor
J_MOTOR = WRIST.ratio**2 * WRIST.rotor_inertia_kg_m2


def _stall_torque(y: np.ndarray, efficiency: float = 1.0) -> float:
    # the vane torque of the final pressures at the final motor angle, through the gear (eq. 6)
    phi = WRIST.ratio * y[R_QM]
    return efficiency * WRIST.ratio * vane_torque(y[R_PA_MOTOR], y[R_PB_MOTOR], phi, *GEOM)


def test_compliant_joint_held_by_its_brake_twists_by_torque_over_stiffness() -> None:
    """Brake engaged (100 N·m), valve fully open at 0.5 MPa: the motor winds the gear up until the
    spring carries the stall torque, twist = tau / k. With both efficiencies 1 the gear passes
    i M both ways; with the wrist's 0.7 / 0.5 the gear's own friction holds the motor anywhere in
    the band eta_f i M / k .. i M / (eta_b k)."""
    compliance = 1e-3
    supply = P_ATM + 5e5
    lossless = WRIST._replace(reducer_compliance_rad_per_nm=compliance, efficiency_forward=1.0, efficiency_backward=1.0)
    h = _one_joint(lossless, 3.0, lambda t: (1.0, 5e5, 0.0), supply, inertia=RIG_J + J_MOTOR)
    y = h[-1]
    tau = _stall_torque(y)
    print(f"\nstall torque {tau:.3f} N·m, twist {y[R_QM] - y[R_THETA]:.6f} rad, tau/k {tau * compliance:.6f} rad")
    assert 40.0 < tau < WRIST.brake_holding_nm  # a real load, and the brake holds it
    assert np.all(h[:, R_THETA] == 0.0)  # held: the joint never moved
    assert y[R_QM] - y[R_THETA] == pytest.approx(tau * compliance, rel=1e-4)
    # with the wrist's efficiencies
    lossy = WRIST._replace(reducer_compliance_rad_per_nm=compliance)
    y = _one_joint(lossy, 3.0, lambda t: (1.0, 5e5, 0.0), supply, inertia=RIG_J + J_MOTOR)[-1]
    twist = y[R_QM] - y[R_THETA]
    assert (
        WRIST.efficiency_forward * _stall_torque(y) * compliance * (1 - 1e-4)
        <= twist
        <= _stall_torque(y) / WRIST.efficiency_backward * compliance
    )
    assert y[R_OMEGA_M] == 0.0  # held by the gear's friction, not swinging


@pytest.mark.parametrize("compliance", [1e-3, 2e-4])
def test_two_mass_oscillation_has_the_analytic_frequency(compliance: float) -> None:
    """Released from a twist with friction, brake and air out of the way, motor and load swing
    against each other at w = sqrt(k (1/J_m + 1/J_j)) (damped: w sqrt(1 - zeta^2), zeta of the
    gear's damping on the reduced inertia J_m J_j / (J_m + J_j)), keeping their total momentum."""
    free = WRIST._replace(
        reducer_compliance_rad_per_nm=compliance,
        coulomb_nm=0.0,
        viscous_nm_s=0.0,
        brake_holding_nm=0.0,
        dead_volume_m3=1e-2,  # 10 l per port: the air's spring is 1e-5 of the gear's, its torque noise
    )
    k = 1.0 / compliance
    y0 = initial_rigid_state(0.0, P_ATM)
    y0[R_QM] = 0.01  # motor side 0.01 rad ahead
    h = _one_joint(free, 0.3, lambda t: (0.0, 0.0, 1.0), P_ATM, y0, inertia=RIG_J + J_MOTOR)
    twist = h[:, R_QM] - h[:, R_THETA]
    t = np.arange(len(h)) * 1e-3
    j_red = J_MOTOR * RIG_J / (J_MOTOR + RIG_J)
    zeta = damping(k, J_MOTOR) / (2.0 * math.sqrt(k * j_red))
    analytic = math.sqrt(k * (1.0 / J_MOTOR + 1.0 / RIG_J))
    # least squares of a damped cosine (zero crossings interpolated on the 1 ms grid are biased by
    # the decay's curvature: 0.6 % at 534 rad/s)
    (amplitude, decay, measured, _), _ = curve_fit(
        lambda t, a, s, w, ph: a * np.exp(-s * t) * np.cos(w * t + ph),
        t,
        twist,
        p0=[0.01, 0.1 * analytic, analytic, 0.0],
    )
    zeta_measured = decay / math.hypot(decay, measured)
    print(
        f"\ncompliance {compliance:g}: w measured {measured:.3f}, analytic {analytic:.3f} "
        f"(damped {analytic * math.sqrt(1 - zeta**2):.3f}) rad/s; "
        f"zeta {zeta_measured:.4f} vs {zeta:.4f}; {measured * t[-1] / (2 * math.pi):.1f} periods"
    )
    assert measured * t[-1] > 2 * math.pi * 10  # at least 10 periods
    assert measured == pytest.approx(analytic * math.sqrt(1.0 - zeta**2), rel=1e-3)
    assert zeta_measured == pytest.approx(zeta, rel=0.02)
    assert 0.05 < zeta < 0.1  # the gear's damping on the rig's two-mass mode (pneumatics/reducer.py)
    momentum = J_MOTOR * h[:, R_OMEGA_M] + RIG_J * h[:, R_OMEGA]
    swing = RIG_J * np.abs(h[:, R_OMEGA]).max()
    assert np.abs(momentum).max() < 0.01 * swing


def test_reversal_through_backlash_loses_the_gap() -> None:
    """Forward, then straight back, both with the valve fully open at 0.6 MPa: with backlash b the
    joint trails the motor by b/2 (plus the flanks' elastic twist) either way, and the reversed
    move loses b of joint travel against the rigid reducer. The flanks are made stiff (1e-5
    rad/N·m: the forward stall torque, 55 N·m, twists them 0.55 mrad) so that b is what remains;
    the tolerance, b/10 = 2 mrad, covers that twist on both flanks and the motor's free run
    across the gap, which it makes without the joint's load (measured: the loss is 0.96 b)."""
    gap = 0.02
    supply = P_ATM + 6e5
    t_rev, t_hold = 0.5, 1.3

    def command(t: float):
        if t < 0.1:
            return (0.0, 0.0, 0.0)
        return (1.0 if t < t_rev else -1.0 if t < t_hold else 0.0, 6e5, 1.0 if t < t_hold else 0.0)

    y0 = initial_rigid_state(0.0, P_ATM)
    y0[R_QM] = 0.5 * gap  # motor on the forward flank
    rigid = _one_joint(WRIST, 1.6, command, supply, inertia=RIG_J + J_MOTOR)
    lash = _one_joint(
        WRIST._replace(reducer_backlash_rad=gap, reducer_compliance_rad_per_nm=1e-5),
        1.6,
        command,
        supply,
        y0,
        inertia=RIG_J + J_MOTOR,
    )
    k_rev, k_hold = round(t_rev / 1e-3), round(t_hold / 1e-3)
    twist = lash[:, R_QM] - lash[:, R_THETA]
    stall = (
        WRIST.ratio * 6e5 * swept_area(0.0, *GEOM) / WRIST.efficiency_backward
    )  # the most the gear ever passes (back-driven)
    elastic = stall * 1e-5
    forward, back = twist[k_rev - 200 : k_rev], twist[k_hold - 300 : k_hold]
    assert (
        rigid[k_rev, R_THETA] > 0.3 and rigid[k_rev, R_THETA] - rigid[k_hold, R_THETA] > 0.5
    )  # really moved, both ways
    assert np.all(forward >= 0.5 * gap) and np.all(forward <= 0.5 * gap + elastic)
    assert np.all(back <= -0.5 * gap) and np.all(back >= -0.5 * gap - elastic)
    loss = (rigid[k_rev, R_THETA] - rigid[k_hold, R_THETA]) - (lash[k_rev, R_THETA] - lash[k_hold, R_THETA])
    print(
        f"\nreversal: rigid travel {rigid[k_rev, R_THETA] - rigid[k_hold, R_THETA]:.4f} rad, "
        f"with backlash {gap}: loss {loss:.5f} rad ({loss / gap:.3f} b); "
        f"twist forward {forward.min():.5f}..{forward.max():.5f}, back {back.min():.5f}..{back.max():.5f}"
    )
    assert loss == pytest.approx(gap, abs=0.1 * gap)


def test_supply_droop_follows_the_air_the_motor_draws():
    # droop = coefficient x the air the open inlet passes, from what the proportional valve delivers
    # into the supplied port's node: the most for an empty port (choked flow, written out here from
    # the gas constants), less as the port fills, none for a stalled motor whose port is up to the
    # supply or above it, none with the valve shut
    p = params_row(WRIST._replace(supply_droop_pa_s_per_kg=5.0e6))
    atm = 101_325.0
    supply = atm + 0.5e6
    full = 1.0 / WRIST.k_u_per_pa  # set point of full opening (above the supply: the valve passes it)
    area = WRIST.inlet_area_m2 * WRIST.conductance_scale
    k, r, t = AIR.k, AIR.r_j_per_kg_k, AIR.t_supply_k
    choked = area * supply * math.sqrt(k * (2.0 / (k + 1.0)) ** ((k + 1.0) / (k - 1.0))) / math.sqrt(r * t)
    empty = effective_supply(supply, full, 1.0, +1.0, atm, p)
    assert supply - empty == pytest.approx(5.0e6 * choked, rel=1e-9)
    assert 20e3 < supply - empty < 40e3  # ~0.5 MPa into an empty port: tens of kPa at 5e6 Pa·s/kg
    droops = [supply - effective_supply(supply, full, 1.0, -1.0, node, p) for node in (atm, 3.5e5, 5.0e5, 5.9e5)]
    assert all(a > b > 0.0 for a, b in zip(droops, droops[1:], strict=False)), droops
    assert effective_supply(supply, full, 1.0, +1.0, supply, p) == supply  # stalled at the supply: no draw
    assert effective_supply(supply, full, 1.0, +1.0, supply + 0.5e5, p) == supply  # pushed back: no rise
    assert effective_supply(supply, full, 1.0, 0.0, atm, p) == supply  # valve shut
    # a set point under the supply: the port fills to it and draws nothing more
    assert effective_supply(supply, 3.0e5, 0.6, +1.0, atm + 3.0e5, p) == supply


def test_a_stalled_motors_least_torque_is_at_half_a_vane_pitch():
    # (L/2)(rho^2 - r^2) with rho^2 = B^2 + 2eB cos(phi) + e^2 cos(2 phi) is least at |phi| = pi/n
    # (DESIGN's vane torque, written out here); the breakaway floor (control) takes this, not the mean
    b, r, length, n = GEOM
    e = b - r
    phi = math.pi / n
    analytic = 0.5 * length * (b**2 + 2 * e * b * math.cos(phi) + e**2 * math.cos(2 * phi) - r**2)
    least = least_displacement_per_rad(*GEOM)
    assert least == pytest.approx(analytic, rel=1e-9)
    grid = [swept_area(x, *GEOM) for x in np.linspace(-phi + 1e-9, phi - 1e-9, 801)]
    assert least <= min(grid) * (1 + 1e-6) and least / displacement_per_rad(*GEOM) == pytest.approx(0.866, abs=0.005)
