"""Forward dynamics: q̈ = M(q)⁻¹ (τ − C q̇ − g + Σ Jᵀ f_ext), two ways.

``aba``: Featherstone's articulated-body algorithm (RBDA Table 7.1), the forward problem the chapter names.
Spatial vectors here are 6-D in Featherstone's order [angular; linear], in each body's own frame; motion
transforms X (parent → body) are built from the same R^{λ(i)}_i, p^{λ(i)}_i as the Newton–Euler code.
``forward_dynamics(..., method="cholesky")``: the M⁻¹ route, Cholesky of M (CRBA) with the right-hand
side τ − rnea(q, q̇, 0) from the Newton–Euler code.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, NumericalError, SingularError
from ..model import REVOLUTE
from ..spatial import skew
from .lagrange import mass_matrix
from .rnea import rnea
from .fast import aba_kernel, aba_one, kernel_arrays
from .core import joint_placements
from .state import (as_batch, check_f_ext, check_output, external_wrenches, fast_shape, raise_kernel_error,
                    quiet, raise_output_error, unbatch)


def _motion_subspace(model):
    """S_i (nv, 6): [axis; 0] for revolute joints, [0; axis] for prismatic ones."""
    S = np.zeros((model.nv, 6))
    for i in range(model.nv):
        k = 0 if model.kind[i] == REVOLUTE else 3
        S[i, k:k + 3] = model.axis[i]
    return S


def _xform(R, p):
    """Motion transform parent → body: X = [[Rᵀ, 0], [−Rᵀ[p]×, Rᵀ]], (N, 6, 6)."""
    Rt = np.swapaxes(R, 1, 2)
    X = np.zeros(R.shape[:1] + (6, 6))
    X[:, :3, :3] = X[:, 3:, 3:] = Rt
    X[:, 3:, :3] = -Rt @ skew(p)
    return X


def _crm(v):
    """Motion cross product matrix v×: [[ω×, 0], [v_lin×, ω×]], (N, 6, 6)."""
    X = np.zeros(v.shape[:1] + (6, 6))
    X[:, :3, :3] = X[:, 3:, 3:] = skew(v[:, :3])
    X[:, 3:, :3] = skew(v[:, 3:])
    return X


def spatial_inertia(model):
    """Body spatial inertias about their frame origins, [angular; linear] order: (nv, 6, 6)."""
    I = np.zeros((model.nv, 6, 6))
    for i in range(model.nv):
        m, C = model.mass[i], skew(model.com[i])
        I[i, :3, :3] = model.inertia[i] + m * C @ C.T
        I[i, :3, 3:], I[i, 3:, :3], I[i, 3:, 3:] = m * C, m * C.T, m * np.eye(3)
    return I


def aba(model, q, v, tau, *, f_ext=None, f_ext_frame="local"):
    """q̈ (nv,) or (N, nv) by the articulated-body algorithm; f_ext as in ``rnea``.

    Raises SingularError naming the joints whose articulated inertia D_i = Sᵀ Iᴬ S vanishes (a moving
    subtree without mass or inertia: M is singular there). Without f_ext this runs the compiled kernel
    (dynamics/fast.py), held by the tests to ``aba_reference``, the readable algorithm.
    """
    nd = fast_shape(model, q, v, tau) if f_ext is None and f_ext_frame == "local" else 0
    if nd == 0:                                                 # checked and converted first
        (Q, V, T), single = as_batch(model, q=q, v=v, tau=tau)
        if check_f_ext(model, f_ext, f_ext_frame, Q.shape[0]) is not None:
            return unbatch(_aba(model, Q, V, T, f_ext, f_ext_frame, "aba"), single)
        if model.nv == 0:
            return unbatch(np.zeros(Q.shape), single)
        q, v, tau = (unbatch(x, single) for x in (Q, V, T))
        nd = 1 if single else 2
    qdd = np.empty(q.shape)
    code = (aba_one if nd == 1 else aba_kernel)(*kernel_arrays(model), q, v, tau, qdd)
    if code != -1:
        raise_kernel_error(model, code, ("q", "v", "tau"), (q, v, tau), "aba", "q̈", qdd)
    return qdd


def aba_reference(model, q, v, tau, *, f_ext=None, f_ext_frame="local"):
    """The readable articulated-body algorithm (RBDA Table 7.1); same contract as ``aba``."""
    (Q, V, T), single = as_batch(model, q=q, v=v, tau=tau)
    return unbatch(_aba(model, Q, V, T, f_ext, f_ext_frame, "aba_reference"), single)


@quiet
def _aba(model, Q, V, T, f_ext, f_ext_frame, call):
    """The articulated-body algorithm on checked batches (N, nv): q̈ (N, nv), checked finite."""
    N, nv = Q.shape[0], model.nv
    check_f_ext(model, f_ext, f_ext_frame, N)                   # before the work
    Rp, pp = joint_placements(model, Q)
    S, I = _motion_subspace(model), spatial_inertia(model)
    X = [_xform(Rp[i], pp[i]) for i in range(nv)]
    vel, c = np.zeros((nv, N, 6)), np.zeros((nv, N, 6))
    IA, pA = np.empty((nv, N, 6, 6)), np.empty((nv, N, 6))
    R0 = np.empty((nv, N, 3, 3)) if f_ext_frame == "world" and f_ext else None
    for i in range(nv):                                   # pass 1: velocities, bias forces
        j = model.parent[i]
        vJ = V[:, i, None] * S[i]
        vel[i] = vJ if j < 0 else np.einsum("nab,nb->na", X[i], vel[j]) + vJ
        c[i] = np.einsum("nab,nb->na", _crm(vel[i]), vJ)                  # c_i = v_i × S_i q̇_i
        IA[i] = I[i]
        Iv = vel[i] @ I[i].T
        pA[i] = -np.einsum("nba,nb->na", _crm(vel[i]), Iv)               # v ×* I v = −(v×)ᵀ I v
        if R0 is not None:
            R0[i] = Rp[i] if j < 0 else R0[j] @ Rp[i]
    ext = external_wrenches(model, f_ext, f_ext_frame, N, R0)
    if ext is not None:
        pA -= np.concatenate([ext[1], ext[0]], axis=-1)                  # [moment; force]
    U, D, u = np.empty((nv, N, 6)), np.empty((nv, N)), np.empty((nv, N))
    for i in reversed(range(nv)):                         # pass 2: articulated inertias
        U[i] = IA[i] @ S[i]
        D[i] = U[i] @ S[i]
        u[i] = T[:, i] - pA[i] @ S[i]
        _check_D(model, i, D[i])
        j = model.parent[i]
        if j >= 0:
            Ia = IA[i] - U[i][:, :, None] * U[i][:, None, :] / D[i][:, None, None]
            pa = pA[i] + np.einsum("nab,nb->na", Ia, c[i]) + U[i] * (u[i] / D[i])[:, None]
            Xt = np.swapaxes(X[i], 1, 2)
            IA[j] += Xt @ Ia @ X[i]
            pA[j] += np.einsum("nab,nb->na", Xt, pa)
    a, qdd = np.zeros((nv, N, 6)), np.empty((N, nv))
    a0 = np.concatenate([np.zeros(3), -model.gravity])   # base acceleration −g: gravity as in rnea
    for i in range(nv):                                   # pass 3: accelerations
        j = model.parent[i]
        ap = np.einsum("nab,b->na", X[i], a0) if j < 0 else np.einsum("nab,nb->na", X[i], a[j])
        ap = ap + c[i]
        qdd[:, i] = (u[i] - np.einsum("na,na->n", U[i], ap)) / D[i]
        a[i] = ap + qdd[:, i, None] * S[i]
    return check_output(call, "q̈", qdd, model, dict(q=Q, v=V, tau=T))


def _check_D(model, i, D):
    if not np.all(np.isfinite(D)):
        raise_output_error("aba", "articulated inertia D", D[:, None], (int(np.argmin(np.isfinite(D))), 0))
    scale = max(float(np.max(np.abs(model.inertia))), float(np.max(model.mass)), 1e-300)
    if np.any(~(D > 1e-14 * scale)):
        raise SingularError(f"mass matrix is singular: joint {model.joint_names[i]!r} moves a subtree "
                            f"without mass or inertia about its axis (articulated inertia D = "
                            f"{float(np.min(D)):.3g})")


def forward_dynamics(model, q, v, tau, *, f_ext=None, f_ext_frame="local", method="aba"):
    """q̈ by ``method``: "aba" (articulated bodies) or "cholesky" (M⁻¹ route: Cholesky of the CRBA mass
    matrix, right-hand side τ − rnea(q, q̇, 0, f_ext) = τ − C q̇ − g + Σ Jᵀ f_ext)."""
    if isinstance(method, str) and method == "aba":
        return aba(model, q, v, tau, f_ext=f_ext, f_ext_frame=f_ext_frame)
    if method != "cholesky":
        raise InputError(f"forward_dynamics method must be 'aba' or 'cholesky', not {method!r}")
    return _cholesky(model, q, v, tau, f_ext, f_ext_frame)


@quiet
def _cholesky(model, q, v, tau, f_ext, f_ext_frame):
    """q̈ by the M⁻¹ route: Cholesky of the CRBA mass matrix, right-hand side τ − rnea(q, q̇, 0, f_ext)."""
    (Q, V, T), single = as_batch(model, q=q, v=v, tau=tau)
    check_f_ext(model, f_ext, f_ext_frame, Q.shape[0])
    if model.nv == 0:
        return unbatch(np.zeros(Q.shape), single)
    try:
        h = rnea(model, Q, V, np.zeros_like(Q), f_ext=f_ext, f_ext_frame=f_ext_frame)
    except NumericalError as exc:
        raise NumericalError(f"forward_dynamics (method='cholesky'), in {exc}") from None
    rhs = check_output("forward_dynamics", "τ − h", T - h, model, dict(q=Q, v=V, tau=T))
    M = mass_matrix(model, Q)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        bad = [model.joint_names[k] for k in range(model.nv) if np.any(M[:, k, k] <= 0)]
        raise SingularError(f"mass matrix is not positive definite (joints with zero diagonal: "
                            f"{', '.join(bad) or 'none; a dependent column'})") from None
    y = np.linalg.solve(L, rhs[..., None])
    qdd = np.linalg.solve(np.swapaxes(L, 1, 2), y)[..., 0]
    return unbatch(check_output("forward_dynamics", "q̈", qdd, model, dict(q=Q, v=V, tau=T)), single)
