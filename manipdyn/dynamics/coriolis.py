"""The Coriolis matrix C(q, q̇) of τ = M q̈ + C q̇ + g (chapter Eq. 24), in O(n²), compiled: the
Christoffel-consistent factorisation of Echeandia & Wensing (2021, "Numerical methods to compute the
Coriolis matrix and Christoffel symbols for rigid-body systems", Alg. 1) — the matrix Pinocchio's
computeCoriolisMatrix returns — instead of Christoffel sums over ∂M/∂q (O(n⁴); ``lagrange.py`` keeps that
route as the chapter's reference).

Everything is in world axes about the world origin (6-vectors [linear; angular], as ``aba.py``): joint j's
columns J_j = ⁰X_j S_j (a motion-subspace column (l, a) of body j's frame becomes [R l + p × R a; R a]), body k
moves at v_k = Σ_{j ⪯ k} J_j q̇_j, and since S_j is constant in body j's frame, J̇_j = v_j × J_j. With I_k the
body's spatial inertia about the world origin, M = Σ_k J_kᵀ I_k J_k (J_k: the columns of the joints that
support k) and

    C = Σ_k J_kᵀ (I_k J̇_k + B_k J_k),   B_k = ½ (v_k ×* I_k − I_k v_k× + (I_k v_k) ×̄),      (E&W Eq. 22)

where (h ×̄) m = m ×* h. B_k + B_kᵀ = İ_k = v_k ×* I_k − I_k v_k× makes Ṁ − 2C skew-symmetric, and B_k v_k
= v_k ×* I_k v_k makes C q̇ the Newton–Euler bias forces (Eqs. 13–18 with q̈ = 0, no gravity). The sum over
bodies k is a sum over subtrees: with composites I^c_i = Σ_{k ⪰ i} I_k, B^c_i = Σ_{k ⪰ i} B_k, for joint i
and each joint j ⪯ i (itself and its ancestors):
    C[j, i] = J_jᵀ F_i,              F_i = I^c_i J̇_i + B^c_i J_i,
    C[i, j] = (I^c_i J_i)ᵀ J̇_j + (B^c_iᵀ J_i)ᵀ J_j     (j ≠ i),
and bodies on different branches do not couple. A free-flyer root is joint 0 with six columns (S = 1₆ in
its body frame): the formula is the same, and so is Pinocchio's C (its tangent-space Christoffel symbols,
the bracket terms of ``lagrange.christoffel_coriolis``, come out of J̇ = v × J).
"""
from __future__ import annotations

import numpy as np

from .._jit import A1, A2, A3, MODEL, entry, njit
from ..spatial import add_force_cross, dot6, first_nonfinite_entry, force_cross, motion_cross, row6, sandwich3
from .forward_kinematics import fk_pass
from .kernel_inputs import model_sizes, nonfinite_input, sized
from .model_arrays import unpack
from .route import route
from .status import OK, WRONG_SIZES, bad_result


