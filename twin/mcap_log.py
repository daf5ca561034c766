"""MCAP log of a run: the telemetry as channels Foxglove plots without set-up, and a reader back
to numpy arrays (the gap diagnosis reads measured and simulated runs with it).

Channels, one message per telemetry sample (50 per simulated second), `sequence` = sample index:

    /joint_states/true       foxglove.JointStates   position = true drive angle, rad
    /joint_states/predicted  foxglove.JointStates   position = controller's predicted angle, rad
    /joint_states/target     foxglove.JointStates   position = set point, rad (NaN: none)
    /tf                      foxglove.FrameTransforms  world -> <body>, one per body
    /scene                   foxglove.SceneUpdate   each body's geoms, once, frame-locked
    /tf/predicted            foxglove.FrameTransforms  world -> predicted/<body>: the arm at the
                                   controller's predicted angles (twin.ghost), samples that have one
    /scene/predicted         foxglove.SceneUpdate   the moving bodies' geoms in predicted/<body>,
                                   translucent orange, once (with the first predicted pose)
    /joint/<joint>           JSON  pressure_a_pa, pressure_b_pa (abs), valve_gauge_pa, direction,
                                   brake_release, brake_engagement, predicted_minus_true_rad; and
                                   for the plots, in the units the rerun recording shows: angle_
                                   {true,predicted,target}_deg, predicted_minus_true_deg,
                                   pressure_{a,b}_bar (abs), valve_gauge_bar
    /arm                     JSON  time_s, supply_pa (abs), brush_force_n, brush_contact_{x,y,z}_m
                                   (world, null: no contact), brush_push_{x,y,z}_n (world), supply_bar
    /events                  foxglove.Log   the controller's and the operator's reports (twin.events)
    /tf/camera               foxglove.FrameTransforms  world -> global_view (the camera's optical
                                   frame, x right, y down, z forward), once at the start
    /camera/global_view/calibration  foxglove.CameraCalibration  its pinhole, once at the start
    /camera/global_view      foxglove.CompressedImage  JPEG frames of the scene's global camera
                                   (`camera_fps` > 0 and offscreen GL works), written at close

Times: a message's log time is the run's start plus its simulated time. The start is fixed,
START_TIME_NS (2000-01-01T00:00:00Z), unless the run's metadata gives one ("start_time_ns", e.g.
`twin run --start-time now`): so the same scenario and seed still give the same file byte for byte
(DESIGN rule 5), and Foxglove's clock shows simulated time as time of day since midnight. The
start and where it came from are in the metadata record ("start_time_utc", "start_time_ns",
"start_time_source").
Camera frames are written together at close, after the telemetry, so their place in the file
does not depend on when the renderer delivered them (a run killed mid-way keeps its telemetry,
not its frames).

foxglove-schemas-protobuf 0.4.0 has JointStates/JointState (name, position, velocity,
acceleration, effort) and FrameTransforms; it has no schema for a pressure or a valve, so those
are JSON (Foxglove plots JSON fields too). JSON floats are written with Python's repr, which
reads back bit-exact; NaN is written as null (JSON has no NaN) and read back as NaN.

The file opens with a metadata record "twin" (joints, bodies, seed, scenario name and path,
overrides, package versions, all JSON strings) and an attachment "scenario.toml" holding the
scenario file text. Chunks are small (32 KB) and every batch ends with a flush, so a run killed
mid-way leaves a file whose every flushed sample can be read back. The encoding runs in a writer
process (McapRecorder), which flushes each batch as it arrives and, if the run's process is
killed, stops there and leaves the file as a killed in-process writer would (DESIGN "What we measured":
`make_reader` rejects a cut file; a streaming reader reads it up to the cut).
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import functools
import json
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.JointStates_pb2 import JointStates
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.records import Attachment, Channel, Footer, Message, Metadata
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import build_file_descriptor_set

from twin import worker
from twin.telemetry import SIGNALS
from twin_plumbing.errors import UserError
from twin_plumbing.provenance import package_versions

log = logging.getLogger(__name__)

CHUNK_SIZE = 32 * 1024  # bytes: ~0.3 s of telemetry, within DESIGN's 4-64 KB
START_TIME_NS = 946_684_800 * 1_000_000_000  # 2000-01-01T00:00:00Z: the fixed start of a log (deterministic)
CAMERA_TOPIC = "/camera/global_view"
CALIBRATION_TOPIC = "/camera/global_view/calibration"
EVENTS_TOPIC = "/events"
GHOST_PREFIX = "predicted/"  # the predicted arm's frames: predicted/<body>
GHOST_RGBA = (1.0, 140 / 255, 0.0, 0.35)  # the prediction's orange (twin.rerun_log), translucent
PA_PER_BAR = 1e5
LOG_LEVELS = {"INFO": Log.INFO, "WARN": Log.WARNING, "ERROR": Log.ERROR}  # twin.events.EventLevel -> foxglove
# what each JSON field holds, with its unit (the schemas' field descriptions)
JOINT_DOC = {
    "pressure_a_pa": "motor chamber A pressure, Pa absolute",
    "pressure_b_pa": "motor chamber B pressure, Pa absolute",
    "valve_gauge_pa": "proportional valve pressure as its sensor reads it, Pa gauge",
    "direction": "direction valve command: -1, 0 (closed) or +1, dimensionless",
    "brake_release": "brake release command: 0 (hold) or 1 (release), dimensionless",
    "brake_engagement": "brake engagement: 0 released .. 1 holding, dimensionless",
    "predicted_minus_true_rad": "controller's predicted angle minus the plant's true angle, rad",
}
# the same in the units the rerun recording shows (for the shipped Foxglove layout's plots)
DISPLAY_DOC = {
    "angle_true_deg": "the plant's true drive angle, deg",
    "angle_predicted_deg": "controller's predicted drive angle, deg (null: no prediction)",
    "angle_target_deg": "controller's set point, deg (null: none)",
    "predicted_minus_true_deg": "controller's predicted angle minus the plant's true angle, deg",
    "pressure_a_bar": "motor chamber A pressure, bar absolute",
    "pressure_b_bar": "motor chamber B pressure, bar absolute",
    "valve_gauge_bar": "proportional valve pressure as its sensor reads it, bar gauge",
}
ARM_DOC = {
    "time_s": "simulated time since the run's start, s",
    "supply_pa": "supply pressure, Pa absolute",
    "brush_force_n": "brush normal force on the discs, N",
    "brush_peak_n": "the largest brush normal force over the physics steps since the previous message, N",
}
ARM_DOC |= {f"brush_contact_{x}_m": f"brush contact point, world {x}, m (null: no contact)" for x in "xyz"}
ARM_DOC |= {f"brush_push_{x}_n": f"force of the brush on what it touches, world {x}, N" for x in "xyz"}
ARM_DOC["supply_bar"] = "supply pressure, bar absolute"
JOINT_FIELDS = ("pressure_a_pa", "pressure_b_pa", "valve_gauge_pa", "direction", "brake_release", "brake_engagement")
ANGLE_CHANNELS = {
    "true_angle_rad": "/joint_states/true",
    "predicted_angle_rad": "/joint_states/predicted",
    "target_angle_rad": "/joint_states/target",
}


JOINT_JSON = "{" + ",".join(f'"{f}":%r' for f in (*JOINT_FIELDS, "predicted_minus_true_rad", *DISPLAY_DOC)) + "}"
# /arm fields: scalars, then each 3-vector of the brush contact as _x, _y, _z, then the supply in bar
ARM_SCALARS = ("time_s", "supply_pa", "brush_force_n", "brush_peak_n")
ARM_VECTORS = {"brush_contact_m": "brush_contact_{}_m", "brush_push_n": "brush_push_{}_n"}
ARM_FIELDS = ARM_SCALARS + tuple(f.format(x) for f in ARM_VECTORS.values() for x in "xyz") + ("supply_bar",)
ARM_JSON = "{" + ",".join(f'"{f}":%r' for f in ARM_FIELDS) + "}"


def _json_object(template: str, values: list[float]) -> bytes:
    """One JSON object of floats by a %r template: Python's float repr is JSON's number (and reads
    back bit-exact); NaN and infinities, which JSON lacks, become null (read back as NaN).
    Templated rather than json.dumps of a dict: this runs several times a sample."""
    text = template % tuple(values)
    if "nan" in text or "inf" in text:  # no field name holds either
        text = template.replace("%r", "%s") % tuple(repr(v) if math.isfinite(v) else "null" for v in values)
    return text.encode()


class LogError(UserError):
    """An MCAP file cannot be written, or is not a readable log of this project."""


class McapWriter:
    """Writes the MCAP file in the calling process: what McapRecorder's writer process runs.

    `bodies` are the body names in telemetry order, `scene` the serialised foxglove.SceneUpdate
    of the model's geometry, `meta` the run's metadata (twin_plumbing.provenance.run_metadata);
    `predicted_scene` the moving bodies' geoms in the predicted arm's frames (written with the
    first predicted pose), `camera` the camera's serialised (FrameTransforms, CameraCalibration).
    """

    def __init__(
        self,
        path,
        joints,
        bodies,
        scene: bytes,
        meta: dict | None = None,
        *,
        chunk_size: int = CHUNK_SIZE,
        predicted_scene: bytes | None = None,
        camera: tuple[bytes, bytes] | None = None,
    ):
        self.path = Path(path)
        self.joints = tuple(joints)
        self.bodies = tuple(bodies)
        meta = dict(meta or {})
        self.start_ns = _start_ns(meta)
        self._file = _open_for_writing(self.path)
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library="pneumatic-arm-twin")

        def proto_channel(topic: str, cls) -> int:
            schema = self._writer.register_schema(
                name=cls.DESCRIPTOR.full_name,
                encoding="protobuf",
                data=build_file_descriptor_set(cls).SerializeToString(),
            )
            return self._writer.register_channel(topic=topic, message_encoding="protobuf", schema_id=schema)

        def json_channel(topic: str, fields: dict[str, str]) -> int:
            schema = {
                "type": "object",
                "properties": {k: {"type": ["number", "null"], "description": d} for k, d in fields.items()},
            }
            sid = self._writer.register_schema(
                name=topic.strip("/").replace("/", "."), encoding="jsonschema", data=json.dumps(schema).encode()
            )
            return self._writer.register_channel(topic=topic, message_encoding="json", schema_id=sid)

        self._JointStates = JointStates
        self._angle_ch = {sig: proto_channel(topic, JointStates) for sig, topic in ANGLE_CHANNELS.items()}
        self._tf_ch = proto_channel("/tf", FrameTransforms)
        scene_ch = proto_channel("/scene", SceneUpdate)
        self._joint_ch = [json_channel(f"/joint/{j}", JOINT_DOC | DISPLAY_DOC) for j in self.joints]
        self._arm_ch = json_channel("/arm", ARM_DOC)
        self._proto_channel = proto_channel
        self._camera_ch: int | None = None  # registered with the first frame

        info = {
            "joints": json.dumps(self.joints),
            "bodies": json.dumps(self.bodies),
            "seed": json.dumps(meta.get("seed")),
            "scenario_name": json.dumps(meta.get("scenario_name")),
            "scenario_path": json.dumps(meta.get("scenario_path")),
            "overrides": json.dumps(meta.get("overrides", {}), default=str),
            "versions": json.dumps(meta.get("versions") or package_versions()),
            "start_time_utc": json.dumps(_utc(self.start_ns)),
            "start_time_ns": json.dumps(self.start_ns),
            "start_time_source": json.dumps(meta.get("start_time_source") or "fixed epoch (deterministic logs)"),
        }
        self._writer.add_metadata("twin", info)
        if meta.get("scenario_text") is not None:
            self._writer.add_attachment(0, 0, "scenario.toml", "application/toml", str(meta["scenario_text"]).encode())
        self._writer.add_message(scene_ch, self.start_ns, scene, self.start_ns, sequence=0)
        self._predicted_scene = predicted_scene
        self._predicted_tf_ch: int | None = None  # registered with the first predicted pose
        self._events_ch: int | None = None  # registered with the first report
        self._events_written = 0
        if camera is not None:
            self._writer.add_message(
                proto_channel("/tf/camera", FrameTransforms), self.start_ns, camera[0], self.start_ns, sequence=0
            )
            calibration_ch = proto_channel(CALIBRATION_TOPIC, CameraCalibration)
            self._writer.add_message(calibration_ch, self.start_ns, camera[1], self.start_ns, sequence=0)
        self._writer.flush()
        self._closed = False

    def write(self, telemetry, start: int) -> None:
        """Append telemetry samples `start`.. and flush them to the file."""
        self.write_arrays(telemetry.arrays(start), start)

    def write_arrays(self, a: dict[str, np.ndarray], start: int) -> None:
        """Append the samples in `a` (Telemetry.arrays columns), the first being sample `start`."""
        times = a["time_s"]
        if len(times) == 0:
            return
        add = self._writer.add_message
        JointStates = self._JointStates
        lists = {k: a[k].tolist() for k in ("time_s", *ANGLE_CHANNELS)}
        # per joint and sample, the JSON fields in order: (T, n, fields) -> nested lists
        error = a["predicted_angle_rad"] - a["true_angle_rad"]
        display = [np.degrees(a[k]) for k in ANGLE_CHANNELS] + [np.degrees(error)]
        display += [a[k] / PA_PER_BAR for k in ("pressure_a_pa", "pressure_b_pa", "valve_gauge_pa")]
        rows = np.stack([a[f] for f in JOINT_FIELDS] + [error] + display, axis=-1).tolist()
        arm_rows = np.concatenate(
            [np.stack([a[f] for f in ARM_SCALARS], axis=-1)]
            + [a[v] for v in ARM_VECTORS]
            + [a["supply_pa"][:, None] / PA_PER_BAR],
            axis=-1,
        ).tolist()
        pos, quat = a["body_pos_m"], a["body_quat_wxyz"]
        for k, t in enumerate(lists["time_s"]):
            seq = start + k
            ns = self.start_ns + int(round(t * 1e9))
            sec, nsec = divmod(ns, 1_000_000_000)
            for sig, ch in self._angle_ch.items():
                msg = JointStates()
                msg.timestamp.seconds, msg.timestamp.nanos = sec, nsec
                for name, value in zip(self.joints, lists[sig][k], strict=True):
                    msg.joints.add(name=name, position=value)
                add(ch, ns, msg.SerializeToString(), ns, sequence=seq)
            tf = _frame_transforms(ns, "world", self.bodies, pos[k].tolist(), quat[k].tolist())
            add(self._tf_ch, ns, tf.SerializeToString(), ns, sequence=seq)
            for ch, row in zip(self._joint_ch, rows[k], strict=True):
                add(ch, ns, _json_object(JOINT_JSON, row), ns, sequence=seq)
            add(self._arm_ch, ns, _json_object(ARM_JSON, arm_rows[k]), ns, sequence=seq)
        if "predicted_pos_m" in a:
            self._write_predicted(a, start)
        self._writer.flush()  # ends the chunk and flushes the file: a kill now loses nothing

    def _write_predicted(self, a: dict[str, np.ndarray], start: int) -> None:
        """The predicted arm's frames (twin.ghost poses in `a`) for the samples that have them."""
        drawn = np.flatnonzero(a["predicted_drawn"])
        if drawn.size == 0:
            return
        if self._predicted_tf_ch is None:
            self._predicted_tf_ch = self._proto_channel("/tf/predicted", FrameTransforms)
            if self._predicted_scene is not None:
                ch = self._proto_channel("/scene/predicted", SceneUpdate)
                self._writer.add_message(ch, self.start_ns, self._predicted_scene, self.start_ns, sequence=0)
        pos, quat, times = a["predicted_pos_m"].tolist(), a["predicted_quat_wxyz"].tolist(), a["time_s"].tolist()
        for k in drawn.tolist():
            ns = self.start_ns + int(round(times[k] * 1e9))
            tf = _frame_transforms(ns, "world", [GHOST_PREFIX + b for b in self.bodies], pos[k], quat[k])
            self._writer.add_message(self._predicted_tf_ch, ns, tf.SerializeToString(), ns, sequence=start + k)

    def write_events(self, events: list[tuple[float, str, str, str]]) -> None:
        """Append reports (time s, source, level "INFO"|"WARN"|"ERROR", text) as foxglove.Log."""
        if not events:
            return
        if self._events_ch is None:
            self._events_ch = self._proto_channel(EVENTS_TOPIC, Log)
        for t, source, level, text in events:
            ns = self.start_ns + int(round(t * 1e9))
            msg = Log(level=LOG_LEVELS[level], message=text, name=source)
            msg.timestamp.seconds, msg.timestamp.nanos = divmod(ns, 1_000_000_000)
            self._writer.add_message(self._events_ch, ns, msg.SerializeToString(), ns, sequence=self._events_written)
            self._events_written += 1
        self._writer.flush()

    def write_frames(self, frames: list[tuple[float, bytes]], camera: str = "global_view") -> None:
        """Append camera frames (simulated time s, JPEG bytes) as foxglove.CompressedImage."""
        if not frames:
            return
        if self._camera_ch is None:
            self._camera_ch = self._proto_channel(CAMERA_TOPIC, CompressedImage)
        for k, (t, jpeg) in enumerate(frames):
            ns = self.start_ns + int(round(t * 1e9))
            msg = CompressedImage(frame_id=camera, data=jpeg, format="jpeg")
            msg.timestamp.seconds, msg.timestamp.nanos = divmod(ns, 1_000_000_000)
            self._writer.add_message(self._camera_ch, ns, msg.SerializeToString(), ns, sequence=k)
        self._writer.flush()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self._writer.finish()
        self._file.close()


