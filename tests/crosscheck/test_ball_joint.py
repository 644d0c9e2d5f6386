"""Ball joints (joints.BALL) in every dynamics algorithm, against Pinocchio 4.1.

Random MJCF trees (``random_ball_mjcf``, seeded): 4-8 bodies, one tree with branches, a ball joint at the root
(alone, or with a slide or hinge in the same body), ball joints mid-chain and several joints in one body (slide +
ball, ball + hinge, hinge + ball), full inertias with offset CoMs, random body and site poses and joint anchors,
armature on some joints (MuJoCo's one value per joint: a ball's three dofs share it). Ours: load_mjcf_string of
the text. Pinocchio's: buildModelFromMJCF of the same tree written with one joint per body (``split``: the
joints of a body become nested bodies at the body's pose, the first ones massless, named as our reader names
them, "body:joint"), so every ball is a JointModelSpherical and every body is one of ours. (Pinocchio reads
several joints in one body as a JointModelComposite: its rnea, crba and aba agree with ours, but its
computeCoriolisMatrix, computeRNEADerivatives and getFrameJacobianTimeVariation differ from ours by O(1), while
our RNEA derivatives equal central differences of rnea to 1e-9 and our C q̇ + g equals nonlinear_effects.)
pm.armature is set from ours.

Compared: the configuration helpers (neutral, integrate, difference, normalize, random_configuration) against
pin.neutral / integrate / difference; rnea (with f_ext on a ball-jointed body and on a site of one), every
per-link term of rnea_terms (validation.Reference.terms), nonlinear_effects, gravity_torques, mass_matrix (CRBA
and method="lagrange"), aba, forward_dynamics (aba and cholesky), coriolis_matrix and christoffel_coriolis
against computeCoriolisMatrix (and Ṁ − 2C skew), rnea_derivatives / aba_derivatives against
computeRNEADerivatives / computeABADerivatives, joint_torque_regressor against computeJointTorqueRegressor
(and Y π = τ − armature ⊙ q̈), frame placements, Jacobians and their time variation (both references) of every
body and site, kinetic and potential energy. Batches equal one-state calls; threads=2 equals threads=1.

Measured (this VM, seeds 0-7, 4 states each), conftest's err: ≤ 4.3e-16 (configuration), ≤ 1.8e-14 (τ, per-link
terms, M, q̈, C, J, J̇, Y, energies), ≤ 3.6e-14 (derivatives of q̈); batches and threads equal single calls exactly.
Tolerances (TOL) beside the worst value each.
"""
from __future__ import annotations

import functools
import tempfile
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import err

import manipdyn as md
from manipdyn.dynamics.lagrange import christoffel_coriolis, mass_matrix_derivatives
from manipdyn.joints import BALL
from manipdyn.validation.reference import Reference

# err tolerances: measured worst over seeds 0-7 (4 states each) beside each, within 100x
TOL = dict(integrate=2e-14, difference=2e-14, normalize=2e-14,                  # 2.2e-16, 4.3e-16, 1.1e-16
           tau=4e-13, tau_ext=4e-13, terms=4e-13, terms_ext=4e-13, nle=4e-13, g=4e-13,  # 4.8, 4.5, 7.4, 7.3, 4.6, 6.2e-15
           M=2e-13, M_lagrange=2e-13, aba=5e-13, fd_aba=5e-13, fd_cholesky=5e-13,    # 3.0, 2.0, 6.6, 6.6, 7.1e-15
           C=5e-13, christoffel=5e-13, skew=3e-13,                              # 9.6e-15, 9.5e-15, 3.6e-15
           dtau_dq=1e-12, dtau_dv=1e-12, dqdd_dq=2e-12, dqdd_dv=2e-12, Minv=2e-12,  # 1.0, 1.0, 3.6, 2.2, 3.3e-14
           Y=4e-13, Y_pi=4e-13,                                                 # 5.6e-15, 4.6e-15
           R=5e-13, p=2e-13, J=1e-12, dJ=1e-12, T=4e-13, V=1e-12)               # 5.8, 2.5, 11, 12, 4.5, 18e-15
