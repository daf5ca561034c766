"""Pictures for the README and reports, made headless by the project itself.

render_arm_png(path): the arm in the substation seen from the scene's `global_view` camera, with
MuJoCo's offscreen renderer (MUJOCO_GL=egl or osmesa; DESIGN "Headless pictures"), or, when no GL
backend works, a matplotlib 3D drawing of the bodies' geoms. It returns which one was used.
plot_angles_png(arrays, path): true, predicted and target angles per joint from a run's arrays
(Telemetry.arrays() or twin.mcap_log.read_mcap()); run_angles_figure(mcap) the same figure from a
log (`twin plot`), and picture_bytes(figure, format) its file.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import mujoco
import numpy as np
from matplotlib.backend_bases import FigureCanvasBase
from matplotlib.figure import Figure
from matplotlib.image import imsave

import assets
from twin.mcap_log import LogError, read_mcap
from twin.model import geom_rgba


def _home_data(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_forward(model, data)
    return data


def render_arm_png(
    path, model_path=assets.SCENE_XML, qpos: np.ndarray | None = None, width: int = 960, height: int = 720
) -> str:
    """Write a PNG of the arm (keyframe "home" unless `qpos` is given) from `global_view`.

    Returns "mujoco-<backend>" when MuJoCo rendered it offscreen, or "matplotlib" for the fallback
    drawing (no GL backend available).
    """
    model = mujoco.MjModel.from_xml_path(str(model_path))
    data = _home_data(model)
    if qpos is not None:
        data.qpos[:] = qpos
        mujoco.mj_forward(model, data)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    backends = [os.environ["MUJOCO_GL"]] if "MUJOCO_GL" in os.environ else ["egl", "osmesa"]
    for backend in backends:
        try:
            img = _render_in_subprocess(model_path, data.qpos.copy(), backend, width, height)
        except RuntimeError:
            continue
        imsave(path, img)
        return f"mujoco-{backend}"
    _draw_geoms_matplotlib(model, data, path)
    return "matplotlib"


def _render_in_subprocess(model_path, qpos: np.ndarray, backend: str, width: int, height: int) -> np.ndarray:
    """MUJOCO_GL is read once per process, so each backend is tried in a child process."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "img.npy"
        code = (
            "import sys, numpy as np, mujoco\n"
            "m = mujoco.MjModel.from_xml_path(sys.argv[1]); d = mujoco.MjData(m)\n"
            "d.qpos[:] = np.array(sys.argv[2].split(','), dtype=float); mujoco.mj_forward(m, d)\n"
            "r = mujoco.Renderer(m, int(sys.argv[4]), int(sys.argv[3])); r.update_scene(d, 'global_view')\n"
            "np.save(sys.argv[5], r.render()); r.close()\n"
        )
        env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
        args = [
            sys.executable,
            "-c",
            code,
            str(model_path),
            ",".join(repr(float(q)) for q in qpos),
            str(width),
            str(height),
            str(out),
        ]
        proc = subprocess.run(args, env=env, capture_output=True, text=True, timeout=120)
        if proc.returncode != 0 or not out.exists():
            raise RuntimeError(f"MUJOCO_GL={backend}: {proc.stderr.strip().splitlines()[-1:] or proc.returncode}")
        return np.load(out)


