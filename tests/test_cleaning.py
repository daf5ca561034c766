"""The cleaning task: the compliant brush against Hooke's law, the per-disc contact analysis, the
operator's camera against MuJoCo's renderer, and a run cut short judged on what it reached."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import assets
from scenarios.cleaning import CONTACT_N, _covered_arc_m, disc_contacts
from scenarios.ik import disc_drive_angles, disc_rim_target, drive_to_qpos, tool_drive_angles
from scenarios.operator import CAMERA, GlobalCamera, Operator, brush_face_m
from scenarios.pinhole import camera_of
from scenarios.schema import OperatorParams
from twin_cli.cli import main as twin_main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def scene() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))


def hold_arm_at(m: mujoco.MjModel, drive: dict[str, float], seconds: float = 1.5, then=None) -> mujoco.MjData:
    """Step the scene with the arm's joints held at `drive` (only the brush head is free);
    `then(m, d)` is called after each of the last 0.2 s of steps."""
    d = mujoco.MjData(m)
    q = drive_to_qpos(drive)
    arm = [m.joint(j).dofadr[0] for j in q]
    n = round(seconds / m.opt.timestep)
    for k in range(n):
        for j, v in q.items():
            d.joint(j).qpos[0] = v
        d.qvel[arm] = 0.0
        mujoco.mj_step(m, d)
        if then is not None and k >= n - round(0.2 / m.opt.timestep):
            then(m, d)
    return d


def axial_contact_force(m: mujoco.MjModel, d: mujoco.MjData) -> float:
    """Force the discs push the brush head back with, along its slide (N)."""
    axis = d.body("brush_head").xmat.reshape(3, 3)[:, 0]
    f, total = np.zeros(6), np.zeros(3)
    brush = m.geom("brush").id
    for i in range(d.ncon):
        c = d.contact[i]
        mujoco.mj_contactForce(m, d, i, f)
        on_geom2 = c.frame.reshape(3, 3).T @ f[:3]
        total += on_geom2 if c.geom2 == brush else -on_geom2
    return float(-total @ axis)


@pytest.mark.parametrize("press_m", [0.010, 0.025, 0.040])
def test_brush_press_follows_hookes_law(scene, press_m):
    """Pressed `press_m` into disc 4's rim with the arm held, the head's spring carries the force:
    F = k (springref - stroke) from the MJCF's spring, and the stroke is the press (the contact
    itself is stiff), so F = preload + k * press, tens of newtons."""
    j = scene.joint("brush_stroke")
    k, springref = float(scene.jnt_stiffness[j.id]), float(scene.qpos_spring[j.qposadr[0]])
    samples = []  # (stroke, force): the light head on a stiff contact still trembles; its mean is at rest
    hold_arm_at(
        scene,
        disc_drive_angles(scene, 4, -press_m),
        then=lambda m, d: samples.append((d.joint("brush_stroke").qpos[0], axial_contact_force(m, d))),
    )
    stroke, force = np.mean(samples, axis=0)
    assert force == pytest.approx(
        k * (springref - stroke), rel=0.03
    )  # the head at rest (tool level: no weight along it); 1.4 % left at 10 mm
    assert -stroke == pytest.approx(press_m, abs=1e-3)  # the contact gives < 1 mm
    assert force == pytest.approx(k * (springref + press_m), rel=0.05)
    assert 10.0 < force < 60.0


def test_a_press_past_the_stroke_rams(scene):
    """Past its 50 mm stroke the head bottoms out and the rigid arm pushes: far above the band."""
    lo = float(scene.joint("brush_stroke").range[0])
    d = hold_arm_at(scene, disc_drive_angles(scene, 4, lo - 0.01))
    assert axial_contact_force(scene, d) > 150.0


def test_disc_contacts_come_from_the_contact_samples(scene):
    """Synthetic telemetry: 1 s pressing disc 3 at 30 N, a 0.1 s graze on disc 5 below the
    threshold, nothing on the others."""
    t = np.arange(0.0, 3.0, 0.02)
    force = np.zeros_like(t)
    point = np.full((len(t), 3), np.nan)
    rim = scene.geom("disc_3").pos - [scene.geom("disc_3").size[0], 0, 0]
    pressing = (t >= 0.5) & (t < 1.5)
    force[pressing], point[pressing] = 30.0, rim
    graze = (t >= 2.0) & (t < 2.1)
    force[graze], point[graze] = CONTACT_N / 2, scene.geom("disc_5").pos - [scene.geom("disc_5").size[0], 0, 0]
    by_disc = {c.disc: c for c in disc_contacts(scene, {"time_s": t, "brush_force_n": force, "brush_contact_m": point})}
    assert by_disc[3].contact_s == pytest.approx(1.0, abs=0.021)
    assert by_disc[3].peak_n == 30.0 and by_disc[3].mean_n == 30.0
    r, b = scene.geom("disc_3").size[0], scene.geom("brush").size[0]
    assert by_disc[3].brushed_m == pytest.approx(2 * r * math.asin(b / r))  # a static press: the face's chord
    assert by_disc[5].contact_s == 0.0 and by_disc[5].peak_n == pytest.approx(CONTACT_N / 2)
    for k in (1, 2, 4, 6, 7, 8):
        assert by_disc[k].contact_s == 0.0 and math.isnan(by_disc[k].peak_n) and by_disc[k].brushed_m == 0.0


def test_covered_arc_is_the_union_of_arcs():
    assert _covered_arc_m(np.array([0.0]), 0.1, 2.0) == pytest.approx(0.4)
    assert _covered_arc_m(np.array([0.0, 0.1]), 0.1, 1.0) == pytest.approx(0.3)  # overlapping
    assert _covered_arc_m(np.array([0.0, math.pi]), 0.1, 1.0) == pytest.approx(0.4)  # apart
    assert _covered_arc_m(np.array([-0.05, 2 * math.pi - 0.02]), 0.1, 1.0) == pytest.approx(0.23)  # across 0
    assert _covered_arc_m(np.linspace(0, 2 * math.pi, 50), 0.1, 1.0) == pytest.approx(2 * math.pi)


def test_the_operators_picture_error_is_the_true_error_to_a_pixel(scene):
    """With the brush 2 cm short and 1.5 cm high of its standoff at disc 6, the operator reads
    that from the camera's picture to within the size of a pixel or two at the string."""
    standoff = 0.05
    params = OperatorParams()
    from scenarios.ik import disc_rim_target, tool_drive_angles

    target = disc_rim_target(scene, 6, standoff)
    tilt = sum(disc_drive_angles(scene, 6, standoff)[j] for j in ("elbow_pitch", "wrist_pitch"))
    true_error = np.array([-0.02, 0.0, 0.015])
    d = hold_arm_at(scene, tool_drive_angles(scene, target + true_error, tilt), seconds=0.05)
    camera = GlobalCamera(scene, d, params)
    camera.capture(0.0)
    operator = Operator(scene, camera, params, np.random.default_rng(0))
    seen = operator.picture_error_m(camera.frames[-1], 6, standoff)
    pixel_m = camera.pinhole.metres_per_px(float(-camera.pinhole.camera_frame(brush_face_m(d)[None])[0, 2]))
    assert np.linalg.norm((seen - true_error)[[0, 2]]) < 2.5 * pixel_m
    pose = operator.read_pose(camera.frames[-1])
    truth = tool_drive_angles(scene, target + true_error, tilt)
    for joint, angle in pose.items():
        assert abs(angle - truth[joint]) < 2 * operator.reading_noise_rad(camera.frames[-1])[joint], joint


