"""Recursive Newton–Euler inverse dynamics (Luh, Walker & Paul 1980), in the chapter's vector form.

One source: the kernel below is the chapter's recursion (Eqs. 3–18 with the errata of docs/design.md §6), compiled
by numba, and the same text runs as plain Python under MANIPDYN_NOJIT=1. Every vector is a 3-vector in its own
link frame (the chapter's primes): body i's frame is its URDF link frame. (R, p) = (Rl[i], pl[i]) is body i in
its parent λ(i) (``joints.joint_placement``), so the chapter's R^i_{i−1} x is Rᵀ x (``rot_t``). A tree replaces
"link i+1" by the children of link i; parent[i] < i, so one sweep each way suffices.

The joint enters through its motion subspace S (``joints``: rows [linear; angular], constant in the body frame):
with (vl, va) = S q̇ and (al, aa) = S q̈ of joint i, and w_in, dw_in, dv_in the parent's ω', ω̇', v̇' moved to
body i's origin and axes, the chapter's revolute (Eqs. 3–6) and prismatic (Eqs. 9–12) cases are one formula:

    ω'_i  = w_in + va                                    (Eq. 3; prismatic Eq. 9)
    ω̇'_i  = dw_in + aa + w_in × va                       (Eq. 5; prismatic Eq. 10)
    v̇'_i  = dv_in + al + 2 w_in × vl + va × vl           (Eq. 6; prismatic Eq. 12; free flyer: al + va × vl)
    τ_i   = Sᵀ [f'_i; n'_i]                              (Eqs. 17, 18)

Gravity enters as a base acceleration: ω'_0 = ω̇'_0 = 0, v̇'_0 = −g (docs/design.md §6). A free-flyer root (q = [x y z
qx qy qz qw], v = [linear; angular] in the body frame) is the same recursion: its τ entries are the wrench
[f'; n'] the root body needs, in its own frame about its origin.

External wrenches (f_ext = {frame: (force, moment)}: what the environment applies on that body, about the
frame's origin, in the frame's axes or in world axes) reach the kernel as rows (``state.wrench_rows``): the
wrench (N, K, 6) = [force; moment] in body axes ("local") or world axes ("world": the kernel turns it into the
body with the orientation it accumulates in the same outward pass), the body (K,) and the frame's origin in
body axes (K, 3), about which the moment is taken.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .._jit import C1, CONTRACT, MODEL, STATE, entry, njit
from ..joints import joint_force, joint_placement, joint_velocity
from ..model import MimicModel
from . import mimic
from ..spatial import add, cross, first_nonfinite, put, rot, rot_t, scale, sub, vec
from .core import finite_state, kernel_arrays, unpack, wrench_rows_of
from .state import (as_batch, check_output, fast, fast_shape, fast_wrenches, quiet, raise_kernel_error, unbatch, wrench_rows)

TERMS = ("w", "dw", "v", "dv", "acc", "dvc", "fc", "nc", "f", "n")   # 3-vectors per link, then R (3, 3)
NT = 3 * len(TERMS) + 9                                            # columns of the per-link terms array
_NO_X, _NO_B, _NO_P, _NO_T = np.zeros((0, 0, 6)), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 0, NT))
_QVA = ("q", "v", "a")
_NO_V = np.empty(0)


def rnea(model, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """τ = M(q) q̈ + C(q, q̇) q̇ + g(q) − Σ J_kᵀ f_ext,k, by the chapter's Eqs. 3–18 (32a–i).

    Parameters
    ----------
    q : (nq,) or (N, nq) configuration; v, a : (nv,) or (N, nv) rates and accelerations (model.v_names order).
    f_ext : {link or frame name: (force (3,)|(N, 3), moment (3,)|(N, 3))}, wrench the environment applies
        on that body about the frame's origin, in the frame's axes (f_ext_frame="local") or world axes.
    Returns
    -------
    tau : (nv,) or (N, nv) joint torques (revolute), forces (prismatic), root wrench [f; n] (free flyer).
    """
    k = fast(model, q, v, a) if f_ext is None and f_ext_frame == "local" else None
    if k is not None:                                           # one float64 state: straight into the kernel
        tau = np.empty(v.shape)
        code = RNEA_ONE.call(k[0], k[1], q, v, a, tau)
        if code == -1:
            return tau
        raise_kernel_error(model, code, _QVA, (q, v, a), "rnea", "tau", tau)
    if f_ext is not None:                                       # one state with wrenches: rows kept per model
        k = fast(model, q, v, a)
        ext = fast_wrenches(model, f_ext, f_ext_frame) if k is not None else None
        if ext is not None:
            tau = np.empty(v.shape)
            if rnea_fext_one(k[0], k[1], q, v, a, *ext, f_ext_frame == "world", tau) == -1:
                return tau
        nd = 0                                                  # else the checked path says what is wrong
    else:
        nd = fast_shape(model, q, v, a) if f_ext_frame == "local" else 0
    if nd == 1:                                                 # one state, no Python-side reshapes
        tau = np.empty(v.shape)
        code = RNEA_ONE.call(*kernel_arrays(model), q, v, a, tau)
    elif nd == 2 and f_ext is None:
        tau = np.empty(v.shape)
        code = rnea_batch(*kernel_arrays(model), q, v, a, _NO_X, _NO_B, _NO_P, False, tau, np.zeros((0, 0, NT)))
    elif type(model) is MimicModel:                             # τ = Gᵀ τ_full (dynamics/mimic.py)
        return mimic.generalized_force(model, rnea, q, v, a, f_ext=f_ext, f_ext_frame=f_ext_frame)
    else:                                                       # checked and converted first
        (Q, V, A), single = as_batch(model, q=q, v=v, a=a)
        return unbatch(_run(model, Q, V, A, f_ext, f_ext_frame, "rnea", single=single)[0], single)
    if code != -1:
        raise_kernel_error(model, code, _QVA, (q, v, a), "rnea", "tau", tau)
    return tau


def nonlinear_effects(model, q, v):
    """h = C(q, q̇) q̇ + g(q) (nv,) or (N, nv): the Newton–Euler recursion with q̈ = 0 (Pinocchio's
    nonLinearEffects), τ = M q̈ + h."""
    return _bias(model, q, v, "nonlinear_effects")


def gravity_torques(model, q):
    """g(q) = ∂V/∂q (nv,) or (N, nv), V = −Σ_b m_b gᵀ c_b: the Newton–Euler recursion with q̇ = q̈ = 0."""
    return _bias(model, q, None, "gravity_torques")


def _bias(model, q, v, call):
    """rnea(q, v, 0) (v = None: rnea(q, 0, 0)) through bias_one / bias_kernel; anything but float64 arrays
    is checked and converted first."""
    k = fast(model, q) if v is None else fast(model, q, v)
    if k is not None:                                         # one float64 state: straight into the kernel
        tau = np.empty(model.kernel.v_shape)
        code = BIAS_ONE.call(k[0], k[1], q, _NO_V if v is None else v, tau)
        if code == -1:
            return tau
    arrays = (q,) if v is None else (q, v)
    nd = fast_shape(model, *arrays)
    if nd == 0 and type(model) is MimicModel:                 # Gᵀ h_full, Gᵀ g_full (dynamics/mimic.py)
        return mimic.generalized_force(model, rnea, *arrays)
    if nd == 0:
        batches, single = as_batch(model, **dict(zip(_QVA, arrays)))
        if not model.njoints:
            return unbatch(np.zeros((batches[0].shape[0], model.nv)), single)
        arrays, nd = tuple(unbatch(x, single) for x in batches), 1 if single else 2
    q = arrays[0]
    v = arrays[1] if len(arrays) > 1 else np.empty(q.shape[:-1] + (0,))
    tau = np.empty(q.shape[:-1] + (model.nv,))
    code = (BIAS_ONE.call if nd == 1 else bias_kernel)(*kernel_arrays(model), q, v, tau)
    if code != -1:
        raise_kernel_error(model, code, _QVA[:len(arrays)], arrays, call, "g" if len(arrays) == 1 else "h", tau)
    return tau


def rnea_terms(model, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """Every per-link intermediate of the Newton–Euler recursion, in link frames, from the same kernel pass.

    Returns a dict of arrays; per-link arrays have shape (N, nb, 3) (or (nb, 3) for one state), nb =
    model.njoints bodies in q order:
      w, dw    ω'_i, ω̇'_i                      (Eqs. 3, 5; prismatic 9, 10)
      v        v'_i, velocity of the frame origin (Eqs. 4, 11)
      dv       v̇'_i, including the −g base offset (Eqs. 6, 12)
      acc      v̇'_i without gravity: the origin's classical linear acceleration
      dvc      v̇'_Ci, including −g                (Eq. 7)
      fc, nc   inertial force m v̇'_Ci and moment I ω̇' + ω' × I ω' about the CoM (Eqs. 13, 14)
      f, n     force and moment link i−1 exerts on link i, about frame i's origin (Eqs. 15, 16)
      R        (N, nb, 3, 3) orientation of each link frame in the base frame
      tau      (N, nv) joint torques/forces (Eqs. 17, 18); a free-flyer root's six entries are its f, n
    """
    (Q, V, A), single = as_batch(model, q=q, v=v, a=a)
    tau, T = _run(model, Q, V, A, f_ext, f_ext_frame, "rnea_terms", terms=True, single=single)
    out = {k: T[:, :, 3 * m:3 * m + 3] for m, k in enumerate(TERMS)}
    out["R"] = T[:, :, 3 * len(TERMS):].reshape(T.shape[:2] + (3, 3))
    inputs = dict(q=Q, v=V, a=A)
    for k, x in out.items():
        check_output("rnea_terms", k, x, model, inputs, "link")
    out["tau"] = tau
    return {k: unbatch(x, single) for k, x in out.items()}


@quiet
def _run(model, Q, V, A, f_ext, f_ext_frame, call, terms=False, single=False):
    """The kernel on checked batches Q (N, nq), V, A (N, nv): τ (N, nv) and the per-link terms (N, nb, NT)
    (or an empty array); f_ext checked and converted first. A batch goes through rnea_batch (fused
    multiply-adds), one state (``single``) through the kernel as written, as the one-state fast paths do."""
    N, nb = Q.shape[0], model.njoints
    X, body, point = wrench_rows(model, f_ext, f_ext_frame, N)
    tau, T = np.zeros((N, model.nv)), np.zeros((N, nb, NT) if terms else (0, nb, NT))
    if nb == 0:
        return tau, T
    Q, V, A = (np.ascontiguousarray(x) for x in (Q, V, A))
    code = (rnea_kernel if single else rnea_batch)(*kernel_arrays(model), Q, V, A, X, body, point,
                                                   f_ext_frame == "world", tau, T)
    if code != -1:
        raise_kernel_error(model, code, _QVA, (Q, V, A), call, "tau", tau)
    return tau, T


# -- the kernel -----------------------------------------------------------------------------------------------
# 3-vectors inside the recursion are 3-tuples (spatial.py's vec, put, add, cross, rot, rot_t).


@njit(cache=True)
def rnea_one(I, F, q, v, a, tau):
    """τ (nv,) of one state q (nq,), v, a (nv,), no external wrench, into tau: ``rnea_kernel`` with N = 1."""
    return rnea_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], a[np.newaxis, :], _NO_X, _NO_B, _NO_P, False,
                       tau[np.newaxis, :], np.zeros((0, 0, NT)))


@njit(cache=True)
def rnea_fext_one(I, F, q, v, a, f, m, P, world, tau):
    """τ (nv,) of one state with one external wrench in ``state.fast_wrenches``' form: ``rnea_kernel``, N = 1."""
    X, xb, xp = wrench_rows_of(f, m, P)
    return rnea_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], a[np.newaxis, :], X, xb, xp, world,
                       tau[np.newaxis, :], np.zeros((0, 0, NT)))


