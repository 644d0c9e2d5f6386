"""The composite-rigid-body algorithm: M(q), the joint-space inertia matrix of T = ½ q̇ᵀ M q̇ (chapter
Eq. 23), RBDA §6.2 — one compiled source for every joint type of ``manipdyn.joints``.

Pass 1 (leaves → root): the composite C_i = body i with everything it carries, kept as (m, c, I_c) —
mass, centre of mass in body i's frame, inertia about that centre of mass — never as an inertia about the
frame origin: a centre of mass far along a joint axis (m|c|² ≫ m(x² + y²)) would lose the moment about
the axis to round-off. C_λ(i) ← C_λ(i) ∪ (C_i carried into λ(i)'s frame), combined about the common
centre of mass as Pinocchio's Inertia does:
    m = m₁ + m₂,  c = (m₁ c₁ + m₂ c₂)/m,  I = I₁ + I₂ + (m₁ m₂/m)(|d|² 1 − d dᵀ),  d = c₁ − c₂.
Pass 2: for every column r of joint i's motion subspace, s_r = [s_l; s_a] (S row r, body frame), the
wrench F = I^c_i s_r that gives C_i the unit motion s_r: the centre of mass moves at s_l + s_a × c, so
    f = m (s_l + s_a × c),   n = I_c s_a + c × f   (about body i's origin).
M[rows of i, r] = S_iᵀ F; carried to each ancestor (f ← R f, n ← R n + p × R f, the force transform of
Eqs. 15–16), M[rows of k, r] = S_kᵀ F; M is symmetric and bodies on different branches do not couple.
A free-flyer root has S = 1₆: its six columns are the composite's momenta of a unit body twist.

Kernel convention: Q (N, nq), M (N, nv, nv); the return value is the kernel's status (dynamics/status.py): a
non-finite q, or the first non-finite entry k (flat) of M (an intermediate overflowed).
"""
from __future__ import annotations

import numpy as np

from .._jit import A1, A2, A3, CONTRACT, MODEL, entry, njit
from ..joints import PLANAR
from ..errors import InputError
from ..model import MimicModel
from ..spatial import (SINCOS_MAX, add, congruence3, first_nonfinite, first_nonfinite_entry, force_up,
                       inertia_motion, merge_shift, mul3, sub)
from . import mimic
from .arguments import check_out
from .lanes import (LANES, add_sym3, gather_lanes, get3, get_rotation, get_sym3, lane_record, on_lanes,
                    placement_lanes, placement_model, planar_placement_lane, quat_model, quat_placement_lane,
                    quat_placement_lanes, screw_placement_one, tree_depth)
from .model_arrays import unpack
from .lagrange import lagrange_mass_matrix
from .route import route, thread_count
from .kernel_inputs import model_sizes, q_sized
from .status import OK, WRONG_SIZES, bad_input, bad_result, shift


@njit(cache=True, inline="always")
def merge_weights(parent, mass, mC, W):
    """The composite masses mC (nb,) = m_i + the masses body i carries, and the weights of each merge
    C_λ(i) ← C_λ(i) ∪ C_i (pass 1 order): W[i] = (m₁/m, m₂/m, m₁ m₂/m), m₁ = mC_i, m₂ = λ(i)'s mass merged
    so far, m = m₁ + m₂ (zeros for a massless union). Masses do not depend on q: computed once per call,
    the composite pass divides by nothing."""
    mC[:] = mass
    for i in range(parent.shape[0] - 1, -1, -1):
        j = parent[i]
        if j < 0:
            continue
        m1, m2 = mC[i], mC[j]
        m = m1 + m2
        W[i, 0] = W[i, 1] = W[i, 2] = 0.0      # a massless union: its centre of mass is immaterial
        if m > 0.0:
            W[i, 0], W[i, 1], W[i, 2] = m1 / m, m2 / m, m1 * m2 / m
        mC[j] = m


@njit(cache=True)
def crba_one(I, F, q, M):
    """One state: q (nq,), M (nv, nv), through the lane kernel's steps for one lane (``crba_steps_one``; (I, F) in
    z-aligned frames, ``Model.kernel.lane_arrays``)."""
    nv = model_sizes(I)[1]
    if not (q_sized(I, q) and M.shape[0] == nv and M.shape[1] == nv):
        return WRONG_SIZES
    return crba_steps_one(I, F, q, M)


