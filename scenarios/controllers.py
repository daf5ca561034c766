"""The controller a scenario asks for, built from control/ with the predictor's configuration."""

from __future__ import annotations

import math

import numpy as np

import assets
from control import ArmController, MotionRefused, PidGains
from pneumatics import JointParams
from scenarios.schema import Scenario
from twin.plant import Plant
from twin.sim import CommandSchedule


def idle(n_joints: int) -> CommandSchedule:
    """mode = "none": the platform sends nothing; every valve closed, every brake engaged."""
    commands = np.zeros((n_joints, 3))
    return CommandSchedule(lambda t: commands, n_joints)


def build(scenario: Scenario, plant: Plant, predictor_params: dict[str, JointParams], targets: list[dict[str, float]]):
    """The scenario's controller, told the start pose (the operator homes the arm before work,
    DESIGN: the only time it learns the truth) and its plan. Returns (controller, refusal): a
    refused plan leaves the arm braked and the refusal's message for the summary."""
    if scenario.control.mode == "none":
        return idle(len(plant.joints)), ""
    start = dict(zip(plant.joints, plant.drive_angles(), strict=True))
    controller = ArmController(
        start,
        xml_path=assets.WRIST_RIG_XML if scenario.model == "wrist_rig" else assets.ARM_XML,
        joints=plant.joints,
        predictor_params=predictor_params,
        mode=scenario.control.mode,
        gains=PidGains(tolerance_rad=math.radians(scenario.control.tolerance_deg)),
        min_rotation_rad=math.radians(scenario.control.min_rotation_deg),
        move_timeout_s=scenario.control.move_timeout_s,
        payload_kg=scenario.payload_kg if scenario.model == "arm" else None,
    )
    try:
        controller.set_targets(
            targets, sequence=scenario.control.sequence, dwell_s=[t.dwell_s for t in scenario.targets]
        )
    except MotionRefused as e:
        return controller, str(e)
    return controller, ""
