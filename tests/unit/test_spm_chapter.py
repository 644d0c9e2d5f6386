"""The chapter's SPM formulation (examples/spm.py, Eqs. 33–61) against independent references and laws.

References: the URDF tree of the same machine closed by <constraint>s (urdf/spm.urdf, manipdyn.constraints:
assembly, closure Jacobians, Lagrange's equations of the 1st kind), Pinocchio on that tree (kinetic and
potential energy; constraintDynamics inverted for the actuator torques), finite differences of rotations,
and physical laws. No check compares the chapter's model with its own output.

States: random platform orientations (tilt 0.35–0.75 rad, any azimuth and torsion), the first IK branch,
far from both singularities (cond A, cond B ≤ 5, every |(u_i × v_i)·w_i| ≥ 0.15), every actuator moving
(|θ̇_i| ≥ 1 rad/s) and accelerating (|θ̈_i| ≥ 1 rad/s²), every passive joint too (≥ 0.3 rad/s, rad/s²). The passive rates and accelerations — the platform's
ω, ω̇, hence φ̇, φ̈ — come from the tree (closures + platform Jacobian and J̇), not from the chapter.
"""
from functools import lru_cache

import numpy as np
import pinocchio as pin
import pytest
from conftest import assert_close

import manipdyn as md
from manipdyn.constraints import complete_state
from manipdyn.errors import SingularError
from manipdyn.examples import spm as S
from manipdyn.examples import spm_params as P
from manipdyn.examples.spm_urdf import tree_guess
from manipdyn.validation.closed import ClosedReference, actuator_torques_by_inversion
from manipdyn.validation.fig7 import SPM_URDF
from manipdyn.validation.reference import Reference

MODEL = md.load_urdf(SPM_URDF)
ACT = [MODEL.joint_index(j) for j in MODEL.actuated]
N_STATES = 6


@lru_cache(maxsize=1)
def references():
    ref = Reference(MODEL, SPM_URDF)
    return ref, ClosedReference(ref)


def _random_pose(rng):
    """(φ (3,), θ (3,)) with the platform far from singular, first IK branch."""
    while True:
        phi = np.array([rng.uniform(-np.pi, np.pi), rng.uniform(0.35, 0.75), rng.uniform(-np.pi, np.pi)])
        try:
            th = S.inverse_kinematics(S.platform_rotation(phi))[:, 0]
        except SingularError:
            continue
        L = S.legs(th, S.platform_rotation(phi))
        if np.linalg.cond(L.A) <= 5 and np.abs(L.B).max() / np.abs(L.B).min() <= 5 and np.abs(L.B).min() >= 0.15:
            return phi, th


def _nonzero(rng, scale, n=3):
    x = rng.normal(0, scale, n)
    return np.sign(x) * np.maximum(np.abs(x), 1.0)


def tree_state(phi, th, thd, thdd):
    """The tree's (q, q̇, q̈) for actuator motion (θ, θ̇, θ̈) at platform pose φ, and the chapter's (q, q̇, q̈)
    with φ̇ = Ψ⁻¹ω, φ̈ = Ψ⁻¹(ω̇ − Ψ̇φ̇), ω = J_ω q̇_tree and ω̇ = J_ω q̈_tree + J̇_ω q̇_tree of the platform."""
    Q = S.platform_rotation(phi)
    qt, vt, at, asm = complete_state(MODEL, tree_guess(MODEL, Q, th), thd, thdd)
    assert asm.residual <= 1e-12 and asm.same_branch
    assert_close(md.frame_placement(MODEL, qt, "platform")[0], Q, 1e-14, "platform pose")  # measured 3.6e-16
    Jw = md.frame_jacobian(MODEL, qt, "platform")[3:]
    om, dom = Jw @ vt, Jw @ at + md.frame_jacobian_dot(MODEL, qt, vt, "platform")[3:] @ vt
    Ps = S.Psi(phi)
    phid = np.linalg.solve(Ps, om)
    phidd = np.linalg.solve(Ps, dom - S.Psi_dot(phi, phid) @ phid)
    return (qt, vt, at), (np.r_[th, phi], np.r_[thd, phid], np.r_[thdd, phidd])


