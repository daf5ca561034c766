"""The plant and what runs it: the MuJoCo model with its pneumatic actuators (twin.plant.Plant,
Sensors, PlantState), the run loop (twin.sim.run), telemetry, the logs (twin.rerun_log,
twin.mcap_log, twin.camera) and pictures. The user errors, checked numbers and output places every
floor shares are twin_plumbing's.

Nothing is imported here: the MCAP writer and camera processes import one module of twin each
(`python -m twin.mcap_log`, `python -m twin.camera`) and do not need the plant's compiled kernels
(twin.plant takes ~0.5 s to import on top of numpy); import from the modules themselves.
"""
