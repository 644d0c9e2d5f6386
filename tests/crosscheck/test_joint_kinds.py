"""Every joint kind of the registry (joints.KINDS) through every algorithm, against Pinocchio 4.1's joint models.

Four seeded random trees (tests/joint_kinds.py): a planar root carrying screw (helical), universal, revolute,
planar, prismatic, spherical and screw joints, a URDF ``floating`` root carrying universal, screw, revolute,
planar and universal joints, and two without a planar joint, which run on the lane steps (a fixed-base chain of
screw, revolute, prismatic and universal joints; a floating root carrying screw, spherical, universal and prismatic
joints) — random placements, axes, pitches, masses, offset CoMs and full inertias. Ours: the
URDF text through load_urdf_string (Drake's ``<drake:joint>`` for screw and universal). Pinocchio's: the same
numbers through JointModelPlanar, JointModelHelicalUnaligned, JointModelUniversal, JointModelFreeFlyer,
JointModelSpherical and the unaligned revolute and prismatic joints (our universal joint is the two revolute joints
it is, 'j.1' and 'j.2', over the same q and v).

Compared, single states and batches: the configuration helpers (neutral, integrate, difference against pin's;
random_configuration's unit blocks), rnea, nonlinear_effects, gravity_torques, mass_matrix (CRBA and Lagrange), aba,
forward_dynamics, coriolis_matrix and christoffel_coriolis (C q̇ = nonLinearEffects − computeGeneralizedGravity, and
Ṁ − 2C skew-symmetric with Ṁ by central differences of pin.crba along q̇),
rnea_derivatives and aba_derivatives against fourth-order central differences of Pinocchio's rnea and aba (along
v, and along q's tangent through pin.integrate), the regressor (Y π = τ),
every link's placement and Jacobian (both references), kinetic and potential energy; a simulation keeps its energy;
a batch over more than one lane block equals single calls; the playback page is built.

Pinocchio 4.1's computeRNEADerivatives, computeABADerivatives and computeCoriolisMatrix are off by O(1) on a
JointModelUniversal (C q̇ ≠ nonLinearEffects − g by 0.2 on a two-joint chain; its rnea, crba and aba agree with ours
and with each other): hence differences of its rnea and aba as the reference, which ours meet to ~1e-11.

Measured (this VM, 4 trees x seeds 0-2, 4 states each), conftest's err: ≤ 3.6e-15 (configuration), ≤ 9.5e-16 (τ,
nle, g, Y π), ≤ 2.2e-15 (M, both routes), ≤ 6.5e-14 (q̈), ≤ 4.2e-15 (C q̇, C of both routes), ≤ 1.7e-15 (placements,
Jacobians), ≤ 1.2e-15 (energies), ≤ 1.2e-10 (derivatives against differences; Ṁ − 2C skew ≤ 2.8e-12); energy
drift of RK4 (dt 1 ms, 0.5 s) and of the adaptive DOP853 ≤ 7e-13 of the swing of T.
"""
from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import err
from joint_kinds import TREES, kinds_robot, pin_names

import manipdyn as md
from manipdyn.dynamics.lagrange import christoffel_coriolis
from manipdyn.dynamics.lanes import on_lanes
from manipdyn.dynamics.model_arrays import unpack
from manipdyn.spatial import SINCOS_MAX

CASES = [(name, seed) for name in TREES for seed in range(3)]
TOL = dict(config=1e-13, tau=1e-13, M=1e-13, qdd=1e-12, C=1e-13, d=1e-9, J=1e-13, E=1e-13)   # ≤ 100× the worst
H = 2.5e-4          # step of the fourth-order central differences (truncation ~H⁴, rounding ~1e-16 / H): on the
#                     screw chain, seed 1, ∂q̈/∂q's difference error is 3.9e-9 at H = 1e-3, 1.5e-11 at 2.5e-4


def diff4(f, x0, plus):
    """Fourth-order central differences of f at x0 along each unit direction e_k: columns (k) of ∂f/∂x, with the
    point moved by plus(x0, h e_k)."""
    n = len(plus(x0, None))
    cols = []
    for e in np.eye(n):
        f1, f2, m1, m2 = (f(plus(x0, c * H * e)) for c in (1, 2, -1, -2))
        cols.append((8 * (f1 - m1) - (f2 - m2)) / (12 * H))
    return np.column_stack(cols)


def sym(M):
    return np.triu(M) + np.triu(M, 1).T


