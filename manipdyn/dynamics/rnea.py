"""Recursive Newton–Euler inverse dynamics (Luh, Walker & Paul 1980), in the chapter's vector form.

Every vector is expressed in its own link frame (the chapter's primes): body i's frame is its URDF link
frame, joint i moves along z'_i = ``model.axis[i]``. ``R`` below is R^{λ(i)}_i (body i in its parent λ(i)),
so the chapter's R^i_{i-1} x is ``rot_t(R, x)``. A tree replaces "link i+1" by the children of link i.
Gravity enters as a base acceleration: ω'_0 = ω̇'_0 = 0, v̇'_0 = −g (DESIGN.md §6).
"""
from __future__ import annotations

import numpy as np

from ..model import REVOLUTE
from ..spatial import cross, rot, rot_t
from .fast import kernel_arrays, rnea_kernel, rnea_one
from .core import joint_placements
from .state import (as_batch, check_f_ext, check_output, external_wrenches, fast_shape, raise_kernel_error,
                    quiet, unbatch)


def rnea(model, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """τ = M(q) q̈ + C(q, q̇) q̇ + g(q) − Σ J_kᵀ f_ext,k, by the chapter's Eqs. 3–18 (32a–i).

    Parameters
    ----------
    q, v, a : (nv,) or (N, nv) joint positions, rates and accelerations (q order of ``model``).
    f_ext : {link or frame name: (force (3,)|(N, 3), moment (3,)|(N, 3))}, wrench the environment applies
        on that body about the frame's origin, in the frame's axes (f_ext_frame="local") or world axes.
    Returns
    -------
    tau : (nv,) or (N, nv) joint torques (revolute) and forces (prismatic).

    Without f_ext this runs the compiled kernel (dynamics/fast.py), held by the tests to ``rnea_terms``,
    the readable recursion below; with f_ext it runs the readable recursion.
    """
    nd = fast_shape(model, q, v, a) if f_ext is None and f_ext_frame == "local" else 0
    if nd == 0:                                                 # checked and converted first
        (Q, V, A), single = as_batch(model, q=q, v=v, a=a)
        if check_f_ext(model, f_ext, f_ext_frame, Q.shape[0]) is not None:
            return unbatch(_terms(model, Q, V, A, f_ext, f_ext_frame, "rnea")["tau"], single)
        if model.nv == 0:
            return unbatch(np.zeros(Q.shape), single)
        q, v, a = (unbatch(x, single) for x in (Q, V, A))
        nd = 1 if single else 2
    tau = np.empty(q.shape)
    code = (rnea_one if nd == 1 else rnea_kernel)(*kernel_arrays(model), q, v, a, tau)
    if code != -1:
        raise_kernel_error(model, code, _QVA, (q, v, a), "rnea", "tau", tau)
    return tau


_QVA = ("q", "v", "a")


def rnea_terms(model, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """Every per-link intermediate of the Newton–Euler recursion, in link frames.

    Returns a dict of arrays; per-link arrays have shape (N, nv, 3) (or (nv, 3) for one state):
      w, dw    ω'_i, ω̇'_i                      (Eqs. 3, 5; prismatic 9, 10)
      v        v'_i, velocity of the frame origin (Eqs. 4, 11)
      dv       v̇'_i, including the −g base offset (Eqs. 6, 12)
      acc      v̇'_i without gravity: the origin's classical linear acceleration
      dvc      v̇'_Ci, including −g                (Eq. 7)
      fc, nc   inertial force m v̇'_Ci and moment I ω̇' + ω' × I ω' about the CoM (Eqs. 13, 14)
      f, n     force and moment link i−1 exerts on link i, about frame i's origin (Eqs. 15, 16)
      R        (N, nv, 3, 3) orientation of each link frame in the base frame
      tau      (N, nv) joint torques/forces (Eqs. 17, 18)
    """
    (Q, V, A), single = as_batch(model, q=q, v=v, a=a)
    out = _terms(model, Q, V, A, f_ext, f_ext_frame, "rnea_terms")
    return {k: unbatch(x, single) for k, x in out.items()}


@quiet
def _terms(model, Q, V, A, f_ext, f_ext_frame, call):
    """rnea_terms on checked batches (N, nv); every array checked finite (NumericalError names ``call``)."""
    check_f_ext(model, f_ext, f_ext_frame, Q.shape[0])           # before the work
    out = _outward(model, Q, V, A)
    ext = external_wrenches(model, f_ext, f_ext_frame, Q.shape[0], out["R"])
    out.update(_inward(model, out, ext))
    out = {k: np.moveaxis(x, 0, 1) for k, x in out.items() if k != "Rp"}
    out["tau"] = out["tau"][..., 0]
    inputs = dict(q=Q, v=V, a=A)
    for k in ("tau", "w", "dw", "v", "dv", "acc", "dvc", "fc", "nc", "f", "n", "R"):   # τ first: the result
        check_output(call, k, out[k], model, inputs, "joint" if k == "tau" else "link")
    return out


def _outward(model, Q, V, A):
    """Outward recursion i: 1 → n, velocities and accelerations (arrays (nv, N, 3))."""
    nv, N = model.nv, Q.shape[0]
    Rp, pp = joint_placements(model, Q)                     # R^{i-1}_i, p^{i-1}_i
    w, dw, vel, dv, dvc = (np.empty((nv, N, 3)) for _ in range(5))
    R = np.empty((nv, N, 3, 3))                              # orientation in the base frame
    zero, base_dv = np.zeros((N, 3)), np.broadcast_to(-model.gravity, (N, 3))  # v̇'_0 = −g
    for i in range(nv):
        j = model.parent[i]
        w0, dw0, v0, dv0 = (zero, zero, zero, base_dv) if j < 0 else (w[j], dw[j], vel[j], dv[j])
        R[i] = Rp[i] if j < 0 else R[j] @ Rp[i]
        z, p, qd, qdd = model.axis[i], pp[i], V[:, i, None], A[:, i, None]
        w_in = rot_t(Rp[i], w0)                               # R^i_{i-1} ω'_{i-1}
        vel[i] = rot_t(Rp[i], v0 + cross(w0, p))              # Eq. 4
        dv[i] = rot_t(Rp[i], dv0 + cross(dw0, p) + cross(w0, cross(w0, p)))   # Eq. 6 (32c uses v̇'_{i-1})
        if model.kind[i] == REVOLUTE:
            w[i] = w_in + qd * z                              # Eq. 3 (as corrected: ω'_{i-1}, θ̇_i)
            dw[i] = rot_t(Rp[i], dw0) + qdd * z + cross(w_in, qd * z)   # Eq. 5 (32b: left side is ω̇')
        else:
            w[i] = w_in                                       # Eq. 9
            dw[i] = rot_t(Rp[i], dw0)                         # Eq. 10
            vel[i] += qd * z                                  # Eq. 11
            dv[i] += 2.0 * cross(w[i], qd * z) + qdd * z      # Eq. 12
        c = model.com[i]
        dvc[i] = dv[i] + cross(dw[i], c) + cross(w[i], cross(w[i], c))   # Eq. 7 (32d as printed is wrong)
    acc = dv + np.einsum("knji,j->kni", R, model.gravity)    # remove the −g offset: v̇ + Rᵀ g
    return dict(w=w, dw=dw, v=vel, dv=dv, acc=acc, dvc=dvc, R=R, Rp=(Rp, pp))


def _inward(model, out, ext):
    """Inward recursion i: n → 1, joint forces/moments and torques (Eqs. 13–18)."""
    Rp, pp = out["Rp"]
    w, dw, dvc = out["w"], out["dw"], out["dvc"]
    I, c = model.inertia, model.com
    fc = model.mass[:, None, None] * dvc                                  # Eq. 13: f'_Ci = m_i v̇'_Ci
    Iw = np.einsum("kij,knj->kni", I, w)
    nc = np.einsum("kij,knj->kni", I, dw) + cross(w, Iw)                  # Eq. 14
    f = fc.copy()
    n = nc + cross(np.broadcast_to(c[:, None, :], fc.shape), fc)          # p'_Ci × f'_Ci of Eq. 16
    if ext is not None:                   # the environment's wrench on link i: f_i = f_Ci + ... − f_ext
        f -= ext[0]
        n -= ext[1]
    tau = np.empty(w.shape[:2] + (1,))
    for i in reversed(range(model.nv)):   # children come after parents, so they are complete here
        jnt = n[i] if model.kind[i] == REVOLUTE else f[i]
        tau[i, :, 0] = jnt @ model.axis[i]                                # Eqs. 17, 18
        j = model.parent[i]
        if j >= 0:
            Rf = rot(Rp[i], f[i])                                         # R^{i-1}_i f'_i
            f[j] += Rf                                                    # Eq. 15
            n[j] += rot(Rp[i], n[i]) + cross(pp[i], Rf)                   # Eq. 16 (32h: p^{i-1}_i)
    return dict(fc=fc, nc=nc, f=f, n=n, tau=tau)
