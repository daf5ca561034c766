"""The blind check at the arm level (`twin gap bench --arm`): rehearsal campaigns made from the
plant with one effect hidden in one joint (or an arm-level effect), or nothing, on three
protocols (the cleaning task, point-to-point moves across the workspace, a one-joint exercise),
read through the camera (gap/arm_rehearsal.py), diagnosed blind (gap/arm_diagnose.py) and scored:
false alarms on the no-effect campaigns, the right joint, the right effect, the held-out shrink.
A case whose hidden effect leaves a signature below the noise on its protocol (gap.arm_diagnose.
signature: no joint's rms would reach the significance rule) is said so and scored apart.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gap.arm_campaign import HiddenArmEffect, load_arm_campaign
from gap.arm_diagnose import diagnose_arm, signature
from gap.arm_effects import candidate_named
from gap.arm_rehearsal import CAMERA, make_arm_campaign
from scenarios.schema import SHIPPED_DIR, load

PROTOCOLS = {  # the shipped scenario files (package data: an installed twin has them too)
    "cleaning": SHIPPED_DIR / "insulator_cleaning.toml",
    "point_to_point": SHIPPED_DIR / "arm_protocols" / "point_to_point.toml",
    "one_joint": SHIPPED_DIR / "arm_protocols" / "one_joint.toml",
}
SUPPLIES_MPA = (0.5, 0.6, 0.7, 0.8)  # the paper's working range (Fig. 10-16)


@dataclass(frozen=True)
class ArmBenchCase:
    """One case of the arm's blind bench: a rehearsal on a shipped protocol with a hidden effect (or none)."""

    name: str
    protocol: str
    reality: HiddenArmEffect | None  # None: nothing hidden


# each hidden effect at a value a user would meet (twice or half the twin's, a few degrees, a few kg)
CASES: tuple[ArmBenchCase, ...] = (
    ArmBenchCase("none_one_joint", "one_joint", None),
    ArmBenchCase("none_point_to_point", "point_to_point", None),
    ArmBenchCase("none_cleaning", "cleaning", None),
    ArmBenchCase("wrist_coulomb", "one_joint", HiddenArmEffect(effect="wrist_pitch:coulomb_friction", value=30.0)),
    ArmBenchCase("elbow_coulomb", "point_to_point", HiddenArmEffect(effect="elbow_pitch:coulomb_friction", value=60.0)),
    ArmBenchCase("shoulder_valve_lag", "one_joint", HiddenArmEffect(effect="shoulder_pitch:valve_lag", value=0.3)),
    ArmBenchCase("elbow_leak", "point_to_point", HiddenArmEffect(effect="elbow_pitch:vane_leakage", value=5e-7)),
    ArmBenchCase("payload_mass", "point_to_point", HiddenArmEffect(effect="arm:payload_mass", value=28.0)),
    ArmBenchCase("tilt_y", "one_joint", HiddenArmEffect(effect="arm:mounting_tilt_y", value=5.0)),
    ArmBenchCase("wrist_brake", "cleaning", HiddenArmEffect(effect="wrist_pitch:brake_slow_engage", value=0.3)),
)


def run_case(case: ArmBenchCase, folder: Path, duration_s: float, jobs: int, seed: int) -> dict:
    """Make the case's campaign, diagnose it blind, and score it."""
    scenario = load(PROTOCOLS[case.protocol])
    t0 = time.perf_counter()
    make_arm_campaign(folder, [scenario], SUPPLIES_MPA, case.reality, CAMERA, seed=seed, duration_s=duration_s)
    made = time.perf_counter() - t0
    t0 = time.perf_counter()
    campaign = load_arm_campaign(folder)
    d = diagnose_arm(campaign, jobs)
    took = time.perf_counter() - t0
    out = {"case": case.name, "protocol": case.protocol, "verdict": d.verdict, "joint": d.joint, "effect": d.effect}
    out |= {"family": d.family or "", "make_s": round(made, 1), "diagnose_s": round(took, 1), "line": d.line()}
    if case.reality is None:
        out["false_alarm"] = d.verdict.alarm
        return out
    truth = candidate_named(case.reality.effect)
    out["truth"] = truth.name
    # an arm-level effect has no joint of its own: any departing joint is right for it
    out["right_joint"] = d.joint != "" and (truth.joint in ("", d.joint))
    out["right_effect"] = d.effect == truth.name
    out["shrink"] = d.fits[0].withheld_shrink if d.fits else None
    # whether the campaign shows the effect at all: its signature (the twin with it against the twin
    # without, noise-free, at the instruments' samples) against the rule the diagnosis goes by
    sig = signature(campaign, truth, case.reality.value, d.latency_s, jobs)
    out["signature_floors"] = round(sig.floors, 4)
    out["signature_snr"] = round(sig.snr, 2)
    out["below_floor"] = sig.below_floor
    if sig.below_floor:
        out["line"] += f" (the effect's signature: {sig.floors:.3f} floors, below the noise on this protocol)"
    return out


def run_arm_bench(
    out: Path,
    only: str | None = None,
    duration_s: float = 20.0,
    jobs: int = 1,
    seed: int = 0,
    report: Callable[[str], None] | None = None,
) -> dict:
    """Every case (or those named in `only`, comma-separated), each its campaign in out/campaigns;
    `report` is given each case's line as it ends (the command line prints it)."""
    names = [n.strip() for n in only.split(",")] if only else [c.name for c in CASES]
    rows = []
    for i, case in enumerate(c for c in CASES if c.name in names):
        rows.append(run_case(case, out / "campaigns" / case.name, duration_s, jobs, seed + i))
        if report is not None:
            report(f"{rows[-1]['line']} [{case.name}]")
    none = [r for r in rows if "false_alarm" in r]
    truths = [r for r in rows if "truth" in r]
    hidden = [r for r in truths if not r["below_floor"]]
    below = [r for r in truths if r["below_floor"]]
    shrinks = [r["shrink"] for r in hidden if r["shrink"] is not None]
    summary = {
        "duration_s": duration_s,
        "false_alarms": f"{sum(r['false_alarm'] for r in none)}/{len(none)}",
        "right_joint": f"{sum(r['right_joint'] for r in hidden)}/{len(hidden)}",
        "right_effect": f"{sum(r['right_effect'] for r in hidden)}/{len(hidden)}",
        "median_withheld_shrink": float(np.median(shrinks)) if shrinks else None,
        # the cases whose hidden effect leaves no trace above the noise: not scored (no diagnosis could)
        "below_floor": [r["case"] for r in below],
        "right_joint_all": f"{sum(r['right_joint'] for r in truths)}/{len(truths)}",
        "right_effect_all": f"{sum(r['right_effect'] for r in truths)}/{len(truths)}",
        "cases": rows,
    }
    (out / "bench.json").write_text(json.dumps(summary, indent=2))
    return summary