@lru_cache(maxsize=1)
def states():
    """N_STATES random (φ, θ, θ̇, θ̈)."""
    rng = np.random.default_rng(2024)
    out = []
    while len(out) < N_STATES:
        phi, th = _random_pose(rng)
        thd, thdd = _nonzero(rng, 4.0), _nonzero(rng, 5.0)
        (_, vt, at), _ = tree_state(phi, th, thd, thdd)
        if min(np.abs(vt).min(), np.abs(at).min()) >= 0.3:           # every joint of every leg moves
            out.append((phi, th, thd, thdd))
    return out


TERMS = ("gravity", "inertia", "velocity", "moment", "full")


@lru_cache(maxsize=None)
def torque_terms(k):
    """Actuator torques of the chapter (Eq. 61), the tree + closures route and Pinocchio, split into
    terms: gravity τ(θ̇ = θ̈ = m = 0); inertia, velocity and moment each alone minus gravity; all at once."""
    phi, th, thd, thdd = states()[k]
    _, cref = references()
    zero, m = np.zeros(3), np.array([0.3, -0.2, 0.25])
    runs = {"gravity": (zero, zero, zero), "inertia": (zero, thdd, zero), "velocity": (thd, zero, zero),
            "moment": (zero, zero, m), "full": (thd, thdd, m)}
    out = {}
    for term, (v_a, a_a, mom) in runs.items():
        (qt, vt, at), ch = tree_state(phi, th, v_a, a_a)
        fx = {"platform": (np.zeros(3), mom)}
        out[term] = (S.inverse_dynamics(*ch, mom),
                     md.constrained_inverse_dynamics(MODEL, qt, vt, at, f_ext=fx, f_ext_frame="world")[0],
                     actuator_torques_by_inversion(MODEL, cref, qt, vt, a_a, ACT,
                                                   md.frame_jacobian(MODEL, qt, "platform")[3:].T @ mom))
    for term in ("inertia", "velocity", "moment"):
        out[term] = tuple(x - g for x, g in zip(out[term], out["gravity"]))
    return out


def test_states_are_far_from_singular_and_every_term_is_large():
    for k, (phi, th, thd, thdd) in enumerate(states()):
        L = S.legs(th, S.platform_rotation(phi))
        assert np.linalg.cond(L.A) <= 5 and np.abs(L.B).min() >= 0.15
        assert np.abs(thd).min() >= 1.0 and np.abs(thdd).min() >= 1.0
        (_, vt, at), _ = tree_state(phi, th, thd, thdd)
        assert np.abs(vt).min() >= 0.3 and np.abs(at).min() >= 0.3       # every joint of every leg moves
        for term, (chap, _, _) in torque_terms(k).items():
            assert np.abs(chap).max() > 1e-3, (k, term)                     # no term is negligible


@pytest.mark.parametrize("k", range(N_STATES))
def test_actuator_torques_against_the_tree_and_pinocchio(k):
    for term, (chap, tree, pino) in torque_terms(k).items():
        assert_close(chap, tree, 1e-13, f"{term}: chapter vs URDF + closures")     # measured 7.6e-15
        assert_close(chap, pino, 5e-14, f"{term}: chapter vs Pinocchio")           # measured 8.9e-16


@pytest.mark.parametrize("k", range(N_STATES))
def test_velocity_and_acceleration_constraints(k):
    # Eq. 39 A ω = B θ̇, Eq. 51 C_q q̇ = 0 and Eqs. 56–59 C_q q̈ = −Ċ_q q̇, at the tree's rates and accelerations
    phi, th, thd, thdd = states()[k]
    _, (q, qd, qdd) = tree_state(phi, th, thd, thdd)
    L = S.legs(th, S.platform_rotation(phi))
    assert_close(L.A @ (S.Psi(phi) @ qd[3:]), L.B * thd, 1e-13, "A ω = B θ̇ (Eq. 39)")        # measured 3.1e-15
    assert_close(S.constraint_jacobian(q) @ qd, np.zeros(3), 1e-12, "C_q q̇ = 0 (Eq. 51)")  # measured 1.2e-14
    assert_close(S.constraint_jacobian(q) @ qdd, -S.constraint_bias(q, qd), 1e-12, "Eq. 56")  # measured 1.3e-14


