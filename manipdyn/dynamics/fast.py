"""Compiled kernels (numba) for the hot paths: the same recursions as rnea.py and lagrange.py (the
readable references, which the tests hold these kernels to), written with scalar 3-vectors so that one
state costs no numpy dispatch and a batch runs in one compiled loop.

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


@njit(cache=True)
def rnea_kernel(I, F, Q, V, A, tau):
    """τ for every state of (Q, V, A) (N, nv) into tau (N, nv): the chapter's Eqs. 3–18. Returns -1, the
    flat index of the first non-finite input, or -2 - nv - (flat index) of the first non-finite τ."""
    parent, rev, axis, R0, p0, mass, com, inertia, mg = _unpack(I, F)
    N, nv = Q.shape
    R = np.empty((nv, 3, 3))
    p = np.empty((nv, 3))
    w = np.empty((nv, 3))
    dw = np.empty((nv, 3))
    dv = np.empty((nv, 3))
    f = np.empty((nv, 3))
    n = np.empty((nv, 3))
    for s in range(N):
        for i in range(nv):                      # outward recursion
            q, qd, qdd = Q[s, i], V[s, i], A[s, i]
            if not (np.isfinite(q) and np.isfinite(qd) and np.isfinite(qdd)):
                return s * nv + i
            _joint_rotation(R0[i], axis[i], rev[i], q, R[i])
            Ri = R[i]
            _joint_translation(R0[i], p0[i], axis[i], rev[i], q, p[i])
            j = parent[i]
            if j < 0:
                w0x = w0y = w0z = 0.0
                dw0x = dw0y = dw0z = 0.0
                a0x, a0y, a0z = mg[0], mg[1], mg[2]
            else:
                w0x, w0y, w0z = w[j, 0], w[j, 1], w[j, 2]
                dw0x, dw0y, dw0z = dw[j, 0], dw[j, 1], dw[j, 2]
                # v̇_{i-1} + ω̇_{i-1} × p + ω_{i-1} × (ω_{i-1} × p)   (Eq. 6, in frame i−1)
                px, py, pz = p[i, 0], p[i, 1], p[i, 2]
                cx, cy, cz = w0y * pz - w0z * py, w0z * px - w0x * pz, w0x * py - w0y * px
                a0x = dv[j, 0] + dw0y * pz - dw0z * py + w0y * cz - w0z * cy
                a0y = dv[j, 1] + dw0z * px - dw0x * pz + w0z * cx - w0x * cz
                a0z = dv[j, 2] + dw0x * py - dw0y * px + w0x * cy - w0y * cx
            zx, zy, zz = axis[i, 0], axis[i, 1], axis[i, 2]
            # rotate into frame i: x_i = Rᵀ x_{i-1}
            wix = Ri[0, 0] * w0x + Ri[1, 0] * w0y + Ri[2, 0] * w0z
            wiy = Ri[0, 1] * w0x + Ri[1, 1] * w0y + Ri[2, 1] * w0z
            wiz = Ri[0, 2] * w0x + Ri[1, 2] * w0y + Ri[2, 2] * w0z
            dwx = Ri[0, 0] * dw0x + Ri[1, 0] * dw0y + Ri[2, 0] * dw0z
            dwy = Ri[0, 1] * dw0x + Ri[1, 1] * dw0y + Ri[2, 1] * dw0z
            dwz = Ri[0, 2] * dw0x + Ri[1, 2] * dw0y + Ri[2, 2] * dw0z
            dvx = Ri[0, 0] * a0x + Ri[1, 0] * a0y + Ri[2, 0] * a0z
            dvy = Ri[0, 1] * a0x + Ri[1, 1] * a0y + Ri[2, 1] * a0z
            dvz = Ri[0, 2] * a0x + Ri[1, 2] * a0y + Ri[2, 2] * a0z
            if rev[i]:                           # Eqs. 3, 5
                dwx += qdd * zx + qd * (wiy * zz - wiz * zy)
                dwy += qdd * zy + qd * (wiz * zx - wix * zz)
                dwz += qdd * zz + qd * (wix * zy - wiy * zx)
                wix += qd * zx
                wiy += qd * zy
                wiz += qd * zz
            else:                                # Eq. 12: + 2 ω × ḋ z + d̈ z
                dvx += 2.0 * qd * (wiy * zz - wiz * zy) + qdd * zx
                dvy += 2.0 * qd * (wiz * zx - wix * zz) + qdd * zy
                dvz += 2.0 * qd * (wix * zy - wiy * zx) + qdd * zz
            w[i, 0], w[i, 1], w[i, 2] = wix, wiy, wiz
            dw[i, 0], dw[i, 1], dw[i, 2] = dwx, dwy, dwz
            dv[i, 0], dv[i, 1], dv[i, 2] = dvx, dvy, dvz
            # Eq. 7, 13, 14: inertial force and moment; moment about the frame origin (Eq. 16's p_C × f_C)
            cx_, cy_, cz_ = com[i, 0], com[i, 1], com[i, 2]
            ux, uy, uz = wiy * cz_ - wiz * cy_, wiz * cx_ - wix * cz_, wix * cy_ - wiy * cx_
            ax = dvx + dwy * cz_ - dwz * cy_ + wiy * uz - wiz * uy
            ay = dvy + dwz * cx_ - dwx * cz_ + wiz * ux - wix * uz
            az = dvz + dwx * cy_ - dwy * cx_ + wix * uy - wiy * ux
            m = mass[i]
            fx, fy, fz = m * ax, m * ay, m * az
            I = inertia[i]
            Iwx = I[0, 0] * wix + I[0, 1] * wiy + I[0, 2] * wiz
            Iwy = I[1, 0] * wix + I[1, 1] * wiy + I[1, 2] * wiz
            Iwz = I[2, 0] * wix + I[2, 1] * wiy + I[2, 2] * wiz
            f[i, 0], f[i, 1], f[i, 2] = fx, fy, fz
            n[i, 0] = I[0, 0] * dwx + I[0, 1] * dwy + I[0, 2] * dwz + wiy * Iwz - wiz * Iwy + cy_ * fz - cz_ * fy
            n[i, 1] = I[1, 0] * dwx + I[1, 1] * dwy + I[1, 2] * dwz + wiz * Iwx - wix * Iwz + cz_ * fx - cx_ * fz
            n[i, 2] = I[2, 0] * dwx + I[2, 1] * dwy + I[2, 2] * dwz + wix * Iwy - wiy * Iwx + cx_ * fy - cy_ * fx
        for i in range(nv - 1, -1, -1):          # inward recursion, Eqs. 15–18
            if rev[i]:
                tau[s, i] = n[i, 0] * axis[i, 0] + n[i, 1] * axis[i, 1] + n[i, 2] * axis[i, 2]
            else:
                tau[s, i] = f[i, 0] * axis[i, 0] + f[i, 1] * axis[i, 1] + f[i, 2] * axis[i, 2]
            j = parent[i]
            if j >= 0:
                Ri = R[i]
                rfx = Ri[0, 0] * f[i, 0] + Ri[0, 1] * f[i, 1] + Ri[0, 2] * f[i, 2]
                rfy = Ri[1, 0] * f[i, 0] + Ri[1, 1] * f[i, 1] + Ri[1, 2] * f[i, 2]
                rfz = Ri[2, 0] * f[i, 0] + Ri[2, 1] * f[i, 1] + Ri[2, 2] * f[i, 2]
                px, py, pz = p[i, 0], p[i, 1], p[i, 2]
                f[j, 0] += rfx
                f[j, 1] += rfy
                f[j, 2] += rfz
                n[j, 0] += Ri[0, 0] * n[i, 0] + Ri[0, 1] * n[i, 1] + Ri[0, 2] * n[i, 2] + py * rfz - pz * rfy
                n[j, 1] += Ri[1, 0] * n[i, 0] + Ri[1, 1] * n[i, 1] + Ri[1, 2] * n[i, 2] + pz * rfx - px * rfz
                n[j, 2] += Ri[2, 0] * n[i, 0] + Ri[2, 1] * n[i, 1] + Ri[2, 2] * n[i, 2] + px * rfy - py * rfx
        for i in range(nv):                      # the result is finite (else an intermediate overflowed)
            if not np.isfinite(tau[s, i]):
                return -2 - nv - (s * nv + i)
    return -1


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
def crba_kernel(I, F, Q, M):
    """M(q) (N, nv, nv) by the composite-rigid-body algorithm, as lagrange._crba: composites (m, h = m c,
    I_O about the frame origin) carried to the parent, then columns by force transmission. Returns -1,
    the flat index of the first non-finite q, or -2 - nv - (flat index) of the first non-finite entry of M."""
    parent, rev, axis, R0, p0, mass, com, inertia, mg = _unpack(I, F)
    N, nv = Q.shape
    R = np.empty((nv, 3, 3))
    p = np.empty((nv, 3))
    mc = np.empty(nv)
    h = np.empty((nv, 3))
    Io = np.empty((nv, 3, 3))
    tmp = np.empty((3, 3))
    hr, f, n, t = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for s in range(N):
        for i in range(nv):
            q = Q[s, i]
            if not np.isfinite(q):
                return s * nv + i
            _joint_rotation(R0[i], axis[i], rev[i], q, R[i])
            _joint_translation(R0[i], p0[i], axis[i], rev[i], q, p[i])
            c = com[i]
            mc[i] = mass[i]
            cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
            for a in range(3):
                h[i, a] = mass[i] * c[a]
                for b in range(3):
                    Io[i, a, b] = inertia[i, a, b] + mass[i] * ((cc if a == b else 0.0) - c[a] * c[b])
        for i in range(nv - 1, -1, -1):          # pass 1: composite bodies
            j = parent[i]
            if j < 0:
                continue
            _rot3(R[i], h[i], hr)
            _sandwich(R[i], Io[i], tmp, Io[j])
            pp = p[i]
            ph = pp[0] * hr[0] + pp[1] * hr[1] + pp[2] * hr[2]
            p2 = pp[0] * pp[0] + pp[1] * pp[1] + pp[2] * pp[2]
            for a in range(3):                   # shift: m(|p|²1 − p pᵀ) + 2(p·h)1 − p hᵀ − h pᵀ
                for b in range(3):
                    Io[j, a, b] += mc[i] * ((p2 if a == b else 0.0) - pp[a] * pp[b]) \
                        + (2.0 * ph if a == b else 0.0) - pp[a] * hr[b] - hr[a] * pp[b]
            for a in range(3):
                h[j, a] += hr[a] + mc[i] * pp[a]
            mc[j] += mc[i]
        M[s, :, :] = 0.0                          # bodies on different branches do not couple
        for i in range(nv):                      # pass 2: column i
            z = axis[i]
            if rev[i]:
                _cross(z, h[i], f)
                _rot3(Io[i], z, n)
                M[s, i, i] = n[0] * z[0] + n[1] * z[1] + n[2] * z[2]
            else:
                for a in range(3):
                    f[a] = mc[i] * z[a]
                _cross(h[i], z, n)
                M[s, i, i] = f[0] * z[0] + f[1] * z[1] + f[2] * z[2]
            k = i
            while parent[k] >= 0:
                _rot3(R[k], f, t)
                _rot3(R[k], n, hr)
                _cross(p[k], t, n)
                for a in range(3):
                    f[a] = t[a]
                    n[a] += hr[a]
                k = parent[k]
                zk = axis[k]
                x = (n[0] * zk[0] + n[1] * zk[1] + n[2] * zk[2]) if rev[k] else (f[0] * zk[0] + f[1] * zk[1] + f[2] * zk[2])
                M[s, i, k] = x
                M[s, k, i] = x
        for i in range(nv):                      # the result is finite (else an intermediate overflowed)
            for k in range(nv):
                if not np.isfinite(M[s, i, k]):
                    return -2 - nv - ((s * nv + i) * nv + k)
    return -1


@njit(cache=True)
def rnea_one(I, F, q, v, a, tau):
    """One state (nv,) through rnea_kernel, without Python-side reshapes."""
    return rnea_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], a[np.newaxis, :], tau[np.newaxis, :])


@njit(cache=True)
def crba_one(I, F, q, M):
    """One state (nv,) through crba_kernel."""
    return crba_kernel(I, F, q[np.newaxis, :], M[np.newaxis, :, :])
