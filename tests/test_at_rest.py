"""The at-rest shortcuts (pneumatics/joint.py `at_rest`, `held_motor_side`; control/predictor.py
`predictor_at_rest`): a still joint whose valves are shut and whose air is within REST_BAND_PA of
atmosphere has its air (and a compliant gear's motor side) held instead of integrated.

Layers (STYLE rule 8):
- the kernel (the real compiled functions the plant and the predictor call): the shortcut is taken
  inside its conditions and not one step outside any of them (air just outside the band, a joint
  turning at the stick speed, a valve open, a gear's motor turning or wound past the bound);
- independent solver: the air of a still, vented joint started anywhere in the band, integrated by
  scipy's LSODA on the kernel's rates, stays in the band, and its torque within `rest_torque_bound`,
  as does the held air's; the bound is the largest torque air in the band gives, found by scanning;
- the plant: a compliant wrist that moved and stopped reaches the held state, and holds its gear's
  torque within the bound.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import assets
from control.predictor import predictor_at_rest
from pneumatics import AIR, JointParams, load_joint_params, params_row
from pneumatics import joint as J
from pneumatics import params as P
from pneumatics.as_built import load_as_built
from twin.plant import Plant
from wrist_rig import commanded_run


def _as_built(joint: str) -> JointParams:
    return load_as_built(load_joint_params(assets.joint_param_path(joint)), assets.as_built_path(joint))


P_ATM = AIR.p_atm_pa
T_WALL = AIR.t_supply_k
DT = 0.5e-3  # the plant's physics step (assets/arm.xml)
NODES_P = [J.S_PA_VALVE, J.S_PA_MOTOR, J.S_PB_VALVE, J.S_PB_MOTOR]
# the as-built shoulder: the arm's largest torque per pascal, and a vane leak coupling its chambers
SHOULDER = params_row(_as_built("shoulder_pitch"))
CREEP_RAD_S = 1e-5  # a joint creeping under its brake in MuJoCo (measured on the cleaning scene: 0.8-1.8e-5)


def _still_shut_joint(offsets_pa: tuple[float, float, float, float]) -> np.ndarray:
    x = J.initial_state(P_ATM, t_k=T_WALL)
    x[NODES_P] = P_ATM + np.asarray(offsets_pa)
    return x


@pytest.mark.parametrize(
    "case, offsets_pa, omega, direction, at_rest",
    [
        ("in the band", (0.9, -0.9, 0.5, 0.9), 0.0, 0.0, True),
        ("creeping", (0.9, 0.9, 0.9, 0.9), CREEP_RAD_S, 0.0, True),
        ("a node just outside the band", (0.9, 1.1, 0.0, 0.0), 0.0, 0.0, False),
        ("turning at the stick speed", (0.5, 0.5, 0.5, 0.5), SHOULDER[P.STICK_SPEED], 0.0, False),
        ("its valve open", (0.5, 0.5, 0.5, 0.5), 0.0, 1.0, False),
    ],
)
def test_the_plants_air_is_held_only_inside_the_rest_conditions(case, offsets_pa, omega, direction, at_rest) -> None:
    """The plant's rigid-joint air step (`advance_air_pair`) leaves the air as it is exactly when the
    joint is at rest, and integrates it otherwise: its pressures move (a node outside the band drains,
    a turning joint pumps, an open valve fills)."""
    x = _still_shut_joint(tuple(J.REST_BAND_PA * f for f in offsets_pa))  # offsets in bands
    x[J.S_DIR] = direction
    before = x.copy()
    J.advance_air_pair(x, 0.1, omega, 0.0, P_ATM + 0.6e6, DT, SHOULDER)
    assert J.at_rest(before, omega, SHOULDER) == at_rest, case
    held = np.array_equal(x[NODES_P], before[NODES_P])
    assert held == at_rest, case


def test_the_rest_torque_bound_is_the_largest_torque_air_in_the_band_gives() -> None:
    """`rest_torque_bound` against a scan of `joint_torque` over a vane pitch, both turning
    directions, the motor nodes at the band's edges: never above it, and within 1 % of it."""
    for p in (SHOULDER, params_row(_as_built("wrist_pitch"))):
        band = J.REST_BAND_PA
        phis = np.linspace(-math.pi / p[P.N_VANES], math.pi / p[P.N_VANES], 2001)
        torques = [abs(J.joint_torque(P_ATM + band, P_ATM - band, phi, w, p)) for phi in phis for w in (-1.0, 1.0)]
        bound = J.rest_torque_bound(p)
        print(f"\nlargest torque in the band {max(torques):.3e} N·m, bound {bound:.3e} N·m")
        assert max(torques) <= bound * (1.0 + 1e-9)  # the pressures' difference to round-off
        assert max(torques) > 0.99 * bound


