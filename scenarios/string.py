"""The insulator string's geometry: where its discs stand, and the scene built around it at run time.

A scenario's `[string]` table says where the string really stands (the top disc's centre, the
string turned about the arm's base axis, its axis leaning from vertical, the number of discs and
their pitch); `scene_spec` builds the scene from `assets/scene.xml` with the file's string replaced
by that one (MuJoCo's MjSpec), so assets/scene.xml stays the default and no file is edited. The
discs keep the file's disc type (the `disc_shell` class: 255 mm shed, 20 mm rim, U70BL).

A disc is a flat cylinder: its centre, its axis (unit, pointing up the string) and its radius. The
brush works on the rim point that faces the arm's base axis (the world's z axis through the
origin, where the shoulder turns): `rim_facing` gives that point and the rim's outward normal
there (in the disc's plane, towards the arm). Everything that places the brush on a disc, judges a
contact or draws the operator's picture takes the discs from here, never from fixed numbers.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np

import assets

DISC_CLASS, CAP_CLASS = "disc_shell", "disc_cap"
CAP_ABOVE_M = 0.045  # the cap's centre above its shell's (assets/scene.xml: 1.295 over 1.250)
HANGER_TOP_Z_M = 1.655  # the hanger's top, under the gantry's beam (scene.xml: 1.4675 + 0.1875)
MAX_DISCS = 12  # a 110-150 kV string (IEC 60383 practice: 7-10 U70 discs at 110 kV, more with fouling)


@dataclass(frozen=True, kw_only=True)
class Disc:
    """One disc's shell: centre (3,) m, axis (3,) unit up the string, radius m, half-thickness m."""

    centre_m: np.ndarray
    axis: np.ndarray
    radius_m: float
    half_thickness_m: float

    def rim_facing(self, towards_m: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(rim point, outward unit normal there) on the side facing the vertical axis through
        `towards_m` (default: the arm's base axis, the world's z axis): the horizontal direction
        from the centre to that axis, laid into the disc's plane."""
        towards = np.zeros(3) if towards_m is None else np.asarray(towards_m, dtype=float)
        d = towards - self.centre_m
        d[2] = 0.0
        d -= (d @ self.axis) * self.axis  # into the disc's plane
        normal = d / max(float(np.linalg.norm(d)), 1e-12)
        return self.centre_m + self.radius_m * normal, normal

    def frame(self) -> np.ndarray:
        """(3, 3) columns: the disc's x (towards the arm's side, in its plane), y, axis."""
        _, normal = self.rim_facing()
        x = -normal
        return np.column_stack([x, np.cross(self.axis, x), self.axis])


def string_discs(
    x_m: float,
    y_m: float,
    top_z_m: float,
    yaw_deg: float,
    tilt_deg: float,
    discs: int,
    pitch_m: float,
    radius_m: float,
    half_thickness_m: float,
) -> list[Disc]:
    """The discs of a string whose top disc's centre is at (x, y, top_z) turned by yaw_deg about
    the arm's base axis, its axis leaning tilt_deg from vertical (about the top disc's centre;
    positive: the bottom towards the arm), `discs` of them `pitch_m` apart, top first."""
    yaw = math.radians(yaw_deg)
    top = np.array([x_m * math.cos(yaw) - y_m * math.sin(yaw), x_m * math.sin(yaw) + y_m * math.cos(yaw), top_z_m])
    radial = np.array([top[0], top[1], 0.0])
    radial /= max(float(np.linalg.norm(radial)), 1e-12)  # from the base axis out to the string
    tilt = math.radians(tilt_deg)
    axis = math.cos(tilt) * np.array([0.0, 0.0, 1.0]) + math.sin(tilt) * radial  # up: the bottom leans in
    return [
        Disc(centre_m=top - k * pitch_m * axis, axis=axis, radius_m=radius_m, half_thickness_m=half_thickness_m)
        for k in range(discs)
    ]


def discs_of(model: mujoco.MjModel) -> list[Disc]:
    """The discs of a compiled scene (geoms disc_1, disc_2, ... as far as they go), top first."""
    out = []
    while mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"disc_{len(out) + 1}") >= 0:
        g = model.geom(f"disc_{len(out) + 1}")
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, g.quat)
        axis = rot.reshape(3, 3)[:, 2].copy()  # the geom's z: the disc's axis
        out.append(Disc(centre_m=g.pos.copy(), axis=axis, radius_m=float(g.size[0]), half_thickness_m=float(g.size[1])))
    return out


def disc_type(spec: mujoco.MjSpec) -> tuple[float, float]:
    """(radius, half-thickness) m of the scene's disc shell class."""
    size = spec.find_default(DISC_CLASS).geom.size
    return float(size[0]), float(size[1])


@functools.cache
def believed_disc_type() -> tuple[float, float]:
    """(radius, half-thickness) m of the disc type the platform's crew knows the line has: the
    scene file's (assets/scene.xml, U70BL); a scenario's [string] moves discs, not their type."""
    return disc_type(scene_spec())


@functools.cache
def believed_discs() -> tuple[Disc, ...]:
    """The string where the scene file puts it: what a platform without the camera plans for."""
    return tuple(discs_of(scene_spec().compile()))


def scene_spec(placement=None) -> mujoco.MjSpec:
    """assets/scene.xml as an MjSpec, its string replaced by `placement` (a schema `String`: the
    fields of `string_discs`); None: the file as it is."""
    spec = mujoco.MjSpec.from_file(str(assets.SCENE_XML))
    if placement is None:
        return spec
    radius, half = disc_type(spec)
    discs = string_discs(
        placement.x_m,
        placement.y_m,
        placement.top_z_m,
        placement.yaw_deg,
        placement.tilt_deg,
        placement.discs,
        placement.pitch_m,
        radius,
        half,
    )
    for g in list(spec.geoms):
        if g.name.startswith("disc_") or g.name == "string_hanger":
            spec.delete(g)
    world = spec.worldbody
    shell, cap = spec.find_default(DISC_CLASS), spec.find_default(CAP_CLASS)
    for k, disc in enumerate(discs, start=1):
        quat = _quat_z_to(disc.axis)
        world.add_geom(name=f"disc_{k}", default=shell, pos=disc.centre_m, quat=quat)
        world.add_geom(name=f"disc_{k}_cap", default=cap, pos=disc.centre_m + CAP_ABOVE_M * disc.axis, quat=quat)
    top = discs[0].centre_m + CAP_ABOVE_M * discs[0].axis
    length = max(HANGER_TOP_Z_M - top[2], 0.02)  # the hanger from the top cap up to the beam (visual)
    world.add_geom(
        name="string_hanger",
        default=spec.find_default("scenery"),
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.012, length / 2, 0],
        pos=top + [0.0, 0.0, length / 2],
    )
    return spec


def _quat_z_to(axis: np.ndarray) -> np.ndarray:
    """The quaternion (w, x, y, z) turning the z axis onto `axis` (unit)."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ axis)
    v = np.cross(z, axis)
    q = np.array([1.0 + c, *v])
    return q / np.linalg.norm(q) if np.linalg.norm(q) > 1e-12 else np.array([0.0, 1.0, 0.0, 0.0])