@njit(cache=True, fastmath=CONTRACT)
def crba_steps_one(I, F, q, M):
    """M (nv, nv) of one state by the steps of the lane kernel (``crba_lanes``), driven for one lane (L = 1): the same
    placement, own-inertia, merge and column steps as a batch (the GPU's driver too), in the same z-aligned frames
    ((I, F) = ``Model.kernel.lane_arrays``: another form raises). An angle beyond ``spatial.SINCOS_MAX`` is placed
    with libm's sin and cos (``lanes.screw_placement_one``). Returns its status (dynamics/status.py): a non-finite q,
    or M's first non-finite entry (an intermediate overflowed)."""
    mdl = unpack(I, F)
    nb, nq, nv = I.shape[1], q.shape[0], M.shape[0]
    if not on_lanes(mdl, nq, True):
        raise ValueError("the CRBA's steps take a model in z-aligned frames (Model.kernel.lane_arrays)")
    if first_nonfinite(q[np.newaxis, :], 0) >= 0:
        return bad_input(0)
    parent, iv, nvj = mdl.parent, mdl.iv, mdl.nvj
    W, mC = np.empty((nb, 3)), np.empty(nb)
    merge_weights(parent, mdl.mass, mC, W)
    S = np.zeros(nb * COMPOSITE + nq + 6 + nv * nv)   # the bodies' records, q, the carried wrench, M's entries
    Rec, Z = S[:nb * COMPOSITE], S[nb * COMPOSITE:nb * COMPOSITE + nq]
    Fw, Mb = S[nb * COMPOSITE + nq:nb * COMPOSITE + nq + 6], S[nb * COMPOSITE + nq + 6:]
    for k in range(nq):
        Z[k] = q[k]
    for i in range(nb):                                   # pass 1: placements, own inertias
        B = Rec[i * COMPOSITE:(i + 1) * COMPOSITE]
        if mdl.kind[i] == PLANAR:
            planar_placement_lane(placement_model(i, mdl), B, Z, 0, 1)
        elif nvj[i] > 1:
            quat_placement_lane(quat_model(i, mdl), B, Z, 0, 1)
        else:
            screw_placement_one(i, mdl, B, Z)
        own_inertia_lane(own_inertia_model(i, mdl), B, 0, 1)
    for i in range(nb - 1, -1, -1):                       # leaves → root: C_λ(i) ← C_λ(i) ∪ C_i
        j = parent[i]
        if j >= 0:
            merge_lane((W[i, 0], W[i, 1], W[i, 2]), Rec[i * COMPOSITE:(i + 1) * COMPOSITE],
                       Rec[j * COMPOSITE:(j + 1) * COMPOSITE], 0, 1)
    for i in range(nb):                                   # pass 2: columns iv_i + r of M
        B = Rec[i * COMPOSITE:(i + 1) * COMPOSITE]
        for r in range(nvj[i]):
            column_lane(column_model(i, r, i, r, mdl), mC[i], B, Fw, Mb, 0, 1)
            for c in range(r):
                block_lane(column_model(i, r, i, c, mdl), Fw, Mb, 0, 1)
            k = i
            while parent[k] >= 0:
                j, Bk = parent[k], Rec[k * COMPOSITE:(k + 1) * COMPOSITE]
                if nvj[j] == 1 or mdl.kind[j] == PLANAR:  # S's rows one by one (``column_multi_lanes``)
                    column_up_lane(column_model(i, r, j, 0, mdl), Bk, Fw, Mb, 0, 1)
                    for c in range(1, nvj[j]):
                        block_lane(column_model(i, r, j, c, mdl), Fw, Mb, 0, 1)
                else:                                     # a free flyer or ball ancestor
                    column_up_multi_lane((iv[i] + r) * nv + iv[j], nvj[j], Bk, Fw, Mb, 0, 1)
                k = j
    bad = 0.0
    for a in range(nv):                                   # the lower triangle, mirrored
        for b in range(a + 1):
            y = Mb[a * nv + b]
            M[a, b] = y
            M[b, a] = y
            bad += y - y
    if bad == 0.0:
        return OK
    return bad_result(nb, first_nonfinite_entry(M))


