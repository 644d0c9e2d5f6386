"""Dask arrays of states (dynamics/route.py, ``Route.lazy``): a routed batched call returns a Dask array at once
and computes it chunk of rows by chunk of rows when asked — on Dask's local threads and on a LocalCluster's
worker — with the numbers of the same call on numpy arrays, bit for bit (which tests/crosscheck holds to
Pinocchio), and with the rows of every chunk checked against Pinocchio here; what it cannot take is refused
by name."""

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, aau_states

import manipdyn as md
from manipdyn.validation.reference import Reference

da = pytest.importorskip("dask.array")
N = 700


@pytest.fixture(scope="module")
def arm():
    return aau_states(N, 11)


CALLS = {
    "rnea": lambda m, Q, V, A: md.rnea(m, Q, V, A),
    "nonlinear_effects": lambda m, Q, V, A: md.nonlinear_effects(m, Q, V),
    "gravity_torques": lambda m, Q, V, A: md.gravity_torques(m, Q),
    "aba": lambda m, Q, V, A: md.aba(m, Q, V, A),
    "forward_dynamics cholesky": lambda m, Q, V, A: md.forward_dynamics(m, Q, V, A, method="cholesky"),
    "mass_matrix": lambda m, Q, V, A: md.mass_matrix(m, Q),
    "coriolis_matrix": lambda m, Q, V, A: md.coriolis_matrix(m, Q, V),
    "joint_torque_regressor": lambda m, Q, V, A: md.joint_torque_regressor(m, Q, V, A),
}


@pytest.mark.parametrize("name", list(CALLS))
def test_dask_states_give_a_lazy_array_of_the_same_numbers(arm, name):
    model, Q, V, A = arm
    f = CALLS[name]
    lazy = f(model, da.from_array(Q, chunks=(200, -1)), da.from_array(V, chunks=(300, 2)), A)   # chunks differ
    assert isinstance(lazy, da.Array) and lazy.chunks[0] == (200, 200, 200, 100)
    assert np.array_equal(lazy.compute(scheduler="threads"), f(model, Q, V, A))


def test_chunk_rows_match_pinocchio(arm):
    model, Q, V, A = arm
    ref = Reference(model, AAU)
    tau = md.rnea(model, *(da.from_array(x, chunks=(200, -1)) for x in (Q, V, A))).compute()
    for s in (0, 199, 200, 450, 699):
        t = pin.rnea(ref.pm, ref.pd, ref.to_pin_q(Q[s]), V[s], A[s])
        assert np.abs(tau[s] - t).max() <= 1e-13 * max(1.0, np.abs(t).max())      # measured ≤ 2e-15


def test_a_local_cluster_computes_the_chunks(arm):
    distributed = pytest.importorskip("distributed")
    model, Q, V, A = arm
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as \
            cluster, distributed.Client(cluster) as client:
        lazy = md.aba(model, *(da.from_array(x, chunks=(250, -1)) for x in (Q, V, A)))
        got = client.compute(lazy).result()
    assert np.array_equal(got, md.aba(model, Q, V, A))


def test_what_a_dask_batch_cannot_take_is_refused(arm):
    model, Q, V, A = arm
    Qd = da.from_array(Q, chunks=(200, -1))
    tip = model.body_names[-1]
    with pytest.raises(md.InputError, match="f_ext with Dask arrays of states is not supported"):
        md.rnea(model, Qd, V, A, f_ext={tip: (np.ones(3), np.zeros(3))})
    with pytest.raises(md.InputError, match=r"v must be \(N, 5\), it is \(700, 4\)"):
        md.rnea(model, Qd, V[:, :4], A)
    with pytest.raises(md.InputError, match=r"the same N"):
        md.rnea(model, Qd, V[:600], A)
    with pytest.raises(md.InputError, match=r"q must be \(N, 5\), it is \(5,\)"):
        md.gravity_torques(model, da.from_array(Q[0]))
    bad = Q.copy()
    bad[450, 1] = np.nan                                  # an error surfaces when the chunk is computed
    with pytest.raises(md.InputError, match=r"chunk of rows 400–599 of the Dask batch .*: q\[50, 1\]"):
        md.rnea(model, da.from_array(bad, chunks=(200, -1)), V, A).compute(scheduler="synchronous")


@pytest.mark.parametrize("name", ["rnea_derivatives", "aba_derivatives"])
def test_dask_states_give_lazy_derivatives_of_the_same_numbers(arm, name):
    model, Q, V, A = arm
    f = getattr(md, name)
    lazy = f(model, da.from_array(Q, chunks=(250, -1)), V, da.from_array(A, chunks=(100, -1)))
    assert len(lazy) == 3 and all(isinstance(x, da.Array) and x.chunks[0] == (250, 250, 200) for x in lazy)
    got = da.compute(*lazy, scheduler="threads")                # one pass per chunk for the three
    for x, y in zip(got, f(model, Q, V, A)):
        assert np.array_equal(x, y)
    ref = Reference(model, AAU)
    pin_call = pin.computeRNEADerivatives if name == "rnea_derivatives" else pin.computeABADerivatives
    for s in (0, 333, N - 1):                                   # and the chunks' rows are Pinocchio's
        theirs = [np.array(y) for y in pin_call(ref.pm, ref.pd, ref.to_pin_q(Q[s]), V[s], A[s])]
        if name == "rnea_derivatives":
            theirs[2] = np.triu(theirs[2]) + np.triu(theirs[2], 1).T           # M: Pinocchio fills its upper half
        for x, y in zip(got, theirs):
            assert np.max(np.abs(x[s] - y)) <= 1e-11 * max(1.0, np.max(np.abs(y))), s   # measured ≤ 6.7e-13


def test_dask_derivatives_name_a_bad_chunk(arm):
    model, Q, V, A = arm
    bad = Q.copy()
    bad[450, 1] = np.nan
    lazy = md.rnea_derivatives(model, da.from_array(bad, chunks=(200, -1)), V, A)
    with pytest.raises(md.InputError, match=r"chunk of rows 400–599.*q\[50, 1\]"):
        da.compute(*lazy, scheduler="threads")
