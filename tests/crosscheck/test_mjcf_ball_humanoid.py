"""An MJCF humanoid with ball joints and armature (tests/data/humanoid_ball.xml: gymnasium's humanoid with its hips
and shoulders as ball joints, scripts/make_humanoid_ball.py) against MuJoCo 4.0 and Pinocchio 4.1's
buildModelFromMJCF: τ, M (armature included) and q̈ on random states.

References: MuJoCo compiling the same file — M = mj_fullM (with dof_armature), τ = mj_rne with q̈ (+ armature ⊙ q̈,
which mj_rne leaves out), q̈ = mj_forward's qacc with τ as qfrc_applied and its constraint solver, contacts and
passive forces (damping, springs) off; Pinocchio's crba, rnea, aba (pm.armature read from the file). States: the
root [x y z qx qy qz qw] and every ball's quaternion uniform on S³, hinges in [−π, π], v, q̈ ~ N(0, 1), τ ~ N(0, 25).
MuJoCo's conventions converted here (as tests/crosscheck/test_mjcf_import.mujoco_errors): a ball's qpos [qw qx qy
qz], its qvel the body-frame ω as ours; the free joint's qvel [R v_lin; ω], qacc [R (a_lin + ω × v_lin); ω̇], its
generalized force Tᵀ τ.

Measured (this VM, 20 states): MuJoCo τ, M ≤ 9.4e-16, q̈ ≤ 3.8e-18 · cond(M); Pinocchio τ, M ≤ 1.4e-15, q̈ ≤
8.0e-18 · cond(M) — TAU_M = 1e-13, QDD = 5e-16 (ball joints and armature agree with Pinocchio well within 1e-12);
to_mjcf of the model (the abdomen's two joints one body again) -> MuJoCo τ, M ≤ 5.0e-16.
The file's joint dynamics: armature and damping read; the abdomen's and a knee's stiffness are quirks (not applied,
and off in MuJoCo's q̈ here).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import ROOT, err, mujoco_full_m
from test_mjcf_import import mujoco_errors, mujoco_qpos, random_state

import manipdyn as md

mujoco = pytest.importorskip("mujoco")

PATH = ROOT / "tests" / "data" / "humanoid_ball.xml"
TAU_M = 1e-13           # measured ≤ 1.4e-15 (Pinocchio), 9.4e-16 (MuJoCo), 5.0e-16 (MuJoCo on the export)
QDD = 5e-16             # q̈ err / cond(M): measured ≤ 8.0e-18 (Pinocchio), 3.8e-18 (MuJoCo)
N = 20


def _model():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_mjcf(PATH)


def _states(model, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(N):
        q, v, a = random_state(model, rng)
        out.append((q, v, a, rng.normal(0.0, 5.0, model.nv)))
    return out


def test_the_file_is_the_generated_one():
    # the committed asset is what scripts/make_humanoid_ball.py writes from gymnasium's file (when installed)
    pytest.importorskip("gymnasium")
    import sys
    sys.path.insert(0, str(ROOT / "scripts"))
    from make_humanoid_ball import convert, source
    assert PATH.read_text() == convert(source().read_text())


def test_joints_and_armature_as_written():
    model = _model()
    balls = [model.joint_names[i] for i in range(model.njoints) if model.kind[i] == md.BALL]
    assert balls == ["right_hip", "left_hip", "right_shoulder", "left_shoulder"]
    assert model.floating and (model.nq, model.nv) == (30, 25)
    for name, arm, damp in (("right_hip", 0.01, 5.0), ("left_shoulder", 0.006, 1.0), ("abdomen_y", 0.02, 5.0)):
        k, n = model.idx_v[model.joint_index(name)], model.nvs[model.joint_index(name)]
        assert model.armature[k:k + n].tolist() == [arm] * n and model.damping[k:k + n].tolist() == [damp] * n
    assert {q.name for q in model.quirks if q.kind == "joint_dynamics"} == {"abdomen_z", "abdomen_y", "abdomen_x",
                                                                             "left_knee"}     # their stiffness


def test_tau_m_qdd_against_mujoco():
    model = _model()
    m = mujoco.MjModel.from_xml_path(str(PATH))
    assert np.array_equal(m.dof_armature, model.armature)        # the reader's order is MuJoCo's, dof by dof
    e = mujoco_errors(model, m, n=N, seed=3)                      # τ and M
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT) | int(mujoco.mjtDisableBit.mjDSBL_CONTACT) \
        | int(mujoco.mjtDisableBit.mjDSBL_DAMPER) | int(mujoco.mjtDisableBit.mjDSBL_SPRING)
    d, worst = mujoco.MjData(m), 0.0
    for q, v, _, tau in _states(model, 4):
        d.qpos[:] = mujoco_qpos(model, m, q)
        mujoco.mj_kinematics(m, d)
        R = d.xmat[m.jnt_bodyid[0]].reshape(3, 3)                 # the root's orientation
        qvel, f = v.copy(), tau.copy()
        qvel[:3], f[:3] = R @ v[:3], R @ tau[:3]                   # v_lin (world); the force's power unchanged
        d.qvel[:], d.qfrc_applied[:] = qvel, f
        mujoco.mj_forward(m, d)
        qdd = d.qacc.copy()
        qdd[:3] = R.T @ d.qacc[:3] - np.cross(v[3:6], v[:3])      # the origin's p̈ -> our spatial acceleration
        M = mujoco_full_m(m, d)
        worst = max(worst, err(md.aba(model, q, v, tau), qdd) / np.linalg.cond(M))
    print(f"\nhumanoid_ball: MuJoCo τ, M {e:.1e}; q̈ {worst:.1e} · cond(M)")
    assert e <= TAU_M and worst <= QDD


def test_tau_m_qdd_against_pinocchio():
    pin = pytest.importorskip("pinocchio")
    model = _model()
    pm = pin.buildModelFromMJCF(str(PATH))
    pd = pm.createData()
    assert (pm.nq, pm.nv) == (model.nq, model.nv) and np.array_equal(pm.armature, model.armature)
    assert [pm.joints[i].shortname() for i in (4, 6, 8, 10)] == ["JointModelSpherical"] * 4
    worst, worst_qdd = 0.0, 0.0
    for q, v, a, tau in _states(model, 5):
        M = pin.crba(pm, pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        worst = max(worst, err(md.rnea(model, q, v, a), pin.rnea(pm, pd, q, v, a)),
                    err(md.mass_matrix(model, q), M))
        worst_qdd = max(worst_qdd, err(md.aba(model, q, v, tau), pin.aba(pm, pd, q, v, tau)) / np.linalg.cond(M))
    print(f"\nhumanoid_ball: Pinocchio τ, M {worst:.1e}; q̈ {worst_qdd:.1e} · cond(M)")
    assert worst <= TAU_M and worst_qdd <= QDD


def test_export_round_trip_against_mujoco():
    # to_mjcf writes the abdomen's two joints back into one body: MuJoCo loads it, and M, τ are ours
    from manipdyn.io.mjcf import to_mjcf
    model = _model()
    text = to_mjcf(model)
    m = mujoco.MjModel.from_xml_string(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = md.load_mjcf_string(text)
    assert back.body_names == model.body_names and m.nbody == 12      # world + 11 moving bodies, as the file's
    e = max(mujoco_errors(back, m, n=5), mujoco_errors(model, m, n=5))
    print(f"\nhumanoid_ball: export -> MuJoCo τ, M {e:.1e}")
    assert e <= TAU_M
