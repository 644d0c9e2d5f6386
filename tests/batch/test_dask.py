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
