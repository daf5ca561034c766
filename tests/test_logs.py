"""Logs: MCAP round trip and recovery after SIGKILL, the rerun recording read back by rerun's own
reader, `twin replay` on good, cut and corrupt files, the pictures."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import assets
from benchmarks.bench_logging import SUPPLY_PA, wrist_schedule
from twin.mcap_log import LogError, McapRecorder, read_mcap
from twin.plant import Plant
from twin.rerun_log import RerunRecorder
from twin.sim import run
from twin_cli.cli import main as twin_main
from twin_plumbing.errors import UserError

ROOT = Path(__file__).resolve().parents[1]
META = {
    "seed": 1234,
    "scenario_name": "logs_test",
    "scenario_path": "scenarios/x.toml",
    "scenario_text": 'name = "logs_test"\n[supply]\npressure_mpa = 0.6\n',
}


class Predicting:
    """A stand-in controller with a prediction and a target (a scaled copy of the schedule's
    time), so that the predicted/target channels carry numbers and NaN both."""

    def __init__(self, joints):
        self.schedule = wrist_schedule(joints)
        self.n = len(joints)
        self.t = 0.0
        self.events: list[str] = []  # reports, as the platform's controller writes them

    def tick(self, sensors):
        self.t = sensors.time_s
        if self.t >= 0.7 and not self.events:
            self.events += [f"t = {self.t:.3f} s: wrist_pitch at 1.00 deg (predicted), target 1.00 deg"]
            self.events += [f"t = {self.t:.3f} s: fault, all brakes engaged: supply lost"]
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
    assert (
        np.isnan(arrays["predicted_angle_rad"][:, 0]).all() and np.isfinite(arrays["predicted_angle_rad"][:, 3]).all()
    )
    # the wrist really moved, so the comparison is not between constants
    assert np.ptp(arrays["true_angle_rad"][:, 3]) > np.radians(5)
    assert meta["seed"] == 1234 and meta["scenario_text"] == META["scenario_text"]
    assert meta["versions"]["mcap"] and meta["versions"]["rerun-sdk"]
    assert meta["recovery"] == {
        "complete": True,
        "samples": len(telemetry),
        "duration_s": pytest.approx(1.5),
        "stopped_by": None,
    }


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
    assert sum(len(e.cylinders) for e in scene.entities) == types.count(int(G.mjGEOM_CYLINDER)) + types.count(
        int(G.mjGEOM_CAPSULE)
    )
    assert sum(len(e.cubes) for e in scene.entities) == types.count(int(G.mjGEOM_BOX)) + types.count(
        int(G.mjGEOM_PLANE)
    )


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
    expected |= {f"/world/string/disc_{i}" for i in range(1, 9)} | {
        "/world/arm/brush_head/brush",
        "/world/scene/floor",
    }  # the brush geom is on its spring-mounted head
    for j in telemetry.joints:
        expected |= {f"/joints/{j}/angle_deg/{s}" for s in ("true", "predicted", "target")}
        expected |= {
            f"/joints/{j}/error_deg/predicted_minus_true",
            f"/joints/{j}/pressure_bar/chamber_a",
            f"/joints/{j}/pressure_bar/chamber_b",
        }
        expected |= {
            f"/joints/{j}/valve/direction",
            f"/joints/{j}/valve/gauge_bar",
            f"/joints/{j}/brake/release",
            f"/joints/{j}/brake/engagement",
        }
    expected |= {"/supply/pressure_bar", "/brush/force_n"}
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
    np.testing.assert_array_equal(series["/supply/pressure_bar"][:, 1], a["supply_pa"] / 1e5)
    # one transform per body per sample: 50 per simulated second (>= 30 frames/s)
    assert len(a["time_s"]) / 1.5 >= 30


def test_replay_makes_a_recording(logged, tmp_path, capsys):
    tmp, telemetry = logged
    assert twin_main(["replay", str(tmp / "run.mcap"), "--rrd", str(tmp_path / "replayed.rrd")]) == 0
    assert "from the whole file" in capsys.readouterr().out
    paths, series, _ = rrd_entities(tmp_path / "replayed.rrd")
    assert "/world/arm/wrist" in paths and "/world/string/disc_8" in paths
    np.testing.assert_array_equal(
        series["/joints/wrist_pitch/angle_deg/true"][:, 1], np.degrees(telemetry.arrays()["true_angle_rad"][:, 3])
    )


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


@pytest.mark.parametrize(
    "content",
    [b"", b"this is not an mcap file\n", b"\x89MCAP0\r\n\x01\x05\x00\x00"],
    ids=["empty", "text", "header-only"],
)
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

    from twin.render import pose_geoms

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


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (a device that is always full)")
def test_a_full_disk_under_the_mcap_ends_the_run_in_one_line_and_keeps_the_rrd(tmp_path, capsys):
    """`--mcap /dev/full`: the writer fails when its file first reaches the disk (ENOSPC). The run
    stops at its next batch to the writer with one line naming the file and the cause, exit 2, and
    the .rrd keeps what was logged until then. The run's last flush (in a `finally`) wrote to the
    failed MCAP again and ended in a ValueError traceback. How far the run gets first depends on
    how far the writer process got (it runs beside the run): 3.5 s of the cleaning run on an idle
    machine, 2.5 s with two diagnoses on both cores, 10 s under a heavier load."""
    rrd = tmp_path / "run.rrd"
    scenario = Path(__file__).parent.parent / "scenarios" / "insulator_cleaning.toml"
    # 60 s: longer than the run gets before the writer's failure is seen, however busy the machine
    code = twin_main(["run", str(scenario), "--mcap", "/dev/full", "--rrd", str(rrd), "--duration", "60"])
    err = capsys.readouterr().err
    assert code == 2
    assert "/dev/full: the MCAP writer failed" in err and "No space left on device" in err
    assert "Traceback" not in err
    _, series, _ = rrd_entities(rrd)
    logged_until = max(float(v[-1, 0]) for v in series.values())
    print(f"\n.rrd logged until {logged_until} s; {err.strip()}")
    # at least the first batch (samples every 20 ms to 0.48 s, sent at 0.5 s), and the run stopped early
    assert 0.48 - 1e-9 <= logged_until < 60.0


def test_telemetry_blocks_give_back_what_was_appended():
    from twin.telemetry import SIGNALS, Telemetry

    joints, bodies = ("a", "b"), ("x", "y", "z")
    tel = Telemetry(joints, bodies, block=3)
    rng = np.random.default_rng(1)
    shape = {"n": 2, "b": 3}
    samples = [
        {k: rng.normal(size=tuple(shape.get(d, d) for d in dims)) for k, dims in SIGNALS.items()} for _ in range(10)
    ]
    for i, s in enumerate(samples):
        tel.append(0.1 * i, s)
    assert len(tel) == 10 and tel.time_at(-1) == pytest.approx(0.9) and tel.time_at(4) == pytest.approx(0.4)
    for start in (0, 2, 3, 7, 10):
        a = tel.arrays(start)
        np.testing.assert_array_equal(a["time_s"], 0.1 * np.arange(start, 10))
        for k in SIGNALS:
            np.testing.assert_array_equal(
                a[k], np.array([s[k] for s in samples[start:]]).reshape((10 - start,) + a[k].shape[1:])
            )
    with pytest.raises(IndexError):
        tel.time_at(10)


def run_with_camera(recorder, path, fps: float = 4.0, shared: bool = False):
    """A 1 s run of the arm logged by `recorder` (RerunRecorder or McapRecorder) with camera
    frames; with `shared`, by both, sharing one camera feed (path without suffix)."""
    from twin.camera import FrameFeed

    plant = Plant(assets.SCENE_XML)
    plant.set_supply(SUPPLY_PA)
    if shared:
        feed = FrameFeed(plant.model, fps)
        recs = [
            cls(path.with_suffix(ext), plant.model, plant.joints, META, camera_fps=fps, frames=feed)
            for cls, ext in ((RerunRecorder, ".rrd"), (McapRecorder, ".mcap"))
        ]
    else:
        recs = [recorder(path, plant.model, plant.joints, META, camera_fps=fps)]
    try:
        run(plant, Predicting(plant.joints), 1.0, recorders=tuple(recs))
    finally:
        for rec in recs:
            rec.close()
    return recs[0]


def rrd_frames(path: Path) -> list[tuple[float, bytes]]:
    """The camera frames of a recording: (time s, JPEG bytes)."""
    import rerun as rr

    out = []
    for chunk in rr.chunk.RrdReader(path).stream():
        if chunk.entity_path.strip("/") == "world/camera/global_view" and not chunk.is_static:
            batch = chunk.to_record_batch()
            times = np.asarray(batch.column("time").cast("int64").to_numpy()) * 1e-9
            out += [
                (t, bytes(b[0])) for t, b in zip(times, batch.column("EncodedImage:blob").to_pylist(), strict=True) if b
            ]
    return sorted(out)


def assert_frames_at_ticks(times_s: np.ndarray, fps: float = 4.0) -> None:
    """One frame per 1/fps of a 1 s run: the first sample (every 20 ms) at or after each tick."""
    lag = times_s - np.arange(0.0, 1.0 + 1e-9, 1.0 / fps)
    assert len(times_s) == int(fps) + 1 and np.all((lag > -1e-9) & (lag < 0.02))


def test_recording_holds_camera_frames_or_says_why(tmp_path, capsys):
    """`camera_fps` frames of the global camera, rendered by twin.camera's process: where offscreen
    GL works, one JPEG per 1/fps simulated seconds at the right times; where it does not, none,
    and a note that names the reason."""
    rec = run_with_camera(RerunRecorder, tmp_path / "cam.rrd")
    frames = rrd_frames(tmp_path / "cam.rrd")
    if rec._camera.error:
        assert frames == [] and "no camera frames" in capsys.readouterr().err
    else:
        assert all(jpeg[:2] == b"\xff\xd8" for _, jpeg in frames)  # JPEG start-of-image
        assert_frames_at_ticks(np.array([t for t, _ in frames]))


def test_camera_without_a_working_backend_says_why():
    """A GL backend that cannot work: no frames, and the reason, from the child's own error."""
    from twin.camera import CameraProcess

    plant = Plant(assets.SCENE_XML)
    cam = CameraProcess(plant.model, backends=("no-such-backend",))
    cam.request(np.array([0.0]), plant.data.xpos[1:][None], plant.data.xquat[1:][None])
    assert cam.close() == []
    assert (
        cam.error.startswith("offscreen rendering failed (MUJOCO_GL=no-such-backend: ")
        and "MUJOCO_GL" in cam.error[40:]
    )


