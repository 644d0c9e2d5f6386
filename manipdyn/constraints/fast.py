"""Compiled closed-chain forward dynamics: the closure rows (closures.closure_rows, the one source of Φ,
Φ_q, Φ̇_q q̇) + dynamics._kkt in one numba kernel: the independent rows by Gram–Schmidt (as
closures.independent_rows) and Eq. 27 on them by the Schur complement with Cholesky of M.
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..dynamics.core import kernel_arrays, nonfinite_input
from ..spatial import first_nonfinite
from ..dynamics.crba import crba_kernel
from ..dynamics.rnea import rnea_one
from ..errors import NumericalError, SingularError
from .closures import RANK_RTOL, closure_arrays, closure_rows, closure_scratch, n_rows


@njit(cache=True)
def constrained_fd_kernel(I, F, CI, CF, m, Q, V, T, alpha, beta, rtol, QDD, LAM, RANK):
    """q̈, λ (zero on redundant rows) and the rank, for every state: Eq. 27 on the independent rows.
    (I, F): core.kernel_arrays, read by the closure rows, the CRBA and Newton–Euler.
    Returns -1 or the flat index of the first non-finite input; -2 if M is not positive definite."""
    N, nq, nv = Q.shape[0], Q.shape[1], V.shape[1]
    Phi, Jc, bias = np.empty(m), np.empty((m, nv)), np.empty(m)
    W = closure_scratch(I.shape[1], nv)
    M = np.empty((1, nv, nv))
    h = np.empty((1, nv))
    zero = np.zeros(nv)
    for s in range(N):
        k = nonfinite_input(Q, V, s)
        if k < 0 and first_nonfinite(T, s) >= 0:
            k = N * nq + s * nv + first_nonfinite(T, s)
        if k >= 0:
            return k
        closure_rows(I, F, CI, CF, Q[s], V[s], W, Phi, Jc, bias)
        crba_kernel(I, F, Q[s:s + 1], M)
        rnea_one(I, F, Q[s], V[s], zero, h[0])                                 # h = C q̇ + g
        c = -bias - 2.0 * alpha * (Jc @ V[s]) - beta * beta * Phi             # Baumgarte (α = β = 0: none)
        scale, phimax = 0.0, 0.0                              # Gram–Schmidt: keep rows that add rank
        for k in range(m):
            scale = max(scale, np.sqrt(Jc[k] @ Jc[k]))
            phimax = max(phimax, abs(Phi[k]))
        tol = max(rtol, 100.0 * phimax / max(scale, 1e-300))  # as closures.independent_rows
        basis, keep = np.empty((m, nv)), np.empty(m, np.int64)
        r = 0
        for k in range(m):
            x = Jc[k].copy()
            for l in range(r):
                x -= (x @ basis[l]) * basis[l]
            nx = np.sqrt(x @ x)
            if nx > tol * max(scale, 1e-300):
                basis[r] = x / nx
                keep[r] = k
                r += 1
        RANK[s] = r
        G = np.empty((r, nv))
        cr = np.empty(r)
        for l in range(r):
            G[l], cr[l] = Jc[keep[l]], c[keep[l]]
        for i in range(nv):
            if not M[0, i, i] > 0.0:
                return -2
        L = np.linalg.cholesky(M[0])
        Minv_r = np.linalg.solve(L.T, np.linalg.solve(L, T[s] - h[0]))
        LAM[s] = 0.0
        if r == 0:
            QDD[s] = Minv_r
            continue
        Minv_Gt = np.linalg.solve(L.T, np.linalg.solve(L, np.ascontiguousarray(G.T)))
        lam = np.linalg.solve(G @ Minv_Gt, G @ Minv_r - cr)
        QDD[s] = Minv_r - Minv_Gt @ lam
        for l in range(r):
            LAM[s, keep[l]] = lam[l]
    return -1


def constrained_fd_fast(model, Q, V, T, baumgarte=None):
    """(q̈ (N, nv), λ (N, m), rank (N,)) through the kernel; Q (N, nq), V, T (N, nv) float64."""
    I, F = kernel_arrays(model)
    CI, CF = closure_arrays(model)
    m = n_rows(model)
    alpha, beta = (0.0, 0.0) if baumgarte is None else (float(baumgarte[0]), float(baumgarte[1]))
    QDD, LAM, RANK = np.empty(V.shape), np.empty((Q.shape[0], m)), np.empty(Q.shape[0], np.int64)
    try:
        code = constrained_fd_kernel(I, F, CI, CF, m, Q, V, T, alpha, beta, RANK_RTOL,
                                     QDD, LAM, RANK)
    except np.linalg.LinAlgError:
        _overflowed(model, Q, V)
        raise SingularError(f"closed-chain dynamics of {model.name!r}: the constraint system is singular "
                            f"(a singular configuration, or closures that cannot hold together)") from None
    return code, QDD, LAM, RANK


def _overflowed(model, Q, V):
    """NumericalError if M or h = C q̇ + g of a state is not finite (what made the kernel's solve fail)."""
    from ..dynamics.crba import mass_matrix
    from ..dynamics.rnea import rnea
    try:
        rnea(model, Q, V, np.zeros_like(V))
        mass_matrix(model, Q)
    except NumericalError as exc:
        raise NumericalError(f"constrained_forward_dynamics, in {exc}") from None
