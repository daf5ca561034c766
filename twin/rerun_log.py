"""Rerun recording of a run: the arm in 3D beside the arm the controller believes in, the true and
predicted angles, pressures, valves, and what the controller and the operator reported.

A `RerunRecorder` implements the Recorder protocol of twin.sim: it logs each body's geometry once
(read from the MuJoCo model: rerun has no MJCF loader, DESIGN "What we measured"), then, for every
batch of telemetry, one transform per body per sample (50 per simulated second) and the time
series, all with `send_columns` (bulk: ~0.3 µs a sample against ~160 µs for one `log` call).

Entity paths (angles in degrees and pressures in bar: the recording is a user-facing edge,
STYLE rule 3):

    world/scene/<geom>                 floor, gantry (static)
    world/string/<disc>                insulator string discs and caps (static)
    world/arm/<body>                   body pose in the world frame, one Transform3D per sample
    world/arm/<body>/<geom>            the body's geoms (static, pose in the body frame)
    world/predicted_arm/<body>[/<geom>]  the same at the controller's predicted angles (twin.ghost),
                                       translucent orange; hide it in the blueprint panel
    world/camera/global_view           the operator's camera: its pose, a pinhole, and its frames
                                       (`camera_fps` > 0 and offscreen GL works)
    joints/<joint>/angle_deg/{true,predicted,target}
    joints/<joint>/error_deg/{predicted_minus_true,target_minus_true}
    joints/<joint>/pressure_bar/{chamber_a,chamber_b}    absolute
    joints/<joint>/valve/{direction,gauge_bar}           direction command -1/0/+1, prop. valve
    joints/<joint>/brake/{release,engagement}            release command 0/1, true engagement
    supply/pressure_bar                absolute
    brush/force_n                      brush normal force on the discs
    world/brush_contact                the brush's push on the string at its contact point (arrow, 1 mm/N)
    events                             the controller's and the operator's reports (TextLog)

Timeline: "time" (simulated seconds, as a duration).
"""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import threading
import warnings
from pathlib import Path

# rerun reports a failed write (a full disk) in log lines of its own (its file sink, encoder and
# recording stream), besides leaving the recording without its footer, which close() finds and
# says in one line; the user's own RUST_LOG wins
os.environ.setdefault("RUST_LOG", "warn,re_log_encoding=off,re_sdk::recording_stream=off")

import mujoco  # noqa: E402 - after RUST_LOG, which rerun reads when it loads
import numpy as np  # noqa: E402
import rerun as rr  # noqa: E402
import rerun.blueprint as rrb

from twin.camera import FrameFeed
from twin.camera_pose import camera_pose
from twin.ghost import GhostArm
from twin.model import body_name, geom_rgba, has_camera
from twin_plumbing.errors import UserError

log = logging.getLogger(__name__)

TIMELINE = "time"
PA_PER_BAR = 1e5
CAMERA_PATH = "world/camera/global_view"
GHOST_PATH = "world/predicted_arm"
GHOST_RGBA = (255, 140, 0, 90)  # the prediction's orange (SERIES_STYLES), about a third opaque
EVENTS_PATH = "events"

# MuJoCo geom types we draw; others (mesh, hfield, sdf, ellipsoid) are skipped with a note.
_GEOM = mujoco.mjtGeom


FULL_DISK_BYTES = 1 << 20  # less free than this where a recording was cut short: the disk filled (assumed)
# a recording's start: the arm's geometry and the blueprint, written as the sinks open (69.7 KB for
# the wrist rig, measured); with less free than this rerun's file sink can block on its first writes
# instead of failing, so a recording is refused before it opens
RECORDING_START_BYTES = 80 * 1024
# how long the recording's last flush may take: rerun's flush waits for its file writer, which can
# wait forever once its writes failed (a full disk); a healthy flush of a run's last batch takes well
# under a second (assumed margin: a slow network file system)
FLUSH_TIMEOUT_S = 30.0


def _within(seconds: float, work) -> bool:
    """Run `work` in a daemon thread; whether it finished within `seconds`. rerun's flush and
    disconnect can block forever once its file writer failed (a full disk): the run then reports
    the recording damaged instead of hanging, and the blocked thread ends with the process."""
    done = threading.Event()

    def run() -> None:
        try:
            work()
        finally:
            done.set()

    threading.Thread(target=run, name="rerun-close", daemon=True).start()
    return done.wait(seconds)


