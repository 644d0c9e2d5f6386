"""A batch spread over threads (dynamics/route.py: ``threads=``): the same numbers as one thread, bit for bit
(each state is computed by the same compiled code, whatever chunk it falls in), checked against Pinocchio
row by row on a few rows of every chunk; the errors of a chunk name the row of the whole batch; bad thread
counts are refused by name. (Speed on every core: the bench's throughput rows and their target.)"""

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, aau_states, inertial_xml, urdf

import manipdyn as md
from manipdyn.dynamics import route
from manipdyn.validation.reference import Reference

N = 1000           # 4 threads: 4 chunks of 250 rows (route.MIN_CHUNK = 128)


@pytest.fixture(scope="module")
def arm():
    return aau_states(N, 7)


def _calls(model):
    tip = model.body_names[-1]
    W = {tip: (np.ones((N, 3)), np.linspace(-1, 1, 3 * N).reshape(N, 3))}
    return {
        "rnea": lambda Q, V, A, **k: md.rnea(model, Q, V, A, **k),
        "rnea f_ext local": lambda Q, V, A, **k: md.rnea(model, Q, V, A, f_ext=W, **k),
        "rnea f_ext world": lambda Q, V, A, **k: md.rnea(model, Q, V, A, f_ext=W, f_ext_frame="world", **k),
        "nonlinear_effects": lambda Q, V, A, **k: md.nonlinear_effects(model, Q, V, **k),
        "gravity_torques": lambda Q, V, A, **k: md.gravity_torques(model, Q, **k),
        "aba": lambda Q, V, A, **k: md.aba(model, Q, V, A, **k),
        "aba f_ext": lambda Q, V, A, **k: md.aba(model, Q, V, A, f_ext=W, **k),
        "forward_dynamics cholesky": lambda Q, V, A, **k: md.forward_dynamics(model, Q, V, A, method="cholesky", **k),
        "mass_matrix": lambda Q, V, A, **k: md.mass_matrix(model, Q, **k),
        "coriolis_matrix": lambda Q, V, A, **k: md.coriolis_matrix(model, Q, V, **k),
        "joint_torque_regressor": lambda Q, V, A, **k: md.joint_torque_regressor(model, Q, V, A, **k),
        "rnea_derivatives": lambda Q, V, A, **k: md.rnea_derivatives(model, Q, V, A, f_ext=W, **k),
        "aba_derivatives": lambda Q, V, A, **k: md.aba_derivatives(model, Q, V, A, **k),
    }