def _frame_transforms(ns: int, parent: str, children, positions, quats_wxyz) -> FrameTransforms:
    """One FrameTransforms of `parent` -> each child at log time `ns` (positions m, quaternions wxyz)."""
    tf = FrameTransforms()
    sec, nsec = divmod(ns, 1_000_000_000)
    for child, (px, py, pz), (qw, qx, qy, qz) in zip(children, positions, quats_wxyz, strict=True):
        x = tf.transforms.add(parent_frame_id=parent, child_frame_id=child)
        x.timestamp.seconds, x.timestamp.nanos = sec, nsec
        x.translation.x, x.translation.y, x.translation.z = px, py, pz
        x.rotation.w, x.rotation.x, x.rotation.y, x.rotation.z = qw, qx, qy, qz
    return tf


def start_time(text: str, where: str = "--start-time") -> dict:
    """The metadata that starts a log at `text`: "now" (the wall clock; the log then differs from
    run to run) or an ISO 8601 time with its zone (2026-11-23T13:00:00Z). LogError otherwise."""
    if text == "now":
        return {"start_time_ns": time.time_ns(), "start_time_source": "wall clock at the run's start"}
    try:
        when = dt.datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        when = None
    allowed = "'now' or an ISO 8601 time with its zone from 1970 (UTC) to 2200, e.g. 2026-11-23T13:00:00Z"
    if when is None or when.tzinfo is None or not 1970 <= when.year <= 2200:
        raise LogError(f"{where} {text!r}: expected {allowed}")
    if when.timestamp() < 0:  # 1970-01-01T00:30+01:00 is in 1969 in UTC, before the log's clock starts
        raise LogError(f"{where} {text!r}: is before 1970-01-01T00:00:00Z; expected {allowed}")
    ns = int(when.timestamp()) * 1_000_000_000 + when.microsecond * 1000
    return {"start_time_ns": ns, "start_time_source": f"given: {text}"}


