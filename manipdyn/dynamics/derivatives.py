"""Analytic derivatives of inverse and forward dynamics: ∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈ = M and ∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ = M⁻¹.

The recursion of Carpentier & Mansard, "Analytical derivatives of rigid body dynamics algorithms" (RSS 2018),
in the form Pinocchio implements it (``computeRNEADerivatives``: rnea-derivatives.hxx, forward and backward
steps): an O(n·d) pass pair (d the depth of the tree, so O(n²) at worst), no finite differences, no ∂M/∂q.
One compiled source (numba), run as plain Python under MANIPDYN_NOJIT=1.

Frame (owned here): every spatial quantity is in the world frame, about the world origin, as 6-vectors
[linear; angular] (Pinocchio's order; ``aba`` owns the algebra: ``cross_motion`` v ×, ``cross_force`` v ×*).
For body i, with λ its parent and S_i its motion subspace (constant in the body frame):
  J_i   = ⁰X_i S_i                            the joint's columns of the world Jacobian
  v_i   = v_λ + J_i q̇_i                       a_i = a_λ + J_i q̈_i + v_i × J_i q̇_i   (a_0 = −a_g = [−g; 0])
  Y_i   world inertia,  h_i = Y_i v_i,  f_i = Y_i a_i + v_i ×* h_i − f^ext_i          (RNEA, world form)
  τ_i   = J_iᵀ F_i,  F_i = Σ_{k ⪰ i} f_k (the subtree's force; Y^c_i, Ẏ^c_i the subtree sums likewise)
and the pieces of the motion's derivatives with respect to joint j's coordinates (Pinocchio's dVdq, dAdq, dAdv):
  V_j = v_λ(j) × J_j,   A_j = a_λ(j) × J_j + v_λ(j) × V_j,   B_j = J̇_j + V_j   (J̇_j = v_j × J_j)
  Ẏ_i = v_i ×* Y_i − Y_i v_i× + h_i ×̄      (the variation of Y_i with its ∂(v ×* h)/∂v term, h ×̄ m = −m ×* h)
— the part of ∂v_i/∂q_j that depends on the body i (for one column, ∂v_i/∂q_j = J_j × (v_i − v_j) = V_j − v_i × J_j)
enters through Ẏ_i's −Y_i v_i× term, which is what lets the subtree sums carry it;
these give, for j ⪯ i (j an ancestor of i or i itself):
  ∂τ_j/∂q_i = J_jᵀ (Ẏ^c_i V_i + Y^c_i A_i + [j ≠ i] J_i ×* F_i),  ∂τ_i/∂q_j = J_iᵀ (Y^c_i A_j + Ẏ^c_i V_j)
  ∂τ_j/∂q̇_i = J_jᵀ (Ẏ^c_i J_i + Y^c_i B_i),                       ∂τ_i/∂q̇_j = J_iᵀ (Y^c_i B_j + Ẏ^c_i J_j)
  ∂τ_j/∂q̈_i = J_jᵀ Y^c_i J_i = M_ji,                              and bodies on different branches do not couple.
The q-derivative is taken in the tangent space, as Pinocchio's: joint j moves to q ⊕ δ_j (``integrate``), so
a free-flyer root's six columns are body-frame twists and every matrix is (nv, nv).

External wrenches (``arguments.wrench_rows``): a wrench fixed in the body ("local": constant in body axes, as
Pinocchio's ``fext``) turns with the body, so −f^ext sits in f_i and its derivative is the rigid-motion term
J ×* F above. A wrench fixed in world axes ("world") about a point p fixed in the body keeps its direction:
its derivative lacks the turning of the wrench about p, R_j ×* f^ext with R_j = [p × ω_j; ω_j] (ω_j the
angular part of J_j), = [ω_j × f; p × (ω_j × f) + ω_j × n] =: A^ext_b ω_j (A^ext_b (6, 3), summed over the
subtree as A^c_i), added to ∂τ_j/∂q_i and ∂τ_i/∂q_j as J_jᵀ A^c_i ω_i and J_iᵀ A^c_i ω_j.

Forward dynamics: ∂q̈/∂τ = M⁻¹, ∂q̈/∂q = −M⁻¹ ∂τ/∂q |_{q̈ = aba(q, q̇, τ)}, ∂q̈/∂q̇ = −M⁻¹ ∂τ/∂q̇ (differentiating
τ = ID(q, q̇, FD(q, q̇, τ))). q̈ from the ABA (``aba.aba_steps_one``, ``aba.aba_lanes``), first; M⁻¹ by a Cholesky factorisation of the M = ∂τ/∂q̈ of the
same pass, in the kernel (O(n³) where the passes are O(n·d); not the O(n²) ABA-based M⁻¹).
"""
from __future__ import annotations

