"""Hard cases: singular configurations, unassemblable closures, long horizons, fast motions, float edges."""
import numpy as np
import pytest
from conftest import AAU, ROOT, assert_close

import manipdyn as md
from manipdyn.constraints import assemble, closure_terms, complete_state, constrained_forward_dynamics, rank_report
from manipdyn.examples import spm as S
from manipdyn.examples import spm_params as P
from manipdyn.examples.spm_urdf import tree_guess
from manipdyn.validation import random_states

ARM = md.load_urdf(AAU)
SPM = md.load_urdf(ROOT / "urdf" / "spm.urdf")


def test_spm_leg_singularity_which_formulation_survives():
    # at t* ≈ 0.281 s leg 2's (u₂ × v₂)·w₂ = 0: the chapter's J = B⁻¹A (Eq. 41) and j_ψ divide by it;
    # the generic constrained route keeps a well-conditioned closure Jacobian and finite, smooth torques
    leg, t_flip = S.singular_time()                                # first 1 ms sample past the sign change
    t = np.arange(0.0, t_flip - 1e-9, 1e-3)
    f = S.fig7(t)                                                   # followed at 1 ms up to the singularity
    print(f"\nleg {leg}: (u×v)·w = {f.leg_triple[-1, leg - 1]:.1e} at t = {t[-1]:.3f} s, cond(B) = "
          f"{f.cond_B[-1]:.1e} (the chapter's J = B⁻¹A divides by it), chapter torques {f.tau[-1]}")
    assert f.cond_B[-1] > 1e3                                      # detected by the condition number
    th, thd = f.q[-1, :3], f.qd[-1, :3]
    q, v, a, asm = complete_state(SPM, tree_guess(SPM, S.platform_rotation(f.q[-1, 3:]), th), thd, np.zeros(3))
    print(f"generic route at the same instant: assembly cond {asm.cond:.2f}, residual {asm.residual:.1e}")
    assert asm.cond < 100 and np.all(np.isfinite(v)) and np.all(np.isfinite(a))
    fx = {"platform": (np.zeros(3), P.MOMENT)}
    tau, _ = md.constraints.constrained_inverse_dynamics(SPM, q, v, a, f_ext=fx, f_ext_frame="world")
    assert np.all(np.isfinite(tau)) and np.abs(tau).max() < 10.0


def test_unassemblable_closure_is_refused():
    text = (ROOT / "urdf" / "fourbar.urdf").read_text()
    # the rocker's pin moved to 0.9 m: C would be ≥ 0.5 m from A, but crank + coupler reach 0.45 m
    short = md.load_urdf_string(text.replace('<child_origin xyz="0.3 0 0"', '<child_origin xyz="0.9 0 0"'))
    with pytest.raises(md.ConstraintError, match="did not converge.*loop"):
        assemble(short, [0.3, -1.3, -2.0], fixed=[])


def test_redundant_closure_rank_is_reported():
    q0 = tree_guess(SPM, S.platform_rotation(P.PHI0), np.radians(P.THETA0_FIRST_BRANCH_DEG))
    q, v, _, _ = complete_state(SPM, q0, P.THETA_DOT0, np.zeros(3))
    qdd, _ = constrained_forward_dynamics(SPM, q, v, np.zeros(SPM.nv))
    rep = rank_report(SPM, closure_terms(SPM, q)[1])
    assert np.all(np.isfinite(qdd))
    assert (rep.rank, rep.rows) == (4, 10) and len(rep.redundant) == 6


def test_long_horizon_torque_free_100s():
    # 100 s torque-free swing under gravity: energy drift per integrator (drift / max kinetic energy)
    q0, v0 = np.array([0.3, -0.5, 0.8, 0.2, -0.4]), np.array([0.5, -0.3, 0.2, 1.0, -0.5])
    out = {}
    for name, kw in (("rk4 dt 2 ms", dict(integrator="rk4", dt=2e-3)),
                     ("euler dt 0.5 ms", dict(integrator="euler", dt=5e-4)),
                     ("adaptive rtol 1e-10", dict(integrator="adaptive", rtol=1e-10, atol=1e-12))):
        r = md.simulate(ARM, q0, v0, (0, 100), **kw)
        E = md.kinetic_energy(ARM, r.q, r.v) + md.potential_energy(ARM, r.q)
        out[name] = np.abs(E - E[0]).max() / md.kinetic_energy(ARM, r.q, r.v).max()
    print("\n100 s energy drift:", {k: f"{v:.1e}" for k, v in out.items()})
    assert out["adaptive rtol 1e-10"] < 5e-9 and out["rk4 dt 2 ms"] < 1e-4   # measured 1.3e-10, 1.4e-5
    assert out["euler dt 0.5 ms"] < 1.0            # measured 0.40; symplectic: bounded, no secular blow-up over 100 s


