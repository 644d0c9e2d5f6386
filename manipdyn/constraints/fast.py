"""Compiled closed-chain forward dynamics: the closure rows (closures.closure_rows, the one source of Φ,
Φ_q, Φ̇_q q̇) + dynamics._kkt in one numba kernel: the independent rows by Gram–Schmidt (as
closures.independent_rows) and Eq. 27 on them by the Schur complement with Cholesky of M.
"""
from __future__ import annotations

import numba
import numpy as np

from .._jit import A2, I1, MODEL, entry, njit
from ..dynamics.kernel_inputs import no_wrenches, nonfinite_input
from ..dynamics.status import bad_input, bad_result, reading, singular_row
from ..dynamics.model_arrays import kernel_arrays
from ..spatial import cholesky, cholesky_solve, first_nonfinite
from ..dynamics.crba import crba_steps_one
from ..dynamics.rnea import rnea_steps_one, steps_scratch
from ..errors import NumericalError, SingularError
from .closures import CLOSURE_FORM, RANK_RTOL, closure_arrays, closure_rows, closure_scratch, n_rows


@njit(cache=True)
def constrained_fd_kernel(I, F, Fz, CI, CF, m, Q, V, T, alpha, beta, rtol, QDD, LAM, RANK):
    """q̈, λ (zero on redundant rows) and the rank, for every state: Eq. 27 on the independent rows.
    (I, F): model_arrays.kernel_arrays, read by the closure rows; (I, Fz) the same model in z-aligned frames
    (``Model.kernel.lane_arrays``), read by the CRBA's and the Newton–Euler steps (``crba.crba_steps_one``,
    ``rnea.rnea_steps_one``).
    Returns its status (dynamics/status.py): a joint whose row of M has no positive pivot (M is not positive
    definite); λ's row s (after q̈'s N·nv entries) where G M⁻¹ Gᵀ is not (the kept rows G are dependent to
    working precision)."""
    N, nv = Q.shape[0], V.shape[1]
    Phi, Jc, bias = np.empty(m), np.empty((m, nv)), np.empty(m)
    W, Wr = closure_scratch(I.shape[1], nv), steps_scratch(I.shape[1], Q.shape[1], nv)
    M, h, Z = np.empty((1, nv, nv))[:, :, :], np.empty((1, nv))[:, :], np.zeros((1, nv))[:, :]   # the kernels'
    X, xb, xp, world = no_wrenches(I, F)                                                   # layout (_jit: "A")
    for s in range(N):
        if nonfinite_input(Q, V, s) >= 0 or first_nonfinite(T, s) >= 0:
            return bad_input(s)
        closure_rows(I, F, CI, CF, Q[s], V[s], W, Phi[::1], Jc[:, :], bias[::1])   # (views: closure_kernel's layout)
        crba_steps_one(I, Fz, Q[s], M[0])                 # (q finite: checked above)
        rnea_steps_one(I, Fz, Q[s], V[s], Z[0], X[0], xb, xp, world, h[0], Wr)   # h = C q̇ + g
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
        L = M[0]                                              # M = L Lᵀ in place (spatial.cholesky)
        k = cholesky(L, nv, 0.0)
        if k >= 0:                                            # M is not positive definite
            return singular_row(I, k)
        Minv_r = T[s] - h[0]                                  # M⁻¹ (τ − h)
        cholesky_solve(L, nv, Minv_r)
        LAM[s] = 0.0
        if r == 0:
            QDD[s] = Minv_r
            continue
        Minv_Gt = np.empty((r, nv))                           # row l: M⁻¹ G_lᵀ
        for l in range(r):
            Minv_Gt[l] = G[l]
            cholesky_solve(L, nv, Minv_Gt[l])
        S = G @ Minv_Gt.T                                     # G M⁻¹ Gᵀ (r, r): positive definite, G of full rank
        lam = G @ Minv_r - cr
        if cholesky(S, r, 0.0) >= 0:                          # no λ: reported as λ's row s (``constrained_fd_fast``)
            LAM[s] = np.nan
            return bad_result(I.shape[1], N * nv + s * m)
        cholesky_solve(S, r, lam)
        QDD[s] = Minv_r - Minv_Gt.T @ lam
        for l in range(r):
            LAM[s, keep[l]] = lam[l]
    return -1


CONSTRAINED_FD = entry(constrained_fd_kernel, *MODEL, MODEL[1], *CLOSURE_FORM, numba.int64, A2, A2, A2, numba.float64,
                       numba.float64, numba.float64, A2, A2, I1)   # its compiled code (``_jit.entry``)


def constrained_fd_fast(model, Q, V, T, baumgarte=None):
    """(q̈ (N, nv), λ (N, m), rank (N,)) through the kernel; Q (N, nq), V, T (N, nv) float64."""
    I, F = kernel_arrays(model)
    CI, CF = closure_arrays(model)
    m = n_rows(model)
    alpha, beta = (0.0, 0.0) if baumgarte is None else (float(baumgarte[0]), float(baumgarte[1]))
    QDD, LAM, RANK = np.empty(V.shape), np.empty((Q.shape[0], m)), np.empty(Q.shape[0], np.int64)
    code = CONSTRAINED_FD.call(I, F, model.kernel.lane_arrays[1], CI, CF, m, Q, V, T, alpha, beta, RANK_RTOL, QDD,
                               LAM, RANK)
    what, k = reading(code, model.njoints)
    if what == "result" and k >= QDD.size:                   # λ: G M⁻¹ Gᵀ is singular
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