@njit(cache=True, inline="always")
def bias_kernel(I, F, Q, V, tau):
    """τ = rnea(q, v, 0) for every state of Q (N, nq), V (N, nv) — or rnea(q, 0, 0) when V has no columns —
    into tau (N, nv): ``rnea_kernel`` with zero accelerations."""
    Z = np.zeros((Q.shape[0], tau.shape[1]))
    return rnea_kernel(I, F, Q, Z if V.shape[1] == 0 else V, Z, _NO_X, _NO_B, _NO_P, False, tau, np.zeros((0, 0, NT)))


@njit(cache=True)
def bias_one(I, F, q, v, tau):
    """One state: q (nq,), v (nv,) or (0,), tau (nv,), through bias_kernel."""
    return bias_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], tau[np.newaxis, :])


# The one-state calls' compiled code (``_jit.entry``): q, v, a as the caller gave them
RNEA_ONE = entry(rnea_one, *MODEL, STATE, STATE, STATE, C1)
BIAS_ONE = entry(bias_one, *MODEL, STATE, STATE, C1)


@njit(cache=True, fastmath=CONTRACT)
def rnea_batch(I, F, Q, V, A, X, xb, xp, world, tau, T):
    """``rnea_kernel`` for a batch of states, compiled with fused multiply-adds (_jit.CONTRACT: batched rnea's
    speed target needs them); one state, whatever its form, goes through the kernel as written."""
    return rnea_kernel(I, F, Q, V, A, X, xb, xp, world, tau, T)