def test_the_press_load_is_the_head_springs_force_by_virtual_work(scene):
    """The controller's load of a press (Pinocchio: -C^-T J^T f, f the head spring's force along the
    rim's normal) against MuJoCo's kinematics of the same arm: the drive torque that holds the force
    is -f . d(tip)/d(drive), by finite differences; 10 N + 800 N/m x 20 mm = 26 N at a 20 mm
    press (assets/arm.xml), nothing clear of the rim."""
    from control.arm_model import ArmModel
    from scenarios.ik import disc_rim_target, tool_drive_angles

    arm = ArmModel(assets.ARM_XML, payload_kg=20.0)
    assert arm.head_spring.force_n(0.020) == pytest.approx(26.0)
    surface, normal = disc_rim_target(scene, 3, 0.0), np.array([-1.0, 0.0, 0.0])
    d = mujoco.MjData(scene)

    def tip(drive: np.ndarray) -> np.ndarray:
        for j, q in drive_to_qpos(dict(zip(arm.joints, drive, strict=True))).items():
            d.joint(j).qpos[0] = q
        mujoco.mj_kinematics(scene, d)
        return d.site("brush_tip").xpos.copy()

    for press, tilt in ((0.020, 0.1), (0.035, -0.2)):
        pose = tool_drive_angles(scene, surface + [press, 0.0, 0.0], tilt)
        drive = np.array([pose[j] for j in arm.joints])
        f = normal * arm.head_spring.force_n(press)
        h = 1e-6
        expected = [-f @ (tip(drive + h * e) - tip(drive - h * e)) / (2 * h) for e in np.eye(len(drive))]
        assert arm.press_torques(drive, surface, normal) == pytest.approx(expected, abs=1e-4)
        assert max(abs(np.array(expected))) > 5.0  # N·m: a load the shoulder notices
    clear = tool_drive_angles(scene, surface - [0.01, 0.0, 0.0], 0.0)
    assert not arm.press_torques(np.array([clear[j] for j in arm.joints]), surface, normal).any()


def test_the_press_load_skips_the_kinematics_only_where_they_give_nothing(scene):
    """press_torques skips Pinocchio's kinematics while the joints have turned too little since its
    last look to bring the tool to the surface: along an approach from 6 cm off disc 3's rim to
    2 cm into it and back, every load equals the one computed afresh (the surface handed in new
    arrays each time: no skip), bit for bit; the skip was taken, and the press was felt."""
    from control.arm_model import ArmModel
    from scenarios.ik import disc_rim_target, tool_drive_angles

    arm, fresh = ArmModel(assets.ARM_XML, payload_kg=20.0), ArmModel(assets.ARM_XML, payload_kg=20.0)
    surface, normal = disc_rim_target(scene, 3, 0.0), np.array([-1.0, 0.0, 0.0])
    far, deep = (tool_drive_angles(scene, surface + [x, 0.0, 0.0], 0.0) for x in (-0.06, 0.02))
    a, b = (np.array([p[j] for j in arm.joints]) for p in (far, deep))
    path = [a + (b - a) * s for s in np.concatenate([np.linspace(0, 1, 400), np.linspace(1, 0, 400)])]
    looked, pressed = [], 0
    forward = ArmModel.press_torques.__globals__["pin"].forwardKinematics

    def counted(*args):
        looked.append(1)
        return forward(*args)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(ArmModel.press_torques.__globals__["pin"], "forwardKinematics", counted)
        for drive in path:
            got = arm.press_torques(drive, surface, normal)
            n = len(looked)
            want = fresh.press_torques(drive, surface.copy(), normal.copy())
            del looked[n:]
            assert np.array_equal(got, want)
            pressed += bool(want.any())
    assert 0 < len(looked) < len(path) - 100  # the kinematics skipped on most of the way clear of the rim
    assert pressed > 100


@pytest.mark.parametrize(("press_m", "tilt_rad"), [(0.010, 0.0), (0.035, 0.26)])
def test_the_operator_reads_the_press_off_the_picture(scene, press_m, tilt_rad):
    """Pressed into disc 3's rim, level or tilted 15 deg up as at disc 1, the head's face stays on
    the rim and its spring gives: the operator reads the head's stroke from the picture (the face
    against its carrier, along the tool) to within two pixels' size at the string, whatever part of
    the face bears on the rim."""
    from scenarios.ik import disc_rim_target, tool_drive_angles

    params = OperatorParams()
    target = disc_rim_target(scene, 3, -press_m)
    d = hold_arm_at(scene, tool_drive_angles(scene, target, tilt_rad), seconds=0.5)
    stroke = -float(d.joint("brush_stroke").qpos[0])
    assert stroke > 0.005  # pressed: the head pushed into its carrier
    camera = GlobalCamera(scene, d, params)
    camera.capture(0.0)
    operator = Operator(scene, camera, params, np.random.default_rng(0))
    pixel_m = camera.pinhole.metres_per_px(float(-camera.pinhole.camera_frame(brush_face_m(d)[None])[0, 2]))
    assert abs(operator.press_error_m(camera.frames[-1], 0.025) - (stroke - 0.025)) < 2 * pixel_m


