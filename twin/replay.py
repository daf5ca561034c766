"""MCAP -> rerun: make a recording from a logged run (`twin replay FILE.mcap --rrd OUT`).

The MCAP holds the telemetry and the body names, not the geometry: the geometry is read from the
MJCF the run used, after checking that its bodies are the ones the log names. Unless told which
(`--model`), that is the shipped model the attached scenario names (its `model` field), or else
the shipped model whose bodies are the log's.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import mujoco
import numpy as np

import assets
from twin.mcap_log import LogError, read_mcap
from twin.model import body_name
from twin.rerun_log import RerunRecorder, most_travelled_joint


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


SHIPPED_MODELS = {"arm": assets.SCENE_XML, "wrist_rig": assets.WRIST_RIG_XML}  # scenario `model` -> MJCF


def _load(path: Path) -> tuple[mujoco.MjModel, tuple[str, ...]]:
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as e:
        message = " ".join(str(e).split())  # MuJoCo's parser errors run over several lines
        raise LogError(f"{path}: cannot load the MJCF model for the geometry: {message}") from e
    return model, tuple(body_name(model, b) for b in range(1, model.nbody))


def _model_of(mcap_path, meta: dict, model_path=None) -> tuple[Path, mujoco.MjModel]:
    """The MJCF a logged run used: `model_path` if given, else the shipped model its attached
    scenario names, else the shipped model with the log's bodies. Its bodies must be the log's."""
    logged = tuple(meta["bodies"])
    if model_path:
        candidates = [Path(model_path)]
    else:
        try:
            named = tomllib.loads(meta.get("scenario_text") or "").get("model", "arm")
        except tomllib.TOMLDecodeError:
            named = None
        candidates = [Path(SHIPPED_MODELS[named])] if named in SHIPPED_MODELS else []
        candidates += [Path(p) for p in SHIPPED_MODELS.values() if Path(p) not in candidates]
    for path in candidates:
        model, bodies = _load(path)
        if bodies == logged:
            return path, model
    raise LogError(
        f"{mcap_path}: its bodies {list(logged)} are not those of {', '.join(map(str, candidates))}; "
        "pass the model the run used with --model"
    )


def replay(mcap_path, rrd_path, model_path=None) -> dict:
    """Write a rerun recording of the run logged in `mcap_path` (its camera frames too); returns
    the reader's recovery report (samples, duration_s, complete, stopped_by). Raises LogError on a bad input."""
    arrays, meta = read_mcap(mcap_path, frames=True)
    if meta["recovery"]["samples"] == 0:
        raise LogError(f"{mcap_path}: holds no complete telemetry sample; nothing to replay")
    model_path, model = _model_of(mcap_path, meta, model_path)
    rrd_path = Path(rrd_path)
    rrd_path.parent.mkdir(parents=True, exist_ok=True)
    focus = most_travelled_joint(tuple(meta["joints"]), arrays["true_angle_rad"])
    frames = meta["camera_frames"]
    recorder = RerunRecorder(rrd_path, model, meta["joints"], meta, focus=focus, camera_view=bool(frames))
    try:
        recorder.write(LoggedRun(arrays, meta["joints"], meta["bodies"]), 0)
        recorder.log_frames(frames)
    finally:
        recorder.close()
    return meta["recovery"]
