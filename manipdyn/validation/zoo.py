"""The robot zoo: fixed-base arms and hands of example-robot-data that Pinocchio loads (DESIGN.md §8)."""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

from ..errors import ManipdynError

# path under robots/ -> what it exercises
ARMS = {
    "ur_description/urdf/ur5_robot.urdf": "axes along y and z",
    "ur_description/urdf/ur10_robot.urdf": "axes along y and z",
    "ur_description/urdf/ur3_robot.urdf": "axes along y and z",
    "ur_description/urdf/ur5_gripper.urdf": "fixed tool links",
    "panda_description/urdf/panda.urdf": "prismatic fingers, mimic joint",
    "kinova_description/robots/kinova.urdf": "continuous joints (Pinocchio nq = 9)",
    "xarm_description/urdf/xarm7.urdf": "7-dof chain",
    "z1_description/urdf/z1.urdf": "7-dof chain",
    "so_arm_description/urdf/so100.urdf": "hobby arm, axes along x/y/z",
    "so_arm_description/urdf/so101.urdf": "hobby arm",
    "double_pendulum_description/urdf/double_pendulum.urdf": "textbook check",
    "double_pendulum_description/urdf/double_pendulum_continuous.urdf": "continuous joints",
    "asr_twodof_description/urdf/TwoDofs.urdf": "minimal chain",
    "finger_edu_description/robots/finger_edu.urdf": "unaligned revolute axes",
    "allegro_hand_description/urdf/allegro_right_hand.urdf": "branching tree, q order != file order",
    "allegro_hand_description/urdf/allegro_left_hand.urdf": "branching tree",
    "baxter_description/urdf/baxter.urdf": "dual-arm tree, prismatic grippers, q order != file order",
    "talos_data/robots/talos_left_arm.urdf": "humanoid arm with mimic joints",
}


def robots_dir() -> Path:
    """example-robot-data's robots/ folder, found from the installed package's files."""
    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError:
        files = []
    for f in files:
        parts = Path(str(f)).parts
        if "robots" in parts and parts[-1].endswith(".urdf"):
            loc = Path(f.locate())
            return Path(*loc.parts[:len(loc.parts) - len(parts) + parts.index("robots") + 1])
    raise ManipdynError("example-robot-data is not installed (pip install example-robot-data)")


def arm_paths() -> list[Path]:
    """Absolute paths of the zoo's arms that are installed."""
    root = robots_dir()
    return [root / rel for rel in ARMS if (root / rel).is_file()]
