"""The arm the controller believes in: Pinocchio built from the same MJCF as the plant (DESIGN, rule 3).

Drive coordinates. Each joint's motor turns a fixed tendon `drive_<joint>` (assets/arm.xml):
drive = C q, with C read from the tendons' joint coefficients in the MJCF (for the parallelogram,
drive_elbow_pitch = shoulder_pitch + elbow_pitch). Power balance f·d(drive) = tau·dq gives the
joint-space torque tau = C^T f, so the load torque each drive must hold is f = C^-T g(q), g from
`pin.computeGeneralizedGravity`; for the parallelogram: f_elbow = G_elbow, f_shoulder =
G_shoulder - G_elbow. The drive-space mass matrix is C^-T M(q) C^-1.

No MuJoCo here: the tendons are read from the XML with xml.etree.
"""

from __future__ import annotations

import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pinocchio as pin

import assets

TOOL_FRAME = "brush_tip"  # the head's centre at its forward stop (assets/arm.xml site)
# press_torques skips the kinematics while the tool frame is certainly further than this in front of
# the surface (m): far above the kinematics' round-off (~1e-15 m), far below any press
CLEAR_MARGIN_M = 1e-9


def _read_xml(path: Path) -> ET.Element:
    """Parse an MJCF file, splicing in the children of every <include file=...> (relative paths)."""
    root = ET.parse(path).getroot()

    def splice(elem: ET.Element, base: Path) -> None:
        for i, child in enumerate(list(elem)):
            if child.tag == "include":
                inc_path = base / child.attrib["file"]
                inc_root = ET.parse(inc_path).getroot()
                splice(inc_root, inc_path.parent)
                elem.remove(child)
                for k, sub in enumerate(list(inc_root)):
                    elem.insert(i + k, sub)
            else:
                splice(child, base)

    splice(root, path.parent)
    return root


def drive_coefficients(xml_path: str | Path, joints: tuple[str, ...]) -> dict[str, dict[str, float]]:
    """{joint: {model joint name: coefficient}} of each joint's drive tendon `drive_<joint>`."""
    root = _read_xml(Path(xml_path))
    tendons = {t.attrib.get("name"): t for t in root.iter("fixed")}
    out = {}
    for j in joints:
        name = assets.drive_tendon(j)
        if name not in tendons:
            raise ValueError(f"{xml_path}: no fixed tendon {name!r} (the drive of joint {j!r})")
        out[j] = {e.attrib["joint"]: float(e.attrib.get("coef", "1")) for e in tendons[name].iter("joint")}
    return out


