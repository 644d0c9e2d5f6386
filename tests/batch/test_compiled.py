"""manipdyn.compiled: the dynamics called from inside a user's own numba.njit code. Each compiled call gives the
public one-state call's numbers to the last bit (the same kernels), a rollout of 10⁴ steps in compiled code gives
the trajectory of the same loop of public calls, and a failing status turns into the public call's typed error."""
import dataclasses
import warnings

import numba
import numpy as np
import pytest

from conftest import AAU, ROOT, free_flyer_model

import manipdyn as md
from manipdyn import compiled
from manipdyn.errors import InputError, NumericalError, SingularError
from manipdyn.validation import random_states
from manipdyn.validation.zoo import robots_dir

SOLO12 = "solo_description/robots/solo12.urdf"

pytestmark = pytest.mark.skipif(md._jit.NOJIT, reason="numba.njit callers need the compiled kernels")


def _models():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {"aau_arm": md.load_urdf(AAU), "solo12_free_flyer": free_flyer_model((robots_dir() / SOLO12).read_text()),
                "humanoid_ball": md.load_mjcf(ROOT / "tests" / "data" / "humanoid_ball.xml")}


MODELS = _models()


@numba.njit
def every_call(I, F, Q, V, A, tau, h, g, M, qdd, nxt):
    """Each compiled call on each state (rows of Q, V, A); the worst status."""
    worst = compiled.OK
    for s in range(Q.shape[0]):
        for status in (compiled.rnea(I, F, Q[s], V[s], A[s], tau[s]),
                       compiled.nonlinear_effects(I, F, Q[s], V[s], h[s]),
                       compiled.gravity_torques(I, F, Q[s], g[s]), compiled.mass_matrix(I, F, Q[s], M[s]),
                       compiled.aba(I, F, Q[s], V[s], A[s], qdd[s]), compiled.integrate(I, Q[s], V[s], nxt[s])):
            worst = max(worst, status)
    return worst


@pytest.mark.parametrize("name", sorted(MODELS))
def test_compiled_calls_give_the_public_calls_numbers(name):
    model = MODELS[name]
    Q, V, A = random_states(model, 20, np.random.default_rng(3))
    n, nv = Q.shape[0], model.nv
    tau, h, g, qdd, M, nxt = *(np.empty((n, nv)) for _ in range(4)), np.empty((n, nv, nv)), np.empty_like(Q)
    assert every_call(*compiled.arrays(model), Q, V[:, ::1], A, tau, h, g, M, qdd, nxt) == compiled.OK
    for s in range(n):                                   # the public one-state calls, bit for bit
        q, v, a = Q[s], V[s], A[s]
        assert np.array_equal(tau[s], md.rnea(model, q, v, a))
        assert np.array_equal(h[s], md.nonlinear_effects(model, q, v))
        assert np.array_equal(g[s], md.gravity_torques(model, q))
        assert np.array_equal(M[s], md.mass_matrix(model, q))
        assert np.array_equal(qdd[s], md.aba(model, q, v, a))
        assert np.array_equal(nxt[s], md.integrate(model, q, v))


@numba.njit
def rollout(I, F, q, v, tau, dt, steps, Q):
    """The docs' example: semi-implicit Euler, q̈ by the ABA, q ⊕ dt v; (steps done, status)."""
    qdd, dq, nxt = np.empty(v.shape[0]), np.empty(v.shape[0]), np.empty(q.shape[0])
    for k in range(steps):
        status = compiled.aba(I, F, q, v, tau, qdd)
        if status != compiled.OK:
            return k, status
        for i in range(v.shape[0]):
            v[i] += dt * qdd[i]
            dq[i] = dt * v[i]
        compiled.integrate(I, q, dq, nxt)
        q[:] = nxt
        Q[k] = q
    return steps, compiled.OK


@pytest.mark.parametrize("name", ["aau_arm", "solo12_free_flyer"])
def test_a_rollout_of_ten_thousand_steps_is_the_public_loops(name):
    """Ten seconds of a passive fall (τ = 0) from a random state, in compiled code and as a loop of public calls."""
    model, steps, dt = MODELS[name], 10_000, 1e-3
    Q0, V0, _ = random_states(model, 1, np.random.default_rng(4))
    tau, Q = np.zeros(model.nv), np.empty((steps, model.nq))
    assert rollout(*compiled.arrays(model), Q0[0].copy(), V0[0].copy(), tau, dt, steps, Q) == (steps, compiled.OK)
    q, v = Q0[0], V0[0]
    for k in range(0, steps):                            # the same loop of public calls
        v = v + dt * md.aba(model, q, v, tau)
        q = md.integrate(model, q, dt * v)
        if k % 997 == 0 or k == steps - 1:
            assert np.array_equal(Q[k], q), k
    if name == "solo12_free_flyer":                      # the base's quaternion stays a unit one
        assert abs(np.linalg.norm(Q[-1, 3:7]) - 1.0) < 1e-12


