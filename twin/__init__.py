"""The plant and what runs it: the MuJoCo model with its pneumatic actuators (twin.plant.Plant,
Sensors, PlantState), the run loop (twin.sim.run), telemetry, the logs (twin.rerun_log,
twin.mcap_log, twin.camera), pictures, and the user errors and checked numbers the floors above
share (twin.errors, twin.checks).

Nothing is imported here: the MCAP writer and camera processes import one module of twin each
(`python -m twin.mcap_log`, `python -m twin.camera`) and do not need the plant's compiled kernels
(twin.plant takes ~0.5 s to import on top of numpy); import from the modules themselves.
"""
