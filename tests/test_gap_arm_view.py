"""The rerun view of an arm campaign's diagnosis (`twin gap arm-diagnose --rrd`, gap/arm_view.py),
read back with rerun's own reader: both arms drawn, the departing joint marked, the verdict
logged, and the replayed arm's poses MuJoCo's forward kinematics at the replayed angles."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

import assets
from gap.arm_campaign import JOINTS, HiddenArmEffect, load_arm_campaign
from gap.arm_diagnose import twin_of
from gap.arm_effects import candidate_named
from gap.arm_rehearsal import CAMERA, make_arm_campaign
from gap.arm_replay import TICK_S, replay
from gap.arm_view import DEPARTS_RGBA, MEASURED_PATH, REPLAYED_PATH, REPLAYED_RGBA, VERDICT_PATH
from scenarios.schema import load
from twin_cli.cli import main as twin_main

SECONDS = 4.0  # the exercise's first move: the base out to 70 deg
HIDDEN = HiddenArmEffect(
    effect="base_yaw:coulomb_friction", value=60.0
)  # the twin's 25 N·m (assets/joints/base_yaw.toml)


@pytest.fixture(scope="module")
def viewed(tmp_path_factory):
    """A two-run camera campaign of the exercise with the base's friction hidden, diagnosed by the
    command line with --rrd: (campaign, diagnosis.json, the recording's chunks by entity)."""
    import rerun as rr

    tmp = tmp_path_factory.mktemp("view")
    scenario = load("scenarios/arm_protocols/one_joint.toml")
    make_arm_campaign(tmp / "c", [scenario], (0.5, 0.7), HIDDEN, CAMERA, seed=1, duration_s=SECONDS)
    code = twin_main(["gap", "arm-diagnose", str(tmp / "c"), "--out", str(tmp / "d"), "--rrd", str(tmp / "v.rrd")])
    assert code == 0
    chunks: dict[str, list] = {}
    for chunk in rr.chunk.RrdReader(tmp / "v.rrd").stream():
        chunks.setdefault(chunk.entity_path.strip("/"), []).append(chunk)
    return load_arm_campaign(tmp / "c"), json.loads((tmp / "d" / "diagnosis.json").read_text()), chunks


def _column(chunks: list, name: str, timeline: str | None = None) -> list:
    """Every row of one component over an entity's chunks (of those indexed on `timeline`), in time order."""
    rows = []
    for c in chunks:
        batch = c.to_record_batch()
        if name not in batch.schema.names or (timeline is not None and timeline not in batch.schema.names):
            continue
        t = batch.column(timeline).cast("int64").to_pylist() if timeline else [0] * batch.num_rows
        rows += list(zip(t, batch.column(name).to_pylist(), strict=True))
    return [v for _, v in sorted(rows, key=lambda r: r[0])]


def test_both_arms_are_drawn_and_the_departing_joint_is_marked(viewed):
    campaign, diagnosis, chunks = viewed
    assert diagnosis["joint"] == "base_yaw", diagnosis["verdict"]  # what the view has to mark
    model = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    bodies = [model.body(b).name for b in range(1, model.nbody)]
    for root in (MEASURED_PATH, REPLAYED_PATH):
        assert {f"{root}/{b}" for b in bodies} <= set(chunks), root
        assert any(p.startswith(f"{root}/upper_arm/") for p in chunks), "the links' geometry is not drawn"
    link = model.body(int(model.jnt_bodyid[model.joint("base_yaw").id])).name  # the turret
    label = _column(chunks[f"{MEASURED_PATH}/{link}/departs"], "Points3D:labels")
    assert label == [["base_yaw departs"]]

    def colours(root: str, body: str) -> set[int]:
        geoms = [p for p in chunks if p.startswith(f"{root}/{body}/") and not p.endswith("departs")]
        return {c[0] for p in geoms for c in _column(chunks[p], next(iter(_colour_fields(chunks[p]))))}

    red, blue = _u32(DEPARTS_RGBA), _u32(REPLAYED_RGBA)
    assert colours(MEASURED_PATH, link) == {red} and red not in colours(MEASURED_PATH, "upper_arm")
    assert colours(REPLAYED_PATH, "upper_arm") == {blue} and blue not in colours(REPLAYED_PATH, link)
    withheld = diagnosis["withheld_runs"]
    verdict = [t[0] for t in _column(chunks[VERDICT_PATH], "TextLog:text", withheld[0])]
    assert verdict[0].startswith("base_yaw departs") and "base_yaw:coulomb_friction" in verdict[0]
    assert any(line.startswith("base_yaw:") and "departs" in line for line in verdict[1:])


def _colour_fields(chunks: list) -> list[str]:
    names = {n for c in chunks for n in c.to_record_batch().schema.names}
    return sorted(n for n in names if n.endswith(":colors"))


def _u32(rgba: tuple[int, ...]) -> int:
    r, g, b, a = rgba
    return (r << 24) | (g << 16) | (b << 8) | a


def test_replayed_arm_is_forward_kinematics_of_the_fitted_replay(viewed):
    """The replayed arm's body poses are MuJoCo's forward kinematics at the fitted twin's replayed
    angles, the joint angles solved here from the drive tendons' Jacobian (not twin.ghost's map)."""
    campaign, diagnosis, chunks = viewed
    run = next(r for r in campaign.runs if r.name == diagnosis["withheld_runs"][0])
    best = min(diagnosis["fits"], key=lambda f: f["withheld_misfit"])
    twin = twin_of(campaign)
    params, setup = candidate_named(best["candidate"]).apply(twin.params, twin.setup, JOINTS, best["value"])
    rep = replay(run, params, setup)
    model = mujoco.MjModel.from_xml_path(str(assets.SCENE_XML))
    data = mujoco.MjData(model)
    tendons = [model.tendon(assets.drive_tendon(j)).id for j in JOINTS]
    qadr = [int(model.joint(j).qposadr[0]) for j in JOINTS]
    jac = np.empty((len(JOINTS), len(JOINTS)))  # a fixed tendon's length is linear in the joints' angles
    for k, adr in enumerate(qadr):
        data.qpos[:] = 0.0
        data.qpos[adr] = 1.0
        mujoco.mj_forward(model, data)
        jac[:, k] = data.ten_length[tendons]
    drawn = np.rint(np.asarray(_times(chunks[f"{REPLAYED_PATH}/forearm"], run.name)) * 1e-9 / TICK_S).astype(int)
    assert len(drawn) > SECONDS / 0.05 and drawn[-1] * TICK_S > SECONDS - 0.05  # 50 poses a second, to the end
    series = np.array(
        [v[0] for v in _column(chunks["joints/base_yaw/angle_deg/replayed"], "Scalars:scalars", run.name)]
    )
    np.testing.assert_allclose(series, np.degrees(rep.angle_rad[drawn, 0]), rtol=0, atol=1e-9)
    for body in ("turret", "forearm", "tool"):
        pos = np.array([v[0] for v in _column(chunks[f"{REPLAYED_PATH}/{body}"], "Transform3D:translation", run.name)])
        quat = np.array([v[0] for v in _column(chunks[f"{REPLAYED_PATH}/{body}"], "Transform3D:quaternion", run.name)])
        for k in (0, len(drawn) // 2, len(drawn) - 1):
            data.qpos[:] = model.qpos0
            data.qpos[qadr] = np.linalg.solve(jac, rep.angle_rad[drawn[k]])
            mujoco.mj_kinematics(model, data)
            np.testing.assert_allclose(pos[k], data.body(body).xpos, atol=1e-6)
            xyzw = np.r_[data.body(body).xquat[1:], data.body(body).xquat[0]]
            assert min(np.abs(quat[k] - xyzw).max(), np.abs(quat[k] + xyzw).max()) < 1e-6  # q and -q: one turn
    moved = np.degrees(np.ptp(rep.angle_rad[drawn, 0]))
    assert moved > 10.0, moved  # the base did turn: the poses are not one pose over and over


def _times(chunks: list, timeline: str) -> list[int]:
    out = []
    for c in chunks:
        batch = c.to_record_batch()
        if timeline in batch.schema.names:
            out += batch.column(timeline).cast("int64").to_pylist()
    return sorted(out)
