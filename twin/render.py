"""Offscreen frames of the model with its bodies at poses taken from a log (what the camera
process renders for a recording, twin.camera): MuJoCo's renderer, no kinematics run."""

from __future__ import annotations

import mujoco
import numpy as np


def _quat_to_mat(q_wxyz: np.ndarray) -> np.ndarray:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.asarray(q_wxyz, dtype=np.float64))
    return out.reshape(3, 3)


def pose_geoms(model: mujoco.MjModel, data: mujoco.MjData, body_pos: np.ndarray, body_quat_wxyz: np.ndarray) -> None:
    """Put every body at the given world poses (bodies 1.., as in Telemetry) and move the geoms
    with them, without running kinematics: what a log holds is enough to draw the arm."""
    for i in range(body_pos.shape[0]):
        b = i + 1
        R = _quat_to_mat(body_quat_wxyz[i])
        data.xpos[b] = body_pos[i]
        data.xquat[b] = body_quat_wxyz[i]
        data.xmat[b] = R.ravel()
    for g in range(model.ngeom):
        b = model.geom_bodyid[g]
        if b == 0:
            continue
        R = data.xmat[b].reshape(3, 3)
        data.geom_xpos[g] = data.xpos[b] + R @ model.geom_pos[g]
        data.geom_xmat[g] = (R @ _quat_to_mat(model.geom_quat[g])).ravel()


class PoseRenderer:
    """Offscreen frames of a camera for body poses taken from a log. Close it when done (an
    unclosed mujoco.Renderer prints an OpenGL error at interpreter exit)."""

    # what a software GL (llvmpipe, no GPU) spends most on: 82 ms a 480x360 frame with them, 14 without
    COSTLY_EFFECTS = (
        mujoco.mjtRndFlag.mjRND_SHADOW,
        mujoco.mjtRndFlag.mjRND_REFLECTION,
        mujoco.mjtRndFlag.mjRND_SKYBOX,
        mujoco.mjtRndFlag.mjRND_HAZE,
    )

    def __init__(
        self,
        model: mujoco.MjModel,
        camera: str = "global_view",
        width: int = 640,
        height: int = 480,
        plain: bool = False,
    ):
        # MuJoCo reads MUJOCO_GL once, at import: set it (egl or osmesa) before starting Python
        self.model, self.camera, self.plain = model, camera, plain
        self.data = mujoco.MjData(model)
        mujoco.mj_forward(model, self.data)  # world-fixed cameras, lights and geoms
        self.renderer = mujoco.Renderer(model, height, width)

    def render(self, body_pos: np.ndarray | None = None, body_quat_wxyz: np.ndarray | None = None) -> np.ndarray:
        if body_pos is not None:
            pose_geoms(self.model, self.data, body_pos, body_quat_wxyz)
        self.renderer.update_scene(self.data, self.camera)
        if self.plain:  # no shadows, reflections, skybox or haze
            for flag in self.COSTLY_EFFECTS:
                self.renderer.scene.flags[flag] = 0
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()
