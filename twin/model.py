"""Loading the MJCF into MuJoCo, looking things up by name, treating warnings as errors, and what
the model says of its bodies, geoms and cameras (names, colours) for the logs and pictures."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np


def keep_mujoco_log_off_disk() -> None:
    """MuJoCo's default log handler prints each warning and error and also appends it to
    MUJOCO_LOG.TXT in the working folder; the twin reports both itself (a refusal, a
    SimulationError), so only the print is kept: no stray file where the user happens to be."""
    config = mujoco.MjLogConfig.get()
    config.logto_file = False
    config.set()


keep_mujoco_log_off_disk()  # at import: every process that loads a model through twin (workers too)


class SimulationError(RuntimeError):
    """MuJoCo warned during a run (divergence, constraint overflow, ...): the run cannot be trusted."""


def load_model(path: str | Path | mujoco.MjSpec) -> mujoco.MjModel:
    """Compile an MJCF file, or a scene built at run time (an MjSpec: scenarios/string.py)."""
    if isinstance(path, mujoco.MjSpec):
        return path.compile()
    return mujoco.MjModel.from_xml_path(str(path))


def ids(model: mujoco.MjModel, kind: mujoco.mjtObj, names) -> np.ndarray:
    """Indices of named objects of one kind, in the order given; KeyError names a missing one."""
    out = []
    for name in names:
        i = mujoco.mj_name2id(model, kind, name)
        if i < 0:
            what = mujoco.mjOBJECTSTRING[kind] if hasattr(mujoco, "mjOBJECTSTRING") else kind
            raise KeyError(f"{what}: no {name!r} in the model")
        out.append(i)
    return np.array(out, dtype=np.int64)


def warning_counts(data: mujoco.MjData) -> np.ndarray:
    """How often each MuJoCo warning has fired so far."""
    return data.warning.number.astype(np.int64)


def raise_on_new_warnings(data: mujoco.MjData, before: np.ndarray, when: str) -> None:
    """SimulationError if any MuJoCo warning fired since `before` (STYLE rule 7)."""
    now = warning_counts(data)
    fired = np.flatnonzero(now > before)
    if fired.size:
        names = ", ".join(mujoco.mjtWarning(int(i)).name for i in fired)
        raise SimulationError(f"MuJoCo warned {when} (t = {data.time:.4f} s): {names}")


def drive_map(model: mujoco.MjModel, tendon_ids) -> np.ndarray:
    """(n, k, 3) array of (qpos address, dof address, coefficient) for each fixed tendon's joints.

    Unused terms have coefficient 0. Only fixed tendons over hinge or slide joints are drives.
    """
    terms = []
    for t in tendon_ids:
        adr, num = model.tendon_adr[t], model.tendon_num[t]
        rows = []
        for w in range(adr, adr + num):
            if model.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT:
                name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TENDON, t)
                raise ValueError(f"tendon {name!r} is not a fixed tendon: it cannot be a joint's drive")
            jnt = model.wrap_objid[w]
            rows.append((model.jnt_qposadr[jnt], model.jnt_dofadr[jnt], model.wrap_prm[w]))
        terms.append(rows)
    k = max(len(r) for r in terms)
    out = np.zeros((len(terms), k, 3))
    for i, rows in enumerate(terms):
        out[i, : len(rows)] = rows
    return out


DEFAULT_GEOM_RGBA = (0.5, 0.5, 0.5, 1.0)  # MuJoCo's internal default of geom/@rgba (MJCF reference)


def geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    """Colour of geom `g` as MuJoCo draws it, RGBA 0..1: its own rgba where that differs from the
    default (MJCF reference: "it takes precedence over the material"), else its material's."""
    mat, own = model.geom_matid[g], np.asarray(model.geom_rgba[g], dtype=np.float64)
    if mat < 0 or not np.allclose(own, DEFAULT_GEOM_RGBA):
        return own
    return np.asarray(model.mat_rgba[mat], dtype=np.float64)


def body_name(model: mujoco.MjModel, b: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body_{b}"


def has_camera(model: mujoco.MjModel, name: str) -> bool:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name) >= 0
