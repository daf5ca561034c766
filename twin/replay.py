"""MCAP -> rerun: make a recording from a logged run (`twin replay FILE.mcap --rrd OUT`).

The MCAP holds the telemetry and the body names, not the geometry: the geometry is read from the
MJCF the run used (assets/scene.xml unless told otherwise), after checking that its bodies are the
ones the log names.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

import assets
from twin.mcap_log import LogError, read_mcap
from twin.rerun_log import RerunRecorder, body_name, most_travelled_joint


class LoggedRun:
    """What a recorder needs of a Telemetry, backed by arrays read from a log."""

    def __init__(self, arrays: dict[str, np.ndarray], joints, bodies):
        self._arrays, self.joints, self.bodies = arrays, tuple(joints), tuple(bodies)

    def __len__(self) -> int:
        return len(self._arrays["time_s"])

    @property
    def time_s(self) -> np.ndarray:
        return self._arrays["time_s"]

    def time_at(self, i: int) -> float:
        return float(self._arrays["time_s"][i])

    def column(self, name: str, start: int = 0) -> np.ndarray:
        return self._arrays[name][start:]

    def arrays(self, start: int = 0) -> dict[str, np.ndarray]:
        return {k: v[start:] for k, v in self._arrays.items()}


def replay(mcap_path, rrd_path, model_path=None) -> dict:
    """Write a rerun recording of the run logged in `mcap_path`; returns the reader's recovery
    report (samples, duration_s, complete, stopped_by). Raises LogError on a bad input."""
    arrays, meta = read_mcap(mcap_path)
    if meta["recovery"]["samples"] == 0:
        raise LogError(f"{mcap_path}: holds no complete telemetry sample; nothing to replay")
    model_path = Path(model_path) if model_path else Path(assets.SCENE_XML)
    try:
        model = mujoco.MjModel.from_xml_path(str(model_path))
    except ValueError as e:
        raise LogError(f"{model_path}: cannot load the MJCF model for the geometry: {e}") from e
    bodies = tuple(body_name(model, b) for b in range(1, model.nbody))
    if bodies != tuple(meta["bodies"]):
        raise LogError(
            f"{mcap_path}: its bodies {list(meta['bodies'])} are not those of {model_path} {list(bodies)}; "
            "pass the model the run used with --model"
        )
    rrd_path = Path(rrd_path)
    rrd_path.parent.mkdir(parents=True, exist_ok=True)
    focus = most_travelled_joint(tuple(meta["joints"]), arrays["true_angle_rad"])
    recorder = RerunRecorder(rrd_path, model, meta["joints"], meta, focus=focus)
    try:
        recorder.write(LoggedRun(arrays, meta["joints"], meta["bodies"]), 0)
    finally:
        recorder.close()
    return meta["recovery"]
