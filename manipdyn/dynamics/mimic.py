"""Dynamics of a tree whose mimic joints follow their targets (model.MimicModel, ``load_urdf(mimic=True)``).

The one place the linear map is applied (our kernels have no mimic joint; Pinocchio 4.1 has JointModelMimic):
    q_full = Gq q + q_offset,  v_full = G v,  a_full = G a         (constant G: no Ġ v term)
    τ = Gᵀ τ_full(q_full, v_full, a_full)                           (virtual work)
    M = Gᵀ M_full G,   q̈ = M⁻¹ (τ − Gᵀ h_full),  h_full = τ_full(q_full, v_full, 0)
Independent coordinates follow Pinocchio's mimic model: the full q order with the mimic joints removed.

``TAKES_MIMIC`` is the one list of the public calls that take a MimicModel: each of them sends it here, handing
over the full-model function the map is built on (so that this module imports no algorithm); every other call
refuses a MimicModel with a message naming these (``arguments.check_model``): give it ``mm.full`` and
``mm.full_state(q, v, a)``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, SingularError
from ..model import MimicModel

__all__ = ["TAKES_MIMIC", "full_state", "generalized_force", "mass_matrix", "forward_dynamics"]

TAKES_MIMIC = ("rnea", "nonlinear_effects", "gravity_torques", "mass_matrix", "aba", "forward_dynamics")


def _check(mm, name, x, n):
    if not isinstance(mm, MimicModel):
        raise InputError(f"expected a MimicModel (load_urdf(..., mimic=True)), not {type(mm).__name__}")
    return mm.check(name, x, n)


def full_state(mm, q, v=None, a=None):
    """(q_full, v_full, a_full) of the full tree from independent coordinates (MimicModel.full_state)."""
    _check(mm, "q", q, mm.nq)
    return mm.full_state(q, v, a)


def generalized_force(mm, full_rnea, q, v=None, a=None, **kw):
    """τ = Gᵀ rnea(full, q_full, G v, G a, **kw) in the independent coordinates; v, a None stand for zeros
    (``gravity_torques``: both; ``nonlinear_effects``: a). full_rnea is the public ``rnea``."""
    q = _check(mm, "q", q, mm.nq)
    zero = np.zeros(q.shape[:-1] + (mm.nv,))
    v = zero if v is None else _check(mm, "v", v, mm.nv)
    Q, V, A = full_state(mm, q, v, zero if a is None else a)
    return full_rnea(mm.full, Q, V, A, **kw) @ mm.G


def mass_matrix(mm, full_mass_matrix, q, **kw):
    """M = Gᵀ M_full(q_full) G, (nv, nv) or (N, nv, nv); full_mass_matrix is the public ``mass_matrix``
    (``method`` among kw)."""
    Q, _, _ = full_state(mm, q)
    return np.einsum("ji,...jk,kl->...il", mm.G, full_mass_matrix(mm.full, Q, **kw), mm.G)


def forward_dynamics(mm, full_rnea, full_mass_matrix, q, v, tau, *, f_ext=None, f_ext_frame="local"):
    """q̈ = M⁻¹ (τ − Gᵀ h_full): forward dynamics in the independent coordinates (Cholesky of M = Gᵀ M_full G;
    no articulated-body recursion exists for the mapped model), for ``aba`` and ``forward_dynamics`` alike."""
    Q, V, _ = full_state(mm, q, v)
    tau = _check(mm, "tau", tau, mm.nv)
    if tau.shape[:-1] != V.shape[:-1]:
        raise InputError(f"tau has shape {tau.shape}; v has {np.shape(v)}: one state or the same batch")
    h = full_rnea(mm.full, Q, V, np.zeros_like(V), f_ext=f_ext, f_ext_frame=f_ext_frame) @ mm.G
    M = mass_matrix(mm, full_mass_matrix, q)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise SingularError(f"mass matrix of {mm.name!r} (mimic joints honoured) is not positive definite") from None
    r = (tau - h)[..., None]
    return np.linalg.solve(np.swapaxes(L, -1, -2), np.linalg.solve(L, r))[..., 0]
