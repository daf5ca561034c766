"""The calibration rig's motion protocols, and how far the twin's replay departs from the plant on
each: the diagnosis's model tolerance.

Each protocol is a list of segments (a direction, a valve set point, the brake command, held for a
duration): what a calibration rig sends to one joint. The library covers what such a rig runs:
the paper's open-loop 60-degree moves at each supply (Sec. IV, Fig. 10-16), a staircase of
partial openings with braked pauses, back-and-forth moves, stop-and-go, and direct reversals.

The model tolerance is measured, not assumed: `python -m gap.protocols` runs the nominal plant
(MuJoCo + pneumatics, twin.plant) through every protocol at every supply of the paper and replays
the same commands through the one-joint twin (gap.replay); TOLERANCE_DEG holds the rms of the
difference per protocol as that command printed it. The diagnosis takes twice the worst of them
as its tolerance (below it a residual is no gap): a campaign's protocol is not declared, and the
twin must not call its own error on any of them an effect.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

# rms difference replay - plant per protocol over 0.5-0.8 MPa, nominal wrist, in angle (deg) and
# chamber pressures (kPa), rounded up; measured by `python -m gap.protocols` on the plant (its air
# by ROS2) and the replay. tests/test_gap.py measures them again and fails when the physics has
# moved them: re-run the command and copy its figures.
TOLERANCE_DEG = {
    "paper_60": 0.04,
    "staircase": 0.016,
    "back_and_forth": 0.032,
    "stop_and_go": 0.152,
    "reversal": 0.036,
}
TOLERANCE_KPA = {"paper_60": 0.26, "staircase": 0.23, "back_and_forth": 0.34, "stop_and_go": 0.8, "reversal": 0.33}
TOLERANCE_FACTOR = 2.0  # the tolerance is twice the measured rms (room for what the campaigns vary)


def worst_tolerance_deg() -> float:
    return TOLERANCE_FACTOR * max(TOLERANCE_DEG.values())


def worst_tolerance_kpa() -> float:
    return TOLERANCE_FACTOR * max(TOLERANCE_KPA.values())


@dataclass(frozen=True)
class Segment:
    duration_s: float
    direction: int  # -1 / 0 / +1
    opening: float | None = (
        None  # proportional valve opening u (set point u / k_u); None: wide open, delivering the supply
    )
    brake_released: bool = True


@dataclass(frozen=True)
class Protocol:
    """One run's command timeline, starting braked at rest for `lead_s`."""

    name: str
    segments: tuple[Segment, ...]
    lead_s: float = 0.1  # braked at rest before the first command (the instrument's zero is read there)
    tail_s: float = 0.4  # braked at rest after the last segment

    def total_s(self) -> float:
        return self.lead_s + sum(s.duration_s for s in self.segments) + self.tail_s

    def commands(
        self, t_s: np.ndarray, supply_gauge_pa: float, k_u_per_pa: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(direction, valve set point gauge Pa, brake_release) at the given times."""
        d = np.zeros_like(t_s)
        u = np.zeros_like(t_s)
        b = np.zeros_like(t_s)
        t0 = self.lead_s
        for s in self.segments:
            m = (t_s >= t0 - 1e-9) & (t_s < t0 + s.duration_s - 1e-9)
            d[m] = s.direction
            if s.direction != 0:
                u[m] = supply_gauge_pa if s.opening is None else s.opening / k_u_per_pa
            b[m] = 1.0 if s.brake_released else 0.0
            t0 += s.duration_s
        return d, u, b


def _stop(t: float) -> Segment:
    return Segment(t, 0, None, False)


# The paper's 60-degree move at full opening: the time the nominal wrist takes to turn 60 deg at
# each supply (gap.synth.paper_motions on the nominal plant; measured before the braked-stop fix
# of pneumatics/joint.py, which does not touch the move itself)
PAPER_MOVE_S = {0.5: 1.0, 0.6: 0.64, 0.7: 0.54, 0.8: 0.48}


def paper_60(supply_mpa: float) -> Protocol:
    t = PAPER_MOVE_S.get(round(supply_mpa, 2), 0.6)
    return Protocol("paper_60", (Segment(t, +1),))


# Every protocol stays inside the wrist's +-90 deg (assets/arm.xml) from a start at 0 at 0.8 MPa,
# where a full-open move turns ~100 deg/s once the brake is clear.
# Partial openings 0.9, 0.95, 1.0 up (set points 4.6, 4.85, 5.1 bar gauge: the first just under
# the brake's full release at 4.75 bar, so the motor-fed brake drags there, as on the real wrist),
# braked pauses between, then back down wide open.
STAIRCASE = Protocol(
    "staircase", (*(s for u in (0.9, 0.95, 1.0) for s in (Segment(0.25, +1, u), _stop(0.25))), Segment(0.5, -1))
)
BACK_AND_FORTH = Protocol("back_and_forth", (Segment(0.4, +1), Segment(0.4, -1), Segment(0.4, +1), Segment(0.4, -1)))
# two braked stops on the way out, two on the way back
STOP_AND_GO = Protocol("stop_and_go", tuple(s for d in (+1, +1, -1, -1) for s in (Segment(0.35, d), _stop(0.3))))
# a move, a direct reversal at opening 0.95 (4.85 bar: above the brake's full release), a stop
REVERSAL = Protocol("reversal", (Segment(0.5, +1), Segment(0.6, -1, 0.95)))


def library(supply_mpa: float) -> dict[str, Protocol]:
    """Every protocol of the library at `supply_mpa` (only the paper's move depends on it)."""
    return {
        "paper_60": paper_60(supply_mpa),
        "staircase": STAIRCASE,
        "back_and_forth": BACK_AND_FORTH,
        "stop_and_go": STOP_AND_GO,
        "reversal": REVERSAL,
    }


# The design library (gap.design proposes runs from it): the library above and runs made to tell
# parts of the joint apart, each inside the wrist's +-90 deg from a start at 0 at every supply of the
# paper. Not in `library`: the diagnosis's tolerance is the worst of the library's protocols, and these
# are measured apart (`python -m gap.protocols --design`, DESIGN_TOLERANCE_DEG below), under it.
# Slow constant-speed runs: a partial opening held long (0.75 / 0.85 of full: set points 3.8 / 4.3 bar,
# both under the brake's full release, 4.75 bar, so a motor-fed brake drags and the joint crawls),
# up and back down at the same opening.
SLOW_075 = Protocol("slow_075", (Segment(1.2, +1, 0.75), _stop(0.3), Segment(1.2, -1, 0.75)))
SLOW_085 = Protocol("slow_085", (Segment(1.0, +1, 0.85), _stop(0.3), Segment(1.0, -1, 0.85)))
# Pressure-only: the valves driven both ways while the brake holds the joint (its holding torque,
# 100 N·m, is above the motor's stall torque at every supply): the chambers fill and empty through
# the valves and hoses, the joint does not turn (what turns it is the brake slipping)
HELD = Protocol("held", (Segment(0.5, +1, None, False), _stop(0.3), Segment(0.5, -1, None, False)))
# Short pulses: four 0.3 s moves at full opening with braked pauses, two each way: the run is mostly
# starts and stops (the brake's release and engagement, the valves' dead times, breakaway)
PULSES = Protocol("pulses", tuple(s for d in (+1, +1, -1, -1) for s in (Segment(0.3, d), _stop(0.3))))
# Dwell, then move: long braked dwells between short moves (each start from a joint that rested long)
DWELL_THEN_MOVE = Protocol(
    "dwell_then_move", (Segment(0.3, +1), _stop(1.0), Segment(0.3, +1), _stop(1.0), Segment(0.6, -1))
)
# Partial openings below the staircase's: steps at 0.8 and 0.85 (4.1 / 4.3 bar), braked between
LOW_STEPS = Protocol(
    "low_steps", (Segment(0.4, +1, 0.8), _stop(0.25), Segment(0.4, +1, 0.85), _stop(0.25), Segment(0.6, -1, 0.9))
)
DESIGN_PROTOCOLS = (SLOW_075, SLOW_085, HELD, PULSES, DWELL_THEN_MOVE, LOW_STEPS)


def design_library(supply_mpa: float) -> dict[str, Protocol]:
    """The library (`library`) and the runs made to tell parts apart (DESIGN_PROTOCOLS) at `supply_mpa`."""
    return {**library(supply_mpa), **{p.name: p for p in DESIGN_PROTOCOLS}}


def measure_tolerance(pressures_mpa=(0.5, 0.6, 0.7, 0.8)) -> dict[str, dict]:
    """Replay vs plant per protocol: rms and max |difference| of the angle (deg) and rms of the
    chamber pressures (kPa) over the given supplies, nominal wrist, no instrument noise."""
    # imported here, not at the top: only this measurement needs the plant (MuJoCo)
    from gap import synth
    from gap.campaign import Campaign, Run
    from gap.campaign_replay import CampaignReplay

    p0 = synth.wrist_params()
    out = {}
    for name in library(0.5):
        ang, pres = [], []
        for mpa in pressures_mpa:
            proto = library(mpa)[name]
            run = synth.simulate_run(p0, mpa, proto)
            measured = Run(
                name,
                None,
                mpa,
                0.0,
                run["time_s"],
                run["direction"],
                run["brake_released"],
                run["valve_set_gauge_pa"],
                run["supply_pa"],
                run["angle_rad"],
                {k: run[k] for k in ("p_a_pa", "p_b_pa")},
            )
            campaign = Campaign(None, synth.JOINT, 0.0, p0.hose_length_m, synth.RIG_INERTIA_KG_M2, None, [measured])
            # the residuals alone, no fit: the objective's pressure weight is not used
            replay = CampaignReplay(campaign, pressure_weight=0.0)
            ((a, p),) = replay.residuals_with([], [0], 0.0).values()
            ang.append(a)
            pres.append(p)
        a = np.rad2deg(np.concatenate(ang))
        out[name] = {
            "rms_deg": float(np.sqrt(np.mean(a**2))),
            "max_deg": float(np.max(np.abs(a))),
            "pressure_rms_kpa": float(np.sqrt(np.mean(np.concatenate(pres) ** 2)) / 1e3),
        }
    return out


if __name__ == "__main__":
    print(json.dumps(measure_tolerance(), indent=1))
