"""Forces judged at the physics rate: the brush's touch sensor against MuJoCo's own contact forces,
its peak kept by every physics step of the compiled plant, and the criteria judging that peak."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import assets
from scenarios.cleaning import disc_contacts, physics_force_n
from scenarios.ik import disc_drive_angles, drive_to_qpos
from twin.plant import BRUSH_TOUCH, Plant
from twin.sim import brush_contact


def _pressed_plant(press_m: float) -> Plant:
    """The scene's plant with the arm put (at rest) where the brush's face is `press_m` into disc
    4's rim: past the head's 50 mm stroke the arm itself strikes the rim and the head rebounds."""
    plant = Plant(assets.SCENE_XML)
    for joint, q in drive_to_qpos(disc_drive_angles(plant.model, 4, -press_m)).items():
        plant.data.joint(joint).qpos[0] = q
    plant.data.qvel[:] = 0.0
    mujoco.mj_forward(plant.model, plant.data)
    return plant


def test_the_touch_sensor_is_the_sum_of_the_brushs_contact_normal_forces():
    """Each step's sensor reading is the sum of the normal forces `mj_contactForce` gives for the
    brush's contacts of that step (an independent reading of the same solver output)."""
    plant = _pressed_plant(0.025)
    adr = plant.model.sensor(BRUSH_TOUCH).adr[0]
    pairs = []
    for _ in range(200):
        plant.step(1)
        pairs.append((plant.data.sensordata[adr], brush_contact(plant)[0]))
    sensor, contacts = np.array(pairs).T
    assert contacts.max() > 20.0  # pressed: tens of newtons
    np.testing.assert_allclose(sensor, contacts, rtol=1e-9, atol=1e-9)


def test_a_blow_between_two_samples_is_kept_at_the_physics_rate():
    """The arm put 10 mm past the head's stroke strikes the rim: the force of the first steps is
    hundreds of newtons and gone within a telemetry period (40 steps). The compiled plant's 40
    steps in one call keep the largest step's force, the same as stepping one at a time and
    reading MuJoCo's contact forces after each; the force at the period's end is far below it."""
    steps = 40  # twin/sim.py: LOG_PERIOD_S / 0.5 ms
    one_by_one = _pressed_plant(0.06)
    per_step = []
    for _ in range(steps):
        one_by_one.step(1)
        per_step.append(brush_contact(one_by_one)[0])
    at_once = _pressed_plant(0.06)
    at_once.step(steps)
    peak = at_once.take_force_peak()
    assert peak == pytest.approx(max(per_step), rel=1e-9)
    assert peak > 150.0 and brush_contact(at_once)[0] < 0.5 * peak
    assert at_once.take_force_peak() == 0.0  # taken: the next stretch starts from nothing


def test_the_criteria_judge_the_physics_steps_peak_not_the_sample():
    """Synthetic telemetry: disc 3 pressed at 30 N with a 300 N blow between two samples; the
    disc's peak and the overall force are the blow's; without the logged peak (an older log) the
    samples' 30 N."""
    scene = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    t = np.arange(0.0, 2.0, 0.02)
    force, peak = np.zeros_like(t), np.zeros_like(t)
    point = np.full((len(t), 3), np.nan)
    pressing = (t >= 0.5) & (t < 1.5)
    force[pressing], point[pressing] = 30.0, scene.geom("disc_3").pos - [scene.geom("disc_3").size[0], 0, 0]
    peak[pressing] = 30.0
    blow = np.flatnonzero(pressing)[-1] + 1  # the stretch after the last pressed sample
    peak[blow] = 300.0
    arrays = {"time_s": t, "brush_force_n": force, "brush_contact_m": point, "brush_peak_n": peak}
    assert disc_contacts(scene, arrays)[2].peak_n == 300.0
    assert physics_force_n(arrays).max() == 300.0
    older = {k: v for k, v in arrays.items() if k != "brush_peak_n"}
    assert disc_contacts(scene, older)[2].peak_n == 30.0
    assert math.isnan(disc_contacts(scene, arrays)[0].peak_n)


def test_the_brushs_friction_in_the_file_is_the_one_its_contacts_use():
    """MuJoCo gives a contact the element-wise larger friction of its two geoms (equal priority):
    the brush's friction as assets/arm.xml writes it is what its contacts with a disc really have,
    not a figure the disc's overrides (the file said 0.3 while the contact used the disc's 1)."""
    plant = _pressed_plant(0.025)
    m, d = plant.model, plant.data
    brush = m.geom("brush").id
    touching = [c for c in d.contact[: d.ncon] if brush in (c.geom1, c.geom2)] if d.ncon else []
    assert touching  # pressed into disc 4's rim
    for c in touching:
        other = c.geom2 if c.geom1 == brush else c.geom1
        assert m.geom(other).name == "disc_4"
        slide, spin, roll = m.geom_friction[brush]  # the contact's: two sliding, one torsional, two rolling
        np.testing.assert_array_equal(c.friction, [slide, slide, spin, roll, roll])
