"""The chapter's SPM formulation (examples/spm.py) against independent references and physical laws."""
import numpy as np
from conftest import assert_close

from manipdyn.examples import spm as S
from manipdyn.examples import spm_params as P

T = np.linspace(0.0, 0.25, 11)
FIG = S.fig7(T)


def test_inverse_kinematics_branches_match_design():
    th = np.degrees(S.inverse_kinematics(S.platform_rotation(P.PHI0)))
    expected = np.array([[-62.58, 77.84], [-50.85, 32.72], [-85.33, 84.32]])
    assert np.abs(th - expected).max() < 0.01
    phi, _ = S.forward_kinematics(np.radians(th[:, 0]), [0.05, 0.5, -0.05])
    assert_close(phi, np.array(P.PHI0), 1e-12, "FK inverts IK")


def test_psi_and_its_derivative_against_finite_differences():
    rng, h = np.random.default_rng(0), 1e-6
    for _ in range(5):
        phi, d = rng.uniform(-1, 1, 3) + [0, 1.2, 0], rng.normal(size=3)
        dQ = (S.platform_rotation(phi + h * d) - S.platform_rotation(phi - h * d)) / (2 * h)
        W = dQ @ S.platform_rotation(phi).T                      # [ω]×
        assert_close(S.Psi(phi) @ d, np.array([W[2, 1], W[0, 2], W[1, 0]]), 1e-8, "ω = Ψ φ̇")
        assert_close(S.Psi_dot(phi, d), (S.Psi(phi + h * d) - S.Psi(phi - h * d)) / (2 * h), 1e-8, "Ψ̇")
        assert_close(S.tilt_torsion(S.platform_rotation(phi)), phi, 1e-12, "tilt-torsion angles")


def test_velocity_and_constraint_equations_along_fig7():
    for k in range(len(T)):
        q, qd, qdd = FIG.q[k], FIG.qd[k], FIG.qdd[k]
        C = S.constraint_jacobian(q)
        assert_close(C @ qd, np.zeros(3), 1e-12, "C_q q̇ = 0 (Eq. 51)")
        assert_close(C @ qdd, -S.constraint_bias(q, qd), 1e-10, "C_q q̈ = −Ċ_q q̇ (Eq. 56)")
    # platform orientation along the motion: dQ/dt = [ω]× Q by finite differences in time (test only)
    h = 1e-6
    f = S.fig7(np.array([0.1 - h, 0.1 + h]))
    dQ = (S.platform_rotation(f.q[1, 3:]) - S.platform_rotation(f.q[0, 3:])) / (2 * h)
    mid = S.fig7(np.array([0.1]))
    W = dQ @ S.platform_rotation(mid.q[0, 3:]).T
    assert_close(np.array([W[2, 1], W[0, 2], W[1, 0]]), S.Psi(mid.q[0, 3:]) @ mid.qd[0, 3:], 1e-6, "ω")


def _kinetic_energy_by_bodies(q, qd):
    """½ Σ Ωᵀ I Ω from each body's angular velocity, written out independently of the module's A_b."""
    th, phi = q[:3], q[3:]
    Q = S.platform_rotation(phi)
    L = S.legs(th, Q)
    om = S.Psi(phi) @ qd[3:]
    Tk = 0.5 * om @ (Q @ S.I_O @ Q.T) @ om
    for i in range(3):
        Tk += 0.5 * P.I_L1 * qd[i] ** 2
        # ω = θ̇u + ψ̇v + ξ̇w: the distal link turns with θ̇ u + ψ̇ v, solved from the leg's 3×3 system
        coef = np.linalg.solve(np.column_stack([L.u[i], L.v[i], L.w[i]]), om)
        rho = coef[0] * L.u[i] + coef[1] * L.v[i]
        E = S.E_frame(L.v[i], L.w[i])
        Tk += 0.5 * rho @ E @ P.I_L2 @ E.T @ rho
    return Tk


def test_mass_matrix_is_the_kinetic_energy():
    for k in range(len(T)):
        M = S.mass_matrix(FIG.q[k])
        assert_close(M, M.T, 1e-16, "symmetric")
        assert np.all(np.linalg.eigvalsh(M) > 0)
        assert_close(0.5 * FIG.qd[k] @ M @ FIG.qd[k], _kinetic_energy_by_bodies(FIG.q[k], FIG.qd[k]), 1e-13, "T")