@pytest.mark.parametrize("offsets_pa", [(1.0, 1.0, -1.0, -1.0), (0.0, 1.0, 0.0, -1.0), (-1.0, 1.0, 1.0, -1.0)])
def test_integrated_air_started_in_the_band_stays_there(offsets_pa) -> None:
    """What the shortcut leaves out: the air of a still, vented shoulder, started at the band's edges,
    integrated by LSODA on the kernel's rates (`air_rates`) for 5 s (ten of its slowest time
    constants). It stays in the band and its torque within `rest_torque_bound`, as the held air's
    does: so the two torques differ by at most twice the bound. (A joint creeping below the stick
    speed pumps its air, which `at_rest` has always left out: at 1e-5 rad/s the shoulder's settles
    0.16 Pa off atmosphere, docs/tick_loop.md.)"""
    p = SHOULDER
    ratio = p[P.RATIO]
    omega = 0.0

    def rates(t, y):
        a = J.AirState(*y, T_WALL, T_WALL, T_WALL, T_WALL)
        r = J.air_rates(a, ratio * (0.1 + omega * t), ratio * omega, 0.0, 0.0, P_ATM + 0.6e6, p)
        return [r.dpa_valve, r.dpa_motor, r.dpb_valve, r.dpb_motor]

    start = P_ATM + J.REST_BAND_PA * np.asarray(offsets_pa)  # offsets in bands
    sol = solve_ivp(rates, (0.0, 5.0), start, method="LSODA", rtol=1e-12, atol=1e-10)
    assert sol.success
    offsets = sol.y - P_ATM
    torque = [
        abs(J.joint_torque(a, b, ratio * (0.1 + omega * t), omega, p))
        for t, a, b in zip(sol.t, sol.y[1], sol.y[3], strict=True)
    ]
    print(f"\nlargest offset {np.abs(offsets).max():.4f} Pa, at the end {np.abs(offsets[:, -1]).max():.2e} Pa")
    assert np.abs(offsets).max() <= J.REST_BAND_PA * (1.0 + 1e-9)
    assert max(torque) <= J.rest_torque_bound(p)


def test_the_predictor_holds_a_joint_only_inside_its_rest_conditions() -> None:
    """`predictor_at_rest` on the one-joint state: the air in the band with the brake on and
    commanded on, the joint held; not with a node outside the band or the joint moving."""
    p = params_row(load_joint_params(assets.joint_param_path("shoulder_pitch")))
    x = J.initial_state(P_ATM, t_k=T_WALL)
    y = J.initial_rigid_state(0.1, P_ATM, T_WALL)
    command = np.zeros(J.N_COMMAND)
    y[J.R_PA_MOTOR] = P_ATM + 0.9 * J.REST_BAND_PA
    assert predictor_at_rest(y, x, command, p)
    y[J.R_PB_VALVE] = P_ATM - 1.1 * J.REST_BAND_PA
    assert not predictor_at_rest(y, x, command, p)
    y[J.R_PB_VALVE] = P_ATM
    y[J.R_OMEGA] = 1e-9
    assert not predictor_at_rest(y, x, command, p)


def _compliant_wrist_plant() -> Plant:
    params = commanded_run.wrist_params()._replace(reducer_compliance_rad_per_nm=2.9e-4, reducer_backlash_rad=2.9e-4)
    plant = Plant(assets.WRIST_RIG_XML, joint_params={"wrist_pitch": params})
    plant.set_supply(P_ATM + 0.6e6)
    return plant


def test_a_compliant_wrist_that_stopped_is_held_and_only_within_the_bound() -> None:
    """The rig with the as-built wrist's gear (compliance and backlash 2.9e-4): turned for 0.3 s,
    then its valve shut and its brake applied for 4 s. It reaches the held state (`held_motor_side`)
    with its gear's torque within the bound, and the held state is left where it must be: the motor
    turning, the joint wound past the bound, a valve open."""
    plant = _compliant_wrist_plant()
    plant.command("wrist_pitch", +1, 0.5e6, True)
    plant.step(600)
    plant.command("wrist_pitch", 0, 0.0, False)
    plant.step(8000)
    x = plant.air[0].copy()
    p = plant.params[0]
    theta, omega = plant.drive_angles()[0], plant.drive_speeds()[0]
    held = J.held_motor_side(x, theta, omega, p)
    print(f"\nheld {held.at_rest}, gear torque {held.torque:.2e} N·m, bound {J.rest_torque_bound(p):.2e} N·m")
    assert held.at_rest
    assert abs(held.torque) <= J.rest_torque_bound(p)
    assert abs(plant.joint_torques()[0]) <= J.rest_torque_bound(p)
    turning = x.copy()
    turning[J.S_OMEGA_M] = 1e-9
    assert not J.held_motor_side(turning, theta, omega, p).at_rest
    wound = x.copy()
    wound[J.S_QM] = theta + 0.5 * p[P.BACKLASH] + 2.0 * J.rest_torque_bound(p) * p[P.COMPLIANCE]
    assert not J.held_motor_side(wound, theta, 0.0, p).at_rest
    open_valve = x.copy()
    open_valve[J.S_DIR] = 1.0
    assert not J.held_motor_side(open_valve, theta, omega, p).at_rest