# -- the lane kernel: the same two passes across a block of states ----------------------------------------------
# As rnea's lane kernel (docs/design.md §4c): a batch runs as blocks of LANES states, the state index last, and every
# innermost loop runs over a block's lanes. A body's record (COMPOSITE rows of LANES numbers): R^{λ}_i (9, row-major)
# and p (3) from lanes.placement_lanes, then the composite's centre of mass c (3) and its inertia about it I_c
# (6: xx, yy, zz, xy, xz, yz). Records live in two arrays by the parity of the body's depth (lanes.lane_record):
# a merge reads a child's record and writes its parent's, in the other array.
COMPOSITE = 21


@njit(cache=True, fastmath=CONTRACT)
def crba_lanes(I, F, Q, M):
    """M (N, nv, nv) for every state of Q (N, nq), block by block across lanes: the batch entry of mass_matrix, in
    z-aligned frames (another form raises). A block with a non-finite q or M or an angle beyond
    ``spatial.SINCOS_MAX`` runs its states one by one as a one-state call does (``crba_steps_one``), whose status
    names the state and entry."""
    N, nb, nq, nv = Q.shape[0], I.shape[1], Q.shape[1], M.shape[2]
    if not on_lanes(unpack(I, F), nq, True):
        raise ValueError("the CRBA's steps take a model in z-aligned frames (Model.kernel.lane_arrays)")
    Im, Fm = I, F               # as given (read-only): the one-state steps' signature
    I, F = I.copy(), F.copy()   # the model for this call alone (as rnea_lanes)
    mdl = unpack(I, F)
    parent, L = mdl.parent, LANES
    mC, W = np.empty(nb), np.empty((nb, 3))
    merge_weights(parent, mdl.mass, mC, W)
    even, odd = np.empty(nb * COMPOSITE * L), np.empty(nb * COMPOSITE * L)     # records by depth parity
    Z, Fw, Mb = np.empty(nq * L), np.empty(6 * L), np.empty(nv * nv * L)     # q; the carried wrench; M's block
    depth, multi = tree_depth(parent), nq > nb        # multi: a free flyer or a ball joint somewhere
    Mb[:] = 0.0     # entries of bodies on different branches: never written, zero for every block (pass 2 writes
    #                 every other entry of the lower triangle in every block; zeroing once, not per block: talos)
    for s0 in range(0, N, L):
        n = min(L, N - s0)
        ok = gather_lanes(Q, s0, n, Z, 0, SINCOS_MAX)
        if ok:
            for i in range(nb):                                        # pass 1: placements, own inertias
                B = lane_record(even, odd, depth, i, COMPOSITE)
                if mdl.nvj[i] > 1:                                     # a free flyer or a ball joint
                    quat_composite_lanes(i, mdl, B, Z)
                else:
                    placement_lanes(i, mdl, B, Z)
                    own_inertia_lanes(i, mdl, B)
            for i in range(nb - 1, -1, -1):                            # leaves → root: C_λ(i) ← C_λ(i) ∪ C_i
                if parent[i] >= 0:
                    merge_lanes(W[i], lane_record(even, odd, depth, i, COMPOSITE),
                                lane_record(even, odd, depth, parent[i], COMPOSITE))
            for i in range(nb):                                        # pass 2: columns iv_i … of M
                if multi:
                    for r in range(mdl.nvj[i]):
                        column_multi_lanes(i, r, mdl, mC[i], even, odd, depth, Fw, Mb)
                else:
                    column_lanes(i, mdl, mC[i], even, odd, depth, Fw, Mb)
            ok = scatter_symmetric(Mb, n, M, s0)
        if not ok:                                  # each state as a one-state call computes it: its status
            for s in range(s0, s0 + n):             # names the culprit
                code = crba_steps_one(Im, Fm, Q[s], M[s])
                if code != OK:
                    return shift(code, s, nb, nv * nv)
    return OK


@njit(cache=True, fastmath=CONTRACT)
def quat_composite_lanes(i, mdl, B, Z):
    """Pass 1 for a free flyer or a ball joint: its quaternion placement (lanes.quat_placement_lanes), its own inertia
    (a function of its own, as rnea.outward_multi_lanes: the screw joints' loops compile as they would alone)."""
    quat_placement_lanes(i, mdl, B, Z)
    own_inertia_lanes(i, mdl, B)


