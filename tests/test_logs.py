"""Logs: MCAP round trip and recovery after SIGKILL, the rerun recording read back by rerun's own
reader, `twin replay` on good, cut and corrupt files, the pictures."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import assets
from benchmarks.bench_logging import SUPPLY_PA, wrist_schedule
from twin.cli import main as twin_main
from twin.errors import UserError
from twin.mcap_log import LogError, McapRecorder, read_mcap
from twin.plant import Plant
from twin.rerun_log import RerunRecorder
from twin.sim import run

ROOT = Path(__file__).resolve().parents[1]
META = {"seed": 1234, "scenario_name": "logs_test", "scenario_path": "scenarios/x.toml", "scenario_text": 'name = "logs_test"\n[supply]\npressure_mpa = 0.6\n'}


class Predicting:
    """A stand-in controller with a prediction and a target (a scaled copy of the schedule's
    time), so that the predicted/target channels carry numbers and NaN both."""

    def __init__(self, joints):
        self.schedule = wrist_schedule(joints)
        self.n = len(joints)
        self.t = 0.0

    def tick(self, sensors):
        self.t = sensors.time_s
        return self.schedule.tick(sensors)

    def predicted_angles(self):
        p = np.full(self.n, np.nan)
        p[3] = 0.5 + 0.1 * self.t  # wrist only: other joints have no prediction (NaN)
        return p

    def target_angles(self):
        return np.array([0.0, 0.1, -0.2, 1.0, np.nan])


def logged_run(tmp_path: Path, seconds: float, mcap=True, rrd=True, background=True):
    plant = Plant(assets.SCENE_XML)
    plant.set_supply(SUPPLY_PA)
    recorders = []
    if mcap:
        recorders.append(McapRecorder(tmp_path / "run.mcap", plant.model, plant.joints, META, background=background))
    if rrd:
        recorders.append(RerunRecorder(tmp_path / "run.rrd", plant.model, plant.joints, META))
    try:
        telemetry = run(plant, Predicting(plant.joints), seconds, recorders=tuple(recorders))
    finally:
        for r in recorders:
            r.close()
    return telemetry


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("logs")
    return tmp, logged_run(tmp, 1.5)


def test_mcap_round_trip_is_exact(logged):
    tmp, telemetry = logged
    arrays, meta = read_mcap(tmp / "run.mcap")
    expected = telemetry.arrays()
    assert set(arrays) == set(expected)
    for name, value in expected.items():
        assert arrays[name].shape == value.shape, name
        # bit-exact, NaN where NaN was logged
        assert np.array_equal(arrays[name], value, equal_nan=True), name
    assert np.isnan(arrays["predicted_angle_rad"][:, 0]).all() and np.isfinite(arrays["predicted_angle_rad"][:, 3]).all()
    # the wrist really moved, so the comparison is not between constants
    assert np.ptp(arrays["true_angle_rad"][:, 3]) > np.radians(5)
    assert meta["seed"] == 1234 and meta["scenario_text"] == META["scenario_text"]
    assert meta["versions"]["mcap"] and meta["versions"]["rerun-sdk"]
    assert meta["recovery"] == {"complete": True, "samples": len(telemetry), "duration_s": pytest.approx(1.5), "stopped_by": None}


def test_mcap_uses_foxglove_schemas(logged):
    from mcap.reader import make_reader

    tmp, _ = logged
    with open(tmp / "run.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    by_topic = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert by_topic["/joint_states/true"] == "foxglove.JointStates"
    assert by_topic["/joint_states/predicted"] == "foxglove.JointStates"
    assert by_topic["/tf"] == "foxglove.FrameTransforms"
    assert by_topic["/scene"] == "foxglove.SceneUpdate"
    assert "/joint/wrist_pitch" in by_topic and "/arm" in by_topic
    # the scene carries every drawable geom: a cylinder per cylinder or capsule, a cube per box/plane
    import mujoco
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    types = [int(t) for t in m.geom_type]
    G = mujoco.mjtGeom
    with open(tmp / "run.mcap", "rb") as f:
        scene = next(SceneUpdate.FromString(msg.data) for _, ch, msg in make_reader(f).iter_messages(topics=["/scene"]))
    assert sum(len(e.cylinders) for e in scene.entities) == types.count(int(G.mjGEOM_CYLINDER)) + types.count(int(G.mjGEOM_CAPSULE))
    assert sum(len(e.cubes) for e in scene.entities) == types.count(int(G.mjGEOM_BOX)) + types.count(int(G.mjGEOM_PLANE))


CHILD = """
import sys
import assets
from benchmarks.bench_logging import SUPPLY_PA, wrist_schedule
from twin.mcap_log import McapRecorder
from twin.plant import Plant
from twin.sim import run
plant = Plant(assets.SCENE_XML)
plant.set_supply(SUPPLY_PA)
rec = McapRecorder(sys.argv[1], plant.model, plant.joints, {"seed": 7, "scenario_text": "killed"})
run(plant, wrist_schedule(plant.joints), 120.0, recorders=(rec,))
"""


def test_sigkill_leaves_a_readable_mcap(tmp_path):
    n_s = 3.0
    path = tmp_path / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(path)], cwd=ROOT, env=env)
    try:
        deadline = time.monotonic() + 120
        seen = 0.0
        while seen < n_s:
            assert proc.poll() is None, "the child run ended before it was killed"
            assert time.monotonic() < deadline, "the child never logged 3 s"
            time.sleep(0.2)
            if path.exists():
                try:
                    seen = read_mcap(path)[1]["recovery"]["duration_s"]
                except LogError:
                    seen = 0.0  # header not yet flushed
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    arrays, meta = read_mcap(path)
    rec = meta["recovery"]
    assert not rec["complete"]
    assert rec["duration_s"] >= n_s - 1.0
    assert rec["samples"] == len(arrays["time_s"]) and meta["seed"] == 7
    # what was recovered is what the run computed: rerun the same thing and compare the prefix
    plant = Plant(assets.SCENE_XML)
    plant.set_supply(SUPPLY_PA)
    again = run(plant, wrist_schedule(plant.joints), float(arrays["time_s"][-1]) + 0.02).arrays()
    m = rec["samples"]
    for name in ("time_s", "true_angle_rad", "pressure_a_pa", "body_quat_wxyz"):
        np.testing.assert_array_equal(arrays[name], again[name][:m], err_msg=name)


def rrd_entities(path: Path) -> tuple[set[str], dict[str, np.ndarray], list]:
    """Entity paths and the scalar series of a .rrd, read with rerun's own reader."""
    import rerun as rr

    reader = rr.chunk.RrdReader(path)
    paths, series = set(), {}
    for chunk in reader.stream():
        paths.add(chunk.entity_path)
        batch = chunk.to_record_batch()
        if "Scalars:scalars" in batch.schema.names and not chunk.is_static:
            t = np.asarray(batch.column("time").cast("int64").to_numpy()) * 1e-9
            v = np.array([x[0] for x in batch.column("Scalars:scalars").to_pylist()])
            old = series.get(chunk.entity_path, np.empty((0, 2)))
            series[chunk.entity_path] = np.vstack([old, np.column_stack([t, v])])
    return paths, {k: v[np.argsort(v[:, 0], kind="stable")] for k, v in series.items()}, reader.blueprints()