def _disk_cause(path: Path) -> str:
    """Why a recording was cut short, as far as can be told: the disk's room, else rerun's writer."""
    full = shutil.disk_usage(path.parent).free < FULL_DISK_BYTES
    return "No space left on device" if full else "rerun could not finish writing it"


class RerunLogError(UserError):
    """A recording cannot be written or opened."""


VISIBLE_GROUPS = (0, 1, 2)  # geom groups MuJoCo's viewer and renderer show by default (mjv_defaultOption)


def geom_texture(model: mujoco.MjModel, g: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The 2D colour texture of geom `g`'s material as an (h, w, 3|4) uint8 image and its repeat
    (u, v) over the geom, or None. MuJoCo tints the texture with the material's rgba."""
    mat = model.geom_matid[g]
    if mat < 0:
        return None
    tex = int(model.mat_texid[mat, int(mujoco.mjtTextureRole.mjTEXROLE_RGB)])
    if tex < 0 or int(model.tex_type[tex]) != int(mujoco.mjtTexture.mjTEXTURE_2D):
        return None
    h, w, c = int(model.tex_height[tex]), int(model.tex_width[tex]), int(model.tex_nchannel[tex])
    image = model.tex_data[model.tex_adr[tex] : model.tex_adr[tex] + h * w * c].reshape(h, w, c)
    tint = geom_rgba(model, g)[:c] if c in (3, 4) else None
    if tint is None:
        return None
    tinted = np.clip(np.rint(image * tint), 0, 255).astype(np.uint8)
    return tinted, np.asarray(model.mat_texrepeat[mat], dtype=np.float64)


def geom_name(model: mujoco.MjModel, g: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom_{g}"


def wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def _rgba8(rgba: np.ndarray) -> list[int]:
    return [int(round(255 * float(np.clip(c, 0, 1)))) for c in rgba]


def geom_archetype(model: mujoco.MjModel, g: int, rgba8: tuple[int, ...] | None = None):
    """The rerun primitive for geom `g` in its own frame, or None for a type we do not draw;
    in its own colour, or in `rgba8` (0..255, alpha included).

    MuJoCo sizes: box half-sizes; cylinder/capsule (radius, half-length) along local z, centred;
    sphere radius; plane (half-x, half-y, grid spacing). Rerun capsules run from z=0 to z=length,
    so they are shifted down by the half-length.
    """
    t, s = int(model.geom_type[g]), model.geom_size[g]  # int: enum `in` tuple fails on numpy ints
    color = [list(rgba8) if rgba8 is not None else _rgba8(geom_rgba(model, g))]
    if t == _GEOM.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[s[:3]], colors=color, fill_mode="solid")
    if t == _GEOM.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * s[1]], radii=[s[0]], colors=color, fill_mode="solid")
    if t == _GEOM.mjGEOM_CAPSULE:
        return rr.Capsules3D(
            lengths=[2 * s[1]], radii=[s[0]], translations=[[0, 0, -s[1]]], colors=color, fill_mode="solid"
        )
    if t == _GEOM.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(half_sizes=[[s[0]] * 3], colors=color, fill_mode="solid")
    if t == _GEOM.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[s[:3]], colors=color, fill_mode="solid")
    if t == _GEOM.mjGEOM_PLANE:
        return plane_mesh(model, g)
    return None


def plane_mesh(model: mujoco.MjModel, g: int):
    """A plane as MuJoCo draws it: a quad (size 0 is infinite in MuJoCo: 4 m x 4 m here) with its
    material's texture repeated `texrepeat` times across it (MuJoCo's rule without texuniform),
    drawn as one textured quad per repeat, so no texture wrapping is needed of the viewer."""
    hx, hy = (model.geom_size[g][0] or 2.0), (model.geom_size[g][1] or 2.0)
    textured = geom_texture(model, g)
    if textured is None:
        color = [_rgba8(geom_rgba(model, g))]
        return rr.Boxes3D(half_sizes=[[hx, hy, 0.001]], centers=[[0, 0, -0.001]], colors=color, fill_mode="solid")
    image, (ru, rv) = textured
    nu, nv = max(1, int(round(ru))), max(1, int(round(rv)))
    xs, ys = np.linspace(-hx, hx, nu + 1), np.linspace(-hy, hy, nv + 1)
    verts, uvs, tris = [], [], []
    for i in range(nu):
        for j in range(nv):
            k = len(verts)
            corners = ((xs[i], ys[j]), (xs[i + 1], ys[j]), (xs[i + 1], ys[j + 1]), (xs[i], ys[j + 1]))
            verts += [[x, y, 0.0] for x, y in corners]
            uvs += [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]
            tris += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
    return rr.Mesh3D(
        vertex_positions=verts,
        triangle_indices=tris,
        vertex_normals=[[0.0, 0.0, 1.0]] * len(verts),
        vertex_texcoords=uvs,
        albedo_texture=image,
    )