def test_an_aim_beyond_a_joints_range_tilts_the_brush_and_keeps_its_place(scene):
    """At the bottom disc the wrist is near its range's end: the operator's aim 5 cm lower, at the
    plan's tilt, would put it past; his aim tilts the tool instead, every joint in range, and
    MuJoCo's kinematics put the brush's tip where he aimed to a tenth of a millimetre. A refused
    aim is taken back (the arm did not move: the same error seen again is not added twice)."""
    from scenarios.ik import disc_rim_target, tool_drive_angles

    target = disc_rim_target(scene, 8, 0.05)
    plan = disc_drive_angles(scene, 8, 0.05)
    tilt = plan["elbow_pitch"] + plan["wrist_pitch"]
    camera = GlobalCamera(scene, mujoco.MjData(scene), OperatorParams())
    operator = Operator(scene, camera, OperatorParams(), np.random.default_rng(0))
    operator.aim_offset_m = np.array([0.0, 0.0, -0.05])
    wrist = scene.joint("wrist_pitch").range
    assert not wrist[0] <= tool_drive_angles(scene, target + operator.aim_offset_m, tilt)["wrist_pitch"] <= wrist[1]
    aimed = operator.aimed(target, tilt)
    for j, q in drive_to_qpos(aimed).items():
        assert scene.joint(j).range[0] <= q <= scene.joint(j).range[1], j
    d = hold_arm_at(scene, aimed, seconds=0.002)
    assert np.linalg.norm(d.site("brush_tip").xpos - (target + operator.aim_offset_m)) < 1e-4
    operator._last_move_m = np.array([0.01, 0.0, -0.02])
    operator.take_back()
    assert np.allclose(operator.aim_offset_m, [0.01, 0.0, -0.07])


def test_the_operator_presses_with_the_big_joints_and_leaves_the_wrist(scene):
    """A press from touching distance at each disc moves the shoulder and elbow only: the wrist is
    not commanded, and with it where it stands MuJoCo's kinematics put the brush's tip where the
    press aims to a micrometre; the tool's tilt follows the forearm by a few degrees."""
    from scenarios.ik import disc_rim_target

    camera = GlobalCamera(scene, mujoco.MjData(scene), OperatorParams())
    operator = Operator(scene, camera, OperatorParams(), np.random.default_rng(0))
    for disc in range(2, 9):
        touch = disc_drive_angles(scene, disc, 0.02)
        tip = disc_rim_target(scene, disc, -0.025)
        press = operator.pressed(tip, touch["wrist_pitch"], touch["elbow_pitch"] + touch["wrist_pitch"])
        assert "wrist_pitch" not in press
        d = hold_arm_at(scene, {**press, "wrist_pitch": touch["wrist_pitch"]}, seconds=0.002)
        assert np.linalg.norm(d.site("brush_tip").xpos - tip) < 1e-5, disc
        assert abs(press["elbow_pitch"] - touch["elbow_pitch"]) < math.radians(6.0), disc


RENDER = """
import sys, json, mujoco, numpy as np
m = mujoco.MjModel.from_xml_path(sys.argv[1]); d = mujoco.MjData(m)
mujoco.mj_resetDataKeyframe(m, d, m.key("home").id); mujoco.mj_forward(m, d)
r = mujoco.Renderer(m, int(sys.argv[3]), int(sys.argv[2]))
r.enable_segmentation_rendering(); r.update_scene(d, camera=sys.argv[4]); seg = r.render()[:, :, 0]; r.close()
out = {}
for name in ("brush", "disc_3", "disc_6"):
    v, u = np.nonzero(seg == m.geom(name).id)
    out[name] = [float(u.min()), float(u.max() + 1), float(v.mean() + 0.5), float(u.mean() + 0.5)]
print(json.dumps(out))
"""


def render_segmentation(width: int, height: int) -> dict | None:
    """Pixel extents of some geoms in MuJoCo's own picture, rendered in a child process (the GL
    backend is chosen when mujoco is imported); None where no offscreen backend works."""
    for backend in ("egl", "osmesa"):
        env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
        proc = subprocess.run(
            [sys.executable, "-c", RENDER, str(assets.SCENE_XML), str(width), str(height), CAMERA],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        if proc.returncode == 0:
            return json.loads(proc.stdout.strip().splitlines()[-1])
    return None


def test_pinhole_agrees_with_mujocos_renderer(scene):
    """The operator's projection against the picture MuJoCo renders for the same camera: the
    discs' near edges, their heights and the brush within a pixel or two. (The discs' far edges
    are hidden behind the gantry's front post: the operator does not use them.)"""
    width, height = 640, 480
    seen = render_segmentation(width, height)
    if seen is None:
        pytest.skip("no offscreen GL backend (EGL or OSMesa) renders on this machine")
    d = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, d, scene.key("home").id)
    mujoco.mj_forward(scene, d)
    cam = camera_of(scene, d, CAMERA, width, height)
    for name in ("disc_3", "disc_6"):
        g = scene.geom(name)
        left = cam.project(g.pos - [g.size[0], 0, 0])[0]
        assert abs(left[0] - seen[name][0]) < 1.5, name
        assert abs(cam.project(g.pos)[0, 1] - seen[name][2]) < 2.0, name
    brush = cam.project(d.geom("brush").xpos)[0]
    assert abs(brush[0] - seen["brush"][3]) < 2.0 and abs(brush[1] - seen["brush"][2]) < 2.0


