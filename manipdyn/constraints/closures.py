"""Loop-closure kinematics: Φ(q), the constraint Jacobian Φ_q and the bias Φ̇_q q̇, exact — one compiled
source (``closure_rows``) on the one forward kinematics (forward_kinematics.fk_pass) and the frame Jacobians of
kinematics.py, used by ``closure_terms`` and by the closed-chain KKT kernel (constraints/fast.py).

For a closure between frame A (on the parent body) and frame B (on the child body), world coordinates:
  position rows (every type):  Φ = p_A − p_B,             Φ_q = J_A,v − J_B,v
  orientation rows:            Φ = a·b (a fixed in A, b in B, a ⊥ b when closed),
                               Φ_q = (a × b)ᵀ (J_A,ω − J_B,ω)   since d(a·b)/dt = (a × b)·(ω_A − ω_B)
  revolute: a ∈ {n1, n2} ⊥ the parent axis e_A, b = the child axis e_B (2 rows, 5 in all);
  fixed: (a, b) = (y_A, z_B), (z_A, x_B), (x_A, y_B) (3 rows, 6 in all); spherical: position only.
Φ̇_q q̇ is the same derivative taken once more at q̈ = 0 (chapter Eq. 26: Φ_q q̈ + Φ̇_q q̇ = 0):
  position rows (J̇_A,v − J̇_B,v) q̇;  orientation rows  d(a × b)/dt · (ω_A − ω_B) + (a × b)·(J̇_A,ω − J̇_B,ω) q̇,
  d(a × b)/dt = (ω_A × a) × b + a × (ω_B × b).
J, J̇ are kinematics.point_jacobian(_dot) of the closure points (world-aligned, Pinocchio's
LOCAL_WORLD_ALIGNED). Rows are labelled "<closure>.x|y|z" (position) and "<closure>.r1|r2|r3" (orientation).
A coupling (URDF+ gear, model.Constraint) is one linear row on the joint coordinates, labelled "<closure>.c":
  Φ = ratio Σ_{j ∈ path(A)} q_j − Σ_{j ∈ path(B)} q_j,   Φ_q = the same coefficients,   Φ̇_q q̇ = 0,
path(X) = the joints from the common ancestor of bodies A and B down to X (generalized_rbda's K matrix).
"""
from __future__ import annotations

import numba
import numpy as np

from .._jit import A2, A3, MODEL, entry, njit
from ..dynamics.forward_kinematics import fk_pass
from ..dynamics.kernel_inputs import nonfinite_input
from ..dynamics.model_arrays import kernel_arrays, unpack
from ..spatial import cross3, rot3
from ..dynamics.kinematics import body_point, point_jacobian, point_jacobian_dot, point_velocity
from ..dynamics.arguments import (as_batch, as_real, check_finite, check_model, check_output, quiet, raise_kernel_error,
                                  unbatch)
from ..errors import InputError


def row_labels(model):
    """Name of every constraint row, in order (a new list each call; ``model.kernel.closure_labels``)."""
    check_model(model)
    return list(model.kernel.closure_labels)


def n_rows(model) -> int:
    """m, the number of closure rows."""
    return sum(c.n_rows for c in model.constraints)


def closure_arrays(model):
    """Closures in kernel form (``model.kernel``): ints CI (nc, 3) = [parent, child, n_pairs], floats
    CF (nc, 24) = [pp, pc, a_1..a_3, b_1..b_3] (orientation pairs, kernel_form.orientation_pairs); a coupling has
    n_pairs = −1 and CF[k, 0] = its ratio."""
    return model.kernel.closure_ints, model.kernel.closure_floats


# -- the rows, compiled --------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def closure_scratch(nb, nv):
    """Scratch of closure_rows, allocated once per kernel call: forward kinematics (Rl, pl, Rw, pw, ω, ȯ),
    per side (A, B) J, J̇ (2, 6, nv), the body's axes, the point and its velocity; 3-vectors (8, 3)."""
    # slices of a few arrays, never many separate small ones (measured 2.3x slower per state in the frame
    # kernel, dynamics/kinematics.py)
    R3, B3, J6 = np.empty((2 * nb + 3, 3, 3)), np.zeros((4 * nb + 12, 3)), np.zeros((4, 6, nv))
    eye = R3[2 * nb + 2]
    eye[:, :] = 0.0
    eye[0, 0] = eye[1, 1] = eye[2, 2] = 1.0
    return (R3[:nb], B3[:nb], R3[nb:2 * nb], B3[nb:2 * nb], B3[2 * nb:3 * nb], B3[3 * nb:4 * nb], J6[:2], J6[2:],
            R3[2 * nb:2 * nb + 2], B3[4 * nb:4 * nb + 2], B3[4 * nb + 2:4 * nb + 4], eye, B3[4 * nb + 4:])


