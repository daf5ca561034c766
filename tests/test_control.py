"""Tests of control/: the predictor-feedback controller (paper Sec. IV) against the real Plant as "reality".

Reality used for the paper's experiments (documented choice): the plant with the predictor's own
model (the paper's chamber law, `paper_model`, and the hose loss on) and a proportional valve that
responds in 60 ms instead of the catalogue's 0.1 s (paper Sec. IV) - an effect the predictor's
configuration lacks. The predictor reads the valve's pressure sensor, so the closed loop sees the
faster valve; the open loop's stopwatch does not. What the plant's best physics (the energy balance
of the joint files) and the as-built arm do to the loop: tests/test_as_built.py.
"""

from __future__ import annotations

import math
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import assets
from control import (
    ArmController,
    ArmModel,
    MotionRefused,
    closed_vs_open_loop,
    minimum_rotation_limit,
    predict_step,
    random_supply_moves,
    run_move,
    run_until_done,
)
from pneumatics import load_joint_params, paper_model
from twin.plant import Plant, Sensors

ATM = 101_325.0
NOMINAL = paper_model(load_joint_params(assets.joint_param_path("wrist_pitch")))  # the predictor's model
REALITY = NOMINAL._replace(hose_loss=1.0, valve_time_constant_s=0.06)


def rig_plant(params=REALITY) -> Plant:
    p = Plant(assets.WRIST_RIG_XML, {"wrist_pitch": params})
    p.set_supply(ATM + 0.5e6)
    return p


def home_drive_angles(plant: Plant) -> dict[str, float]:
    return dict(zip(plant.joints, plant.drive_angles(), strict=True))


# -- the arm model: Pinocchio's load torque per drive equals MuJoCo's -------------------------
def test_drive_load_torque_equals_mujoco_bias_through_tendon_jacobian():
    arm = ArmModel(assets.ARM_XML)
    m = mujoco.MjModel.from_xml_path(str(assets.ARM_XML))
    d = mujoco.MjData(m)
    tids = [m.tendon(assets.drive_tendon(j)).id for j in arm.joints]
    rng = np.random.default_rng(1)
    for _ in range(5):
        for j in assets.JOINTS:
            lo, hi = m.joint(j).range
            d.joint(j).qpos[0] = rng.uniform(lo, hi)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        ten_j = np.zeros((m.ntendon, m.nv))
        mujoco.mju_sparse2dense(ten_j, d.ten_J, m.ten_J_rownnz, m.ten_J_rowadr, m.ten_J_colind)
        # qfrc_bias - qfrc_spring = J_tendon^T f  ->  f, the load each drive holds (gravity and the
        # wrist's counterbalance spring, MuJoCo's own; on the driven joints' dofs: the brush head's
        # spring slide is undriven, at its stop, and locked in the controller's model)
        dofs = [m.joint(j).dofadr[0] for j in assets.JOINTS]
        assert np.any(d.qfrc_spring[dofs] != 0.0)  # the counterbalance is in the comparison
        f_mujoco = np.linalg.solve(ten_j[tids][:, dofs].T, d.qfrc_bias[dofs] - d.qfrc_spring[dofs])
        drive = d.ten_length[tids]
        np.testing.assert_allclose(arm.load_torques(drive), f_mujoco, atol=1e-9)
        g = {j: d.qfrc_bias[m.joint(j).dofadr[0]] - d.qfrc_spring[m.joint(j).dofadr[0]] for j in assets.JOINTS}
        f = dict(zip(arm.joints, arm.load_torques(drive), strict=True))
        assert f["elbow_pitch"] == pytest.approx(g["elbow_pitch"], abs=1e-9)  # parallelogram
        assert f["shoulder_pitch"] == pytest.approx(g["shoulder_pitch"] - g["elbow_pitch"], abs=1e-9)