def test_a_run_cut_short_is_judged_on_the_targets_it_reached(capsys, tmp_path):
    """`twin run --duration 22`: disc 1 has been pressed and is judged; discs 2-8 are listed as
    not reached, not failed; the target column shows the target in force at 22 s.

    At 0.7 MPa with this seed the operator's press from the plan's 5 cm standoff (a 7.5 cm move)
    put the head's side on disc 1's rim top edge, 138 N: he now closes in to 2 cm and looks again
    before he presses, and the press stays in the spring's band."""
    toml = (ROOT / "scenarios" / "insulator_cleaning.toml").read_text()
    supply = "pressure_mpa = 0.6 "
    assert supply in toml
    path = tmp_path / "cleaning_07.toml"
    path.write_text(toml.replace(supply, "pressure_mpa = 0.7 "))
    argv = ["run", str(path), "--json", "--duration", "22", "--seed", "4215923173971654960"]
    assert twin_main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    discs = {d["disc"]: d for d in summary["discs"]}
    assert discs[1]["cleaned"] is True and 15.0 < discs[1]["peak_force_n"] < 55.0
    assert any("disc_1: operator closes in to 2 cm" in e for e in summary["controller_events"])
    assert any("disc_1: operator backs out to 2 cm" in e for e in summary["controller_events"])
    assert all(discs[k]["cleaned"] is None for k in range(2, 9))
    assert any("disc_8" in t for t in summary["not_reached"])
    judged = [c for c in summary["criteria"] if c["judged"]]
    assert judged and all(c["passed"] for c in judged)
    assert summary["joints"]["shoulder_pitch"]["target_deg"] != 90.0  # not the plan's last target (home)


def test_a_press_seen_off_is_made_again_from_touching_distance(monkeypatch):
    """The operator sees disc 1's first press 1.5 cm short (his look made so: the picture's own
    error added). Pressing deeper from inside the press, shoulder and elbow turning together with
    the brush on the rim, lifted the head off and swung its side onto the rim: 682 N (as-built,
    0.5 MPa, his seed 2021340933837429789, with the earlier press). He backs out to touching distance, the
    brush off the rim, and presses again from there as he pressed the first time: disc 1 is
    pressed in the band, and no contact on the way leaves it."""
    from scenarios.operator import Operator
    from scenarios.runner import run_scenario
    from scenarios.schema import load

    looks = []
    seen = Operator.press_error_m

    def first_look_short(self, frame, press_m):
        looks.append(press_m)
        return seen(self, frame, press_m) - (0.015 if len(looks) == 1 else 0.0)

    monkeypatch.setattr(Operator, "press_error_m", first_look_short)
    result = run_scenario(load(ROOT / "scenarios" / "insulator_cleaning.toml"), duration_s=30.0)
    again = [e for e in result.events if "disc_1: operator backs out to 2 cm to press again" in e]
    assert again, result.events
    at = float(again[0].split("t = ")[1].split(" s")[0])
    t = result.telemetry.time_s
    force = np.asarray(result.telemetry.arrays()["brush_force_n"])
    after = t > at
    off = np.flatnonzero(after & (force == 0.0))
    assert off.size, "the brush never left the rim before the press again"
    again_pressed = (t > t[off[0]]) & (force > 0.0)
    assert again_pressed.any()  # it pressed again
    disc_1 = next(d for d in result.discs if d.disc == 1)
    assert 15.0 < disc_1.peak_n < 55.0, disc_1


def test_at_half_a_megapascal_the_counterbalanced_wrist_reaches_its_targets(capsys, tmp_path):
    """Issue 13: at 0.5 MPa the paper's wrist pair (DESIGN "Sizing") stalled under the 20 kg
    payload 1 deg short of the first target above it (4.41 bar needed at its port on the mean
    torque, 5.1 at its worst vane angle, against a 5 bar supply), the platform faulted at 20.7 s and
    again every 15 s, and the operator cleaned 1-2 discs of 8. With the wrist's counterbalance spring
    (assets/arm.xml), known to the controller's load model, every move of the first 28 s arrives and
    disc 1 is pressed in the band and left (at 14.7 s; 16.3 s with Heun's air, 22.6 s
    with ROS2 before the vane leak's coupling joined its W: the camera's corrections vary)."""
    toml = (ROOT / "scenarios" / "insulator_cleaning.toml").read_text()
    supply = "pressure_mpa = 0.6 "
    assert supply in toml
    path = tmp_path / "cleaning_05.toml"
    path.write_text(toml.replace(supply, "pressure_mpa = 0.5 "))
    assert twin_main(["run", str(path), "--json", "--duration", "28"]) == 0
    summary = json.loads(capsys.readouterr().out)
    events = summary["controller_events"]
    assert not [e for e in events if "did not reach" in e]
    assert any("disc_1: operator backs out to 2 cm" in e for e in events)
    disc_1 = next(d for d in summary["discs"] if d["disc"] == 1)
    assert disc_1["cleaned"] is True and 15.0 < disc_1["peak_force_n"] < 55.0


def test_a_press_reaches_its_depth_when_the_platform_knows_the_springs_reaction(capsys, tmp_path):
    """Issue 13, the press's depth (as-built, 0.52 MPa, a held-out seed): disc 2 was pressed at 13 N,
    under the 15-55 N band. The true shoulder stalled 0.1-0.6 deg short of the predicted against
    the head spring's 20-30 N (the predictor knew nothing of it), and the operator pressed without
    looking at the press; the platform now expects the spring's reaction at the rim, he looks at the
    press and presses again when it is off by more than his centimetre, and the brush leaves the
    press shoulder first. Discs 1 and 2 are pressed well inside the band."""
    toml = (ROOT / "scenarios" / "insulator_cleaning.toml").read_text()
    supply = "pressure_mpa = 0.6 "
    assert supply in toml
    path = tmp_path / "cleaning_052.toml"
    path.write_text(toml.replace(supply, "pressure_mpa = 0.52 "))
    assert twin_main(["run", str(path), "--json", "--duration", "40", "--seed", "5220146013781160048"]) == 0
    summary = json.loads(capsys.readouterr().out)
    discs = {d["disc"]: d for d in summary["discs"]}
    for k in (1, 2):
        assert discs[k]["cleaned"] is True, discs[k]
        # inside the 15-55 N band with room (46 N at disc 1 since the plan is made for the string as
        # the operator finds it, 2 mm off the scene's: 45 N before)
        assert 18.0 < discs[k]["peak_force_n"] < 50.0, discs[k]