Work = namedtuple("Work", "Rl Rw pl w dw vel dv dvc fc nc f n sv")
Work.__doc__ = """Scratch of one recursion (``rnea_workspace``), per body i (nb rows): Rl, pl its placement in its parent
(3, 3), (3,); Rw its world orientation (3, 3); the 3-vectors of TERMS: w ω'_i, dw ω̇'_i, vel v'_i, dv v̇'_i,
dvc v̇'_Ci, fc f'_Ci, nc n'_Ci, f f'_i, n n'_i; sv (4, 3) spare 3-vectors."""


@njit(cache=True, inline="always")
def rnea_workspace(nb):
    """The ``Work`` of a model with nb bodies, cut from three allocations."""
    RR, B, sv = np.empty((2, nb, 3, 3)), np.empty((10, nb, 3)), np.empty((4, 3))
    return Work(RR[0], RR[1], B[0], B[1], B[2], B[3], B[4], B[5], B[6], B[7], B[8], B[9], sv)


@njit(cache=True, inline="always")
def rnea_kernel(I, F, Q, V, A, X, xb, xp, world, tau, T):
    """τ = Sᵀ [f'; n'] of every joint for every state (Eqs. 3–18): outward pass, external wrenches, inward pass.

    I, F: the model in core form (``core.kernel_arrays``); Q (N, nq), V, A (N, nv); X (N, K, 6) external
    wrenches [force; moment about xp[k]] on bodies xb (K,) int, in body axes (world=False) or world axes
    (world=True), K = 0 for none; tau (N, nv) result; T (N, nb, NT) per-link terms (TERMS, then R), or an
    array with no rows to skip them. The bodies' world orientations are accumulated only when world
    wrenches or the terms need them. Returns -1, ≥ 0 for a non-finite input (state index), or −2 − nb − k
    for a non-finite τ at flat index k of tau.
    """
    mdl = unpack(I, F)
    N, nb, nv = Q.shape[0], I.shape[1], V.shape[1]
    work = rnea_workspace(nb)
    keep = T.shape[0] > 0
    for s in range(N):
        if not finite_state(Q, V, A, s):
            return s
        outward(mdl, work, Q[s], V[s], A[s], world or keep, keep)
        external(work, X, s, xb, xp, world)
        inward(mdl, work, tau[s])
        if keep:
            store_terms(mdl, work, T[s])
        k = first_nonfinite(tau, s)            # the result is finite (else an intermediate overflowed)
        if k >= 0:
            return -2 - nb - (s * nv + k)
    return -1