SEEDS = range(8)
N = 4                   # states per tree
# the joints of one body: a ball alone, with a slide or a hinge before or after it, a hinge or slide alone (two balls
# in one body are left out: the first then turns a subtree whose articulated inertia about it is singular)
COMBOS = (("ball",), ("hinge",), ("slide", "ball"), ("ball", "hinge"), ("hinge", "ball"), ("slide",))
ROOTS = (("ball",), ("slide", "ball"), ("ball", "hinge"))


def _n(rng, k, s=1.0):
    return " ".join(repr(float(x)) for x in rng.normal(size=k) * s)


def random_ball_mjcf(seed):
    """(text, split): a random MJCF tree with ball joints, and the same tree with one joint per body (the joints
    of body b after the first become nested bodies "b:j" at the identity pose: MuJoCo turns a body by its joints
    one after the other, each about its anchor in the frame the previous ones left)."""
    rng = np.random.default_rng(seed)
    head = f'<mujoco model="ball{seed}"><compiler angle="radian"/><worldbody>'
    text, split, close = [head], [head], []
    for k in range(int(rng.integers(4, 9))):
        for _ in range(int(rng.integers(0, len(close))) if k else 0):     # branches; the root stays open: one tree
            t, s = close.pop()
            text.append(t)
            split.append(s)
        pose = f'pos="{_n(rng, 3, 0.3)}" quat="{_n(rng, 4)}"'
        kinds = ROOTS[int(rng.integers(0, len(ROOTS)))] if k == 0 else COMBOS[int(rng.integers(0, len(COMBOS)))]
        joints = []
        for j, kind in enumerate(kinds):
            arm = f' armature="{rng.uniform(0.0, 0.2)!r}"' if rng.random() < 0.5 else ""
            axis = f' axis="{_n(rng, 3)}"' if kind != "ball" else ""
            joints.append(f'<joint name="j{k}_{j}" type="{kind}" pos="{_n(rng, 3, 0.1)}"{axis}{arm}/>')
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        I = R @ np.diag(rng.uniform(0.05, 0.1, 3)) @ R.T                        # principal moments: a triangle
        body = [f'<inertial pos="{_n(rng, 3, 0.1)}" mass="{rng.uniform(0.5, 3.0)!r}" fullinertia="'
                + " ".join(repr(float(x)) for x in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])) + '"/>',
                f'<site name="s{k}" pos="{_n(rng, 3, 0.1)}" quat="{_n(rng, 4)}"/>']
        text += [f'<body name="b{k}" {pose}>'] + joints + body
        names = [f"b{k}:j{k}_{j}" for j in range(len(kinds) - 1)] + [f"b{k}"]
        for j, (name, joint) in enumerate(zip(names, joints)):
            split += [f'<body name="{name}" {pose if j == 0 else ""}>', joint]
        split += body
        close.append(("</body>", "</body>" * len(kinds)))
    text += [t for t, _ in close[::-1]] + ["</worldbody></mujoco>"]
    split += [s for _, s in close[::-1]] + ["</worldbody></mujoco>"]
    return "\n".join(text), "\n".join(split)


class MJCFReference(Reference):
    """validation.Reference (per-link terms, q conversion) on Pinocchio's model of an MJCF file; f_ext on any
    frame (sites are Pinocchio OP_FRAMEs, not BODY frames)."""

    def __init__(self, model, pm):
        self.model, self.pm, self.pd = model, pm, pm.createData()
        self.idx_q = np.array([pm.joints[i + 1].idx_q for i in range(model.njoints)], int)
        self.nq_j = np.array([pm.joints[i + 1].nq for i in range(model.njoints)], int)

    def fext(self, q, f_ext, f_ext_frame="local"):
        assert f_ext_frame == "local"
        out = [pin.Force.Zero() for _ in range(self.pm.njoints)]
        for name, (f, m) in f_ext.items():
            fr = self.pm.frames[self.pm.getFrameId(name)]
            out[fr.parentJoint] += fr.placement.act(pin.Force(np.asarray(f, float), np.asarray(m, float)))
        return out


