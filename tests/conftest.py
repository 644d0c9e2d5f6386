"""Shared test helpers: the one error measure (docs/design.md §3), URDF builders, the robot zoo."""
from __future__ import annotations

import sys
from pathlib import Path

import warnings

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


def err(x, y) -> float:
    """err = max|x − y| / max(max|y|, 1): relative to the term's largest entry, absolute below 1."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    assert x.shape == y.shape, f"shape {x.shape} != {y.shape}"
    return float(np.max(np.abs(x - y)) / max(np.max(np.abs(y)), 1.0))


def assert_close(x, y, tol, what=""):
    e = err(x, y)
    assert e <= tol, f"{what}: err {e:.3e} > tol {tol:.0e}"


def mujoco_full_m(m, d):
    """MuJoCo's full mass matrix M (nv, nv) of data d (after mj_forward or mj_inverse), armature included:
    mj_fullM's arguments changed from (m, dst, qM) in MuJoCo 3 to (m, d, dst) in MuJoCo 4."""
    import mujoco
    M = np.zeros((m.nv, m.nv))
    if hasattr(d, "qM"):
        mujoco.mj_fullM(m, M, d.qM)
    else:
        mujoco.mj_fullM(m, d, M)
    return M


def inertial_xml(mass, com=(0, 0, 0), I=(0, 0, 0, 0, 0, 0), rpy=(0, 0, 0)):
    ixx, iyy, izz, ixy, ixz, iyz = I
    return (f'<inertial><origin xyz="{com[0]} {com[1]} {com[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
            f'<mass value="{mass}"/><inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" '
            f'ixz="{ixz}" iyz="{iyz}"/></inertial>')


def urdf(links, joints, name="test_robot"):
    """URDF text from {link: inertial xml or ''} and [(name, type, parent, child, xyz, rpy, axis), ...]."""
    body = [f'<link name="{n}">{x}</link>' for n, x in links.items()]
    for jn, jt, par, ch, xyz, rpy, axis in joints:
        lim = '<limit lower="-3" upper="3" effort="10" velocity="10"/>' if jt in ("revolute", "prismatic") else ""
        ax = f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>' if axis is not None else ""
        body.append(f'<joint name="{jn}" type="{jt}"><parent link="{par}"/><child link="{ch}"/>'
                    f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>{ax}{lim}</joint>')
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n' + "\n".join(body) + "\n</robot>\n"


@pytest.fixture
def write_urdf(tmp_path):
    def _write(text, name="robot.urdf"):
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


def zoo_paths():
    from manipdyn.validation import arm_paths
    return arm_paths()


AAU = ROOT / "urdf" / "aau_arm.urdf"


def aau_states(n, seed):
    """(model, Q, V, A): the AAU arm (its load warnings silenced) and n random states of it (validation's
    random_states), for the batch tests."""
    import manipdyn as md
    from manipdyn.validation import random_states
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(AAU)
    return (model, *random_states(model, n, np.random.default_rng(seed)))


def free_flyer_model(text, **kw):
    """Our model of URDF text with a free-flyer root joint "root_joint" (Pinocchio's
    buildModelFromUrdf(path, JointModelFreeFlyer()) of the same file), built in the tests only: the file
    is loaded under an added fixed link joined to its root link by a continuous joint at the identity
    (so the root link becomes body 0 with its own and its merged links' inertia, the rest of the tree
    numbered after it in the same order), and that joint is made the free flyer."""
    import dataclasses
    import re

    import manipdyn as md
    from manipdyn.joints import FREEFLYER
    root = md.load_urdf_string(text, **kw).root_link
    extra = (f'<link name="__fixed_world"/><joint name="root_joint" type="continuous"><parent link="__fixed_world"/>'
             f'<child link="{root}"/><origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/></joint>')
    pinned = md.load_urdf_string(re.sub(r"(<robot\b[^>]*>)", lambda m: m.group(1) + extra, text, count=1), **kw)
    assert pinned.joint_names[0] == "root_joint" and pinned.body_names[0] == root
    ff = lambda x, v: np.concatenate([[v], np.asarray(x)[1:]])      # noqa: E731  (joint 0's entry replaced)
    return dataclasses.replace(
        pinned, root_link="__fixed_world", kind=ff(pinned.kind, FREEFLYER).astype(int),
        continuous=ff(pinned.continuous, False).astype(bool), axis=np.vstack([np.zeros(3), pinned.axis[1:]]),
        lower=ff(pinned.lower, -np.inf), upper=ff(pinned.upper, np.inf),
        effort=ff(pinned.effort, np.inf), velocity=ff(pinned.velocity, np.inf),
        **{k: np.concatenate([np.zeros(6), getattr(pinned, k)[1:]]) for k in ("armature", "damping", "friction")})
