"""Planar four-bar (urdf/fourbar.urdf) against its closed-form loop kinematics and reduced dynamics."""
import numpy as np
import pytest
from conftest import ROOT, assert_close

import manipdyn as md
from manipdyn.constraints import (assemble, complete_state, constrained_forward_dynamics,
                                  constrained_inverse_dynamics, rank_report, closure_terms)

MODEL = md.load_urdf(ROOT / "urdf" / "fourbar.urdf")
a, b, c, d = 0.1, 0.35, 0.3, 0.4


def e(t):      # unit vector of a link at angle t about +y, in (x, z): rotation takes x̂ to (cos t, −sin t)
    return np.array([np.cos(t), -np.sin(t)])


def closed_form_q(t1, branch):
    """Circle intersection (Freudenstein): the coupler-rocker pin C for crank angle t1, two branches ±1."""
    B, D = a * e(t1), np.array([d, 0.0])
    delta = D - B
    ell = np.linalg.norm(delta)
    x0 = (b**2 - c**2 + ell**2) / (2 * ell)
    h = np.sqrt(b**2 - x0**2)
    u = delta / ell
    C = B + x0 * u + branch * h * np.array([-u[1], u[0]])
    ang = lambda w: np.arctan2(-w[1], w[0])  # noqa: E731
    return np.array([t1, ang(C - B) - t1, ang(C - D)])


def loop_jacobian(q):
    """F_q and Ḟ_q q̇ of f(q) = a e(θ1) + b e(θ1 + θ2) − c e(θ3) − (d, 0), in closed form."""
    de = lambda t: np.array([-np.sin(t), -np.cos(t)])  # noqa: E731
    t12 = q[0] + q[1]
    return np.column_stack([a * de(q[0]) + b * de(t12), b * de(t12), -c * de(q[2])])


def loop_bias(q, v):
    t12 = q[0] + q[1]
    return -(a * e(q[0]) * v[0]**2 + b * e(t12) * (v[0] + v[1])**2 - c * e(q[2]) * v[2]**2)


def reduced(q, v1):
    """q̇ = N θ̇1 and q̈ = N θ̈1 + n0 from the closed-form loop."""
    F = loop_jacobian(q)
    N = np.r_[1.0, -np.linalg.solve(F[:, 1:], F[:, 0])]
    v = N * v1
    n0 = np.r_[0.0, -np.linalg.solve(F[:, 1:], loop_bias(q, v))]
    return N, v, n0


@pytest.mark.parametrize("t1", np.linspace(-3, 3, 7))
@pytest.mark.parametrize("branch", [1, -1])
def test_assembly_lands_on_the_closed_form_branch(t1, branch):
    exact = closed_form_q(t1, branch)
    guess = exact + np.array([0.0, 0.15, -0.1])
    asm = assemble(MODEL, guess)
    wrap = lambda x: (x + np.pi) % (2 * np.pi) - np.pi  # noqa: E731
    assert_close(wrap(asm.q - exact), np.zeros(3), 1e-14, "assembled q")  # measured 4.4e-16
    assert asm.residual <= 1e-12 and asm.same_branch


def test_rank_is_two_and_redundant_rows_are_named():
    q = closed_form_q(0.4, 1)
    _, J, _ = closure_terms(MODEL, q[None])
    rep = rank_report(MODEL, J[0])
    assert (rep.rank, rep.rows) == (2, 5)
    assert set(rep.redundant) == {"loop.y", "loop.r1", "loop.r2"}


@pytest.mark.parametrize("t1", np.linspace(-3, 3, 5))
def test_forward_dynamics_equals_reduced_closed_form(t1):
    q = closed_form_q(t1, 1)
    tau1, v1 = 0.7, 1.9
    N, v, n0 = reduced(q, v1)
    M, h = md.mass_matrix(MODEL, q), md.rnea(MODEL, q, v, np.zeros(3))
    # virtual work in the one independent coordinate: Nᵀ(M (N θ̈1 + n0) + h) = τ1
    t1dd = (tau1 - N @ (M @ n0 + h)) / (N @ M @ N)
    qdd_exact = N * t1dd + n0
    for baumgarte in (None, (5.0, 5.0)):   # on the manifold Baumgarte's extra terms vanish
        qdd, lam = constrained_forward_dynamics(MODEL, q, v, np.array([tau1, 0, 0]), baumgarte=baumgarte)
        assert_close(qdd, qdd_exact, 5e-14, "q̈")  # measured 1.8e-15
    # and the inverse: the crank torque that produces that motion
    ta, _ = constrained_inverse_dynamics(MODEL, q, v, qdd_exact)
    assert_close(ta, np.array([tau1]), 2e-14, "τ_crank")  # measured 7.8e-16