@pytest.mark.parametrize("k", range(N_STATES))
def test_energies_against_pinocchio(k):
    # T = ½ q̇ᵀ M q̇ (Eqs. 54–55) and V (Eq. 52) against Pinocchio's energies of the tree in the same state
    ref, _ = references()
    phi, th, thd, thdd = states()[k]
    (qt, vt, _), (q, qd, _) = tree_state(phi, th, thd, thdd)
    pq = ref.to_pin_q(qt)
    T_pin = pin.computeKineticEnergy(ref.pm, ref.pd, pq, vt)
    V_pin = pin.computePotentialEnergy(ref.pm, ref.pd, pq)
    assert_close(0.5 * qd @ S.mass_matrix(q) @ qd, T_pin, 1e-15, "T")                        # measured 1.4e-17
    assert_close(sum(m * S.G_VEC @ c for _, _, _, m, c in S._bodies(q, qd)), V_pin, 1e-15, "V")  # measured 2.8e-17


@pytest.mark.parametrize("k", range(N_STATES))
def test_forward_dynamics_under_the_tree_torques(k):
    # Eq. 60 solved under the tree route's torques gives the tree's accelerations
    phi, th, thd, thdd = states()[k]
    m = np.array([0.3, -0.2, 0.25])
    _, (q, qd, qdd) = tree_state(phi, th, thd, thdd)
    tau = torque_terms(k)["full"][1]
    qdd2, _, rank = S.forward_dynamics(q, qd, tau, m)
    assert rank == 9
    assert_close(qdd2, qdd, 1e-11, "q̈")                                                    # measured 5.0e-13


def test_inverse_kinematics_branches_match_design():
    th = np.degrees(S.inverse_kinematics(S.platform_rotation(P.PHI0)))
    expected = np.array([[-62.58, 77.84], [-50.85, 32.72], [-85.33, 84.32]])    # docs/design.md §6, 2 decimals
    assert np.abs(th - expected).max() <= 0.005          # measured 0.0048: the reference is rounded to 0.01°


@pytest.mark.parametrize("k", range(N_STATES))
def test_forward_kinematics_against_the_tree_assembly(k):
    # the tree, assembled with the actuators held at θ from a guess near the pose, places the platform at
    # the orientation the chapter's Newton iteration finds from a guess 0.05 rad away
    phi, th, _, _ = states()[k]
    phi_fk, _ = S.forward_kinematics(th, phi + 0.05)
    (qt, _, _), _ = tree_state(phi, th, np.zeros(3), np.zeros(3))
    assert_close(S.platform_rotation(phi_fk), md.frame_placement(MODEL, qt, "platform")[0], 1e-12, "Q")  # measured 2.7e-14


def test_psi_and_its_derivative_against_finite_differences():
    rng, h = np.random.default_rng(0), 1e-6
    for _ in range(5):
        phi, d = rng.uniform(-1, 1, 3) + [0, 1.2, 0], rng.normal(size=3)
        dQ = (S.platform_rotation(phi + h * d) - S.platform_rotation(phi - h * d)) / (2 * h)
        W = dQ @ S.platform_rotation(phi).T                      # [ω]×
        assert_close(S.Psi(phi) @ d, np.array([W[2, 1], W[0, 2], W[1, 0]]), 1e-9, "ω = Ψ φ̇")  # measured 8.2e-11
        assert_close(S.Psi_dot(phi, d), (S.Psi(phi + h * d) - S.Psi(phi - h * d)) / (2 * h), 1e-9, "Ψ̇")  # measured 7.3e-11
        assert_close(S.tilt_torsion(S.platform_rotation(phi)), phi, 1e-14, "tilt-torsion angles")  # measured 2.2e-16


T = np.linspace(0.0, 0.25, 11)
FIG = S.fig7(T)