def test_a_failing_status_is_the_public_calls_error():
    model = MODELS["aau_arm"]
    I, F = compiled.arrays(model)
    q, v, tau = md.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
    q[2] = np.nan
    k, status = rollout(I, F, q, v, tau, 1e-3, 3, np.empty((3, model.nq)))
    assert k == 0 and status != compiled.OK
    with pytest.raises(InputError, match=r"q\[2\] \(joint 'joint3'\) is nan"):
        compiled.check(model, "aba", status, q, v, tau)
    compiled.check(model, "aba", compiled.OK, q, v, tau)          # OK: nothing to raise
    Q0, V0, T = random_states(model, 1, np.random.default_rng(4))  # random torques: explicit Euler diverges
    q, v = Q0[0].copy(), V0[0].copy()
    k, status = rollout(I, F, q, v, T[0], 1e-3, 10_000, np.empty((10_000, model.nq)))
    assert 0 < k < 10_000 and status != compiled.OK                # (q, v: the state of the failing step)
    with pytest.raises(NumericalError, match=r"aba: the result q̈\[\d\] \(joint 'joint\d'\) is (nan|-?inf)"):
        compiled.check(model, "aba", status, q, v, T[0])
    massless = dataclasses.replace(model, mass=np.zeros(model.njoints), inertia=np.zeros((model.njoints, 3, 3)))
    qdd, q0, v = np.empty(model.nv), md.neutral(model), np.zeros(model.nv)
    status = compiled.aba(*compiled.arrays(massless), q0, v, v, qdd)
    assert status != compiled.OK
    with pytest.raises(SingularError, match="moves a subtree without mass"):
        compiled.check(massless, "aba", status, q0, v, v)


def test_arrays_and_shapes_are_checked_in_python():
    model = MODELS["aau_arm"]
    I, F = compiled.arrays(model)
    assert I.flags.writeable and F.flags.writeable and I.flags.c_contiguous and I.dtype == np.int64
    assert not np.shares_memory(I, model.kernel.lane_arrays[0])
    compiled.check_shapes(model, "aba", md.neutral(model), np.zeros(model.nv), np.zeros(model.nv), np.zeros(model.nv))
    with pytest.raises(InputError, match=r"compiled.aba: qdd must be a float64 array of shape \(5,\), not float64 \(4,\)"):
        compiled.check_shapes(model, "aba", md.neutral(model), np.zeros(5), np.zeros(5), np.zeros(4))
    with pytest.raises(InputError, match="takes q, M: 2 arrays, not 1"):
        compiled.check_shapes(model, "mass_matrix", md.neutral(model))
    with pytest.raises(InputError, match="no compiled call 'crba'"):
        compiled.check_shapes(model, "crba", md.neutral(model))
    with pytest.raises(InputError, match="expected a manipdyn Model, got str"):
        compiled.arrays("aau_arm.urdf")


@numba.njit
def frame_calls(I, F, Q, V, A, f, n, W, X, XL, tau, qdd, R, p, J, JL, E):
    """The wrench, frame and energy calls on each state; the worst status (E[s] = T, V)."""
    worst = compiled.OK
    for s in range(Q.shape[0]):
        for status in (compiled.rnea_fext(I, F, Q[s], V[s], A[s], f, n, W, tau[s]),
                       compiled.aba_fext(I, F, Q[s], V[s], A[s], f, n, W, qdd[s]),
                       compiled.frame_placement(I, F, Q[s], X, R[s], p[s]),
                       compiled.frame_jacobian(I, F, Q[s], X, J[s]), compiled.frame_jacobian(I, F, Q[s], XL, JL[s])):
            worst = max(worst, status)
        E[s, 0], E[s, 1] = compiled.kinetic_energy(I, F, Q[s], V[s]), compiled.potential_energy(I, F, Q[s])
    return worst


