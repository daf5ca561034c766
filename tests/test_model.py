"""Tests of the arm's MJCF (assets/arm.xml) and its scene (assets/scene.xml).

Layers: compile and run without warnings, explicit inertials, reach (paper: 1500 mm high,
1100 mm out), the parallelogram's drive tendon, the 20 kg payload, Pinocchio against MuJoCo
gravity at rest (shared/DESIGN.md, Rule 3), the overview camera and reaching the insulator string.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

import assets
from control.arm_model import ArmModel
from control.pid import DEFAULT_GAINS
from pneumatics import load_joint_params
from pneumatics.motor import least_displacement_per_rad

ASSETS = Path(__file__).resolve().parents[1] / "assets"
ARM_XML = ASSETS / "arm.xml"
SCENE_XML = ASSETS / "scene.xml"

JOINTS = ("base_yaw", "shoulder_pitch", "elbow_pitch", "wrist_pitch", "tool_roll")
UNDRIVEN = ("brush_stroke",)  # the brush head's spring slide: no motor, the controller's model locks it
ARM_BODIES = ("base", "turret", "upper_arm", "forearm", "wrist", "tool", "brush", "brush_head", "payload")
PAYLOAD_KG = 20.0  # paper: maximum payload
DISC_RADIUS_M = 0.255 / 2  # U70BL-like disc, 255 mm diameter
DISC_SPACING_M = 0.146  # U70BL-like unit spacing


@pytest.fixture(scope="module")
def arm() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(ARM_XML))


@pytest.fixture(scope="module")
def scene() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(SCENE_XML))


def set_q(m: mujoco.MjModel, d: mujoco.MjData, q_by_name: dict[str, float]) -> None:
    for name, value in q_by_name.items():
        d.joint(name).qpos[0] = value


def tip_position(m: mujoco.MjModel, q_by_name: dict[str, float]) -> np.ndarray:
    d = mujoco.MjData(m)
    set_q(m, d, q_by_name)
    mujoco.mj_forward(m, d)
    return d.site("brush_tip").xpos.copy()


def joint_range(m: mujoco.MjModel, name: str) -> tuple[float, float]:
    lo, hi = m.joint(name).range
    return float(lo), float(hi)


def random_q(m: mujoco.MjModel, rng: np.random.Generator) -> dict[str, float]:
    return {name: rng.uniform(*joint_range(m, name)) for name in JOINTS}


def total_warnings(d: mujoco.MjData) -> int:
    return sum(int(d.warning[i].number) for i in range(len(d.warning)))


# --- compile and run -------------------------------------------------------------------------


def test_scene_includes_arm_and_has_the_interface(scene: mujoco.MjModel) -> None:
    assert [scene.joint(i).name for i in range(scene.njnt)] == list(JOINTS + UNDRIVEN)
    assert [scene.actuator(i).name for i in range(scene.nu)] == list(JOINTS)
    for name in JOINTS:
        act = scene.actuator(name)
        assert act.trntype[0] == mujoco.mjtTrn.mjTRN_TENDON
        assert scene.tendon(int(act.trnid[0])).name == f"drive_{name}"
        assert act.gear[0] == 1.0
        assert not scene.actuator_ctrllimited[act.id]
    np.testing.assert_array_equal(scene.tendon_frictionloss, 0.0)
    np.testing.assert_array_equal(scene.tendon_damping, 0.0)
    np.testing.assert_array_equal(scene.tendon_armature, 0.0)
    assert scene.opt.timestep == 0.0005
    assert scene.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    scene.camera("global_view")
    scene.key("home")


@pytest.mark.parametrize("hold", [False, True], ids=["falling", "held_by_brakes"])
def test_2000_steps_from_home_without_warnings(scene: mujoco.MjModel, hold: bool) -> None:
    m = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    if hold:
        m.tendon_frictionloss[:] = 1000.0  # brakes on: 1 kN·m is far above any gravity torque
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    d.ctrl[:] = 0.0
    q0 = d.qpos.copy()
    for _ in range(2000):
        mujoco.mj_step(m, d)
        assert total_warnings(d) == 0, [(i, d.warning[i].number) for i in range(len(d.warning))]
    assert np.all(np.isfinite(d.qpos))
    if hold:
        # friction is a soft constraint: a held joint creeps (arm.xml, tendon default); < 5 mrad/s
        np.testing.assert_allclose(d.qpos, q0, atol=5e-3)
    else:
        assert not np.allclose(d.qpos, q0, atol=1e-3)  # it really did fall


def test_home_is_within_limits_and_out_of_contact(scene: mujoco.MjModel) -> None:
    d = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, d, scene.key("home").id)
    mujoco.mj_forward(scene, d)
    for name in JOINTS:
        lo, hi = joint_range(scene, name)
        assert lo <= d.joint(name).qpos[0] <= hi, name
    assert d.ncon == 0
    tip = d.site("brush_tip").xpos
    string_x = scene.geom("disc_1").pos[0]
    assert tip[0] < string_x - DISC_RADIUS_M  # in front of the string, not inside it


def test_brush_touches_discs_but_not_the_floor(scene: mujoco.MjModel) -> None:
    """Only brush-disc contacts: put the brush into disc_8's rim and on the floor."""
    brush, floor = scene.geom("brush"), scene.geom("floor")
    disc = scene.geom("disc_8")

    def can_collide(a, b) -> bool:
        return bool((a.contype[0] & b.conaffinity[0]) or (b.contype[0] & a.conaffinity[0]))

    assert can_collide(brush, disc)
    assert not can_collide(brush, floor)
    for i in range(scene.ngeom):
        g = scene.geom(i)
        if scene.geom_bodyid[i] != 0 and g.name != "brush":
            assert g.contype[0] == 0 and g.conaffinity[0] == 0, g.name


