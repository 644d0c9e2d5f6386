"""Dynamics of a tree whose mimic joints follow their targets (model.MimicModel, ``load_urdf(mimic=True)``).

The one place the linear map is applied (our kernels have no mimic joint; Pinocchio 4.1 has JointModelMimic):
    q_full = Gq q + q_offset,  v_full = G v,  a_full = G a         (constant G: no Ġ v term)
    τ = Gᵀ τ_full(q_full, v_full, a_full)                           (virtual work)
    M = Gᵀ M_full G,   q̈ = M⁻¹ (τ − Gᵀ h_full),  h_full = τ_full(q_full, v_full, 0)
Independent coordinates follow Pinocchio's mimic model: the full q order with the mimic joints removed.
The public ``rnea``, ``mass_matrix``, ``gravity_torques``, ``aba`` and ``forward_dynamics`` send a MimicModel
here (their first lines); every other function takes ``mm.full`` and ``mm.full_state(q, v, a)``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, SingularError
from ..model import MimicModel
from .lagrange import mass_matrix as _mass_matrix
from .rnea import rnea as _rnea
from .state import MIMIC

__all__ = ["full_state", "rnea", "crba", "mass_matrix", "gravity_torques", "aba", "forward_dynamics"]


def _check(mm, name, x, n):
    if not isinstance(mm, MimicModel):
        raise InputError(f"expected a MimicModel (load_urdf(..., mimic=True)), not {type(mm).__name__}")
    return mm.check(name, x, n)


def full_state(mm, q, v=None, a=None):
    """(q_full, v_full, a_full) of the full tree from independent coordinates (MimicModel.full_state)."""
    _check(mm, "q", q, mm.nq)
    return mm.full_state(q, v, a)


def rnea(mm, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """τ = Gᵀ rnea(full, q_full, G v, G a, f_ext): inverse dynamics in the independent coordinates."""
    Q, V, A = full_state(mm, q, v, a)
    return _rnea(mm.full, Q, V, A, f_ext=f_ext, f_ext_frame=f_ext_frame) @ mm.G


def crba(mm, q):
    """M = Gᵀ M_full(q_full) G, (nv, nv) or (N, nv, nv)."""
    Q, _, _ = full_state(mm, q)
    M = _mass_matrix(mm.full, Q)
    return np.einsum("ji,...jk,kl->...il", mm.G, M, mm.G)


def mass_matrix(mm, q, method="crba"):
    """M = Gᵀ M_full G with M_full by ``method`` ("crba" or "lagrange", as manipdyn.mass_matrix)."""
    Q, _, _ = full_state(mm, q)
    return np.einsum("ji,...jk,kl->...il", mm.G, _mass_matrix(mm.full, Q, method=method), mm.G)


def gravity_torques(mm, q):
    """g = Gᵀ g_full(q_full) = rnea(q, 0, 0) in the independent coordinates."""
    q = _check(mm, "q", q, mm.nq)
    z = np.zeros(q.shape[:-1] + (mm.nv,))
    return rnea(mm, q, z, z)


def nonlinear_effects(mm, q, v):
    """h = Gᵀ h_full(q_full, q̇_full) = rnea(q, q̇, 0) in the independent coordinates."""
    v = _check(mm, "v", v, mm.nv)
    return rnea(mm, q, v, np.zeros_like(v))


def aba(mm, q, v, tau, *, f_ext=None, f_ext_frame="local"):
    """q̈ = M⁻¹ (τ − Gᵀ h_full): forward dynamics in the independent coordinates (Cholesky of M = Gᵀ M_full G;
    no articulated-body recursion exists for the mapped model)."""
    Q, V, _ = full_state(mm, q, v)
    tau = _check(mm, "tau", tau, mm.nv)
    if tau.shape[:-1] != V.shape[:-1]:
        raise InputError(f"tau has shape {tau.shape}; v has {np.shape(v)}: one state or the same batch")
    h = _rnea(mm.full, Q, V, np.zeros_like(V), f_ext=f_ext, f_ext_frame=f_ext_frame) @ mm.G
    M = crba(mm, q)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise SingularError(f"mass matrix of {mm.name!r} (mimic joints honoured) is not positive definite") from None
    r = (tau - h)[..., None]
    return np.linalg.solve(np.swapaxes(L, -1, -2), np.linalg.solve(L, r))[..., 0]


def forward_dynamics(mm, q, v, tau, *, f_ext=None, f_ext_frame="local", method="aba"):
    """q̈ as ``aba`` above, whichever method ("aba" or "cholesky"): both are the M⁻¹ route here."""
    if not (isinstance(method, str) and method in ("aba", "cholesky")):
        raise InputError(f"forward_dynamics method must be 'aba' or 'cholesky', not {method!r}")
    return aba(mm, q, v, tau, f_ext=f_ext, f_ext_frame=f_ext_frame)


MIMIC.update(rnea=rnea, mass_matrix=mass_matrix, gravity_torques=gravity_torques,
             nonlinear_effects=nonlinear_effects, aba=aba,
             forward_dynamics=forward_dynamics)   # the public functions send a MimicModel here (state.mimic_call)