import numpy as np

# These kernels round as written, without fused multiply-adds (_jit.CONTRACT), so that the uncompiled source gives
# the compiled numbers bit for bit (tests/crosscheck/test_derivatives.py). The q̈ they differentiate is the ABA's lane
# steps', which fuse: ∂q̈ is a solve with M, which magnifies that rounding change by cond(M) (measured 2.5e-14 between
# the compiled and the uncompiled ∂q̈/∂q on solo12).

from .._jit import A1, A2, A3, C2, C3, FLAG, I1, MODEL, entry, njit
from ..joints import joint_placement
from ..spatial import (cross_force, cross_motion, dot6, first_nonfinite_entry, inertia_variation, mat6, rigid6,
                       spd_inverse, world_inertia, world_motion)
from .aba import ABA, aba_steps_one
from .route import is_dask, lazy, run_chunks, thread_count
from .kernel_inputs import finite_state, no_wrenches
from .model_arrays import kernel_arrays, unpack
from .arguments import as_batch, fast_shape, raise_kernel_error, raise_output_error, unbatch, wrench_rows
from .status import OK, bad_input, bad_result, reading, singular_row

_QVA, _QVT = ("q", "v", "a"), ("q", "v", "tau")
OUT_RNEA, OUT_ABA = ("dtau_dq", "dtau_dv", "dtau_da"), ("dqdd_dq", "dqdd_dv", "dqdd_dtau")


@njit(cache=True, inline="always", fastmath=False)
def first_nonfinite3(D, s):
    """The flat index (which, row, column) within D[:, s] of the first non-finite entry of the three
    (N, nv, nv) matrices D = (dq, dv, da), or -1 (spatial.first_nonfinite_entry on each)."""
    nv = D[0].shape[1]
    for w in range(3):
        k = first_nonfinite_entry(D[w][s])
        if k >= 0:
            return w * nv * nv + k
    return -1


# -- the kernel: Carpentier & Mansard's two passes, nested so that they share the scratch arrays -------------

