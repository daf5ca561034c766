"""What the compliant brush and the operator cost, measured in one run (ratios, not times).

- MuJoCo's step of the scene, the brush head on its spring slide (assets/) against the rigid brush
  of `git show REF:assets/arm.xml` (default REF main), at home and pressed on a disc.
- The cleaning scenario's first `sim_s` simulated seconds per strategy (sensorless, operator), as a
  multiple of real time, and the operator's over the sensorless run's wall time.

    python -m benchmarks.bench_cleaning [REF]
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco

import assets
from scenarios.ik import disc_drive_angles, drive_to_qpos
from scenarios.runner import run_scenario
from scenarios.schema import load, with_overrides
from scenarios.study import SCENARIO


def _step_us(scene: Path, pressed: bool, n: int = 4000) -> float:
    m = mujoco.MjModel.from_xml_path(str(scene))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    if pressed:
        for j, v in drive_to_qpos(disc_drive_angles(m, 4, -0.02)).items():
            d.joint(j).qpos[0] = v
    m.tendon_frictionloss[:] = 1000.0  # brakes on
    mujoco.mj_forward(m, d)
    t0 = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(m, d)
    return (time.perf_counter() - t0) / n * 1e6


def _rigid_scene(ref: str, folder: Path) -> Path:
    """scene.xml beside the arm.xml of git `ref` (the rigid brush)."""
    root = Path(assets.SCENE_XML).parent
    arm = subprocess.run(
        ["git", "show", f"{ref}:assets/arm.xml"], cwd=root, capture_output=True, text=True, check=True
    ).stdout
    (folder / "arm.xml").write_text(arm)
    shutil.copy(assets.SCENE_XML, folder / "scene.xml")
    return folder / "scene.xml"


def bench_cleaning(ref: str = "main", sim_s: float = 20.0) -> dict:
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        rigid = _rigid_scene(ref, Path(tmp))
        for pressed in (False, True):
            where = "pressed" if pressed else "home"
            new, old = _step_us(Path(assets.SCENE_XML), pressed), _step_us(rigid, pressed)
            out[f"mj_step_{where}_us"] = {
                "compliant": round(new, 2),
                "rigid": round(old, 2),
                "ratio": round(new / old, 3),
            }
    scenario = load(SCENARIO)
    wall = {}
    for strategy in ("sensorless", "operator"):
        s = with_overrides(scenario, {"control.strategy": strategy})
        run_scenario(s, duration_s=1.0)  # compile and warm up
        t0 = time.perf_counter()
        run_scenario(s, duration_s=sim_s)
        wall[strategy] = time.perf_counter() - t0
        out[f"{strategy}_x_real_time"] = round(sim_s / wall[strategy], 1)
    out["operator_over_sensorless_wall"] = round(wall["operator"] / wall["sensorless"], 3)
    return out


if __name__ == "__main__":
    print(json.dumps(bench_cleaning(*sys.argv[1:2]), indent=2))