@functools.lru_cache(maxsize=None)
def case(seed):
    """(our model, MJCFReference, states Q (N, nq), V, A, Tau (N, nv))."""
    text, split = random_ball_mjcf(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # quirks of the reader (armature noted)
        model = md.load_mjcf_string(text)
    with tempfile.NamedTemporaryFile("w", suffix=".xml") as f:
        f.write(split)
        f.flush()
        pm = pin.buildModelFromMJCF(f.name)
    pm.armature = np.asarray(model.armature, float)
    pm.gravity.linear = np.asarray(model.gravity, float)
    rng = np.random.default_rng(seed)
    Q = md.random_configuration(model, rng, N)
    V, A, Tau = (rng.normal(size=(N, model.nv)) for _ in range(3))
    return model, MJCFReference(model, pm), Q, V, A, Tau


def sym(M):
    """Pinocchio's upper triangle mirrored (crba, computeMinverse fill it alone)."""
    M = np.array(M)
    return np.triu(M) + np.triu(M, 1).T


def hemisphere(model, q, like):
    """q (nq,) or (N, nq) with each quaternion's sign turned to that of the same block in ``like`` (q and −q are one
    rotation: Pinocchio's SO(3) integrate keeps the sign quat ⊗ exp(ω) falls on, its SE(3) one and ours the sign
    nearest the start)."""
    q, like = np.array(q, float), np.asarray(like, float)
    blocks = model.quat_q[:, None] + np.arange(4)
    flip = np.sum(q[..., blocks] * like[..., blocks], axis=-1, keepdims=True) < 0
    q[..., blocks] = np.where(flip, -q[..., blocks], q[..., blocks])
    return q


def ball_bodies(model):
    return [model.body_names[i] for i in range(model.njoints) if model.kind[i] == BALL]


def test_the_trees_draw_every_case():
    """Ball joints at the root, mid-chain, with another joint in the same body (before and after it), in
    branches, with armature; every tree one connected tree of 4-8 MJCF bodies."""
    seen = dict(root=0, mid=0, before=0, after=0, branch=0, armature=0)
    for seed in SEEDS:
        model, _, _, _, _, _ = case(seed)
        balls = np.flatnonzero(model.kind == BALL)
        seen["root"] += model.kind[0] == BALL or model.kind[1] == BALL and model.parent[1] == 0
        seen["mid"] += any(model.parent[i] >= 1 and i in model.parent for i in balls)
        seen["before"] += any(":" in model.body_names[i] for i in balls)
        seen["after"] += any(":" in model.body_names[model.parent[i]] for i in balls if model.parent[i] >= 0)
        seen["branch"] += len(set(model.parent.tolist())) < model.njoints
        seen["armature"] += any(model.armature[model.idx_v[i]] > 0 for i in balls)
        assert model.parent[0] == -1 and np.all(model.parent[1:] >= 0)
    assert all(n >= 2 for n in seen.values()), seen


@pytest.mark.parametrize("seed", SEEDS)
def test_pinocchio_reads_the_same_joints(seed):
    model, ref, _, _, _, _ = case(seed)
    pm = ref.pm
    assert tuple(pm.names[1:]) == model.joint_names and (pm.nq, pm.nv) == (model.nq, model.nv)
    kinds = {md.REVOLUTE: "JointModelRevoluteUnaligned", md.PRISMATIC: "JointModelPrismaticUnaligned",
             BALL: "JointModelSpherical"}
    assert [pm.joints[i + 1].shortname() for i in range(model.njoints)] == [kinds[k] for k in model.kind]
    assert ref.idx_q.tolist() == model.idx_q.tolist() and ref.nq_j.tolist() == model.nqs.tolist()
    assert [pm.joints[i + 1].idx_v for i in range(model.njoints)] == model.idx_v.tolist()
    assert [pm.parents[i + 1] - 1 for i in range(model.njoints)] == model.parent.tolist()
    assert np.array_equal(model.armature[model.idx_v[model.kind == BALL] + 2],
                          model.armature[model.idx_v[model.kind == BALL]])          # one armature per ball
    for i in range(model.njoints):          # the split text's bodies are ours (the reader is held to MuJoCo elsewhere)
        Y, X = pm.inertias[i + 1], pm.jointPlacements[i + 1]
        assert err(model.mass[i], Y.mass) <= 1e-14 and err(model.com[i], Y.lever) <= 1e-14
        assert err(model.inertia[i], Y.inertia) <= 1e-14 and err(model.R0[i], X.rotation) <= 1e-14
        assert err(model.p0[i], X.translation) <= 1e-14


@pytest.mark.parametrize("seed", SEEDS)
def test_configuration_helpers_against_pinocchio(seed):
    model, ref, Q, V, _, _ = case(seed)
    pm = ref.pm
    assert np.array_equal(md.neutral(model), pin.neutral(pm))
    blocks = model.quat_q[:, None] + np.arange(4)
    quats = Q[:, blocks]
    assert np.abs(np.linalg.norm(quats, axis=-1) - 1.0).max() <= 1e-15              # measured ≤ 2.2e-16
    worst = dict(integrate=0.0, difference=0.0, normalize=0.0)
    cont = model.idx_v[model.continuous]      # MJCF hinges without a range
    for s in range(N):
        q0, q1, v = Q[s], Q[(s + 1) % N], V[s]
        for scale in (1e-9, 1e-3, 1.0, 4.0):
            q = md.integrate(model, q0, scale * v)
            worst["integrate"] = max(worst["integrate"], err(q, hemisphere(model, pin.integrate(pm, q0, scale * v), q)))
            assert np.all(np.sum((q * q0)[blocks].reshape(-1, 4), axis=1) >= 0)         # the sign nearest q0
        d = pin.difference(pm, q0, q1)        # a continuous joint's: the shortest angle (Pinocchio: q1 − q0 here)
        d[cont] = np.arctan2(np.sin(d[cont]), np.cos(d[cont]))
        worst["difference"] = max(worst["difference"], err(md.difference(model, q0, q1), d))
        scaled = q0.copy()
        scaled[blocks] *= 1.7
        worst["normalize"] = max(worst["normalize"], err(md.normalize(model, scaled), pin.normalize(pm, scaled)))
    batch = md.integrate(model, Q, V)
    assert err(batch, hemisphere(model, [pin.integrate(pm, q, v) for q, v in zip(Q, V)], batch)) <= TOL["integrate"]
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


def _wrenches(model, rng):
    """f_ext on the MJCF body the last ball joint moves and on the site of the first one's (offset and turned)."""
    balls = [b.partition(":")[0] for b in ball_bodies(model)]
    return {balls[-1]: (rng.normal(size=3), rng.normal(size=3)),
            "s" + balls[0][1:]: (rng.normal(size=3), rng.normal(size=3))}


@pytest.mark.parametrize("seed", SEEDS)
def test_inverse_dynamics_and_every_link_term(seed):
    model, ref, Q, V, A, _ = case(seed)
    pm, pd = ref.pm, ref.pd
    fx = _wrenches(model, np.random.default_rng(seed + 100))
    worst = dict(tau=0.0, tau_ext=0.0, terms=0.0, terms_ext=0.0, nle=0.0, g=0.0)
    for q, v, a in zip(Q, V, A):
        for ext, kt, kx in ((None, "tau", "terms"), (fx, "tau_ext", "terms_ext")):
            theirs = ref.terms(q, v, a, ext)
            tau, T = md.rnea(model, q, v, a, f_ext=ext), md.rnea_terms(model, q, v, a, f_ext=ext)
            T["nO"] = T["nc"] + np.cross(model.com, T["fc"])          # the inertial moment about the origin
            worst[kt] = max(worst[kt], err(tau, theirs["tau"]), err(T["tau"], theirs["tau"]))
            for k in ("w", "v", "f", "n", "fc", "nO", "dw", "acc"):
                worst[kx] = max(worst[kx], err(T[k], theirs[k]))
        worst["nle"] = max(worst["nle"], err(md.nonlinear_effects(model, q, v), pin.nonLinearEffects(pm, pd, q, v)))
        worst["g"] = max(worst["g"], err(md.gravity_torques(model, q), pin.computeGeneralizedGravity(pm, pd, q)))
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


@pytest.mark.parametrize("seed", SEEDS)
def test_mass_matrix_and_forward_dynamics(seed):
    model, ref, Q, V, _, Tau = case(seed)
    pm, pd = ref.pm, ref.pd
    worst = dict(M=0.0, M_lagrange=0.0, aba=0.0, fd_aba=0.0, fd_cholesky=0.0)
    for q, v, t in zip(Q, V, Tau):
        M, qdd = sym(pin.crba(pm, pd, q)), pin.aba(pm, pd, q, v, t).copy()
        worst["M"] = max(worst["M"], err(md.mass_matrix(model, q), M))
        worst["M_lagrange"] = max(worst["M_lagrange"], err(md.mass_matrix(model, q, method="lagrange"), M))
        worst["aba"] = max(worst["aba"], err(md.aba(model, q, v, t), qdd))
        worst["fd_aba"] = max(worst["fd_aba"], err(md.forward_dynamics(model, q, v, t), qdd))
        worst["fd_cholesky"] = max(worst["fd_cholesky"], err(md.forward_dynamics(model, q, v, t, method="cholesky"),
                                                             qdd))
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


@pytest.mark.parametrize("seed", SEEDS)
def test_coriolis_matrix_both_routes(seed):
    model, ref, Q, V, _, _ = case(seed)
    pm, pd = ref.pm, ref.pd
    C, Cc = md.coriolis_matrix(model, Q, V), christoffel_coriolis(model, Q, V)
    worst = dict(C=0.0, christoffel=0.0)
    for s, (q, v) in enumerate(zip(Q, V)):
        theirs = pin.computeCoriolisMatrix(pm, pd, q, v)
        worst["C"] = max(worst["C"], err(C[s], theirs))
        worst["christoffel"] = max(worst["christoffel"], err(Cc[s], theirs))
    dM = mass_matrix_derivatives(model, Q)
    S = np.einsum("nkij,nk->nij", dM, V) - 2 * C
    worst["skew"] = err(S, -np.swapaxes(S, 1, 2))
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


@pytest.mark.parametrize("seed", SEEDS)
def test_derivatives_against_pinocchio(seed):
    model, ref, Q, V, A, Tau = case(seed)
    pm, pd = ref.pm, ref.pd
    worst = dict(dtau_dq=0.0, dtau_dv=0.0, M=0.0, dqdd_dq=0.0, dqdd_dv=0.0, Minv=0.0)
    for q, v, a, t in zip(Q, V, A, Tau):
        ours = md.rnea_derivatives(model, q, v, a)
        theirs = [np.array(x) for x in pin.computeRNEADerivatives(pm, pd, q, v, a)]
        for k, x, y in zip(("dtau_dq", "dtau_dv", "M"), ours, (theirs[0], theirs[1], sym(theirs[2]))):
            worst[k] = max(worst[k], err(x, y))
        ours = md.aba_derivatives(model, q, v, t)
        theirs = [np.array(x) for x in pin.computeABADerivatives(pm, pd, q, v, t)]
        for k, x, y in zip(("dqdd_dq", "dqdd_dv", "Minv"), ours, (theirs[0], theirs[1], sym(theirs[2]))):
            worst[k] = max(worst[k], err(x, y))
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


@pytest.mark.parametrize("seed", SEEDS)
def test_regressor_against_pinocchio(seed):
    model, ref, Q, V, A, _ = case(seed)
    pi = md.dynamic_parameters(model)
    worst = dict(Y=0.0, Y_pi=0.0)
    for q, v, a in zip(Q, V, A):
        Y = md.joint_torque_regressor(model, q, v, a)
        worst["Y"] = max(worst["Y"], err(Y, ref.regressor(q, v, a)))
        worst["Y_pi"] = max(worst["Y_pi"], err(Y @ pi, pin.rnea(ref.pm, ref.pd, q, v, a) - model.armature * a))
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


@pytest.mark.parametrize("seed", SEEDS)
def test_frames_and_energies_against_pinocchio(seed):
    model, ref, Q, V, _, _ = case(seed)
    pm, pd = ref.pm, ref.pd
    frames = [f for f in model.frames if model.frames[f].body >= 0]
    assert len(frames) == 2 * model.njoints - sum(":" in b for b in model.body_names)   # bodies ("b:j" too), sites
    armature, worst = pm.armature.copy(), dict(R=0.0, p=0.0, J=0.0, dJ=0.0, T=0.0, V=0.0)
    for q, v in zip(Q, V):
        pin.computeJointJacobians(pm, pd, q)
        pin.computeJointJacobiansTimeVariation(pm, pd, q, v)
        pin.updateFramePlacements(pm, pd)
        for f in frames:     # a body "b:j" of ours sits at its joint's anchor: Pinocchio's frame of joint j
            fid = pm.getFrameId(f.partition(":")[2] or f)
            R, p = md.frame_placement(model, q, f)
            worst["R"] = max(worst["R"], err(R, pd.oMf[fid].rotation))
            worst["p"] = max(worst["p"], err(p, pd.oMf[fid].translation))
            for name, pref in (("local_world_aligned", pin.LOCAL_WORLD_ALIGNED), ("local", pin.LOCAL)):
                worst["J"] = max(worst["J"], err(md.frame_jacobian(model, q, f, name),
                                                 pin.getFrameJacobian(pm, pd, fid, pref)))
                worst["dJ"] = max(worst["dJ"], err(md.frame_jacobian_dot(model, q, v, f, name),
                                                   pin.getFrameJacobianTimeVariation(pm, pd, fid, pref)))
        # ours is the links' T alone; Pinocchio 4.1 adds ½ armature v² of its spherical and prismatic joints (not
        # of its revolute-unaligned ones): its T is taken without armature
        pm.armature[:] = 0.0
        T = pin.computeKineticEnergy(pm, pd, q, v)
        pm.armature[:] = armature
        worst["T"] = max(worst["T"], err(md.kinetic_energy(model, q, v), T))
        worst["V"] = max(worst["V"], err(md.potential_energy(model, q), pin.computePotentialEnergy(pm, pd, q)))
    print(f"\nseed {seed}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k] for k, e in worst.items()), worst


def test_batches_equal_single_states_and_threads():
    """A batch (the lane kernels hand multi-dof joints to the scalar form) equals its states one by one, to
    1e-14; threads=2 (N = 300: two chunks) equals threads=1 exactly."""
    model, _, Q, V, A, Tau = case(2)
    rng = np.random.default_rng(11)
    n = 300
    Qb = md.random_configuration(model, rng, n)
    Vb, Ab, Tb = (rng.normal(size=(n, model.nv)) for _ in range(3))
    calls = {"rnea": (md.rnea, (Qb, Vb, Ab)), "nonlinear_effects": (md.nonlinear_effects, (Qb, Vb)),
             "gravity_torques": (md.gravity_torques, (Qb,)), "mass_matrix": (md.mass_matrix, (Qb,)),
             "aba": (md.aba, (Qb, Vb, Tb)), "forward_dynamics": (md.forward_dynamics, (Qb, Vb, Tb)),
             "coriolis_matrix": (md.coriolis_matrix, (Qb, Vb)),
             "regressor": (md.joint_torque_regressor, (Qb, Vb, Ab)),
             "rnea_derivatives": (lambda m, *x, **kw: np.stack(md.rnea_derivatives(m, *x, **kw), -3), (Qb, Vb, Ab)),
             "aba_derivatives": (lambda m, *x, **kw: np.stack(md.aba_derivatives(m, *x, **kw), -3), (Qb, Vb, Tb))}
    worst = {}
    for name, (fn, x) in calls.items():
        one = fn(model, *x, threads=1)
        assert np.array_equal(fn(model, *x, threads=2), one), name
        single = np.array([fn(model, *(y[s] for y in x)) for s in range(0, n, 37)])
        worst[name] = err(one[::37], single)
    single = {"kinetic_energy": [md.kinetic_energy(model, q, v) for q, v in zip(Q, V)],
              "potential_energy": [md.potential_energy(model, q) for q in Q],
              "lagrange": [md.mass_matrix(model, q, method="lagrange") for q in Q]}
    worst["kinetic_energy"] = err(md.kinetic_energy(model, Q, V), single["kinetic_energy"])
    worst["potential_energy"] = err(md.potential_energy(model, Q), single["potential_energy"])
    worst["lagrange"] = err(md.mass_matrix(model, Q, method="lagrange"), single["lagrange"])
    for f in ("b3", "s3"):
        R, p = md.frame_placement(model, Q, f)
        worst["frame"] = max(worst.get("frame", 0.0), err(R, [md.frame_placement(model, q, f)[0] for q in Q]),
                             err(p, [md.frame_placement(model, q, f)[1] for q in Q]),
                             err(md.frame_jacobian(model, Q, f), [md.frame_jacobian(model, q, f) for q in Q]),
                             err(md.frame_jacobian_dot(model, Q, V, f),
                                 [md.frame_jacobian_dot(model, q, v, f) for q, v in zip(Q, V)]))
    print("\n" + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= 1e-14 for e in worst.values()), worst         # measured 0 (the multi-dof joints' scalar form)
