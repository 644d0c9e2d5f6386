"""What every kernel checks and receives besides the model: finite states (the check each kernel makes on
entry) and external wrenches as the rows the kernels read (X, body, point, world; ``arguments.wrench_rows`` lays
them out for a batch).
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..joints import config_sizes
from ..spatial import first_nonfinite
from .status import OK, bad_input


@njit(cache=True, inline="always")
def model_sizes(I):
    """(nq, nv) of the model whose kernel ints are I (model_arrays' layout: rows kind, idx_q, idx_v are 1–3;
    joints.config_sizes)."""
    return config_sizes(I[1], I[2], I[3])


@njit(cache=True, inline="always")
def q_sized(I, q):
    """True when q has the model's nq entries (``sized`` without other arrays)."""
    return q.shape[0] == model_sizes(I)[0]


@njit(cache=True, inline="always")
def sized(I, q, vs):
    """True when q has the model's nq entries and every array of the tuple vs (states, a vector result) nv: the
    check a one-state kernel makes before it reads anything (status.WRONG_SIZES otherwise; a matrix result's kernel
    checks its shape too). vs holds one array at least (numba iterates no empty tuple)."""
    nq, nv = model_sizes(I)
    ok = q.shape[0] == nq
    for x in vs:
        ok &= x.shape[0] == nv
    return ok


@njit(cache=True, inline="always")
def nonfinite_input(Q, V, s):
    """−1 when state s's q and v (Q (N, nq), V (N, nv) or (N, 0)) are finite, else its status ``status.bad_input(s)``
    (``spatial.first_nonfinite`` on each row)."""
    return bad_input(s) if max(first_nonfinite(Q, s), first_nonfinite(V, s)) >= 0 else OK


@njit(cache=True, inline="always")
def wrench_rows_of(f, m, P):
    """One state's single external wrench as the kernels read it (arguments.fast_wrenches): X (1, K, 6) =
    [R f; R m], body (K,) and point (K, 3), from the force f (3,), the moment m (3,) and the frame's row P (13,)
    = [R row by row (R turns the frame's axes into the body's), its origin in the body, body]. K = 0 for a
    wrench on the fixed base (it changes no joint torque)."""
    K = 1 if P[12] >= 0 else 0
    X, body, point = np.empty((1, K, 6)), np.empty(K, np.int64), np.empty((K, 3))
    for k in range(K):
        body[k] = int(P[12])
        for r in range(3):
            X[0, k, r] = P[3 * r] * f[0] + P[3 * r + 1] * f[1] + P[3 * r + 2] * f[2]
            X[0, k, 3 + r] = P[3 * r] * m[0] + P[3 * r + 1] * m[1] + P[3 * r + 2] * m[2]
            point[k, r] = P[9 + r]
    return X[:, :, :], body[::1], point[:, :]          # views of the kernels' layout (_jit: "A")


@njit(cache=True, inline="always")
def no_wrenches(I, F):
    """X (1, 0, 3), body (0,), point (0, 3), world = False: no external wrench, in the layout of ``wrench_rows_of``
    — views with no rows of the model's arrays (I, F), so that a one-state call allocates nothing for them (X's
    entries are never read without a wrench); world a run-time bool, not the constant False, for which numba
    would compile anew."""
    return F[:1, :0, :], I[0, :0][::1], F[0, :0, :], np.bool_(False)


@njit(cache=True, inline="always")
def finite_state(Q, V, A, s):
    """True when state s's q, v and a (or τ) are all finite: the check every dynamics kernel makes on entry
    (``spatial.first_nonfinite`` on each row)."""
    return max(first_nonfinite(Q, s), first_nonfinite(V, s), first_nonfinite(A, s)) < 0   # no early exit
