"""The robot zoo: example-robot-data's models that Pinocchio loads (docs/design.md §8).

ARMS are fixed-base arms and hands. FLOATING are the robots that example-robot-data's own Python loaders
(``example_robot_data.robots_loader``, not shipped in the 6.0 wheel) build with a free flyer: each loader
class sets ``free_flyer = True`` and calls ``buildModelFromUrdf(path, pin.JointModelFreeFlyer())``; nothing
in the URDF itself says so. They load here with ``load_urdf(path, root_joint="free_flyer")``. Left out:
romeo and human (bodies without mass make M singular: Pinocchio's aba returns NaN) — the tests use them for
inverse dynamics only.
"""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

from ..extras import missing

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


# path under robots/ -> what it exercises, loaded with root_joint="free_flyer"
FLOATING = {
    "solo_description/robots/solo12.urdf": "quadruped, 12 joints",
    "solo_description/robots/solo.urdf": "quadruped, 8 joints",
    "anymal_b_simple_description/robots/anymal.urdf": "quadruped, base mass on a fixed child link",
    "anymal_b_simple_description/robots/anymal-kinova.urdf": "quadruped with an arm",
    "anymal_c_simple_description/urdf/anymal.urdf": "quadruped",
    "hyq_description/robots/hyq_no_sensors.urdf": "heavy quadruped (61 kg base)",
    "go1_description/urdf/go1.urdf": "quadruped",
    "go2_description/urdf/go2.urdf": "quadruped",
    "a1_description/urdf/a1.urdf": "quadruped",
    "b1_description/urdf/b1.urdf": "quadruped",
    "b1_description/urdf/b1-z1.urdf": "quadruped with an arm",
    "laikago_description/urdf/laikago.urdf": "quadruped",
    "bolt_description/robots/bolt.urdf": "biped, 6 joints",
    "talos_data/robots/talos_reduced.urdf": "humanoid, 32 joints",
    "talos_data/robots/talos_full_v2.urdf": "humanoid with hands, 44 joints",
    "icub_description/robots/icub.urdf": "humanoid",
    "icub_description/robots/icub_reduced.urdf": "humanoid",
    "g1_description/urdf/g1_29dof_rev_1_0.urdf": "humanoid",
    "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf": "biped lower body",
    "simple_humanoid_description/urdf/simple_humanoid.urdf": "humanoid",
    "centauro_description/urdf/centauro.urdf": "quadruped with wheels and arms",
    "pr2_description/urdf/pr2.urdf": "mobile base, continuous and prismatic joints (Pinocchio nq = nq + 4)",
    "borinot_description/urdf/borinot_flying_arm_2.urdf": "drone with an arm",
    "hextilt_description/urdf/hextilt_flying_arm_5.urdf": "drone with an arm",
    "hector_description/robots/quadrotor_base.urdf": "a free body alone (nv = 6)",
    "iris_description/robots/iris_simple.urdf": "a free body alone, merged rotors",
}


def robots_dir() -> Path:
    """example-robot-data's robots/ folder, found from the installed package's files (its Python module is
    never imported); MissingExtraError without the validate extra."""
    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError:
        files = []
    for f in files:
        parts = Path(str(f)).parts
        if "robots" in parts and parts[-1].endswith(".urdf"):
            loc = Path(f.locate())
            return Path(*loc.parts[:len(loc.parts) - len(parts) + parts.index("robots") + 1])
    raise missing("example_robot_data", "validate", "the robot zoo (manipdyn validate --zoo)")


def arm_paths() -> list[Path]:
    """Absolute paths of the zoo's arms that are installed."""
    root = robots_dir()
    return [root / rel for rel in ARMS if (root / rel).is_file()]


def floating_paths() -> list[Path]:
    """Absolute paths of the zoo's floating robots that are installed (load them with a free flyer)."""
    root = robots_dir()
    return [root / rel for rel in FLOATING if (root / rel).is_file()]