def test_fig7_platform_rates_against_finite_differences_in_time():
    # Fig. 7's ω (Eq. 39 through Ψ) against dQ/dt = [ω]× Q by central differences of its own poses
    h = 1e-6
    f = S.fig7(np.array([0.1 - h, 0.1 + h]))
    dQ = (S.platform_rotation(f.q[1, 3:]) - S.platform_rotation(f.q[0, 3:])) / (2 * h)
    mid = S.fig7(np.array([0.1]))
    W = dQ @ S.platform_rotation(mid.q[0, 3:]).T
    assert_close(np.array([W[2, 1], W[0, 2], W[1, 0]]), S.Psi(mid.q[0, 3:]) @ mid.qd[0, 3:], 1e-9, "ω")  # measured 3.1e-11


def _potential(q):
    return sum(m * S.G_VEC @ c for _, _, _, m, c in S._bodies(q, np.zeros(6)))


def test_bias_against_lagrange_by_finite_differences():
    # Lagrange's equations: Eq. 60's Ṁq̇ − T_q + V_q by finite differences of M and V. The module's h₀
    # (Euler's equation about O, projected) differs from it by C_qᵀ(·) only — forces the multipliers absorb
    # — so the two agree on the null space N of C_q, which is all the motion and the actuator torques see.
    h = 1e-6
    for k in (0, 5, 10):
        q, qd = FIG.q[k], FIG.qd[k]
        Mdot = (S.mass_matrix(q + h * qd) - S.mass_matrix(q - h * qd)) / (2 * h)
        Tq = np.array([0.5 * qd @ ((S.mass_matrix(q + h * e) - S.mass_matrix(q - h * e)) / (2 * h)) @ qd
                       for e in np.eye(6)])
        Vq = np.array([(_potential(q + h * e) - _potential(q - h * e)) / (2 * h) for e in np.eye(6)])
        N = np.linalg.svd(S.constraint_jacobian(q))[2][3:].T        # (6, 3) null space of C_q
        assert_close(N.T @ S.bias(q, qd), N.T @ (Mdot @ qd - Tq + Vq), 1e-9, "Nᵀ h₀")  # measured 9.2e-11
        assert_close(N.T @ S.bias(q, np.zeros(6)), N.T @ Vq, 5e-10, "Nᵀ V_q")  # measured 1.0e-11


def test_power_balance_along_fig7():
    # physical law: τ_a·θ̇ + m·ω = dE/dt, E = T + V; dE/dt = q̇ᵀ(M q̈ + ½ Ṁ q̇) + V_q q̇ (the chapter's M)
    h = 1e-6
    for k in range(len(T)):
        q, qd, qdd = FIG.q[k], FIG.qd[k], FIG.qdd[k]
        Mdot = (S.mass_matrix(q + h * qd) - S.mass_matrix(q - h * qd)) / (2 * h)
        Vq = np.array([(_potential(q + h * e) - _potential(q - h * e)) / (2 * h) for e in np.eye(6)])
        dE = qd @ (S.mass_matrix(q) @ qdd + 0.5 * Mdot @ qd) + Vq @ qd
        power = FIG.tau[k] @ qd[:3] + P.MOMENT @ (S.Psi(q[3:]) @ qd[3:])
        assert abs(power - dE) <= 1e-8 * max(abs(dE), 1.0)   # measured 2.2e-10


def test_massless_mechanism_power_is_zero(monkeypatch):
    for name in ("M_P", "M_L1", "M_L2", "I_L1"):
        monkeypatch.setattr(P, name, 0.0)
    monkeypatch.setattr(P, "I_L2", np.zeros((3, 3)))
    monkeypatch.setattr(S, "I_O", np.zeros((3, 3)))
    for k in range(len(T)):
        q, qd, qdd = FIG.q[k], FIG.qd[k], FIG.qdd[k]
        tau = S.inverse_dynamics(q, qd, qdd, P.MOMENT)
        assert abs(tau @ qd[:3] + P.MOMENT @ (S.Psi(q[3:]) @ qd[3:])) <= 1e-14   # measured 5.6e-16


def test_singularity_and_span():
    leg, t = S.singular_time()
    assert leg == 2 and 0.25 <= t <= 0.31
    assert FIG.cond_A.max() < 3.0 and FIG.cond_B.max() < 20.0      # far from singular on [0, 0.25] s
    assert np.all(np.abs(FIG.leg_triple) > 0.04)