@njit(cache=True, inline="always")
def outward(mdl, work, q, v, a, orient, terms):
    """Outward pass i = 1 … nb (Eqs. 3–14): ω'_i, ω̇'_i, v̇'_i of every body, its inertial wrench
    (``inertial``), if terms the origin velocity v'_i (Eqs. 4, 11: no torque needs it), and if orient its
    world orientation Rw_i = Rw_λ R."""
    parent, kind, iq, iv, nvj, S = mdl.parent, mdl.kind, mdl.iq, mdl.iv, mdl.nvj, mdl.S
    axis, R0, p0, mg = mdl.axis, mdl.R0, mdl.p0, mdl.mg
    Rl, Rw, pl, w, dw, vel, dv = work.Rl, work.Rw, work.pl, work.w, work.dw, work.vel, work.dv
    for i in range(parent.shape[0]):
        joint_placement(i, kind, iq, axis, R0, p0, q, Rl, pl)           # R^{i−1}_i, p^{i−1}_i
        j = parent[i]
        if j < 0:                                          # the fixed base: ω'_0 = ω̇'_0 = 0, v̇'_0 = −g
            w_in, dw_in, v_in = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
            dv_in = rot_t(Rl, i, (mg[0], mg[1], mg[2]))
        else:                                              # the parent's motion at body i's origin, in its axes
            p, w0 = vec(pl, i), vec(w, j)
            w_in = rot_t(Rl, i, w0)                        # R^i_{i−1} ω'_{i−1} (Eq. 3 uses ω'_{i−1})
            dw_in = rot_t(Rl, i, vec(dw, j))
            v_in = rot_t(Rl, i, add(vec(vel, j), cross(w0, p))) if terms else (0.0, 0.0, 0.0)   # Eq. 4
            dv_in = rot_t(Rl, i, add(vec(dv, j), add(cross(vec(dw, j), p), cross(w0, cross(w0, p)))))
            #                                              Eq. 6 (32c: v̇'_{i−1}, in frame i−1)
        VL, VA = joint_velocity(S, iv[i], nvj[i], v)      # S q̇ = [vl; va]
        AL, AA = joint_velocity(S, iv[i], nvj[i], a)      # S q̈ = [al; aa]
        put(w, i, add(w_in, VA))                           # Eq. 3 (as corrected: ω'_{i−1}, θ̇_i); Eq. 9
        put(dw, i, add(add(dw_in, AA), cross(w_in, VA)))   # Eq. 5 (32b: left side is ω̇'); Eq. 10
        put(vel, i, add(v_in, VL))                         # Eq. 4; prismatic Eq. 11
        put(dv, i, add(add(dv_in, AL), add(scale(2.0, cross(w_in, VL)), cross(VA, VL))))   # Eqs. 6, 12
        inertial(i, mdl, work)
        if orient:
            for r in range(3):
                for c in range(3):
                    Rw[i, r, c] = Rl[i, r, c] if j < 0 else \
                        Rw[j, r, 0] * Rl[i, 0, c] + Rw[j, r, 1] * Rl[i, 1, c] + Rw[j, r, 2] * Rl[i, 2, c]