def test_shoulder_load_depends_on_the_shoulder_angle_alone_and_falls_as_it_rises():
    """Why a shoulder prediction error grows move by move (insulator_cleaning: +3.5 deg after the
    brush press, +25 deg at t = 51 s) and why elbow/wrist errors cannot feed it. Through the
    parallelogram the shoulder drive's gravity load is A cos(shoulder) whatever the elbow and wrist
    do, so the predictor's load error is exactly -A sin(theta) x (its own angle error), about
    3 N·m per degree at 20 kg: negative slope from 0 to 180 deg, so an error makes the predicted
    load wrong in the direction that makes the next move's error larger."""
    arm = ArmModel(assets.ARM_XML, payload_kg=20.0)
    i = arm.joints.index("shoulder_pitch")
    rng = np.random.default_rng(2)
    for shoulder in np.radians([35.0, 55.0, 75.0, 95.0]):
        loads = []
        for _ in range(4):
            drive = np.radians(rng.uniform(-90.0, 90.0, len(arm.joints)))
            drive[i] = shoulder
            loads.append(arm.load_torques(drive)[i])
        assert np.ptp(loads) == pytest.approx(0.0, abs=1e-9)  # elbow, wrist, base, roll: no effect
        h = 1e-6
        up, down = drive.copy(), drive.copy()
        up[i] += h
        down[i] -= h
        slope = (arm.load_torques(up)[i] - arm.load_torques(down)[i]) / (2 * h)
        a = arm.load_torques(np.where(np.arange(len(drive)) == i, 0.0, drive))[i]  # A: the load horizontal
        assert slope == pytest.approx(-a * math.sin(shoulder), rel=1e-6)
        assert slope < -100.0  # N·m/rad: > 1.7 N·m of load error per degree of angle error


def test_wrist_rig_has_no_gravity_load():
    arm = ArmModel(assets.WRIST_RIG_XML)
    assert arm.joints == ("wrist_pitch",)
    assert arm.load_torques(np.array([0.7]))[0] == pytest.approx(0.0, abs=1e-12)
    assert arm.drive_inertias(np.zeros(1))[0] == pytest.approx(0.02)  # rig_load inertial


# -- sensorless by construction -------------------------------------------------------------
def test_control_imports_neither_mujoco_nor_twin():
    code = (
        "import sys, control; bad = [m for m in sys.modules if m == 'mujoco' or m.startswith('mujoco.') "
        "or m == 'twin' or m.startswith('twin.')]; print(bad)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_controller_runs_on_sensor_records_alone_and_ignores_the_truth():
    """Two plants whose true joints differ (one far more friction) but whose sensor streams are
    replaced by the same record: the controller's commands depend only on what it is handed."""
    plant = rig_plant()
    c1 = ArmController({"wrist_pitch": 0.0}, assets.WRIST_RIG_XML)
    c2 = ArmController({"wrist_pitch": 0.0}, assets.WRIST_RIG_XML)
    c1.set_targets({"wrist_pitch": math.radians(40)})
    c2.set_targets({"wrist_pitch": math.radians(40)})
    other = rig_plant(NOMINAL._replace(coulomb_nm=40.0))  # a different truth, never seen by c2
    for _ in range(800):
        s = plant.sensors()
        record = Sensors(s.time_s, s.supply_pa, s.valve_gauge_pa.copy())  # a copy: no way back to the plant
        cmd1 = c1.tick(record).copy()
        cmd2 = c2.tick(Sensors(record.time_s, record.supply_pa, record.valve_gauge_pa.copy())).copy()
        np.testing.assert_array_equal(cmd1, cmd2)
        plant.commands[:] = cmd1
        other.commands[:] = cmd2
        plant.step(2)
        other.step(2)
    assert abs(other.drive_angles()[0] - plant.drive_angles()[0]) > math.radians(5)  # the truths differ
    assert not any(isinstance(v, Plant) for v in vars(c1).values())


# -- refusals --------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "target, words",
    [
        ({"wrist_pitch": math.radians(120.0)}, ["wrist_pitch", "120.00", "-90.00..90.00"]),
        ({"elbow_pitch": math.nan}, ["elbow_pitch", "nan", "finite"]),
        ({"wrist_pitch": None}, None),
    ],
)
def test_bad_targets_are_refused_and_the_arm_stays_braked(target, words):
    plant = Plant(assets.SCENE_XML)
    c = ArmController(home_drive_angles(plant))
    if words is None:  # minimum rotation: 10 deg from where the wrist is
        target = {"wrist_pitch": plant.drive_angles()[3] + math.radians(10.0)}
        words = ["wrist_pitch", "10.00", "20.0", "jog"]
    with pytest.raises(MotionRefused) as e:
        c.set_targets(target)
    assert isinstance(e.value, ValueError)
    for w in words:
        assert w in str(e.value), str(e.value)
    cmd = c.tick(plant.sensors())
    assert (cmd == 0.0).all()  # valves shut, no brake release air
    assert c.done and c.events and "refused" in c.events[-1]


