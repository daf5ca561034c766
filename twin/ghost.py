"""The arm the controller believes in: body poses at the predicted drive angles (the "ghost").

A sensorless controller closes its loop on a prediction; drawn beside the true arm, the predicted
arm shows where and when the two part. The logs (rerun, MCAP) draw it from these poses.

Each joint's drive coordinate is a fixed tendon over the model's joints (the elbow's is shoulder +
elbow: the parallelogram, assets/arm.xml), so drive angles map to joint angles by the inverse of
the tendons' coefficient matrix (twin.model.drive_map); MuJoCo's forward kinematics then gives
each body's world pose. Joints no drive turns (the brush's spring stroke) stay at the model's
reference pose, and a joint the controller does not predict (NaN) is drawn at its true angle.
"""

from __future__ import annotations

import mujoco
import numpy as np

import assets
from twin.model import drive_map, ids


class GhostArm:
    """Body poses of `model` at given drive angles of `joints` (rad), bodies 1.. in order."""

    def __init__(self, model: mujoco.MjModel, joints):
        self.model = model
        dm = drive_map(model, ids(model, mujoco.mjtObj.mjOBJ_TENDON, [assets.drive_tendon(j) for j in joints]))
        used = dm[:, :, 2] != 0.0
        self._qpos = np.array(sorted({int(a) for a in dm[:, :, 0][used]}), dtype=np.int64)
        coef = np.zeros((len(joints), len(self._qpos)))
        where = {int(a): c for c, a in enumerate(self._qpos)}
        for i in range(len(joints)):
            for adr, _, k in dm[i][used[i]]:
                coef[i, where[int(adr)]] += k
        if coef.shape[0] != coef.shape[1] or abs(np.linalg.det(coef)) < 1e-9:
            raise ValueError(f"the drive tendons of {tuple(joints)} do not fix their joints' angles")
        self._joint_from_drive = np.linalg.inv(coef)
        self._data = mujoco.MjData(model)

    def poses(self, predicted_rad: np.ndarray, true_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(positions (T, b, 3) m, orientations (T, b, 4) wxyz, drawn (T,) bool) of the bodies at
        `predicted_rad` (T, n), each NaN taken from `true_rad`; a sample without any prediction
        is not drawn (its poses are NaN)."""
        predicted_rad = np.atleast_2d(predicted_rad)
        drawn = np.isfinite(predicted_rad).any(axis=1)
        drive = np.where(np.isfinite(predicted_rad), predicted_rad, true_rad)
        q = drive @ self._joint_from_drive.T
        m, d = self.model, self._data
        nb = m.nbody - 1
        pos, quat = np.full((len(q), nb, 3), np.nan), np.full((len(q), nb, 4), np.nan)
        for k in np.flatnonzero(drawn & np.isfinite(q).all(axis=1)):
            d.qpos[:] = m.qpos0
            d.qpos[self._qpos] = q[k]
            mujoco.mj_kinematics(m, d)
            pos[k], quat[k] = d.xpos[1:], d.xquat[1:]
        return pos, quat, drawn
