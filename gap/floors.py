"""What a residual is measured against (step 2): the instrument's noise and the drift between
repeats (gap.noise, from the campaign's repeated runs), and the twin's own model tolerance
(measured per protocol, gap.protocols), in angle and, where measured, chamber pressure."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gap.campaign import Campaign
from gap.campaign_replay import Prepared
from gap.candidate import Candidate
from gap.noise import RepeatNoise, repeat_noise
from gap.protocols import worst_tolerance_deg, worst_tolerance_kpa
from gap.stats import normalised_rms

# The angle's model tolerance (below it a residual is no gap): twice the worst replay-vs-plant rms
# over the protocol library (gap.protocols, measured per protocol), not one motion's.
MODEL_TOLERANCE_DEG = worst_tolerance_deg()
# The same for the motor-chamber pressures, where a campaign measured them.
MODEL_TOLERANCE_KPA = worst_tolerance_kpa()
SIGNIFICANCE = 2.0  # a gap is significant above SIGNIFICANCE x floor, floor = sqrt(noise^2 + drift^2/2 + tol^2)


@dataclass
class Floors:
    """What a residual is measured against: the instrument's noise, the repeats' drift and the
    twin's own model tolerance, in angle and (where measured) chamber pressure."""

    noise_deg: float
    noise: RepeatNoise  # from repeats (rad)
    tolerance_deg: float
    floor_deg: float
    threshold_deg: float
    noise_p: RepeatNoise  # from repeats (Pa)
    floor_kpa: float
    threshold_kpa: float
    # the fit's weight on squared pressure residuals, (angle floor / pressure floor)^2 in rad^2/Pa^2
    # (gap.campaign_replay.CampaignReplay's objective); 0 where no run measured chamber pressures
    pressure_weight: float

    def above(self, angle_deg: float, pressure_kpa: float | None) -> bool:
        """Is a residual of these rms values above the significance threshold in either channel, the
        angle or (where measured) the chamber pressures? Each channel is tested against its own
        floor: pooled into one misfit, a gap seen in one channel would be diluted by the other's
        samples (pressures are sampled more often than angles), and a gap the pressures show
        clearly would be no gap while the angle stays under its threshold."""
        return angle_deg > self.threshold_deg or (pressure_kpa is not None and pressure_kpa > self.threshold_kpa)

    def score(self, c: Candidate) -> float:
        """Held-out misfit in units of the floors, angle and (where measured) chamber pressure
        together: the ranking's key. Without pressures it is the angle rms over its floor."""
        return normalised_rms(c.heldout, c.heldout_p, self.floor_deg, self.floor_kpa)


def floors_of(campaign: Campaign, runs: list[Prepared], model_tolerance_deg: float) -> Floors:
    """The floors of `campaign` from its prepared runs (gap.campaign_replay.prepared_runs)."""
    nz = angle_noise(runs)
    declared = campaign.instrument.noise_deg
    noise_deg = declared if declared is not None else (0.0 if math.isnan(nz.sigma) else math.degrees(nz.sigma))
    drift_deg = 0.0 if math.isnan(nz.drift) else math.degrees(nz.drift)
    # a run departs from its repeats' mean by drift/sqrt(2): no effect fitted to all can explain that
    floor = math.sqrt(noise_deg**2 + drift_deg**2 / 2.0 + model_tolerance_deg**2)
    nzp = pressure_noise(runs)
    sp = (0.0 if math.isnan(nzp.sigma) else nzp.sigma / 1e3) ** 2 + (
        0.0 if math.isnan(nzp.drift) else nzp.drift / 1e3
    ) ** 2 / 2.0
    floor_kpa = math.sqrt(sp + MODEL_TOLERANCE_KPA**2)
    measured_pressure = any(pr.pmeas.size for pr in runs)
    return Floors(
        noise_deg=noise_deg,
        noise=nz,
        tolerance_deg=model_tolerance_deg,
        floor_deg=floor,
        threshold_deg=SIGNIFICANCE * floor,
        noise_p=nzp,
        floor_kpa=floor_kpa,
        threshold_kpa=SIGNIFICANCE * floor_kpa,
        # each channel counts in units of its own floor
        pressure_weight=(math.radians(floor) / (floor_kpa * 1e3)) ** 2 if measured_pressure else 0.0,
    )


def repeat_groups(runs: list[Prepared]) -> list[list[int]]:
    """The runs' indices grouped by signature (repeats of one command, supply and load)."""
    groups: dict[tuple, list[int]] = {}
    for k, pr in enumerate(runs):
        groups.setdefault(pr.run.signature(), []).append(k)
    return list(groups.values())


def angle_noise(runs: list[Prepared]) -> RepeatNoise:
    """Angle noise and drift (rad) of the reference instrument, from repeated runs."""
    return repeat_noise(repeat_groups(runs), lambda k: (runs[k].ts, runs[k].meas))


def pressure_noise(runs: list[Prepared]) -> RepeatNoise:
    """Chamber-pressure noise and drift (Pa) of the transducers (port A), from repeated runs."""
    return repeat_noise(
        repeat_groups(runs), lambda k: (runs[k].tp[runs[k].pmask[0]], runs[k].pmeas[: int(runs[k].pmask[0].sum())])
    )
