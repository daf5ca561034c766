"""An arm campaign's diagnosis in rerun: the measured arm and the replayed arm side by side, the
departing joint marked (docs/gap_arm.md, "Seeing it").

For each withheld run (where the diagnosis judges its fit), on a timeline of the run's name:

    world/scene/<geom>, world/string/<disc>   the floor, the gantry, the insulator string (static)
    world/measured_arm/<body>[/<geom>]        the arm at the instrument's drive angles, drawn
                                              `latency_s` earlier than they were read (when the arm
                                              was there); a joint the instrument does not see, or a
                                              frame it lost, at the replayed twin's angle
    world/replayed_arm/<body>[/<geom>]        the twin with the diagnosis' best fit (the nominal twin
                                              when none), replayed through the run's commands,
                                              translucent blue, 50 poses a simulated second
    world/measured_arm/<link>/departs         a labelled point at the departing joint's axis; that
                                              link red on both arms
    joints/<joint>/angle_deg/{measured,replayed,nominal}
    joints/<joint>/residual_deg/{nominal,replayed}   measured - twin at the instrument's samples
    joints/<joint>/pressure_bar/{measured_a,measured_b,replayed_a,replayed_b}   platform ports, absolute
    diagnosis                                 the verdict and each joint's gap (TextLog, at the run's start)

The arms' poses are MuJoCo's forward kinematics at the drive angles (twin.ghost.GhostArm: the
drive tendons' coefficients inverted to joint angles). The recording opens on the departing
joint's plots (tests/test_gap_arm_view.py reads it back with rerun's reader).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from gap.arm_campaign import JOINTS, ArmCampaign, ArmRun
from gap.arm_diagnose import ArmDiagnosis, ReplayedArm, _replays, _with, residual, twin_of
from gap.arm_effects import candidate_named
from gap.arm_replay import TICK_S, Replay, arm_plant
from gap.jobs import parallel_jobs
from twin.ghost import GhostArm
from twin.rerun_log import (
    PA_PER_BAR,
    close_recording,
    eye,
    log_arm_geometry,
    log_scene_geometry,
    open_recording,
    wxyz_to_xyzw,
)
from twin.sim import LOG_PERIOD_S

MEASURED_PATH = "world/measured_arm"
REPLAYED_PATH = "world/replayed_arm"
VERDICT_PATH = "diagnosis"
DRAW_PERIOD_S = LOG_PERIOD_S  # the replayed arm's poses and series as often as a run's recording samples
REPLAYED_RGBA = (60, 170, 255, 110)  # the twin's blue, translucent
DEPARTS_RGBA = (230, 40, 40, 255)  # the departing joint's link on the measured arm
DEPARTS_REPLAYED_RGBA = (230, 40, 40, 110)  # and on the replayed arm
DEPARTS_RADIUS_M = 0.04  # the marker at the departing joint's axis
# series on the viewer's dark theme: the instrument white points, the fitted twin blue, the nominal grey
SERIES = {
    "angle_deg/replayed": ((60, 170, 255), "replayed (best fit)"),
    "angle_deg/nominal": ((150, 150, 150), "nominal twin"),
    "residual_deg/replayed": ((60, 170, 255), "measured - best fit"),
    "residual_deg/nominal": ((150, 150, 150), "measured - nominal"),
    "pressure_bar/replayed_a": ((255, 90, 90), "port A, replayed"),
    "pressure_bar/replayed_b": ((90, 160, 255), "port B, replayed"),
}
POINTS = {
    "angle_deg/measured": ((245, 245, 245), "measured"),
    "pressure_bar/measured_a": ((255, 150, 150), "port A, measured"),
    "pressure_bar/measured_b": ((150, 200, 255), "port B, measured"),
}


def departing_link(model: mujoco.MjModel, joint: str) -> str:
    """The body `joint` turns (the link drawn red)."""
    return model.body(int(model.jnt_bodyid[model.joint(joint).id])).name


def fitted_twin(campaign: ArmCampaign, diagnosis: ArmDiagnosis) -> tuple[ReplayedArm, str]:
    """The twin with the diagnosis' best candidate at its fitted value (the nominal twin when it
    fitted none), and a label saying which."""
    twin = twin_of(campaign)
    if not diagnosis.fits:
        return twin, "nominal twin (nothing fitted)"
    best = min(diagnosis.fits, key=lambda f: f.withheld_misfit)
    return _with(twin, candidate_named(best.candidate), best.value), f"{best.candidate} = {best.value:.4g}"


@dataclass(frozen=True)
class RunView:
    """One run's arms: the measured drive angles (NaN where none) with their times, the replays."""

    run: ArmRun
    nominal: Replay
    replayed: Replay