def _geom_parent_path(model: mujoco.MjModel, g: int) -> str:
    b = model.geom_bodyid[g]
    if b != 0:
        return f"world/arm/{body_name(model, b)}"
    return "world/string" if geom_name(model, g).startswith("disc_") else "world/scene"


def log_static_geometry(rec, model: mujoco.MjModel, ghost: bool = False) -> list[str]:
    """Log every drawable geom once (static); returns the entity paths written. With `ghost`, the
    moving bodies' shown geoms once more under GHOST_PATH, translucent: the arm at its predicted
    angles (twin.ghost)."""
    if ghost:
        return log_arm_geometry(rec, model, GHOST_PATH, GHOST_RGBA)
    return _log_geoms(rec, model, range(model.ngeom), lambda g: _geom_parent_path(model, g), lambda g: None)


def log_scene_geometry(rec, model: mujoco.MjModel) -> list[str]:
    """The geoms fixed to the world (floor, gantry, insulator string), static; the paths written."""
    fixed = [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) == 0]
    return _log_geoms(rec, model, fixed, lambda g: _geom_parent_path(model, g), lambda g: None)


def log_arm_geometry(
    rec, model: mujoco.MjModel, root: str, rgba8: tuple[int, ...] | None = None, marked: dict | None = None
) -> list[str]:
    """The moving bodies' shown geoms under `root`/<body>/<geom> (static, pose in the body frame),
    in their own colours or in `rgba8` (0..255, alpha included); `marked` maps a body's name to a
    colour of its own (a link drawn apart). The bodies' poses are logged at `root`/<body>."""
    marked = marked or {}
    shown = [
        g for g in range(model.ngeom) if int(model.geom_bodyid[g]) != 0 and int(model.geom_group[g]) in VISIBLE_GROUPS
    ]

    def colour(g: int) -> tuple[int, ...] | None:
        return marked.get(body_name(model, int(model.geom_bodyid[g])), rgba8)

    return _log_geoms(rec, model, shown, lambda g: f"{root}/{body_name(model, int(model.geom_bodyid[g]))}", colour)


def _log_geoms(rec, model: mujoco.MjModel, geoms, parent_of, colour_of) -> list[str]:
    paths = []
    for g in geoms:
        arch = geom_archetype(model, g, colour_of(g))
        if arch is None:
            continue
        path = f"{parent_of(g)}/{geom_name(model, g)}"
        pose = rr.Transform3D(translation=model.geom_pos[g], quaternion=wxyz_to_xyzw(model.geom_quat[g]))
        rec.log(path, pose, arch, static=True)
        paths.append(path)
    return paths


def log_camera(rec, model: mujoco.MjModel) -> bool:
    """The operator's camera in 3D (static): its pose and a pinhole of its frames' size and field
    of view (twin.camera_pose), which the frames logged at CAMERA_PATH fill. False: no world-fixed
    camera "global_view"."""
    cam = camera_pose(model)
    if cam is None:
        return False
    rec.log(
        CAMERA_PATH,
        rr.Transform3D(translation=cam.position_m, quaternion=wxyz_to_xyzw(cam.quat_wxyz)),
        rr.Pinhole(
            image_from_camera=cam.intrinsics(),
            resolution=[cam.width, cam.height],
            camera_xyz=rr.ViewCoordinates.RUB,  # MuJoCo's camera frame: x right, y up, looking along -z
            image_plane_distance=0.3,
        ),
        static=True,
    )
    return True