@njit(cache=True)                 # compiled once, called (not inlined) by closure_kernel and constrained_fd_kernel
def closure_rows(I, F, CI, CF, q, v, W, Phi, Jc, bias):
    """Φ (m,), Φ_q (m, nv) and, when v has entries, Φ̇_q q̇ (m,) of one state q (nq,), v (nv,), rows in
    row_labels order (the module docstring gives them); W = closure_scratch(nb, nv)."""
    mdl = unpack(I, F)
    parent, iq, iv, nvj, S = mdl.parent, mdl.iq, mdl.iv, mdl.nvj, mdl.S
    Rl, pl, Rw, pw, ww, vw, J, dJ, Rs, x, xd, eye, t = W
    a, b, axb, wA, wB, t1, t2, t3 = t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7]
    nv, with_v = Jc.shape[1], v.shape[0] > 0
    fk_pass(mdl, q, v, Rl, pl, Rw, pw, ww, vw)
    row = 0
    for k in range(CI.shape[0]):
        if CI[k, 2] < 0:                                      # coupling: one linear row, Φ̇_q q̇ = 0
            Phi[row] = _coupling_row(parent, iq, iv, CI[k, 0], CI[k, 1], CF[k, 0], q, Jc[row])
            if with_v:
                bias[row] = 0.0
            row += 1
            continue
        for side in range(2):                                 # 0: A on the parent, 1: B on the child
            body = CI[k, side]
            body_point(body, Rw, pw, eye, CF[k, 3 * side:3 * side + 3], Rs[side], x[side])   # Rs: the body's axes
            point_jacobian(parent, iv, nvj, S, body, Rw, pw, x[side], J[side])
            if with_v:
                point_velocity(body, pw, ww, vw, x[side], xd[side])
                point_jacobian_dot(parent, iv, nvj, S, body, Rw, pw, ww, vw, x[side], xd[side], dJ[side])
        for d in range(3):                                    # position rows: p_A − p_B
            Phi[row] = x[0, d] - x[1, d]
            acc = 0.0
            for r in range(nv):
                Jc[row, r] = J[0, d, r] - J[1, d, r]
                if with_v:
                    acc += (dJ[0, d, r] - dJ[1, d, r]) * v[r]   # (J̇_A,v − J̇_B,v) q̇
            if with_v:
                bias[row] = acc
            row += 1
        _omega(CI[k, 0], ww, wA)
        _omega(CI[k, 1], ww, wB)
        for m in range(CI[k, 2]):                             # orientation rows: a·b
            rot3(Rs[0], CF[k, 6 + 3 * m:9 + 3 * m], a)
            rot3(Rs[1], CF[k, 15 + 3 * m:18 + 3 * m], b)
            cross3(a, b, axb)
            Phi[row] = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
            acc = 0.0
            for r in range(nv):                               # (a × b)ᵀ (J_A,ω − J_B,ω), its J̇ q̇ term
                Jc[row, r] = _axb_rows(axb, J, r)
                if with_v:
                    acc += _axb_rows(axb, dJ, r) * v[r]
            if with_v:                                        # d(a × b)/dt = (ω_A × a) × b + a × (ω_B × b)
                cross3(wA, a, t1)
                cross3(t1, b, t2)
                cross3(wB, b, t1)
                cross3(a, t1, t3)
                gyro = 0.0
                for c in range(3):
                    gyro += (t2[c] + t3[c]) * (wA[c] - wB[c])
                bias[row] = gyro + acc
            row += 1


@njit(cache=True, inline="always")
def _coupling_row(parent, iq, iv, A, B, ratio, q, Jrow):
    """Φ = ratio Σ q_j (joints from the common ancestor down to body A) − Σ q_j (down to body B); Jrow (nv,)
    gets the coefficients. Walks up from the deeper index (parent[i] < i) until the two meet."""
    for r in range(Jrow.shape[0]):
        Jrow[r] = 0.0
    phi = 0.0
    while A != B:
        if A > B:
            phi += ratio * q[iq[A]]
            Jrow[iv[A]] += ratio
            A = parent[A]
        else:
            phi -= q[iq[B]]
            Jrow[iv[B]] -= 1.0
            B = parent[B]
    return phi


@njit(cache=True, inline="always")
def _axb_rows(axb, J, r):
    """(a × b)·(J_A,ω − J_B,ω) of column r, J = (J_A, J_B) (2, 6, nv)."""
    return (axb[0] * (J[0, 3, r] - J[1, 3, r]) + axb[1] * (J[0, 4, r] - J[1, 4, r])
            + axb[2] * (J[0, 5, r] - J[1, 5, r]))