def test_fast_motion_50_rad_per_s():
    rng = np.random.default_rng(4)
    Q = rng.uniform(-np.pi, np.pi, (20, ARM.nv))
    V = rng.choice([-50.0, 50.0], (20, ARM.nv))
    A = rng.normal(0, 5, (20, ARM.nv))
    tau = md.rnea(ARM, Q, V, A)
    M, C, g = md.mass_matrix(ARM, Q), md.coriolis_matrix(ARM, Q, V), md.gravity_torques(ARM, Q)
    assert_close(np.einsum("nij,nj->ni", M, A) + np.einsum("nij,nj->ni", C, V) + g, tau, 1e-14, "50 rad/s")  # measured 4.1e-16
    assert_close(md.aba(ARM, Q, V, tau), A, 1e-13 * np.linalg.cond(M).max(), "aba at 50 rad/s")  # measured 4.7e-15 × cond


def test_float_edge_cases():
    Q, V, A = random_states(ARM, 5, np.random.default_rng(5))
    tau = md.rnea(ARM, Q, V, A)
    # angles far beyond 2π: the same configuration (to the rounding of q itself, ~1e-11 rad here)
    assert_close(md.rnea(ARM, Q + 2 * np.pi * 1e4, V, A), tau, 1e-10, "q + 2π·1e4")  # measured 4.0e-12
    # without gravity τ = M q̈ + C(q, q̇) q̇ is exactly homogeneous: tiny and huge values scale through
    free = md.load_urdf(AAU, gravity=(0.0, 0.0, 0.0))
    for s in (1e-150, 1e150):
        assert_close(md.rnea(free, Q, 0 * V, s * A) / s, md.rnea(free, Q, 0 * V, A), 1e-14, f"q̈ × {s:g}")  # measured 1.8e-16
        assert_close(md.rnea(free, Q, s * V, 0 * A) / s**2 if s < 1 else md.rnea(free, Q, np.sqrt(s) * V, 0 * A) / s,
                     md.rnea(free, Q, V, 0 * A), 1e-14, "q̇ scaled")  # measured 7.6e-16
    with pytest.raises(md.InputError, match="inf"):
        md.rnea(ARM, Q, np.full_like(V, np.inf), A)               # non-finite input is refused, named


def test_elbow_singularity_is_detected_and_damped():
    from manipdyn.examples import aau_arm as ex
    q0 = ex.initial_configuration(ARM)
    _, p0 = md.frame_placement(ARM, q0, "tool")
    shoulder = md.frame_placement(ARM, np.zeros(ARM.nv), "link2")[1]
    goal = p0 + 0.8 * (p0 - shoulder) / np.linalg.norm(p0 - shoulder)     # straight out, beyond reach
    tr = ex.singular_path(ARM, q0, goal=goal)
    i = int(np.argmin(tr.sigma_min))
    print(f"\nelbow: σ_min {tr.sigma_min[i]:.1e} at t = {tr.t[i]:.2f} s, damped samples {tr.damped.sum()}, "
          f"max |q̇| {np.abs(tr.v).max():.2f} rad/s, final pose error {tr.pos_err[-1]:.3f} m (goal out of reach)")
    assert np.all(np.isfinite(tr.v)) and np.all(np.isfinite(tr.a))
    assert tr.damped.any() and tr.sigma_min.min() < 0.05 and np.abs(tr.v).max() < 10.0
    assert tr.pos_err[:np.argmax(tr.damped)].max() < 1e-9


def test_constrained_inverse_dynamics_says_how_actuated():
    from manipdyn.constraints import actuation_status, constrained_inverse_dynamics
    q0 = tree_guess(SPM, S.platform_rotation(P.PHI0), np.radians(P.THETA0_FIRST_BRANCH_DEG))
    q, v, a, _ = complete_state(SPM, q0, P.THETA_DOT0, np.zeros(3))
    over = ["leg1_theta", "leg2_theta", "leg3_theta", "leg1_psi"]
    assert len(constrained_inverse_dynamics(SPM, q, v, a)[0]) == 3 and actuation_status(SPM, q) == "fully"
    assert len(constrained_inverse_dynamics(SPM, q, v, a, actuated=over)[0]) == 4
    assert actuation_status(SPM, q, over) == "over"
    with pytest.raises(TypeError, match="info"):    # one result type: the status is its own function
        constrained_inverse_dynamics(SPM, q, v, a, info=True)
