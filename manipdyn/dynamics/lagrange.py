"""Lagrange's equations of the 2nd kind: τ = M(q) q̈ + C(q, q̇) q̇ + g(q) (chapter Eqs. 22–25).

M comes from the kinetic energy T = ½ q̇ᵀ M q̇ (Eq. 23), summed over links from their CoM Jacobians
(``lagrange_mass_matrix``, compiled: ``lagrange_mass_kernel``; ``mass_matrix(method="lagrange")`` in crba.py,
whose default is the composite-rigid-body algorithm). C (``coriolis_matrix``) is computed in O(n²) by
``coriolis.py``; g = ∂V/∂q, V = −Σ m_b gᵀ c_b, by the Newton–Euler recursion at rest (``rnea.gravity_torques``).

The chapter's own route to C, the Christoffel symbols of M, stays here as ``christoffel_coriolis`` (with
∂M/∂q derived analytically from the derivatives of the link Jacobians, ``mass_matrix_derivatives``): O(n⁴)
in numpy, the tests' second route to C. With a free-flyer root, v is not q̇: its six entries are the root's
twist in its own frame, and q moves on a Lie group. "∂M/∂q_k" is then the derivative along the k-th
velocity direction (X_k; for a 1-dof joint ∂/∂q_k), and the free flyer's directions do not commute,
[X_i, X_j] = X_[e_i, e_j] (the se(3) bracket): the Christoffel symbols of the kinetic metric in this frame
gain the bracket terms (Koszul's formula),
    2Γ_kij = X_i M_jk + X_j M_ik − X_k M_ij + ⟨[X_i, X_j], X_k⟩ − ⟨[X_j, X_k], X_i⟩ + ⟨[X_k, X_i], X_j⟩,
C_kj = Σ_i Γ_kij v_i, and Ṁ − 2C stays skew-symmetric (Ṁ = Σ_k X_k(M) v_k).
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..joints import motion_subspace
from ..spatial import first_nonfinite, first_nonfinite_entry, sandwich3, skew
from .forward_kinematics import fk_pass
from .model_arrays import kernel_arrays, unpack
from .kinematics import body_point, com_jacobians, point_jacobian, supports
from .arguments import as_batch, check_output, fast_shape, quiet, raise_kernel_error, unbatch
from .status import OK, bad_input, bad_result

__all__ = ["lagrange_mass_matrix", "christoffel_coriolis", "mass_matrix_derivatives"]


def lagrange_mass_matrix(model, q):
    """M(q) (nv, nv) or (N, nv, nv) by the closed form of T = ½ q̇ᵀ M q̇ (Eq. 23), summed over links from their
    CoM Jacobians: M = Σ_b m_b J_vbᵀ J_vb + J_ωbᵀ R_b I_b R_bᵀ J_ωb + diag(armature) (O(n³), compiled: ``lagrange_mass_kernel``).
    The route of ``mass_matrix(model, q, method="lagrange")``."""
    nd = fast_shape(model, q)
    if nd == 0:
        (Q,), single = as_batch(model, q=q)
        if not model.njoints:
            return unbatch(np.zeros((Q.shape[0], 0, 0)), single)
        q, nd = unbatch(Q, single), 1 if single else 2
    M = np.empty(q.shape[:-1] + (model.nv, model.nv))
    code = lagrange_mass_kernel(*kernel_arrays(model), q[None] if nd == 1 else q, M[None] if nd == 1 else M)
    if code != -1:
        raise_kernel_error(model, code, ("q",), (q,), "mass_matrix", "M", M)
    return M


@njit(cache=True)
def lagrange_mass_kernel(I, F, Q, M):
    """M = Σ_b m_b J_vbᵀ J_vb + J_ωbᵀ (R_b I_b R_bᵀ) J_ωb (chapter Eq. 23) for every state of Q (N, nq) into
    M (N, nv, nv): the CoM Jacobian J_b of every body (point_jacobian at its world CoM), summed over the
    columns of the joints that support it. Returns its status (dynamics/status.py; a non-finite M: its flat
    index)."""
    mdl = unpack(I, F)
    parent, iv, nvj, S, mass, com, inertia = mdl.parent, mdl.iv, mdl.nvj, mdl.S, mdl.mass, mdl.com, mdl.inertia
    N, nb, nv = Q.shape[0], I.shape[1], M.shape[2]
    # scratch as slices of a few arrays (separate small arrays measured 2.3x slower per state: frame_kernel)
    R3, B3, J, cols, v0 = np.empty((2 * nb + 4, 3, 3)), np.empty((3 * nb + 1, 3)), np.empty((6, nv)), \
        np.empty(nv, np.int64), np.empty(0)
    Rp, Rw, tmp, Rc, Iw, eye = R3[:nb], R3[nb:2 * nb], R3[2 * nb], R3[2 * nb + 1], R3[2 * nb + 2], R3[2 * nb + 3]
    pp, pw, ww, c = B3[:nb], B3[nb:2 * nb], B3[2 * nb:3 * nb], B3[3 * nb]
    eye[:, :] = 0.0
    eye[0, 0] = eye[1, 1] = eye[2, 2] = 1.0
    for s in range(N):
        if first_nonfinite(Q, s) >= 0:
            return bad_input(s)
        fk_pass(mdl, Q[s], v0, Rp, pp, Rw, pw, ww, ww)            # placements only (v0 empty)
        Ms = M[s]
        Ms[:, :] = 0.0
        for b in range(nb):
            body_point(b, Rw, pw, eye, com[b], Rc, c)
            point_jacobian(parent, iv, nvj, S, b, Rw, pw, c, J)
            Iw[:, :] = 0.0
            sandwich3(Rw[b], inertia[b], tmp, Iw)
            n, j = 0, b                                # the columns of the joints that support b
            while j >= 0:
                for r in range(iv[j], iv[j] + nvj[j]):
                    cols[n] = r
                    n += 1
                j = parent[j]
            for x in range(n):
                r = cols[x]
                wx = Iw[0, 0] * J[3, r] + Iw[0, 1] * J[4, r] + Iw[0, 2] * J[5, r]      # I_w J_ω,r
                wy = Iw[1, 0] * J[3, r] + Iw[1, 1] * J[4, r] + Iw[1, 2] * J[5, r]
                wz = Iw[2, 0] * J[3, r] + Iw[2, 1] * J[4, r] + Iw[2, 2] * J[5, r]
                for y in range(x, n):
                    t = cols[y]
                    Ms[t, r] += (mass[b] * (J[0, r] * J[0, t] + J[1, r] * J[1, t] + J[2, r] * J[2, t])
                                 + wx * J[3, t] + wy * J[4, t] + wz * J[5, t])
        for r in range(nv):                            # cols run from the body down: mirror both ways
            for t in range(r):
                x = Ms[r, t] + Ms[t, r]
                Ms[r, t] = Ms[t, r] = x
            Ms[r, r] += mdl.armature[r]                # + diag(armature): the rotors' T (docs/design.md §3)
        k = first_nonfinite_entry(Ms)
        if k >= 0:
            return bad_result(nb, s * nv * nv + k)
    return OK


def _links_mass_matrix(model, J, Iw):
    """The links' M = Σ_b m_b J_vbᵀ J_vb + J_ωbᵀ (R_b I_b R_bᵀ) J_ωb (Eq. 23), J (nb, N, 6, nv), Iw (nb, N, 3, 3)
    (numpy: the bracket terms' M). Without diag(armature): rnea adds armature ⊙ q̈ alone, and so do
    coriolis_matrix and Pinocchio; a ball's armature a (a 1₃ in its block) would add bracket terms ½ a [ξ]×
    (C q̇ the same: ξ × ξ = 0)."""
    Jv, Jw = J[:, :, :3], J[:, :, 3:]
    return np.einsum("b,bnki,bnkj->nij", model.mass, Jv, Jv) + np.einsum("bnki,bnkl,bnlj->nij", Jw, Iw, Jw)


def mass_matrix_derivatives(model, Q, terms=None):
    """X_k(M) for a batch Q (N, nq): (N, nv(k), nv, nv), exact, from derivatives of the link Jacobians.

    X_k is the k-th velocity direction (∂/∂q_k for 1-dof joints; a free flyer's body-frame twist e_k).
    Moving along it turns every body joint(k) supports about a_k (world, = the angular part of column k:
    z_k for a revolute joint, 0 for a prismatic one). For body b's CoM Jacobian column j (k, j supporting b):
      joint(k) supports joint(j) (same joint included):  X_k J_j = a_k × J_j   (both blocks turn with it)
      joint(j) supports joint(k), another joint:         X_k J_j = [a_j × J_v,k; 0]   (the CoM moves by J_v,k)
    and X_k(R I Rᵀ) = [a_k]× I_w − I_w [a_k]× when joint(k) supports b. ``terms`` = com_jacobians(model, Q).
    """
    N, nv = Q.shape[0], model.nv
    _, J, Iw = com_jacobians(model, Q) if terms is None else terms
    Sb = supports(model)                                     # Sb[b, j]: joint j moves body b
    vj = np.asarray(model.v_joint)                           # the joint of each velocity
    Sv, Svv = Sb[:, vj], Sb[vj][:, vj]                       # body × velocity, velocity × velocity
    a = np.stack([J[vj[k], :, 3:, k] for k in range(nv)], 1) if nv else np.zeros((N, 0, 3))   # a_k (N, nv, 3)
    dM = np.zeros((N, nv, nv, nv))
    for b in range(model.njoints):
        Jb, cols = J[b], np.flatnonzero(Sv[b])
        Jv, Jw = Jb[:, :3], Jb[:, 3:]                        # (N, 3, nv)
        for k in cols:
            dJ = np.zeros((N, 6, nv))
            turn = cols[Svv[cols, k]]                        # joint(k) supports joint(j)
            lift = cols[Svv[k, cols] & (vj[cols] != vj[k])]  # joint(j) strictly supports joint(k)
            ak = a[:, k, :, None]
            dJ[:, :3, turn] = np.cross(ak, Jv[:, :, turn], axis=1)
            dJ[:, 3:, turn] = np.cross(ak, Jw[:, :, turn], axis=1)
            dJ[:, :3, lift] = np.cross(np.swapaxes(a[:, lift], 1, 2), Jv[:, :, k, None], axis=1)
            dJv, dJw = dJ[:, :3], dJ[:, 3:]
            sym = model.mass[b] * np.einsum("nai,naj->nij", dJv, Jv) + np.einsum("nai,nab,nbj->nij", dJw, Iw[b], Jw)
            Z = skew(a[:, k])
            dI = Z @ Iw[b] - Iw[b] @ Z
            dM[:, k] += sym + np.swapaxes(sym, 1, 2) + np.einsum("nai,nab,nbj->nij", Jw, dI, Jw)
    return dM


@quiet
def christoffel_coriolis(model, q, v):
    """C(q, q̇) (nv, nv) or (N, nv, nv) from the Christoffel symbols of M (the chapter's route, O(n⁴) in
    numpy; ``coriolis_matrix`` is the fast one):

    C_ij = Σ_k ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) q̇_k, so that Ṁ − 2C is skew-symmetric; with a
    free flyer, plus its bracket terms (module docstring, ``_bracket_terms``).
    """
    (Q, V), single = as_batch(model, q=q, v=v)
    terms = com_jacobians(model, Q)
    dM = mass_matrix_derivatives(model, Q, terms)            # dM[n, k, i, j] = ∂M_ij/∂q_k
    C = 0.5 * (np.einsum("nkij,nk->nij", dM, V) + np.einsum("njik,nk->nij", dM, V)
               - np.einsum("nijk,nk->nij", dM, V))
    if np.any(model.nvs > 1):
        C += _bracket_terms(model, _links_mass_matrix(model, *terms[1:]), V)
    return unbatch(check_output("christoffel_coriolis", "C", C, model, dict(q=Q, v=V)), single)


def _ad(x):
    """ad_ξ (N, 6, 6), ξ = [v; ω] (N, 6): ad_ξ η = [ω × η_v + v × η_ω; ω × η_ω], the se(3) bracket [ξ, η]."""
    out = np.zeros(x.shape[:1] + (6, 6))
    W, L = skew(x[:, 3:]), skew(x[:, :3])
    out[:, :3, :3], out[:, :3, 3:], out[:, 3:, 3:] = W, L, W
    return out


def _bracket_terms(model, M, V):
    """½ Σ_i v_i (⟨[X_i, X_j], X_k⟩ − ⟨[X_j, X_k], X_i⟩ + ⟨[X_k, X_i], X_j⟩) as a matrix [k, j]. Only the
    directions of one joint of several velocities (free flyer, ball, planar) fail to commute (directions of
    different joints act on different factors of q); for each such block b, with ξ = v[b], f = (M v)[b] and the
    joint's motion subspace S_b (n, 6) (orthonormal rows spanning a subalgebra of se(3)):
      first:  M[:, b] ad_ξ  (columns j of the block)
      second: ⟨f, [e_k, e_j]⟩ = S_b G(S_bᵀ f) S_bᵀ, G(φ) = [[0, −[φ_v]×], [−[φ_v]×, −[φ_ω]×]]  (the block itself:
              a free flyer's G, a ball joint's −[f]×)
      third:  −ad_ξᵀ M[b, :]  (rows k of the block),
    ad_ξ = S_b ad(S_bᵀ ξ) S_bᵀ with se(3)'s ``_ad`` (a ball joint's [ξ]×, a planar joint's se(2) bracket)."""
    N, nv = V.shape
    out = np.zeros((N, nv, nv))
    for kind, axis, h, a, n in zip(model.kind, model.axis, model.pitch, model.idx_v, model.nvs):
        if n == 1:
            continue
        b, Sb = slice(a, a + n), motion_subspace(kind, axis, h)
        xi, f = V[:, b], np.einsum("nij,nj->ni", M[:, b], V)
        ad = Sb @ _ad(xi @ Sb) @ Sb.T
        out[:, :, b] += M[:, :, b] @ ad
        phi = f @ Sb
        G = np.zeros((N, 6, 6))
        G[:, :3, 3:], G[:, 3:, :3], G[:, 3:, 3:] = -skew(phi[:, :3]), -skew(phi[:, :3]), -skew(phi[:, 3:])
        out[:, b, b] += Sb @ G @ Sb.T
        out[:, b, :] -= np.swapaxes(ad, 1, 2) @ M[:, b, :]
    return 0.5 * out