def write_arm_view(
    path: Path, campaign: ArmCampaign, diagnosis: ArmDiagnosis, n_jobs: int = 1, scheduler: str | None = None
) -> None:
    """The recording of `diagnosis` on `campaign`'s withheld runs, written to `path` (.rrd)."""
    nominal = twin_of(campaign)
    fitted, label = fitted_twin(campaign, diagnosis)
    runs = [r for r in campaign.runs if r.name in diagnosis.withheld_runs] or campaign.runs
    with parallel_jobs(n_jobs, scheduler) as run_jobs:
        nom, rep = _replays(run_jobs, runs, [nominal, fitted])
    views = [RunView(r, n, p) for r, n, p in zip(runs, nom, rep, strict=True)]
    model = arm_plant(fitted.params, fitted.setup, runs[0].start_rad).model
    rec = open_recording(Path(path), None, _blueprint(model, diagnosis.joint or JOINTS[0]))
    try:
        _log_static(rec, model, diagnosis, label)
        arm = GhostArm(model, JOINTS)
        for v in views:
            _log_run(rec, arm, v, diagnosis, label)
    finally:
        close_recording(rec, Path(path))


def _log_static(rec, model: mujoco.MjModel, diagnosis: ArmDiagnosis, label: str) -> None:
    log_scene_geometry(rec, model)
    marked = {}
    if diagnosis.joint:
        link = departing_link(model, diagnosis.joint)
        marked = {link: DEPARTS_RGBA}
        axis = model.jnt_pos[model.joint(diagnosis.joint).id]
        rec.log(
            f"{MEASURED_PATH}/{link}/departs",
            rr.Points3D(
                positions=[axis],
                radii=[DEPARTS_RADIUS_M],
                colors=[DEPARTS_RGBA],
                labels=[f"{diagnosis.joint} departs"],
                show_labels=True,
            ),
            static=True,
        )
    log_arm_geometry(rec, model, MEASURED_PATH, None, marked)
    log_arm_geometry(rec, model, REPLAYED_PATH, REPLAYED_RGBA, {k: DEPARTS_REPLAYED_RGBA for k in marked})
    for j in JOINTS:
        for sub, (colour, name) in SERIES.items():
            rec.log(f"joints/{j}/{sub}", rr.SeriesLines(colors=[colour], names=[name]), static=True)
        for sub, (colour, name) in POINTS.items():
            rec.log(
                f"joints/{j}/{sub}", rr.SeriesPoints(colors=[colour], names=[name], marker_sizes=[2.0]), static=True
            )


def verdict_lines(diagnosis: ArmDiagnosis, label: str) -> list[tuple[str, str]]:
    """(text, level) rows of the verdict: the line, the arm replayed, each joint's gap before and after."""
    level = "WARN" if diagnosis.verdict.alarm else "INFO"
    rows = [(diagnosis.line(), level), (f"replayed arm: {label}", "INFO")]
    after = {g.joint: g for g in diagnosis.withheld_after}
    for g in diagnosis.withheld_before:
        a = after.get(g.joint, g)
        mark = "  <- departs" if g.joint == diagnosis.joint else ""
        rows.append(
            (
                f"{g.joint}: withheld angle {g.angle_rms_deg:.3f} -> {a.angle_rms_deg:.3f} deg rms, ports "
                f"{g.pressure_rms_kpa:.2f} -> {a.pressure_rms_kpa:.2f} kPa rms{mark}",
                "INFO",
            )
        )
    return rows