@pytest.mark.parametrize("f_ext_frame", ["local", "world"])
@pytest.mark.parametrize("name", sorted(MODELS))
def test_wrench_frame_and_energy_calls_give_the_public_calls_numbers(name, f_ext_frame):
    """With one wrench: the public calls' numbers to the last bit (the same kernels, the same wrench row); the frame
    calls and energies run in the arrays' z-aligned body frames: the public numbers to rounding."""
    model = MODELS[name]
    Q, V, A = random_states(model, 10, np.random.default_rng(5))
    n_, nv, frame = Q.shape[0], model.nv, model.body_names[-1]
    f, n = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.4])
    tau, qdd = np.empty((n_, nv)), np.empty((n_, nv))
    R, p, J, JL, E = np.empty((n_, 3, 3)), np.empty((n_, 3)), np.empty((n_, 6, nv)), np.empty((n_, 6, nv)), np.empty((n_, 2))
    rows = compiled.wrench_row(model, frame, f_ext_frame), compiled.frame_row(model, frame), \
        compiled.frame_row(model, frame, "local")
    assert frame_calls(*compiled.arrays(model), Q, V, A, f, n, *rows, tau, qdd, R, p, J, JL, E) == compiled.OK
    for s in range(n_):
        q, v, a, wrench = Q[s], V[s], A[s], {frame: (f, n)}
        assert np.array_equal(tau[s], md.rnea(model, q, v, a, f_ext=wrench, f_ext_frame=f_ext_frame))
        assert np.array_equal(qdd[s], md.aba(model, q, v, a, f_ext=wrench, f_ext_frame=f_ext_frame))
        R0, p0 = md.frame_placement(model, q, frame)
        assert np.allclose(R[s], R0, rtol=0, atol=1e-14) and np.allclose(p[s], p0, rtol=0, atol=1e-14)
        for got, reference in ((J[s], "local_world_aligned"), (JL[s], "local")):
            want = md.frame_jacobian(model, q, frame, reference)
            assert np.allclose(got, want, rtol=0, atol=1e-14 * max(1.0, np.abs(want).max()))
        T, Vp = md.kinetic_energy(model, q, v), md.potential_energy(model, q)
        assert abs(E[s, 0] - T) <= 1e-13 * max(1.0, abs(T)) and abs(E[s, 1] - Vp) <= 1e-13 * max(1.0, abs(Vp))


def test_wrench_and_frame_calls_name_their_faults():
    model = MODELS["aau_arm"]
    I, F = compiled.arrays(model)
    frame, q, v = model.body_names[-1], md.neutral(model), np.zeros(model.nv)
    f, n, tau, J = np.array([np.inf, 0.0, 0.0]), np.zeros(3), np.empty(model.nv), np.empty((6, model.nv))
    status = compiled.rnea_fext(I, F, q, v, v, f, n, compiled.wrench_row(model, frame), tau)
    assert status != compiled.OK
    with pytest.raises(InputError, match=r"f_ext\['" + frame + r"'\]"):
        compiled.check(model, "rnea_fext", status, q, v, v, f, n, frame=frame)
    q[1] = np.nan
    status = compiled.frame_jacobian(I, F, q, compiled.frame_row(model, frame), J)
    with pytest.raises(InputError, match=r"q\[1\] \(joint 'joint2'\) is nan"):
        compiled.check(model, "frame_jacobian", status, q, frame=frame)
    assert np.isnan(compiled.potential_energy(I, F, q))
    with pytest.raises(InputError, match="needs frame="):
        compiled.check(model, "frame_jacobian", status, q)
    with pytest.raises(InputError, match="has no link or frame named 'no_such_link'; closest: "):
        compiled.frame_row(model, "no_such_link")
    with pytest.raises(InputError, match="f_ext_frame must be 'local' or 'world'"):
        compiled.wrench_row(model, frame, "body")
    compiled.check_shapes(model, "frame_jacobian", md.neutral(model), np.zeros((6, model.nv)))
    with pytest.raises(InputError, match=r"compiled.rnea_fext: n must be a float64 array of shape \(3,\)"):
        compiled.check_shapes(model, "rnea_fext", md.neutral(model), v, v, np.zeros(3), np.zeros(4), v)


@numba.njit
def derivative_calls(I, F, Q, V, A, Dr, Da, qdd):
    """rnea_derivatives and aba_derivatives on each state into Dr[s], Da[s] (3, nv, nv); the worst status."""
    worst = compiled.OK
    for s in range(Q.shape[0]):
        worst = max(worst, compiled.rnea_derivatives(I, F, Q[s], V[s], A[s], Dr[s, 0], Dr[s, 1], Dr[s, 2]))
        worst = max(worst, compiled.aba_derivatives(I, F, Q[s], V[s], A[s], qdd[s], Da[s, 0], Da[s, 1], Da[s, 2]))
    return worst