# --- inertia ---------------------------------------------------------------------------------


def test_every_body_has_its_explicit_inertial(arm: mujoco.MjModel) -> None:
    root = ET.parse(ARM_XML).getroot()
    written = {b.get("name"): b.find("inertial") for b in root.iter("body")}
    assert set(written) == set(ARM_BODIES)
    for name in ARM_BODIES:
        inertial = written[name]
        assert inertial is not None, f"{name}: no <inertial>"
        body = arm.body(name)
        assert body.mass[0] > 0.0
        assert body.mass[0] == pytest.approx(float(inertial.get("mass")), rel=1e-12)
        diag = np.array([float(v) for v in inertial.get("diaginertia").split()])
        # mujoco may reorder principal axes; the set of moments must be as written
        np.testing.assert_allclose(np.sort(body.inertia), np.sort(diag), rtol=1e-9)
        np.testing.assert_allclose(body.ipos, [float(v) for v in inertial.get("pos").split()], atol=1e-12)


def test_payload_is_20_kg(arm: mujoco.MjModel) -> None:
    assert arm.body("payload").mass[0] == pytest.approx(PAYLOAD_KG)
    # centre 0.05 m behind the brush tip along the tool axis
    d = mujoco.MjData(arm)
    mujoco.mj_forward(arm, d)
    behind = d.site("brush_tip").xpos - d.body("payload").xipos
    np.testing.assert_allclose(behind, [0.05, 0.0, 0.0], atol=1e-9)


# --- kinematics ------------------------------------------------------------------------------


def test_reach_out_and_up(arm: mujoco.MjModel) -> None:
    zero = tip_position(arm, {name: 0.0 for name in JOINTS})
    assert math.hypot(zero[0], zero[1]) == pytest.approx(1.10, abs=0.01)  # paper: 1100 mm out
    assert zero[2] == pytest.approx(0.40, abs=0.01)  # shoulder height
    up = tip_position(arm, {"shoulder_pitch": math.pi / 2})
    assert up[2] == pytest.approx(1.50, abs=0.01)  # paper: 1500 mm high


def test_positive_pitch_raises_the_arm(arm: mujoco.MjModel) -> None:
    for name in ("shoulder_pitch", "elbow_pitch", "wrist_pitch"):
        assert tip_position(arm, {name: 0.2})[2] > 0.40 + 1e-3, name
    # forearm absolute pitch = shoulder + elbow: 30 + (-30) keeps the forearm level
    q = {"shoulder_pitch": math.radians(30), "elbow_pitch": math.radians(-30)}
    d = mujoco.MjData(arm)
    set_q(arm, d, q)
    mujoco.mj_forward(arm, d)
    np.testing.assert_allclose(d.body("forearm").xmat.reshape(3, 3), np.eye(3), atol=1e-12)


