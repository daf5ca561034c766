"""The twin from Python (a notebook, a script): run a scenario, get its telemetry as numpy arrays
or a pandas DataFrame, sweep it, read a logged run, diagnose a calibration campaign.

    import pneumatic_arm_twin as pat

    run = pat.run("wrist_closed_loop_60deg", duration_s=3.0)   # a shipped scenario, or a path
    run.passed, run.summary["joints"]["wrist_pitch"]["error_deg"]
    a = run.arrays()          # {"time_s": (T,), "true_angle_rad": (T, joints), ...} numpy arrays
    t = run.table()           # flat 1-D columns: "time_s", "true_angle_rad.wrist_pitch", ...
    df = run.to_dataframe()   # the same table as a pandas DataFrame indexed by time (s)
    run.plot_angles("angles.png")
    pat.run("wrist_closed_loop_60deg", overrides={"supply": {"pressure_mpa": 0.7}})  # or dotted keys

    log = pat.read_log("out/run.mcap")                # a run logged with `twin run --mcap`
    sw = pat.sweep("wrist_closed_loop_60deg", {"supply.pressure_mpa": [0.5, 0.7]}, duration_s=2.0)
    sw.summaries, sw.table(), sw.to_dataframe(), sw.to_csv("sweep.csv")
    st = pat.study(["sensorless"], [0.6], seeds=1)    # the cleaning study; st.to_dataframe()
    d = pat.diagnose("my_campaign/", out="report/")   # d.verdict, d.effect, d.ranking(), d.which
    d = pat.diagnose(pat.synthetic_campaign(seed=1))  # a campaign made by the plant, in memory
    # sweep(..., scheduler="tcp://host:8786") and diagnose(..., scheduler=...) run on a Dask cluster
    plan = pat.design_runs("my_campaign/", out="next/")   # the next runs: plan.chosen, next/plan/

The notebook docs/example.ipynb walks through a run, a sweep, a diagnosis and the plots.

Signals and their units are those of twin.telemetry.SIGNALS (SI: rad, Pa absolute unless
`gauge`, N, m). This package sits above every other one (DESIGN rule 9) and is the one to import
from a notebook; the command line (`twin`) offers the same.
"""

from gap import Campaign, make_campaign
from gap.result import Diagnosis
from pneumatic_arm_twin.api import (
    Log,
    Run,
    Study,
    Sweep,
    diagnose,
    read_log,
    run,
    scenario,
    study,
    sweep,
    synthetic_campaign,
)
from pneumatic_arm_twin.design import design_runs

__all__ = [
    "Campaign",
    "Diagnosis",
    "Log",
    "Run",
    "Study",
    "Sweep",
    "design_runs",
    "diagnose",
    "make_campaign",
    "read_log",
    "run",
    "scenario",
    "study",
    "sweep",
    "synthetic_campaign",
]