@njit(cache=True, fastmath=False)
def rnea_derivatives_kernel(I, F, Q, V, A, X, xb, xp, world, dq, dv, da):
    """∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈ (N, nv, nv) into dq, dv, da for every state of Q (N, nq), V, A (N, nv), with the
    external wrenches X (N, K, 6) on bodies xb (K,) about points xp (K, 3) (``arguments.wrench_rows``; body axes,
    or world axes with ``world``). Returns its status (dynamics/status.py); −2 − nb − k a non-finite
    result, k = ((s·3 + w)·nv + r)·nv + c for entry (r, c) of output w (0 dq, 1 dv, 2 da) of state s."""
    mdl = unpack(I, F)
    parent, kind, iq, iv, nvj, S = mdl.parent, mdl.kind, mdl.iq, mdl.iv, mdl.nvj, mdl.S
    axis, pitch, R0, p0, mass, com, inertia = mdl.axis, mdl.pitch, mdl.R0, mdl.p0, mdl.mass, mdl.com, mdl.inertia
    mg, armature = mdl.mg, mdl.armature
    N, nv, nb = Q.shape[0], V.shape[1], I.shape[1]
    R33, P3 = np.empty((2 * nb, 3, 3)), np.empty((2 * nb, 3))    # five allocations, cut into blocks
    B6, B66, B63 = np.empty((3 * nb + 4 * nv + 3, 6)), np.empty((2 * nb + 5, 6, 6)), np.empty((nb + 1, 6, 3))
    T6 = np.empty((27, nv))        # J, A, V, B transposed (rows contiguous along the columns), 3 rows scratch
    Rl, Rw, pl, pw = R33[:nb], R33[nb:], P3[:nb], P3[nb:]         # placements in the parent, in the world
    vel, acc, frc = B6[:nb], B6[nb:2 * nb], B6[2 * nb:3 * nb]     # v_i, a_i (with −a_g), f_i
    e = 3 * nb                                                  # J, V, A, B: one row per joint column
    Jc, Vc, Ac, Bc = B6[e:e + nv], B6[e + nv:e + 2 * nv], B6[e + 2 * nv:e + 3 * nv], B6[e + 3 * nv:e + 4 * nv]
    t, u, a0 = B6[e + 4 * nv], B6[e + 4 * nv + 1], B6[e + 4 * nv + 2]   # scratch; a_0 = −a_g = [−g; 0]
    Yc, dYc, Ae, AJ = B66[:nb], B66[nb:2 * nb], B63[:nb], B63[nb]      # Y^c, Ẏ^c, A^c per body; A^cᵀ J
    YJ, dYJ, Fq, Fv, T = B66[2 * nb], B66[2 * nb + 1], B66[2 * nb + 2], B66[2 * nb + 3], B66[2 * nb + 4]
    JT, AT, VT, BT, g = T6[0:6], T6[6:12], T6[12:18], T6[18:24], T6[24:27]
    for x in range(3):                                          # (per column of joint i: Y^c J, Ẏ^cᵀ J, Fq, Fv)
        a0[x], a0[3 + x] = mg[x], 0.0

    def motion(q, v, a):
        """Forward pass (i = 1 … nb): placements, J_i, v_i, a_i, V_i, A_i, B_i, Y_i, f_i, Ẏ_i."""
        for i in range(nb):
            joint_placement(i, kind, iq, axis, pitch, R0, p0, q, Rl, pl)
            j = parent[i]
            for x in range(3):
                for y in range(3):
                    Rw[i, x, y] = Rl[i, x, y] if j < 0 else \
                        Rw[j, x, 0] * Rl[i, 0, y] + Rw[j, x, 1] * Rl[i, 1, y] + Rw[j, x, 2] * Rl[i, 2, y]
                pw[i, x] = pl[i, x] if j < 0 else \
                    pw[j, x] + Rw[j, x, 0] * pl[i, 0] + Rw[j, x, 1] * pl[i, 1] + Rw[j, x, 2] * pl[i, 2]
            vl, al = vel[max(j, 0)], acc[j] if j >= 0 else a0      # v_λ (read only if j ≥ 0), a_λ
            t[:] = 0.0
            for x in range(6):
                vel[i, x] = vl[x] if j >= 0 else 0.0
                acc[i, x] = al[x]
            for r in range(iv[i], iv[i] + nvj[i]):
                world_motion(Rw[i], pw[i], S[r], Jc[r])             # J_i = ⁰X_i S_i
                for x in range(6):
                    t[x] += Jc[r, x] * v[r]                         # J_i q̇_i
                    vel[i, x] += Jc[r, x] * v[r]                    # v_i = v_λ + J_i q̇_i
                    acc[i, x] += Jc[r, x] * a[r]
            cross_motion(vel[i], t, u)
            for x in range(6):
                acc[i, x] += u[x]                                   # a_i = a_λ + J_i q̈_i + v_i × J_i q̇_i
            for r in range(iv[i], iv[i] + nvj[i]):
                cross_motion(vel[i], Jc[r], Bc[r])                  # J̇_i = v_i × J_i
                cross_motion(al, Jc[r], Ac[r])                      # A_i = a_λ × J_i + v_λ × V_i
                Vc[r, :] = 0.0
                if j >= 0:
                    cross_motion(vl, Jc[r], Vc[r])                  # V_i = v_λ × J_i
                    cross_motion(vl, Vc[r], u)
                    for x in range(6):
                        Ac[r, x] += u[x]
                for x in range(6):
                    Bc[r, x] += Vc[r, x]                            # B_i = J̇_i + V_i
                    JT[x, r], AT[x, r], VT[x, r], BT[x, r] = Jc[r, x], Ac[r, x], Vc[r, x], Bc[r, x]
            world_inertia(mass[i], com[i], inertia[i], Rw[i], pw[i], T, Yc[i])
            rigid6(Yc[i], vel[i], t, False)                           # h_i = Y_i v_i
            rigid6(Yc[i], acc[i], frc[i], False)
            cross_force(vel[i], t, u)
            for x in range(6):
                frc[i, x] += u[x]                                   # f_i = Y_i a_i + v_i ×* h_i
            inertia_variation(Yc[i], vel[i], t, T, dYc[i])          # Ẏ_i
            Ae[i, :, :] = 0.0

    def external(x):
        """f_b −= [f; n + p × f] (world axes, about the world origin) for each wrench x[k] = [f; n] on body
        b = xb[k] about its point p (xp[k] in the body); "world" wrenches also add A^ext_b (module docstring)."""
        for k in range(xb.shape[0]):
            b = xb[k]
            for y in range(3):                                      # t = [f; n] in world axes, u[:3] = p
                u[y] = pw[b, y] + Rw[b, y, 0] * xp[k, 0] + Rw[b, y, 1] * xp[k, 1] + Rw[b, y, 2] * xp[k, 2]
                for z in (0, 3):
                    t[z + y] = x[k, z + y] if world else \
                        Rw[b, y, 0] * x[k, z] + Rw[b, y, 1] * x[k, z + 1] + Rw[b, y, 2] * x[k, z + 2]
            frc[b, 0] -= t[0]
            frc[b, 1] -= t[1]
            frc[b, 2] -= t[2]
            frc[b, 3] -= t[3] + u[1] * t[2] - u[2] * t[1]
            frc[b, 4] -= t[4] + u[2] * t[0] - u[0] * t[2]
            frc[b, 5] -= t[5] + u[0] * t[1] - u[1] * t[0]
            if world:                                               # column y: ω = e_y, g = e_y × f:
                for y in range(3):                                  # [g; p × g + e_y × n]
                    gx, gy, gz = (0.0, -t[2], t[1]) if y == 0 else (t[2], 0.0, -t[0]) if y == 1 else (-t[1], t[0], 0.0)
                    ex, ey, ez = (0.0, -t[5], t[4]) if y == 0 else (t[5], 0.0, -t[3]) if y == 1 else (-t[4], t[3], 0.0)
                    Ae[b, 0, y] += gx
                    Ae[b, 1, y] += gy
                    Ae[b, 2, y] += gz
                    Ae[b, 3, y] += u[1] * gz - u[2] * gy + ex
                    Ae[b, 4, y] += u[2] * gx - u[0] * gz + ey
                    Ae[b, 5, y] += u[0] * gy - u[1] * gx + ez

    def columns(i):
        """Joint i's columns against the subtree (Y^c_i, Ẏ^c_i, F_i, A^c_i complete): Y^c J, Ẏ^cᵀ J, the
        force derivatives Fq = Ẏ^c V + Y^c A + A^c ω, Fv = Ẏ^c J + Y^c B, and A^cᵀ J."""
        for c in range(nvj[i]):
            r = iv[i] + c
            rigid6(Yc[i], Jc[r], YJ[c], False)
            mat6(dYc[i], Vc[r], Fq[c], False)
            rigid6(Yc[i], Ac[r], Fq[c], True)
            mat6(dYc[i], Jc[r], Fv[c], False)
            rigid6(Yc[i], Bc[r], Fv[c], True)
            for x in range(6):
                dYJ[c, x] = (dYc[i, 0, x] * Jc[r, 0] + dYc[i, 1, x] * Jc[r, 1] + dYc[i, 2, x] * Jc[r, 2]
                             + dYc[i, 3, x] * Jc[r, 3] + dYc[i, 4, x] * Jc[r, 4] + dYc[i, 5, x] * Jc[r, 5])
            for y in range(3):
                AJ[c, y] = 0.0
            if not world:                                           # A^c = 0: no world-axes wrench
                continue
            for x in range(6):
                Fq[c, x] += Ae[i, x, 0] * Jc[r, 3] + Ae[i, x, 1] * Jc[r, 4] + Ae[i, x, 2] * Jc[r, 5]
            for y in range(3):
                AJ[c, y] = (Ae[i, 0, y] * Jc[r, 0] + Ae[i, 1, y] * Jc[r, 1] + Ae[i, 2, y] * Jc[r, 2]
                            + Ae[i, 3, y] * Jc[r, 3] + Ae[i, 4, y] * Jc[r, 4] + Ae[i, 5, y] * Jc[r, 5])

    def own_block(i, Dq, Dv, Da):
        """The (i, i) block: ∂τ_i/∂q_i = J_iᵀ Fq, ∂τ_i/∂q̇_i = J_iᵀ Fv, M_ii = J_iᵀ Y^c J_i."""
        for r in range(iv[i], iv[i] + nvj[i]):
            for c in range(nvj[i]):
                k = iv[i] + c
                Da[r, k] = Da[k, r] = dot6(Jc[r], YJ[c]) + (armature[r] if r == k else 0.0)    # M + diag(armature)
                Dq[r, k] = dot6(Jc[r], Fq[c])
                Dv[r, k] = dot6(Jc[r], Fv[c])

    def ancestors(i, r0, r1, Dq, Dv, Da):
        """The (j, i) and (i, j) blocks for the ancestors j whose columns are rows r0 … r1 − 1 (module
        docstring): ∂τ_j/∂q_i = J_jᵀ Fq, ∂τ_i/∂q_j = (Y^c J_i)ᵀ A_j + (Ẏ^cᵀ J_i)ᵀ V_j + (A^cᵀ J_i)ᵀ ω_j, and
        for q̇, q̈. Along rows of the transposed J, A, V, B: independent multiply-adds over the ancestors'
        columns (the same operations in the same order as one dot product per pair; measured 11 % off the whole
        kernel on a 32-link chain); the entries of column k go through the scratch rows g."""
        J0, J1, J2, J3, J4, J5 = JT[0], JT[1], JT[2], JT[3], JT[4], JT[5]
        ga, gq, gv = g[0], g[1], g[2]
        for c in range(nvj[i]):
            k = iv[i] + c
            y0, y1, y2, y3, y4, y5 = YJ[c, 0], YJ[c, 1], YJ[c, 2], YJ[c, 3], YJ[c, 4], YJ[c, 5]
            d0, d1, d2, d3, d4, d5 = dYJ[c, 0], dYJ[c, 1], dYJ[c, 2], dYJ[c, 3], dYJ[c, 4], dYJ[c, 5]
            f0, f1, f2, f3, f4, f5 = Fq[c, 0], Fq[c, 1], Fq[c, 2], Fq[c, 3], Fq[c, 4], Fq[c, 5]
            h0, h1, h2, h3, h4, h5 = Fv[c, 0], Fv[c, 1], Fv[c, 2], Fv[c, 3], Fv[c, 4], Fv[c, 5]
            e0, e1, e2 = AJ[c, 0], AJ[c, 1], AJ[c, 2]
            dq, dv = Dq[k], Dv[k]
            for r in range(r0, r1):
                ga[r] = y0 * J0[r] + y1 * J1[r] + y2 * J2[r] + y3 * J3[r] + y4 * J4[r] + y5 * J5[r]
                gq[r] = f0 * J0[r] + f1 * J1[r] + f2 * J2[r] + f3 * J3[r] + f4 * J4[r] + f5 * J5[r]
                gv[r] = h0 * J0[r] + h1 * J1[r] + h2 * J2[r] + h3 * J3[r] + h4 * J4[r] + h5 * J5[r]
                dq[r] = ((y0 * AT[0, r] + y1 * AT[1, r] + y2 * AT[2, r] + y3 * AT[3, r] + y4 * AT[4, r]
                          + y5 * AT[5, r])
                         + (d0 * VT[0, r] + d1 * VT[1, r] + d2 * VT[2, r] + d3 * VT[3, r] + d4 * VT[4, r]
                            + d5 * VT[5, r])
                         + e0 * J3[r] + e1 * J4[r] + e2 * J5[r])
                dv[r] = ((y0 * BT[0, r] + y1 * BT[1, r] + y2 * BT[2, r] + y3 * BT[3, r] + y4 * BT[4, r]
                          + y5 * BT[5, r])
                         + (d0 * J0[r] + d1 * J1[r] + d2 * J2[r] + d3 * J3[r] + d4 * J4[r] + d5 * J5[r]))
            for r in range(r0, r1):
                Da[k, r] = Da[r, k] = ga[r]
                Dq[r, k] = gq[r]
                Dv[r, k] = gv[r]

    def derivatives(Dq, Dv, Da):
        """Backward pass (i = nb … 1): joint i's blocks against itself and its ancestors, then the subtree
        sums Y^c, Ẏ^c, F, A^c handed to the parent."""
        Dq[:, :] = 0.0                                              # different branches do not couple
        Dv[:, :] = 0.0
        Da[:, :] = 0.0
        for i in range(nb - 1, -1, -1):
            columns(i)
            own_block(i, Dq, Dv, Da)
            for c in range(nvj[i]):                                 # for the ancestors' rows: + J_i ×* F_i
                cross_force(Jc[iv[i] + c], frc[i], t)
                for x in range(6):
                    Fq[c, x] += t[x]
            j = parent[i]
            while j >= 0:                                           # the ancestors, a run at a time: bodies
                lo = j                                              # lo … j, each the parent of the next,
                while lo > 0 and parent[lo] == lo - 1:              # own the contiguous rows iv[lo] … iv[j] + nvj[j]
                    lo -= 1
                ancestors(i, iv[lo], iv[j] + nvj[j], Dq, Dv, Da)
                j = parent[lo]
            j = parent[i]
            if j >= 0:
                for x in range(6):
                    frc[j, x] += frc[i, x]
                    for y in range(6):
                        Yc[j, x, y] += Yc[i, x, y]
                        dYc[j, x, y] += dYc[i, x, y]
                    for y in range(3 if world else 0):
                        Ae[j, x, y] += Ae[i, x, y]

    for s in range(N):
        if not finite_state(Q, V, A, s):
            return bad_input(s)
        motion(Q[s], V[s], A[s])
        external(X[s if X.shape[0] > 1 else 0])
        derivatives(dq[s], dv[s], da[s])
        k = first_nonfinite3((dq, dv, da), s)
        if k >= 0:
            return bad_result(nb, s * 3 * nv * nv + k)
    return OK


