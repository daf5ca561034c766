"""The arm's files: MJCF models and per-joint parameter files, and the names that tie them together.

Both MuJoCo (twin/) and Pinocchio (control/) read the same MJCF from here (DESIGN, rule 3).
"""

from pathlib import Path

ASSETS_DIR = Path(__file__).resolve().parent
ARM_XML = ASSETS_DIR / "arm.xml"  # the arm alone (what Pinocchio reads)
SCENE_XML = ASSETS_DIR / "scene.xml"  # the arm in a substation bay with an insulator string
WRIST_RIG_XML = ASSETS_DIR / "wrist_rig.xml"  # the paper's single-joint bench (Fig. 9, Fig. 22)
JOINTS_DIR = ASSETS_DIR / "joints"
AS_BUILT_DIR = ASSETS_DIR / "as_built"  # what the real arm has that the nominal files lack (pneumatics/as_built.py)

# the five joints, base to tool; each is driven through the fixed tendon "drive_<joint>" by the
# actuator "<joint>" and has the parameter file joints/<joint>.toml
JOINTS = ("base_yaw", "shoulder_pitch", "elbow_pitch", "wrist_pitch", "tool_roll")


def joint_param_path(joint: str) -> Path:
    """Parameter file of a joint."""
    return JOINTS_DIR / f"{joint}.toml"


def as_built_path(joint: str) -> Path:
    """As-built file of a joint: the effects reality has on top of joint_param_path(joint)."""
    return AS_BUILT_DIR / f"{joint}.toml"


def drive_tendon(joint: str) -> str:
    """Name of the fixed tendon that is the joint's drive coordinate (what its motor turns)."""
    return f"drive_{joint}"
