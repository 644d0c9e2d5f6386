"""The chapter's own formulation of the co-axial SPM (Example II, Eqs. 33–61), independent of the tree code.

Coordinates q = [θ1, θ2, θ3, φ, θ, σ] (Eq. 49): actuator angles and the platform's tilt-and-torsion angles,
Q = Rz(φ) Ry(θ) Rz(σ − φ), ω = Ψ φ̇ (Eq. 43). Every body turns about O, so each has an angular velocity
Ω_b = A_b(q) q̇ and an inertia I_b about O (world axes): proximal i: Ω = θ̇_i u_i, I_l1 about u_i; distal i:
ρ_i = (u_i j_iᵀ + v_i j_ψiᵀ) ω (Eq. 55b), E_i I_l2 E_iᵀ; platform: ω, Q I_O Qᵀ. Then
    M = Σ A_bᵀ I_b A_b                                  (Eqs. 54–55)
    h₀ = Σ A_bᵀ (I_b Ȧ_b q̇ + Ω_b × I_b Ω_b) + Σ m_b A_bᵀ (c_b × g),  g = [0, 0, 9.81]
(Euler's equation about O for each body, projected; V = Σ m_b gᵀ c_b, Eq. 52's sign). Writing θ̇_i = j_iᵀω
inside ρ_i (as Eq. 55b does) uses the constraint, so h₀ equals Eq. 60's Ṁq̇ − T_q + V_q only up to
C_qᵀ(·) — generalized forces the multipliers absorb: the motion and the actuator torques are the same, λ is
not (the tests check h₀ on the null space of C_q, and the torques against two independent routes).
Misprints corrected here (docs/design.md §6): Ψ(3,3) = cos θ; Eq. 47's e_x, e_y, e_z; Eq. 52's
T_p needs the platform inertia about O, I_O = I_p + m_p(|p*|² 1 − p* p*ᵀ); Eq. 55b E → E_i; Eq. 57
Ċ_q q̇ = Ḃθ̇ − Ȧω − AΨ̇φ̇; Eq. 60's right side [τ; Ψᵀm] − (Ṁq̇ − T_q) − V_q, with the external moment m
(environment on the platform, base axes) doing work m·ω = (Ψᵀm)·φ̇; Eq. 61 τ_a = τ − J⁻ᵀ m, J⁻ᵀ = B A⁻ᵀ.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SingularError
from . import spm_params as P

G_VEC = np.array([0.0, 0.0, 9.81])          # the chapter's g: V = m gᵀ c with z up
I_O = P.I_P + P.M_P * (P.P_STAR @ P.P_STAR * np.eye(3) - np.outer(P.P_STAR, P.P_STAR))


def platform_rotation(phi3):
    """Q = Rz(φ) Ry(θ) Rz(σ − φ) (Eq. 44's rotation), (3, 3)."""
    f, t, s = phi3
    return _rz(f) @ _ry(t) @ _rz(s - f)


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def Psi(phi3):
    """Ψ with ω = Ψ φ̇ (Eq. 44; entry (3,3) is cos θ, not cos φ as printed)."""
    f, t, _ = phi3
    sf, cf, st, ct = np.sin(f), np.cos(f), np.sin(t), np.cos(t)
    return np.array([[-st * cf, -sf, st * cf], [-st * sf, cf, st * sf], [1 - ct, 0.0, ct]])


def Psi_dot(phi3, phi3_dot):
    """Ψ̇, the exact time derivative of Ψ."""
    f, t, _ = phi3
    df, dt = phi3_dot[0], phi3_dot[1]
    sf, cf, st, ct = np.sin(f), np.cos(f), np.sin(t), np.cos(t)
    return np.array([[-ct * cf * dt + st * sf * df, -cf * df, ct * cf * dt - st * sf * df],
                     [-ct * sf * dt - st * cf * df, -sf * df, ct * sf * dt + st * cf * df],
                     [st * dt, 0.0, -st * dt]])


def tilt_torsion(Q):
    """(φ, θ, σ) of a rotation Q = Rz(φ) Ry(θ) Rz(σ − φ) (θ in [0, π]; φ undefined at zero tilt)."""
    t = np.arccos(np.clip(Q[2, 2], -1.0, 1.0))
    f = np.arctan2(Q[1, 2], Q[0, 2])
    return np.array([f, t, f + np.arctan2(Q[2, 1], -Q[2, 0])])


@dataclass(frozen=True)
class Legs:
    """The leg geometry at one configuration: every vector world-frame, (3, 3) arrays indexed [leg]."""
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    A: np.ndarray            # rows (v_i × w_i)ᵀ, Eq. 40a
    B: np.ndarray            # (3,) diagonal (u_i × v_i)·w_i, Eq. 40b
    j_psi: np.ndarray        # rows (u_i × w_i)ᵀ / ((u_i × w_i)·v_i), Eq. 45


def legs(theta, Q):
    """u_i, v_i, w_i (Eqs. 33–36), A, B (Eq. 40) and j_ψi (Eq. 45) for actuator angles θ and platform Q."""
    u = np.array([P.u_axis(i) for i in range(3)])
    v = np.array([P.v_axis(i, theta[i]) for i in range(3)])
    w = np.array([Q @ P.w_star(i) for i in range(3)])
    uw = np.cross(u, w)
    return Legs(u, v, w, np.cross(v, w), np.einsum("ij,ij->i", np.cross(u, v), w),
                uw / np.einsum("ij,ij->i", uw, v)[:, None])


def J_matrix(L):
    """J = B⁻¹ A (Eq. 41): θ̇ = J ω; needs B non-singular."""
    return L.A / L.B[:, None]


def E_frame(v, w):
    """E_i = [e_x e_y e_z] of Eq. 47 (corrected): (v − w), (v + w), v × w normalised."""
    cols = (v - w, v + w, np.cross(v, w))
    return np.column_stack([c / np.linalg.norm(c) for c in cols])


def inverse_kinematics(Q):
    """Both branches of θ_i per leg for platform orientation Q: (3, 2), solving v_i(θ_i)·w_i = cos α2."""
    out = np.empty((3, 2))
    for i in range(3):
        w = Q @ P.w_star(i)
        k0 = 0.5 * (P.v_axis(i, 0.0) + P.v_axis(i, np.pi))       # v(θ) = k0 + kc cos θ + ks sin θ (Eq. 34)
        kc, ks = P.v_axis(i, 0.0) - k0, P.v_axis(i, np.pi / 2) - k0
        a, b, c = w @ kc, w @ ks, np.cos(P.ALPHA2) - w @ k0
        r = np.hypot(a, b)
        if abs(c) > r:
            raise SingularError(f"leg {i + 1} cannot reach this platform orientation")
        base, d = np.arctan2(b, a), np.arccos(c / r)
        out[i] = [_wrap(base - d), _wrap(base + d)]
    return out


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def forward_kinematics(theta, phi_guess, tol=1e-13, max_iter=50):
    """φ for actuator angles θ by Newton on v_i·(Q w_i*) = cos α2 from a guess (∂f/∂φ = −A Ψ)."""
    phi = np.array(phi_guess, float)
    for it in range(max_iter):
        Q = platform_rotation(phi)
        L = legs(theta, Q)
        f = np.einsum("ij,ij->i", L.v, L.w) - np.cos(P.ALPHA2)
        if np.max(np.abs(f)) < tol:
            return phi, it
        Jf = -L.A @ Psi(phi)
        if np.linalg.cond(Jf) > 1e12:
            raise SingularError(f"forward kinematics: A Ψ is singular (cond {np.linalg.cond(Jf):.2g}) at φ = {phi}")
        phi = phi - np.linalg.solve(Jf, f)
    raise SingularError(f"forward kinematics did not converge from {phi_guess} (residual {np.max(np.abs(f)):.2g})")


def _bodies(q, qd):
    """Per body: (A_b (3, 6), I_b (3, 3) about O, world; Ȧ_b q̇ (3,); mass; CoM (3,)), for q, q̇."""
    theta, phi = q[:3], q[3:]
    Q = platform_rotation(phi)
    L = legs(theta, Q)
    Ps = Psi(phi)
    om, dom = Ps @ qd[3:], Psi_dot(phi, qd[3:]) @ qd[3:]      # ω and ω̇ at q̈ = 0 (Eq. 43)
    out = []
    for i in range(3):
        u, v, w = L.u[i], L.v[i], L.w[i]
        Ap = np.zeros((3, 6))                                   # proximal: Ω = θ̇_i u_i
        Ap[:, i] = u
        prox_com = _prox_com(i, theta[i])
        out.append((Ap, P.I_L1 * np.outer(u, u), np.zeros(3), P.M_L1, prox_com))
        vd, wd = qd[i] * np.cross(u, v), np.cross(om, w)        # v̇ = θ̇ u × v, ẇ = ω × w
        B, D = np.cross(u, v) @ w, np.cross(u, w) @ v
        s, r = np.cross(v, w) @ om / B, np.cross(u, w) @ om / D  # θ̇_i = j_iᵀω, ψ̇_i = j_ψiᵀω
        Bd = np.cross(u, vd) @ w + np.cross(u, v) @ wd
        Dd = np.cross(u, wd) @ v + np.cross(u, w) @ vd
        sd = ((np.cross(vd, w) + np.cross(v, wd)) @ om + np.cross(v, w) @ dom - s * Bd) / B
        rd = (np.cross(u, wd) @ om + np.cross(u, w) @ dom - r * Dd) / D
        Ad = np.zeros((3, 6))                                   # distal: ρ = (u jᵀ + v j_ψᵀ) Ψ φ̇
        Ad[:, 3:] = (np.outer(u, np.cross(v, w) / B) + np.outer(v, np.cross(u, w) / D)) @ Ps
        E = E_frame(v, w)
        out.append((Ad, E @ P.I_L2 @ E.T, sd * u + rd * v + r * vd, P.M_L2,
                    P.R_L2 * (v + w) / np.linalg.norm(v + w)))
    Apl = np.zeros((3, 6))                                      # platform: Ω = ω = Ψ φ̇
    Apl[:, 3:] = Ps
    out.append((Apl, Q @ I_O @ Q.T, dom, P.M_P, Q @ P.P_STAR))
    return out


def _prox_com(i, theta):
    """World CoM of proximal link i (spm_params: on the u–v bisector, R_L1 from O)."""
    u, v = P.u_axis(i), P.v_axis(i, theta)
    b = (u + v) / np.linalg.norm(u + v)
    return P.R_L1 * b


def mass_matrix(q):
    """M(q) = Σ A_bᵀ I_b A_b, block-diagonal [M1, M2] as Eqs. 54–55: (6, 6)."""
    return sum(A.T @ I @ A for A, I, _, _, _ in _bodies(q, np.zeros(6)))


def bias(q, qd):
    """h₀ = Ṁ q̇ − T_q + V_q (Eq. 60's velocity and gravity terms): (6,)."""
    h = np.zeros(6)
    for A, I, Adq, m, c in _bodies(q, qd):
        Om = A @ qd
        h += A.T @ (I @ Adq + np.cross(Om, I @ Om)) + m * A.T @ np.cross(c, G_VEC)
    return h


def constraint_jacobian(q):
    """C_q = [B, −A Ψ] (Eq. 51): (3, 6)."""
    L = legs(q[:3], platform_rotation(q[3:]))
    return np.hstack([np.diag(L.B), -L.A @ Psi(q[3:])])


def constraint_bias(q, qd):
    """Ċ_q q̇ = Ḃ θ̇ − Ȧ ω − A Ψ̇ φ̇ (Eq. 57 corrected; Ȧ, Ḃ rows of Eqs. 58–59): (3,)."""
    L = legs(q[:3], platform_rotation(q[3:]))
    om = Psi(q[3:]) @ qd[3:]
    vd = qd[:3, None] * np.cross(L.u, L.v)
    wd = np.cross(om, L.w)
    Ad = np.cross(vd, L.w) + np.cross(L.v, wd)                  # j_Ai, Eq. 59a
    Bd = np.einsum("ij,ij->i", np.cross(L.u, vd), L.w) + np.einsum("ij,ij->i", np.cross(L.u, L.v), wd)
    return Bd * qd[:3] - Ad @ om - L.A @ (Psi_dot(q[3:], qd[3:]) @ qd[3:])


def forward_dynamics(q, qd, tau, moment=np.zeros(3)):
    """(q̈, λ, rank): Eq. 60, [M C_qᵀ; C_q 0][q̈; λ] = [[τ; Ψᵀ m] − h₀; −Ċ_q q̇], solved by least squares."""
    M, C = mass_matrix(q), constraint_jacobian(q)
    rhs = np.r_[np.r_[tau, Psi(q[3:]).T @ moment] - bias(q, qd), -constraint_bias(q, qd)]
    K = np.block([[M, C.T], [C, np.zeros((3, 3))]])
    x, _, rank, _ = np.linalg.lstsq(K, rhs, rcond=1e-12)
    return x[:6], x[6:], rank


def inverse_dynamics(q, qd, qdd, moment=np.zeros(3)):
    """τ_a (3,): τ = h_θ + J⁻ᵀ Ψ⁻ᵀ h_φ with h = M q̈ + h₀, then Eq. 61 τ_a = τ − J⁻ᵀ m, J⁻ᵀ = B A⁻ᵀ."""
    h = mass_matrix(q) @ qdd + bias(q, qd)
    L = legs(q[:3], platform_rotation(q[3:]))
    JinvT = np.diag(L.B) @ np.linalg.inv(L.A).T
    return h[:3] + JinvT @ np.linalg.solve(Psi(q[3:]).T, h[3:]) - JinvT @ moment


@dataclass(frozen=True)
class Fig7:
    """The Fig. 7 scenario sampled at t: q, q̇, q̈ (T, 6), τ_a (T, 3), and the conditioning along it."""
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    cond_A: np.ndarray
    cond_B: np.ndarray
    leg_triple: np.ndarray      # (T, 3): (u_i × v_i)·w_i, the chapter's divisor


def fig7(t, theta_ddot=(0.0, 0.0, 0.0), branch=0, moment=P.MOMENT, phi_guess=None):
    """Table 2's scenario: φ0 = [0, π/6, 0], θ̇0 = [−8, −7, −9] rad/s, constant θ̈, external moment m.
    The platform is followed by forward kinematics from sample to sample, starting at φ0 (or phi_guess)."""
    th0 = inverse_kinematics(platform_rotation(np.array(P.PHI0, float)))[:, branch]
    phi = np.array(P.PHI0 if phi_guess is None else phi_guess, float)
    thdd = np.asarray(theta_ddot, float)
    rows = []
    for tk in np.asarray(t, float):
        th, thd = th0 + P.THETA_DOT0 * tk + 0.5 * thdd * tk**2, P.THETA_DOT0 + thdd * tk
        phi, _ = forward_kinematics(th, phi)
        L = legs(th, platform_rotation(phi))
        om = np.linalg.solve(L.A, L.B * thd)                    # Eq. 39
        Ps = Psi(phi)
        phid = np.linalg.solve(Ps, om)
        q, qd0 = np.r_[th, phi], np.r_[thd, phid]
        # ω̇ = A⁻¹(Ḃθ̇ + Bθ̈ − Ȧω), from d/dt(Bθ̇ − Aω) = 0 (constraint_bias with q̈ = 0 gives Ḃθ̇ − Ȧω − AΨ̇φ̇)
        rhs = L.B * thdd + constraint_bias(q, qd0) + L.A @ (Psi_dot(phi, phid) @ phid)
        dom = np.linalg.solve(L.A, rhs)
        phidd = np.linalg.solve(Ps, dom - Psi_dot(phi, phid) @ phid)
        qdd = np.r_[thdd, phidd]
        rows.append((q, qd0, qdd, inverse_dynamics(q, qd0, qdd, moment), np.linalg.cond(L.A),
                     np.linalg.cond(np.diag(L.B)), L.B))
    return Fig7(np.asarray(t, float), *(np.array(x) for x in zip(*rows)))


def singular_time(theta_ddot=(0.0, 0.0, 0.0), t_max=0.4, dt=1e-3):
    """First time at which a leg's (u_i × v_i)·w_i changes sign along the Fig. 7 motion (leg, time)."""
    t = np.arange(0.0, t_max, dt)
    f = fig7(t, theta_ddot)
    s = np.sign(f.leg_triple)
    for k in range(1, len(t)):
        flip = np.flatnonzero(s[k] != s[0])
        if flip.size:
            return int(flip[0]) + 1, float(t[k])
    return None, None