@njit(cache=True, fastmath=False)
def aba_derivatives_kernel(I, F, Q, V, Tau, X, xb, xp, world, qdd, dq, dv, Minv):
    """∂q̈/∂q, ∂q̈/∂q̇ (N, nv, nv) into dq, dv and M⁻¹ into Minv at q̈ = aba(q, q̇, τ), given in qdd (N, nv) (the ABA's,
    computed first by ``aba.aba_lanes`` or ``aba.aba_steps_one``): the RNEA derivatives at q̈ (M into Minv), then M⁻¹ by Cholesky and
    ∂q̈/∂x = −M⁻¹ ∂τ/∂x. Tau is not read (the signature of the batch entries). Returns -1; a bad input; −2 − i for
    a pivot of M not > 0 at joint i; −2 − nb − N·nv − k for a non-finite derivative, k as in
    rnea_derivatives_kernel (w = 0 dq, 1 dv, 2 M⁻¹): after the N·nv entries of q̈, which the ABA reports."""
    N, nv, nb = Q.shape[0], V.shape[1], I.shape[1]
    code = rnea_derivatives_kernel(I, F, Q, V, qdd, X, xb, xp, world, dq, dv, Minv)
    if code != -1:
        return code - N * nv if code <= -2 - nb else code   # non-finite entries: after q̈'s codes
    W = np.empty((4 * nv, nv))              # Cholesky factor (lower triangle); M, then L⁻¹; −M⁻¹; a copy of D
    L, M, Mn, T = W[:nv], W[nv:2 * nv], W[2 * nv:3 * nv], W[3 * nv:]
    for s in range(N):
        M[:, :] = Minv[s]
        k = spd_inverse(M, L, Minv[s])
        if k >= 0:
            return singular_row(I, k)
        for r in range(nv):
            for c in range(nv):
                Mn[r, c] = -Minv[s, r, c]
        for D in (dq[s], dv[s]):                          # D ← −M⁻¹ D (BLAS: 2 n³ flops, the bulk at n ≳ 20)
            T[:, :] = D
            np.dot(Mn, T, D)
        k = first_nonfinite3((dq, dv, Minv), s)
        if k >= 0:
            return bad_result(nb, N * nv + s * 3 * nv * nv + k)
    return OK


