"""simulate checks its step, span, torques and tolerances before work, and bounds the work: a step budget,
bounds on |q| and |q̇|, and a budget of adaptive steps, all ending in a named error."""
import numpy as np
import pytest
from conftest import AAU, assert_close

import manipdyn as md
from manipdyn.dynamics.aba import aba

ARM = md.load_urdf(AAU)
N5 = ARM.nv
Z = np.zeros(N5)
Q0 = np.array([0.3, -0.4, 0.5, 0.2, -0.1])


@pytest.mark.parametrize("dt,match", [
    (0.0, "dt is 0.0; it must be > 0"), (-1e-3, "dt is -0.001; it must be > 0"), (np.nan, "dt is nan"),
    (np.inf, "dt is inf"), (1e-15, r"needs 1e\+15 steps, more than max_steps"), ("1e-3", "dt must be a real number"),
    (None, "dt must be a real number"), (True, "dt must be a real number"), (1e-3 + 0j, "dt must be a real number"),
], ids=["zero", "negative", "nan", "inf", "1e-15", "string", "None", "bool", "complex"])
def test_bad_dt(dt, match):
    with pytest.raises(md.InputError, match=match):
        md.simulate(ARM, Z, Z, (0, 1), dt=dt)


@pytest.mark.parametrize("span,match", [
    ((0, np.inf), r"t_span\[1\] is inf"), ((0, np.nan), r"t_span\[1\] is nan"), ((-np.inf, 0), r"t_span\[0\] is -inf"),
    ((1, 0), "end must come after the start"), ((1, 1), "end must come after the start"),
    ((0,), "t_span must be a pair"), ((0, 1, 2), "t_span must be a pair"), (None, "t_span must be a pair"),
    ((0, 1e300), "more than max_steps"), ((1e17, 1e17 + 100), "below the resolution of t"),
], ids=["inf", "nan", "-inf_start", "reversed", "empty", "one", "three", "None", "huge", "t_resolution"])
def test_bad_span(span, match):
    with pytest.raises(md.InputError, match=match):
        md.simulate(ARM, Z, Z, span, dt=1.0 if span == (1e17, 1e17 + 100) else 1e-3)


def test_max_steps_is_the_fixed_step_budget():
    with pytest.raises(md.InputError, match="needs 1e\\+03 steps, more than max_steps = 100"):
        md.simulate(ARM, Z, Z, (0, 1), dt=1e-3, max_steps=100)
    assert md.simulate(ARM, Z, Z, (0, 0.1), dt=1e-3, max_steps=100).n_steps == 100


@pytest.mark.parametrize("integrator", ["adaptive", "rk4", "euler"])
@pytest.mark.parametrize("torque", [1e3, 1e6, 1e12, 1e100], ids=["1e3", "1e6", "1e12", "1e100"])
def test_huge_torque_ends_in_divergence_error(integrator, torque):
    # runaway: |q̇| passes max_rate (1e4) within a few steps, or an intermediate overflows
    with pytest.raises(md.DivergenceError, match=r"diverged at t = "):
        md.simulate(ARM, Z, Z, (0, 10), tau=np.full(N5, torque), integrator=integrator)


def test_adaptive_step_budget():
    with pytest.raises(md.DivergenceError, match=r"did not reach t = 1 s within max_steps = 5 adaptive steps"):
        md.simulate(ARM, Q0, Z, (0, 1), integrator="adaptive", max_steps=5)


def test_state_bounds_name_the_joint_and_row():
    V = np.zeros((3, N5))
    V[1, 2] = 50.0
    with pytest.raises(md.DivergenceError, match=r"\(initial state 1\): v\['joint3'\] = .* exceeds max_rate = 60"):
        md.simulate(ARM, np.zeros((3, N5)), V, (0, 1), tau=np.r_[0, 0, 50.0, 0, 0], max_rate=60)
    with pytest.raises(md.InputError, match=r"initial state: q\['joint1'\] = 2e\+06 exceeds max_position"):
        md.simulate(ARM, np.r_[2e6, 0, 0, 0, 0], Z, (0, 1))


@pytest.mark.parametrize("tau,match", [
    (lambda t, q, v: np.zeros(3), r"returned shape \(3,\) at t = 0 s; expected \(5,\)"),
    (lambda t, q, v: np.full(5, np.nan), r"returned nan at t = 0 s, joint 'joint1'"),
    (lambda t, q, v: "torque", "tau\\(t, q, v\\) at t = 0 s: cannot be read"),
    (lambda t, q, v: None, "tau\\(t, q, v\\) at t = 0 s is None"),
    (lambda t, q, v: np.zeros(5) + 1j, "complex"),
    (np.zeros(3), r"tau has shape \(3,\)"),
    (np.full(5, np.inf), r"tau\[0\] is inf"),
    ("abc", "tau: cannot be read"),
], ids=["callable_shape", "callable_nan", "callable_string", "callable_None", "callable_complex",
        "const_shape", "const_inf", "const_string"])
def test_bad_torque(tau, match):
    with pytest.raises(md.InputError, match=match):
        md.simulate(ARM, Z, Z, (0, 0.01), tau=tau)


def test_torque_shape_error_later_in_the_run_is_still_an_input_error():
    with pytest.raises(md.InputError, match=r"returned shape \(4,\) at t = 0.04"):
        md.simulate(ARM, Z, Z, (0, 0.1), dt=1e-2, tau=lambda t, q, v: np.zeros(4 if t > 0.04 else 5))


@pytest.mark.parametrize("kw,match", [
    (dict(integrator="rk5"), "integrator must be"), (dict(method="lu"), "method must be 'aba' or 'cholesky'"),
    (dict(stabilization="x"), "stabilization must be"), (dict(integrator="adaptive", rtol=-1.0), "rtol is -1.0"),
    (dict(integrator="adaptive", atol=np.nan), "atol is nan"), (dict(max_steps=0), "max_steps is 0"),
    (dict(max_rate=np.inf), "max_rate is inf"),
], ids=["integrator", "method", "stabilization", "rtol", "atol", "max_steps", "max_rate"])
def test_bad_options(kw, match):
    with pytest.raises(md.InputError, match=match):
        md.simulate(ARM, Z, Z, (0, 0.01), **kw)


@pytest.mark.parametrize("name", ["euler", "rk4", "adaptive"])
def test_integrator_name_as_method_points_to_integrator(name):
    # method= is the forward-dynamics route ("aba", "cholesky"); the integrator is integrator=
    with pytest.raises(md.InputError, match=f"use integrator='{name}'"):
        md.simulate(ARM, Z, Z, (0, 0.01), method=name)


def test_adaptive_stepping_matches_solve_ivp():
    # independent reference: scipy's own driver on the same right-hand side (same DOP853 steps); measured 0
    from scipy.integrate import solve_ivp
    r = md.simulate(ARM, Q0, Z, (0, 0.2), integrator="adaptive", rtol=1e-10, atol=1e-12)
    sol = solve_ivp(lambda t, x: np.r_[x[N5:], aba(ARM, x[:N5], x[N5:], Z)], (0, 0.2), np.r_[Q0, Z],
                    method="DOP853", rtol=1e-10, atol=1e-12)
    assert r.t.shape == sol.t.shape
    assert_close(r.q, sol.y[:N5].T, 1e-14, "q")
    assert_close(r.v, sol.y[N5:].T, 1e-14, "v")