@pytest.mark.parametrize("name", sorted(MODELS))
def test_derivative_calls_give_the_public_calls_numbers(name):
    """The derivatives run on the arrays' z-aligned body frames: the public calls' numbers to rounding; q̈ of
    aba_derivatives is the public aba's to the last bit (the same one-state ABA)."""
    model = MODELS[name]
    Q, V, A = random_states(model, 5, np.random.default_rng(6))
    n, nv = Q.shape[0], model.nv
    Dr, Da, qdd = np.empty((n, 3, nv, nv)), np.empty((n, 3, nv, nv)), np.empty((n, nv))
    assert derivative_calls(*compiled.arrays(model), Q, V, A, Dr, Da, qdd) == compiled.OK
    for s in range(n):
        q, v, a = Q[s], V[s], A[s]
        assert np.array_equal(qdd[s], md.aba(model, q, v, a))
        for got, want in zip([*Dr[s], *Da[s]], [*md.rnea_derivatives(model, q, v, a), *md.aba_derivatives(model, q, v, a)]):
            assert np.allclose(got, want, rtol=0, atol=1e-12 * max(1.0, np.abs(want).max()))


@numba.njit
def sized_calls(I, F, q, v, a, tau, M, W, X, R, p, J, D):
    """Every compiled call on the given arrays: their statuses (the energies: 0 finite, 1 NaN)."""
    return (compiled.rnea(I, F, q, v, a, tau), compiled.nonlinear_effects(I, F, q, v, tau),
            compiled.gravity_torques(I, F, q, tau), compiled.mass_matrix(I, F, q, M), compiled.aba(I, F, q, v, a, tau),
            compiled.integrate(I, q, v, q.copy()), compiled.rnea_fext(I, F, q, v, a, p, p, W, tau),
            compiled.aba_fext(I, F, q, v, a, p, p, W, tau), compiled.frame_placement(I, F, q, X, R, p),
            compiled.frame_jacobian(I, F, q, X, J), compiled.rnea_derivatives(I, F, q, v, a, D[0], D[1], D[2]),
            compiled.aba_derivatives(I, F, q, v, a, tau, D[0], D[1], D[2]), int(np.isnan(compiled.kinetic_energy(I, F, q, v))),
            int(np.isnan(compiled.potential_energy(I, F, q))))


def test_arrays_of_other_sizes_are_refused_before_they_are_read():
    """A state, a result, a frame's or a wrench's row of another size: WRONG_SIZES (NaN for an energy) from every
    compiled call, before the kernel reads past an array's end; check names the array."""
    model = MODELS["solo12_free_flyer"]
    I, F = compiled.arrays(model)
    frame, nv = model.body_names[-1], model.nv
    q, v = md.neutral(model), np.zeros(nv)
    W, X = compiled.wrench_row(model, frame), compiled.frame_row(model, frame)
    good = dict(q=q, v=v, a=v, tau=np.empty(nv), M=np.empty((nv, nv)), W=W, X=X, R=np.empty((3, 3)), p=np.zeros(3),
                J=np.empty((6, nv)), D=np.empty((3, nv, nv)))
    assert sized_calls(I, F, *good.values()) == (compiled.OK,) * 12 + (0, 0)
    bad_body = X.copy()
    bad_body[4, 0] = model.njoints                          # a body the model does not have
    for name, x in (("q", q[:-1]), ("v", np.zeros(nv + 1)), ("tau", np.empty(nv - 1)), ("X", bad_body),
                    ("W", W[:13]), ("D", np.empty((3, nv, nv - 1)))):
        statuses = sized_calls(I, F, *{**good, name: x}.values())
        users = {"q": range(14), "v": (0, 1, 4, 5, 6, 7, 10, 11, 12), "tau": (0, 1, 2, 4, 6, 7, 11),
                 "X": (8, 9), "W": (6, 7), "D": (10, 11)}[name]
        for k, status in enumerate(statuses):
            want = (1 if k >= 12 else compiled.WRONG_SIZES) if k in users else (0 if k >= 12 else compiled.OK)
            assert status == want, (name, k, status)
    tau = np.empty(nv - 1)
    status = compiled.rnea(I, F, q, v, v, tau)
    with pytest.raises(InputError, match="an array is not of the model's sizes"):
        compiled.check(model, "rnea", status, q, v, v)
    with pytest.raises(InputError, match=rf"^v has shape \({nv - 1},\)"):
        compiled.check(model, "rnea", status, q, v[:-1], v)