@njit(cache=True, inline="always")
def one_block(D):
    """D (nv, nv), C order, as a batch of one (1, nv, nv), still C order (a newaxis view would not be)."""
    return D.reshape(1, D.shape[0], D.shape[1])


@njit(cache=True, fastmath=False)
def rnea_derivatives_one(I, F, q, v, a, dq, dv, da):
    """One state (nq,), (nv,), no external wrench: the kernel on row views, no Python-side reshapes."""
    X, xb, xp, world = no_wrenches(I, F)
    return rnea_derivatives_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], a[np.newaxis, :], X, xb, xp, world,
                                   one_block(dq), one_block(dv), one_block(da))


@njit(cache=True, fastmath=False)
def aba_derivatives_one(I, F, Il, Fl, q, v, tau, qdd, dq, dv, Minv):
    """One state (nq,), (nv,), no external wrench: q̈ by ``aba.aba_steps_one`` on the model in z-aligned frames
    (Il, Fl: ``Model.kernel.lane_arrays``), then the kernel on row views, no Python-side reshapes."""
    X, xb, xp, world = no_wrenches(Il, Fl)
    code = aba_steps_one(Il, Fl, q, v, tau, X[0], xb, xp, world, qdd)
    if code != OK:
        return code
    X, xb, xp, world = no_wrenches(I, F)
    return aba_derivatives_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], tau[np.newaxis, :], X, xb, xp, world,
                                  qdd[np.newaxis, :], one_block(dq), one_block(dv), one_block(Minv))