def _potential(q):
    return sum(m * S.G_VEC @ c for _, _, _, m, c in S._bodies(q, np.zeros(6)))


def test_bias_against_lagrange_by_finite_differences():
    # Eq. 60's Ṁq̇ − T_q + V_q by finite differences of M and V (fine in a test). The module's h₀ (Euler's
    # equation about O, projected) differs from it by C_qᵀ(·) only — forces the multipliers absorb — so
    # the two agree on the null space N of C_q, which is all the motion and the actuator torques see.
    h = 1e-6
    for k in (0, 5, 10):
        q, qd = FIG.q[k], FIG.qd[k]
        Mdot = (S.mass_matrix(q + h * qd) - S.mass_matrix(q - h * qd)) / (2 * h)
        Tq = np.array([0.5 * qd @ ((S.mass_matrix(q + h * e) - S.mass_matrix(q - h * e)) / (2 * h)) @ qd
                       for e in np.eye(6)])
        Vq = np.array([(_potential(q + h * e) - _potential(q - h * e)) / (2 * h) for e in np.eye(6)])
        N = np.linalg.svd(S.constraint_jacobian(q))[2][3:].T        # (6, 3) null space of C_q
        assert_close(N.T @ S.bias(q, qd), N.T @ (Mdot @ qd - Tq + Vq), 1e-6, "Nᵀ h₀")
        assert_close(N.T @ S.bias(q, np.zeros(6)), N.T @ Vq, 1e-7, "Nᵀ V_q")


def test_power_balance_along_fig7():
    # physical law: τ_a·θ̇ + m·ω = dE/dt, E = T + V; dE/dt = q̇ᵀ(M q̈ + ½ Ṁ q̇) + V_q q̇ (the chapter's M)
    h = 1e-6
    for k in range(len(T)):
        q, qd, qdd = FIG.q[k], FIG.qd[k], FIG.qdd[k]
        Mdot = (S.mass_matrix(q + h * qd) - S.mass_matrix(q - h * qd)) / (2 * h)
        Vq = np.array([(_potential(q + h * e) - _potential(q - h * e)) / (2 * h) for e in np.eye(6)])
        dE = qd @ (S.mass_matrix(q) @ qdd + 0.5 * Mdot @ qd) + Vq @ qd
        power = FIG.tau[k] @ qd[:3] + P.MOMENT @ (S.Psi(q[3:]) @ qd[3:])
        assert abs(power - dE) <= 1e-7 * max(abs(dE), 1.0)


def test_massless_mechanism_power_is_zero(monkeypatch):
    for name in ("M_P", "M_L1", "M_L2", "I_L1"):
        monkeypatch.setattr(P, name, 0.0)
    monkeypatch.setattr(P, "I_L2", np.zeros((3, 3)))
    monkeypatch.setattr(S, "I_O", np.zeros((3, 3)))
    for k in range(len(T)):
        q, qd, qdd = FIG.q[k], FIG.qd[k], FIG.qdd[k]
        tau = S.inverse_dynamics(q, qd, qdd, P.MOMENT)
        assert abs(tau @ qd[:3] + P.MOMENT @ (S.Psi(q[3:]) @ qd[3:])) <= 1e-12


def test_forward_dynamics_inverts_inverse_dynamics():
    for k in range(len(T)):
        q, qd, qdd = FIG.q[k], FIG.qd[k], FIG.qdd[k]
        qdd2, _, rank = S.forward_dynamics(q, qd, np.r_[FIG.tau[k]], P.MOMENT)
        assert rank == 9
        assert_close(qdd2, qdd, 1e-10, "q̈")


def test_singularity_and_span():
    leg, t = S.singular_time()
    assert leg == 2 and 0.25 <= t <= 0.31
    assert FIG.cond_A.max() < 3.0 and FIG.cond_B.max() < 20.0      # far from singular on [0, 0.25] s
    assert np.all(np.abs(FIG.leg_triple) > 0.04)
