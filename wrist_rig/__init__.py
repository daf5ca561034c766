"""The wrist on the paper's single-joint bench (assets/wrist_rig.xml), as the plant runs it and as
the one-joint model replays it: what the gap diagnosis and the paper's validation both stand on.

    wrist_rig.commanded_run   Motion, a command timeline; simulate_run, the plant driven by one
                              (1 ms command rows, the true angle and chamber pressures); wrist_params
    wrist_rig.one_joint       replay_run, the one-joint model (the predictor's, paper eq. 7) through
                              a run's command rows, one compiled loop; DT_S, its 1 ms step

Above twin/ (the plant), below gap/ and scenarios/: neither imports the other for physics.
Nothing is imported here (one_joint needs no MuJoCo); import from the modules.
"""