def case(name, seed, n=4):
    text, pm = kinds_robot(name, seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf_string(text, source=f"{name}.urdf")
    assert model.joint_names == pin_names(pm) and (model.nq, model.nv) == (pm.nq, pm.nv)
    rng = np.random.default_rng(100 + seed)
    Q = md.random_configuration(model, rng, n)
    return model, pm, pm.createData(), Q, rng.normal(0, 2, (n, model.nv)), rng.normal(0, 5, (n, model.nv))


def check(worst):
    print(" ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= TOL[k.split(":")[0]] for k, e in worst.items()), worst


def test_the_trees_hold_every_kind_of_the_registry():
    kinds = set()
    for name in TREES:
        model = case(name, 0)[0]
        kinds |= {md.joints.KINDS[int(k)].name for k in model.kind}
        kinds |= {"universal"} if any(j.endswith(".2") for j in model.joint_names) else set()
    assert kinds == {k.name for k in md.joints.KINDS}


@pytest.mark.parametrize("name,seed", CASES)
def test_configuration_helpers_against_pinocchio(name, seed):
    model, pm, _, Q, V, _ = case(name, seed)
    worst = {"config:neutral": err(md.neutral(model), pin.neutral(pm))}
    Q1 = md.random_configuration(model, seed + 7, len(Q))
    for k, m in model.unit_q:                               # quaternions and planar (cos, sin): unit
        assert np.allclose(np.linalg.norm(Q[:, k:k + m], axis=1), 1.0, rtol=0, atol=1e-15)
    for s in range(len(Q)):
        worst["config:integrate"] = max(worst.get("config:integrate", 0),    # (a quaternion of either sign)
                                        err(md.difference(model, pin.integrate(pm, Q[s], V[s]),
                                                          md.integrate(model, Q[s], V[s])), 0 * V[s]))
        worst["config:difference"] = max(worst.get("config:difference", 0),
                                         err(md.difference(model, Q[s], Q1[s]), pin.difference(pm, Q[s], Q1[s])))
    back = md.integrate(model, Q, md.difference(model, Q, Q1))      # Q1 again (a quaternion maybe of either sign)
    assert np.abs(md.difference(model, Q1, back)).max() < 1e-12
    check(worst)


@pytest.mark.parametrize("name,seed", CASES)
def test_dynamics_against_pinocchio(name, seed):
    model, pm, pd, Q, V, A = case(name, seed)
    worst = dict.fromkeys(("tau", "tau:nle", "tau:g", "M", "M:lagrange", "qdd", "qdd:cholesky", "C:v",
                           "C:christoffel", "d:Mdot-2C skew"), 0.0)
    tau, M, C = md.rnea(model, Q, V, A), md.mass_matrix(model, Q), md.coriolis_matrix(model, Q, V)
    Cc, ML = christoffel_coriolis(model, Q, V), md.mass_matrix(model, Q, method="lagrange")
    for s, (q, v, a) in enumerate(zip(Q, V, A)):
        t = pin.rnea(pm, pd, q, v, a)
        worst["tau"] = max(worst["tau"], err(tau[s], t), err(md.rnea(model, q, v, a), t))
        worst["tau:nle"] = max(worst["tau:nle"], err(md.nonlinear_effects(model, q, v), pin.nonLinearEffects(pm, pd, q, v)))
        worst["tau:g"] = max(worst["tau:g"], err(md.gravity_torques(model, q), pin.computeGeneralizedGravity(pm, pd, q)))
        Mp = sym(pin.crba(pm, pd, q))
        worst["M"] = max(worst["M"], err(M[s], Mp), err(md.mass_matrix(model, q), Mp))
        worst["M:lagrange"] = max(worst["M:lagrange"], err(ML[s], Mp))
        worst["qdd"] = max(worst["qdd"], err(md.aba(model, q, v, t), pin.aba(pm, pd, q, v, t)))
        worst["qdd:cholesky"] = max(worst["qdd:cholesky"], err(md.forward_dynamics(model, q, v, t, method="cholesky"), a))
        cv = pin.nonLinearEffects(pm, pd, q, v) - pin.computeGeneralizedGravity(pm, pd, q)
        worst["C:v"] = max(worst["C:v"], err(C[s] @ v, cv), err(Cc[s] @ v, cv))
        worst["C:christoffel"] = max(worst["C:christoffel"], err(Cc[s], C[s]))
        u = np.linalg.norm(v)                                   # Ṁ = dM(q ⊕ t q̇)/dt at t = 0, a unit step along q̇
        Md = u * diff4(lambda x: sym(pin.crba(pm, pd, pin.integrate(pm, q, x[0] * v / u))).ravel(), np.zeros(1),
                       lambda x, d: x if d is None else x + d).reshape(M[s].shape)
        K = Md - 2 * C[s]
        worst["d:Mdot-2C skew"] = max(worst["d:Mdot-2C skew"], err(K, -K.T))      # (Ṁ by differences)
    check(worst)


@pytest.mark.parametrize("name,seed", CASES)
def test_derivatives_and_regressor_against_pinocchio(name, seed):
    model, pm, pd, Q, V, A = case(name, seed)
    pi = md.dynamic_parameters(model)
    worst = dict.fromkeys(("d:dtau_dq", "d:dtau_dv", "d:dqdd_dq", "d:dqdd_dv", "d:Minv", "tau:Y_pi"), 0.0)
    on_q = lambda x, d: np.zeros(model.nv) if d is None else pin.integrate(pm, x, d)     # noqa: E731
    on_v = lambda x, d: x if d is None else x + d                                           # noqa: E731
    for q, v, a in zip(Q, V, A):
        t = pin.rnea(pm, pd, q, v, a)
        ours = md.rnea_derivatives(model, q, v, a)
        worst["d:dtau_dq"] = max(worst["d:dtau_dq"], err(ours[0], diff4(lambda x: pin.rnea(pm, pd, x, v, a), q, on_q)))
        worst["d:dtau_dv"] = max(worst["d:dtau_dv"], err(ours[1], diff4(lambda x: pin.rnea(pm, pd, q, x, a), v, on_v)))
        ours = md.aba_derivatives(model, q, v, t)
        worst["d:dqdd_dq"] = max(worst["d:dqdd_dq"], err(ours[0], diff4(lambda x: pin.aba(pm, pd, x, v, t), q, on_q)))
        worst["d:dqdd_dv"] = max(worst["d:dqdd_dv"], err(ours[1], diff4(lambda x: pin.aba(pm, pd, q, x, t), v, on_v)))
        worst["d:Minv"] = max(worst["d:Minv"], err(ours[2], np.linalg.inv(sym(pin.crba(pm, pd, q)))))
        worst["tau:Y_pi"] = max(worst["tau:Y_pi"], err(md.joint_torque_regressor(model, q, v, a) @ pi, t))
    check(worst)


@pytest.mark.parametrize("name,seed", CASES)
def test_frames_and_energies_against_pinocchio(name, seed):
    """Every link's frame (the body of each Pinocchio joint: a universal joint's child is our 'j.2''s body), one
    state at a time and as a batch (the lane kernel where the model is on the lanes)."""
    model, pm, pd, Q, V, _ = case(name, seed)
    worst = dict.fromkeys(("J:R", "J:p", "J", "J:batch", "E:T", "E:V"), 0.0)
    for jid in range(1, pm.njoints):
        link = f"l{jid - 1}"
        R, p = md.frame_placement(model, Q, link)
        J = {ref: md.frame_jacobian(model, Q, link, ref) for ref in ("local_world_aligned", "local")}
        for s, q in enumerate(Q):
            pin.computeJointJacobians(pm, pd, q)
            worst["J:batch"] = max(worst["J:batch"], err(R[s], pd.oMi[jid].rotation), err(p[s], pd.oMi[jid].translation),
                                   err(J["local_world_aligned"][s], pin.getJointJacobian(pm, pd, jid, pin.LOCAL_WORLD_ALIGNED)),
                                   err(J["local"][s], pin.getJointJacobian(pm, pd, jid, pin.LOCAL)))
    for q, v in zip(Q, V):
        pin.computeJointJacobians(pm, pd, q)
        for jid in range(1, pm.njoints):
            link = f"l{jid - 1}"
            R, p = md.frame_placement(model, q, link)
            worst["J:R"] = max(worst["J:R"], err(R, pd.oMi[jid].rotation))
            worst["J:p"] = max(worst["J:p"], err(p, pd.oMi[jid].translation))
            for ref, pref in (("local_world_aligned", pin.LOCAL_WORLD_ALIGNED), ("local", pin.LOCAL)):
                worst["J"] = max(worst["J"], err(md.frame_jacobian(model, q, link, ref),
                                                 pin.getJointJacobian(pm, pd, jid, pref)))
        worst["E:T"] = max(worst["E:T"], err(md.kinetic_energy(model, q, v), pin.computeKineticEnergy(pm, pd, q, v)))
        worst["E:V"] = max(worst["E:V"], err(md.potential_energy(model, q), pin.computePotentialEnergy(pm, pd, q)))
    check(worst)


def test_a_huge_screw_angle_one_state():
    """A screw joint turned beyond SINCOS_MAX (the lanes' sin and cos range): the one-state CRBA places it with libm's
    sin and cos and slides it h θ (lanes.screw_placement_one) — Pinocchio's crba; rnea and aba too."""
    model, pm, pd, Q, V, A = case("screw_chain", 0)
    q = Q[0].copy()
    q[0] = 4 * SINCOS_MAX                                     # j0: the chain's root, a screw joint
    ref = pin.crba(pm, pd, q)
    assert err(md.mass_matrix(model, q), np.triu(ref) + np.triu(ref, 1).T) < 5e-14      # measured 8.4e-16
    assert err(md.rnea(model, q, V[0], A[0]), pin.rnea(pm, pd, q, V[0], A[0])) < 5e-14     # 3.8e-16
    assert err(md.aba(model, q, V[0], A[0]), pin.aba(pm, pd, q, V[0], A[0])) < 5e-14       # 5.3e-16


@pytest.mark.parametrize("name", TREES)
def test_batches_over_several_lane_blocks_equal_single_calls(name):
    """N = 70 > one lane block: the screw trees run the lane steps (helical joints included) in blocks and one by
    one; the trees with a planar joint too (the one-state CRBA and ABA without a helical joint: planar_chain)."""
    model, *_ = case(name, 0)
    assert on_lanes(unpack(*model.kernel.lane_arrays), model.nq, True)       # rnea, crba, aba: every tree
    assert on_lanes(unpack(*model.kernel.lane_arrays), model.nq, True, False) == (name == "planar_chain")
    #                                                              (the one-state CRBA's and ABA's drivers)
    rng = np.random.default_rng(5)
    Q, V, A = md.random_configuration(model, rng, 70), rng.normal(size=(70, model.nv)), rng.normal(size=(70, model.nv))
    tau, M = md.rnea(model, Q, V, A), md.mass_matrix(model, Q)
    qdd = md.aba(model, Q, V, tau)
    tip = model.body_names[-1]
    (R, p), J = md.frame_placement(model, Q, tip), md.frame_jacobian(model, Q, tip, "local")
    for s in (0, 33, 69):            # (the batch runs in the lanes' z-aligned frames: equal to rounding)
        assert err(tau[s], md.rnea(model, Q[s], V[s], A[s])) < 1e-14
        assert err(M[s], md.mass_matrix(model, Q[s])) < 1e-14
        assert err(qdd[s], A[s]) < 1e-12
        R1, p1 = md.frame_placement(model, Q[s], tip)
        assert max(err(R[s], R1), err(p[s], p1), err(J[s], md.frame_jacobian(model, Q[s], tip, "local"))) < 1e-14


@pytest.mark.parametrize("integrator", ["rk4", "adaptive"])
@pytest.mark.parametrize("name", TREES)
def test_a_simulation_keeps_its_energy(name, integrator):
    """No damping, no torque: T + V is constant (RK4 on the configuration's Lie group: the planar joint's SE(2), the
    free flyer's SE(3); DOP853 on q̇(q, v), the planar joint's (cos, sin) turned by ω); its drift, over the swing of
    T, is the integrator's error."""
    model, *_ = case(name, 1)
    rng = np.random.default_rng(2)
    q0, v0 = md.random_configuration(model, rng), rng.normal(0, 0.5, model.nv)
    res = md.simulate(model, q0, v0, (0.0, 0.5), dt=1e-3, integrator=integrator)
    E = md.kinetic_energy(model, res.q, res.v) + md.potential_energy(model, res.q)
    T = md.kinetic_energy(model, res.q, res.v)
    drift = np.max(np.abs(E - E[0])) / (np.ptp(T) + 1e-300)
    print(f"energy drift {drift:.1e} of the swing {np.ptp(T):.3g} J")
    assert drift < 1e-10
    for k, m in model.unit_q:
        assert np.allclose(np.linalg.norm(res.q[:, k:k + m], axis=1), 1.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", TREES)
def test_the_playback_page_is_built(name, tmp_path):
    from manipdyn.viz import export_html
    text, _ = kinds_robot(name, 0)
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    model = case(name, 0)[0]
    t = np.linspace(0.0, 1.0, 11)
    Q = md.integrate(model, np.tile(md.neutral(model), (11, 1)), np.outer(t, np.linspace(0.2, 0.5, model.nv)))
    out = tmp_path / "play.html"
    export_html(model, path, t, Q, out)
    html = out.read_text()
    assert all(j in html for j in model.joint_names[:3])