@njit(cache=True)
def coriolis_kernel(I, F, Q, V, C):
    """C (N, nv, nv) for every state of Q (N, nq), V (N, nv) (module docstring). Returns its status
    (dynamics/status.py; a non-finite C: its flat index)."""
    mdl = unpack(I, F)
    parent, iv, nvj, S, mass, com, inertia = mdl.parent, mdl.iv, mdl.nvj, mdl.S, mdl.mass, mdl.com, mdl.inertia
    N, nv, nb = Q.shape[0], V.shape[1], I.shape[1]
    R3, P3, M6, B6 = np.empty((2 * nb, 3, 3)), np.empty((4 * nb, 3)), np.empty((2 * nb, 6, 6)), \
        np.empty((2 * nv, 6))                          # four allocations, cut into the scratch arrays
    Rl, Rw, pl, pw, ww, vw = R3[:nb], R3[nb:], P3[:nb], P3[nb:2 * nb], P3[2 * nb:3 * nb], P3[3 * nb:]
    Ic, Bc, J, dJ = M6[:nb], M6[nb:], B6[:nv], B6[nv:]

    def bodies(q, v):
        """Outward: forward kinematics (forward_kinematics.fk_pass); each body's velocity v_i about the world origin
        (v_P + p × ω), its columns J_r = [R l + p × R a; R a] and J̇_r = v_i × J_r, its spatial inertia I_i about
        the world origin and B_i = ½ (v ×* I − I v× + (I v) ×̄) (E&W Eq. 22). I is symmetric and (v×)ᵀ = −v×*,
        so −I v× = (v ×* I)ᵀ: B = ½ (Z + Zᵀ + h ×̄) with Z = v ×* I (column by column), h = I v, and
        (h ×̄) m = m ×* h = [−[h_l]× ω_m; −[h_l]× v_m − [h_a]× ω_m]."""
        fk_pass(mdl, q, v, Rl, pl, Rw, pw, ww, vw)
        for i in range(nb):
            R, p, w = Rw[i], pw[i], ww[i]
            vi = (vw[i, 0] + p[1] * w[2] - p[2] * w[1], vw[i, 1] + p[2] * w[0] - p[0] * w[2],
                  vw[i, 2] + p[0] * w[1] - p[1] * w[0], w[0], w[1], w[2])
            for r in range(iv[i], iv[i] + nvj[i]):
                ax = R[0, 0] * S[r, 3] + R[0, 1] * S[r, 4] + R[0, 2] * S[r, 5]
                ay = R[1, 0] * S[r, 3] + R[1, 1] * S[r, 4] + R[1, 2] * S[r, 5]
                az = R[2, 0] * S[r, 3] + R[2, 1] * S[r, 4] + R[2, 2] * S[r, 5]
                Jr = (R[0, 0] * S[r, 0] + R[0, 1] * S[r, 1] + R[0, 2] * S[r, 2] + p[1] * az - p[2] * ay,
                      R[1, 0] * S[r, 0] + R[1, 1] * S[r, 1] + R[1, 2] * S[r, 2] + p[2] * ax - p[0] * az,
                      R[2, 0] * S[r, 0] + R[2, 1] * S[r, 1] + R[2, 2] * S[r, 2] + p[0] * ay - p[1] * ax, ax, ay, az)
                dJr = motion_cross(vi, Jr)
                for k in range(6):
                    J[r, k], dJ[r, k] = Jr[k], dJr[k]
            m, Y, Z = mass[i], Ic[i], Bc[i]
            cx = p[0] + R[0, 0] * com[i, 0] + R[0, 1] * com[i, 1] + R[0, 2] * com[i, 2]    # world CoM
            cy = p[1] + R[1, 0] * com[i, 0] + R[1, 1] * com[i, 1] + R[1, 2] * com[i, 2]
            cz = p[2] + R[2, 0] * com[i, 0] + R[2, 1] * com[i, 1] + R[2, 2] * com[i, 2]
            Y[:, :] = 0.0                              # I_i = [[m 1, −m [c]×], [m [c]×, R I_C Rᵀ − m [c]×²]]
            sandwich3(R, inertia[i], Z, Y[3:, 3:])     # (Z: scratch here)
            cc = (cx, cy, cz)
            for a in range(3):
                Y[a, a] = m
                for b in range(3):
                    Y[3 + a, 3 + b] += m * ((cx * cx + cy * cy + cz * cz if a == b else 0.0) - cc[a] * cc[b])
            Y[3, 1], Y[3, 2], Y[4, 0], Y[4, 2], Y[5, 0], Y[5, 1] = -m * cz, m * cy, m * cz, -m * cx, -m * cy, m * cx
            Y[1, 3], Y[2, 3], Y[0, 4], Y[2, 4], Y[0, 5], Y[1, 5] = -m * cz, m * cy, m * cz, -m * cx, -m * cy, m * cx
            for b in range(6):                         # Z = v ×* I, column b (= row b: I symmetric)
                zb = force_cross(vi, row6(Y, b))
                for a in range(6):
                    Z[a, b] = zb[a]
            h = (dot6(row6(Y, 0), vi), dot6(row6(Y, 1), vi), dot6(row6(Y, 2), vi), dot6(row6(Y, 3), vi),
                 dot6(row6(Y, 4), vi), dot6(row6(Y, 5), vi))
            for a in range(6):                         # B = ½ (Z + Zᵀ), in place
                for b in range(a):
                    Z[a, b] = Z[b, a] = 0.5 * (Z[a, b] + Z[b, a])
            add_force_cross(Z, h, 0.5)                 # + ½ (h ×̄)

    def composites():
        """Inward: I^c_λ += I^c_i, B^c_λ += B^c_i (leaves → root; parent[i] < i)."""
        for i in range(nb - 1, -1, -1):
            j = parent[i]
            if j >= 0:
                for a in range(6):
                    for b in range(6):
                        Ic[j, a, b] += Ic[i, a, b]
                        Bc[j, a, b] += Bc[i, a, b]

    def blocks(Cs):
        """For every column r of joint i: F = I^c J̇_r + B^c J_r, G = I^c J_r, H = B^cᵀ J_r; then for joint i
        and each ancestor k: C[x, r] = J_xᵀ F, and for k ≠ i C[r, x] = Gᵀ J̇_x + Hᵀ J_x (module docstring)."""
        Cs[:, :] = 0.0                                 # bodies on different branches do not couple
        for i in range(nb):
            for r in range(iv[i], iv[i] + nvj[i]):
                Jr, dJr = row6(J, r), row6(dJ, r)
                Fr = (dot6(row6(Ic[i], 0), dJr) + dot6(row6(Bc[i], 0), Jr), dot6(row6(Ic[i], 1), dJr) + dot6(row6(Bc[i], 1), Jr),
                      dot6(row6(Ic[i], 2), dJr) + dot6(row6(Bc[i], 2), Jr), dot6(row6(Ic[i], 3), dJr) + dot6(row6(Bc[i], 3), Jr),
                      dot6(row6(Ic[i], 4), dJr) + dot6(row6(Bc[i], 4), Jr), dot6(row6(Ic[i], 5), dJr) + dot6(row6(Bc[i], 5), Jr))
                G = (dot6(row6(Ic[i], 0), Jr), dot6(row6(Ic[i], 1), Jr), dot6(row6(Ic[i], 2), Jr),
                     dot6(row6(Ic[i], 3), Jr), dot6(row6(Ic[i], 4), Jr), dot6(row6(Ic[i], 5), Jr))
                H = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
                for b in range(6):                     # H = B^cᵀ J_r
                    H = (H[0] + Bc[i, b, 0] * Jr[b], H[1] + Bc[i, b, 1] * Jr[b], H[2] + Bc[i, b, 2] * Jr[b],
                         H[3] + Bc[i, b, 3] * Jr[b], H[4] + Bc[i, b, 4] * Jr[b], H[5] + Bc[i, b, 5] * Jr[b])
                k = i
                while k >= 0:                          # joint i itself, then its ancestors
                    for x in range(iv[k], iv[k] + nvj[k]):
                        Cs[x, r] = dot6(row6(J, x), Fr)
                        if k != i:
                            Cs[r, x] = dot6(G, row6(dJ, x)) + dot6(H, row6(J, x))
                    k = parent[k]

    for s in range(N):
        bad = nonfinite_input(Q, V, s)
        if bad >= 0:
            return bad
        bodies(Q[s], V[s])
        composites()
        blocks(C[s])
        k = first_nonfinite_entry(C[s])
        if k >= 0:
            return bad_result(nb, s * nv * nv + k)
    return OK


@njit(cache=True)
def coriolis_one(I, F, q, v, C):
    """One state: q (nq,), v (nv,), C (nv, nv), through coriolis_kernel."""
    nv = model_sizes(I)[1]
    if not (sized(I, q, (v,)) and C.shape[0] == nv and C.shape[1] == nv):
        return WRONG_SIZES
    return coriolis_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], C[np.newaxis, :, :])


@route("coriolis_matrix", ("q", "v"), "C", "vv", entry(coriolis_one, *MODEL, A1, A1, A2),
       entry(coriolis_kernel, *MODEL, A2, A2, A3))
def coriolis_matrix(model, q, v, *, threads=None, out=None):
    """C(q, q̇) (nv, nv) or (N, nv, nv): the Christoffel-consistent Coriolis matrix (module docstring;
    Pinocchio's computeCoriolisMatrix): C q̇ = Newton–Euler bias forces without gravity, Ṁ − 2C skew.
    threads, out: ``rnea``'s."""