@njit(cache=True, inline="always")
def own_inertia_lanes(i, mdl, B):
    """``own_inertia_lane`` for every lane of the block."""
    om = own_inertia_model(i, mdl)
    for l in range(LANES):
        own_inertia_lane(om, B, l, LANES)


@njit(cache=True, inline="always")
def own_inertia_model(i, mdl):
    """Body i's centre of mass and its inertia about it (xx, yy, zz, xy, xz, yz): the start of its composite."""
    c, J = mdl.com, mdl.inertia
    return (c[i, 0], c[i, 1], c[i, 2]), (J[i, 0, 0], J[i, 1, 1], J[i, 2, 2], J[i, 0, 1], J[i, 0, 2], J[i, 1, 2])


@njit(cache=True, inline="always")
def own_inertia_lane(om, B, l, L):
    """Rows 12–20 of a body's record at lane l: its own centre of mass and inertia (om: ``own_inertia_model``)."""
    c, J = om
    B[12 * L + l], B[13 * L + l], B[14 * L + l] = c
    B[15 * L + l], B[16 * L + l], B[17 * L + l] = J[0], J[1], J[2]
    B[18 * L + l], B[19 * L + l], B[20 * L + l] = J[3], J[4], J[5]


@njit(cache=True, fastmath=CONTRACT)
def merge_lanes(w, B, P):
    """``merge_lane`` for every lane of the block."""
    wt = (w[0], w[1], w[2])
    for l in range(LANES):
        merge_lane(wt, B, P, l, LANES)


@njit(cache=True, inline="always")
def merge_lane(w, B, P, l, L):
    """The composite of B's body carried into its parent's frame and merged into the parent's (P) at lane l:
    d = R c + p, I_c,λ += R I_c Rᵀ + ``spatial.merge_shift``, c_λ ← (m₁ c + m₂ c_λ)/m (w: ``merge_weights``)."""
    w0, w1, k = w
    R = get_rotation(B, l, L)
    d = add(mul3(R, get3(B, 12, l, L)), get3(B, 9, l, L))                       # c_i in λ's frame: R c + p
    c2 = get3(P, 12, l, L)
    add_sym3(P, 15, l, L, congruence3(R, get_sym3(B, 15, l, L)))                # R I_c Rᵀ, then the shift
    add_sym3(P, 15, l, L, merge_shift(k, sub(d, c2)))
    P[12 * L + l], P[13 * L + l], P[14 * L + l] = w0 * d[0] + w1 * c2[0], w0 * d[1] + w1 * c2[1], \
        w0 * d[2] + w1 * c2[2]


@njit(cache=True, fastmath=CONTRACT)
def column_lanes(i, mdl, m, even, odd, depth, Fw, Mb):
    """Column iv_i of M for every lane of the block, on a model of screw joints: ``column_lane``, then
    ``column_up_lane`` for each ancestor (``column_multi_lanes`` with r = 0 and one velocity a body, kept apart: its
    extra loops cost the fixed-base arms 6–8 %)."""
    parent = mdl.parent
    B, cm = lane_record(even, odd, depth, i, COMPOSITE), column_model(i, 0, i, 0, mdl)
    for l in range(LANES):
        column_lane(cm, m, B, Fw, Mb, l, LANES)
    k = i
    while parent[k] >= 0:
        B, cm = lane_record(even, odd, depth, k, COMPOSITE), column_model(i, 0, parent[k], 0, mdl)
        for l in range(LANES):
            column_up_lane(cm, B, Fw, Mb, l, LANES)
        k = parent[k]


