"""The plant and the glue: MuJoCo model, pneumatic actuators coupled to it, runs, logs, CLI."""

from twin.model import SimulationError
from twin.plant import Plant, PlantState, Sensors

__all__ = ["Plant", "PlantState", "Sensors", "SimulationError"]
