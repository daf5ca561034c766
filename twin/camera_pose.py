"""Where a scene camera stands and what it sees, for the logs' 3D views: a pinhole in rerun, a
foxglove.CameraCalibration in the MCAP.

MuJoCo's camera frame has x to the right, y up and looks along -z (MJCF reference, camera); its
vertical field of view is `fovy` and its pixels are square, so the focal length in pixels is
(height / 2) / tan(fovy / 2) both ways, with the principal point at the image's centre. Foxglove
(and OpenCV) put an image's optical frame x right, y down, z forward: that frame is MuJoCo's
turned half a turn about its x axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

FRAME_WIDTH, FRAME_HEIGHT = 480, 360  # px: the camera frames the recordings hold (twin.camera)


@dataclass(frozen=True)
class CameraPose:
    name: str
    width: int  # px
    height: int  # px
    position_m: np.ndarray  # (3,) world
    quat_wxyz: np.ndarray  # (4,) world from MuJoCo's camera frame (x right, y up, looking along -z)
    focal_px: float  # focal length in pixels, both axes

    def intrinsics(self) -> np.ndarray:
        """The 3x3 matrix K from camera-frame rays (x right, y down, z forward) to pixels."""
        return np.array([[self.focal_px, 0.0, self.width / 2], [0.0, self.focal_px, self.height / 2], [0.0, 0.0, 1.0]])

    def optical_quat_wxyz(self) -> np.ndarray:
        """World from the optical frame (x right, y down, z forward): MuJoCo's frame turned by pi about x."""
        out = np.empty(4)
        mujoco.mju_mulQuat(out, self.quat_wxyz, np.array([0.0, 1.0, 0.0, 0.0]))
        return out


def camera_pose(
    model: mujoco.MjModel, name: str = "global_view", width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT
) -> CameraPose | None:
    """The pose of camera `name` if the model has it fixed to the world (None otherwise: a camera
    carried by a moving body has no single pose to log)."""
    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
    if cam < 0 or model.cam_bodyid[cam] != 0:
        return None
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, data.cam_xmat[cam])
    focal = (height / 2) / math.tan(math.radians(float(model.cam_fovy[cam])) / 2)
    return CameraPose(name, width, height, data.cam_xpos[cam].copy(), quat, focal)