def _start_ns(meta: dict) -> int:
    """The log's start: the metadata's "start_time_ns", else the fixed START_TIME_NS."""
    return int(meta["start_time_ns"]) if meta.get("start_time_ns") is not None else START_TIME_NS


def _utc(ns: int) -> str:
    return dt.datetime.fromtimestamp(ns // 1_000_000_000, dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _open_for_writing(path: Path):
    try:
        return open(path, "wb")
    except OSError as e:
        raise LogError(f"{path}: cannot write the MCAP log: {e.strerror}") from e


def _open_for_reading(path: Path):
    try:
        return open(path, "rb")
    except OSError as e:
        raise LogError(f"{path}: cannot open the MCAP log: {e.strerror}") from e


def _serve(stdin, stdout) -> None:
    """The writer process (`python -m twin.mcap_log`): reads pickles from `stdin` (the
    McapWriter's arguments, then (columns, start) per batch, then None), writes the file, and
    answers one line on `stdout` at the end: "ok" or what failed. If the run's process vanishes
    (killed), the file is left as a killed run leaves it: every batch received is flushed and the
    summary is missing, so the reader says it is incomplete."""
    try:
        messages = worker.requests(stdin)
        args, kwargs = next(messages)
        writer = McapWriter(*args, **kwargs)
        for msg in messages:
            if msg is None:
                writer.close()
                stdout.write(b"ok\n")
                return
            if isinstance(msg, dict):  # {"frames": [(t, jpeg), ...]} or {"events": [(t, source, level, text), ...]}
                if "frames" in msg:
                    writer.write_frames(msg["frames"])
                else:
                    writer.write_events(msg["events"])
                continue
            writer.write_arrays(*msg)
    except Exception as e:  # the run reads it at its next write or at close
        stdout.write(f"{type(e).__name__}: {e}\n".encode())
    finally:
        stdout.flush()


class McapRecorder:
    """Writes an MCAP file while a run goes (Recorder protocol of twin.sim).

    `plant_model` is the run's MjModel (body names and geometry), `joints` the joint names in
    telemetry order, `meta` the run's metadata (twin_plumbing.provenance.run_metadata: scenario_text,
    seed, versions, ...).

    The encoding (protobuf, JSON, zstd: ~0.12 ms a sample in pure Python, a fifth of the run's
    own time) runs in a writer process of its own, `python -m twin.mcap_log`, so on a machine with
    a spare core the run does not wait for it: the run pickles each batch of columns down a pipe.
    A plain subprocess rather than multiprocessing, which would re-import the user's main script.
    `background=False` writes in-process; the file is the same byte for byte either way.
    `camera_fps` > 0 adds the scene's `global_view` camera as JPEG frames (twin.camera), written
    at close; where offscreen GL does not work the log goes on without them and says so.
    `frames` is a twin.camera.FrameFeed shared with another recorder (each frame rendered once).
    """

    def __init__(
        self,
        path,
        plant_model,
        joints,
        meta: dict | None = None,
        *,
        chunk_size: int = CHUNK_SIZE,
        background: bool = True,
        camera_fps: float = 0.0,
        frames=None,
    ):
        # MuJoCo on use: the writer process (`python -m twin.mcap_log`) starts in 0.35 s without it, 0.59 s with
        from twin.camera import FrameFeed
        from twin.ghost import GhostArm
        from twin.model import body_name

        self.path = Path(path)
        _open_for_writing(self.path).close()  # a bad path is refused here, before the run starts
        bodies = tuple(body_name(plant_model, b) for b in range(1, plant_model.nbody))
        args = (self.path, tuple(joints), bodies, _scene_update(plant_model).SerializeToString(), dict(meta or {}))
        kwargs = {
            "chunk_size": chunk_size,
            "predicted_scene": _scene_update(plant_model, GHOST_PREFIX, GHOST_RGBA).SerializeToString(),
            "camera": _camera_messages(plant_model, _start_ns(meta or {})),
        }
        self._ghost = GhostArm(plant_model, tuple(joints))
        self._inline = self._proc = None
        self._closed = False
        self._camera = frames
        if self._camera is None and camera_fps > 0:
            self._camera = FrameFeed(plant_model, camera_fps)
        if not background:
            self._inline = McapWriter(*args, **kwargs)
            return
        self._proc = worker.start("twin.mcap_log")
        self._send((args, kwargs))

    def _send(self, obj) -> None:
        try:
            worker.send(self._proc.stdin, obj)  # the writer has each batch now: a kill of this process loses none
        except OSError:  # BrokenPipeError among them
            self._closed = True
            raise LogError(f"{self.path}: the MCAP writer failed: {self._finish()}") from None

    def _finish(self) -> str:
        """Wait for the writer process; its last word ("ok" or what failed)."""
        with contextlib.suppress(BrokenPipeError, OSError):
            self._proc.stdin.close()
        reply = self._proc.stdout.read().decode(errors="replace").strip()
        self._proc.wait()
        return reply or f"the writer process ended with exit code {self._proc.returncode}"

    def write(self, telemetry, start: int) -> None:
        """Send telemetry samples `start`.. to the writer (each batch is flushed to the file). Nothing
        once the writer has failed: its LogError was raised then, and the run's last flush (in a
        `finally`) must still reach the other recorders."""
        if self._closed:
            return
        if self._camera is not None and len(telemetry) > start:
            self._camera.request(telemetry, start)
        a = telemetry.arrays(start)
        a["predicted_pos_m"], a["predicted_quat_wxyz"], a["predicted_drawn"] = self._ghost.poses(
            a["predicted_angle_rad"], a["true_angle_rad"]
        )
        if self._inline is not None:
            return self._inline.write_arrays(a, start)
        self._send((a, start))

    def write_events(self, events) -> None:
        """The controller's and the operator's reports (twin.events.Event) as foxglove.Log."""
        if self._closed or not events:
            return
        rows = [(e.time_s, e.source, e.level.value, e.text) for e in events]
        if self._inline is not None:
            return self._inline.write_events(rows)
        self._send({"events": rows})

    def _close_camera(self) -> list[tuple[float, bytes]]:
        """All frames, in time order (the order they were rendered in is the renderer's)."""
        if self._camera is None:
            return []
        frames = sorted(self._camera.frames_from(0, wait=True), key=lambda f: f[0])
        if self._camera.error:  # the log holds everything else
            log.warning("note: no camera frames in %s: %s", self.path, self._camera.error)
        return frames

    def close(self) -> None:
        """Finish the file: waits for the camera's frames and for the writer to write all it was sent."""
        if self._closed:
            return
        frames = self._close_camera()
        self._closed = True
        if self._inline is not None:
            self._inline.write_frames(frames)
            return self._inline.close()
        if frames:
            self._send({"frames": frames})
        self._send(None)
        reply = self._finish()
        if reply != "ok":
            raise LogError(f"{self.path}: the MCAP writer failed: {reply}")


def _place(prim, offset=(0.0, 0.0, 0.0), *, pos, quat, rot, rgba) -> None:
    """A foxglove primitive at a geom's pose (`offset` along the geom's own axes) in its colour."""
    c = pos + rot @ np.asarray(offset)
    prim.pose.position.x, prim.pose.position.y, prim.pose.position.z = (float(v) for v in c)
    o = prim.pose.orientation
    o.w, o.x, o.y, o.z = (float(v) for v in quat)
    prim.color.r, prim.color.g, prim.color.b, prim.color.a = rgba


def _camera_messages(model, start_ns: int) -> tuple[bytes, bytes] | None:
    """The global camera's pose (FrameTransforms world -> its optical frame) and pinhole
    (CameraCalibration), serialised, at the log's start; None without a world-fixed camera."""
    from twin.camera_pose import camera_pose

    cam = camera_pose(model)
    if cam is None:
        return None
    pose = [cam.position_m.tolist()], [cam.optical_quat_wxyz().tolist()]
    tf = _frame_transforms(start_ns, "world", [cam.name], *pose)
    K = cam.intrinsics()
    calibration = CameraCalibration(
        frame_id=cam.name,
        width=cam.width,
        height=cam.height,
        distortion_model="plumb_bob",  # with D all zero: MuJoCo's pinhole has no distortion
        D=[0.0] * 5,
        K=K.ravel().tolist(),
        R=np.eye(3).ravel().tolist(),
        P=np.hstack([K, np.zeros((3, 1))]).ravel().tolist(),
    )
    calibration.timestamp.seconds, calibration.timestamp.nanos = divmod(start_ns, 1_000_000_000)
    return tf.SerializeToString(), calibration.SerializeToString()


def _scene_update(model, prefix: str = "", rgba_override: tuple[float, ...] | None = None):
    """Each geom as a foxglove primitive in its body's frame (world geoms in "world"). With a
    `prefix`: only the moving bodies' shown geoms, in frames `prefix + body`, in `rgba_override`
    (the predicted arm)."""
    import mujoco  # on use: see McapRecorder (the writer process starts in 0.35 s without MuJoCo, 0.59 s with)

    from twin.model import body_name, geom_rgba

    G = mujoco.mjtGeom
    update = SceneUpdate()
    entities = {}
    for g in range(model.ngeom):
        b = model.geom_bodyid[g]
        if prefix and (b == 0 or int(model.geom_group[g]) > 2):  # groups 0-2: what MuJoCo shows by default
            continue
        frame = "world" if b == 0 else prefix + body_name(model, b)
        if frame not in entities:
            entities[frame] = update.entities.add(frame_id=frame, id=f"geoms/{frame}", frame_locked=True)
        ent = entities[frame]
        t, s = int(model.geom_type[g]), model.geom_size[g]  # int: enum `in` tuple fails on numpy ints
        p, q = model.geom_pos[g], model.geom_quat[g]
        rgba = rgba_override or tuple(float(c) for c in geom_rgba(model, g))
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, q)
        place = functools.partial(_place, pos=p, quat=q, rot=R.reshape(3, 3), rgba=rgba)

        if t == G.mjGEOM_BOX:
            c = ent.cubes.add()
            c.size.x, c.size.y, c.size.z = (2 * float(v) for v in s[:3])
            place(c)
        elif t == G.mjGEOM_PLANE:
            c = ent.cubes.add()
            c.size.x, c.size.y, c.size.z = 2 * float(s[0] or 2), 2 * float(s[1] or 2), 0.002
            place(c, (0, 0, -0.001))
        elif t in (int(G.mjGEOM_CYLINDER), int(G.mjGEOM_CAPSULE)):
            c = ent.cylinders.add(bottom_scale=1.0, top_scale=1.0)
            c.size.x = c.size.y = 2 * float(s[0])
            c.size.z = 2 * float(s[1])
            place(c)
            if t == G.mjGEOM_CAPSULE:
                for end in (-1, 1):
                    sp = ent.spheres.add()
                    sp.size.x = sp.size.y = sp.size.z = 2 * float(s[0])
                    place(sp, (0, 0, end * float(s[1])))
        elif t == G.mjGEOM_SPHERE:
            sp = ent.spheres.add()
            sp.size.x = sp.size.y = sp.size.z = 2 * float(s[0])
            place(sp)
        else:
            continue
    return update


