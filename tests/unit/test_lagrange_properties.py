"""Physical identities of Lagrange's equations on random states (RigidBodyDynamics.jl style)."""
import numpy as np
import pytest
from conftest import AAU, assert_close, inertial_xml, urdf, zoo_paths

import manipdyn as md
from manipdyn.dynamics.lagrange import mass_matrix_derivatives
from manipdyn.validation import random_states

PATHS = [AAU] + [p for p in zoo_paths() if p.name in ("baxter.urdf", "panda.urdf", "allegro_right_hand.urdf")]


@pytest.fixture(params=PATHS, ids=lambda p: p.stem)
def states(request):
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(request.param)
    return model, *random_states(model, 40, np.random.default_rng(11))


def test_mass_matrix_symmetric_positive_definite(states):
    model, Q, _, _ = states
    M = md.mass_matrix(model, Q)
    assert_close(M, np.swapaxes(M, 1, 2), 1e-15, "symmetry")  # measured 0 (symmetric by construction)
    assert np.all(np.linalg.eigvalsh(M)[:, 0] > 0)
    assert_close(md.mass_matrix(model, Q, method="lagrange"), M, 5e-14, "Lagrange route = CRBA")  # measured 1.0e-15


def test_Mdot_minus_2C_is_skew(states):
    # Ṁ = Σ_k ∂M/∂q_k q̇_k, exact; checked first against a central difference of M along q̇
    model, Q, V, _ = states
    Mdot = np.einsum("nkij,nk->nij", mass_matrix_derivatives(model, Q), V)
    h = 1e-6
    fd = (md.mass_matrix(model, Q + h * V) - md.mass_matrix(model, Q - h * V)) / (2 * h)
    assert_close(Mdot, fd, 5e-9, "Ṁ vs central difference")  # measured 1.1e-10 (central difference, h = 1e-6)
    N = Mdot - 2 * md.coriolis_matrix(model, Q, V)
    assert_close(N, -np.swapaxes(N, 1, 2), 1e-14, "Ṁ − 2C skew")  # measured 1.4e-16


def test_forward_routes_agree_and_invert_rnea(states):
    """Both routes invert rnea: without the joints' losses on τ itself, with them on τ plus the losses (damping ⊙ q̇
    + friction ⊙ tanh(q̇/ε), written out here: panda, allegro and baxter declare damping or friction)."""
    model, Q, V, A = states
    tau = md.rnea(model, Q, V, A)
    loss = np.asarray(model.damping) * V + np.asarray(model.friction) * np.tanh(V / md.model.FRICTION_EPS)
    cond = np.linalg.cond(md.mass_matrix(model, Q))
    # with losses, τ + loss − loss rounds relative to |loss|, which M⁻¹ carries into q̈: a second term, eps-sized
    # (measured ≤ 0.9e-16 × |loss| ‖M⁻¹‖ / max(|q̈|, 1) on allegro, whose losses are ~1e3 × its τ)
    carried = [np.abs(loss[s]).max() * np.linalg.norm(np.linalg.inv(M), 2) / max(np.abs(A[s]).max(), 1.0)
               for s, M in enumerate(md.mass_matrix(model, Q))]
    for method in ("aba", "cholesky"):
        for name, qdd, k in (("rigid", md.forward_dynamics(model, Q, V, tau, method=method, joint_dynamics=False), 0),
                             ("with losses", md.forward_dynamics(model, Q, V, tau + loss, method=method), 1)):
            for s in range(len(Q)):
                assert_close(qdd[s], A[s], 1e-14 * cond[s] + k * 5e-15 * carried[s],
                             f"{method} {name} inverts rnea")                        # measured 5.2e-16 × cond


def test_f_ext_in_forward_dynamics(states):
    # aba with f_ext must invert rnea with the same f_ext (both frames)
    model, Q, V, A = states
    frame = model.body_names[-1]
    rng = np.random.default_rng(5)
    fx = {frame: (rng.normal(size=3), rng.normal(size=3))}
    for ff in ("local", "world"):
        tau = md.rnea(model, Q, V, A, f_ext=fx, f_ext_frame=ff)
        qdd = md.aba(model, Q, V, tau, f_ext=fx, f_ext_frame=ff)
        cond = np.linalg.cond(md.mass_matrix(model, Q))
        worst = max(md.validation.error(qdd[s], A[s]) / cond[s] for s in range(len(Q)))
        # state by state, scaled by its cond(M): measured ≤ 1.5e-16 on the arms, 5.4e-14 on allegro (a 1 N wrench
        # on a 12 g fingertip, whose share of τ dwarfs M q̈: the error scales with it, not with q̈)
        tol = 1e-13 if model.name.startswith("allegro") else 2e-15
        assert worst <= tol, (ff, worst)


def test_lagrange_equals_newton_euler(states):
    model, Q, V, A = states
    M, C, g = md.mass_matrix(model, Q), md.coriolis_matrix(model, Q, V), md.gravity_torques(model, Q)
    lhs = np.einsum("nij,nj->ni", M, A) + np.einsum("nij,nj->ni", C, V) + g
    assert_close(lhs, md.rnea(model, Q, V, A), 2e-14, "M q̈ + C q̇ + g = τ")  # measured 4.1e-16


def test_singular_mass_matrix_names_the_joint():
    text = urdf({"base": "", "a": inertial_xml(1.0, (0, 0, 0.1), (0.1, 0.1, 0.1, 0, 0, 0)), "tip": ""},
                [("ja", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
                 ("jtip", "revolute", "a", "tip", (0, 0, 0.2), (0, 0, 0), (0, 1, 0))])
    model = md.load_urdf_string(text)
    with pytest.raises(md.SingularError, match="jtip"):
        md.aba(model, np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(md.SingularError):
        md.forward_dynamics(model, np.zeros(2), np.zeros(2), np.zeros(2), method="cholesky")


def test_romeo_fingers_make_forward_dynamics_raise():
    # romeo's finger joints carry only massless bodies: rnea works, forward dynamics must refuse
    import warnings
    from manipdyn.validation import robots_dir
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(robots_dir() / "romeo_description/urdf/romeo.urdf")
    q = np.zeros(model.nv)
    assert np.all(np.isfinite(md.rnea(model, q, q, q)))
    with pytest.raises(md.SingularError, match="mass matrix is singular"):
        md.aba(model, q, q, q)


def test_bad_method_and_reference():
    model = md.load_urdf(AAU)
    z = np.zeros(model.nv)
    with pytest.raises(md.InputError, match="method"):
        md.mass_matrix(model, z, method="newton")
    with pytest.raises(md.InputError, match="reference"):
        md.frame_jacobian(model, z, "tool", reference="LOCAL")
