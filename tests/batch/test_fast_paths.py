"""The compiled paths against each other and their input checks. (Each algorithm has one source, compiled or
not: tests/crosscheck/ holds them to Pinocchio.) Here: the ABA inverts Newton–Euler — aba(q, v, rnea(q, v, a))
= a — two independent recursions agreeing to round-off scaled by cond(M)."""
import warnings

import numpy as np
import pytest
from conftest import assert_close, inertial_xml, urdf, zoo_paths

import manipdyn as md
from manipdyn.validation import random_states


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_urdf(path)


@pytest.mark.parametrize("path", zoo_paths(), ids=lambda p: p.stem)
def test_kernels_equal_references(path):
    model = _load(path)
    Q, V, A = random_states(model, 200, np.random.default_rng(21))
    tau = md.rnea(model, Q, V, A)
    cond = np.linalg.cond(md.mass_matrix(model, Q)).max()
    assert_close(md.aba(model, Q, V, tau), A, 1e-14 * cond, "aba inverts rnea")  # measured ≤ 1.0e-16 × cond


def test_fast_path_checks_inputs():
    model = _load(zoo_paths()[0])
    z = np.zeros(model.nv)
    bad = z.copy()
    bad[2] = np.nan
    for f in (lambda x: md.rnea(model, z, x, z), lambda x: md.aba(model, z, x, z)):
        with pytest.raises(md.InputError, match=rf"v\[2\] \(joint '{model.joint_names[2]}'\) is nan"):
            f(bad)
    with pytest.raises(md.InputError, match=r"q\[1, 0\]"):
        md.mass_matrix(model, np.vstack([z, np.r_[np.inf, z[1:]]]))
    # non-contiguous, integer and list inputs take the checked path and give the same numbers
    Q, V, A = random_states(model, 4, np.random.default_rng(2))
    ref = md.rnea(model, Q, V, A)
    assert_close(md.rnea(model, np.asfortranarray(Q), V.tolist(), A), ref, 1e-15, "converted inputs")
    assert_close(md.rnea(model, Q[0], V[0], A[0]), ref[0], 1e-15, "single state")


def test_fast_aba_refuses_massless_subtree():
    model = md.load_urdf_string(urdf({"base": "", "a": inertial_xml(1.0, (0, 0, 0.1), (0.1, 0.1, 0.1, 0, 0, 0)),
                                      "tip": ""},
                                     [("ja", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
                                      ("jtip", "revolute", "a", "tip", (0, 0, 0.2), (0, 0, 0), (0, 1, 0))]))
    with pytest.raises(md.SingularError, match="jtip"):
        md.aba(model, np.zeros(2), np.zeros(2), np.zeros(2))


@pytest.mark.parametrize("name", ["fourbar.urdf", "spm.urdf"])
def test_closed_chain_kernel_equals_reference(name):
    """The KKT kernel (constraints/fast.py) against the readable KKT solve (constraints/dynamics.py). Both read
    the one source of closure rows (closures.closure_rows), which tests/crosscheck/test_spatial_loops.py and
    tests/batch/test_kernels_vs_readable.py hold to Pinocchio's frame Jacobians and to finite differences."""
    from conftest import ROOT
    from manipdyn.constraints import closure_terms, rank_report
    from manipdyn.constraints.dynamics import (constrained_forward_dynamics,
                                               constrained_forward_dynamics_reference)
    from manipdyn.validation.closed import manifold_states
    model = md.load_urdf(ROOT / "urdf" / name)
    rng = np.random.default_rng(8)
    Q, V = manifold_states(model, 30, rng)
    T = rng.normal(size=Q.shape)
    for bg in (None, (3.0, 4.0)):
        fast = constrained_forward_dynamics(model, Q, V, T, baumgarte=bg)
        ref = constrained_forward_dynamics_reference(model, Q, V, T, baumgarte=bg)
        for s in range(len(Q)):   # two round-offs of one solve: bound scaled by its conditioning
            kappa = np.linalg.cond(md.mass_matrix(model, Q[s])) * rank_report(model, closure_terms(model, Q[s])[1]).cond ** 2
            assert_close(fast[0][s], ref[0][s], 1e-15 * kappa, "q̈")
            assert_close(fast[1][s], ref[1][s], 1e-15 * kappa, "λ")
    one = constrained_forward_dynamics(model, Q[0], V[0], T[0])
    assert len(one) == 2 and one[0].shape == (model.nv,)
    assert rank_report(model, closure_terms(model, Q[0])[1]).rank == (2 if name == "fourbar.urdf" else 4)