def test_the_back_off_from_touching_distance_draws_the_brush_out_of_the_rim_first(monkeypatch):
    """After a press the operator backs out to 2 cm, then takes the plan's back-off: from 2 cm the
    joints turning one after another swung the brush back onto disc 1's rim (153 N) under a
    slightly different integration of the air. The back-off is sent in two steps, first the joints
    whose own turn draws the brush out of the rim, then the rest (`_out_of_the_rim_first`)."""
    from control.controller import ArmController
    from scenarios.runner import run_scenario
    from scenarios.schema import load

    plans = []
    set_targets = ArmController.set_targets

    def recorded(self, targets, sequence="one_after_another", dwell_s=0.0):
        plans.append(([dict(t) for t in targets] if isinstance(targets, list) else [dict(targets)], self.time_s))
        return set_targets(self, targets, sequence, dwell_s)

    monkeypatch.setattr(ArmController, "set_targets", recorded)
    result = run_scenario(load(ROOT / "scenarios" / "insulator_cleaning.toml"), duration_s=22.0)
    out_at = next(
        float(e.split("t = ")[1].split(" s")[0]) for e in result.events if "disc_1: operator backs out to 2 cm" in e
    )
    back_off = next(steps for steps, t in plans if t > out_at)  # the plan's, once out to 2 cm
    assert len(back_off) == 2 and set(back_off[0]) < set(back_off[1]), back_off


def _operator_looking_at(scene, drive: dict[str, float], stroke_m: float = 0.0, params=None):
    """The operator and his cameras with the arm standing at `drive` (kinematics only) and the
    brush's head pushed `stroke_m` into its carrier; one frame taken at t = 0."""
    params = params or OperatorParams()
    d = mujoco.MjData(scene)
    for j, q in drive_to_qpos(drive).items():
        d.joint(j).qpos[0] = q
    d.joint("brush_stroke").qpos[0] = -stroke_m
    mujoco.mj_forward(scene, d)
    camera = GlobalCamera(scene, d, params)
    camera.capture(0.0)
    return Operator(scene, camera, params, np.random.default_rng(0))


def _platform(drive: dict[str, float]):
    from control import ArmController
    from scenarios.schema import nominal_params

    return ArmController(
        drive, xml_path=assets.ARM_XML, joints=assets.JOINTS, predictor_params=nominal_params(assets.JOINTS)
    )


def test_the_operator_reads_the_base_yaw_from_the_overhead_view_and_resets_it(scene):
    """The arm turned 6.5 deg past where the platform believes it (the yaw a string turned 6 deg
    left unnoticed): the operator reads the yaw off his two views to within a third of a degree and
    sets the platform's belief to it; a belief right to the noise of his reading he leaves."""
    drive = tool_drive_angles(scene, disc_rim_target(scene, 1, 0.05), 0.0)
    truth = {**drive, "base_yaw": drive["base_yaw"] + math.radians(6.5)}
    operator = _operator_looking_at(scene, truth)
    platform = _platform(drive)
    assert operator.review(5.0, 0.0, 1, 0.05, platform, aim=False) is True
    yaw = platform.predicted_angles()[platform.joints.index("base_yaw")]
    assert abs(yaw - truth["base_yaw"]) < math.radians(0.35)
    assert any("base_yaw seen" in e for e in operator.log), operator.log
    assert operator.review(5.0, 0.0, 1, 0.05, _platform(truth), aim=False) is False  # nothing to reset


def test_the_operator_stops_at_a_pose_too_far_off_to_correct_at_the_rim(scene):
    """The elbow seen 25 deg off the platform's belief (beyond any drift between two looks), or the
    shoulder 8 deg off with the brush 2 cm from the rim (going to the target again would move it 7 cm
    into the rim): he sets the belief to what he sees and flags the look, and the task stops and
    backs off clear of the string before it goes there. The elbow 4 deg off 12 cm clear of the rim,
    or the shoulder 8 deg off the other way (the brush to go away from the rim), he only corrects."""
    drive = tool_drive_angles(scene, disc_rim_target(scene, 2, 0.05), 0.0)
    for joint, off_deg, standoff_m, stops in (
        ("elbow_pitch", 25.0, 0.12, True),
        ("shoulder_pitch", -8.0, 0.02, True),
        ("elbow_pitch", 4.0, 0.12, False),
        ("shoulder_pitch", 8.0, 0.02, False),
    ):
        operator = _operator_looking_at(scene, drive)
        platform = _platform({**drive, joint: drive[joint] + math.radians(off_deg)})
        assert operator.review(5.0, 0.0, 2, standoff_m, platform, aim=True) is True
        assert bool(operator.implausible) is stops, (joint, off_deg, operator.log)
        believed = platform.predicted_angles()[platform.joints.index(joint)]
        assert abs(believed - drive[joint]) < math.radians(2.0)  # the belief is what he sees


def test_a_head_seen_pushed_in_with_its_face_off_the_rim_is_not_pressed_again(scene):
    """The head seen pushed 4.5 cm into its carrier (2 cm more than planned) with the brush's face
    4 cm clear of disc 3's rim: nothing can push it, the picture is misread; he backs out without
    pressing again. With the face on the rim the same stroke is an over-press he corrects."""
    from scenarios.plan import PRESS_M

    clear = _operator_looking_at(scene, disc_drive_angles(scene, 3, 0.04 + 0.045), stroke_m=0.045)
    assert clear.review_press(5.0, 0.0, 3, PRESS_M) is False
    assert "not believed, the operator backs out" in clear.log[-1], clear.log
    assert not clear.aim_offset_m.any()
    on_rim = _operator_looking_at(scene, disc_drive_angles(scene, 3, -0.045), stroke_m=0.045)
    assert on_rim.review_press(5.0, 0.0, 3, PRESS_M) is True
    assert on_rim.aim_offset_m @ np.array([-1.0, 0.0, 0.0]) > 0.015  # moved out along the rim's normal