@njit(cache=True, fastmath=CONTRACT)
def column_multi_lanes(i, r, mdl, m, even, odd, depth, Fw, Mb):
    """Column iv_i + r of M (r < nv_i: the joint's velocity r) for every lane of the block, on a model with a free
    flyer, a ball or a planar joint: ``column_lane``, the entries of the joint's own block left of the diagonal
    (``block_lane``), then for each ancestor ``column_up_lane`` (a free flyer or ball ancestor:
    ``column_up_multi_lane``; a planar one: ``column_up_lane`` for its first velocity, ``block_lane`` for the
    others)."""
    parent = mdl.parent
    B, cm = lane_record(even, odd, depth, i, COMPOSITE), column_model(i, r, i, r, mdl)
    for l in range(LANES):
        column_lane(cm, m, B, Fw, Mb, l, LANES)
    for c in range(r):                                    # M[iv_i + r, iv_i + c] = S_cᵀ F, c < r
        cm = column_model(i, r, i, c, mdl)
        for l in range(LANES):
            block_lane(cm, Fw, Mb, l, LANES)
    k, nv = i, mdl.S.shape[0]
    while parent[k] >= 0:
        B, j = lane_record(even, odd, depth, k, COMPOSITE), parent[k]
        if mdl.nvj[j] == 1 or mdl.kind[j] == PLANAR:
            cm = column_model(i, r, j, 0, mdl)
            for l in range(LANES):
                column_up_lane(cm, B, Fw, Mb, l, LANES)
            for c in range(1, mdl.nvj[j]):                # (a planar ancestor's other velocities)
                cm = column_model(i, r, j, c, mdl)
                for l in range(LANES):
                    block_lane(cm, Fw, Mb, l, LANES)
        else:                                             # a free flyer or ball ancestor: its entries in one pass
            e = (mdl.iv[i] + r) * nv + mdl.iv[j]
            if mdl.nvj[j] == 6:
                for l in range(LANES):
                    column_up_multi_lane(e, 6, B, Fw, Mb, l, LANES)
            else:
                for l in range(LANES):
                    column_up_multi_lane(e, 3, B, Fw, Mb, l, LANES)
        k = j


@njit(cache=True, inline="always")
def column_model(i, r, k, c, mdl):
    """What M's entry (iv_i + r, iv_k + c) takes from the model: (its flat index in Mb's rows, S's row iv_k + c as s_l,
    s_a, the armature of velocity iv_k + c: added on the diagonal only, ``column_lane``)."""
    S, x = mdl.S, mdl.iv[k] + c
    return (mdl.iv[i] + r) * S.shape[0] + x, (S[x, 0], S[x, 1], S[x, 2]), (S[x, 3], S[x, 4], S[x, 5]), \
        mdl.armature[x]


@njit(cache=True, inline="always")
def column_lane(cm, m, B, Fw, Mb, l, L):
    """At lane l: F = I^c_i s (``spatial.inertia_motion``; m: the composite's mass; cm: ``column_model(i, i)``) into
    Fw's 6 rows, and M_ii = sᵀ F + armature_i into Mb (row-major nv × nv rows of L numbers: the lower triangle is
    written; M + diag(armature), docs/design.md §3, Joint dynamics)."""
    e, sl, sa, ar = cm
    F = inertia_motion(m, get3(B, 12, l, L), get_sym3(B, 15, l, L), sl, sa)
    Fw[0 * L + l], Fw[1 * L + l], Fw[2 * L + l], Fw[3 * L + l], Fw[4 * L + l], Fw[5 * L + l] = F
    Mb[e * L + l] = sl[0] * F[0] + sl[1] * F[1] + sl[2] * F[2] + sa[0] * F[3] + sa[1] * F[4] + sa[2] * F[5] + ar


@njit(cache=True, inline="always")
def column_up_lane(cm, B, Fw, Mb, l, L):
    """At lane l: the column's wrench F (Fw) carried from body k to its parent λ(k) (``spatial.force_up``; B: k's
    record), and M[iv_i + r, iv_λ(k)] = S_{iv_λ(k)}ᵀ F (cm: ``column_model(i, r, λ(k), 0)``)."""
    e, tl, ta, _ = cm
    F = force_up(get_rotation(B, l, L), get3(B, 9, l, L), Fw[0 * L + l], Fw[1 * L + l], Fw[2 * L + l],
                 Fw[3 * L + l], Fw[4 * L + l], Fw[5 * L + l])
    Fw[0 * L + l], Fw[1 * L + l], Fw[2 * L + l], Fw[3 * L + l], Fw[4 * L + l], Fw[5 * L + l] = F
    Mb[e * L + l] = tl[0] * F[0] + tl[1] * F[1] + tl[2] * F[2] + ta[0] * F[3] + ta[1] * F[4] + ta[2] * F[5]