def test_drive_elbow_tendon_is_the_forearm_absolute_pitch(arm: mujoco.MjModel) -> None:
    rng = np.random.default_rng(1)
    d = mujoco.MjData(arm)
    for _ in range(20):
        set_q(arm, d, random_q(arm, rng))
        mujoco.mj_forward(arm, d)
        shoulder = d.joint("shoulder_pitch").qpos[0]
        elbow = d.joint("elbow_pitch").qpos[0]
        assert d.tendon("drive_elbow_pitch").length[0] == pytest.approx(shoulder + elbow, abs=1e-12)
        for name in ("base_yaw", "shoulder_pitch", "wrist_pitch", "tool_roll"):
            assert d.tendon(f"drive_{name}").length[0] == pytest.approx(d.joint(name).qpos[0], abs=1e-12)


# --- Pinocchio against MuJoCo (DESIGN Rule 3) ------------------------------------------------


def arm_xml_with_payload(tmp_path: Path, mass_kg: float) -> Path:
    """The same arm.xml with only the payload's mass changed: read by both engines."""
    tree = ET.parse(ARM_XML)
    (payload,) = [b for b in tree.getroot().iter("body") if b.get("name") == "payload"]
    payload.find("inertial").set("mass", repr(mass_kg))
    path = tmp_path / f"arm_payload_{mass_kg:g}kg.xml"
    tree.write(path)
    return path


@pytest.mark.parametrize("payload_kg", [PAYLOAD_KG, 1e-6], ids=["payload_on", "payload_off"])
def test_pinocchio_gravity_equals_mujoco_at_rest(tmp_path: Path, payload_kg: float) -> None:
    path = arm_xml_with_payload(tmp_path, payload_kg)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    model = pin.buildModelFromMJCF(str(path))
    data = model.createData()
    assert m.body("payload").mass[0] == pytest.approx(payload_kg)
    assert model.nq == model.nv == len(JOINTS + UNDRIVEN)

    # by name, never by index
    pin_q_index = {name: model.joints[model.getJointId(name)].idx_q for name in JOINTS}
    pin_v_index = {name: model.joints[model.getJointId(name)].idx_v for name in JOINTS}
    for name in JOINTS:
        lo, hi = joint_range(m, name)
        assert model.lowerPositionLimit[pin_q_index[name]] == pytest.approx(lo)
        assert model.upperPositionLimit[pin_q_index[name]] == pytest.approx(hi)

    rng = np.random.default_rng(2)
    for _ in range(20):
        q = random_q(m, rng)
        set_q(m, d, q)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        q_pin = np.zeros(model.nq)
        for name, value in q.items():
            q_pin[pin_q_index[name]] = value
        g_pin = pin.computeGeneralizedGravity(model, data, q_pin)
        for name in JOINTS:
            mj = d.qfrc_bias[m.joint(name).dofadr[0]]
            pn = g_pin[pin_v_index[name]]
            assert pn == pytest.approx(mj, rel=1e-6, abs=1e-9), (name, q)
    if payload_kg > 1.0:
        # the payload really loads the shoulder: 20 kg at up to 1.05 m
        set_q(m, d, {name: 0.0 for name in JOINTS})
        mujoco.mj_forward(m, d)
        assert abs(d.qfrc_bias[m.joint("shoulder_pitch").dofadr[0]]) > PAYLOAD_KG * 9.81 * 1.0


# --- camera and insulator string -------------------------------------------------------------


def test_global_view_sees_the_workspace_and_the_string(scene: mujoco.MjModel) -> None:
    d = mujoco.MjData(scene)
    mujoco.mj_forward(scene, d)
    cam = d.camera("global_view")
    R = cam.xmat.reshape(3, 3)  # columns: camera x (right), y (up), z (backwards)
    tan_v = math.tan(math.radians(scene.camera("global_view").fovy[0]) / 2)
    aspect = scene.vis.global_.offwidth / scene.vis.global_.offheight
    shoulder = np.array([0.0, 0.0, 0.40])
    points = [shoulder + 1.10 * np.array([math.cos(a), math.sin(a), 0]) for a in np.linspace(0, 2 * math.pi, 24)]
    points += [shoulder + np.array([0, 0, 1.10]), np.zeros(3)]
    for k in range(1, 9):
        c = scene.geom(f"disc_{k}").pos
        points += [c + [DISC_RADIUS_M, 0, 0], c - [DISC_RADIUS_M, 0, 0]]
    for p in points:
        xc, yc, zc = R.T @ (p - cam.xpos)
        assert zc < 0, p
        assert abs(yc / -zc) < tan_v and abs(xc / -zc) < tan_v * aspect, p


