"""The model tolerance measured: how far the one-joint model's replay (wrist_rig.one_joint, through
the nominal campaign replay, gap.campaign_replay) departs from the plant (twin.plant, MuJoCo) on each
protocol of the library (gap.protocols) at each supply of the paper, nominal wrist, no instrument
noise. `python -m gap.tolerance` prints the figures gap.protocols.TOLERANCE_DEG and TOLERANCE_KPA
hold, rounded up; tests/test_gap.py measures them again.

Apart from gap.protocols, which the diagnosis takes its tolerance from: this measurement replays
through the diagnosis and runs the plant.
"""

from __future__ import annotations

import json

import numpy as np

from gap.campaign import Campaign, MeasuredRun
from gap.campaign_replay import CampaignReplay
from gap.protocols import library
from wrist_rig import commanded_run


def measure_tolerance(pressures_mpa=(0.5, 0.6, 0.7, 0.8)) -> dict[str, dict]:
    """Replay vs plant per protocol: rms and max |difference| of the angle (deg) and rms of the
    chamber pressures (kPa) over the given supplies, nominal wrist, no instrument noise."""
    p0 = commanded_run.wrist_params()
    out = {}
    for name in library(0.5):
        ang, pres = [], []
        for mpa in pressures_mpa:
            proto = library(mpa)[name]
            run = commanded_run.simulate_run(p0, mpa, proto)
            measured = MeasuredRun(
                name=name,
                path=None,
                supply_mpa=mpa,
                start_rad=0.0,
                time_s=run["time_s"],
                direction=run["direction"],
                brake_released=run["brake_released"],
                valve_gauge_pa=run["valve_set_gauge_pa"],
                supply_pa=run["supply_pa"],
                angle_rad=run["angle_rad"],
                extra={k: run[k] for k in ("p_a_pa", "p_b_pa")},
            )
            campaign = Campaign(
                folder=None,
                joint=commanded_run.JOINT,
                payload_kg=0.0,
                hose_length_m=p0.hose_length_m,
                rig_inertia_kg_m2=commanded_run.RIG_INERTIA_KG_M2,
                twin_hose_loss=None,
                runs=[measured],
            )
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
