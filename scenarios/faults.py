"""Faults that strike a run at a given time, applied to the plant (never to the controller).

supply_lost       the supply falls to atmosphere (the brakes' springs engage)
hose_leak         port A's hose leaks to atmosphere through `value` m^2
valve_stuck_open  the joint's direction valve sticks in its +1 position, fully open
brake_fails       the joint's brake no longer engages (holding torque 0)
sensor_bias       the joint's proportional-valve pressure sensor reads `value` Pa high
"""

from __future__ import annotations

import math

from control.schedule import Schedule, Until
from pneumatics import AIR
from scenarios.schema import Fault
from twin.plant import Plant


class FaultEvents:
    """The scenario's faults as the run loop's event schedule (control/schedule.py's EventSchedule):
    `apply(plant, t)` applies each fault once its time has come, `due_s(t)` is the next one's time.

    A lost supply is the supply's own schedule (`supply`: atmosphere from the fault's time on), so
    the loop writes the supply once a tick; `apply` leaves it to that schedule."""

    def __init__(self, faults: tuple[Fault, ...]):
        # the faults not applied yet, in time order (after a run: those it never reached)
        self.pending = sorted(faults, key=lambda f: f.at_s)
        self.supply_lost_s = min((f.at_s for f in faults if f.kind == "supply_lost"), default=math.inf)

    def supply(self, profile: Schedule) -> Schedule:
        """The supply the plant gets: `profile`, at atmosphere from a `supply_lost` fault on."""
        return profile if self.supply_lost_s == math.inf else Until(profile, self.supply_lost_s, AIR.p_atm_pa)

    def apply(self, plant: Plant, t: float) -> None:
        while self.pending and self.pending[0].at_s <= t:
            fault = self.pending.pop(0)
            if fault.kind != "supply_lost":  # the supply's schedule carries it (`supply`)
                apply_fault(plant, fault)

    def due_s(self, t: float) -> float:
        return self.pending[0].at_s if self.pending else math.inf


def apply_fault(plant: Plant, fault: Fault) -> None:
    if fault.kind == "supply_lost":
        plant.set_supply(AIR.p_atm_pa)
        return
    j = plant.joints.index(fault.joint)
    params = plant.joint_params[fault.joint]
    if fault.kind == "hose_leak":
        plant.set_joint_params(fault.joint, params._replace(hose_leak_area_m2=fault.value))
    elif fault.kind == "brake_fails":
        plant.set_joint_params(fault.joint, params._replace(brake_holding_nm=0.0))
    elif fault.kind == "sensor_bias":
        plant.sensor_bias_pa[j] = fault.value
    elif fault.kind == "valve_stuck_open":
        plant.stick_valve(fault.joint, +1.0)
