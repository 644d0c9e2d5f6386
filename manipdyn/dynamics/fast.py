"""Compiled kernels (numba) of the articulated-body algorithm (aba.py is the readable reference the tests
hold them to); Newton–Euler is compiled in rnea.py, the CRBA in crba.py.

The kernels take the model as plain arrays (``kernel_arrays``), states as (N, nv) C-contiguous float64, and
write into preallocated outputs. Finiteness is checked inside the loop: a kernel returns the flat index of
the first non-finite input entry, -2 - nv - k when entry k (flat) of its result is not finite (an
overflow, checked at the end of each state's pass), or -1. Compiled code is cached on disk (numba
``cache=True``).
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..model import REVOLUTE

def kernel_arrays(model):
    """The model in kernel form, built once per model: (I, F) with I (nv, 2) int64 = [parent, revolute]
    and F one float64 vector [axis, R0, p0, mass, com, inertia, −g] that ``_unpack`` views again inside
    the kernels (two arguments instead of nine: each array argument costs ~80 ns of dispatch)."""
    arr = model.__dict__.get("_kernel_arrays")
    if arr is None:
        I = np.ascontiguousarray(np.column_stack([model.parent, model.kind == REVOLUTE]), dtype=np.int64)
        F = np.concatenate([np.ravel(x) for x in (model.axis, model.R0, model.p0, model.mass, model.com,
                                                   model.inertia, -np.asarray(model.gravity, float))])
        arr = (I, F)
        object.__setattr__(model, "_kernel_arrays", arr)   # a cache, not model data (Model is frozen)
    return arr


@njit(cache=True, inline="always")
def _unpack(I, F):
    """Views of the model arrays: parent, rev (nv,), axis (nv, 3), R0 (nv, 3, 3), p0 (nv, 3), mass (nv,),
    com (nv, 3), inertia (nv, 3, 3), mg (3,)."""
    nv = I.shape[0]
    k = np.cumsum(np.array([0, 3 * nv, 9 * nv, 3 * nv, nv, 3 * nv, 9 * nv, 3]))
    return (I[:, 0], I[:, 1] == 1, F[k[0]:k[1]].reshape(nv, 3), F[k[1]:k[2]].reshape(nv, 3, 3),
            F[k[2]:k[3]].reshape(nv, 3), F[k[3]:k[4]], F[k[4]:k[5]].reshape(nv, 3),
            F[k[5]:k[6]].reshape(nv, 3, 3), F[k[6]:k[7]])


@njit(cache=True, inline="always")
def _joint_rotation(R0, axis, rev, q, out):
    """out = R0 Rot(axis, q) (revolute) or R0 (prismatic): Rodrigues written out."""
    if not rev:
        out[:, :] = R0
        return
    s, c = np.sin(q), np.cos(q)
    x, y, z = axis[0], axis[1], axis[2]
    t = 1.0 - c
    r00, r01, r02 = c + t * x * x, t * x * y - s * z, t * x * z + s * y
    r10, r11, r12 = t * x * y + s * z, c + t * y * y, t * y * z - s * x
    r20, r21, r22 = t * x * z - s * y, t * y * z + s * x, c + t * z * z
    for i in range(3):
        a0, a1, a2 = R0[i, 0], R0[i, 1], R0[i, 2]
        out[i, 0] = a0 * r00 + a1 * r10 + a2 * r20
        out[i, 1] = a0 * r01 + a1 * r11 + a2 * r21
        out[i, 2] = a0 * r02 + a1 * r12 + a2 * r22


@njit(cache=True, inline="always")
def _joint_translation(R0, p0, axis, rev, q, out):
    """out = p^{i-1}_i: p0 (revolute) or p0 + d R0 axis (prismatic, evaluated at the current d, Eqs. 8–12)."""
    for k in range(3):
        out[k] = p0[k] if rev else p0[k] + q * (R0[k, 0] * axis[0] + R0[k, 1] * axis[1] + R0[k, 2] * axis[2])


@njit(cache=True, inline="always")
def _rot3(R, x, out):
    """out = R x (3,)."""
    a, b, c = x[0], x[1], x[2]
    for k in range(3):
        out[k] = R[k, 0] * a + R[k, 1] * b + R[k, 2] * c


@njit(cache=True, inline="always")
def _rot3t(R, x, out):
    """out = Rᵀ x (3,)."""
    a, b, c = x[0], x[1], x[2]
    for k in range(3):
        out[k] = R[0, k] * a + R[1, k] * b + R[2, k] * c


@njit(cache=True, inline="always")
def _cross(a, b, out):
    x = a[1] * b[2] - a[2] * b[1]
    y = a[2] * b[0] - a[0] * b[2]
    z = a[0] * b[1] - a[1] * b[0]
    out[0], out[1], out[2] = x, y, z


@njit(cache=True, inline="always")
def _sandwich(R, X, tmp, out):
    """out += R X Rᵀ for 3×3 blocks (tmp is scratch)."""
    for i in range(3):
        for j in range(3):
            tmp[i, j] = R[i, 0] * X[0, j] + R[i, 1] * X[1, j] + R[i, 2] * X[2, j]
    for i in range(3):
        for j in range(3):
            out[i, j] += tmp[i, 0] * R[j, 0] + tmp[i, 1] * R[j, 1] + tmp[i, 2] * R[j, 2]


@njit(cache=True)
def aba_kernel(I, F, Q, V, T, out):
    """q̈ by the articulated-body algorithm (RBDA Table 7.1) for every state; spatial quantities in blocks
    [angular; linear] of 3-vectors and 3×3 matrices: Iᴬ = [[A, B], [Bᵀ, C]], pᴬ = [pn; pf], c = [cw; cv],
    U = [uw; uv]. Returns -1, the flat index of the first non-finite input, -2 - i when the articulated
    inertia D_i of joint i vanishes (singular mass matrix), or -2 - nv - (flat index) of a non-finite q̈."""
    parent, rev, axis, R0, p0, mass, com, inertia, mg = _unpack(I, F)
    N, nv = Q.shape
    R = np.empty((nv, 3, 3))
    p = np.empty((nv, 3))
    w, vl = np.empty((nv, 3)), np.empty((nv, 3))
    cw, cv = np.empty((nv, 3)), np.empty((nv, 3))
    A, B, C = np.empty((nv, 3, 3)), np.empty((nv, 3, 3)), np.empty((nv, 3, 3))
    pn, pf = np.empty((nv, 3)), np.empty((nv, 3))
    uw, uv = np.empty((nv, 3)), np.empty((nv, 3))
    D, u = np.empty(nv), np.empty(nv)
    aw, av = np.empty((nv, 3)), np.empty((nv, 3))
    t1, t2, t3 = np.empty(3), np.empty(3), np.empty(3)
    dmin = 1e-14 * max(np.max(np.abs(inertia)), np.max(mass), 1e-300)
    M3, Pm = np.empty((3, 3)), np.empty((3, 3))
    Ar, Br, Cr = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    for s in range(N):
        for i in range(nv):                                   # pass 1: velocities, bias terms
            q, qd = Q[s, i], V[s, i]
            if not (np.isfinite(q) and np.isfinite(qd) and np.isfinite(T[s, i])):
                return s * nv + i
            _joint_rotation(R0[i], axis[i], rev[i], q, R[i])
            _joint_translation(R0[i], p0[i], axis[i], rev[i], q, p[i])
            j = parent[i]
            if j < 0:
                w[i, :] = 0.0
                vl[i, :] = 0.0
            else:                                             # ω_i = Rᵀ ω_λ; v_i = Rᵀ (v_λ + ω_λ × p)
                _rot3t(R[i], w[j], w[i])
                _cross(w[j], p[i], t1)
                for k in range(3):
                    t1[k] += vl[j, k]
                _rot3t(R[i], t1, vl[i])
            z = axis[i]
            if rev[i]:                                        # c = v × S q̇
                _cross(w[i], z, cw[i])
                _cross(vl[i], z, cv[i])
                for k in range(3):
                    cw[i, k] *= qd
                    cv[i, k] *= qd
                    w[i, k] += qd * z[k]
            else:
                _cross(w[i], z, cv[i])
                for k in range(3):
                    cw[i, k] = 0.0
                    cv[i, k] *= qd
                    vl[i, k] += qd * z[k]
            m, c, Ic = mass[i], com[i], inertia[i]            # rigid-body blocks about the frame origin
            cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
            for a in range(3):
                for b in range(3):
                    A[i, a, b] = Ic[a, b] + m * ((cc if a == b else 0.0) - c[a] * c[b])
                    B[i, a, b] = 0.0
                    C[i, a, b] = m if a == b else 0.0
            B[i, 0, 1], B[i, 0, 2], B[i, 1, 2] = -m * c[2], m * c[1], -m * c[0]
            B[i, 1, 0], B[i, 2, 0], B[i, 2, 1] = m * c[2], -m * c[1], m * c[0]
            # pᴬ = v ×* (I v): h = I v = [A ω + B v; Bᵀ ω + m v]; v ×* h = [ω × hn + v × hf; ω × hf]
            for k in range(3):
                t1[k] = A[i, k, 0] * w[i, 0] + A[i, k, 1] * w[i, 1] + A[i, k, 2] * w[i, 2] \
                    + B[i, k, 0] * vl[i, 0] + B[i, k, 1] * vl[i, 1] + B[i, k, 2] * vl[i, 2]
                t2[k] = B[i, 0, k] * w[i, 0] + B[i, 1, k] * w[i, 1] + B[i, 2, k] * w[i, 2] + m * vl[i, k]
            _cross(w[i], t1, pn[i])
            _cross(vl[i], t2, t3)
            _cross(w[i], t2, pf[i])
            for k in range(3):
                pn[i, k] += t3[k]
        for i in range(nv - 1, -1, -1):                       # pass 2: articulated inertias
            z = axis[i]
            if rev[i]:                                        # U = Iᴬ S
                for k in range(3):
                    uw[i, k] = A[i, k, 0] * z[0] + A[i, k, 1] * z[1] + A[i, k, 2] * z[2]
                    uv[i, k] = B[i, 0, k] * z[0] + B[i, 1, k] * z[1] + B[i, 2, k] * z[2]
                D[i] = uw[i, 0] * z[0] + uw[i, 1] * z[1] + uw[i, 2] * z[2]
                u[i] = T[s, i] - (pn[i, 0] * z[0] + pn[i, 1] * z[1] + pn[i, 2] * z[2])
            else:
                for k in range(3):
                    uw[i, k] = B[i, k, 0] * z[0] + B[i, k, 1] * z[1] + B[i, k, 2] * z[2]
                    uv[i, k] = C[i, k, 0] * z[0] + C[i, k, 1] * z[1] + C[i, k, 2] * z[2]
                D[i] = uv[i, 0] * z[0] + uv[i, 1] * z[1] + uv[i, 2] * z[2]
                u[i] = T[s, i] - (pf[i, 0] * z[0] + pf[i, 1] * z[1] + pf[i, 2] * z[2])
            if not D[i] > dmin:                               # as aba._check_D: massless moving subtree
                if np.isfinite(D[i]):
                    return -2 - i
                out[s, i] = D[i]                              # D overflowed: reported as q̈_i
                return -2 - nv - (s * nv + i)
            j = parent[i]
            if j < 0:
                continue
            inv = 1.0 / D[i]
            for a in range(3):                                # Iᵃ = Iᴬ − U Uᵀ / D
                for b in range(3):
                    A[i, a, b] -= uw[i, a] * uw[i, b] * inv
                    B[i, a, b] -= uw[i, a] * uv[i, b] * inv
                    C[i, a, b] -= uv[i, a] * uv[i, b] * inv
            g = u[i] * inv                                    # pᵃ = pᴬ + Iᵃ c + U u / D
            for k in range(3):
                t1[k] = pn[i, k] + uw[i, k] * g
                t2[k] = pf[i, k] + uv[i, k] * g
                for l in range(3):
                    t1[k] += A[i, k, l] * cw[i, l] + B[i, k, l] * cv[i, l]
                    t2[k] += B[i, l, k] * cw[i, l] + C[i, k, l] * cv[i, l]
            Ri = R[i]                                         # into the parent frame: force transform
            _rot3(Ri, t2, t3)                                 # R pf
            _rot3(Ri, t1, t2)                                 # R pn
            _cross(p[i], t3, t1)
            for k in range(3):
                pf[j, k] += t3[k]
                pn[j, k] += t2[k] + t1[k]
            # Iᴬ_λ += Xᵀ Iᵃ X: rotate the blocks (A', B', C'), then shift by P = [p]×:
            # A += A' + P B'ᵀ − B' P − P C' P;  B += B' + P C';  C += C'
            Ar[:, :] = 0.0
            Br[:, :] = 0.0
            Cr[:, :] = 0.0
            _sandwich(Ri, A[i], M3, Ar)
            _sandwich(Ri, B[i], M3, Br)
            _sandwich(Ri, C[i], M3, Cr)
            px, py, pz = p[i, 0], p[i, 1], p[i, 2]
            Pm[0, 0], Pm[0, 1], Pm[0, 2] = 0.0, -pz, py
            Pm[1, 0], Pm[1, 1], Pm[1, 2] = pz, 0.0, -px
            Pm[2, 0], Pm[2, 1], Pm[2, 2] = -py, px, 0.0
            for a in range(3):
                for b in range(3):
                    PC, PBt, BP = 0.0, 0.0, 0.0
                    for k in range(3):
                        PC += Pm[a, k] * Cr[k, b]
                        PBt += Pm[a, k] * Br[b, k]
                        BP += Br[a, k] * Pm[k, b]
                    M3[a, b] = PC
                    A[j, a, b] += Ar[a, b] + PBt - BP
                    B[j, a, b] += Br[a, b] + PC
                    C[j, a, b] += Cr[a, b]
            for a in range(3):                                # − P C' P = − (P C') P
                for b in range(3):
                    A[j, a, b] -= M3[a, 0] * Pm[0, b] + M3[a, 1] * Pm[1, b] + M3[a, 2] * Pm[2, b]
        for i in range(nv):                                   # pass 3: accelerations
            j = parent[i]
            if j < 0:                                         # a_0 = [0; −g]
                for k in range(3):
                    t1[k] = 0.0
                _rot3t(R[i], mg, t2)
            else:                                             # X a_λ = [Rᵀ ȧω; Rᵀ (ȧv + ȧω × p)]
                _rot3t(R[i], aw[j], t1)
                _cross(aw[j], p[i], t3)
                for k in range(3):
                    t3[k] += av[j, k]
                _rot3t(R[i], t3, t2)
            for k in range(3):
                t1[k] += cw[i, k]
                t2[k] += cv[i, k]
            qdd = (u[i] - (uw[i, 0] * t1[0] + uw[i, 1] * t1[1] + uw[i, 2] * t1[2]
                           + uv[i, 0] * t2[0] + uv[i, 1] * t2[1] + uv[i, 2] * t2[2])) / D[i]
            out[s, i] = qdd
            if not np.isfinite(qdd):                          # an intermediate overflowed
                return -2 - nv - (s * nv + i)
            z = axis[i]
            for k in range(3):
                aw[i, k] = t1[k] + (qdd * z[k] if rev[i] else 0.0)
                av[i, k] = t2[k] + (0.0 if rev[i] else qdd * z[k])
    return -1


@njit(cache=True)
def aba_one(I, F, q, v, t, out):
    """One state (nv,) through aba_kernel."""
    return aba_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], t[np.newaxis, :], out[np.newaxis, :])