@dataclasses.dataclass
class _Records:
    """What streaming a log's records gathers: each sample's messages by sequence and topic, the
    camera frames' Message records, the metadata, and how the stream ended."""

    samples: dict[int, dict[str, bytes]] = dataclasses.field(default_factory=dict)
    images: list = dataclasses.field(default_factory=list)
    meta: dict = dataclasses.field(default_factory=dict)
    complete: bool = False
    stopped_by: str | None = None


def _cut_short(e: Exception, f, path: Path) -> str:
    """Why reading stopped early: where in the file, and the decoding error."""
    where = f"at byte {f.tell()} of {path.stat().st_size}"
    return (
        f"cut short or damaged {where}: {type(e).__name__}: {e}"
        if str(e)
        else f"cut short or damaged {where}: {type(e).__name__}"
    )


def _stream_records(path: Path, frames: bool) -> _Records:
    """Every record up to the end of the file or to where it is cut short or damaged."""
    topics: dict[int, str] = {}
    got = _Records()
    with _open_for_reading(path) as f:
        try:
            for rec in StreamReader(f, skip_magic=False).records:
                if isinstance(rec, Channel):
                    topics[rec.id] = rec.topic
                elif isinstance(rec, Message):
                    topic = topics.get(rec.channel_id)
                    if topic == CAMERA_TOPIC and frames:
                        got.images.append(rec)
                    if topic is None or topic in ("/scene", CAMERA_TOPIC):
                        continue
                    got.samples.setdefault(rec.sequence, {})[topic] = rec.data
                elif isinstance(rec, Metadata) and rec.name == "twin":
                    got.meta.update({k: json.loads(v) for k, v in rec.metadata.items()})
                elif isinstance(rec, Attachment) and rec.name == "scenario.toml":
                    got.meta["scenario_text"] = rec.data.decode("utf-8", errors="replace")
                elif isinstance(rec, Footer):
                    got.complete = True
        except Exception as e:  # a cut or damaged file surfaces as any decoding error (struct, zstd, CRC, mcap)
            if not topics:
                raise LogError(f"{path}: not a readable MCAP file ({type(e).__name__}: {e})") from e
            got.stopped_by = _cut_short(e, f, path)
    return got


