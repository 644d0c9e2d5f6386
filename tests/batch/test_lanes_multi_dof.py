"""The lane kernels on free flyers and ball joints (lanes.on_lanes with multi: rnea.motion_lane_multi, core.
quat_placement_lane, crba's columns of a multi-dof joint, aba.articulated_multi): floating-base robots and
ball-jointed trees run at lane speed, not through the one-state kernels, and give Pinocchio's numbers.

Against Pinocchio 4.1 (docs/design.md §3 measure; q̈ scaled by cond(M)): ur5 on a free flyer (buildModelFromUrdf
with JointModelFreeFlyer), random MJCF trees with ball joints at the root and mid-chain (buildModelFromMJCF), armature
on the free flyer and on the balls, blocks of LANES states with a partial last block. Against the one-state kernels
(the scalar form the lanes replace) to 1e-14. A block with a non-finite entry or a singular articulated inertia runs
the one-state form and names its row. Measured worst beside each tolerance."""
import dataclasses
import tempfile
import warnings

import numpy as np
import pinocchio as pin
import pytest
from ball_models import random_tree
from conftest import assert_close, err

import manipdyn as md
from manipdyn.dynamics.lanes import LANES, on_lanes
from manipdyn.dynamics.model_arrays import unpack
from manipdyn.errors import InputError, SingularError
from manipdyn.joints import BALL, FREEFLYER
from manipdyn.validation import random_states
from manipdyn.validation.reference import Reference
from manipdyn.validation.zoo import robots_dir

UR5 = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
SIZES = (1, LANES - 1, 2 * LANES + 5)