REALITY = "payload_mass_ratio = 1.1\npayload_com_m = [0.02, 0.0, 0.0]\nbrush_spring_ratio = 1.4\nfriction_ratio = 1.3\n"


def _shipped_with(reality: str, table: str = "reality"):
    """The shipped cleaning scenario with these lines added to its [reality] (or [predictor]) table."""
    from scenarios.schema import parse

    text = (ROOT / "scenarios" / "insulator_cleaning.toml").read_text()
    assert f"[{table}]\n" in text
    return parse(text.replace(f"[{table}]\n", f"[{table}]\n{reality}"), "x.toml")


def test_reality_differs_from_what_the_platform_is_told():
    """[reality] payload 10 % heavier with its centre 2 cm further out along the tool, the brush
    spring 1.4 times stiffer, friction 1.3 times: the plant has them, the platform's controller keeps
    the files' and [payload]'s. With the tool level, MuJoCo's gravity torque on the wrist exceeds the
    controller's (Pinocchio, 20 kg at
    the MJCF's centre) by 2 kg x g x 0.10 m (the payload's centre off the wrist axis, assets/arm.xml)
    plus 22 kg x g x 0.02 m."""
    from scenarios import controllers
    from scenarios.runner import build_plant, plan
    from scenarios.schema import joint_params_for, nominal_params, reality_params

    scenario = _shipped_with(REALITY)
    plant = build_plant(scenario)
    m = plant.model
    assert m.body("payload").mass[0] == pytest.approx(22.0)
    assert m.jnt_stiffness[m.joint("brush_stroke").id] == pytest.approx(1.4 * 800.0)
    base = reality_params(scenario)
    for joint, params in plant.joint_params.items():
        assert params.coulomb_nm == pytest.approx(1.3 * base[joint].coulomb_nm)
        assert params.viscous_nm_s == pytest.approx(1.3 * base[joint].viscous_nm_s)
    planned, _, targets = plan(scenario, plant)
    predictor = joint_params_for(nominal_params(planned.joints), planned.predictor)
    assert predictor["shoulder_pitch"].coulomb_nm == nominal_params(("shoulder_pitch",))["shoulder_pitch"].coulomb_nm
    controller, refusal = controllers.build(planned, plant, predictor, targets)
    assert not refusal
    assert controller.arm.head_spring.force_n(0.025) == pytest.approx(10.0 + 800.0 * 0.025)  # the MJCF's spring
    # level tool: shoulder up, forearm and tool horizontal
    drive = {"base_yaw": 0.0, "shoulder_pitch": math.pi / 2, "elbow_pitch": 0.0, "wrist_pitch": 0.0, "tool_roll": 0.0}
    d = mujoco.MjData(m)
    for j, q in drive_to_qpos(drive).items():
        d.joint(j).qpos[0] = q
    mujoco.mj_forward(m, d)
    truth = d.qfrc_bias[m.joint("wrist_pitch").dofadr[0]]
    believed = controller.arm.load_torques(np.array([drive[j] for j in controller.arm.joints]))
    wrist = controller.arm.joints.index("wrist_pitch")
    g = -m.opt.gravity[2]
    expected = 2.0 * g * 0.10 + 22.0 * g * 0.02
    spring = d.qfrc_spring[m.joint("wrist_pitch").dofadr[0]]  # the wrist's counterbalance, in both
    assert abs(truth - spring) - abs(believed[wrist]) == pytest.approx(expected, rel=0.02)


def test_reality_fields_are_refused_with_the_field_and_what_is_allowed():
    """Out of range, in [predictor] (the platform's belief has none of them) or on the rig: refused
    in one line naming the file, the field, the value and what is allowed."""
    from scenarios.schema import ScenarioError, parse

    with pytest.raises(
        ScenarioError, match=r"x.toml: reality.payload_mass_ratio = 3.0 is not allowed; allowed: a number in 0.5..2$"
    ):
        _shipped_with("payload_mass_ratio = 3.0\n")
    with pytest.raises(
        ScenarioError,
        match=r"x.toml: reality.payload_com_m\[1\] = 0.5 is not allowed; allowed: a number in -0.1..0.1 m$",
    ):
        _shipped_with("payload_com_m = [0.0, 0.5, 0.0]\n")
    with pytest.raises(ScenarioError, match=r"x.toml: reality.camera_noise_px = -1 is not allowed"):
        _shipped_with("camera_noise_px = -1\n")
    with pytest.raises(ScenarioError, match=r"x.toml: predictor.brush_spring_ratio is not a known field"):
        _shipped_with("brush_spring_ratio = 1.2\n", table="predictor")
    rig = 'model = "wrist_rig"\nduration_s = 1.0\n[reality]\ncamera_noise_px = 1.0\n'
    with pytest.raises(
        ScenarioError, match=r"x.toml: reality.camera_noise_px = 1.0 is not allowed; allowed: no reality"
    ):
        parse(rig, "x.toml")
    assert parse('model = "wrist_rig"\nduration_s = 1.0\n[reality]\nfriction_ratio = 1.3\n', "x.toml")


def test_a_stiffer_real_brush_spring_presses_harder_than_the_platform_expects():
    """brush_spring_ratio = 1.4: pressed 25 mm into disc 4 with the arm held, the plant's head gives
    1.4 (10 N + 800 N/m x 25 mm) = 42 N, against the 30 N the platform's model expects."""
    scenario = _shipped_with("brush_spring_ratio = 1.4\n")
    from scenarios.runner import build_plant

    m = build_plant(scenario).model
    samples = []
    hold_arm_at(m, disc_drive_angles(m, 4, -0.025), then=lambda m, d: samples.append(axial_contact_force(m, d)))
    assert np.mean(samples) == pytest.approx(1.4 * (10.0 + 800.0 * 0.025), rel=0.05)


