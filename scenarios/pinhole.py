"""A scene camera as a pinhole: world points to pixel coordinates, the way MuJoCo renders it.

MuJoCo's camera looks along its frame's -z with +y up and a vertical field of view `fovy`; the
image's focal length in pixels is (height / 2) / tan(fovy / 2), square pixels, the principal point
at the image's centre. Pixel coordinates here: u to the right, v down, (0, 0) the top-left corner
of the top-left pixel, so pixel (i, j) spans u in [i, i+1], v in [j, j+1] (a rendered image's
row j, column i). tests/test_operator.py holds this against MuJoCo's own renderer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True, kw_only=True)
class Pinhole:
    position_m: np.ndarray  # camera centre, world frame
    R_world_cam: np.ndarray  # columns: the camera's x (right), y (up), z (backwards) in world
    focal_px: float
    width_px: int
    height_px: int

    def camera_frame(self, points_world: np.ndarray) -> np.ndarray:
        """Points (k, 3) in the camera's frame (z negative in front of it)."""
        return (np.asarray(points_world, dtype=float) - self.position_m) @ self.R_world_cam

    def project(self, points_world: np.ndarray) -> np.ndarray:
        """Pixel coordinates (k, 2): u right, v down; NaN for points behind the camera."""
        c = self.camera_frame(np.atleast_2d(points_world))
        depth = -c[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = self.width_px / 2 + self.focal_px * c[:, 0] / depth
            v = self.height_px / 2 - self.focal_px * c[:, 1] / depth
        uv = np.stack([u, v], axis=1)
        uv[depth <= 0] = np.nan
        return uv

    def metres_per_px(self, depth_m: float) -> float:
        """Size of one pixel at `depth_m` along the optical axis."""
        return depth_m / self.focal_px


def camera_of(model: mujoco.MjModel, data: mujoco.MjData, name: str, width_px: int, height_px: int) -> Pinhole:
    """The named camera of a model at the pose in `data` (after mj_forward or a step)."""
    cam = data.camera(name)
    fovy = math.radians(float(model.camera(name).fovy[0]))
    return Pinhole(
        position_m=cam.xpos.copy(),
        R_world_cam=cam.xmat.reshape(3, 3).copy(),
        focal_px=(height_px / 2) / math.tan(fovy / 2),
        width_px=int(width_px),
        height_px=int(height_px),
    )