def test_complete_state_matches_closed_form_rates():
    q0 = closed_form_q(1.0, -1)
    q, v, acc, _ = complete_state(MODEL, q0 + [0, 0.05, 0.05], [1.3], [0.4])
    N, v_exact, n0 = reduced(q0, 1.3)
    assert_close(q, q0, 1e-12, "q")  # measured 5.6e-14
    assert_close(v, v_exact, 1e-12, "q̇")  # measured 1.3e-14
    assert_close(acc, N * 0.4 + n0, 1e-12, "q̈")  # measured 4.9e-14


def test_inverse_dynamics_refuses_inconsistent_states():
    q = closed_form_q(0.2, 1)
    with pytest.raises(md.ConstraintError, match="loop"):
        constrained_inverse_dynamics(MODEL, q + 0.01, np.zeros(3), np.zeros(3))
    with pytest.raises(md.ConstraintError, match="velocity"):
        constrained_inverse_dynamics(MODEL, q, np.array([1.0, 0, 0]), np.zeros(3))


def test_redundant_duplicate_closure_changes_nothing_but_the_rank():
    # the same loop declared twice: 10 rows of rank 2; q̈ must equal the single closure's and the
    # closed-form (non-redundant, reduced-coordinate) solution
    text = (ROOT / "urdf" / "fourbar.urdf").read_text()
    block = text[text.index("  <constraint"):text.index("</constraint>") + len("</constraint>")]
    twice = md.load_urdf_string(text.replace(block, block + "\n" + block.replace('name="loop"', 'name="loop_again"')))
    q = closed_form_q(0.9, 1)
    N, v, n0 = reduced(q, -1.2)
    tau = np.array([0.3, 0.0, 0.0])
    qdd1, _ = constrained_forward_dynamics(MODEL, q, v, tau)
    qdd2, lam2 = constrained_forward_dynamics(twice, q, v, tau)
    rep = rank_report(twice, closure_terms(twice, q)[1])
    with pytest.raises(TypeError, match="info"):    # one result type: the rank is rank_report's
        constrained_forward_dynamics(twice, q, v, tau, info=True)
    assert (rep.rank, rep.rows) == (2, 10)
    assert set(rep.redundant) >= {f"loop_again.{k}" for k in ("x", "y", "z", "r1", "r2")}
    assert_close(qdd2, qdd1, 1e-14, "duplicate closure")  # measured 0
    M, h = md.mass_matrix(MODEL, q), md.rnea(MODEL, q, v, np.zeros(3))
    t1dd = (tau[0] - N @ (M @ n0 + h)) / (N @ M @ N)
    assert_close(qdd2, N * t1dd + n0, 2e-14, "vs reduced closed form")  # measured 5.1e-16


def test_dead_point_is_detected_not_nan():
    # drive the rocker: at its extreme angle crank and coupler are collinear and the passive block of
    # the closure Jacobian is singular — assembly must say so (or damp and flag), never return NaN
    phi = np.arccos(((a + b)**2 + d**2 - c**2) / (2 * (a + b) * d))   # crank angle with A, B, C aligned
    C = (a + b) * e(phi)
    t3 = np.arctan2(-(C - [d, 0])[1], (C - [d, 0])[0])
    guess = np.array([phi + 0.05, 0.05, t3])
    with pytest.raises((md.SingularError, md.ConstraintError), match="singular|converge"):
        assemble(MODEL, guess, fixed=["j3_rocker"], max_cond=1e6)
    asm = assemble(MODEL, guess, fixed=["j3_rocker"], max_cond=1e4, damping=1e-6, max_iter=500)
    assert asm.damped and np.all(np.isfinite(asm.q)) and asm.cond > 1e4 and asm.residual <= 1e-12
    assert abs(asm.q[1]) < 1e-5          # it found the dead point: crank and coupler collinear