def test_rrd_holds_the_entities(logged):
    tmp, telemetry = logged
    paths, series, blueprints = rrd_entities(tmp / "run.rrd")
    expected = {f"/world/arm/{b}" for b in telemetry.bodies}
    expected |= {f"/world/string/disc_{i}" for i in range(1, 9)} | {"/world/arm/brush_head/brush", "/world/scene/floor"}  # the brush geom is on its spring-mounted head
    for j in telemetry.joints:
        expected |= {f"/joints/{j}/angle_deg/{s}" for s in ("true", "predicted", "target")}
        expected |= {f"/joints/{j}/error_deg/predicted_minus_true", f"/joints/{j}/pressure_pa/chamber_a", f"/joints/{j}/pressure_pa/chamber_b"}
        expected |= {f"/joints/{j}/valve/direction", f"/joints/{j}/valve/gauge_pa", f"/joints/{j}/brake/release", f"/joints/{j}/brake/engagement"}
    expected |= {"/supply/pressure_pa", "/brush/force_n"}
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    geoms = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(m.ngeom)}
    assert geoms <= {p.rsplit("/", 1)[1] for p in paths if p.startswith("/world/")}, "a geom of the model is missing"
    expected |= {"/world/arm/upper_arm/upper_arm", "/world/arm/base/pedestal", "/world/arm/forearm/shed_1"}
    assert expected <= paths, sorted(expected - paths)
    assert blueprints, "the recording carries no blueprint"
    a = telemetry.arrays()
    true = series["/joints/wrist_pitch/angle_deg/true"]
    np.testing.assert_allclose(true[:, 0], a["time_s"], atol=1e-8)
    np.testing.assert_array_equal(true[:, 1], np.degrees(a["true_angle_rad"][:, 3]))
    err = series["/joints/wrist_pitch/error_deg/predicted_minus_true"][:, 1]
    np.testing.assert_allclose(err, np.degrees(a["predicted_angle_rad"][:, 3]) - np.degrees(a["true_angle_rad"][:, 3]))
    np.testing.assert_array_equal(series["/supply/pressure_pa"][:, 1], a["supply_pa"])
    # one transform per body per sample: 50 per simulated second (>= 30 frames/s)
    assert len(a["time_s"]) / 1.5 >= 30