def test_supply_loss_during_a_move_brakes_everything():
    plant = rig_plant()
    c = ArmController({"wrist_pitch": 0.0}, assets.WRIST_RIG_XML)
    c.set_targets({"wrist_pitch": math.radians(60)})
    for k in range(400):
        if k == 200:
            plant.set_supply(ATM + 0.1e6)  # below the brake's 0.3 MPa release pressure
        plant.commands[:] = c.tick(plant.sensors())
        plant.step(2)
    assert c.faulted and "brake release" in c.events[-1]
    assert (plant.commands == 0.0).all()


# -- the paper's experiments on the wrist rig ------------------------------------------------
def test_closed_loop_beats_open_loop_20_to_90_deg():
    """Paper Fig. 23: closed 1.60-2.02 deg vs open 4.04-7.18 deg at 0.5 MPa. Up to 80 deg: 90 deg is
    the rig's end stop (assets/wrist_rig.xml), where an open loop that overshoots ends on the stop,
    placed by the wall, not by its timing (0.0002 deg off on this rig)."""
    result = closed_vs_open_loop(rig_plant, angles_deg=(20, 40, 60, 80), predictor_params=NOMINAL)
    for angle, (closed, opened, _) in result.items():
        assert closed < opened, (angle, closed, opened)
        assert closed < 2.5, (angle, closed)


@pytest.mark.parametrize("stop_deg, supply_gauge_pa", [(90.0, 0.5e6), (90.0, 0.8e6), (-90.0, 0.8e6)])
def test_a_prediction_stops_at_the_joint_s_end_stop_as_the_joint_does(stop_deg, supply_gauge_pa):
    """An open-loop move to one of the rig's +-90 deg end stops, the predictor's own model as
    reality: the joint coasts into the stop and rests on it (MuJoCo's stiff joint limit,
    assets/wrist_rig.xml), and the prediction, the same one-joint model, stops there too
    (`pneumatics.joint.at_the_stops` at the MJCF's range, `ArmModel.drive_stops`). Without its
    stop it ran on 0.40 and 0.50 deg past +90 deg at 0.5 and 0.8 MPa."""
    true, predicted = run_move(stop_deg, "open_loop", rig_plant(NOMINAL), NOMINAL, supply_gauge_pa)
    assert true == pytest.approx(stop_deg, abs=0.01)
    assert predicted == pytest.approx(true, abs=0.05)


def test_the_elbow_s_drive_has_no_stop_of_its_own_and_the_others_have_their_joint_s_range():
    """The elbow's drive angle is shoulder + elbow (the parallelogram's tendon): where it stops
    depends on the shoulder, so its drive has no stop; every other drive is its joint alone."""
    arm = ArmModel()
    stops = arm.drive_stops()
    for i, j in enumerate(arm.joints):
        if j == "elbow_pitch":
            assert stops[i].tolist() == [-math.inf, math.inf]
        else:
            assert stops[i].tolist() == [arm.joint_lower[i], arm.joint_upper[i]]
            assert np.all(np.isfinite(stops[i]))


def test_a_real_brake_stiffer_than_predicted_does_not_steer_the_closed_loop():
    """The wrist's brake is fed by the motor's port; the loop floors its set point a margin above the
    predicted brake's full release, so a real brake whose spring is 0.1 bar stiffer than predicted
    leaves the 20 and 90 deg moves at 0.5 MPa within the paper's ~2 deg (measured -1.5 and -0.6 deg;
    with the floor at the predicted full release itself, -6.2 and -7.3 deg)."""
    stiffer = REALITY._replace(brake_release_gauge_pa=NOMINAL.brake_release_gauge_pa + 0.1e5)
    for angle in (20.0, 90.0):
        true, _ = run_move(angle, "closed_loop", rig_plant(stiffer), NOMINAL, 0.5e6)
        assert abs(true - angle) < 2.0, (angle, true)