@njit(cache=True, inline="always")
def _omega(b, ww, out):
    """out = world angular velocity of body b (zero for the fixed base)."""
    for c in range(3):
        out[c] = ww[b, c] if b >= 0 else 0.0


@njit(cache=True)
def closure_kernel(I, F, CI, CF, Q, V, Phi, Jc, bias):
    """closure_rows for every state: Q (N, nq), V (N, nv) or (N, 0); Φ (N, m), Φ_q (N, m, nv), Φ̇_q q̇ (N, m).
    Returns its status (dynamics/status.py)."""
    N = Q.shape[0]
    W = closure_scratch(I.shape[1], Jc.shape[2])
    for s in range(N):
        bad = nonfinite_input(Q, V, s)
        if bad >= 0:
            return bad
        closure_rows(I, F, CI, CF, Q[s], V[s], W, Phi[s], Jc[s], bias[s])
    return -1


# The compiled code every call reaches (``_jit.entry``): closures in kernel form (``closure_arrays``)
CLOSURE_FORM = (numba.types.Array(numba.int64, 2, "C"), numba.types.Array(numba.float64, 2, "C"))
CLOSURE = entry(closure_kernel, *MODEL, *CLOSURE_FORM, A2, A2, A2, A3, A2)


@quiet
def closure_terms(model, q, v=None):
    """Φ (N, m), Φ_q (N, m, nv) and, with v, Φ̇_q q̇ (N, m) (None without v) for a batch q (N, nq), v (N, nv),
    or Φ (m,), Φ_q (m, nv), Φ̇_q q̇ (m,) for one state."""
    if v is None:
        (Q,), single = as_batch(model, q=q)
        V = None
    else:
        (Q, V), single = as_batch(model, q=q, v=v)
    out = _closure_terms(model, Q, V)
    inputs = dict(q=Q) if V is None else dict(q=Q, v=V)
    for name, x in zip(("Φ", "Φ_q", "Φ̇_q q̇"), out):
        if x is not None:
            check_output("closure_terms", name, x, model, inputs, what="closure row", labels=row_labels(model))
    return tuple(None if x is None else unbatch(x, single) for x in out)


def _closure_terms(model, Q, V=None):
    """closure_terms on finite batches Q (N, nq), V (N, nv), results unchecked (batch form)."""
    N, m = Q.shape[0], n_rows(model)
    Phi, Jc, bias = np.empty((N, m)), np.empty((N, m, model.nv)), np.empty((N, m))
    if m:
        Q = np.asarray(Q, float)
        Vk = np.empty((N, 0)) if V is None else np.asarray(V, float)
        code = CLOSURE.call(*kernel_arrays(model), *closure_arrays(model), Q, Vk, Phi, Jc, bias)
        if code != -1:
            raise_kernel_error(model, code, ("q",) if V is None else ("q", "v"), (Q,) if V is None else (Q, Vk),
                               "closure_terms")
    return Phi, Jc, (bias if V is not None else None)


RANK_RTOL = 1e-6   # rows whose new direction is below 1e-6 of the largest row are redundant: off the
#                    manifold (mid-step states) the ideally redundant rows keep components ~|Φ|, which a
#                    tighter tolerance would take as rank and make the KKT solve singular


def independent_rows(J, rtol=RANK_RTOL, phi=None):
    """Greedy rank-revealing row selection: indices of rows of J (m, nv) that add rank, in order.

    A row is kept when its component orthogonal to the rows kept so far exceeds rtol · max row norm;
    the rows left out are the redundant ones (dependent on earlier rows). Off the closures (|Φ| > 0, e.g.
    inside an integrator step) the ideally redundant rows gain spurious components of the order of |Φ|:
    given Φ, the tolerance is raised to 100 max|Φ| / (max row norm) so they are not taken as rank.
    """
    J = as_real("J", J)
    if J.ndim != 2:
        raise InputError(f"J has shape {J.shape}; expected one closure Jacobian (m, nv)")
    check_finite("J", J)
    scale = max(float(np.max(np.linalg.norm(J, axis=1), initial=0.0)), 1e-300)
    if phi is not None and len(phi):
        rtol = max(rtol, 100.0 * float(np.max(np.abs(phi))) / scale)
    basis, keep = [], []
    for k, row in enumerate(J):
        r = row.copy()
        for b in basis:
            r -= (r @ b) * b
        nr = np.linalg.norm(r)
        if nr > rtol * scale:
            basis.append(r / nr)
            keep.append(k)
    return keep
