"""Compiled closed-chain forward dynamics: closures.closure_terms + dynamics._kkt in one numba kernel.

Same equations as the readable modules (which the tests hold this kernel to): world placements and twists
of the bodies, the closure rows Φ, Φ_q, Φ̇_q q̇ (closures.py's docstring), the independent rows by
Gram–Schmidt, and Eq. 27 on them by the Schur complement with Cholesky of M.
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..dynamics import core
from ..dynamics.fast import _joint_rotation, _unpack, crba_kernel, kernel_arrays
from ..dynamics.rnea import rnea_one
from ..dynamics.kinematics import supports
from ..errors import NumericalError, SingularError
from .closures import RANK_RTOL, _pairs

TYPES = {"spherical": 0, "revolute": 1, "fixed": 2}


def closure_arrays(model):
    """Closures in kernel form, built once per model: ints (nc, 3) = [parent, child, n_pairs], floats
    (nc, 24) = [pp, pc, a_1..a_3, b_1..b_3] (orientation pairs, a in the parent's frame, b in the child's),
    and the support matrix (nv, nv)."""
    arr = model.__dict__.get("_closure_arrays")
    if arr is None:
        nc = len(model.constraints)
        ints, flts = np.zeros((nc, 3), np.int64), np.zeros((nc, 24))
        for k, c in enumerate(model.constraints):
            pairs = _pairs(c)
            ints[k] = c.parent, c.child, len(pairs)
            flts[k, :3], flts[k, 3:6] = c.pp, c.pc
            for m, (a, b) in enumerate(pairs):
                flts[k, 6 + 3 * m:9 + 3 * m], flts[k, 15 + 3 * m:18 + 3 * m] = a, b
        arr = (ints, flts, supports(model).astype(np.bool_))
        object.__setattr__(model, "_closure_arrays", arr)     # a cache, not model data (Model is frozen)
    return arr


@njit(cache=True)
def _bodies(I, F, q, v, Rw, pw, z, w, vel, al, acc):
    """World placement (Rw, pw), axis z, angular/linear velocity (w, vel of the origin) and the
    accelerations at q̈ = 0 without gravity (al, acc) of every body."""
    parent, rev, axis, R0, p0, mass, com, inertia, mg = _unpack(I, F)
    Rp = np.empty((3, 3))
    for i in range(q.shape[0]):
        _joint_rotation(R0[i], axis[i], rev[i], q[i], Rp)
        pp = p0[i].copy() if rev[i] else p0[i] + q[i] * (R0[i] @ axis[i])
        j = parent[i]
        if j < 0:
            Rw[i], pw[i] = Rp, pp
            w[i], vel[i], al[i], acc[i] = 0.0, 0.0, 0.0, 0.0
            w0, v0, a0, c0 = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
        else:
            Rw[i] = Rw[j] @ Rp
            pw[i] = pw[j] + Rw[j] @ pp
            r = pw[i] - pw[j]
            w0, a0 = w[j], al[j]
            v0 = vel[j] + np.cross(w0, r)
            c0 = acc[j] + np.cross(a0, r) + np.cross(w0, np.cross(w0, r))
        z[i] = Rw[i] @ axis[i]
        qz = v[i] * z[i]
        if rev[i]:
            w[i], vel[i] = w0 + qz, v0
            al[i], acc[i] = a0 + np.cross(w0, qz), c0
        else:
            w[i], vel[i] = w0, v0 + qz
            al[i], acc[i] = a0, c0 + 2.0 * np.cross(w0, qz)


@njit(cache=True)
def _point(I, b, x, pw, z, w, vel, al, acc, S, rev, J):
    """World-aligned Jacobian J (6, nv) of point x on body b; returns its velocity and its acceleration
    at q̈ = 0 (zero on the fixed base)."""
    J[:, :] = 0.0
    if b < 0:
        return np.zeros(3), np.zeros(3)
    r = x - pw[b]
    for j in range(S.shape[1]):
        if S[b, j]:
            if rev[j]:
                J[:3, j] = np.cross(z[j], x - pw[j])
                J[3:, j] = z[j]
            else:
                J[:3, j] = z[j]
    return vel[b] + np.cross(w[b], r), acc[b] + np.cross(al[b], r) + np.cross(w[b], np.cross(w[b], r))


@njit(cache=True)
def closure_kernel(I, F, CI, CF, S, q, v, Phi, Jc, bias):
    """Φ (m,), Φ_q (m, nv) and Φ̇_q q̇ (m,) of one state, rows in closures.row_labels order."""
    nv = q.shape[0]
    rev = I[:, 1] == 1
    Rw, z = np.empty((nv, 3, 3)), np.empty((nv, 3))
    pw, w, vel, al, acc = np.empty((nv, 3)), np.empty((nv, 3)), np.empty((nv, 3)), np.empty((nv, 3)), np.empty((nv, 3))
    _bodies(I, F, q, v, Rw, pw, z, w, vel, al, acc)
    JA, JB = np.empty((6, nv)), np.empty((6, nv))
    row = 0
    for k in range(CI.shape[0]):
        a_b, b_b, npair = CI[k, 0], CI[k, 1], CI[k, 2]
        RA = Rw[a_b] if a_b >= 0 else np.eye(3)
        RB = Rw[b_b] if b_b >= 0 else np.eye(3)
        xA = (pw[a_b] if a_b >= 0 else np.zeros(3)) + RA @ CF[k, 0:3]
        xB = (pw[b_b] if b_b >= 0 else np.zeros(3)) + RB @ CF[k, 3:6]
        _, accA = _point(I, a_b, xA, pw, z, w, vel, al, acc, S, rev, JA)
        _, accB = _point(I, b_b, xB, pw, z, w, vel, al, acc, S, rev, JB)
        for d in range(3):                                    # position rows
            Phi[row] = xA[d] - xB[d]
            Jc[row] = JA[d] - JB[d]
            bias[row] = accA[d] - accB[d]
            row += 1
        wA = w[a_b] if a_b >= 0 else np.zeros(3)
        wB = w[b_b] if b_b >= 0 else np.zeros(3)
        aA = al[a_b] if a_b >= 0 else np.zeros(3)
        aB = al[b_b] if b_b >= 0 else np.zeros(3)
        for m in range(npair):                                # orientation rows: a·b
            a = RA @ CF[k, 6 + 3 * m:9 + 3 * m]
            b = RB @ CF[k, 15 + 3 * m:18 + 3 * m]
            axb = np.cross(a, b)
            Phi[row] = a @ b
            Jc[row] = axb @ (JA[3:] - JB[3:])
            daxb = np.cross(np.cross(wA, a), b) + np.cross(a, np.cross(wB, b))
            bias[row] = daxb @ (wA - wB) + axb @ (aA - aB)
            row += 1


@njit(cache=True)
def constrained_fd_kernel(I, F, IC, FC, CI, CF, S, m, Q, V, T, alpha, beta, rtol, QDD, LAM, RANK):
    """q̈, λ (zero on redundant rows) and the rank, for every state: Eq. 27 on the independent rows.
    (I, F): the model in dynamics/fast.py's form (closures, CRBA); (IC, FC): in dynamics/core.py's form
    (Newton–Euler). Returns -1 or the flat index of the first non-finite input; -2 if M is not positive
    definite."""
    N, nv = Q.shape
    Phi, Jc, bias = np.empty(m), np.empty((m, nv)), np.empty(m)
    M = np.empty((1, nv, nv))
    h, zero = np.empty(nv), np.zeros(nv)
    for s in range(N):
        for i in range(nv):
            if not (np.isfinite(Q[s, i]) and np.isfinite(V[s, i]) and np.isfinite(T[s, i])):
                return s * nv + i
        closure_kernel(I, F, CI, CF, S, Q[s], V[s], Phi, Jc, bias)
        crba_kernel(I, F, Q[s:s + 1], M)
        rnea_one(IC, FC, Q[s], V[s], zero, h)                                 # h = C q̇ + g
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
        Minv_r = np.linalg.solve(L.T, np.linalg.solve(L, T[s] - h))
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
    """(q̈ (N, nv), λ (N, m), rank (N,)) through the kernel; Q, V, T float64 (N, nv)."""
    I, F = kernel_arrays(model)
    CI, CF, S = closure_arrays(model)
    m = sum(c.n_rows for c in model.constraints)
    alpha, beta = (0.0, 0.0) if baumgarte is None else (float(baumgarte[0]), float(baumgarte[1]))
    QDD, LAM, RANK = np.empty(Q.shape), np.empty((Q.shape[0], m)), np.empty(Q.shape[0], np.int64)
    try:
        code = constrained_fd_kernel(I, F, *core.kernel_arrays(model), CI, CF, S, m, Q, V, T, alpha, beta,
                                     RANK_RTOL, QDD, LAM, RANK)
    except np.linalg.LinAlgError:
        _overflowed(model, Q, V)
        raise SingularError(f"closed-chain dynamics of {model.name!r}: the constraint system is singular "
                            f"(a singular configuration, or closures that cannot hold together)") from None
    return code, QDD, LAM, RANK


def _overflowed(model, Q, V):
    """NumericalError if M or h = C q̇ + g of a state is not finite (what made the kernel's solve fail)."""
    from ..dynamics.lagrange import mass_matrix
    from ..dynamics.rnea import rnea
    try:
        rnea(model, Q, V, np.zeros_like(Q))
        mass_matrix(model, Q)
    except NumericalError as exc:
        raise NumericalError(f"constrained_forward_dynamics, in {exc}") from None


def closure_rows(model, q, v=None):
    """Φ (m,), Φ_q (m, nv) and Φ̇_q q̇ (m,) of one state (v = 0 if not given) through the kernel."""
    I, F = kernel_arrays(model)
    CI, CF, S = closure_arrays(model)
    m = sum(c.n_rows for c in model.constraints)
    Phi, Jc, bias = np.empty(m), np.empty((m, model.nv)), np.empty(m)
    closure_kernel(I, F, CI, CF, S, np.ascontiguousarray(q, float),
                   np.zeros(model.nv) if v is None else np.ascontiguousarray(v, float), Phi, Jc, bias)
    return Phi, Jc, bias