# Series styles, chosen for the viewer's default dark theme: the plant's truth a thin bright line
# on top of the controller's belief, a wide orange band (so both show where they agree), its
# target blue; each quantity with its unit has a view of its own
SERIES_STYLES = {
    "angle_deg/true": ((245, 245, 245), 1.5, "true (plant)"),
    "angle_deg/predicted": ((255, 140, 0), 5.0, "predicted (controller)"),
    "angle_deg/target": ((60, 170, 255), 1.5, "target"),
    "error_deg/predicted_minus_true": ((255, 140, 0), 2.0, "predicted − true"),
    "error_deg/target_minus_true": ((60, 170, 255), 1.5, "target − true"),
    "pressure_bar/chamber_a": ((255, 90, 90), 1.5, "chamber A"),
    "pressure_bar/chamber_b": ((90, 160, 255), 1.5, "chamber B"),
    "valve/gauge_bar": ((110, 220, 110), 1.5, "prop. valve set pressure"),
    "valve/direction": ((255, 210, 60), 1.5, "direction valve"),
    "brake/release": ((110, 220, 110), 1.5, "release command"),
    "brake/engagement": ((255, 90, 90), 1.5, "engagement"),
}
OTHER_STYLES = {
    "supply/pressure_bar": ((200, 200, 200), 1.5, "supply"),
    "brush/force_n": ((255, 210, 60), 1.5, "brush force"),
}


def moving_joint(joints, start_rad, targets_rad: list[dict[str, float]]) -> str:
    """The joint a plan moves furthest (sum of its commanded travels from the start angles),
    what the recording opens on; the first joint when the plan moves none."""
    where = dict(zip(joints, (float(a) for a in start_rad), strict=True))
    travel = dict.fromkeys(joints, 0.0)
    for target in targets_rad:
        for j, angle in target.items():
            if j in where and math.isfinite(angle):
                travel[j] += abs(angle - where[j])
                where[j] = angle
    best = max(joints, key=lambda j: travel[j])
    return best if travel[best] > 0 else joints[0]


def most_travelled_joint(joints, true_angle_rad: np.ndarray) -> str:
    """The joint whose logged true angle travelled furthest (for a log without its plan)."""
    if len(true_angle_rad) < 2:
        return joints[0]
    travel = np.nansum(np.abs(np.diff(true_angle_rad, axis=0)), axis=0)
    return joints[int(np.argmax(travel))]


def eye(model: mujoco.MjModel, closer: float = 0.75) -> dict:
    """Where the 3D view's eye starts: MuJoCo's free camera (looking at the model's centre from
    its `visual/global` azimuth and elevation), brought `closer` to the arm than MuJoCo's
    1.5 x extent."""
    az, el = math.radians(model.vis.global_.azimuth), math.radians(model.vis.global_.elevation)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    target = np.asarray(model.stat.center, dtype=np.float64)
    position = target - closer * 1.5 * model.stat.extent * forward
    return {"position": position, "look_target": target, "eye_up": [0.0, 0.0, 1.0]}


def hidden_geom_paths(model: mujoco.MjModel) -> list[str]:
    """Entity paths of geoms MuJoCo does not show by default (groups 3..5: the payload's box)."""
    hidden = [g for g in range(model.ngeom) if int(model.geom_group[g]) not in VISIBLE_GROUPS]
    return [f"{_geom_parent_path(model, g)}/{geom_name(model, g)}" for g in hidden]


def joint_views(j: str):
    """One joint's time series, one view per quantity and unit."""
    p = f"joints/{j}"

    def view(name, contents, **kw):
        return rrb.TimeSeriesView(name=name, origin="/", contents=contents, **kw)

    return rrb.Vertical(
        view(f"{j}: angle (deg)", f"{p}/angle_deg/**"),
        view(f"{j}: angle error (deg)", f"{p}/error_deg/**"),
        view(f"{j}: absolute pressure (bar)", [f"{p}/pressure_bar/**", "supply/pressure_bar"]),
        view(f"{j}: proportional valve, gauge (bar)", f"{p}/valve/gauge_bar"),
        rrb.Horizontal(
            view(f"{j}: direction valve (-1, 0, +1)", f"{p}/valve/direction"),
            view(f"{j}: brake (0 released, 1 holding)", f"{p}/brake/**"),
        ),
        row_shares=[3, 2, 2, 1.5, 1.5],
        name=j,
    )


