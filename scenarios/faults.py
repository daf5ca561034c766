"""Faults that strike a run at a given time, applied to the plant (never to the controller).

Each kind is one row of FAULTS: its name, what it does, whether it names a joint and takes a value
(and in what range), and how it acts on the plant. The scenario schema reads its kinds and their
checks from here (scenarios/schema.py), so a new fault is one row; docs/scenario_kinds.md lists them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import assets
from control.schedule import Schedule, Until
from pneumatics import AIR, load_joint_params
from scenarios.kinds import registry

if TYPE_CHECKING:  # types only: the schema imports its fault kinds from this module
    from scenarios.schema import Fault
    from twin.plant import Plant


@dataclass(frozen=True, kw_only=True)
class FaultKind:
    """One kind of fault: what the file's `[[faults]]` table of that kind means and does."""

    name: str  # the file's `kind`
    what: str  # what strikes the plant, in words
    # strikes: changes the plant, once, at the fault's time; None for a fault of the supply (`supply_pa`)
    act: Callable[[Plant, Fault], None] | None = None
    # why the kind names no joint (it strikes every joint); "": it names the one joint it strikes
    whole_arm: str = ""
    value: tuple[float, float, str] | None = None  # its `value`'s range and unit (not 0); None: it takes none
    # the largest value on a given joint and that limit in words (beyond `value`'s range), if any
    value_limit: Callable[[str], tuple[float, str]] | None = None
    # a fault of the supply: the supply (Pa, absolute) from its time on, which the supply's schedule
    # carries in a run (FaultEvents.supply); None: it acts on the plant through `act`
    supply_pa: float | None = None

    def __post_init__(self):
        if (self.act is None) == (self.supply_pa is None):
            raise ValueError(f"fault kind {self.name!r}: give it either `act` or `supply_pa`, not both or neither")


class FaultEvents:
    """The scenario's faults as the run loop's event schedule (control/schedule.py's EventSchedule):
    `apply(plant, t)` applies each fault once its time has come, `due_s(t)` is the next one's time.

    A fault of the supply (a row with `supply_pa`) is the supply's own schedule (`supply`: that
    pressure from the fault's time on), so the loop writes the supply once a tick; `apply` leaves it
    to that schedule."""

    def __init__(self, faults: tuple[Fault, ...]):
        # the faults not applied yet, in time order (after a run: those it never reached)
        self.pending = sorted(faults, key=lambda f: f.at_s)
        on_supply = [f for f in self.pending if FAULTS[f.kind].supply_pa is not None]
        self.supply_fault = on_supply[0] if on_supply else None  # the first fault of the supply, if any

    def supply(self, profile: Schedule) -> Schedule:
        """The supply the plant gets: `profile`, then the first supply fault's pressure from its time on."""
        f = self.supply_fault
        return profile if f is None else Until(profile, f.at_s, FAULTS[f.kind].supply_pa)

    def apply(self, plant: Plant, t: float) -> None:
        while self.pending and self.pending[0].at_s <= t:
            fault = self.pending.pop(0)
            kind = FAULTS[fault.kind]
            if kind.act is not None:  # a fault of the supply is the supply's schedule's (`supply`)
                kind.act(plant, fault)

    def due_s(self, t: float) -> float:
        return self.pending[0].at_s if self.pending else math.inf


def _leak_hose(plant: Plant, fault: Fault) -> None:
    plant.set_joint_params(fault.joint, plant.joint_params[fault.joint]._replace(hose_leak_area_m2=fault.value))


def _stick_valve_open(plant: Plant, fault: Fault) -> None:
    plant.stick_valve(fault.joint, +1.0)


def _fail_brake(plant: Plant, fault: Fault) -> None:
    plant.set_joint_params(fault.joint, plant.joint_params[fault.joint]._replace(brake_holding_nm=0.0))


def _bias_sensor(plant: Plant, fault: Fault) -> None:
    plant.sensor_bias_pa[plant.joints.index(fault.joint)] = fault.value


def _hose_bore(joint: str) -> tuple[float, str]:
    """The whole bore of the joint's hose (m^2, its parameter file's diameter): the largest leak."""
    bore_m2 = math.pi / 4 * load_joint_params(assets.joint_param_path(joint)).hose_diameter_m ** 2
    return bore_m2, f"a leak area in 0..{bore_m2:.3g} m^2 (the whole bore of {joint}'s hose)"


FAULTS: dict[str, FaultKind] = registry(
    FaultKind(
        name="supply_lost",
        what="the supply falls to atmosphere (the brakes' springs engage)",
        whole_arm="the supply feeds every joint",
        supply_pa=AIR.p_atm_pa,
    ),
    FaultKind(
        name="hose_leak",
        what="port A's hose leaks to atmosphere through `value` m^2",
        act=_leak_hose,
        # at most the whole bore of the hose: 8 mm the widest (assets/joints/*.toml); per joint by value_limit
        value=(0.0, 5.1e-5, "m^2"),
        value_limit=_hose_bore,
    ),
    FaultKind(
        name="valve_stuck_open",
        what="the joint's direction valve sticks in its +1 position, fully open",
        act=_stick_valve_open,
    ),
    FaultKind(
        name="brake_fails",
        what="the joint's brake no longer engages (holding torque 0)",
        act=_fail_brake,
    ),
    FaultKind(
        name="sensor_bias",
        what="the joint's proportional-valve pressure sensor reads `value` Pa high",
        act=_bias_sensor,
        value=(-1e6, 1e6, "Pa"),  # +-10 bar: beyond the 0.5-0.8 MPa supply's whole span
    ),
)
