"""The twin from Python (a notebook, a script): run a scenario, get its telemetry as numpy arrays
or a pandas DataFrame, sweep it, read a logged run, diagnose a calibration campaign.

    import pneumatic_arm_twin as pat

    run = pat.run("wrist_closed_loop_60deg", duration_s=3.0)   # a shipped scenario, or a path
    run.passed, run.summary["joints"]["wrist_pitch"]["error_deg"]
    a = run.arrays()          # {"time_s": (T,), "true_angle_rad": (T, joints), ...} numpy arrays
    t = run.table()           # flat 1-D columns: "time_s", "true_angle_rad.wrist_pitch", ...
    df = run.to_dataframe()   # the same table as a pandas DataFrame (needs pandas)
    run.plot_angles("angles.png")

    log = pat.read_log("out/run.mcap")                # a run logged with `twin run --mcap`
    sw = pat.sweep("wrist_closed_loop_60deg", {"supply.pressure_mpa": [0.5, 0.7]}, duration_s=2.0)
    sw.summaries, sw.table(), sw.to_csv("sweep.csv")
    d = pat.diagnose("my_campaign/", out="report/")   # d.verdict, d.effect, d.details
    plan = pat.design_runs("my_campaign/", out="next/")   # the next runs: plan.chosen, next/plan/

Signals and their units are those of twin.telemetry.SIGNALS (SI: rad, Pa absolute unless
`gauge`, N, m). This package sits above every other one (DESIGN rule 9) and is the one to import
from a notebook; the command line (`twin`) offers the same.
"""

from pneumatic_arm_twin.api import (
    Diagnosis,
    Log,
    Run,
    Sweep,
    design_runs,
    diagnose,
    read_log,
    run,
    scenario,
    sweep,
)

__all__ = ["Diagnosis", "Log", "Run", "Sweep", "design_runs", "diagnose", "read_log", "run", "scenario", "sweep"]