def _log_run(rec, arm: GhostArm, v: RunView, diagnosis: ArmDiagnosis, label: str) -> None:
    timeline = v.run.name
    latency = diagnosis.latency_s

    def at(t: np.ndarray) -> list:
        return [rr.TimeColumn(timeline, duration=t)]

    def scalars(p: str, t: np.ndarray, values: np.ndarray) -> None:
        keep = np.isfinite(values)
        if keep.any():
            rec.send_columns(p, indexes=at(t[keep]), columns=rr.Scalars.columns(scalars=values[keep]))

    rows = verdict_lines(diagnosis, label)
    rec.send_columns(
        VERDICT_PATH,
        indexes=at(np.zeros(len(rows))),
        columns=rr.TextLog.columns(text=[t for t, _ in rows], level=[lv for _, lv in rows]),
    )
    every = max(1, round(DRAW_PERIOD_S / TICK_S))
    t_rep = v.replayed.time_s[::every]
    rep_angle = v.replayed.angle_rad[::every]
    pos, quat, _ = arm.poses(rep_angle, rep_angle)
    _send_poses(rec, arm, REPLAYED_PATH, at(t_rep), pos, quat)

    # the instrument's samples inside the replay, each drawn when the arm was there (latency earlier)
    res_rep = residual(v.run, v.replayed, latency).angle
    res_nom = residual(v.run, v.nominal, latency).angle
    n = len(res_rep)
    t_meas = v.run.time_s[:n] - latency
    measured = v.run.angle_rad[:n]
    seen = np.isfinite(measured).any(axis=1) & (t_meas >= 0.0)
    fallback = np.stack(
        [np.interp(t_meas, v.replayed.time_s, v.replayed.angle_rad[:, j]) for j in range(len(JOINTS))], 1
    )
    pos, quat, drawn = arm.poses(measured[seen], fallback[seen])
    _send_poses(rec, arm, MEASURED_PATH, at(t_meas[seen][drawn]), pos[drawn], quat[drawn])

    t_port = v.run.time_s[:n]
    for k, j in enumerate(JOINTS):
        p = f"joints/{j}"
        scalars(f"{p}/angle_deg/measured", t_meas, np.degrees(measured[:, k]))
        scalars(f"{p}/angle_deg/replayed", t_rep, np.degrees(rep_angle[:, k]))
        scalars(f"{p}/angle_deg/nominal", t_rep, np.degrees(v.nominal.angle_rad[::every, k]))
        scalars(f"{p}/residual_deg/nominal", t_meas, np.degrees(res_nom[:, k]))
        scalars(f"{p}/residual_deg/replayed", t_meas, np.degrees(res_rep[:, k]))
        for c, side in enumerate("ab"):
            scalars(f"{p}/pressure_bar/measured_{side}", t_port, v.run.port_pa[:n, k, c] / PA_PER_BAR)
            scalars(f"{p}/pressure_bar/replayed_{side}", t_rep, v.replayed.port_pa[::every, k, c] / PA_PER_BAR)


def _send_poses(rec, arm: GhostArm, root: str, index: list, pos: np.ndarray, quat: np.ndarray) -> None:
    model = arm.model
    for i in range(model.nbody - 1):
        rec.send_columns(
            f"{root}/{model.body(i + 1).name}",
            indexes=index,
            columns=rr.Transform3D.columns(translation=pos[:, i], quaternion=wxyz_to_xyzw(quat[:, i])),
        )


def _blueprint(model: mujoco.MjModel, focus: str) -> rrb.Blueprint:
    """The two arms in 3D with the verdict below (left); each joint's angle, residual and port
    pressures in tabs, opened on the departing joint (right)."""
    arm = rrb.Spatial3DView(
        name="measured (solid) and replayed (blue) arm",
        origin="world",
        line_grid=False,
        eye_controls=rrb.EyeControls3D(**eye(model)),
        overrides={REPLAYED_PATH: rrb.EntityBehavior(visible=True, interactive=False)},
    )
    left = rrb.Vertical(arm, rrb.TextLogView(name="diagnosis", origin=VERDICT_PATH), row_shares=[3, 1])

    def tab(j: str):
        p = f"joints/{j}"
        return rrb.Vertical(
            rrb.TimeSeriesView(name=f"{j}: drive angle (deg)", origin=f"{p}/angle_deg"),
            rrb.TimeSeriesView(name=f"{j}: angle residual (deg)", origin=f"{p}/residual_deg"),
            rrb.TimeSeriesView(name=f"{j}: port pressures, absolute (bar)", origin=f"{p}/pressure_bar"),
            name=j,
        )

    right = rrb.Tabs(*(tab(j) for j in JOINTS), active_tab=JOINTS.index(focus), name="joints")
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[1, 1]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="expanded"),
    )


def describe(path: Path, diagnosis: ArmDiagnosis) -> str:
    """The line the command prints for the recording."""
    marked = f", {diagnosis.joint} marked" if diagnosis.joint else ""
    return f"rerun view: {path} (measured and replayed arm on the {len(diagnosis.withheld_runs)} withheld runs{marked})"