@njit(cache=True, inline="always")
def inertial(i, mdl, work):
    """Body i's inertial wrench about its origin: v̇'_C (Eq. 7, as 32d should read), f'_C (Eq. 13), n'_C
    (Eq. 14), f'_i = f'_C, n'_i = n'_C + p'_C × f'_C (Eq. 16's CoM term)."""
    mass, com, inertia = mdl.mass, mdl.com, mdl.inertia
    w, dw, dv, dvc, fc, nc, f, n = work.w, work.dw, work.dv, work.dvc, work.fc, work.nc, work.f, work.n
    c, wi, dwi = vec(com, i), vec(w, i), vec(dw, i)
    dvc_i = add(vec(dv, i), add(cross(dwi, c), cross(wi, cross(wi, c))))   # Eq. 7 (32d as printed is wrong)
    fc_i = scale(mass[i], dvc_i)                                          # Eq. 13: f'_Ci = m_i v̇'_Ci
    nc_i = add(rot(inertia, i, dwi), cross(wi, rot(inertia, i, wi)))      # Eq. 14
    put(dvc, i, dvc_i)
    put(fc, i, fc_i)
    put(nc, i, nc_i)
    put(f, i, fc_i)
    put(n, i, add(nc_i, cross(c, fc_i)))


@njit(cache=True, inline="always")
def external(work, X, s, xb, xp, world):
    """f'_b −= f_e, n'_b −= n_e + p × f_e for each wrench (f_e, n_e) the environment applies on body b about
    its point p (body axes); world-axes wrenches are first turned into the body: Rw_bᵀ f_e, Rw_bᵀ n_e."""
    Rw, f, n = work.Rw, work.f, work.n
    for k in range(xb.shape[0]):
        b = xb[k]
        fe, ne = (X[s, k, 0], X[s, k, 1], X[s, k, 2]), (X[s, k, 3], X[s, k, 4], X[s, k, 5])
        if world:
            fe, ne = rot_t(Rw, b, fe), rot_t(Rw, b, ne)
        put(f, b, sub(vec(f, b), fe))
        put(n, b, sub(vec(n, b), add(ne, cross(vec(xp, k), fe))))