def test_ctrl_c_finishes_the_logs(tmp_path):
    """Ctrl-C in a terminal signals the whole foreground process group: the run stops with exit
    status 130 and a note, and its logs are finished, not cut (DESIGN rule 6), although the MCAP
    writer and the camera run in processes of their own."""
    text = (ROOT / "scenarios" / "insulator_cleaning.toml").read_text()
    long = tmp_path / "long.toml"
    longer, n = re.subn(r"(?m)^duration_s = [0-9.]+", "duration_s = 900.0", text)
    assert n == 1, "the cleaning scenario's duration_s line was not found"  # else the run may end first
    long.write_text(longer)
    mcap, rrd = tmp_path / "run.mcap", tmp_path / "run.rrd"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-m", "twin_cli.cli", "run", str(long), "--mcap", str(mcap), "--rrd", str(rrd)],
        cwd=ROOT,
        env=env,
        start_new_session=True,
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
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
    """The first 13 s of the cleaning task press the brush on the string: each sample in contact has
    its point on the disc's surface (rim or face, whichever the press meets) and a push into the
    disc along that surface's inward normal (MuJoCo's contact frame read the right way round), no
    smaller than the normal force; MCAP gives the vectors back exactly, and the recording draws one
    arrow per sample in contact."""
    from scenarios.runner import build_plant, run_scenario
    from scenarios.schema import load, with_overrides

    # reality = the nominal self, run by the predictor alone (deterministic, no operator): where it
    # lands (a rim or a face) is the run's business; the test checks that what is logged is on a
    # disc's surface and pushes into it
    scenario = with_overrides(
        load(ROOT / "scenarios" / "insulator_cleaning.toml"),
        {"reality.arm": "nominal", "control.strategy": "sensorless"},
    )
    plant = build_plant(scenario)
    recs = (
        McapRecorder(tmp_path / "c.mcap", plant.model, plant.joints, META),
        RerunRecorder(tmp_path / "c.rrd", plant.model, plant.joints, META),
    )
    try:
        a = run_scenario(scenario, recorders=recs, duration_s=13.0).telemetry.arrays()
    finally:
        for r in recs:
            r.close()
    touching = np.isfinite(a["brush_contact_m"][:, 0])
    assert touching.sum() >= 5 and np.all(a["brush_force_n"][~touching] == 0.0)
    p, push = a["brush_contact_m"][touching], a["brush_push_n"][touching]
    # the disc each point belongs to (cylinders, axes vertical, the string does not move): the
    # nearest centre; the sensorless press need not land on the disc it was aimed at
    discs = [plant.model.geom(f"disc_{k}") for k in range(1, 9)]
    centres = np.array([plant.data.geom_xpos[g.id] for g in discs])
    nearest = np.argmin(np.linalg.norm(p[:, None, :] - centres[None], axis=2), axis=1)
    centre, (radius, half) = centres[nearest], discs[0].size[:2]  # the eight are alike (scene.xml)
    assert all(np.array_equal(g.size, discs[0].size) for g in discs)
    radial = np.hypot(p[:, 0] - centre[:, 0], p[:, 1] - centre[:, 1])
    height = p[:, 2] - centre[:, 2]
    # on the surface: MuJoCo's contact point sits mid-penetration, millimetres from it
    off_rim, off_face = radial - radius, np.abs(height) - half
    assert np.all(np.abs(np.maximum(off_rim, off_face)) < 0.005), (off_rim.max(), off_face.max())
    # the inward normals of the surfaces each point is on: the rim's, the top or bottom face's, or
    # both where it sits on the edge between them (within 5 mm of each; there the contact's normal
    # may point anywhere between the two: with the wrist's counterbalance the sensorless press lands
    # on disc 2's top edge, pushing at ~45 deg)
    on_rim, on_face = off_rim > off_face - 0.005, off_face > off_rim - 0.005
    rim_normal, face_normal = np.zeros_like(p), np.zeros_like(p)
    rim_normal[on_rim, :2] = (centre[on_rim, :2] - p[on_rim, :2]) / radial[on_rim, None]
    face_normal[on_face, 2] = -np.sign(height[on_face])
    inward = np.einsum("ij,ij->i", push, rim_normal) + np.einsum("ij,ij->i", push, face_normal)
    # the brush pushes the disc away from it: into the surface it touches, nearly always, and mostly
    # along its normal, or inside the edge's cone of normals (the spring-mounted head's first touch
    # can bounce: one sample in 28 pushed outward at 13 s)
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