def test_the_cameras_noise_is_drawn_per_frame_from_the_seed(scene):
    """camera_noise_px = 2: each point of a picture moves by a normal draw of 2 px before it is cut
    to whole pixels (the spread of the moves: sqrt(2^2 + 1/6) px), the same frame gives the same
    picture whenever it is made, another seed another."""
    d = hold_arm_at(scene, disc_drive_angles(scene, 3, 0.05), seconds=0.002)

    def camera(noise, seed):
        c = GlobalCamera(scene, d, OperatorParams(), noise, seed)
        c.capture(0.0)
        return c

    clean, noisy, again, other = camera(0.0, 1), camera(2.0, 1), camera(2.0, 1), camera(2.0, 2)
    moved = np.concatenate(
        [(noisy.disc_ends_px - clean.disc_ends_px).ravel(), (noisy.frames[0].arm_px - clean.frames[0].arm_px).ravel()]
    )
    assert np.std(moved) == pytest.approx(math.sqrt(4.0 + 1.0 / 6.0), rel=0.3)
    assert np.array_equal(noisy.frames[0].arm_top_px, again.frames[0].arm_top_px)
    assert np.array_equal(noisy.disc_ends_px, again.disc_ends_px)
    assert not np.array_equal(noisy.disc_ends_px, other.disc_ends_px)


def test_a_joint_the_platform_does_not_move_so_little_is_left_where_it_is(scene):
    """The base yaw seen 2.5 deg off: he sets the belief and sends the arm again; the platform
    believes it went (its prediction arrives) but he sees the yaw where it was (a small move under
    friction 1.3 times the files' is a fraction of the one commanded): he sets the belief once more
    and lets it be, instead of sending it again (116 looks in one run before)."""
    drive = tool_drive_angles(scene, disc_rim_target(scene, 1, 0.12), 0.0)
    truth = {**drive, "base_yaw": drive["base_yaw"] - math.radians(2.5)}
    operator = _operator_looking_at(scene, truth)
    platform = _platform(drive)
    assert operator.review(5.0, 0.0, 1, 0.12, platform, aim=False) is True  # set, sent again
    platform.reference("base_yaw", drive["base_yaw"])  # the prediction arrived; the arm did not move
    assert operator.review(6.0, 0.0, 1, 0.12, platform, aim=False) is False
    assert "left there" in operator.log[-1], operator.log
    yaw = platform.predicted_angles()[platform.joints.index("base_yaw")]
    assert abs(yaw - truth["base_yaw"]) < math.radians(0.5)


def test_a_base_yaw_left_where_it_stands_is_not_sent_again_by_little(scene):
    """After he has seen the base yaw not move by a small move and left it (the belief set), a
    later target within that move of where it stands keeps it there (the platform would not move it
    either: 60 re-reads a run with friction x1.3 before); a target further off is a real move, and
    lets it go. The pitch joints are never held (holding one would move the brush in the picture)."""
    drive = tool_drive_angles(scene, disc_rim_target(scene, 1, 0.12), 0.0)
    truth = {**drive, "base_yaw": drive["base_yaw"] - math.radians(2.5)}
    operator = _operator_looking_at(scene, truth)
    platform = _platform(drive)
    assert operator.review(5.0, 0.0, 1, 0.12, platform, aim=False) is True
    platform.reference("base_yaw", drive["base_yaw"])  # the prediction arrived; the arm did not move
    assert operator.review(6.0, 0.0, 1, 0.12, platform, aim=False) is False
    assert set(operator.held) == {"base_yaw"}
    near = {**drive, "base_yaw": drive["base_yaw"] + math.radians(0.5)}
    held = operator.hold(near)
    assert abs(held["base_yaw"] - truth["base_yaw"]) < math.radians(0.5)  # kept where it stands
    assert {j: q for j, q in held.items() if j != "base_yaw"} == {j: q for j, q in near.items() if j != "base_yaw"}
    far = {**drive, "base_yaw": drive["base_yaw"] + math.radians(40.0)}
    assert operator.hold(far) == far and not operator.held  # a real move: let go


def test_a_coarse_picture_sets_how_near_he_places_the_brush(scene):
    """He cannot see an error under a pixel: at 160x120 a pixel at the string is ~2.5 cm, so he
    places the brush to that, not to the scenario's 1 cm (which at 640x480, 0.6 cm a pixel, stays)."""
    d = mujoco.MjData(scene)
    mujoco.mj_forward(scene, d)
    for width, height, expected_m in ((640, 480, 0.01), (160, 120, None)):
        params = OperatorParams(width_px=width, height_px=height)
        operator = Operator(scene, GlobalCamera(scene, d, params), params, np.random.default_rng(0))
        pixel = operator.sighting.m_per_px
        if expected_m is None:
            assert 0.02 < pixel < 0.03 and operator.tolerance_m == pixel
        else:
            assert pixel < 0.01 and operator.tolerance_m == expected_m


def test_a_correction_across_the_rim_near_it_is_made_from_clear_of_it(scene):
    """The elbow believed 8 deg off with the brush 5 cm from disc 1's rim: going to the target again
    would move the brush ~6 cm, mostly across the rim's normal (down onto its edge: 292 N with a
    160x120 picture). With a picture coarser than his tolerance (320x240: 1.25 cm a pixel) that may
    be his misreading: he stops and backs off clear of the string first; 12 cm off (the plan's
    clearance) he only corrects. With the shipped 640x480 picture it is the arm's real sag (payload
    x1.1), corrected where it is."""
    drive = tool_drive_angles(scene, disc_rim_target(scene, 1, 0.05), math.radians(10.0))
    coarse = OperatorParams(width_px=320, height_px=240)
    for params, standoff_m, stops in ((coarse, 0.05, True), (coarse, 0.12, False), (OperatorParams(), 0.05, False)):
        operator = _operator_looking_at(scene, drive, params=params)
        assert operator.coarse is (params is coarse)
        platform = _platform({**drive, "elbow_pitch": drive["elbow_pitch"] - math.radians(8.0)})
        assert operator.review(5.0, 0.0, 1, standoff_m, platform, aim=True) is True
        assert bool(operator.implausible) is stops, (standoff_m, operator.log)
        if stops:
            assert "across it" in operator.implausible