def joint_springs(xml_path: str | Path, joints: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Per joint (model joint names), the MJCF's joint spring: stiffness (N·m/rad) and springref
    (rad), zeros where it has none (the wrist's counterbalance, assets/arm.xml). MuJoCo's law:
    torque = -stiffness (q - springref). Springs set through <default> classes are refused: they
    would be missed here (the file is read, not compiled)."""
    root = _read_xml(Path(xml_path))
    for default in root.iter("default"):
        for joint in default.findall("joint"):
            if float(joint.attrib.get("stiffness", "0")) != 0.0:
                raise ValueError(
                    f"{xml_path}: a joint stiffness in a <default> class is not supported; set it on the joint"
                )
    found = {j.attrib.get("name"): j for j in root.iter("joint")}
    k = np.array([float(found[j].attrib.get("stiffness", "0")) if j in found else 0.0 for j in joints])
    ref = np.array([float(found[j].attrib.get("springref", "0")) if j in found else 0.0 for j in joints])
    return k, ref


@dataclass(frozen=True, kw_only=True)
class HeadSpring:
    """The brush head's spring slide (joint `brush_stroke`, assets/arm.xml): the force it presses
    with is preload_n + stiffness_n_m x stroke, up to stroke_m (bottomed out)."""

    stiffness_n_m: float
    preload_n: float
    stroke_m: float

    def force_n(self, press_m: float) -> float:
        """The head's force pressed `press_m` into a surface (0 clear of it), the spring's law: the
        head leaves its stop at the preload; past the stroke the rigid arm pushes, which the plan
        never asks for (the spring's end force is kept, not extrapolated)."""
        if press_m <= 0.0:
            return 0.0
        return self.preload_n + self.stiffness_n_m * min(press_m, self.stroke_m)


def head_spring(xml_path: str | Path, joint: str = "brush_stroke") -> HeadSpring | None:
    """The MJCF's spring slide `joint` (stiffness, springref, range), None where the model has none.
    MuJoCo's law: force = -stiffness (q - springref); the head rests at q = 0 (its forward stop),
    so the preload is stiffness x springref and the stroke the range's length."""
    found = next((j for j in _read_xml(Path(xml_path)).iter("joint") if j.attrib.get("name") == joint), None)
    if found is None:
        return None
    k, ref = joint_springs(xml_path, (joint,))
    lo, hi = (float(v) for v in found.attrib["range"].split())
    return HeadSpring(stiffness_n_m=float(k[0]), preload_n=float(k[0] * ref[0]), stroke_m=hi - lo)


class _Clear(NamedTuple):
    """A look of `press_torques` that found the tool frame clear of a surface (known by its arrays)."""

    surface_m: np.ndarray
    normal: np.ndarray
    q: list[float]  # the joint angles it looked at, rad
    clearance_m: float  # how far in front of the surface the frame stood


def _pinocchio_model(xml_path: Path, payload_kg: float | None) -> pin.Model:
    return _lock_undriven(_full_model(xml_path, payload_kg))


def _lock_undriven(model: pin.Model) -> pin.Model:
    """The model with every joint that no motor drives (the brush head's spring slide) locked at
    its neutral position: the controller believes the head rests at its stop, where its spring's
    preload holds it whenever the brush touches nothing."""
    undriven = [i for i in range(1, model.njoints) if model.names[i] not in assets.JOINTS]
    if not undriven:
        return model
    return pin.buildReducedModel(model, undriven, pin.neutral(model))


def _full_model(xml_path: Path, payload_kg: float | None) -> pin.Model:
    if payload_kg is None:
        return pin.buildModelFromMJCF(str(xml_path))
    # the payload's mass as the scenario says: the same MJCF with <body name="payload"><inertial mass>
    root = _read_xml(xml_path)
    found = False
    for body in root.iter("body"):
        if body.attrib.get("name") == "payload":
            inertial = body.find("inertial")
            if inertial is not None:
                # ~0 rather than 0: an MJCF body needs mass (same convention as the tests' variant)
                inertial.set("mass", repr(max(float(payload_kg), 1e-9)))
                found = True
    if not found:
        raise ValueError(f"{xml_path}: no body 'payload' with an <inertial> to set payload_kg = {payload_kg:g}")
    _anchor_asset_paths(root, xml_path.parent)
    # written to a folder of its own, never beside the MJCF: the installed package may be read-only
    with tempfile.TemporaryDirectory() as folder:
        copy = Path(folder) / xml_path.name
        ET.ElementTree(root).write(copy)
        return pin.buildModelFromMJCF(str(copy))


def _anchor_asset_paths(root: ET.Element, base: Path) -> None:
    """Make the MJCF's file references absolute (from the folder `base` it was read from), so that a
    copy written elsewhere finds its meshes and textures: the compiler's asset folders if it names
    any (mesh files are relative to them), else each element's `file`."""
    folders = [c for c in root.iter("compiler") if {"meshdir", "texturedir", "assetdir"} & set(c.attrib)]
    for compiler in folders:
        for key in ("meshdir", "texturedir", "assetdir"):
            if key in compiler.attrib:
                compiler.set(key, str(base / compiler.attrib[key]))
    if not folders:
        for element in root.iter():
            if "file" in element.attrib:
                element.set("file", str(base / element.attrib["file"]))


class ArmModel:
    """Gravity load and inertia of each drive at a configuration given in drive angles.

    `joints` are the driven joints, in the controller's order (default: those of assets.JOINTS
    present in the model). Constant model, mutable data (Pinocchio's own split).
    """

    def __init__(
        self,
        xml_path: str | Path = assets.ARM_XML,
        joints: tuple[str, ...] | None = None,
        payload_kg: float | None = None,
    ):
        xml_path = Path(xml_path)
        self.xml_path = xml_path
        self.model = _pinocchio_model(xml_path, payload_kg)
        self.data = self.model.createData()
        m = self.model
        names = [m.names[i] for i in range(1, m.njoints)]
        if joints is None:
            joints = tuple(j for j in assets.JOINTS if j in names)
        self.joints = tuple(joints)
        n = len(self.joints)
        if m.nq != m.nv or m.nv != n:
            raise ValueError(
                f"{xml_path}: {m.nv} degrees of freedom but {n} drives {self.joints}: the drive map must be square"
            )
        coefs = drive_coefficients(xml_path, self.joints)
        C = np.zeros((n, m.nv))
        for i, j in enumerate(self.joints):
            for name, c in coefs[j].items():
                if not m.existJointName(name):
                    raise ValueError(f"{xml_path}: tendon drive_{j} names joint {name!r}, which the model lacks")
                C[i, m.joints[m.getJointId(name)].idx_v] = c
        if abs(np.linalg.det(C)) < 1e-9:
            raise ValueError(f"{xml_path}: the drive tendons {self.joints} do not determine the joint angles")
        self.C = C  # drive = C q
        self.C_inv = np.linalg.inv(C)  # q = C^-1 drive
        self.C_inv_T = np.ascontiguousarray(self.C_inv.T)  # f = C^-T tau
        # joint springs (the wrist's counterbalance), in Pinocchio's joint order: their holding torque
        # k (q - q_ref) is part of each drive's static load, as gravity's is
        names_by_v = [""] * m.nv
        for i in range(1, m.njoints):
            names_by_v[m.joints[i].idx_v] = m.names[i]
        self.spring_k, self.spring_ref = joint_springs(xml_path, tuple(names_by_v))
        # (index, k, q_ref) of each sprung joint: added one by one in load_torques, per tick (a numpy
        # expression on the 5-vectors costs more than the few floats)
        self._springs = [
            (int(i), float(self.spring_k[i]), float(self.spring_ref[i])) for i in np.flatnonzero(self.spring_k)
        ]
        self._q = np.zeros(m.nq)
        # the brush head's spring and the frame it is pressed at (press_torques)
        self.head_spring = head_spring(xml_path)
        self._tool_frame = m.getFrameId(TOOL_FRAME) if m.existFrame(TOOL_FRAME) else -1
        if self._tool_frame < 0:
            self.head_spring = None
        # how far the tool frame can move per radian of any joint: no further from a revolute joint's
        # axis than the chain's placements summed (inf where a joint is not revolute: no bound)
        revolute = all(m.joints[i].shortname().startswith("JointModelR") for i in range(1, m.njoints))
        reach = sum(float(np.linalg.norm(m.jointPlacements[i].translation)) for i in range(1, m.njoints))
        if self._tool_frame >= 0:
            reach += float(np.linalg.norm(m.frames[self._tool_frame].placement.translation))
        self._reach_m = reach if revolute else np.inf
        self._clear_at: _Clear | None = None  # the last press_torques clear of its surface
        self._no_press = np.zeros(n)
        self._no_press.flags.writeable = False  # returned by press_torques clear of the surface, shared
        lo, hi = m.lowerPositionLimit, m.upperPositionLimit
        self.joint_lower = np.array(lo, dtype=float)
        self.joint_upper = np.array(hi, dtype=float)

    def drive_stops(self) -> np.ndarray:
        """(n, 2): the end stops (low, high) of each drive angle in rad, for the one-joint model
        (`pneumatics.params.params_row`'s stops): its joint's range where the drive is that joint
        alone, else none (-inf, inf): a joint without a range, or a drive that sums joints (the
        elbow's, shoulder + elbow, stops where the shoulder puts it)."""
        out = np.tile([-np.inf, np.inf], (len(self.joints), 1))
        for i, row in enumerate(self.C):
            (terms,) = np.nonzero(row)
            if len(terms) == 1 and row[terms[0]] == 1.0:  # (Pinocchio's range of an unlimited joint is +-inf)
                out[i] = self.joint_lower[terms[0]], self.joint_upper[terms[0]]
        return out

    def joint_positions(self, drive_angles: np.ndarray) -> np.ndarray:
        """Pinocchio q (rad) from the drive angles (rad)."""
        return self.C_inv @ np.asarray(drive_angles, dtype=float)

    def load_torques(self, drive_angles: np.ndarray) -> np.ndarray:
        """Load torque on each drive (N·m) from gravity, payload included, and the joints' springs,
        f = C^-T (g(q) + k (q - q_ref)).

        Positive when the load pulls the drive negative (it adds to the torque the drive must make,
        `single_joint_rates`'s `load_torque_nm`)."""
        # ndarray.dot: the same product as @, with half its call overhead on 5-vectors (per tick)
        q = self.C_inv.dot(drive_angles)
        g = pin.computeGeneralizedGravity(self.model, self.data, q)
        for i, k, ref in self._springs:  # in Pinocchio's data.g, scratch recomputed every call
            g[i] += k * (q[i] - ref)
        return self.C_inv_T.dot(g)

    def load_slope(self, drive_angles: np.ndarray) -> np.ndarray:
        """The derivative of `load_torques` by the drive angles, (n, n) N·m/rad: C^-T (dg/dq + k) C^-1,
        dg/dq from `pin.computeGeneralizedGravityDerivatives` (the press's load is not smooth and has
        none: control/predicted_load.py)."""
        q = self.C_inv.dot(drive_angles)
        dg = pin.computeGeneralizedGravityDerivatives(self.model, self.data, q)
        for i, k, _ in self._springs:
            dg[i, i] += k
        return self.C_inv_T.dot(dg).dot(self.C_inv)

    def press_clearance_m(self, drive_angles: np.ndarray, surface_m: np.ndarray, normal: np.ndarray) -> float:
        """How far (m) the tool frame is certainly in front of the surface at these drive angles, less
        CLEAR_MARGIN_M, after `press_torques` there: the clearance its last look found, less the chain's
        reach times the joints' turn since (what `press_torques` skips its kinematics by). inf without
        a head spring (nothing presses); -inf where no bound is known (pressed, touching, a chain that
        is not all revolute)."""
        if self.head_spring is None:
            return np.inf
        return self._clearance(self.C_inv.dot(drive_angles), surface_m, normal) - CLEAR_MARGIN_M

    def _clearance(self, q: np.ndarray, surface_m: np.ndarray, normal: np.ndarray) -> float:
        # how far (m) the tool frame is certainly in front of this surface at joint angles q: the
        # clearance the last look found, less the chain's reach times the joints' turn since; -inf
        # where no bound is known (no look clear of this surface, a chain not all revolute)
        clear = self._clear_at
        if (
            clear is None
            or clear.surface_m is not surface_m
            or clear.normal is not normal
            or not np.isfinite(self._reach_m)
        ):
            return -np.inf
        # (a list's sum: numpy's costs more than the kinematics it would spare)
        turned = sum([abs(a - b) for a, b in zip(q.tolist(), clear.q, strict=True)])
        return clear.clearance_m - self._reach_m * turned

    @property
    def reach_m(self) -> float:
        """How far the tool frame can move per radian of any joint's turn (m; inf: no bound)."""
        return self._reach_m

    def press_torques(self, drive_angles: np.ndarray, surface_m: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """The load on each drive (N·m, `load_torques`'s sign) of the brush head pressed into a
        surface: the plane through `surface_m` (where `tool_frame` stands when the head's face
        touches it) with the unit `normal` pointing out of it, towards the arm (numpy arrays). The
        head is pressed by the depth of the frame behind the plane along the normal and pushes back
        along it with its spring's force (f = F n, world): the drive must add -C^-T J^T f to hold
        it. Zeros (read-only, shared) clear of the surface, or without a head spring in the model.
        A surface is known by its arrays: a new surface comes in new arrays, not changed in place."""
        if self.head_spring is None:
            return self._no_press
        # per tick while a move is on a disc: ~5 us clear of it (forward kinematics of one frame), none
        # while the joints have turned too little since the last look to bring the frame to the surface
        q = self.C_inv.dot(drive_angles)
        if self._clearance(q, surface_m, normal) > CLEAR_MARGIN_M:
            return self._no_press  # what the kinematics below would give: no force
        m, d = self.model, self.data
        pin.forwardKinematics(m, d, q)
        tip = pin.updateFramePlacement(m, d, self._tool_frame).translation
        press_m = float(surface_m.dot(normal) - tip.dot(normal))
        self._clear_at = None
        if press_m < 0.0:  # clear of it: later calls skip the kinematics while the joints turn too little to touch
            self._clear_at = _Clear(surface_m=surface_m, normal=normal, q=q.tolist(), clearance_m=-press_m)
        force = self.head_spring.force_n(press_m)
        if force == 0.0:
            return self._no_press
        jac = pin.computeFrameJacobian(m, d, q, self._tool_frame, pin.LOCAL_WORLD_ALIGNED)[:3]
        return -self.C_inv_T.dot(jac.T.dot(force * normal))

    def spring_torques(self, drive_angles: np.ndarray) -> np.ndarray:
        """The joint springs' share of `load_torques` (N·m per drive): C^-T k (q - q_ref)."""
        q = self.C_inv.dot(drive_angles)
        return self.C_inv_T.dot(self.spring_k * (q - self.spring_ref))

    def drive_inertias(self, drive_angles: np.ndarray) -> np.ndarray:
        """Diagonal of the drive-space mass matrix C^-T M(q) C^-1 (kg·m²), links only (no rotor)."""
        M = pin.crba(self.model, self.data, self.C_inv @ np.asarray(drive_angles, dtype=float))
        M = np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle
        return np.diag(self.C_inv_T @ M @ self.C_inv).copy()

    def joints_within_limits(self, drive_angles: np.ndarray) -> np.ndarray:
        """Joint positions q (rad) for the drive angles and whether each joint is inside its range."""
        q = self.joint_positions(drive_angles)
        return q, (q >= self.joint_lower - 1e-9) & (q <= self.joint_upper + 1e-9)
