"""Lagrange's equations of the 2nd kind: τ = M(q) q̈ + C(q, q̇) q̇ + g(q) (chapter Eqs. 22–25).

M comes from the kinetic energy T = ½ q̇ᵀ M q̇ (Eq. 23) — summed over links from their Jacobians
("lagrange") or by the composite-rigid-body algorithm ("crba", the fast route). C comes from the
Christoffel symbols of M with ∂M/∂q derived analytically from the derivatives of the link Jacobians; g
from the potential energy V = −Σ m_b gᵀ c_b. None of these calls the Newton–Euler code.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import REVOLUTE
from ..spatial import cross, skew
from .kinematics import axes_world, placements, point_jacobian, supports
from .crba import crba
from .state import as_batch, check_output, quiet, unbatch


def _com_jacobians(model, R, p):
    """Per body: world CoM (nv, N, 3), CoM Jacobian (nv, N, 6, nv), world inertia about CoM (nv, N, 3, 3)."""
    z = axes_world(model, R)
    c = p + np.einsum("bnij,bj->bni", R, model.com)
    J = np.stack([point_jacobian(model, R, p, z, b, c[b]) for b in range(model.nv)]) if model.nv else \
        np.zeros((0, R.shape[1], 6, 0))
    Iw = R @ model.inertia[:, None] @ np.swapaxes(R, -1, -2)
    return c, J, Iw, z


def mass_matrix(model, q, method="crba"):
    """M(q) (nv, nv) or (N, nv, nv) for q (nq,) or (N, nq), the joint-space inertia matrix of
    T = ½ q̇ᵀ M q̇ (Eq. 23).

    method="crba" (default, O(n²)): the composite-rigid-body algorithm (dynamics/crba.py, compiled).
    method="lagrange": the closed form M = Σ_b m_b J_vbᵀ J_vb + J_ωbᵀ R_b I_b R_bᵀ J_ωb over links
    (costly, as the chapter warns).
    """
    if method == "crba":
        return crba(model, q)
    (Q,), single = as_batch(model, q=q)
    if method == "lagrange":
        _, J, Iw, _ = _com_jacobians(model, *placements(model, Q))
        Jv, Jw = J[:, :, :3], J[:, :, 3:]
        M = np.einsum("b,bnki,bnkj->nij", model.mass, Jv, Jv) + np.einsum("bnki,bnkl,bnlj->nij", Jw, Iw, Jw)
    else:
        raise InputError(f"mass_matrix method must be 'crba' or 'lagrange', not {method!r}")
    return unbatch(check_output("mass_matrix", "M", M, model, dict(q=Q)), single)


@quiet
def gravity_torques(model, q):
    """g(q) = ∂V/∂q with V = −Σ_b m_b gᵀ c_b(q): g = −Σ_b m_b J_vbᵀ g (nv,) or (N, nv)."""
    (Q,), single = as_batch(model, q=q)
    _, J, _, _ = _com_jacobians(model, *placements(model, Q))
    g = -np.einsum("b,bnki,k->ni", model.mass, J[:, :, :3], model.gravity)
    return unbatch(check_output("gravity_torques", "g", g, model, dict(q=Q)), single)


def mass_matrix_derivatives(model, Q):
    """∂M/∂q_k for a batch: (N, nv(k), nv, nv), exact, from derivatives of the link Jacobians.

    With z_k the axis of revolute joint k, for body b's CoM Jacobian column j (k, j supporting b):
      k supports j (k = j included):  ∂J_j/∂q_k = z_k × J_j   (both blocks turn with joint k)
      j supports k, k ≠ j:            ∂J_j/∂q_k = [z_j × J_v,k; 0] for revolute j, 0 for prismatic j
    and ∂(R I Rᵀ)/∂q_k = [z_k]× I_w − I_w [z_k]× when k supports b. Prismatic k: only the second rule.
    """
    N, nv = Q.shape[0], model.nv
    c, J, Iw, z = _com_jacobians(model, *placements(model, Q))
    S = supports(model)                                     # S[b, j]: joint j moves body b
    dM = np.zeros((N, nv, nv, nv))
    for b in range(nv):
        Jv, Jw = J[b, :, :3], J[b, :, 3:]                   # (N, 3, nv)
        for k in np.flatnonzero(S[b]):
            dJ = np.zeros((N, 6, nv))
            for j in np.flatnonzero(S[b]):
                if S[j, k] and model.kind[k] == REVOLUTE:   # k supports j
                    dJ[:, :3, j], dJ[:, 3:, j] = cross(z[k], Jv[:, :, j]), cross(z[k], Jw[:, :, j])
                elif S[k, j] and k != j and model.kind[j] == REVOLUTE:   # j supports k
                    dJ[:, :3, j] = cross(z[j], Jv[:, :, k])
            dJv, dJw = dJ[:, :3], dJ[:, 3:]
            sym = model.mass[b] * np.einsum("nai,naj->nij", dJv, Jv) + np.einsum("nai,nab,nbj->nij", dJw, Iw[b], Jw)
            dM[:, k] += sym + np.swapaxes(sym, 1, 2)
            if model.kind[k] == REVOLUTE:
                Z = skew(z[k])
                dI = Z @ Iw[b] - Iw[b] @ Z
                dM[:, k] += np.einsum("nai,nab,nbj->nij", Jw, dI, Jw)
    return dM


@quiet
def coriolis_matrix(model, q, v):
    """C(q, q̇) (nv, nv) or (N, nv, nv) from the Christoffel symbols of M:

    C_ij = Σ_k ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) q̇_k, so that Ṁ − 2C is skew-symmetric.
    """
    (Q, V), single = as_batch(model, q=q, v=v)
    dM = mass_matrix_derivatives(model, Q)                   # dM[n, k, i, j] = ∂M_ij/∂q_k
    C = 0.5 * (np.einsum("nkij,nk->nij", dM, V) + np.einsum("njik,nk->nij", dM, V)
               - np.einsum("nijk,nk->nij", dM, V))
    return unbatch(check_output("coriolis_matrix", "C", C, model, dict(q=Q, v=V)), single)