def _brush_to_disc_m(scene, drive: dict[str, float], disc: str) -> float:
    """MuJoCo's distance between the brush's head and a disc's shell at these drive angles (m; under
    0: overlapping), an independent measure of the geometry the operator judges by."""
    d = mujoco.MjData(scene)
    for j, q in drive_to_qpos(drive).items():
        d.joint(j).qpos[0] = q
    mujoco.mj_forward(scene, d)
    return float(mujoco.mj_geomDistance(scene, d, scene.geom("brush").id, scene.geom(disc).id, 0.5, None))


def test_before_turning_back_he_sees_from_above_whether_the_brush_will_pass_clear_of_the_string(scene):
    """The plan's home pose turned aside (base yaw 40 deg) with the shoulder 7.6 deg short of its
    90 (as the retreat left it in a 160x120 run): turned back to yaw 0 the head would stand in disc
    5 (MuJoCo's distance between them under 0; the turn struck it at 419 N). From both views, with
    the shipped picture and with a 160x120 one, he finds the brush's carrier further out than the
    platform believes, sets the shoulder's belief to within his reading of the truth and sends the
    target again; with the shoulder where the platform believes it (the head 2.7 cm off disc 5
    turned back) he turns it back."""
    home = {"base_yaw": math.radians(40.0), "shoulder_pitch": math.radians(90.0)}
    home |= {"elbow_pitch": math.radians(-30.0), "wrist_pitch": math.radians(30.0), "tool_roll": 0.0}
    short = {**home, "shoulder_pitch": math.radians(82.4)}
    assert _brush_to_disc_m(scene, {**short, "base_yaw": 0.0}, "disc_5") < 0.0
    assert _brush_to_disc_m(scene, {**home, "base_yaw": 0.0}, "disc_5") > 0.02
    for params, within_deg in ((OperatorParams(), 1.0), (OperatorParams(width_px=160, height_px=120), 4.0)):
        operator = _operator_looking_at(scene, short, params=params)
        platform = _platform(home)
        assert operator.review_swing(5.0, 0.0, platform, 0.0) is True, operator.log
        believed = platform.predicted_angles()[platform.joints.index("shoulder_pitch")]
        assert abs(math.degrees(believed) - 82.4) < within_deg, operator.log
        assert "pose re-read" in operator.log[-1]
        at_home = _operator_looking_at(scene, home, params=params)
        assert at_home.review_swing(5.0, 0.0, _platform(home), 0.0) is False, at_home.log
        assert "turned back" in at_home.log[-1]


def test_a_brush_seen_on_the_rim_where_it_should_stand_clear_is_drawn_out_first(scene):
    """A 160x120 picture, the platform believing the brush 5 cm off disc 2's rim: with the brush in
    truth 2.5 cm past the rim (a shoulder 7 deg off, unread: the head's stroke shows as 0.5 cm at a
    2.5 cm pixel) he sees its face past the rim, sets the belief and says how far to draw it out
    (the 5 cm and what he sees past the rim, to his pixels; so with the shipped picture too); with
    the brush at its standoff, or with
    the tool tilted 45 deg 4 cm off the rim (the face's edge seen on it, its centre off), he does
    not. At most DRAW_OUTS_PER_DISC times a disc."""
    from scenarios.operator import DRAW_OUTS_PER_DISC

    coarse = OperatorParams(width_px=160, height_px=120)
    target = tool_drive_angles(scene, disc_rim_target(scene, 2, 0.05), 0.0)
    past = tool_drive_angles(scene, disc_rim_target(scene, 2, -0.025), 0.0)
    for params in (coarse, OperatorParams()):
        operator = _operator_looking_at(scene, past, params=params)
        for _ in range(DRAW_OUTS_PER_DISC):
            assert operator.review(5.0, 0.0, 2, 0.05, _platform(target), aim=True) is True
            assert operator.on_rim and "draws it out" in operator.log[-1], operator.log
            # the face and the rim each cut to a whole pixel: their distance to two
            assert operator.draw_out_m == pytest.approx(0.075, abs=2.0 * operator.sighting.m_per_px)
        operator.review(5.0, 0.0, 2, 0.05, _platform(target), aim=True)
        assert not operator.on_rim  # out of draw-outs on this disc: a look as any other
    tilted = tool_drive_angles(scene, disc_rim_target(scene, 3, 0.04), math.radians(-45.0))
    for drive, standoff_m in ((target, 0.05), (tilted, 0.04)):
        operator = _operator_looking_at(scene, drive, params=coarse)
        operator.review(5.0, 0.0, 2 if drive is target else 3, standoff_m, _platform(drive), aim=True)
        assert not operator.on_rim, operator.log


def test_with_a_coarse_picture_a_press_is_corrected_only_past_the_pixel_of_its_reading(scene):
    """The head pushed 4 cm into disc 3's rim (42 N, in the 15-55 N band; 1.5 cm more than the
    plan's 2.5): the shipped picture reads the stroke to its 0.6 cm pixel and he corrects the press;
    a 160x120 one reads it as the distance between two points each cut to a 2.5 cm pixel (here 3 cm
    off the plan's, past his 2.5 cm tolerance), so a seen error under his tolerance plus that pixel
    he leaves (corrected by such readings, each an out-and-in of the shoulder, the platform's belief
    drifted 14 deg and the next move swept disc 4 at 329 N)."""
    from scenarios.plan import PRESS_M

    coarse = OperatorParams(width_px=160, height_px=120)
    for params, corrects in ((OperatorParams(), True), (coarse, False)):
        operator = _operator_looking_at(scene, disc_drive_angles(scene, 3, -0.04), stroke_m=0.04, params=params)
        seen = operator.press_error_m(operator.camera.frames[-1], PRESS_M)
        assert seen > operator.tolerance_m  # off by more than he places to: corrected before
        if params is coarse:
            assert seen < operator.tolerance_m + operator.sighting.m_per_px
        assert (operator.review_press(5.0, 0.0, 3, PRESS_M) is True) is corrects, (params, seen, operator.log)