@njit(cache=True, inline="always")
def inward(mdl, work, tau):
    """Inward pass i = nb … 1 (Eqs. 15–18): τ_i = Sᵀ [f'_i; n'_i] (Eqs. 17, 18), then the parent takes
    f'_λ += R f'_i (Eq. 15) and n'_λ += R n'_i + p × R f'_i (Eq. 16; 32h: p^{i−1}_i × R^{i−1}_i f'_i)."""
    parent, iv, nvj, S = mdl.parent, mdl.iv, mdl.nvj, mdl.S
    Rl, pl, f, n = work.Rl, work.pl, work.f, work.n
    for i in range(parent.shape[0] - 1, -1, -1):        # children come after parents: complete here
        joint_force(S, iv[i], nvj[i], f[i], n[i], tau)
        j = parent[i]
        if j >= 0:
            Rf = rot(Rl, i, vec(f, i))
            put(f, j, add(vec(f, j), Rf))                                                  # Eq. 15
            put(n, j, add(vec(n, j), add(rot(Rl, i, vec(n, i)), cross(vec(pl, i), Rf))))  # Eq. 16


@njit(cache=True, inline="always")
def store_terms(mdl, work, T):
    """T (nb, NT) = [ω', ω̇', v', v̇', acc, v̇'_C, f'_C, n'_C, f', n', Rw] per body (TERMS order), with
    acc = v̇' + Rwᵀ g: v̇' without the −g offset of v̇'_0."""
    mg = mdl.mg
    Rw, w, dw, vel, dv, dvc = work.Rw, work.w, work.dw, work.vel, work.dv, work.dvc
    fc, nc, f, n = work.fc, work.nc, work.f, work.n
    for i in range(T.shape[0]):
        acc = sub(vec(dv, i), rot_t(Rw, i, (mg[0], mg[1], mg[2])))
        for m, x in enumerate((vec(w, i), vec(dw, i), vec(vel, i), vec(dv, i), acc, vec(dvc, i), vec(fc, i),
                               vec(nc, i), vec(f, i), vec(n, i))):
            T[i, 3 * m], T[i, 3 * m + 1], T[i, 3 * m + 2] = x
        for r in range(3):
            for c in range(3):
                T[i, 30 + 3 * r + c] = Rw[i, r, c]