def test_replay_makes_a_recording(logged, tmp_path, capsys):
    tmp, telemetry = logged
    assert twin_main(["replay", str(tmp / "run.mcap"), "--rrd", str(tmp_path / "replayed.rrd")]) == 0
    assert "from the whole file" in capsys.readouterr().out
    paths, series, _ = rrd_entities(tmp_path / "replayed.rrd")
    assert "/world/arm/wrist" in paths and "/world/string/disc_8" in paths
    np.testing.assert_array_equal(series["/joints/wrist_pitch/angle_deg/true"][:, 1], np.degrees(telemetry.arrays()["true_angle_rad"][:, 3]))


def test_replay_of_a_cut_file_says_how_much(logged, tmp_path, capsys):
    tmp, telemetry = logged
    data = (tmp / "run.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    assert twin_main(["replay", str(cut), "--rrd", str(tmp_path / "cut.rrd")]) == 0
    out = capsys.readouterr().out
    assert "cut short" in out
    arrays, meta = read_mcap(cut)
    m = meta["recovery"]["samples"]
    assert 0 < m < len(telemetry)
    np.testing.assert_array_equal(arrays["true_angle_rad"], telemetry.arrays()["true_angle_rad"][:m])


@pytest.mark.parametrize("content", [b"", b"this is not an mcap file\n", b"\x89MCAP0\r\n\x01\x05\x00\x00"], ids=["empty", "text", "header-only"])
def test_replay_of_a_bad_file_is_a_user_error(tmp_path, capsys, content):
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(content)
    with pytest.raises(LogError) as info:
        read_mcap(bad)
    assert isinstance(info.value, UserError) and str(bad) in str(info.value)
    assert twin_main(["replay", str(bad), "--rrd", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("twin: error:") and "Traceback" not in err


def test_replay_of_a_missing_file_and_view_of_a_bad_rrd(tmp_path, capsys):
    assert twin_main(["replay", str(tmp_path / "none.mcap"), "--rrd", str(tmp_path / "x.rrd")]) == 2
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(b"nope")
    assert twin_main(["view", str(bad)]) == 2
    assert "not a readable rerun recording" in capsys.readouterr().err


def test_angle_plot(logged, tmp_path):
    from twin.pictures import plot_angles_png

    _, telemetry = logged
    out = plot_angles_png(telemetry.arrays(), tmp_path / "angles.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_arm_picture_without_gl_falls_back(tmp_path, monkeypatch):
    """The matplotlib fallback (no GL backend) still draws the arm: forced by a bogus backend."""
    from twin.pictures import render_arm_png

    monkeypatch.setenv("MUJOCO_GL", "no-such-backend")
    used = render_arm_png(tmp_path / "arm.png", width=160, height=120)
    assert used == "matplotlib"
    assert (tmp_path / "arm.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_body_poses_place_every_geom_as_mujoco_does(logged):
    """The log's body poses plus each geom's pose in its body (what the rerun entities chain)
    put every geom where MuJoCo's own kinematics put it."""
    import mujoco

    from twin.pictures import pose_geoms

    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    plant = Plant(assets.SCENE_XML)
    plant.set_supply(SUPPLY_PA)
    telemetry = run(plant, wrist_schedule(plant.joints), 0.6)
    a = telemetry.arrays()
    d = mujoco.MjData(m)
    pose_geoms(m, d, a["body_pos_m"][-1], a["body_quat_wxyz"][-1])
    arm = m.geom_bodyid > 0
    np.testing.assert_allclose(d.geom_xpos[arm], plant.data.geom_xpos[arm], atol=1e-12)
    np.testing.assert_allclose(d.geom_xmat[arm], plant.data.geom_xmat[arm], atol=1e-12)


def test_mcap_is_deterministic(tmp_path):
    """Same run, same metadata: byte-identical MCAP files (DESIGN rule 5), whether the writer
    process or the run's own process encodes them."""
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir(), (tmp_path / "c").mkdir()
    logged_run(tmp_path / "a", 0.5, rrd=False)
    logged_run(tmp_path / "b", 0.5, rrd=False)
    logged_run(tmp_path / "c", 0.5, rrd=False, background=False)
    a = (tmp_path / "a" / "run.mcap").read_bytes()
    assert a == (tmp_path / "b" / "run.mcap").read_bytes() == (tmp_path / "c" / "run.mcap").read_bytes()


def test_a_failing_mcap_writer_is_a_log_error(tmp_path):
    """The writer process's failure reaches the run as a LogError naming the file."""
    plant = Plant(assets.SCENE_XML)
    rec = McapRecorder(tmp_path / "run.mcap", plant.model, plant.joints, META)
    rec._proc.kill()  # the writer dies under the run
    rec._proc.wait()
    telemetry = run(plant, Predicting(plant.joints), 0.1)
    with pytest.raises(LogError, match="run.mcap: the MCAP writer failed"):
        for _ in range(50):  # the pipe may take a few writes to report that nobody reads it
            rec.write(telemetry, 0)
    rec.close()  # nothing more to do, no second error


def test_telemetry_blocks_give_back_what_was_appended():
    from twin.telemetry import SIGNALS, Telemetry

    joints, bodies = ("a", "b"), ("x", "y", "z")
    tel = Telemetry(joints, bodies, block=3)
    rng = np.random.default_rng(1)
    shape = {"n": 2, "b": 3}
    samples = [{k: rng.normal(size=tuple(shape.get(d, d) for d in dims)) for k, dims in SIGNALS.items()} for _ in range(10)]
    for i, s in enumerate(samples):
        tel.append(0.1 * i, s)
    assert len(tel) == 10 and tel.time_at(-1) == pytest.approx(0.9) and tel.time_at(4) == pytest.approx(0.4)
    for start in (0, 2, 3, 7, 10):
        a = tel.arrays(start)
        np.testing.assert_array_equal(a["time_s"], 0.1 * np.arange(start, 10))
        for k in SIGNALS:
            np.testing.assert_array_equal(a[k], np.array([s[k] for s in samples[start:]]).reshape((10 - start,) + a[k].shape[1:]))
    with pytest.raises(IndexError):
        tel.time_at(10)


def test_recording_holds_camera_frames_or_says_why(tmp_path, capsys):
    """`camera_fps` frames of the global camera, rendered by twin.camera's process: where offscreen
    GL works, one JPEG per 1/fps simulated seconds at the right times; where it does not, none,
    and a note that names the reason."""
    plant = Plant(assets.SCENE_XML)
    plant.set_supply(SUPPLY_PA)
    rec = RerunRecorder(tmp_path / "cam.rrd", plant.model, plant.joints, META, camera_fps=4.0)
    try:
        run(plant, Predicting(plant.joints), 1.0, recorders=(rec,))
    finally:
        rec.close()
    import rerun as rr

    times = []
    for chunk in rr.chunk.RrdReader(tmp_path / "cam.rrd").stream():
        if chunk.entity_path.strip("/") == "camera/global_view" and not chunk.is_static:
            batch = chunk.to_record_batch()
            times += list(np.asarray(batch.column("time").cast("int64").to_numpy()) * 1e-9)
            blobs = [b[0] for b in batch.column("EncodedImage:blob").to_pylist() if b]  # one blob per row
            assert blobs and all(bytes(b[:2]) == b"\xff\xd8" for b in blobs)  # JPEG start-of-image
    if rec._camera.error:
        assert times == [] and "no camera frames" in capsys.readouterr().err
    else:
        lag = np.sort(times) - np.arange(0.0, 1.0 + 1e-9, 0.25)  # the first sample (every 20 ms) at or after each tick
        assert len(times) == 5 and np.all((lag > -1e-9) & (lag < 0.02))


def test_camera_without_a_working_backend_says_why():
    """A GL backend that cannot work: no frames, and the reason, from the child's own error."""
    from twin.camera import CameraProcess

    plant = Plant(assets.SCENE_XML)
    cam = CameraProcess(plant.model, backends=("no-such-backend",))
    cam.request(np.array([0.0]), plant.data.xpos[1:][None], plant.data.xquat[1:][None])
    assert cam.close() == []
    assert cam.error.startswith("offscreen rendering failed (MUJOCO_GL=no-such-backend: ") and "MUJOCO_GL" in cam.error[40:]


def test_ctrl_c_finishes_the_logs(tmp_path):
    """Ctrl-C in a terminal signals the whole foreground process group: the run stops with exit
    status 130 and a note, and its logs are finished, not cut (DESIGN rule 6), although the MCAP
    writer and the camera run in processes of their own."""
    text = (ROOT / "scenarios" / "insulator_cleaning.toml").read_text()
    long = tmp_path / "long.toml"
    long.write_text(text.replace("duration_s = 90.0", "duration_s = 900.0"))
    mcap, rrd = tmp_path / "run.mcap", tmp_path / "run.rrd"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-m", "twin.cli", "run", str(long), "--mcap", str(mcap), "--rrd", str(rrd)],
        cwd=ROOT, env=env, start_new_session=True, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as an interactive shell leaves it
    )
    try:
        deadline = time.monotonic() + 120
        seen = 0.0
        while seen < 2.0:
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.2)
            try:
                seen = read_mcap(mcap)[1]["recovery"]["duration_s"] if mcap.exists() else 0.0
            except LogError:
                seen = 0.0
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130 and "interrupted; the logs written so far are kept" in err.decode()
    arrays, meta = read_mcap(mcap)
    assert meta["recovery"]["complete"] and meta["recovery"]["duration_s"] >= 2.0
    paths, _, _ = rrd_entities(rrd)
    assert any(p.strip("/").startswith("joints/") for p in paths)


def test_brush_contact_is_logged_where_and_how_hard_it_pushes(tmp_path):
    """The first 13 s of the cleaning task press the brush on disc 1: each sample in contact has
    its point on the disc's rim and a push into the disc (MuJoCo's contact frame read the right way
    round), no smaller than the normal force; MCAP gives the vectors back exactly, and the
    recording draws one arrow per sample in contact."""
    from scenarios.runner import build_plant, run_scenario
    from scenarios.schema import load

    scenario = load(ROOT / "scenarios" / "insulator_cleaning.toml")
    plant = build_plant(scenario)
    recs = (McapRecorder(tmp_path / "c.mcap", plant.model, plant.joints, META), RerunRecorder(tmp_path / "c.rrd", plant.model, plant.joints, META))
    try:
        a = run_scenario(scenario, recorders=recs, duration_s=13.0).telemetry.arrays()
    finally:
        for r in recs:
            r.close()
    touching = np.isfinite(a["brush_contact_m"][:, 0])
    assert touching.sum() >= 5 and np.all(a["brush_force_n"][~touching] == 0.0)
    g = plant.model.geom("disc_1")
    centre, radius = plant.data.geom_xpos[g.id], g.size[0]  # the string does not move
    p, push = a["brush_contact_m"][touching], a["brush_push_n"][touching]
    radial = np.hypot(p[:, 0] - centre[0], p[:, 1] - centre[1])
    assert np.all(np.abs(radial - radius) < 0.01) and np.all(np.abs(p[:, 2] - centre[2]) < 0.02)
    inward = np.einsum("ij,ij->i", push[:, :2], (centre[:2] - p[:, :2]) / radial[:, None])
    # the brush pushes the disc away from it: inward always, and mostly so once pressed (the first
    # touch lands on the rim's top edge, so it pushes down as well)
    # (the spring-mounted head's first touch can bounce: one sample in 28 pushes outward at 13 s)
    assert np.mean(inward > 0) > 0.9 and np.median(inward / np.linalg.norm(push, axis=1)) > 0.9
    assert np.all(np.linalg.norm(push, axis=1) >= a["brush_force_n"][touching] - 1e-9)
    back, _ = read_mcap(tmp_path / "c.mcap")
    for name in ("brush_contact_m", "brush_push_n"):
        assert np.array_equal(back[name], a[name], equal_nan=True), name
    import rerun as rr

    arrows = 0
    for chunk in rr.chunk.RrdReader(tmp_path / "c.rrd").stream():
        if chunk.entity_path.strip("/") == "world/brush_contact":
            arrows += sum(len(v or []) for v in chunk.to_record_batch().column("Arrows3D:vectors").to_pylist())
    assert arrows == touching.sum()