def _draw_geoms_matplotlib(model: mujoco.MjModel, data: mujoco.MjData, path: Path) -> None:
    """Fallback: each geom drawn as a wireframe of its shape (boxes, cylinders, capsules,
    spheres) in its world pose; planes are left out."""
    fig = Figure(figsize=(8, 6))
    ax = fig.add_subplot(projection="3d")
    u = np.linspace(0, 2 * np.pi, 16)
    for g in range(model.ngeom):
        t, s = int(model.geom_type[g]), model.geom_size[g]  # int: enum `in` tuple fails on numpy ints
        pos, R = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
        color = geom_rgba(model, g)[:3]
        if t == mujoco.mjtGeom.mjGEOM_BOX:
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * s[:3]
            pts = corners @ R.T + pos
            for a in range(8):
                for b in range(a + 1, 8):
                    if np.sum(np.abs(corners[a] - corners[b]) > 1e-12) == 1:
                        ax.plot(*pts[[a, b]].T, color=color, lw=0.8)
        elif t in (int(mujoco.mjtGeom.mjGEOM_CYLINDER), int(mujoco.mjtGeom.mjGEOM_CAPSULE)):
            r, h = s[0], s[1]
            zs = np.array([-h, h])
            X, Z = np.meshgrid(np.cos(u) * r, zs)
            Y = np.meshgrid(np.sin(u) * r, zs)[0]
            P = np.stack([X, Y, Z], axis=-1) @ R.T + pos
            ax.plot_surface(P[..., 0], P[..., 1], P[..., 2], color=color, linewidth=0, alpha=0.9)
        elif t == mujoco.mjtGeom.mjGEOM_SPHERE:
            v = np.linspace(0, np.pi, 8)
            P = (
                s[0]
                * np.stack(
                    [
                        np.outer(np.cos(u), np.sin(v)),
                        np.outer(np.sin(u), np.sin(v)),
                        np.outer(np.ones_like(u), np.cos(v)),
                    ],
                    -1,
                )
                + pos
            )
            ax.plot_surface(P[..., 0], P[..., 1], P[..., 2], color=color, linewidth=0, alpha=0.9)
    ax.set_xlim(-0.6, 1.2), ax.set_ylim(-0.9, 0.9), ax.set_zlim(0, 1.8)
    ax.set_box_aspect((1.8, 1.8, 1.8))
    ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)"), ax.set_zlabel("z (m)")
    ax.set_title("pneumatic arm and insulator string (matplotlib fallback: no offscreen GL)")
    fig.savefig(path, dpi=120)


ANGLES_DPI = 110
# what Figure.savefig writes here, by suffix: matplotlib's formats but pgf, which needs a LaTeX install
PICTURE_FORMATS = tuple(sorted(set(FigureCanvasBase.get_supported_filetypes()) - {"pgf"}))


def plot_angles_png(arrays: dict, path, joints: tuple[str, ...] = assets.JOINTS, only_moving: bool = True) -> Path:
    """Plot true, predicted and target angles (deg) against time, one panel per joint; with
    `only_moving`, joints whose true angle stays within 0.01° are left out."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    angles_figure(arrays, joints, only_moving).savefig(path, dpi=ANGLES_DPI)
    return path


def angles_figure(arrays: dict, joints: tuple[str, ...] = assets.JOINTS, only_moving: bool = True) -> Figure:
    """The figure of `plot_angles_png`, not yet written anywhere."""
    t = arrays["time_s"]
    true = np.degrees(arrays["true_angle_rad"])
    pred = np.degrees(arrays["predicted_angle_rad"])
    target = np.degrees(arrays["target_angle_rad"])
    keep = [k for k in range(len(joints)) if not only_moving or np.ptp(true[:, k]) > 0.01] or list(range(len(joints)))
    fig = Figure(figsize=(8, 2.6 * len(keep)))
    axes = fig.subplots(len(keep), 1, sharex=True, squeeze=False)
    for ax, k in zip(axes[:, 0], keep, strict=True):
        ax.plot(t, true[:, k], color="k", lw=1.5, label="true (plant)")
        if np.isfinite(pred[:, k]).any():
            ax.plot(t, pred[:, k], color="tab:red", lw=1.2, ls="--", label="predicted (controller)")
        if np.isfinite(target[:, k]).any():
            ax.plot(t, target[:, k], color="tab:blue", lw=1.0, ls=":", label="target")
        ax.set_ylabel(f"{joints[k]} (deg)")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("simulated time (s)")
    fig.tight_layout()
    return fig


def picture_bytes(fig: Figure, fmt: str, dpi: float = ANGLES_DPI) -> bytes:
    """`fig` as a file of format `fmt` (one of PICTURE_FORMATS), e.g. for twin_plumbing.outputs.write_atomic."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=dpi)
    return buffer.getvalue()


def run_angles_figure(mcap_path, until_s: float | None = None, only_moving: bool = True) -> tuple[Figure, dict]:
    """The angles figure of a run logged as MCAP (cut short or whole; the first `until_s`
    simulated seconds if given), and the reader's recovery report.
    Raises twin.mcap_log.LogError on a file that is not a readable log."""
    arrays, meta = read_mcap(mcap_path)
    if meta["recovery"]["samples"] == 0:
        raise LogError(f"{mcap_path}: holds no complete telemetry sample; nothing to plot")
    if until_s is not None:
        keep = arrays["time_s"] <= until_s
        arrays = {k: v[keep] for k, v in arrays.items()}
    return angles_figure(arrays, joints=tuple(meta["joints"]), only_moving=only_moving), meta["recovery"]
