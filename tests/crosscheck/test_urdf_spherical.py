"""URDF ``type="spherical"`` joints (PyBullet's and MuJoCo's extension; urdfdom, so Pinocchio, refuses them) load as
ball joints (manipdyn.joints.BALL), held to MuJoCo reading the same file: M (mj_fullM) and τ (mj_rne) on random
states, MuJoCo's ball qpos [w x y z] mapped from ours [x y z w] (qvel: the body-frame ω in both).

Measured: the random trees ≤ 4.0e-15, pybullet_data's humanoid.urdf (8 spherical joints, a NUL byte after the
document: an "xml_text" quirk) ≤ 1.1e-15. TOL = 1e-13.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from conftest import err, inertial_xml, mujoco_full_m

mujoco = pytest.importorskip("mujoco")

TOL = 1e-13   # measured ≤ 4.0e-15


def spherical_tree(seed):
    """base -> j0 (revolute) -> a -> s1 (spherical, turned origin) -> b -> s2 (spherical) -> c; b -> p (prismatic)
    -> d: random origins, masses, centres and inertias (positive definite, triangle inequality held)."""
    rng = np.random.default_rng(seed)

    def inertial():
        moments = rng.uniform(0.05, 0.1, 3)                 # the triangle inequality holds
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        J = R @ np.diag(moments) @ R.T
        return inertial_xml(rng.uniform(0.5, 2.0), rng.uniform(-0.1, 0.1, 3).tolist(),
                            (J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]))

    def origin():
        xyz, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-1, 1, 3)
        return f'<origin xyz="{" ".join(map(str, xyz.tolist()))}" rpy="{" ".join(map(str, rpy.tolist()))}"/>'
    lim = '<limit lower="-2" upper="2" effort="10" velocity="10"/>'
    axis = " ".join(map(str, rng.normal(size=3).tolist()))
    links = "".join(f'<link name="{n}">{inertial() if n != "base" else ""}</link>' for n in "base a b c d".split())
    joints = (f'<joint name="j0" type="revolute"><parent link="base"/><child link="a"/>{origin()}'
              f'<axis xyz="{axis}"/>{lim}</joint>'
              f'<joint name="s1" type="spherical"><parent link="a"/><child link="b"/>{origin()}</joint>'
              f'<joint name="s2" type="spherical"><parent link="b"/><child link="c"/>{origin()}'
              f'<dynamics damping="0.3"/></joint>'
              f'<joint name="p" type="prismatic"><parent link="b"/><child link="d"/>{origin()}'
              f'<axis xyz="0 1 0"/>{lim}</joint>')
    return f'<?xml version="1.0"?><robot name="spherical">{links}{joints}</robot>'


def mujoco_errors(model, m, n=5, seed=0):
    """Worst err of our M and τ against MuJoCo's over n random states (joints matched by name)."""
    d, rng, worst = mujoco.MjData(m), np.random.default_rng(seed), 0.0
    byname = {m.joint(j).name: j for j in range(m.njnt)}
    assert sorted(byname) == sorted(model.joint_names)
    iv = np.concatenate([m.jnt_dofadr[byname[n_]] + np.arange(model.nvs[i]) for i, n_ in enumerate(model.joint_names)])
    for _ in range(n):
        q = md.random_configuration(model, rng)
        v, a = rng.normal(size=model.nv), rng.normal(size=model.nv)
        qpos = np.zeros(m.nq)
        for i, name in enumerate(model.joint_names):
            k, j = model.idx_q[i], m.jnt_qposadr[byname[name]]
            qpos[j:j + model.nqs[i]] = np.r_[q[k + 3], q[k:k + 3]] if model.kind[i] == md.BALL else q[k]
        d.qpos[:], d.qvel[iv] = qpos, v
        mujoco.mj_forward(m, d)
        d.qacc[:] = 0.0
        d.qacc[iv] = a
        tau_mj = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 1, tau_mj)
        M_mj = mujoco_full_m(m, d)
        worst = max(worst, err(md.rnea(model, q, v, a), tau_mj[iv]), err(md.mass_matrix(model, q), M_mj[np.ix_(iv, iv)]))
    return worst


@pytest.mark.parametrize("seed", range(4))
def test_spherical_urdf_joints_agree_with_mujoco(seed, tmp_path):
    text = spherical_tree(seed)
    model = md.load_urdf_string(text)
    assert model.joint_names == ("j0", "s1", "p", "s2")                 # b's children by name (docs/design.md §3)
    assert [md.joints.TYPE_NAMES[k] for k in model.kind] == ["revolute", "ball", "prismatic", "ball"]
    assert model.damping.tolist() == [0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.3, 0.3]     # j0, s1 (3), p, s2 (3)
    path = tmp_path / "spherical.urdf"
    path.write_text(text)
    e = mujoco_errors(model, mujoco.MjModel.from_xml_path(str(path)))
    print(f"\nseed {seed}: M, τ against MuJoCo reading the same URDF: {e:.1e}")
    assert e <= TOL


def test_pybullet_humanoid_urdf_loads_and_agrees_with_mujoco():
    """pybullet_data's humanoid.urdf: spherical joints, and a NUL byte after the document (MuJoCo and PyBullet read
    it; urdfdom refuses the spherical type)."""
    data = pytest.importorskip("pybullet_data")
    from pathlib import Path
    path = Path(data.getDataPath()) / "humanoid" / "humanoid.urdf"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(path)
    assert "xml_text" in [k.kind for k in model.quirks]
    assert int(np.sum(model.kind == md.BALL)) == 8 and (model.nq, model.nv) == (36, 28)
    e = mujoco_errors(model, mujoco.MjModel.from_xml_path(str(path)))
    print(f"\nhumanoid.urdf: M, τ against MuJoCo: {e:.1e}")
    assert e <= TOL


def test_spherical_joint_cannot_be_a_mimic():
    text = spherical_tree(0)
    bad = text.replace('<joint name="p" type="prismatic"><parent link="b"/>',
                       '<joint name="p" type="prismatic"><mimic joint="s1"/><parent link="b"/>')
    with pytest.raises(md.URDFError, match="names a spherical joint"):
        md.load_urdf_string(bad)