def test_string_is_a_u70bl_like_stack(scene: mujoco.MjModel) -> None:
    centres = np.array([scene.geom(f"disc_{k}").pos for k in range(1, 9)])
    np.testing.assert_allclose(-np.diff(centres[:, 2]), DISC_SPACING_M, atol=1e-9)
    np.testing.assert_allclose(centres[:, :2], np.broadcast_to(centres[0, :2], (8, 2)), atol=1e-12)
    for k in range(1, 9):
        assert scene.geom(f"disc_{k}").size[0] == pytest.approx(DISC_RADIUS_M)


def solve_tip_ik(m: mujoco.MjModel, target: np.ndarray, q_start: dict[str, float]) -> dict[str, float]:
    """Damped least squares on brush_tip's position, joints clamped to their ranges."""
    d = mujoco.MjData(m)
    set_q(m, d, q_start)
    jac = np.zeros((3, m.nv))
    lo, hi = m.jnt_range[:, 0], m.jnt_range[:, 1]
    for _ in range(300):
        mujoco.mj_forward(m, d)
        error = target - d.site("brush_tip").xpos
        if np.linalg.norm(error) < 1e-4:
            break
        mujoco.mj_jacSite(m, d, jac, None, m.site("brush_tip").id)
        step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-3 * np.eye(3), error)
        d.qpos[:] = np.clip(d.qpos + step, lo, hi)  # hinge-only arm: qpos and dofs line up
    return {name: float(d.joint(name).qpos[0]) for name in JOINTS}


@pytest.mark.parametrize("disc", ["disc_1", "disc_8"], ids=["top", "bottom"])
def test_brush_reaches_the_disc_rim(scene: mujoco.MjModel, disc: str) -> None:
    centre = scene.geom(disc).pos
    near_rim = centre - np.array([DISC_RADIUS_M, 0.0, 0.0])  # the rim point facing the arm
    home = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, home, scene.key("home").id)
    q = solve_tip_ik(scene, near_rim, {name: float(home.joint(name).qpos[0]) for name in JOINTS})
    for name, value in q.items():
        lo, hi = joint_range(scene, name)
        assert lo <= value <= hi, (name, value)
    assert np.linalg.norm(tip_position(scene, q) - near_rim) < 0.02, {k: math.degrees(v) for k, v in q.items()}


# --- the wrist's counterbalance ----------------------------------------------------------------


def test_the_wrist_counterbalance_lets_the_papers_wrist_turn_either_way_at_0_5_mpa() -> None:
    """DESIGN "Sizing": the paper's wrist pair (1UP motor, ratio 120) is a slewing joint, and at
    0.5 MPa it stalled under the 20 kg payload (issue 13). A moving motor's port is held between
    the brake's full release plus the loop's margin (4.5 bar) and the supply (5 bar); a stalled one
    must break away at its worst vane angle. The static load is the controller's (Pinocchio's
    gravity plus the MJCF's spring), checked against MuJoCo in tests/test_control.py. Without the
    spring, lifting the level tool needs more than the supply; with it, every tool pitch over the
    wrist's whole range needs less than the floor, lifting or lowering."""
    arm = ArmModel(ARM_XML, payload_kg=PAYLOAD_KG)
    p = load_joint_params(assets.joint_param_path("wrist_pitch"))
    per_pa = (
        least_displacement_per_rad(p.stator_radius_m, p.rotor_radius_m, p.vane_length_m, p.n_vanes)
        * p.ratio
        * p.efficiency_forward
    )
    w, e = arm.joints.index("wrist_pitch"), arm.joints.index("elbow_pitch")
    need_pa, need_without_pa = [], []
    lo, hi = joint_range(mujoco.MjModel.from_xml_path(str(ARM_XML)), "wrist_pitch")
    for wrist in np.linspace(lo, hi, 37):
        for pitch in np.radians(np.linspace(-90.0, 90.0, 37)):  # the tool's absolute pitch
            drive = np.zeros(len(arm.joints))
            drive[w], drive[e] = wrist, pitch - wrist  # tool pitch = forearm (elbow drive) + wrist
            load, spring = arm.load_torques(drive)[w], arm.spring_torques(drive)[w]
            need_pa.append((abs(load) + p.coulomb_nm) / per_pa)
            need_without_pa.append((abs(load - spring) + p.coulomb_nm) / per_pa)
    floor_pa = p.brake_release_gauge_pa + DEFAULT_GAINS.brake_clear_margin_pa
    assert max(need_without_pa) > 0.5e6  # the paper's wrist alone: stalls with the supply at its port
    assert max(need_pa) < floor_pa  # with the counterbalance: moves wherever the loop moves it
