"""The predicted load between Pinocchio's looks (control/predicted_load.py) against Pinocchio's load
computed afresh: its derivative, the tangent's error over the arm's range, and the press, whose
load the tangent must never stand for."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import assets
from control import ArmController, ArmModel
from control.predicted_load import LOAD_UPDATE_RAD, advance_load
from pneumatics.joint import R_THETA

# the largest error the default radius allows anywhere in the arm's range (N·m; predicted_load.py)
TANGENT_ERROR_NM = 0.012


@pytest.fixture(scope="module")
def arm() -> ArmModel:
    return ArmModel(assets.ARM_XML, payload_kg=20.0)


def _random_drives(arm: ArmModel, rng: np.random.Generator, n: int) -> list[np.ndarray]:
    lo, hi = arm.joint_lower, arm.joint_upper
    return [arm.C @ (lo + (hi - lo) * rng.random(len(lo))) for _ in range(n)]


def test_the_load_slope_is_the_derivative_of_the_load(arm):
    """Pinocchio's gravity derivative, with the wrist's counterbalance spring, through the drive map,
    against central differences of `load_torques` at random poses."""
    for theta in _random_drives(arm, np.random.default_rng(3), 20):
        h = 1e-6
        fd = np.column_stack(
            [(arm.load_torques(theta + h * e) - arm.load_torques(theta - h * e)) / (2 * h) for e in np.eye(len(theta))]
        )
        slope = arm.load_slope(theta)
        assert np.abs(slope - fd).max() < 1e-6 * max(1.0, np.abs(fd).max())
    assert np.abs(slope).max() > 10.0  # N·m/rad: gravity's slope is no rounding error


def test_the_tangent_stays_within_its_error_anywhere_in_the_arms_range(arm):
    """Within the default radius of the last look, in any direction, the tangent's load is the exact
    one to TANGENT_ERROR_NM (its error is second order: a quarter of it at half the radius); the load
    it stands for changes by ~100 times that over the radius."""
    rng = np.random.default_rng(7)
    worst, worst_half, change = 0.0, 0.0, 0.0
    for theta in _random_drives(arm, rng, 1500):
        base, slope = arm.load_torques(theta), arm.load_slope(theta)
        step = LOAD_UPDATE_RAD * rng.choice([-1.0, 1.0], size=len(theta))
        exact = arm.load_torques(theta + step)
        worst = max(worst, np.abs(exact - base - slope @ step).max())
        worst_half = max(worst_half, np.abs(arm.load_torques(theta + step / 2) - base - slope @ step / 2).max())
        change = max(change, np.abs(exact - base).max())
    assert worst <= TANGENT_ERROR_NM
    assert worst_half < 0.3 * worst
    assert change > 50 * TANGENT_ERROR_NM


def _controller_load_along(arm, path, surface=None, normal=None, radius=LOAD_UPDATE_RAD):
    """The controller's load at each drive angle of `path` (advance_load, and the look when stale),
    how many looks it took, and the exact load there (a fresh model, the surface in new arrays)."""
    c = ArmController(dict(zip(arm.joints, path[0], strict=True)), payload_kg=20.0, load_update_rad=radius)
    if surface is not None:
        c.expect_press(surface, normal)
    fresh = ArmModel(assets.ARM_XML, payload_kg=20.0)
    got, want, looks = [], [], 0
    for theta in path:
        c.y[:, R_THETA] = theta
        if advance_load(c._drives, c.y, c._load_base, c._load_slope, c._c_inv, c._load_bound):
            c.update_load()
            looks += 1
        got.append(c.load.copy())
        exact = fresh.load_torques(theta)
        if surface is not None:
            exact = exact + fresh.press_torques(theta, surface.copy(), normal.copy())
        want.append(exact)
    return np.array(got), np.array(want), looks


def test_the_tangent_never_stands_for_the_press():
    """Along an approach from 6 cm off disc 3's rim to 2 cm into it and back: wherever the tangent
    gave the load, it is the exact one (Pinocchio afresh, press included) to TANGENT_ERROR_NM, so the
    press's jump at the touch is never missed; in contact every tick looks; clear of the rim most
    ticks do not."""
    from scenarios.ik import disc_rim_target, tool_drive_angles

    scene = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    arm = ArmModel(assets.ARM_XML, payload_kg=20.0)
    surface, normal = disc_rim_target(scene, 3, 0.0), np.array([-1.0, 0.0, 0.0])
    far, deep = (tool_drive_angles(scene, surface + [x, 0.0, 0.0], 0.0) for x in (-0.06, 0.02))
    a, b = (np.array([p[j] for j in arm.joints]) for p in (far, deep))
    path = [a + (b - a) * s for s in np.concatenate([np.linspace(0, 1, 600), np.linspace(1, 0, 600)])]
    got, want, looks = _controller_load_along(arm, path, surface, normal)
    assert np.abs(got - want).max() <= TANGENT_ERROR_NM
    in_contact = [arm.press_torques(theta, surface.copy(), normal.copy()).any() for theta in path]
    assert sum(in_contact) > 100
    assert sum(in_contact) <= looks < len(path) - 200  # every tick in contact looked; clear of it, few


def test_radius_zero_is_pinocchio_at_every_tick(arm):
    """With the radius 0 the controller looks whenever an angle moved: its load is Pinocchio's at the
    angle, bit for bit, as before the tangent; with the default it is within TANGENT_ERROR_NM and
    looks a tenth as often."""
    rng = np.random.default_rng(11)
    start = _random_drives(arm, rng, 1)[0]
    path = [start + np.radians(0.06) * k * np.array([1.0, -0.5, 0.7, 1.0, 0.3]) for k in range(400)]
    got, want, looks = _controller_load_along(arm, path, radius=0.0)
    assert np.array_equal(got, want) and looks == len(path) - 1
    got, want, looks = _controller_load_along(arm, path)
    assert np.abs(got - want).max() <= TANGENT_ERROR_NM and looks < len(path) / 8
