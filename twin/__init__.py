"""The plant and the glue: MuJoCo model, pneumatic actuators coupled to it, runs, logs, CLI.

The names below load on first use (PEP 562), so that a process needing only a light module
(the MCAP writer process imports twin.mcap_log) does not load MuJoCo and the compiled kernels.
"""

from importlib import import_module

_LAZY = {"SimulationError": "twin.model", "Plant": "twin.plant", "PlantState": "twin.plant", "Sensors": "twin.plant"}
__all__ = list(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'twin' has no attribute {name!r}")