def _empty_arrays(joints: tuple, bodies: tuple, m: int) -> dict[str, np.ndarray]:
    """Telemetry.arrays()'s shapes for m samples ("n": per joint, "b": per body)."""
    n, nb = len(joints), len(bodies)
    out = {"time_s": np.empty(m)}
    for name, shape in SIGNALS.items():
        dims = tuple(n if s == "n" else nb if s == "b" else s for s in shape)
        out[name] = np.empty((m,) + dims)
    return out


def _fill_sample(out: dict[str, np.ndarray], i: int, msgs: dict[str, bytes], joints: tuple, bodies: tuple) -> None:
    """Row i of `out` from one sample's messages (raises KeyError, ValueError or TypeError if malformed)."""
    for sig, topic in ANGLE_CHANNELS.items():
        js = JointStates.FromString(msgs[topic])
        by_name = {x.name: x.position for x in js.joints}
        out[sig][i] = [by_name[j] for j in joints]
    tf = FrameTransforms.FromString(msgs["/tf"])
    by_body = {x.child_frame_id: x for x in tf.transforms}
    for b, body in enumerate(bodies):
        x = by_body[body]
        out["body_pos_m"][i, b] = (x.translation.x, x.translation.y, x.translation.z)
        out["body_quat_wxyz"][i, b] = (x.rotation.w, x.rotation.x, x.rotation.y, x.rotation.z)
    for j, joint in enumerate(joints):
        rec = json.loads(msgs[f"/joint/{joint}"])
        for fld in JOINT_FIELDS:
            out[fld][i, j] = math.nan if rec[fld] is None else rec[fld]
    arm = json.loads(msgs["/arm"])
    for fld in ARM_SCALARS:
        value = arm.get(fld) if fld == "brush_peak_n" else arm[fld]  # brush_peak_n: absent from older logs
        out[fld][i] = math.nan if value is None else value
    for sig, fmt in ARM_VECTORS.items():  # absent from logs written before they existed: NaN
        out[sig][i] = [math.nan if arm.get(fmt.format(x)) is None else arm[fmt.format(x)] for x in "xyz"]