def test_random_supply_keeps_the_pose_error_small():
    """Paper Fig. 18-19 (max 4.33 deg over 30 s): moves 0 -> 45 -> 0 -> -45 -> 0 deg under a supply
    jumping at random every 0.5 s (mean 0.6 MPa, variance 5e9 Pa^2); shortened to ~10 s."""
    errors, t = random_supply_moves(rig_plant, NOMINAL, seed=7)
    assert t > 4.0
    assert max(errors) < 4.33, errors


def test_minimum_rotation_limit_exists():
    """Paper Fig. 21: below ~20 deg the loop loses its ability to adjust. The twin's limit lies
    between a few degrees and 40 deg, and small moves below it really fail."""
    limit = minimum_rotation_limit(rig_plant, predictor_params=NOMINAL, angles_deg=(1, 2, 3, 4, 8, 16, 24, 32, 40))
    # measured: 2 deg (1 deg stops at 0.81 deg); 4 deg with Heun's air integrator (3 deg ended at
    # 3.31 deg, just outside its 10 % band; 3.29 since); 8 deg while the loop floored its set point at the brake's
    # full release, where every approach throttled into the brake's drag (issue 14's brake margin),
    # 16 while the predictor's braked stops crept (before issue 12). The paper's ~20 deg is a
    # comparison for the as-built reality, not for this self-check
    assert 1 < limit <= 40, limit


# -- the arm: a short multi-joint motion and determinism -----------------------------------------
def run_arm(sequence: str) -> tuple[np.ndarray, np.ndarray, ArmController]:
    plant = Plant(assets.SCENE_XML)
    start = plant.drive_angles()
    c = ArmController(home_drive_angles(plant))
    target = {"base_yaw": math.radians(25.0), "wrist_pitch": start[3] - math.radians(25.0)}
    c.set_targets([target], sequence=sequence)
    run_until_done(c, plant, ATM + 0.6e6, max_s=8.0)
    return plant.drive_angles(), np.array([target.get(j, a) for j, a in zip(plant.joints, start, strict=True)]), c


def test_arm_moves_joints_one_after_another_and_is_deterministic():
    final, target, c = run_arm("one_after_another")
    assert c.done and not c.faulted, c.events
    err = np.degrees(np.abs(final - target))
    assert err.max() < 3.0, err
    arrivals = [e for e in c.events if "predicted" in e]
    assert [a.split()[4] for a in arrivals] == ["base_yaw", "wrist_pitch"]
    final2, _, c2 = run_arm("one_after_another")
    np.testing.assert_array_equal(final, final2)
    assert c.events == c2.events


def test_a_move_that_times_out_faults_and_the_prediction_coasts_on_with_the_valves_shut():
    # the fault shuts everything on the tick the move times out, then the predictor advances over
    # that tick with zero commands and the load Pinocchio gives at the predicted angles; checked
    # against predict_step called here
    plant = Plant(assets.SCENE_XML)
    plant.set_supply(ATM + 0.6e6)
    c = ArmController(home_drive_angles(plant), move_timeout_s=0.05)
    c.set_targets({"elbow_pitch": math.radians(60.0)})
    for _ in range(100):
        y, x = c.y.copy(), c.x.copy()
        sensors = plant.sensors()
        timing_out = bool((c.mode != 0).any()) and bool(((c.elapsed + c.dt) > c.timeout)[c.mode != 0].any())
        plant.commands[:] = c.tick(sensors)
        if timing_out:
            break
        plant.step(2)
    assert timing_out and c.faulted and "did not reach" in c.events[-1], c.events
    assert not c.commands.any() and not (c.mode != 0).any()
    load = c.arm.load_torques(y[:, 0])
    predict_step(
        y, x, np.zeros_like(c.commands), sensors.valve_gauge_pa, sensors.supply_pa, load, c.inertia, c.params, c.dt
    )
    np.testing.assert_array_equal(c.load, load)
    np.testing.assert_array_equal(c.y, y)
    np.testing.assert_array_equal(c.x, x)