def test_chunks_cover_the_batch_in_order():
    c = route.CALLER_SHARE
    for N, threads in ((1000, 4), (1001, 3), (10_000, 2), (5 * route.MIN_CHUNK, 64), (10**6, 7)):
        parts = route.chunks(N, threads)
        n = min(threads, N // route.MIN_CHUNK)
        assert len(parts) == n and parts[0][0] == 0 and parts[-1][1] == N, (N, threads)
        assert all(b == a2 for (_, b), (a2, _) in zip(parts, parts[1:]))                  # contiguous, in order
        sizes = [b - a for a, b in parts]
        assert abs(sizes[0] - N * c / (n - 1 + c)) <= 0.5                       # the caller's: CALLER_SHARE × …
        assert max(sizes[1:]) - min(sizes[1:]) <= 1                             # … the workers' equal chunks
    assert route.chunks(2 * route.MIN_CHUNK - 1, 8) == [(0, 2 * route.MIN_CHUNK - 1)]   # too few rows to split
    assert route.chunks(10_000, 1) == [(0, 10_000)]
    assert route.chunks(10_000, 2) == [(0, 5146), (5146, 10_000)]                 # 1.06 : 1


@pytest.mark.parametrize("name", ["rnea", "rnea f_ext local", "rnea f_ext world", "nonlinear_effects",
                                  "gravity_torques", "aba", "aba f_ext", "forward_dynamics cholesky", "mass_matrix",
                                  "coriolis_matrix", "joint_torque_regressor", "rnea_derivatives",
                                  "aba_derivatives"])
def test_threads_give_one_threads_numbers(arm, name):
    model, Q, V, A = arm
    f = _calls(model)[name]
    one = f(Q, V, A, threads=1)
    for threads in (2, 4, 7, None):
        assert np.array_equal(f(Q, V, A, threads=threads), one), (name, threads)   # (the derivatives: 3 arrays)


def test_threaded_rows_match_pinocchio(arm):
    """A few rows of every chunk of a 4-thread batch against Pinocchio's rnea, aba and crba."""
    model, Q, V, A = arm
    ref = Reference(model, AAU)
    tau, qdd, M = (md.rnea(model, Q, V, A, threads=4), md.aba(model, Q, V, A, threads=4),
                   md.mass_matrix(model, Q, threads=4))
    for s in (0, 249, 250, 499, 500, 749, 750, 999):
        pq = ref.to_pin_q(Q[s])
        t_pin = pin.rnea(ref.pm, ref.pd, pq, V[s], A[s])
        assert np.abs(tau[s] - t_pin).max() <= 1e-13 * max(1.0, np.abs(t_pin).max())   # measured ≤ 2e-15
        a_pin = pin.aba(ref.pm, ref.pd, pq, V[s], A[s])
        assert np.abs(qdd[s] - a_pin).max() <= 1e-12 * max(1.0, np.abs(a_pin).max())   # measured ≤ 1e-14
        M_pin = pin.crba(ref.pm, ref.pd, pq)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        assert np.abs(M[s] - M_pin).max() <= 1e-13 * max(1.0, np.abs(M_pin).max())     # measured ≤ 1e-15


def test_errors_name_the_row_of_the_whole_batch(arm):
    model, Q, V, A = arm
    bad = Q.copy()
    bad[900, 2] = np.nan                                   # in the 4th chunk of 4
    with pytest.raises(md.InputError, match=r"q\[900, 2\]"):
        md.rnea(model, bad, V, A, threads=4)
    big = A.copy()
    big[700, 1] = 1e308                                    # overflows in the 3rd chunk: the result's row is named
    with pytest.raises(md.NumericalError, match=r"tau\[700, 0\] \(row 700"):
        md.rnea(model, Q, V, big, threads=4)
    for f in (md.rnea_derivatives, md.aba_derivatives):   # their codes: a failing chunk is run again on one thread
        with pytest.raises(md.InputError, match=r"q\[900, 2\]"):
            f(model, bad, V, A, threads=4)
        with pytest.raises(md.NumericalError, match=r"row 700"):
            f(model, Q, V, big, threads=4)
    two = Q.copy()
    two[300, 0], two[800, 0] = np.inf, np.nan              # two chunks fail: the first row is the one reported
    with pytest.raises(md.InputError, match=r"q\[300, 0\]"):
        md.aba(model, two, V, A, threads=4)


def test_a_singular_joint_is_named_through_the_chunks():
    model = md.load_urdf_string(urdf({"base": "", "a": inertial_xml(1.0, (0, 0, 0.1), (0.1, 0.1, 0.1, 0, 0, 0)),
                                      "tip": ""},
                                     [("ja", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
                                      ("jtip", "revolute", "a", "tip", (0, 0, 0.2), (0, 0, 0), (0, 1, 0))]))
    Z = np.zeros((N, 2))
    with pytest.raises(md.SingularError, match="jtip"):
        md.aba(model, Z, Z, Z, threads=4)


@pytest.mark.parametrize("threads", [0, -2, 1.5, True, "2", np.float64(2.0), route.MAX_THREADS + 1, 10**9])
def test_bad_thread_counts_are_refused(arm, threads):
    model, Q, V, A = arm
    for call in (lambda: md.rnea(model, Q, V, A, threads=threads),
                 lambda: md.rnea(model, Q[0], V[0], A[0], threads=threads),
                 lambda: md.mass_matrix(model, Q, method="lagrange", threads=threads),
                 lambda: md.forward_dynamics(model, Q, V, A, method="cholesky", threads=threads)):
        with pytest.raises(md.InputError, match=r"threads must be a positive integer \(at most 1024\) or None"):
            call()


def test_numpy_integers_and_more_threads_than_cores(arm):
    model, Q, V, A = arm
    one = md.aba(model, Q, V, A, threads=1)
    assert np.array_equal(md.aba(model, Q, V, A, threads=np.int64(3)), one)
    assert np.array_equal(md.aba(model, Q, V, A, threads=4 * route.CORES), one)