@njit(cache=True, inline="always")
def column_up_multi_lane(e, n, B, Fw, Mb, l, L):
    """``column_up_lane`` into a free flyer or a ball joint (n velocities, S = [0; 1_n]): its n entries M[iv_i + r,
    iv_λ(k) + c] = S_cᵀ F are F's last n entries, written in the pass that carries F (e: the first one's index)."""
    F = force_up(get_rotation(B, l, L), get3(B, 9, l, L), Fw[0 * L + l], Fw[1 * L + l], Fw[2 * L + l],
                 Fw[3 * L + l], Fw[4 * L + l], Fw[5 * L + l])
    Fw[0 * L + l], Fw[1 * L + l], Fw[2 * L + l], Fw[3 * L + l], Fw[4 * L + l], Fw[5 * L + l] = F
    for c in range(n):
        Mb[(e + c) * L + l] = F[6 - n + c]


@njit(cache=True, inline="always")
def block_lane(cm, Fw, Mb, l, L):
    """At lane l: M[iv_i + r, iv_k + c] = S_{iv_k + c}ᵀ F, the column's wrench F (Fw) against a velocity of body k, which
    carries it (cm: ``column_model(i, r, k, c)``)."""
    e, tl, ta, _ = cm
    Mb[e * L + l] = tl[0] * Fw[0 * L + l] + tl[1] * Fw[1 * L + l] + tl[2] * Fw[2 * L + l] + ta[0] * Fw[3 * L + l] \
        + ta[1] * Fw[4 * L + l] + ta[2] * Fw[5 * L + l]


@njit(cache=True, inline="always")
def scatter_symmetric(Mb, n, M, s0):
    """M[s0 + l] = the block's lower triangle, mirrored, for its n states. Returns False if an entry is not finite."""
    nv, bad = M.shape[1], 0.0
    for l in range(n):
        for a in range(nv):
            for b in range(a + 1):
                y = Mb[(a * nv + b) * LANES + l]
                M[s0 + l, a, b] = y
                M[s0 + l, b, a] = y
                bad += y - y
    return bad == 0.0


_CRBA = "crba"


def mass_matrix(model, q, method=_CRBA, *, threads=None, out=None):
    """M(q) (nv, nv) or (N, nv, nv) for q (nq,) or (N, nq), the joint-space inertia matrix of
    T = ½ q̇ᵀ M q̇ (Eq. 23).

    method="crba" (default, O(n²)): the composite-rigid-body algorithm (this module, compiled).
    method="lagrange": the closed form M = Σ_b m_b J_vbᵀ J_vb + J_ωbᵀ R_b I_b R_bᵀ J_ωb over links
    (O(n³), compiled: ``lagrange.lagrange_mass_matrix``; a batch of it runs on one thread).
    threads: a batch's threads; out: an (nv, nv) or (N, nv, nv) float64 array to write M into (both ``rnea``'s).
    """
    if method is _CRBA and threads is None and type(model) is not MimicModel:   # the default, one test (~80 ns
        return crba(model, q) if out is None else crba(model, q, out=out)         # less a call than below)
    if isinstance(method, str) and method == "crba" and type(model) is not MimicModel:
        return crba(model, q, threads=threads, out=out)
    if type(model) is MimicModel:                   # M = Gᵀ M_full G (dynamics/mimic.py)
        M = mimic.mass_matrix(model, mass_matrix, q, method=method)
    elif not (isinstance(method, str) and method == "lagrange"):        # (an array compares elementwise)
        raise InputError(f"mass_matrix method must be 'crba' or 'lagrange', not {method!r}")
    else:
        thread_count(threads, "mass_matrix")
        M = lagrange_mass_matrix(model, q)
    if out is None:
        return M
    check_out("mass_matrix", "M", out, M.shape)[...] = M     # (M is computed: out may share q's memory)
    return out


@route("mass_matrix", ("q",), "M", "vv", entry(crba_one, *MODEL, A1, A2), entry(crba_lanes, *MODEL, A2, A3),
       lanes=True, one_lanes=True)
def crba(model, q, *, threads=None, out=None):
    """M(q) (nv, nv) or (N, nv, nv) for q (nq,) or (N, nq): the composite-rigid-body algorithm (above; its
    route: dynamics/route.py). threads, out: ``rnea``'s."""