def test_mcap_starts_at_its_declared_epoch_with_units_in_its_schemas(logged):
    """Log times are the fixed start (recorded in the metadata) plus simulated time, not 1970; every
    JSON field's description names its unit."""
    import datetime as dt
    import json as json_

    from mcap.reader import make_reader

    from twin.mcap_log import START_TIME_NS

    tmp, telemetry = logged
    with open(tmp / "run.mcap", "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        meta = {m.name: m.metadata for m in reader.iter_metadata()}["twin"]
        first = next(msg for _, ch, msg in reader.iter_messages(topics=["/joint_states/true"]))
    assert json_.loads(meta["start_time_utc"]) == "2000-01-01T00:00:00Z"
    assert dt.datetime.fromtimestamp(START_TIME_NS / 1e9, dt.UTC) == dt.datetime(2000, 1, 1, tzinfo=dt.UTC)
    assert summary.statistics.message_start_time >= START_TIME_NS
    assert first.log_time == START_TIME_NS + round(telemetry.time_at(0) * 1e9)
    assert summary.statistics.message_end_time == START_TIME_NS + round(telemetry.time_at(-1) * 1e9)
    units = (
        ", Pa absolute",
        ", Pa gauge",
        ", bar absolute",
        ", bar gauge",
        ", rad",
        ", deg",
        ", s",
        ", N",
        ", m",
        "dimensionless",
    )
    for schema in summary.schemas.values():
        if schema.encoding == "jsonschema":
            for name, prop in json_.loads(schema.data)["properties"].items():
                assert any(u in prop["description"] for u in units) and prop["description"] != name, (schema.name, name)


def test_mcap_holds_camera_frames_as_compressed_images_or_says_why(tmp_path, capsys):
    """With `camera_fps` the MCAP gets the global camera's JPEG frames as foxglove.CompressedImage,
    one per 1/fps simulated seconds, in time order; where offscreen GL fails, none and a note."""
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from mcap.reader import make_reader

    from twin.mcap_log import CAMERA_TOPIC, START_TIME_NS

    rec = run_with_camera(McapRecorder, tmp_path / "cam.mcap")
    with open(tmp_path / "cam.mcap", "rb") as f:
        messages = make_reader(f).iter_messages(topics=[CAMERA_TOPIC])
        frames = [(msg.log_time, CompressedImage.FromString(msg.data), sch.name) for sch, _, msg in messages]
    if rec._camera.error:
        assert frames == [] and "no camera frames" in capsys.readouterr().err
        return
    assert {s for *_, s in frames} == {"foxglove.CompressedImage"}
    assert_frames_at_ticks((np.array([ns for ns, *_ in frames]) - START_TIME_NS) * 1e-9)  # in time order
    assert all(img.format == "jpeg" and img.data[:2] == b"\xff\xd8" for _, img, _ in frames)
    assert read_mcap(tmp_path / "cam.mcap")[1]["recovery"]["complete"]  # frames do not disturb the reader


def test_shipped_foxglove_layout_is_current_and_reads_logged_channels(logged):
    """assets/foxglove_layout.json is what twin.foxglove_layout makes, and every channel it reads
    is one a log has; every field it plots is one its channel's schema declares, in the units the
    rerun recording shows (degrees and bar, not radians and pascals); its tabs name the log's joints."""
    import json as json_
    import re

    from mcap.reader import make_reader

    from twin.foxglove_layout import LAYOUT_PATH, layout, topics_used
    from twin.mcap_log import CAMERA_TOPIC

    shipped = json_.loads(LAYOUT_PATH.read_text())
    assert shipped == json_.loads(json_.dumps(layout())), "regenerate: python -m twin.foxglove_layout"
    tmp, telemetry = logged
    with open(tmp / "run.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    topics = {c.topic for c in summary.channels.values()}
    assert topics_used(shipped) <= topics | {CAMERA_TOPIC}
    fields = {
        c.topic: json_.loads(summary.schemas[c.schema_id].data)["properties"]
        for c in summary.channels.values()
        if summary.schemas[c.schema_id].encoding == "jsonschema"
    }
    plotted = [p["value"] for panel in shipped["configById"].values() for p in panel.get("paths", [])]
    for path in plotted:
        topic, field = path.split(".", 1)
        unit = fields[topic][field]["description"]
        assert ", rad" not in unit and ", Pa" not in unit, (path, unit)
    units = " ".join(fields[p.split(".", 1)[0]][p.split(".", 1)[1]]["description"] for p in plotted)
    assert ", deg" in units and ", bar absolute" in units and ", bar gauge" in units
    named = set(re.findall(r"^/joint/(\w+)\.", "\n".join(plotted), flags=re.M))
    assert named == set(telemetry.joints)
    assert "foxglove_layout.json" in (ROOT / "pyproject.toml").read_text().replace('"*.json"', "foxglove_layout.json")


def test_rerun_floor_is_mujocos_texture_and_the_payload_is_hidden_as_in_mujoco(logged):
    """The floor carries MuJoCo's own checker texture (tinted by its material, repeated as MuJoCo
    repeats it), and geoms of groups MuJoCo hides by default are left out of the 3D view."""
    import mujoco
    import rerun as rr

    from twin.rerun_log import blueprint, geom_texture, hidden_geom_paths

    tmp, _ = logged
    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    floor = None
    for chunk in rr.chunk.RrdReader(tmp / "run.rrd").stream():
        if chunk.entity_path == "/world/scene/floor":
            batch = chunk.to_record_batch()
            if "Mesh3D:albedo_texture_buffer" in batch.schema.names:
                floor = batch
    assert floor is not None, "the floor is not a textured mesh"
    texture = np.frombuffer(bytes(floor.column("Mesh3D:albedo_texture_buffer").to_pylist()[0][0]), dtype=np.uint8)
    g = m.geom("floor").id
    tex = m.mat_texid[m.geom_matid[g], int(mujoco.mjtTextureRole.mjTEXROLE_RGB)]
    np.testing.assert_array_equal(
        texture, m.tex_data[m.tex_adr[tex] : m.tex_adr[tex] + m.tex_height[tex] * m.tex_width[tex] * 3]
    )
    image, repeat = geom_texture(m, g)
    assert len(floor.column("Mesh3D:vertex_positions").to_pylist()[0]) == 4 * int(np.prod(repeat))  # a quad per repeat
    hidden = hidden_geom_paths(m)
    assert hidden and all(m.geom(p.rsplit("/", 1)[1]).group >= 3 for p in hidden)
    assert "world/arm/payload/payload" in hidden  # group 3 in arm.xml
    arm_view = blueprint(assets.JOINTS, m, "elbow_pitch").root_container.contents[0].contents[0]
    assert [f"- {p}" for p in hidden] == [str(c) for c in arm_view.contents][1:]


def test_rerun_series_are_distinct_on_the_dark_theme(logged):
    """True and predicted angles (static SeriesLines in the recording) both stand out from the
    viewer's dark background and from each other (contrast ratio, WCAG's formula)."""
    import rerun as rr

    tmp, _ = logged
    colors = {}
    for chunk in rr.chunk.RrdReader(tmp / "run.rrd").stream():
        path = chunk.entity_path
        if chunk.is_static and path.startswith("/joints/wrist_pitch/angle_deg/"):
            batch = chunk.to_record_batch()
            if "SeriesLines:colors" in batch.schema.names:
                c = batch.column("SeriesLines:colors").to_pylist()[0][0]  # packed 0xRRGGBBAA
                colors[path.rsplit("/", 1)[1]] = np.array([(c >> 24) & 255, (c >> 16) & 255, (c >> 8) & 255]) / 255

    def luminance(rgb):
        lin = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        return float(lin @ [0.2126, 0.7152, 0.0722])

    def contrast(a, b):
        hi, lo = sorted((luminance(a), luminance(b)), reverse=True)
        return (hi + 0.05) / (lo + 0.05)

    background = np.array([13, 16, 17]) / 255  # rerun's dark plot background
    assert set(colors) == {"true", "predicted", "target"}
    for name, rgb in colors.items():
        assert contrast(rgb, background) >= 4.5, name  # WCAG AA for text: clearly visible
    assert np.abs(colors["true"] - colors["predicted"]).max() > 0.5  # different hues, not shades


def test_recording_opens_on_the_joint_the_plan_moves():
    from twin.rerun_log import most_travelled_joint, moving_joint

    joints = ("base_yaw", "shoulder_pitch", "elbow_pitch")
    start = np.radians([0.0, 90.0, -30.0])
    plan = [{"base_yaw": np.radians(10.0), "elbow_pitch": np.radians(30.0)}, {"elbow_pitch": np.radians(0.0)}]
    assert moving_joint(joints, start, plan) == "elbow_pitch"  # 60 + 30 deg against 10 deg
    assert moving_joint(joints, start, []) == "base_yaw"
    true = np.radians([[0.0, 90.0, -30.0], [5.0, 80.0, -30.0], [0.0, 70.0, -30.0]])
    assert most_travelled_joint(joints, true) == "shoulder_pitch"


def test_the_real_viewer_shows_the_recording(logged, tmp_path):
    """A screenshot of the rerun viewer itself on the recording (software Vulkan without a GPU):
    its plot of the wrist's angles shows the orange prediction band and the white true line on
    the dark background. Skipped where the viewer cannot run (no xvfb, no Vulkan driver)."""
    from twin.screenshot import missing_requirements, screenshot

    reason = missing_requirements()
    if reason:
        pytest.skip(f"the rerun viewer cannot run here: {reason}")
    tmp, _ = logged
    shot = screenshot(tmp / "run.rrd", tmp_path / "shot.png", size="1000x640")
    import matplotlib.image as mpimg

    img = mpimg.imread(shot)[..., :3]
    h, w, _ = img.shape
    plots = img[: h // 2, w // 2 :]  # the joint's angle plot: upper right
    orange = (plots[..., 0] > 0.85) & (np.abs(plots[..., 1] - 0.55) < 0.12) & (plots[..., 2] < 0.2)
    white = plots.min(axis=-1) > 0.9
    dark = plots.max(axis=-1) < 0.12
    assert dark.mean() > 0.4 and orange.sum() > 200 and white.sum() > 200


def test_both_logs_share_one_camera(tmp_path):
    """With both logs and a shared feed each frame is rendered once and lands in both."""
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from mcap.reader import make_reader

    from twin.mcap_log import CAMERA_TOPIC, START_TIME_NS

    rec = run_with_camera(None, tmp_path / "both", shared=True)
    if rec._camera.error:
        pytest.skip(f"no offscreen GL here: {rec._camera.error}")
    in_rrd = rrd_frames(tmp_path / "both.rrd")
    with open(tmp_path / "both.mcap", "rb") as f:
        messages = make_reader(f).iter_messages(topics=[CAMERA_TOPIC])
        in_mcap = [
            ((m.log_time - START_TIME_NS) * 1e-9, CompressedImage.FromString(m.data).data) for _, _, m in messages
        ]
    assert_frames_at_ticks(np.array([t for t, _ in in_rrd]))
    assert [b for _, b in in_rrd] == [b for _, b in in_mcap]
    np.testing.assert_allclose([t for t, _ in in_rrd], [t for t, _ in in_mcap], atol=1e-8)


def test_mcap_start_time_given_or_refused(tmp_path, capsys):
    """`--start-time` moves the MCAP's clock (and says where it came from); a time without its
    zone or a word is refused before the run, exit 2."""
    from mcap.reader import make_reader

    wrist = str(ROOT / "scenarios" / "wrist_closed_loop_60deg.toml")
    out = tmp_path / "t.mcap"
    assert twin_main(
        ["run", wrist, "--duration", "0.1", "--mcap", str(out), "--start-time", "2026-11-23T13:00:00Z"]
    ) in (0, 1)
    with open(out, "rb") as f:
        reader = make_reader(f)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}["twin"]
        start = reader.get_summary().statistics.message_start_time
    assert start == 1_795_438_800 * 10**9  # 2026-11-23T13:00:00Z
    assert "given: 2026-11-23T13:00:00Z" in meta["start_time_source"]
    for bad in ("yesterday", "2026-11-23T13:00:00"):
        assert (
            twin_main(["run", wrist, "--duration", "0.1", "--mcap", str(tmp_path / "u.mcap"), "--start-time", bad]) == 2
        )
        assert "--start-time" in capsys.readouterr().err and not (tmp_path / "u.mcap").exists()


def test_start_time_without_mcap_is_refused(tmp_path, capsys):
    """`--start-time` sets only the MCAP's clock: without --mcap a bad one is refused as with it,
    and a good one is refused too (it would do nothing), before the run."""
    wrist = str(ROOT / "scenarios" / "wrist_closed_loop_60deg.toml")
    cases = [
        (["--start-time", "garbage"], "expected 'now' or an ISO 8601 time"),
        (["--start-time", "now", "--rrd", str(tmp_path / "r.rrd")], "no --mcap is asked for"),
    ]
    for flags, needle in cases:
        assert twin_main(["run", wrist, "--duration", "0.1", *flags]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "--start-time" in err and needle in err, err
    assert not (tmp_path / "r.rrd").exists()


def test_replay_carries_the_camera_frames_of_a_log(tmp_path):
    """Frames in an MCAP log come back in the recording `twin replay` makes, at their times."""
    rec = run_with_camera(McapRecorder, tmp_path / "cam.mcap")
    if rec._camera.error:
        pytest.skip(f"no offscreen GL here: {rec._camera.error}")
    _, meta = read_mcap(tmp_path / "cam.mcap", frames=True)
    assert twin_main(["replay", str(tmp_path / "cam.mcap"), "--rrd", str(tmp_path / "cam.rrd")]) == 0
    replayed = rrd_frames(tmp_path / "cam.rrd")
    assert [b for _, b in replayed] == [b for _, b in meta["camera_frames"]]
    np.testing.assert_allclose([t for t, _ in replayed], [t for t, _ in meta["camera_frames"]], atol=1e-8)
    assert_frames_at_ticks(np.array([t for t, _ in replayed]))


def test_mcap_with_camera_frames_is_deterministic(tmp_path):
    """Frames are written at close in time order, so when they were rendered does not matter:
    the same run gives the same file byte for byte, frames included (DESIGN rule 5)."""
    a = run_with_camera(McapRecorder, tmp_path / "a.mcap")
    if a._camera.error:
        pytest.skip(f"no offscreen GL here: {a._camera.error}")
    run_with_camera(McapRecorder, tmp_path / "b.mcap")
    assert len(read_mcap(tmp_path / "a.mcap", frames=True)[1]["camera_frames"]) == 5
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def expected_predicted_arm(telemetry) -> tuple[np.ndarray, np.ndarray]:
    """Body positions (T, b, 3) and orientations (T, b, 4, wxyz) of the arm at the logged
    predicted angles (the true one where a joint has no prediction), by MuJoCo from joint angles
    that scenarios.ik's inverse of the drive tendons gives (not twin.ghost's matrix)."""
    import mujoco

    from scenarios.ik import drive_to_qpos

    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    d = mujoco.MjData(m)
    a = telemetry.arrays()
    drive = np.where(np.isfinite(a["predicted_angle_rad"]), a["predicted_angle_rad"], a["true_angle_rad"])
    pos, quat = [], []
    for row in drive:
        d.qpos[:] = m.qpos0
        for joint, q in drive_to_qpos(dict(zip(telemetry.joints, row, strict=True))).items():
            d.joint(joint).qpos[0] = q
        mujoco.mj_kinematics(m, d)
        pos.append(d.xpos[1:].copy())
        quat.append(d.xquat[1:].copy())
    return np.array(pos), np.array(quat)


def rrd_transforms(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times s, translations, quaternions xyzw) an entity's Transform3D takes in a .rrd."""
    import rerun as rr

    rows = []
    for chunk in rr.chunk.RrdReader(path).stream():
        if chunk.entity_path == entity and not chunk.is_static:
            b = chunk.to_record_batch()
            t = np.asarray(b.column("time").cast("int64").to_numpy()) * 1e-9
            tr = [x[0] for x in b.column("Transform3D:translation").to_pylist()]
            q = [x[0] for x in b.column("Transform3D:quaternion").to_pylist()]
            rows += list(zip(t, tr, q, strict=True))
    rows.sort(key=lambda r: r[0])
    return np.array([r[0] for r in rows]), np.array([r[1] for r in rows]), np.array([r[2] for r in rows])


def test_rrd_draws_the_predicted_arm_at_the_predicted_angles(logged):
    """world/predicted_arm/<body> follows the controller's predicted angles (the wrist: 0.5 +
    0.1 t rad), not the true ones, translucent, and is a visible toggle of the 3D view."""
    import mujoco
    import rerun as rr

    from twin.rerun_log import GHOST_PATH, blueprint

    tmp, telemetry = logged
    pos, quat = expected_predicted_arm(telemetry)
    a = telemetry.arrays()
    for b, body in enumerate(telemetry.bodies):
        t, tr, q = rrd_transforms(tmp / "run.rrd", f"/{GHOST_PATH}/{body}")
        np.testing.assert_allclose(t, a["time_s"], atol=1e-8)
        np.testing.assert_allclose(tr, pos[:, b], atol=1e-6)
        np.testing.assert_allclose(np.abs(np.sum(q * np.roll(quat[:, b], -1, axis=1), axis=1)), 1.0, atol=1e-6)
    head = telemetry.bodies.index("brush_head")
    _, tr, _ = rrd_transforms(tmp / "run.rrd", f"/{GHOST_PATH}/brush_head")
    apart = np.linalg.norm(tr - a["body_pos_m"][:, head], axis=1)
    assert apart.max() > 0.05, "the predicted brush stands where the true one does: the ghost is the true arm"
    alphas = []
    for chunk in rr.chunk.RrdReader(tmp / "run.rrd").stream():
        if chunk.entity_path.startswith(f"/{GHOST_PATH}/") and chunk.is_static:
            batch = chunk.to_record_batch()
            alphas += [
                c[0] & 255 for n in batch.schema.names if n.endswith(":colors") for c in batch.column(n).to_pylist()
            ]
    assert alphas and max(alphas) < 128, "the predicted arm is not translucent"
    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    arm_view = blueprint(assets.JOINTS, m, "wrist_pitch").root_container.contents[0].contents[0]
    behaviour = arm_view.visualizer_overrides[GHOST_PATH]
    assert list(behaviour.visible.as_arrow_array().to_pylist()) == [True]


def test_mcap_has_the_predicted_arm_as_its_own_frames_and_scene(logged):
    """/tf/predicted puts frames predicted/<body> where the predicted angles put the bodies, and
    /scene/predicted draws the moving bodies in those frames, translucent."""
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from mcap.reader import make_reader

    tmp, telemetry = logged
    pos, _ = expected_predicted_arm(telemetry)
    with open(tmp / "run.mcap", "rb") as f:
        msgs = list(make_reader(f).iter_messages(topics=["/tf/predicted", "/scene/predicted"]))
    tfs = [FrameTransforms.FromString(m.data) for _, ch, m in msgs if ch.topic == "/tf/predicted"]
    (scene,) = [SceneUpdate.FromString(m.data) for _, ch, m in msgs if ch.topic == "/scene/predicted"]
    assert len(tfs) == len(telemetry)
    got = np.array([[(x.translation.x, x.translation.y, x.translation.z) for x in tf.transforms] for tf in tfs])
    assert [x.child_frame_id for x in tfs[0].transforms] == [f"predicted/{b}" for b in telemetry.bodies]
    np.testing.assert_allclose(got, pos, atol=1e-9)
    frames = {e.frame_id for e in scene.entities}
    assert frames and all(f.startswith("predicted/") for f in frames)
    assert all(c.color.a < 0.5 for e in scene.entities for c in e.cylinders)


def test_reports_are_a_text_log_and_foxglove_log_at_their_time(logged):
    """The controller's reports land in the .rrd's `events` (TextLog, with a level) and the MCAP's
    /events (foxglove.Log) at the simulated time the report names."""
    import rerun as rr
    from foxglove_schemas_protobuf.Log_pb2 import Log
    from mcap.reader import make_reader

    from twin.mcap_log import START_TIME_NS

    tmp, _ = logged
    texts = []
    for chunk in rr.chunk.RrdReader(tmp / "run.rrd").stream():
        if chunk.entity_path == "/events":
            b = chunk.to_record_batch()
            t = np.asarray(b.column("time").cast("int64").to_numpy()) * 1e-9
            texts += list(
                zip(
                    t,
                    [x[0] for x in b.column("TextLog:text").to_pylist()],
                    [x[0] for x in b.column("TextLog:level").to_pylist()],
                    strict=True,
                )
            )
    assert len(texts) == 2
    assert all(abs(t - 0.7) < 0.021 for t, _, _ in texts)
    assert texts[0][1].startswith("controller: wrist_pitch at") and texts[0][2] == "INFO"
    assert "brakes engaged" in texts[1][1] and texts[1][2] == "WARN"
    with open(tmp / "run.mcap", "rb") as f:
        logs = [(m.log_time, Log.FromString(m.data)) for _, _, m in make_reader(f).iter_messages(topics=["/events"])]
    assert [(lg.name, lg.level) for _, lg in logs] == [("controller", Log.INFO), ("controller", Log.WARNING)]
    assert [lg.message for _, lg in logs] == [text.removeprefix("controller: ") for _, text, _ in texts]
    assert all(abs((ns - START_TIME_NS) * 1e-9 - t) < 1e-6 for (ns, _), (t, _, _) in zip(logs, texts, strict=True))


def test_the_camera_stands_in_3d_where_mujoco_puts_it(logged):
    """The .rrd holds a pinhole at the global camera's pose and the MCAP a CameraCalibration and its
    optical frame: a point straight ahead of MuJoCo's camera lands on the image centre, a point
    above that ahead above the centre (image y grows down), both ways."""
    import mujoco
    import rerun as rr
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from mcap.reader import make_reader

    tmp, _ = logged
    m = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    cam = m.camera("global_view").id
    R = d.cam_xmat[cam].reshape(3, 3)  # columns: camera x (right), y (up), z (back) in the world
    ahead = d.cam_xpos[cam] - 2.0 * R[:, 2]
    above = ahead + 0.3 * R[:, 1]
    with open(tmp / "run.mcap", "rb") as f:
        msgs = {
            ch.topic: m_.data
            for _, ch, m_ in make_reader(f).iter_messages(topics=["/tf/camera", "/camera/global_view/calibration"])
        }
    cal = CameraCalibration.FromString(msgs["/camera/global_view/calibration"])
    (x,) = FrameTransforms.FromString(msgs["/tf/camera"]).transforms
    assert x.child_frame_id == cal.frame_id == "global_view" and (cal.width, cal.height) == (480, 360)
    R_opt = np.empty(9)
    mujoco.mju_quat2Mat(R_opt, np.array([x.rotation.w, x.rotation.x, x.rotation.y, x.rotation.z]))
    origin = np.array([x.translation.x, x.translation.y, x.translation.z])
    K = np.array(cal.K).reshape(3, 3)

    def pixel(p):
        ray = R_opt.reshape(3, 3).T @ (p - origin)
        uvw = K @ ray
        return uvw[:2] / uvw[2]

    np.testing.assert_allclose(pixel(ahead), [240, 180], atol=1e-6)
    u, v = pixel(above)
    fy = 180 / np.tan(np.radians(m.cam_fovy[cam]) / 2)
    assert abs(u - 240) < 1e-6 and v == pytest.approx(180 - fy * 0.3 / 2.0)
    pinhole = None
    for chunk in rr.chunk.RrdReader(tmp / "run.rrd").stream():
        if chunk.entity_path == "/world/camera/global_view" and chunk.is_static:
            pinhole = chunk.to_record_batch()
    assert pinhole is not None
    K_rr = np.array(pinhole.column("Pinhole:image_from_camera").to_pylist()[0][0]).reshape(3, 3).T  # column-major
    np.testing.assert_allclose(K_rr, K, rtol=1e-6)
    np.testing.assert_allclose(pinhole.column("Transform3D:translation").to_pylist()[0][0], d.cam_xpos[cam], atol=1e-6)


def test_mcap_display_fields_are_the_logged_values_in_degrees_and_bar(logged):
    """The fields the Foxglove layout plots are the telemetry in the rerun recording's units."""
    import json as json_

    from mcap.reader import make_reader

    tmp, telemetry = logged
    a = telemetry.arrays()
    with open(tmp / "run.mcap", "rb") as f:
        messages = list(make_reader(f).iter_messages(topics=["/joint/wrist_pitch", "/arm"]))
    rows = [json_.loads(m.data) for _, ch, m in messages if ch.topic == "/joint/wrist_pitch"]
    arm = [json_.loads(m.data) for _, ch, m in messages if ch.topic == "/arm"]
    k = telemetry.joints.index("wrist_pitch")
    col = {f: np.array([r[f] for r in rows], dtype=float) for f in rows[0]}
    np.testing.assert_allclose(col["angle_true_deg"], np.degrees(a["true_angle_rad"][:, k]))
    np.testing.assert_allclose(col["angle_predicted_deg"], np.degrees(a["predicted_angle_rad"][:, k]))
    np.testing.assert_allclose(col["pressure_a_bar"], a["pressure_a_pa"][:, k] / 1e5)
    np.testing.assert_allclose(col["valve_gauge_bar"], a["valve_gauge_pa"][:, k] / 1e5)
    np.testing.assert_allclose([r["supply_bar"] for r in arm], a["supply_pa"] / 1e5)


# rerun's own server, stopped by SIGTERM, leaves its saved file without the footer newer readers
# index by; the reader says so and scans the whole file, which is all this test needs
@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_run_streams_live_to_a_viewer_it_connects_to(tmp_path):
    """`twin run --connect ADDR` streams the recording to a running rerun gRPC server: here rerun's
    own, on 127.0.0.1 only, saving what arrives (`rerun --save`); what it saved is the run."""
    import shutil
    import socket

    import rerun as rr

    exe = shutil.which("rerun", path=str(Path(sys.executable).parent)) or shutil.which("rerun")
    if exe is None:
        pytest.skip("rerun's command line is not installed beside this Python")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    saved = tmp_path / "live.rrd"
    server = subprocess.Popen(
        [exe, "--port", str(port), "--bind", "127.0.0.1", "--save", str(saved)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # `rerun` is a wrapper that starts the viewer's binary: stop both together
    )
    try:
        deadline = time.monotonic() + 30
        while True:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            assert time.monotonic() < deadline and server.poll() is None, "the rerun server did not start"
            time.sleep(0.1)
        url = f"rerun+http://127.0.0.1:{port}/proxy"
        # arrives (an event) at 1.25 s
        assert twin_main(["run", "wrist_closed_loop_60deg", "--duration", "1.5", "--connect", url]) == 0
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)
    paths = {chunk.entity_path for chunk in rr.chunk.RrdReader(saved).stream()}
    assert {"/joints/wrist_pitch/angle_deg/predicted", "/world/predicted_arm/rig_load", "/events"} <= paths
