"""Non-planar mechanisms with closed-form M, C (Christoffel), g and J̇ derived by hand.

Both mechanisms are a two-axis gimbal: joint 1 about the world z axis, joint 2 about body 1's x axis, the
two axes meeting at the origin, so body 2 turns with R = Rz(q1) Rx(q2) and its angular velocity in its own
axes is ω₂ = Rx(q2)ᵀ [0, 0, q̇1] + [q̇2, 0, 0] = [q̇2, q̇1 s2, q̇1 c2] (s2 = sin q2, c2 = cos q2).
"""
import numpy as np
import pytest
from conftest import assert_close, inertial_xml, urdf

import manipdyn as md

G = 9.81
RNG = np.random.default_rng(11)
STATES = [(RNG.uniform(-np.pi, np.pi, 2), RNG.normal(0, 2, 2)) for _ in range(20)]
STATES = [(q, v) for q, v in STATES if abs(np.sin(q[1])) > 0.2]       # keep M well away from singular

# gimbal: body 1 (outer ring) has I1 about z; body 2 has principal moments A, B, C (all different) about
# its CoM, which sits at distance d along body 2's y axis
I1, A, B, C, M2, D = 0.05, 0.021, 0.023, 0.037, 1.3, 0.2
GIMBAL = md.load_urdf_string(urdf(
    {"base": "", "ring": inertial_xml(0.7, (0, 0, 0), (0.03, 0.04, I1, 0, 0, 0)),
     "body": inertial_xml(M2, (0, D, 0), (A, B, C, 0, 0, 0))},
    [("j1", "revolute", "base", "ring", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
     ("j2", "revolute", "ring", "body", (0, 0, 0), (0, 0, 0), (1, 0, 0))]))

# spherical pendulum: the same two axes, a point mass m at distance L along body 2's −z (the bob frame)
MB, L, I1P = 0.9, 0.6, 0.02
PENDULUM = md.load_urdf_string(urdf(
    {"base": "", "ring": inertial_xml(0.1, (0, 0, 0), (0.01, 0.01, I1P, 0, 0, 0)), "arm": "",
     "bob": inertial_xml(MB)},
    [("j1", "revolute", "base", "ring", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
     ("j2", "revolute", "ring", "arm", (0, 0, 0), (0, 0, 0), (1, 0, 0)),
     ("rod", "fixed", "arm", "bob", (0, 0, -L), (0, 0, 0), None)]))


def gimbal_terms(q, v, Ia, Ib, Ic, m, d, I1):
    """M, C, g of the gimbal by hand.

    Body 2's inertia about the origin, in its axes: diag(A', B', C') = diag(A + m d², B, C + m d²) (parallel
    axis along y). T = ½ I1 q̇1² + ½ ω₂ᵀ diag(A', B', C') ω₂ = ½ (I1 + B' s2² + C' c2²) q̇1² + ½ A' q̇2², so
    M = diag(I1 + B' s2² + C' c2², A'), and the only non-zero derivative is ∂M11/∂q2 = (B' − C') sin 2q2 =: D.
    Christoffel C_ij = Σ_k ½(∂_k M_ij + ∂_j M_ik − ∂_i M_jk) q̇_k gives C11 = ½ D q̇2, C12 = ½ D q̇1,
    C21 = −½ D q̇1, C22 = 0. The CoM height is z = d s2 (z up), V = m g d s2, so g = [0, m g d c2].
    """
    Ap, Bp, Cp = Ia + m * d**2, Ib, Ic + m * d**2
    s2, c2 = np.sin(q[1]), np.cos(q[1])
    Dm = (Bp - Cp) * np.sin(2 * q[1])
    M = np.diag([I1 + Bp * s2**2 + Cp * c2**2, Ap])
    Cm = 0.5 * Dm * np.array([[v[1], v[0]], [-v[0], 0.0]])
    return M, Cm, np.array([0.0, m * G * d * c2])


@pytest.mark.parametrize("k", range(len(STATES)))
def test_gimbal_M_C_g(k):
    q, v = STATES[k]
    M, Cm, g = gimbal_terms(q, v, A, B, C, M2, D, I1)
    assert_close(md.mass_matrix(GIMBAL, q), M, 1e-15, "M")                                  # measured 1.4e-17
    assert_close(md.mass_matrix(GIMBAL, q, method="lagrange"), M, 1e-15, "M (Lagrange)")    # measured 4.2e-17
    assert_close(md.coriolis_matrix(GIMBAL, q, v), Cm, 1e-15, "C")                          # measured 2.8e-17
    assert_close(md.gravity_torques(GIMBAL, q), g, 1e-14, "g")                              # measured 3.9e-16
    a = np.random.default_rng(k).normal(0, 5, 2)
    assert_close(md.rnea(GIMBAL, q, v, a), M @ a + Cm @ v + g, 1e-14, "τ")                  # measured 3.7e-16


def pendulum_jacobians(q, v):
    """World-aligned and local J, J̇ of the bob frame (rows [linear; angular]), by hand.

    p = Rz(q1) Rx(q2) [0, 0, −L] = L [−s1 s2, c1 s2, −c2]. World: linear columns ∂p/∂q1 = L[−c1 s2, −s1 s2, 0],
    ∂p/∂q2 = L[−s1 c2, c1 c2, s2]; angular columns z and Rz(q1) x = [c1, s1, 0]; J̇ differentiates each entry
    in time. Local (bob axes = body 2's): the velocity is ω₂ × [0, 0, −L] = [−L s2 q̇1, L q̇2, 0], so the linear
    block is [[−L s2, 0], [0, L], [0, 0]] and the angular one [[0, 1], [s2, 0], [c2, 0]] (ω₂ above); J̇ again
    entry by entry.
    """
    s1, c1, s2, c2 = np.sin(q[0]), np.cos(q[0]), np.sin(q[1]), np.cos(q[1])
    d1, d2 = v
    Jw = np.array([[-L * c1 * s2, -L * s1 * c2], [-L * s1 * s2, L * c1 * c2], [0, L * s2],
                   [0, c1], [0, s1], [1, 0]])
    dJw = np.array([[L * (s1 * s2 * d1 - c1 * c2 * d2), L * (-c1 * c2 * d1 + s1 * s2 * d2)],
                    [L * (-c1 * s2 * d1 - s1 * c2 * d2), L * (-s1 * c2 * d1 - c1 * s2 * d2)],
                    [0, L * c2 * d2], [0, -s1 * d1], [0, c1 * d1], [0, 0]])
    Jl = np.array([[-L * s2, 0], [0, L], [0, 0], [0, 1], [s2, 0], [c2, 0]])
    dJl = np.array([[-L * c2 * d2, 0], [0, 0], [0, 0], [0, 0], [c2 * d2, 0], [-s2 * d2, 0]])
    return Jw, dJw, Jl, dJl


@pytest.mark.parametrize("k", range(len(STATES)))
def test_spherical_pendulum_M_C_g(k):
    # a point mass is the gimbal with A' = B' = m L², C' = 0 about the origin, and its CoM at −L on z:
    # M = diag(I1 + m L² s2², m L²), C as the gimbal's with B' − C' = m L², g = [0, m g L s2]
    q, v = STATES[k]
    Dm = MB * L**2 * np.sin(2 * q[1])
    M = np.diag([I1P + MB * L**2 * np.sin(q[1])**2, MB * L**2])
    Cm = 0.5 * Dm * np.array([[v[1], v[0]], [-v[0], 0.0]])
    g = np.array([0.0, MB * G * L * np.sin(q[1])])
    assert_close(md.mass_matrix(PENDULUM, q), M, 1e-15, "M")                                 # measured 5.6e-17
    assert_close(md.coriolis_matrix(PENDULUM, q, v), Cm, 1e-14, "C")                         # measured 1.9e-16
    assert_close(md.gravity_torques(PENDULUM, q), g, 1e-14, "g")                             # measured 4.0e-16


@pytest.mark.parametrize("k", range(len(STATES)))
def test_spherical_pendulum_jacobians(k):
    q, v = STATES[k]
    Jw, dJw, Jl, dJl = pendulum_jacobians(q, v)
    assert_close(md.frame_jacobian(PENDULUM, q, "bob"), Jw, 1e-14, "J world")                # measured 2.2e-16
    assert_close(md.frame_jacobian(PENDULUM, q, "bob", reference="local"), Jl, 1e-14, "J local")  # measured 2.2e-16
    assert_close(md.frame_jacobian_dot(PENDULUM, q, v, "bob"), dJw, 1e-14, "J̇ world")       # measured 3.7e-16
    assert_close(md.frame_jacobian_dot(PENDULUM, q, v, "bob", reference="local"), dJl, 1e-14, "J̇ local")  # measured 4.4e-16
