"""The physics of air for the pneumatic arm: plain functions in SI units, no MuJoCo.

Each law is written once here and used by the plant (twin/), the angle predictor (control/)
and the gap diagnosis (gap/). Pressures are absolute Pa unless a name says `gauge`.

The names below load on first use (PEP 562), so importing the package or one light module of it
does not load the compiled laws and numba with them: 0.45 s of `twin --version`'s 0.5 s before
they were lazy (`python -X importtime -c "import twin_cli.cli"`). A parameter file's errors are
twin_plumbing.errors.ParameterError.
"""

from __future__ import annotations

import importlib

_PUBLIC = {  # module -> the names the package gives from it
    "pneumatics.brake": ("brake_feed_gauge_pa", "brake_holding_torque", "brake_step", "brake_target"),
    "pneumatics.chamber": ("carried_temperature", "chamber_energy_rates", "chamber_pressure_rate", "vessel_response"),
    "pneumatics.friction": ("coulomb_viscous_torque", "reducer_output_torque", "stribeck_excess"),
    "pneumatics.gas": ("AIR", "Gas", "isentropic_temperature"),
    "pneumatics.heat": ("vane_chamber_heat_transfer", "vessel_heat_transfer_coefficient"),
    "pneumatics.hose": ("friction_factor", "hose_mass_flow", "hose_pressure_drop", "hose_volume", "reynolds_number"),
    "pneumatics.motor": (
        "chamber_volumes",
        "displacement_per_rad",
        "least_displacement_per_rad",
        "swept_area",
        "vane_torque",
        "wrap_motor_angle",
    ),
    "pneumatics.orifice": (
        "critical_pressure_ratio",
        "flow_function",
        "orifice_mass_flow",
        "orifice_mass_flow_between",
    ),
    "pneumatics.params": ("JointParams", "load_joint_params", "paper_model", "params_row", "validated"),
    "pneumatics.reducer": ("transmitted_torque",),
    "pneumatics.valves": (
        "dead_time_step",
        "lag_toward",
        "proportional_valve_target",
        "solenoid_step",
        "valve_opening",
    ),
}
_WHERE = {name: module for module, names in _PUBLIC.items() for name in names}
__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_WHERE[name]), name)
    globals()[name] = value  # looked up once
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