def blueprint(
    joints: tuple[str, ...], model: mujoco.MjModel | None = None, focus: str | None = None, camera: bool = False
):
    """The layout the recording opens with: the arm in 3D, close up, with the arm the controller
    believes in beside it (its visibility a toggle of the 3D view's blueprint), and the reports
    below (left); the time series of one joint at a time in tabs, opened on `focus` (the joint
    that moves; right)."""
    focus = focus if focus in joints else joints[0]
    hidden = [f"- {p}" for p in hidden_geom_paths(model)] if model is not None else []
    arm = rrb.Spatial3DView(
        name="arm",
        origin="world",
        contents=["+ $origin/**", *hidden],
        line_grid=False,  # the model's own floor is drawn
        eye_controls=rrb.EyeControls3D(**eye(model)) if model is not None else None,
        # shown, and not picked by a click (the true arm is what one inspects)
        overrides={GHOST_PATH: rrb.EntityBehavior(visible=True, interactive=False)},
    )
    below = []
    if camera:
        below.append(rrb.Spatial2DView(name="global_view camera", origin=CAMERA_PATH))
    if model is None or mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "brush") >= 0:
        below.append(rrb.TimeSeriesView(name="brush normal force (N)", origin="brush"))
    below.append(rrb.TextLogView(name="controller and operator", origin=EVENTS_PATH))
    left = rrb.Vertical(arm, rrb.Horizontal(*below), row_shares=[3, 1])
    right = rrb.Tabs(*(joint_views(j) for j in joints), active_tab=joints.index(focus), name="joints")
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[1, 1]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed"),
    )


def open_recording(path: Path | None, viewer: str | None, layout) -> rr.RecordingStream:
    """A recording stream writing to the file `path`, and/or a live viewer (`viewer`: "spawn"
    starts one on this machine, else the gRPC URL of a running one, e.g.
    rerun+http://127.0.0.1:9876/proxy), opening on the blueprint `layout`. RerunLogError: the file
    cannot be written (no room for a recording's start, an unwritable place, a bad URL)."""
    where = ", ".join(str(x) for x in (path, viewer) if x is not None)
    if path is not None:
        free = shutil.disk_usage(path.parent if path.parent.exists() else Path.cwd()).free
        if free < RECORDING_START_BYTES:
            raise RerunLogError(
                f"{path}: not written: No space left on device ({free} bytes free; a recording's start "
                f"takes {RECORDING_START_BYTES // 1024} KB)"
            )
    rec = rr.RecordingStream("pneumatic_arm_twin")
    try:
        sinks = [rr.FileSink(str(path))] if path is not None else []
        if viewer == "spawn":
            rec.spawn(connect=False)  # a viewer on rerun's default port, which GrpcSink() reaches
            sinks.append(rr.GrpcSink())
        elif viewer is not None:
            sinks.append(rr.GrpcSink(viewer))
        rec.set_sinks(*sinks, default_blueprint=layout)
    except Exception as e:  # rerun raises its own error types for unwritable paths and bad URLs
        raise RerunLogError(f"{where}: cannot write a rerun recording: {e}") from e
    return rec


def close_recording(rec: rr.RecordingStream, path: Path | None) -> None:
    """Flush and disconnect `rec`, waiting at most FLUSH_TIMEOUT_S for rerun's writer; then
    RerunLogError unless the file `path` is whole (ends in rerun's footer)."""
    finished = _within(FLUSH_TIMEOUT_S, lambda: _flush_and_disconnect(rec))
    if not finished:  # rerun's shutdown at exit would wait for the same writer: the process would hang
        rr.unregister_shutdown()
    if not finished and path is not None:
        raise RerunLogError(
            f"{path}: damaged: rerun's file writer did not finish within {FLUSH_TIMEOUT_S:g} s ({_disk_cause(path)})"
        )
    if path is not None:
        _check_whole(path)


def _flush_and_disconnect(rec: rr.RecordingStream) -> None:
    try:
        rec.flush(timeout_sec=FLUSH_TIMEOUT_S)
        rec.disconnect()
    except Exception:  # rerun's own errors: its file writer stopped (a full disk) or the flush timed out
        rec.disconnect()