def _ball_tree(seed, kinds):
    """(our model, Pinocchio's model) of a random MJCF tree of ball and hinge joints, armature on every joint."""
    text = random_tree(seed, kinds, one_root=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_mjcf_string(text)
    model = md.with_joint_dynamics(model, {j: {"armature": 0.01 * (k + 1)} for k, j in enumerate(model.joint_names)})
    with tempfile.NamedTemporaryFile("w", suffix=".xml") as f:
        f.write(text)
        f.flush()
        pm = pin.buildModelFromMJCF(f.name)
    assert tuple(pm.names[1:]) == model.joint_names
    pm.armature = np.asarray(model.armature, float)
    pm.gravity.linear = np.asarray(model.gravity, float)
    return model, pm, lambda q: q                       # a ball's q is Pinocchio's (qx qy qz qw), a hinge's one angle


def _ur5_floating():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(UR5, root_joint="free_flyer")
    model = md.with_joint_dynamics(model, {"root_joint": {"armature": [0.1, 0.2, 0.3, 0.01, 0.02, 0.03]}})
    ref = Reference(model, UR5)
    return model, ref.pm, ref.to_pin_q


@pytest.fixture(scope="module")
def models():
    return {"ur5_floating": _ur5_floating(), "ball_root": _ball_tree(3, "BHBHBH"), "ball_mid": _ball_tree(5, "HBBHB")}


def test_the_models_take_the_lanes(models):
    """Each model has the joints this file is about, and the lane kernels take it (no scalar fallback)."""
    kinds = {name: set(m.kind.tolist()) for name, (m, _, _) in models.items()}
    assert FREEFLYER in kinds["ur5_floating"] and BALL in kinds["ball_root"] and BALL in kinds["ball_mid"]
    assert models["ball_mid"][0].kind[0] != BALL and BALL in models["ball_mid"][0].kind[1:]     # a ball mid-chain
    for model, _, _ in models.values():
        I, F = model.kernel.lane_arrays
        assert on_lanes(unpack(I, F), model.nq, True) and not on_lanes(unpack(I, F), model.nq)


def _states(model, N, seed):
    Q, V, A = random_states(model, N, np.random.default_rng(seed))
    return Q, V, A


@pytest.mark.parametrize("name", ["ur5_floating", "ball_root", "ball_mid"])
@pytest.mark.parametrize("N", SIZES)
def test_multi_dof_lanes_match_pinocchio_and_the_one_state_kernels(models, name, N):
    model, pm, to_pin = models[name]
    pd = pm.createData()
    Q, V, A = _states(model, N, N)
    PQ = [to_pin(q) for q in Q]
    tau = md.rnea(model, Q, V, A, threads=1)
    assert_close(tau, [pin.rnea(pm, pd, q, v, a) for q, v, a in zip(PQ, V, A)], 5e-14, "rnea")   # measured 6.8e-16
    assert_close(tau, [md.rnea(model, *x) for x in zip(Q, V, A)], 1e-14, "rnea one")              # 6.1e-16
    h, g = md.nonlinear_effects(model, Q, V, threads=1), md.gravity_torques(model, Q, threads=1)
    assert_close(h, [pin.nonLinearEffects(pm, pd, q, v) for q, v in zip(PQ, V)], 5e-14, "h")        # 9.2e-16
    assert_close(g, [pin.computeGeneralizedGravity(pm, pd, q) for q in PQ], 5e-14, "g")            # 5.8e-16
    M = md.mass_matrix(model, Q, threads=1)
    ref_M = []
    for q in PQ:
        X = np.array(pin.crba(pm, pd, q))
        ref_M.append(np.triu(X) + np.triu(X, 1).T)
    assert_close(M, ref_M, 5e-14, "M")                                                           # 7.4e-16
    assert_close(M, [md.mass_matrix(model, q) for q in Q], 1e-14, "M one")                         # 5.1e-16
    qdd = md.aba(model, Q, V, tau, threads=1)
    for s in range(N):
        c = np.linalg.cond(ref_M[s])
        ref = pin.aba(pm, pd, PQ[s], V[s], tau[s])
        assert err(qdd[s], ref) <= 1e-14 * c, (s, err(qdd[s], ref), c)                          # 2.3e-16 × cond
        assert err(qdd[s], md.aba(model, Q[s], V[s], tau[s])) <= 1e-14 * c                      # 1.8e-16 × cond
        assert err(qdd[s], A[s]) <= 1e-14 * c                                                    # aba ∘ rnea = 1: 2.5e-16 × cond


def test_lane_rnea_with_wrenches_on_a_floating_base():
    """External wrenches in body and world axes on the lanes (lanes.external_lanes turns a world wrench by the
    bodies' placements, the free flyer's quaternion placement first) against Pinocchio's rnea with fext."""
    model, _, _ = _ur5_floating()
    ref = Reference(model, UR5)
    Q, V, A = _states(model, 2 * LANES + 3, 11)
    rng = np.random.default_rng(12)
    fx = {"wrist_3_link": (rng.normal(size=(len(Q), 3)), rng.normal(size=(len(Q), 3))),
          "base_link": (rng.normal(size=(len(Q), 3)), rng.normal(size=(len(Q), 3)))}
    for frame in ("local", "world"):
        tau = md.rnea(model, Q, V, A, f_ext=fx, f_ext_frame=frame, threads=1)
        theirs = [pin.rnea(ref.pm, ref.pd, ref.to_pin_q(Q[s]), V[s], A[s],
                           ref.fext(Q[s], {k: (f[s], m[s]) for k, (f, m) in fx.items()}, frame))
                  for s in range(len(Q))]
        assert_close(tau, theirs, 3e-14, frame)                                                 # measured 3.1e-16


def test_a_non_finite_state_in_a_later_block_is_named(models):
    """A NaN in the second block's quaternion: the block runs the one-state form, whose error names the row and
    the entry (arguments.raise_kernel_error)."""
    model, _, _ = models["ur5_floating"]
    Q, V, A = _states(model, 2 * LANES, 3)
    Q[LANES + 5, 4] = np.nan
    for call, args in (("rnea", (Q, V, A)), ("aba", (Q, V, A)), ("mass_matrix", (Q,))):
        with pytest.raises(InputError, match=rf"q\[{LANES + 5}, 4\]"):
            getattr(md, call)(model, *args, threads=1)


def test_a_singular_ball_joint_is_named():
    """A massless body on a ball joint at the tip (its D = Sᵀ I^A S is 0): the lane ABA counts the pivot, the block
    runs the one-state form, whose error names the joint."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_mjcf_string(random_tree(4, "HB", one_root=True))
    model = dataclasses.replace(model, mass=np.r_[model.mass[:-1], 0.0], com=np.r_[model.com[:-1], np.zeros((1, 3))],
                                inertia=np.r_[model.inertia[:-1], np.zeros((1, 3, 3))])
    assert model.kind[-1] == BALL and model.mass[-1] == 0.0
    Q, V, T = _states(model, 2 * LANES, 5)
    with pytest.raises(SingularError, match=model.joint_names[-1]):
        md.aba(model, Q, V, T, threads=1)


def test_a_turned_and_offset_free_flyer_frame():
    """A free flyer whose joint frame is turned and offset in the base (R0 ≠ 1, p0 ≠ 0: the Model allows it; the
    loaders give 1 and 0): the lane placement R0 R(quat) (lanes.quat_placement_lane) equals the one-state kernels'
    (joints.joint_placement). (τ, M and q̈ do not depend on where the free body is, only on how it is turned.)"""
    model, _, _ = _ur5_floating()
    c, s = np.cos(0.7), np.sin(0.7)
    R0 = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    model = dataclasses.replace(model, R0=np.r_[R0[None], model.R0[1:]], p0=np.r_[[[0.3, -0.2, 0.5]], model.p0[1:]])
    Q, V, A = _states(model, LANES + 3, 8)
    tau = md.rnea(model, Q, V, A, threads=1)
    assert_close(tau, [md.rnea(model, *x) for x in zip(Q, V, A)], 1e-14, "rnea")               # measured 2.6e-16
    M = md.mass_matrix(model, Q, threads=1)
    assert_close(M, [md.mass_matrix(model, q) for q in Q], 1e-14, "M")                           # 1.3e-16
    qdd = md.aba(model, Q, V, tau, threads=1)
    for k in range(len(Q)):                                                           # 4.0e-17 × cond(M)
        assert err(qdd[k], md.aba(model, Q[k], V[k], tau[k])) <= 4e-15 * np.linalg.cond(M[k])