def read_mcap(path, frames: bool = False) -> tuple[dict[str, np.ndarray], dict]:
    """Read a log written by McapRecorder back into arrays shaped like Telemetry.arrays().

    Works on a file cut short (a run killed mid-way): it streams records up to the cut and keeps
    every sample whose messages all arrived. `meta` holds the metadata record (joints, bodies,
    seed, versions, ...), "scenario_text" from the attachment, and "recovery": complete (the file
    was closed properly), samples, duration_s (simulated seconds recovered), stopped_by (why
    reading stopped early, or None). With `frames`, meta["camera_frames"] holds the camera's
    frames as (simulated time s, JPEG bytes) in time order.
    Raises LogError when the file is missing, is not MCAP, or is not a log of this project.
    """
    path = Path(path)
    got = _stream_records(path, frames)
    meta = got.meta
    if "joints" not in meta or "bodies" not in meta:
        raise LogError(
            f"{path}: an MCAP file, but not a log of this project (no 'twin' metadata record with joints and bodies)"
        )
    joints, bodies = tuple(meta["joints"]), tuple(meta["bodies"])
    needed = set(ANGLE_CHANNELS.values()) | {"/tf", "/arm"} | {f"/joint/{j}" for j in joints}
    seqs = sorted(s for s, msgs in got.samples.items() if needed <= msgs.keys())
    m = len(seqs)
    out = _empty_arrays(joints, bodies, m)
    try:
        for i, s in enumerate(seqs):
            _fill_sample(out, i, got.samples[s], joints, bodies)
    except (KeyError, ValueError, TypeError) as e:
        raise LogError(f"{path}: sample {s} is malformed ({type(e).__name__}: {e})") from e
    duration = float(out["time_s"][-1] - out["time_s"][0]) if m else 0.0
    meta["recovery"] = {"complete": got.complete, "samples": m, "duration_s": duration, "stopped_by": got.stopped_by}
    if frames:
        start_ns = int(meta.get("start_time_ns", 0))  # logs written before it had a start began at 0
        meta["camera_frames"] = sorted(
            ((r.log_time - start_ns) * 1e-9, CompressedImage.FromString(r.data).data) for r in got.images
        )
    return out, meta


if __name__ == "__main__":
    _serve(sys.stdin.buffer, sys.stdout.buffer)