# The compiled code every call reaches (``_jit.entry``): inputs of any strides; the three matrices, which these
# calls allocate themselves, in C order (BLAS writes −M⁻¹ D into them)
RNEA_DERIVATIVES = entry(rnea_derivatives_kernel, *MODEL, A2, A2, A2, A3, I1, A2, FLAG, C3, C3, C3)
ABA_DERIVATIVES = entry(aba_derivatives_kernel, *MODEL, A2, A2, A2, A3, I1, A2, FLAG, A2, C3, C3, C3)
RNEA_DERIVATIVES_ONE = entry(rnea_derivatives_one, *MODEL, A1, A1, A1, C2, C2, C2)
ABA_DERIVATIVES_ONE = entry(aba_derivatives_one, *MODEL, *MODEL, A1, A1, A1, A1, C2, C2, C2)


# -- Python entry points ----------------------------------------------------------------------------------

def rnea_derivatives(model, q, v, a, *, f_ext=None, f_ext_frame="local", threads=None):
    """(∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈) of τ = rnea(q, q̇, q̈, f_ext), as Pinocchio's computeRNEADerivatives.

    Parameters
    ----------
    q : (nq,) or (N, nq); v, a : (nv,) or (N, nv).
    f_ext : as ``rnea``: {link or frame name: (force, moment)} in the frame's axes (f_ext_frame="local", the
        wrench turns with the body, as Pinocchio's fext) or in world axes ("world": its direction is fixed
        while its point moves with the body).
    threads : a batch's threads (``rnea``'s).
    Returns
    -------
    dtau_dq, dtau_dv, dtau_da : (nv, nv) or (N, nv, nv); dtau_da = M(q). The q-derivative is in the tangent
        space: column j is d τ(q ⊕ ε e_j)/dε (``integrate``; a free flyer's columns are body-frame twists).
    """
    return _call(model, q, v, a, f_ext, f_ext_frame, False, threads)


