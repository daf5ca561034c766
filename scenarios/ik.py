"""Where the joints must be for the brush to stand on an insulator disc's rim.

The base yaw turns the arm's plane to the target (the shoulder sits on the yaw axis, arm.xml), the
tool roll stays at zero, so in that plane the shoulder and the parallelogram elbow form a planar
two-link arm and the inverse kinematics is closed-form (law of cosines, elbow above the line from
shoulder to wrist). Lengths are read from the compiled model, not repeated here. A disc's rim is
the one facing the arm's base (scenarios/string.py), wherever the string stands.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Iterator

import mujoco
import numpy as np

from scenarios.string import Disc, discs_of

# the brush's face stands this far in front of its centre site (cylinder half-length, arm.xml)
BRUSH_HALF_LENGTH_M = 0.03
# the margin a planned pose keeps from every joint's stop (rad): four times the arrival band (control/pid.py)
RANGE_MARGIN_RAD = math.radians(2.0)


# the lengths per model, with the geometry they were read from: allocating an MjData costs ~1 ms
# (the scene's arena) and the operator asks for the lengths at every look
_LENGTHS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def arm_lengths(model: mujoco.MjModel) -> tuple[np.ndarray, float, float, float]:
    """(shoulder position, upper arm, forearm, wrist axis to brush_tip) in m, at the zero pose
    (the model's qpos0), read from the model as it is now."""
    geometry = b"".join(
        a.tobytes()
        for a in (model.qpos0, model.body_pos, model.body_quat, model.jnt_pos, model.jnt_axis, model.site_pos)
    )
    known = _LENGTHS.get(model)
    if known is not None and known[0] == geometry:
        shoulder, upper, fore, tool = known[1]
        return shoulder.copy(), upper, fore, tool
    d = mujoco.MjData(model)
    mujoco.mj_forward(model, d)
    shoulder = d.body("upper_arm").xpos.copy()
    upper = float(np.linalg.norm(d.body("forearm").xpos - shoulder))
    fore = float(np.linalg.norm(d.body("wrist").xpos - d.body("forearm").xpos))
    tool = float(np.linalg.norm(d.site("brush_tip").xpos - d.body("wrist").xpos))
    _LENGTHS[model] = (geometry, (shoulder.copy(), upper, fore, tool))
    return shoulder, upper, fore, tool


def tool_drive_angles(model: mujoco.MjModel, tip_target: np.ndarray, tool_pitch_rad: float = 0.0) -> dict[str, float]:
    """Drive angles (rad) that put brush_tip at `tip_target` with the tool's absolute pitch
    `tool_pitch_rad` (0: level, pointing away from the base axis): the base yaw turns the arm's
    plane through the target (0 for a target on the x axis).

    Drive coordinates: shoulder = shoulder pitch, elbow = forearm's absolute pitch (parallelogram),
    wrist = tool pitch - forearm pitch. ValueError if out of reach.
    """
    shoulder, l1, l2, lt = arm_lengths(model)
    yaw = math.atan2(tip_target[1], tip_target[0])
    radial = math.hypot(tip_target[0], tip_target[1])  # the shoulder is on the yaw axis: radial = x in its plane
    wx = radial - lt * math.cos(tool_pitch_rad) - shoulder[0]
    wz = tip_target[2] - lt * math.sin(tool_pitch_rad) - shoulder[2]
    r = math.hypot(wx, wz)
    if not abs(l1 - l2) < r < l1 + l2:
        raise ValueError(f"brush target {tip_target} is out of reach (wrist at {r:.3f} m from the shoulder)")
    # elbow above the shoulder-wrist line: upper arm raised by the triangle's angle at the shoulder
    alpha = math.atan2(wz, wx)
    beta = math.acos((l1 * l1 + r * r - l2 * l2) / (2 * l1 * r))
    q_shoulder = alpha + beta
    elbow_x = l1 * math.cos(q_shoulder)
    elbow_z = l1 * math.sin(q_shoulder)
    q_forearm = math.atan2(wz - elbow_z, wx - elbow_x)  # absolute pitch of the forearm
    return {
        "base_yaw": yaw,
        "shoulder_pitch": q_shoulder,
        "elbow_pitch": q_forearm,
        "wrist_pitch": tool_pitch_rad - q_forearm,
        "tool_roll": 0.0,
    }


def carrier_m(model: mujoco.MjModel, drive: dict[str, float]) -> np.ndarray:
    """Where brush_tip stands (world) at these drive angles (rad): the forward counterpart of
    `tool_drive_angles`, the tool roll left out (it turns the brush about its own axis)."""
    shoulder, l1, l2, lt = arm_lengths(model)
    s, f, tool = drive["shoulder_pitch"], drive["elbow_pitch"], drive["elbow_pitch"] + drive["wrist_pitch"]
    radial = shoulder[0] + l1 * math.cos(s) + l2 * math.cos(f) + lt * math.cos(tool)
    z = shoulder[2] + l1 * math.sin(s) + l2 * math.sin(f) + lt * math.sin(tool)
    yaw = drive["base_yaw"]
    return np.array([radial * math.cos(yaw), radial * math.sin(yaw), z])


def disc_drive_angles(model: mujoco.MjModel, disc: int, standoff_m: float = -0.006) -> dict[str, float]:
    """Drive angles for the brush on disc `disc`'s rim: the tool level where the arm reaches,
    else tilted in 5 deg steps (up to 45 deg, up or down: the top and the bottom discs), with
    every joint inside its range."""
    try:
        return tip_drive_angles(model, disc_rim_target(model, disc, standoff_m), 0.0)
    except ValueError:
        raise ValueError(f"disc_{disc} is out of the brush's reach (standoff {standoff_m} m)") from None


def tip_drive_angles(model: mujoco.MjModel, tip_target: np.ndarray, tilt_rad: float) -> dict[str, float]:
    """Drive angles that put brush_tip at `tip_target` with every joint inside its range: the tool
    at `tilt_rad` where the arm reaches, else tilted from it in 5 deg steps (up to 45 deg either
    way; the brush's tilt is free within that, its position is not). ValueError if none does."""
    for drive in _tilted(model, tip_target, tilt_rad):
        return drive
    raise ValueError(f"brush target {tip_target} is out of reach with every joint inside its range")


def _tilted(model: mujoco.MjModel, tip_target: np.ndarray, tilt_rad: float) -> Iterator[dict[str, float]]:
    """Each pose putting brush_tip at `tip_target` with every joint inside its range, in the order
    `tip_drive_angles` tries them: the tool at `tilt_rad`, then tilted from it 5 deg at a time, the
    nearer first (up before down at the same angle), up to 45 deg either way."""
    for step_deg in sorted(range(-45, 50, 5), key=lambda t: (abs(t), -t)):
        try:
            drive = tool_drive_angles(model, tip_target, tilt_rad + math.radians(step_deg))
        except ValueError:
            continue
        if _within_ranges(model, drive_to_qpos(drive)):
            yield drive


def _within_ranges(model: mujoco.MjModel, qpos: dict[str, float]) -> bool:
    return not joint_out_of_range(model, qpos, RANGE_MARGIN_RAD)


def joint_out_of_range(model: mujoco.MjModel, qpos: dict[str, float], margin_rad: float = 0.0) -> str:
    """The first joint of `qpos` (MuJoCo joint angles, rad) outside its range narrowed by `margin_rad`
    at each end; '' if none is."""
    for j, q in qpos.items():
        lo, hi = model.joint(j).range
        if not lo + margin_rad <= q <= hi - margin_rad:
            return j
    return ""


def disc_rim_target(model: mujoco.MjModel, disc: int, standoff_m: float) -> np.ndarray:
    """brush_tip position that puts the brush face on disc `disc`'s rim facing the arm, in the
    model's scene (the truth; the operator's plan uses `rim_target` on the discs he found).

    A negative standoff presses the brush into the rim; a positive one holds it clear.
    """
    return rim_target(discs_of(model)[disc - 1], standoff_m)


def normal_pitch(disc: Disc) -> float:
    """The tool's absolute pitch (rad) that points it into the rim along the rim's normal: level
    on a vertical string, tilted as the disc is on a leaning one."""
    _, normal = disc.rim_facing()
    return math.atan2(-normal[2], math.hypot(normal[0], normal[1]))


def rim_target(disc: Disc, standoff_m: float) -> np.ndarray:
    """brush_tip position that puts the brush face `standoff_m` off `disc`'s rim facing the arm,
    along the rim's outward normal (negative: pressed into it)."""
    rim, normal = disc.rim_facing()
    return rim + (BRUSH_HALF_LENGTH_M + standoff_m) * normal


def rim_drive_angles(
    model: mujoco.MjModel, disc: Disc, standoff_m: float, tilt_rad: float | None = None
) -> dict[str, float]:
    """Drive angles putting the brush face `standoff_m` off `disc`'s rim, the tool at the absolute
    pitch `tilt_rad` (None: along the rim's normal), tilted from it in 5 deg steps where out of
    range (`tip_drive_angles`). ValueError if none does."""
    return tip_drive_angles(model, rim_target(disc, standoff_m), normal_pitch(disc) if tilt_rad is None else tilt_rad)


def rim_pitches(model: mujoco.MjModel, disc: Disc, standoff_m: float, tilt_rad: float | None = None) -> list[float]:
    """The tool's absolute pitches (rad) of every pose `rim_drive_angles` could take for the brush
    `standoff_m` off `disc`'s rim, in the order it tries them (empty: out of reach)."""
    tilt = normal_pitch(disc) if tilt_rad is None else tilt_rad
    return [d["elbow_pitch"] + d["wrist_pitch"] for d in _tilted(model, rim_target(disc, standoff_m), tilt)]


def drive_to_qpos(drive: dict[str, float]) -> dict[str, float]:
    """Joint angles (qpos) from drive angles: the parallelogram's elbow drive is absolute."""
    q = dict(drive)
    if "elbow_pitch" in drive:
        q["elbow_pitch"] = drive["elbow_pitch"] - drive.get("shoulder_pitch", 0.0)
    return q


def qpos_to_drive(q: dict[str, float]) -> dict[str, float]:
    """Drive angles from joint angles (inverse of `drive_to_qpos`)."""
    drive = dict(q)
    if "elbow_pitch" in q:
        drive["elbow_pitch"] = q["elbow_pitch"] + q.get("shoulder_pitch", 0.0)
    return drive
