"""Dynamics of a tree whose mimic joints follow their targets (model.MimicModel, ``load_urdf(mimic=True)``).

The one place the linear map is applied (our kernels have no mimic joint; Pinocchio 4.1 has JointModelMimic):
    q_full = Gq q + q_offset,  v_full = G v,  a_full = G a         (constant G: no Ġ v term)
    τ = Gᵀ τ_full(q_full, v_full, a_full)                           (virtual work)
    M = Gᵀ M_full G,   q̈ = M⁻¹ (τ − Gᵀ h_full),  h_full = τ_full(q_full, v_full, 0)
Independent coordinates follow Pinocchio's mimic model: the full q order with the mimic joints removed.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, SingularError
from ..model import MimicModel
from .lagrange import mass_matrix
from .rnea import rnea as _rnea

__all__ = ["full_state", "rnea", "crba", "aba"]


def _check(mm, name, x, n):
    if not isinstance(mm, MimicModel):
        raise InputError(f"expected a MimicModel (load_urdf(..., mimic=True)), not {type(mm).__name__}")
    try:
        x = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be real numbers, not {x!r}") from None
    if x.ndim not in (1, 2) or x.shape[-1] != n:
        raise InputError(f"{name} has shape {x.shape}; expected ({n},) or (N, {n}) for {mm.name!r} "
                         f"(independent coordinates: {', '.join(mm.joint_names)})")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{name} has non-finite entries")
    return x


def full_state(mm, q, v=None, a=None):
    """(q_full, v_full, a_full) of the full tree from independent coordinates (v, a None stay None)."""
    q = _check(mm, "q", q, mm.nq)
    out = [q @ mm.Gq.T + mm.q_offset]
    for name, x in (("v", v), ("a", a)):
        out.append(None if x is None else _check(mm, name, x, mm.nv) @ mm.G.T)
    return tuple(out)


def rnea(mm, q, v, a):
    """τ = Gᵀ rnea(full, q_full, G v, G a): inverse dynamics in the independent coordinates, (nv,) or (N, nv)."""
    Q, V, A = full_state(mm, q, v, a)
    return _rnea(mm.full, Q, V, A) @ mm.G


def crba(mm, q):
    """M = Gᵀ M_full(q_full) G, (nv, nv) or (N, nv, nv)."""
    Q, _, _ = full_state(mm, q)
    M = mass_matrix(mm.full, Q)
    return np.einsum("ji,...jk,kl->...il", mm.G, M, mm.G)


def aba(mm, q, v, tau):
    """q̈ = M⁻¹ (τ − Gᵀ h_full): forward dynamics in the independent coordinates (Cholesky of M)."""
    Q, V, _ = full_state(mm, q, v)
    tau = _check(mm, "tau", tau, mm.nv)
    h = _rnea(mm.full, Q, V, np.zeros_like(V)) @ mm.G
    M = crba(mm, q)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise SingularError(f"mass matrix of {mm.name!r} (mimic joints honoured) is not positive definite") from None
    r = (tau - h)[..., None]
    return np.linalg.solve(np.swapaxes(L, -1, -2), np.linalg.solve(L, r))[..., 0]
