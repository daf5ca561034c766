"""What runs on the operator's PC: the angle predictor, the arm model it believes (Pinocchio, from
the same MJCF as the plant), PID on the prediction, valve and brake sequencing, the minimum-rotation
rule, the open-loop baseline and multi-joint sequencing. Sees only the sensors the real arm has;
imports neither mujoco nor twin/ (DESIGN, rule 1).
"""

from control.arm_model import ArmModel, drive_coefficients
from control.controller import MODES, SEQUENCES, ArmController, MotionRefused
from control.experiments import (
    closed_vs_open_loop,
    minimum_rotation_limit,
    random_supply,
    random_supply_moves,
    run_move,
    run_until_done,
)
from control.open_loop import open_loop_duration
from control.pid import PidGains
from control.predictor import predict_step

__all__ = [
    "MODES",
    "SEQUENCES",
    "ArmController",
    "ArmModel",
    "MotionRefused",
    "PidGains",
    "drive_coefficients",
    "open_loop_duration",
    "predict_step",
    "closed_vs_open_loop",
    "minimum_rotation_limit",
    "random_supply",
    "random_supply_moves",
    "run_move",
    "run_until_done",
]