def _check_whole(path: Path) -> None:
    """RerunLogError unless the file ends in rerun's footer: rerun does not raise when its writes
    fail (a full disk), it leaves the file cut short there."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rr.chunk.RrdReader(path)
            whole = not any("footer" in str(w.message) for w in caught)
        except Exception:  # rerun's own error types: not even a readable start
            whole = False
    if not whole:
        raise RerunLogError(f"{path}: damaged, cut short where writing failed ({_disk_cause(path)}): no rerun footer")


class RerunRecorder:
    """Writes a .rrd file while a run goes (Recorder protocol of twin.sim).

    `plant_model` is the run's MjModel (geometry is read from it once); `joints` the joint names in
    telemetry order; `meta` the run's metadata (scenario, seed, versions), stored as a text entity
    `meta`. `camera_fps` > 0 logs the scene's `global_view` camera (the operator's aid in the
    paper) at that rate as JPEG frames, rendered by twin.camera's process where offscreen GL
    (egl or osmesa) works; where none does, the recording goes on without frames and says so.
    `focus` is the joint whose plots the recording opens on (`moving_joint` of the plan);
    `frames` a twin.camera.FrameFeed shared with another recorder (then `camera_fps` is its);
    `camera_view` shows the camera's view for frames logged by `log_frames` (a replay).
    """

    def __init__(
        self,
        path,
        plant_model: mujoco.MjModel,
        joints,
        meta: dict | None = None,
        *,
        camera_fps: float = 0.0,
        focus: str | None = None,
        frames=None,
        camera_view: bool = False,
        viewer: str | None = None,
    ):
        if path is None and viewer is None:
            raise ValueError("a rerun recording needs a file, a viewer, or both")
        self.path = Path(path) if path is not None else None
        self.model = plant_model
        self.joints = tuple(joints)
        self.bodies = tuple(body_name(plant_model, b) for b in range(1, plant_model.nbody))
        camera = camera_view or (camera_fps > 0 and has_camera(plant_model, "global_view"))
        self.rec = open_recording(self.path, viewer, blueprint(self.joints, plant_model, focus, camera=camera))
        if meta and meta.get("scenario_name"):
            self.rec.send_recording_name(str(meta["scenario_name"]))
        self.rec.log(
            "meta", rr.TextDocument(json.dumps(meta or {}, indent=2, default=str), media_type="text/plain"), static=True
        )
        log_static_geometry(self.rec, plant_model)
        log_camera(self.rec, plant_model)
        self._ghost = GhostArm(plant_model, self.joints)
        self._ghost_drawn = False  # its geometry is logged with its first predicted pose
        self._log_series_styles()
        self.camera_fps = float(camera_fps)
        if self.camera_fps < 0:
            raise RerunLogError(f"camera_fps {camera_fps}: must be >= 0 (0: no camera frames)")
        # simulated seconds per bulk send: rerun's cost is per call (~0.1 ms), so fewer, longer
        # columns; a killed run loses up to this much of its .rrd (the MCAP archive loses < 1 s)
        self.batch_s = 10.0
        self._pending: int | None = None  # first telemetry sample not yet sent
        self._telemetry = None
        self._camera, self._frames_seen = frames, 0
        if self._camera is None and self.camera_fps > 0:
            self._camera = FrameFeed(plant_model, self.camera_fps)
        self._closed = False

    def _log_series_styles(self) -> None:
        styles = {f"joints/{j}/{sub}": s for j in self.joints for sub, s in SERIES_STYLES.items()} | OTHER_STYLES
        for path, (color, width, name) in styles.items():
            self.rec.log(path, rr.SeriesLines(colors=[color], widths=[width], names=[name]), static=True)

    def write(self, telemetry, start: int) -> None:
        """Queue telemetry samples `start`..; they are sent in bulk once `batch_s` of simulated
        time has gathered (fewer, larger columns: rerun's cost is per call) and at close."""
        if self._pending is None:
            self._pending = start
        self._telemetry = telemetry
        if self._camera is not None and len(telemetry) > start:
            # frames are asked for at every write, not every batch: the camera process renders
            # them while the run goes on, and close has next to nothing left to wait for
            self._camera.request(telemetry, start)
            self.log_frames(self._camera.frames_from(self._frames_seen))
        if len(telemetry) > self._pending and telemetry.time_at(-1) - telemetry.time_at(self._pending) >= self.batch_s:
            self._send(telemetry, self._pending)
            self._pending = None

    def _send(self, telemetry, start: int) -> None:
        a = telemetry.arrays(start)
        if len(a["time_s"]) == 0:
            return
        send = self.rec.send_columns
        idx = [rr.TimeColumn(TIMELINE, duration=a["time_s"])]

        def scalars(path: str, values: np.ndarray) -> None:
            send(path, indexes=idx, columns=rr.Scalars.columns(scalars=np.ascontiguousarray(values, dtype=np.float64)))

        for i, body in enumerate(telemetry.bodies):
            send(
                f"world/arm/{body}",
                indexes=idx,
                columns=rr.Transform3D.columns(
                    translation=a["body_pos_m"][:, i], quaternion=wxyz_to_xyzw(a["body_quat_wxyz"][:, i])
                ),
            )
        self._send_ghost(a, idx)
        true_deg = np.degrees(a["true_angle_rad"])
        pred_deg = np.degrees(a["predicted_angle_rad"])
        target_deg = np.degrees(a["target_angle_rad"])
        for k, j in enumerate(telemetry.joints):
            p = f"joints/{j}"
            scalars(f"{p}/angle_deg/true", true_deg[:, k])
            scalars(f"{p}/angle_deg/predicted", pred_deg[:, k])
            scalars(f"{p}/angle_deg/target", target_deg[:, k])
            scalars(f"{p}/error_deg/predicted_minus_true", pred_deg[:, k] - true_deg[:, k])
            scalars(f"{p}/error_deg/target_minus_true", target_deg[:, k] - true_deg[:, k])
            scalars(f"{p}/pressure_bar/chamber_a", a["pressure_a_pa"][:, k] / PA_PER_BAR)
            scalars(f"{p}/pressure_bar/chamber_b", a["pressure_b_pa"][:, k] / PA_PER_BAR)
            scalars(f"{p}/valve/direction", a["direction"][:, k])
            scalars(f"{p}/valve/gauge_bar", a["valve_gauge_pa"][:, k] / PA_PER_BAR)
            scalars(f"{p}/brake/release", a["brake_release"][:, k])
            scalars(f"{p}/brake/engagement", a["brake_engagement"][:, k])
        scalars("supply/pressure_bar", a["supply_pa"] / PA_PER_BAR)
        scalars("brush/force_n", a["brush_force_n"])
        # the brush's push on the string, drawn where it touches: an arrow per sample in contact,
        # none otherwise (rows of length 0 clear it); 1 mm per N
        touching = np.isfinite(a["brush_contact_m"][:, 0])
        send(
            "world/brush_contact",
            indexes=idx,
            columns=rr.Arrows3D.columns(
                origins=a["brush_contact_m"][touching], vectors=1e-3 * a["brush_push_n"][touching]
            ).partition(touching.astype(np.int32)),
        )

    def _send_ghost(self, a: dict[str, np.ndarray], idx: list) -> None:
        """The arm at the controller's predicted angles, for the samples that have a prediction
        (a replayed command schedule has none: then no ghost is drawn at all)."""
        pos, quat, drawn = self._ghost.poses(a["predicted_angle_rad"], a["true_angle_rad"])
        if not drawn.any():
            return
        if not self._ghost_drawn:
            log_static_geometry(self.rec, self.model, ghost=True)
            self._ghost_drawn = True
        times = [rr.TimeColumn(TIMELINE, duration=a["time_s"][drawn])]
        for i, body in enumerate(self.bodies):
            self.rec.send_columns(
                f"{GHOST_PATH}/{body}",
                indexes=times,
                columns=rr.Transform3D.columns(translation=pos[drawn, i], quaternion=wxyz_to_xyzw(quat[drawn, i])),
            )

    def write_events(self, events) -> None:
        """The controller's and the operator's reports (twin.events.Event), as a text log."""
        if not events:
            return
        self.rec.send_columns(
            EVENTS_PATH,
            indexes=[rr.TimeColumn(TIMELINE, duration=[e.time_s for e in events])],
            columns=rr.TextLog.columns(
                text=[f"{e.source}: {e.text}" for e in events], level=[e.level.value for e in events]
            ),
        )

    def log_frames(self, frames: list[tuple[float, bytes]]) -> None:
        """Log camera frames (simulated time s, JPEG bytes), e.g. those a replayed log holds."""
        self._frames_seen += len(frames)
        for t, jpeg in frames:
            self.rec.set_time(TIMELINE, duration=t)
            self.rec.log(CAMERA_PATH, rr.EncodedImage(contents=jpeg, media_type="image/jpeg"))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._pending is not None:
            self._send(self._telemetry, self._pending)
        if self._camera is not None:
            self.log_frames(self._camera.frames_from(self._frames_seen, wait=True))
            if self._camera.error:  # the recording holds everything else
                log.warning("note: no camera frames in %s: %s", self.path or "the viewer", self._camera.error)
        close_recording(self.rec, self.path)