def aba_derivatives(model, q, v, tau, *, f_ext=None, f_ext_frame="local", threads=None):
    """(∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ) of q̈ = aba(q, q̇, τ, f_ext), as Pinocchio's computeABADerivatives:
    ∂q̈/∂τ = M⁻¹, ∂q̈/∂q = −M⁻¹ ∂τ/∂q and ∂q̈/∂q̇ = −M⁻¹ ∂τ/∂q̇ at q̈ (RNEA derivatives; M⁻¹ by Cholesky).

    Parameters and shapes as ``rnea_derivatives`` (tau in place of a). Raises SingularError as ``aba``.
    """
    return _call(model, q, v, tau, f_ext, f_ext_frame, True, threads)


def _call(model, q, v, x, f_ext, f_ext_frame, fd, threads=None):
    """Both entry points: the one-state kernel for plain float64 input, else checked batches."""
    names, call, outs = (_QVT, "aba_derivatives", OUT_ABA) if fd else (_QVA, "rnea_derivatives", OUT_RNEA)
    if threads is not None:
        thread_count(threads, call)
    if any(is_dask(y) for y in (q, v, x)):                # Dask arrays of states: three lazy results
        public = aba_derivatives if fd else rnea_derivatives
        stacked = lazy(call, names, lambda m, *b, threads: np.stack(public(m, *b, threads=threads), axis=1),
                       model, (q, v, x), f_ext, (3, model.nv, model.nv))
        return tuple(stacked[:, k] for k in range(3))
    nd = fast_shape(model, q, v, x) if f_ext is None and f_ext_frame == "local" else 0
    if nd == 1:
        nv = model.nv
        D = (np.empty((nv, nv)), np.empty((nv, nv)), np.empty((nv, nv)))
        if fd:
            qdd = np.empty(nv)
            code = ABA_DERIVATIVES_ONE.call(*kernel_arrays(model), *model.kernel.lane_arrays, q, v, x, qdd, *D)
        else:
            code = RNEA_DERIVATIVES_ONE.call(*kernel_arrays(model), q, v, x, *D)
        if code == -1:
            return D
        Q, V, Xs, D = q[None], v[None], x[None], tuple(d[None] for d in D)
    else:
        (Q, V, Xs), single = as_batch(model, **dict(zip(names, (q, v, x))))
        N, nv = Q.shape[0], model.nv
        ext = wrench_rows(model, f_ext, f_ext_frame, N)
        ext_lanes = wrench_rows(model, f_ext, f_ext_frame, N, True) if fd else ext   # (the ABA's: z-aligned axes)
        if model.njoints == 0:
            return tuple(unbatch(np.zeros((N, nv, nv)), single) for _ in range(3))
        D = tuple(np.empty((3, N, nv, nv)))   # one block, three views; every entry written (fresh zeros cost
        # 2.6 µs per state on chain32's 24 MB). One block, not three: malloc then keeps it in its heap between
        # calls (three 8 MB blocks went back to the OS each call: ~950 page faults, 3 µs per state)
        qdd = np.empty((N, nv)) if fd else None
        kernel, results = (ABA_DERIVATIVES, (qdd, *D)) if fd else (RNEA_DERIVATIVES, D)
        world = f_ext_frame == "world"

        def run(a, b):                          # rows a … b − 1 (route.run_chunks: on several threads)
            x = (ext[0][a:b] if ext[0].shape[0] == N else ext[0], *ext[1:])
            if fd:                              # q̈ first: the ABA's batch entry
                xl = (ext_lanes[0][a:b] if ext_lanes[0].shape[0] == N else ext_lanes[0], *ext_lanes[1:])
                code = ABA.call(*model.kernel.lane_arrays, Q[a:b], V[a:b], Xs[a:b], *xl, world, qdd[a:b])
                if code != OK:
                    return code
            return kernel.call(*kernel_arrays(model), Q[a:b], V[a:b], Xs[a:b], *x, world, *(r[a:b] for r in results))
        code = run_chunks(run, N, thread_count(threads, call))
        if code == -1:
            return tuple(unbatch(d, single) for d in D)
    _raise(model, code, names, (Q, V, Xs), call, outs, D, qdd if fd else None)


def _raise(model, code, names, batches, call, outs, D, qdd):
    """The error of a kernel's return code: a bad input (InputError), a singular M (SingularError), a
    non-finite q̈ (the ABA's codes, first N·nv of the flat codes when qdd is given) or a non-finite
    derivative entry (NumericalError naming the matrix, its row's joint and the state)."""
    nb, nv, N = model.njoints, model.nv, batches[0].shape[0]
    what, k = reading(code, nb)
    if what != "result":                                          # a bad input or a singular M
        raise_kernel_error(model, code, names, batches, call)
    if qdd is not None:
        if k < N * nv:
            raise_kernel_error(model, code, names, batches, call, "q̈", qdd.reshape(N, nv))
        k -= N * nv
    s, w, r, c = np.unravel_index(k, (N, 3, nv, nv))
    raise_output_error(call, outs[w], D[w], (s, r, c), model, dict(zip(names, batches)))
