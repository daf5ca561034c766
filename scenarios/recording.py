"""The logs a scenario's run writes (`twin run --rrd --mcap`, pneumatic_arm_twin.run): the
recorders opened for the scenario, and closed together whatever happens to one of them."""

from __future__ import annotations

from pathlib import Path

from scenarios.runner import build_plant, plan
from twin.camera import FrameFeed
from twin.mcap_log import McapRecorder
from twin.mcap_log import start_time as start_meta
from twin.rerun_log import RerunRecorder, moving_joint
from twin_plumbing.checks import RECORDING_CAMERA_FPS
from twin_plumbing.errors import UserError
from twin_plumbing.provenance import run_metadata
from twin_plumbing.signals import shielded


def open_recorders(
    scenario,
    rrd: Path | None,
    mcap: Path | None,
    camera_fps: float = RECORDING_CAMERA_FPS,
    start_time: str | None = None,
    viewer: str | None = None,
) -> list:
    """The log writers a run asked for, told what they need to know about the scenario;
    `start_time` ("now" or ISO 8601) starts the MCAP's clock there (twin.mcap_log.start_time);
    `viewer` streams the rerun recording live ("spawn": a viewer started here, else a viewer's
    gRPC URL), beside the `rrd` file or instead of it."""
    start = {} if start_time is None else start_meta(start_time)  # refused when bad, with or without a log
    if start and not mcap:
        raise UserError(
            f"--start-time {start_time}: sets the MCAP log's start, and no --mcap is asked for; "
            "allowed: --start-time with --mcap"
        )
    recorders = []
    if not (rrd or mcap or viewer):
        return recorders
    meta = run_metadata(scenario) | start
    plant = build_plant(scenario)
    frames = None
    if (rrd or viewer) and mcap and camera_fps > 0:  # one camera process renders each frame for both logs
        frames = FrameFeed(plant.model, camera_fps)
    if rrd or viewer:
        if rrd:
            rrd.parent.mkdir(parents=True, exist_ok=True)
        focus = moving_joint(plant.joints, plant.drive_angles(), plan(scenario, plant)[2])
        recorders.append(
            RerunRecorder(
                rrd, plant.model, plant.joints, meta, camera_fps=camera_fps, focus=focus, frames=frames, viewer=viewer
            )
        )
    if mcap:
        mcap.parent.mkdir(parents=True, exist_ok=True)
        recorders.append(McapRecorder(mcap, plant.model, plant.joints, meta, camera_fps=camera_fps, frames=frames))
    return recorders


def close_all(recorders) -> dict[Path, str]:
    """Close every recorder, also when one fails (a full disk, a vanished folder) or a signal
    arrives: the others still finish their files. Returns what failed (the log's path: why), for
    after the summary."""
    errors = {}
    with shielded():  # Ctrl-C or SIGTERM now would cut the very files it asks to keep
        for r in recorders:
            try:
                r.close()
            except (UserError, OSError) as e:
                errors[r.path] = str(e)
    return errors
