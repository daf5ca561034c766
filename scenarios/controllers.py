"""The controller a scenario asks for, built from control/ with the predictor's configuration."""

from __future__ import annotations

import numpy as np

from pneumatics import JointParams
from scenarios.schema import Scenario
from twin.plant import Plant
from twin.sim import CommandSchedule


def idle(n_joints: int) -> CommandSchedule:
    """mode = "none": the platform sends nothing; every valve closed, every brake engaged."""
    commands = np.zeros((n_joints, 3))
    return CommandSchedule(lambda t: commands, n_joints)


def build(scenario: Scenario, plant: Plant, predictor_params: dict[str, JointParams], targets: list[dict[str, float]]):
    """The scenario's controller, told the start pose (the operator homes the arm) and never the truth after."""
    if scenario.control.mode == "none":
        return idle(len(plant.joints))
    raise NotImplementedError("closed_loop/open_loop: wired when control/ lands")
