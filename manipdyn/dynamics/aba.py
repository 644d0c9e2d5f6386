"""Forward dynamics: q̈ = M(q)⁻¹ (τ − C q̇ − g + Σ Jᵀ f_ext), two ways.

``aba``: Featherstone's articulated-body algorithm (RBDA §7.3, Table 7.1), one compiled source on the joint
model (``joints``), run as plain Python under MANIPDYN_NOJIT=1. Three passes over the bodies:
  1 (outward)  velocities v_i, velocity-product accelerations c_i, rigid inertias, bias forces p^A_i;
  2 (inward)   articulated inertias I^A_i and bias forces p^A_i, handed to the parent;
  3 (outward)  accelerations a_i and q̈_i.
Each pass is a set of steps on a body's record (``velocity_lane``, ``bias_lane``, ``articulated_lane``, ``handed_lane``,
``acceleration_lane`` and their multi-dof forms), driven across a block of states (``aba_lanes``, the batch), for one
state (``aba_steps_one``) and by a GPU thread (gpu.py): one source, in the chapter's symbols.
It is generic over joint types: joint i has n_i = nv_j velocities and the motion subspace S_i (6 × n_i, its
rows ``S[iv:iv+n_i]`` in the model's kernel form), constant in the body frame (c_J = 0, no Ṡ). For a
1-dof joint D_i = S_iᵀ I^A_i S_i is a number; for a free flyer (S = 1₆), a ball or a planar joint it is n_i × n_i,
factored by Cholesky (``articulated_multi``).

Spatial vectors (owned here): 6-vectors in the order [linear; angular] — the order of S's rows and of
Pinocchio — in each body's own frame, about its origin:
  motion  m = [v_O; ω],   force  f = [f; n_O],
  rigid inertia  I = [[m 1, −m [c]×], [m [c]×, I_C − m [c]×²]]   (RBDA Eq. 2.63, blocks reordered).
With (R, p) body i's placement in its parent λ (x_λ = R x_i + p, ``core``):
  ⁱX_λ m  = [Rᵀ (v + ω × p); Rᵀ ω]          motion, parent → body
  ^λX*_i f = [R f; R n + p × R f]            force, body → parent
Gravity enters as the base acceleration a_0 = −a_g = [−g; 0] (RBDA §5.3, docs/design.md §6).

External wrenches enter after pass 1 (Table 7.1: p^A_i = v_i ×* I_i v_i − f^x_i, f^x_i in body coordinates;
``lanes.external_lane``), as ``arguments.wrench_rows`` lays them out: one row per named frame (body, the frame's
origin in it, [force; moment about that origin] in the body's z-aligned axes, or in world axes which the one-state
driver turns into the body's, ``lanes.wrench_in_body``).

``forward_dynamics(..., method="cholesky")``: the M⁻¹ route, Cholesky of M (CRBA) with the right-hand side
τ − rnea(q, q̇, 0) from the Newton–Euler code.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import A1, A2, A3, CONTRACT, FLAG, I1, MODEL, entry, njit
from ..errors import InputError
from ..joints import PLANAR
from ..model import FRICTION_EPS, MimicModel
from . import mimic
from ..spatial import (SINCOS_MAX, add, cholesky, cholesky_solve, first_nonfinite, force_cross, force_up,
                       inertia_motion, inertia_up, motion_cross, motion_down, mul3, mul3t, scale)
from .kernel_inputs import finite_state, no_wrenches, sized, wrench_rows_of
from .lanes import (LANES, add_sym3, external_lane, external_lanes, gather_lanes, get3, get6, get_rotation, get_sym3,
                    inertial_model, lane_record, motion_model, multi_model, multi_rates, on_lanes, one_lane,
                    placement_lanes, placement_model, planar_placement_lane, quat_model, quat_placement_lane,
                    quat_placement_lanes, scatter_lanes, screw_placement_one, selected, set3, set6, tree_depth,
                    wrench_in_body)
from .model_arrays import unpack
from .crba import crba, crba_lanes, crba_steps_one
from .rnea import rnea, rnea_lanes, rnea_steps_one, steps_scratch
from .route import route
from .status import OK, WRONG_SIZES, bad_input, bad_result, shift, singular_joint, singular_row


@njit(cache=True, inline="always")
def singular_threshold(inertia, mass):
    """dmin = 1e-14 · max(max |I_C|, max m): a pivot of D_i below it is a massless moving subtree."""
    x = 1e-300
    for i in range(mass.shape[0]):
        x = max(x, mass[i])
        for a in range(3):
            for b in range(3):
                x = max(x, abs(inertia[i, a, b]))
    return 1e-14 * x


# -- the lane kernel: the three passes across a block of states ------------------------------------------------
# As rnea's lane kernel (docs/design.md §4c): a batch runs as blocks of LANES states, the state index last, and every
# innermost loop runs over a block's lanes. A body's record (ARTICULATED rows of LANES numbers): R^λ_i (9) and p (3)
# (lanes.placement_lanes), v_i, c_i (6 each), I^A_i (21: the blocks of [[C, Bᵀ], [B, A]] as spatial.inertia_up names
# them — C and A as lanes.get_sym3 stores a symmetric 3×3, B row-major), p^A_i (6), U_i (6), D_i, u_i, a_i (6); two
# arrays by depth parity (lanes.lane_record). A free flyer or a ball joint (n velocities, S = [0; 1_n]) keeps its pass-2
# factors in a record of its own (MULTI rows, ``articulated_multi``).
_V, _C, _IA, _IB, _IAA, _PA, _U, _D, _A = 12, 18, 24, 30, 39, 45, 51, 57, 59      # first rows: v, c, I^A (C, B, A),
ARTICULATED = 65                                                              # p^A, U, D (then u), a


@njit(cache=True, fastmath=CONTRACT)
def aba_lanes(I, F, Q, V, Tau, X, body, point, world, out):
    """q̈ (N, nv) into out for every state of Q (N, nq), V, Tau (N, nv), block by block across lanes (RBDA Table 7.1):
    the batch entry of aba. Its status as ``aba_steps_one``'s, the state shifted. (I, F): the model in z-aligned
    frames (``Model.kernel.lane_arrays``: another form raises).

    External wrenches X (N, K, 6) (``arguments.wrench_rows``, in z-aligned axes; K = 0 for none) enter between the
    first two passes (``lanes.external_lanes``). A block with a non-finite
    input or q̈, a singular D_i or an angle beyond ``spatial.SINCOS_MAX`` runs state by state too, as a one-state
    call does: its status names the state, the joint or the entry. Every lane is computed alone, so a state's q̈
    does not depend on the batch around it; it agrees with the one-state call's to rounding
    (tests/batch/test_lanes.py)."""
    N, nb, nq, nv = Q.shape[0], I.shape[1], Q.shape[1], V.shape[1]
    if not on_lanes(unpack(I, F), nq, True):
        raise ValueError("the ABA's steps take a model in z-aligned frames (Model.kernel.lane_arrays)")
    Im, Fm = I, F               # as given (read-only): the one-state steps' signature
    I, F = I.copy(), F.copy()   # the model for this call alone (as rnea_lanes)
    mdl = unpack(I, F)
    parent, L = mdl.parent, LANES
    even, odd = np.empty(nb * ARTICULATED * L), np.empty(nb * ARTICULATED * L)     # records by depth parity
    base = np.zeros(12 * L)                  # the base as a parent: v_0 = 0 (rows 0–5), a_0 = [−g; 0] (rows 6–11)
    for l in range(L):
        base[6 * L + l], base[7 * L + l], base[8 * L + l] = mdl.mg[0], mdl.mg[1], mdl.mg[2]
    Z, QDD = np.empty((nq + 2 * nv) * L), np.empty(nv * L)   # q, q̇, τ and q̈ of the block, state index last
    depth, dmin = tree_depth(parent), singular_threshold(mdl.inertia, mdl.mass)
    slot, m = np.empty(nb, np.int64), 0                  # the multi-dof joints' records: slot[i] = their index
    for i in range(nb):
        slot[i], m = m, m + (mdl.nvj[i] > 1)
    G = np.empty(m * MULTI * L)
    W, path = np.empty(6 * L), np.empty(nb, np.int64)      # a wrench of the block, a body's path (external_lanes)
    for s0 in range(0, N, L):
        n = min(L, N - s0)
        ok = gather_lanes(Q, s0, n, Z, 0, SINCOS_MAX) & gather_lanes(V, s0, n, Z, nq) \
            & gather_lanes(Tau, s0, n, Z, nq + nv)
        if ok:
            for i in range(nb):                                          # pass 1 (outward)
                j = parent[i]
                par = base[:6 * L] if j < 0 else lane_record(even, odd, depth, j, ARTICULATED)[_V * L:(_V + 6) * L]
                B = lane_record(even, odd, depth, i, ARTICULATED)
                if mdl.nvj[i] > 1:                                       # a free flyer or a ball joint
                    velocity_multi_lanes(i, mdl, B, par, Z, nq)
                else:
                    velocity_lanes(i, mdl, B, par, Z, nq)
            if body.shape[0] > 0:                                        # external wrenches: p^A_b −= f^x_b
                external_lanes(parent, even, odd, depth, ARTICULATED, _PA, X, s0, n, body, point, world, W, path)
            singular = 0
            for i in range(nb - 1, -1, -1):                              # pass 2 (inward)
                j = parent[i]
                B = lane_record(even, odd, depth, i, ARTICULATED)
                if mdl.nvj[i] > 1:
                    singular += articulated_multi_lanes(i, mdl, dmin, B, G[slot[i] * MULTI * L:(slot[i] + 1) * MULTI * L],
                                                        Z, j >= 0, nq)
                else:
                    singular += articulated_lanes(i, mdl, dmin, B, Z, j >= 0, nq)
                if j >= 0:
                    inertia_up_lanes(B, lane_record(even, odd, depth, j, ARTICULATED))
            ok = singular == 0
        if ok:
            for i in range(nb):                                          # pass 3 (outward)
                j = parent[i]
                par = base[6 * L:] if j < 0 else lane_record(even, odd, depth, j, ARTICULATED)[_A * L:(_A + 6) * L]
                B = lane_record(even, odd, depth, i, ARTICULATED)
                if mdl.nvj[i] > 1:
                    acceleration_multi_lanes(i, mdl, B, G[slot[i] * MULTI * L:(slot[i] + 1) * MULTI * L], par, QDD)
                else:
                    acceleration_lanes(i, mdl, B, par, QDD, nq)
            ok = scatter_lanes(QDD, n, out, s0)
        if not ok:                                  # each state as a one-state call computes it: its code
            for s in range(s0, s0 + n):             # names the culprit
                code = aba_steps_one(Im, Fm, Q[s], V[s], Tau[s], X[s if X.shape[0] > 1 else 0], body, point, world,
                                     out[s])
                if code != OK:
                    return shift(code, s, nb, nv)
    return OK


@njit(cache=True, inline="always")
def rigid_model(i, mdl):
    """I_i = [[m 1, −m [c]×], [m [c]×, I_C − m [c]×²]] (``spatial.rigid_inertia``) as the lane record stores I^A: the
    blocks C (xx, yy, zz, xy, xz, yz), B = m [c]× (its rows), A (as C)."""
    m, cm, J = mdl.mass[i], (mdl.com[i, 0], mdl.com[i, 1], mdl.com[i, 2]), mdl.inertia
    mc, cc = scale(m, cm), cm[0] * cm[0] + cm[1] * cm[1] + cm[2] * cm[2]
    A = (J[i, 0, 0] + m * (cc - cm[0] * cm[0]), J[i, 1, 1] + m * (cc - cm[1] * cm[1]),
         J[i, 2, 2] + m * (cc - cm[2] * cm[2]), J[i, 0, 1] - m * cm[0] * cm[1], J[i, 0, 2] - m * cm[0] * cm[2],
         J[i, 1, 2] - m * cm[1] * cm[2])
    return (m, m, m, 0.0, 0.0, 0.0), ((0.0, -mc[2], mc[1]), (mc[2], 0.0, -mc[0]), (-mc[1], mc[0], 0.0)), A


@njit(cache=True, fastmath=CONTRACT)
def velocity_lanes(i, mdl, B, par, Z, nq):
    """Pass 1 for body i, every lane of the block (pass 1): placement, then
    ``velocity_lane``, then ``bias_lane``."""
    placement_lanes(i, mdl, B, Z)
    mm, rm, im = motion_model(i, mdl, nq), rigid_model(i, mdl), inertial_model(i, mdl)
    for l in range(LANES):
        velocity_lane(mm, B, par, Z, l, LANES)
    for l in range(LANES):
        bias_lane(rm, im, B, l, LANES)


@njit(cache=True, fastmath=CONTRACT)
def velocity_multi_lanes(i, mdl, B, par, Z, nq):
    """``velocity_lanes`` for a free flyer or a ball joint: its quaternion placement, ``velocity_multi_lane``, then
    ``bias_lane`` (a function of its own, as rnea.outward_multi_lanes)."""
    quat_placement_lanes(i, mdl, B, Z)
    mm, rm, im = multi_model(i, mdl, nq), rigid_model(i, mdl), inertial_model(i, mdl)
    for l in range(LANES):
        velocity_multi_lane(mm, B, par, Z, l, LANES)
    for l in range(LANES):
        bias_lane(rm, im, B, l, LANES)


@njit(cache=True, inline="always")
def velocity_lane(mm, B, par, Z, l, L):
    """At lane l: v_i = ⁱX_λ v_λ + v_J (v_J = s q̇; par: v_λ), c_i = v_i × v_J (mm: ``rnea.motion_model``)."""
    _, sl, sa, rv, _, _ = mm
    R, p, w = get_rotation(B, l, L), get3(B, 9, l, L), get3(par, 3, l, L)
    vl, va = motion_down(R, p, get3(par, 0, l, L), w)                              # ⁱX_λ v_λ
    qd = Z[rv * L + l]
    jl, ja = scale(qd, sl), scale(qd, sa)                                           # v_J = s q̇
    v = (vl[0] + jl[0], vl[1] + jl[1], vl[2] + jl[2], va[0] + ja[0], va[1] + ja[1], va[2] + ja[2])
    c = motion_cross(v, (jl[0], jl[1], jl[2], ja[0], ja[1], ja[2]))
    set6(B, _V, l, L, v)
    set6(B, _C, l, L, c)


@njit(cache=True, inline="always")
def velocity_multi_lane(mm, B, par, Z, l, L):
    """``velocity_lane`` for a free flyer or a ball joint: v_J = S q̇ (``lanes.multi_rates``; mm: ``lanes.multi_model``)."""
    R, p, w = get_rotation(B, l, L), get3(B, 9, l, L), get3(par, 3, l, L)
    vl, va = motion_down(R, p, get3(par, 0, l, L), w)                              # ⁱX_λ v_λ
    jl, ja = multi_rates(mm, Z, mm[3], l, L)
    v = (vl[0] + jl[0], vl[1] + jl[1], vl[2] + jl[2], va[0] + ja[0], va[1] + ja[1], va[2] + ja[2])
    set6(B, _V, l, L, v)
    set6(B, _C, l, L, motion_cross(v, (jl[0], jl[1], jl[2], ja[0], ja[1], ja[2])))


@njit(cache=True, inline="always")
def bias_lane(rm, im, B, l, L):
    """At lane l: I^A_i = I_i (rm: ``rigid_model``), p^A_i = v_i ×* I_i v_i (``spatial.inertia_motion``; im:
    ``rnea.inertial_model``)."""
    C, Bm, A = rm
    set6(B, _IA, l, L, C)
    set3(B, _IB, l, L, Bm[0])
    set3(B, _IB + 3, l, L, Bm[1])
    set3(B, _IB + 6, l, L, Bm[2])
    set6(B, _IAA, l, L, A)
    m, cm, J = im
    v = get6(B, _V, l, L)
    set6(B, _PA, l, L, force_cross(v, inertia_motion(m, cm, J, (v[0], v[1], v[2]), (v[3], v[4], v[5]))))


@njit(cache=True, inline="always")
def articulated_model(i, mdl, nq):
    """What body i's pass 2 and 3 take from the model: (its row r of S, s as a 6-tuple, the row of τ_r in the block's
    Z — q, q̇, τ stacked —, the armature of velocity r)."""
    S, r = mdl.S, mdl.iv[i]
    return r, (S[r, 0], S[r, 1], S[r, 2], S[r, 3], S[r, 4], S[r, 5]), nq + S.shape[0] + r, mdl.armature[r]


@njit(cache=True, fastmath=CONTRACT, error_model="numpy")      # (x / 0 is ±inf, not a raise: a branch less)
def articulated_lanes(i, mdl, dmin, B, Z, child, nq):
    """Pass 2 for body i, every lane of the block (one velocity):
    ``articulated_lane``, and for a child of a body (``child``) ``handed_lane``. Returns the number of lanes whose
    D_i is not > dmin (singular, or NaN)."""
    am = articulated_model(i, mdl, nq)
    singular = 0
    for l in range(LANES):
        singular += articulated_lane(am, dmin, B, Z, l, LANES)
    if child:
        for l in range(LANES):
            handed_lane(B, l, LANES)
    return singular


@njit(cache=True, inline="always")
def articulated_lane(am, dmin, B, Z, l, L):
    """At lane l: U_i = I^A_i s, D_i = sᵀ U_i + armature_i, u_i = τ_i − sᵀ p^A_i (am: ``articulated_model``). Returns
    1 if D_i is not > dmin (singular, or NaN), else 0."""
    r, s, rt, ar = am
    C, Bm, A = get_sym3(B, _IA, l, L), (get3(B, _IB, l, L), get3(B, _IB + 3, l, L), get3(B, _IB + 6, l, L)), \
        get_sym3(B, _IAA, l, L)
    sl, sa = (s[0], s[1], s[2]), (s[3], s[4], s[5])
    Ul, Ua = add(mul3(C, sl), mul3t(Bm, sa)), add(mul3(Bm, sl), mul3(A, sa))     # U = I^A s
    pA = get6(B, _PA, l, L)
    D = s[0] * Ul[0] + s[1] * Ul[1] + s[2] * Ul[2] + s[3] * Ua[0] + s[4] * Ua[1] + s[5] * Ua[2] + ar   # + armature
    u = Z[rt * L + l] - (s[0] * pA[0] + s[1] * pA[1] + s[2] * pA[2] + s[3] * pA[3] + s[4] * pA[4]
                                   + s[5] * pA[5])
    set3(B, _U, l, L, Ul)
    set3(B, _U + 3, l, L, Ua)
    B[_D * L + l], B[(_D + 1) * L + l] = D, u
    return 0 if D > dmin else 1


# -- a free flyer or a ball joint: n velocities, S = [0; 1_n] (the last n rows of a spatial vector, o = 6 − n) --------
# Its record (MULTI rows of L numbers): the Cholesky factor 𝓛 of D_i = Sᵀ I^A_i S + diag(armature) (21 rows, packed
# lower triangle: row r, column c at r(r+1)/2 + c), Y = 𝓛⁻¹ U_iᵀ (6 rows per velocity), t = 𝓛⁻¹ u_i (6 rows); as the
# one-dof steps, with D a matrix (U D⁻¹ Uᵀ = Yᵀ Y, U D⁻¹ u = Yᵀ t, q̈ = 𝓛⁻ᵀ (t − Y a')): ``articulated_multi``,
# ``handed_multi``, ``acceleration_multi``.
MULTI = 63
_Y, _T = 21, 57                     # first rows of Y and t


@njit(cache=True, inline="always")
def tri(r, c):
    """Row of entry (r, c), c ≤ r, of a packed lower triangle."""
    return r * (r + 1) // 2 + c


@njit(cache=True, inline="always")
def inertia_row(a, b):
    """The record row that holds I^A's entry (a, b), a ≥ b, of [[C, Bᵀ], [B, A]] (C, A: lanes.get_sym3's order)."""
    if b >= 3:
        return _IAA + (a - 3 if a == b else a - 3 + b - 3 + 2)
    if a >= 3:
        return _IB + 3 * (a - 3) + b
    return _IA + (a if a == b else a + b + 2)


@njit(cache=True, fastmath=CONTRACT, error_model="numpy")
def articulated_multi_lanes(i, mdl, dmin, B, G, Z, child, nq):
    """Pass 2 for a free flyer or a ball joint (n velocities), every lane of the block: ``articulated_multi``, and
    for a child of a body (``child``) ``handed_multi``. Returns the number of pivots of D_i not > dmin (singular,
    or NaN) over the lanes."""
    n, r = mdl.nvj[i], mdl.iv[i]
    rt, ar = nq + mdl.S.shape[0] + r, mdl.armature[r:r + n]
    if n == 6:                            # the trip counts known to the compiler
        singular = articulated_multi(6, ar, rt, dmin, B, G, Z, 0, LANES, LANES, False)
        if child:
            handed_multi(6, B, G, 0, LANES, LANES)
    else:
        singular = articulated_multi(3, ar, rt, dmin, B, G, Z, 0, LANES, LANES, mdl.kind[i] == PLANAR)
        if child:
            handed_multi(3, B, G, 0, LANES, LANES)
    return singular


# The multi-dof steps work on lanes l0 … l1 − 1 (the CPU: a block, 0 … LANES − 1; a GPU thread: its own lane), with
# the loops over the joint's velocities outside and the loop over the lanes inside each operation — the order in
# which the compiler vectorises them (a per-lane Cholesky inside the lane loop stayed scalar).

@njit(cache=True, inline="always")
def articulated_multi(n, ar, rt, dmin, B, G, Z, l0, l1, L, planar):
    """D = Sᵀ I^A S + diag(armature) = 𝓛 𝓛ᵀ (Cholesky), Y = 𝓛⁻¹ U_iᵀ with U_i = I^A S (the columns of I^A that S
    selects: ``selected``), t = 𝓛⁻¹ u, u = τ − Sᵀ p^A (τ from Z's rows rt …), into G's rows. Returns the number of
    pivots not > dmin."""
    bad = 0
    for r in range(n):                                      # 𝓛, entry by entry
        for c in range(r + 1):
            e, src, a = tri(r, c), inertia_row(selected(n, planar, r), selected(n, planar, c)), ar[r] if r == c else 0.0
            for l in range(l0, l1):
                G[e * L + l] = B[src * L + l] + a
            for k in range(c):
                e1, e2 = tri(r, k), tri(c, k)
                for l in range(l0, l1):
                    G[e * L + l] -= G[e1 * L + l] * G[e2 * L + l]
            if r == c:
                for l in range(l0, l1):
                    x = G[e * L + l]
                    bad += 0 if x > dmin else 1
                    G[e * L + l] = math.sqrt(x)     # (math: numba-cuda has no np.sqrt)
            else:
                d = tri(c, c)
                for l in range(l0, l1):
                    G[e * L + l] /= G[d * L + l]
    for r in range(n):                                      # [Y | t] = 𝓛⁻¹ [Uᵀ | u], forward substitution
        d = tri(r, r)
        for k in range(6):
            x = selected(n, planar, r)
            y, src = _Y + 6 * r + k, inertia_row(max(x, k), min(x, k))
            for l in range(l0, l1):
                G[y * L + l] = B[src * L + l]
            for c in range(r):
                e, yc = tri(r, c), _Y + 6 * c + k
                for l in range(l0, l1):
                    G[y * L + l] -= G[e * L + l] * G[yc * L + l]
            for l in range(l0, l1):
                G[y * L + l] /= G[d * L + l]
        t = _T + r
        for l in range(l0, l1):
            G[t * L + l] = Z[(rt + r) * L + l] - B[(_PA + selected(n, planar, r)) * L + l]
        for c in range(r):
            e, tc = tri(r, c), _T + c
            for l in range(l0, l1):
                G[t * L + l] -= G[e * L + l] * G[tc * L + l]
        for l in range(l0, l1):
            G[t * L + l] /= G[d * L + l]
    return bad


@njit(cache=True, inline="always")
def handed_multi(n, B, G, l0, l1, L):
    """In place: Iᵃ = I^A − Yᵀ Y and pᵃ = p^A + Iᵃ c + Yᵀ t (``handed_lane`` for n velocities)."""
    for a in range(6):
        for b in range(a + 1):
            row = inertia_row(a, b)
            for r in range(n):
                ya, yb = _Y + 6 * r + a, _Y + 6 * r + b
                for l in range(l0, l1):
                    B[row * L + l] -= G[ya * L + l] * G[yb * L + l]
    for a in range(6):
        pa = _PA + a
        for b in range(6):
            row, cb = inertia_row(max(a, b), min(a, b)), _C + b
            for l in range(l0, l1):
                B[pa * L + l] += B[row * L + l] * B[cb * L + l]
        for r in range(n):
            ya, t = _Y + 6 * r + a, _T + r
            for l in range(l0, l1):
                B[pa * L + l] += G[ya * L + l] * G[t * L + l]


@njit(cache=True, fastmath=CONTRACT, error_model="numpy")
def acceleration_multi_lanes(i, mdl, B, G, par, QDD):
    """Pass 3 for a free flyer or a ball joint, every lane of the block: ``acceleration_multi``."""
    n, r = mdl.nvj[i], mdl.iv[i]
    if n == 6:
        acceleration_multi(6, r, B, G, par, QDD, 0, LANES, LANES, False)
    else:
        acceleration_multi(3, r, B, G, par, QDD, 0, LANES, LANES, mdl.kind[i] == PLANAR)


@njit(cache=True, inline="always")
def acceleration_multi(n, r0, B, G, par, QDD, l0, l1, L, planar):
    """a' = ⁱX_λ a_λ + c_i, q̈ = 𝓛⁻ᵀ (t − Y a') (D q̈ = u − U_iᵀ a') into rows r0 … of QDD, a_i = a' + S q̈."""
    for l in range(l0, l1):
        R, p, w = get_rotation(B, l, L), get3(B, 9, l, L), get3(par, 3, l, L)
        al, aa = motion_down(R, p, get3(par, 0, l, L), w)                          # ⁱX_λ a_λ
        c = get6(B, _C, l, L)
        set6(B, _A, l, L, (al[0] + c[0], al[1] + c[1], al[2] + c[2], aa[0] + c[3], aa[1] + c[4], aa[2] + c[5]))
    for r in range(n):                                      # y = t − Y a' (into t's rows)
        t = _T + r
        for k in range(6):
            y, a = _Y + 6 * r + k, _A + k
            for l in range(l0, l1):
                G[t * L + l] -= G[y * L + l] * B[a * L + l]
    for r in range(n - 1, -1, -1):                          # 𝓛ᵀ q̈ = y, back substitution
        q, t = r0 + r, _T + r
        for l in range(l0, l1):
            QDD[q * L + l] = G[t * L + l]
        for c in range(r + 1, n):
            e, qc = tri(c, r), r0 + c
            for l in range(l0, l1):
                QDD[q * L + l] -= G[e * L + l] * QDD[qc * L + l]
        d = tri(r, r)
        for l in range(l0, l1):
            QDD[q * L + l] /= G[d * L + l]
    for r in range(n):                                      # a_i = a' + S q̈
        a, q = _A + selected(n, planar, r), r0 + r
        for l in range(l0, l1):
            B[a * L + l] += QDD[q * L + l]


@njit(cache=True, inline="always")
def handed_lane(B, l, L):
    """At lane l, in place: Iᵃ = I^A_i − U (Uᵀ/D) and pᵃ = p^A_i + Iᵃ c_i + U u/D, what body i hands its parent.
    The scalar D is used as it is: through Y = U / √D the subtraction Iᵃ = I^A − Y Yᵀ, which cancels heavily on
    ill-conditioned chains, lost ~10× in q̈ (median relative error 6e-15 against 4e-16 on a uniform 6-link planar
    chain, 50-digit reference; bench report, hard cases)."""
    U, D, u = get6(B, _U, l, L), B[_D * L + l], B[(_D + 1) * L + l]
    W, ud = (U[0] / D, U[1] / D, U[2] / D, U[3] / D, U[4] / D, U[5] / D), u / D
    for k in range(3):                                      # C −= U_l W_lᵀ, A −= U_a W_aᵀ (xx, yy, zz, xy, xz, yz)
        B[(_IA + k) * L + l] -= U[k] * W[k]
        B[(_IAA + k) * L + l] -= U[3 + k] * W[3 + k]
    B[(_IA + 3) * L + l] -= U[1] * W[0]
    B[(_IA + 4) * L + l] -= U[2] * W[0]
    B[(_IA + 5) * L + l] -= U[2] * W[1]
    B[(_IAA + 3) * L + l] -= U[4] * W[3]
    B[(_IAA + 4) * L + l] -= U[5] * W[3]
    B[(_IAA + 5) * L + l] -= U[5] * W[4]
    for a in range(3):
        for b in range(3):                                                        # B −= U_a W_lᵀ
            B[(_IB + 3 * a + b) * L + l] -= U[3 + a] * W[b]
    C, Bm, A = get_sym3(B, _IA, l, L), (get3(B, _IB, l, L), get3(B, _IB + 3, l, L), get3(B, _IB + 6, l, L)), \
        get_sym3(B, _IAA, l, L)
    c = get6(B, _C, l, L)
    cl, ca = (c[0], c[1], c[2]), (c[3], c[4], c[5])
    fl, fa = add(mul3(C, cl), mul3t(Bm, ca)), add(mul3(Bm, cl), mul3(A, ca))      # Iᵃ c
    for k in range(3):
        B[(_PA + k) * L + l] += fl[k] + U[k] * ud
        B[(_PA + 3 + k) * L + l] += fa[k] + U[3 + k] * ud


@njit(cache=True, fastmath=CONTRACT)
def inertia_up_lanes(B, P):
    """``inertia_up_lane`` then ``bias_up_lane`` for every lane of the block."""
    for l in range(LANES):
        inertia_up_lane(B, P, l, LANES)
    for l in range(LANES):
        bias_up_lane(B, P, l, LANES)


@njit(cache=True, inline="always")
def inertia_up_lane(B, P, l, L):
    """At lane l: the parent's I^A += ^λX*_i Iᵃ ⁱX_λ (``spatial.inertia_up``); B: body i's record, P: its parent's."""
    R, p = get_rotation(B, l, L), get3(B, 9, l, L)
    C, Bm, A = inertia_up(R, p, get_sym3(B, _IA, l, L),
                          (get3(B, _IB, l, L), get3(B, _IB + 3, l, L), get3(B, _IB + 6, l, L)), get_sym3(B, _IAA, l, L))
    add_sym3(P, _IA, l, L, C)
    add_sym3(P, _IAA, l, L, A)
    for a in range(3):
        for b in range(3):
            P[(_IB + 3 * a + b) * L + l] += Bm[a][b]


@njit(cache=True, inline="always")
def bias_up_lane(B, P, l, L):
    """At lane l: the parent's p^A += ^λX*_i pᵃ (``spatial.force_up``)."""
    pa = get6(B, _PA, l, L)
    F = force_up(get_rotation(B, l, L), get3(B, 9, l, L), pa[0], pa[1], pa[2], pa[3], pa[4], pa[5])
    for k in range(6):
        P[(_PA + k) * L + l] += F[k]


@njit(cache=True, fastmath=CONTRACT, error_model="numpy")
def acceleration_lanes(i, mdl, B, par, QDD, nq):
    """Pass 3 for body i, every lane of the block: ``acceleration_lane``."""
    am = articulated_model(i, mdl, nq)
    for l in range(LANES):
        acceleration_lane(am, B, par, QDD, l, LANES)


@njit(cache=True, inline="always")
def acceleration_lane(am, B, par, QDD, l, L):
    """At lane l (pass 3): a'_i = ⁱX_λ a_λ + c_i (par: a_λ), q̈_i = (u_i − U_iᵀ a'_i) / D_i into
    row iv_i of QDD, a_i = a'_i + s q̈_i (am: ``articulated_model``)."""
    r, s, _, _ = am
    R, p, w = get_rotation(B, l, L), get3(B, 9, l, L), get3(par, 3, l, L)
    al, aa = motion_down(R, p, get3(par, 0, l, L), w)                              # ⁱX_λ a_λ
    c, U = get6(B, _C, l, L), get6(B, _U, l, L)
    a = (al[0] + c[0], al[1] + c[1], al[2] + c[2], aa[0] + c[3], aa[1] + c[4], aa[2] + c[5])
    qdd = (B[(_D + 1) * L + l] - (U[0] * a[0] + U[1] * a[1] + U[2] * a[2] + U[3] * a[3] + U[4] * a[4]
                                  + U[5] * a[5])) / B[_D * L + l]
    QDD[r * L + l] = qdd
    set6(B, _A, l, L, (a[0] + s[0] * qdd, a[1] + s[1] * qdd, a[2] + s[2] * qdd, a[3] + s[3] * qdd, a[4] + s[4] * qdd,
                       a[5] + s[5] * qdd))


@njit(cache=True)
def aba_one(I, F, q, v, tau, out):
    """One state (nq,), (nv,) without external wrenches: ``aba_steps_one`` ((I, F) in z-aligned frames,
    ``Model.kernel.lane_arrays``)."""
    if not sized(I, q, (v, tau, out)):
        return WRONG_SIZES
    X, xb, xp, world = no_wrenches(I, F)
    return aba_steps_one(I, F, q, v, tau, X[0], xb, xp, world, out)


@njit(cache=True)
def aba_fext_one(I, F, q, v, tau, f, m, P, world, out):
    """One state with one external wrench in ``arguments.fast_wrenches``' form (the wrench in z-aligned frames, as
    (I, F)): ``aba_steps_one``."""
    if not (sized(I, q, (v, tau, out)) and f.shape[0] == 3 and m.shape[0] == 3 and P.shape[0] == 13):
        return WRONG_SIZES
    X, xb, xp = wrench_rows_of(f, m, P)
    return aba_steps_one(I, F, q, v, tau, X[0], xb, xp, world, out)


@njit(cache=True, fastmath=CONTRACT, error_model="numpy")
def aba_steps_one(I, F, q, v, tau, X, xb, xp, world, out):
    """q̈ (nv,) of one state by the steps of the lane kernel (``aba_lanes``), driven for one lane: records of one
    number a row (L = 1), the same velocity, bias, articulated-inertia, hand-off and acceleration steps (a free
    flyer's, a ball's or a planar joint's multi-dof steps included), in the same z-aligned frames ((I, F) =
    ``Model.kernel.lane_arrays``: another form raises) — one source for a batch and for one state. A helical joint's
    slide and an angle beyond ``spatial.SINCOS_MAX`` are placed as the RNEA's and the CRBA's drivers place them
    (``lanes.screw_placement_one``). External wrenches X (K, 6) on bodies xb about their points xp, in the bodies'
    z-aligned axes or (world) in world axes, enter after pass 1: p^A_b −= f^x_b (Table 7.1; ``lanes.external_lane``;
    K = 0 for none: ``kernel_inputs.no_wrenches``). Returns its status (dynamics/status.py): a non-finite q, q̇ or
    τ; −2 − i for joint i whose D_i has a pivot not > dmin (``singular_threshold``: a massless moving subtree); −2 −
    nb − r for a non-finite q̈_r (an intermediate overflowed: a NaN pivot of D_i is reported in its first row)."""
    mdl = unpack(I, F)
    nb, nq, nv = I.shape[1], q.shape[0], v.shape[0]
    parent, nvj = mdl.parent, mdl.nvj
    if not on_lanes(mdl, nq, True):
        raise ValueError("the ABA's steps take a model in z-aligned frames (Model.kernel.lane_arrays)")
    if not finite_state(q[np.newaxis, :], v[np.newaxis, :], tau[np.newaxis, :], 0):
        return bad_input(0)
    m = 0
    for i in range(nb):
        m += nvj[i] > 1
    W = np.empty(nb * ARTICULATED + 12 + nq + 2 * nv + m * MULTI)   # records, the base, q q̇ τ, multi-dof
    Rec, base = W[:nb * ARTICULATED], W[nb * ARTICULATED:nb * ARTICULATED + 12]
    Z = W[nb * ARTICULATED + 12:nb * ARTICULATED + 12 + nq + 2 * nv]
    G = W[nb * ARTICULATED + 12 + nq + 2 * nv:]
    one_lane(q, v, tau, Z, base, mdl.mg)                            # a_0 = [−g; 0]
    dmin = singular_threshold(mdl.inertia, mdl.mass)
    for i in range(nb):                                             # pass 1 (outward)
        j, B = parent[i], Rec[i * ARTICULATED:(i + 1) * ARTICULATED]
        par = base[:6] if j < 0 else Rec[j * ARTICULATED + _V:j * ARTICULATED + _V + 6]
        if nvj[i] > 1:                                              # a free flyer, a ball, a planar joint
            if mdl.kind[i] == PLANAR:
                planar_placement_lane(placement_model(i, mdl), B, Z, 0, 1)
            else:
                quat_placement_lane(quat_model(i, mdl), B, Z, 0, 1)
            velocity_multi_lane(multi_model(i, mdl, nq), B, par, Z, 0, 1)
        else:
            screw_placement_one(i, mdl, B, Z)
            velocity_lane(motion_model(i, mdl, nq), B, par, Z, 0, 1)
        bias_lane(rigid_model(i, mdl), inertial_model(i, mdl), B, 0, 1)
    for k in range(xb.shape[0]):                                    # external wrenches: p^A_b −= f^x_b
        fe, ne = wrench_in_body(parent, Rec, ARTICULATED, X, k, xb[k], world)
        external_lane(Rec[xb[k] * ARTICULATED:(xb[k] + 1) * ARTICULATED], _PA, fe, ne, (xp[k, 0], xp[k, 1], xp[k, 2]),
                      0, 1)
    g = m
    for i in range(nb - 1, -1, -1):                                 # pass 2 (inward)
        j, B = parent[i], Rec[i * ARTICULATED:(i + 1) * ARTICULATED]
        n, r = nvj[i], mdl.iv[i]
        g -= n > 1                                                  # (records in body order: the last first)
        Gi = G[g * MULTI:(g + 1) * MULTI]
        if n > 1:
            bad = articulated_multi(n, mdl.armature[r:r + n], nq + nv + r, dmin, B, Gi, Z, 0, 1, 1,
                                    mdl.kind[i] == PLANAR)
        else:
            bad = articulated_lane(articulated_model(i, mdl, nq), dmin, B, Z, 0, 1)
        if bad:                                                     # singular, or NaN from an overflow in I^A
            for k in range(_IA, _PA):
                if not math.isfinite(B[k]):
                    out[r] = np.nan
                    return bad_result(nb, r)
            return singular_joint(i)
        if j >= 0:
            if n > 1:
                handed_multi(n, B, Gi, 0, 1, 1)
            else:
                handed_lane(B, 0, 1)
            P = Rec[j * ARTICULATED:(j + 1) * ARTICULATED]
            inertia_up_lane(B, P, 0, 1)
            bias_up_lane(B, P, 0, 1)
    for i in range(nb):                                             # pass 3 (outward)
        j, B = parent[i], Rec[i * ARTICULATED:(i + 1) * ARTICULATED]
        par = base[6:] if j < 0 else Rec[j * ARTICULATED + _A:j * ARTICULATED + _A + 6]
        if nvj[i] > 1:
            acceleration_multi(nvj[i], mdl.iv[i], B, G[g * MULTI:(g + 1) * MULTI], par, out, 0, 1, 1,
                               mdl.kind[i] == PLANAR)
            g += 1
        else:
            acceleration_lane(articulated_model(i, mdl, nq), B, par, out, 0, 1)
    k = first_nonfinite(out[np.newaxis, :], 0)                      # (an intermediate overflowed)
    return OK if k < 0 else bad_result(nb, k)


# -- the M⁻¹ route ----------------------------------------------------------------------------------------

@njit(cache=True)
def cholesky_kernel(I, F, Q, V, Tau, X, body, point, world, out):
    """``cholesky_states`` for a batch: the lane kernels for M and h, whatever N (a state's q̈ does not depend on
    the batch around it: a Dask chunk or a thread's share gives the numbers of the whole batch)."""
    return cholesky_states(I, F, Q, V, Tau, X, body, point, world, out, np.bool_(True))   # (run-time bools: one compiled cholesky_states)


@njit(cache=True, fastmath=CONTRACT)
def cholesky_states(I, F, Q, V, Tau, X, body, point, world, out, lanes):
    """q̈ = M⁻¹ (τ − h) for every state (the M⁻¹ route): M by the CRBA (crba.crba_lanes), factored in place,
    M = L Lᵀ; h = rnea(q, q̇, 0, f_ext) = C q̇ + g − Σ Jᵀ f_ext (rnea.rnea_lanes, wrenches included; X a row a
    state or one row for all) into scratch H (not out: one state's out may be its τ, ``route``), then
    out ← L⁻ᵀ L⁻¹ (τ − h). A chunk of LANES states at a time (with
    ``lanes``, the lane kernels' block: M and h across states; N = 1000, one thread: chain32 13.0 → 7.7 µs a state,
    AAU arm 1.25 → 0.43 µs), so that their M (scratch) stay in cache; without (one state, N = 1: a block of lanes
    costs LANES states) the one-lane drivers of the same steps (``crba.crba_steps_one``, ``rnea.rnea_steps_one``).
    (I, F) in z-aligned frames (``Model.kernel.lane_arrays``), the wrenches in them as ``aba_lanes``'s. Returns its status (dynamics/status.py): -2 - i a
    pivot of M not > 0 in joint i's rows (M is not positive definite); -2 - nb - k a non-finite q̈ at flat index k."""
    N, nv, nb = Q.shape[0], V.shape[1], I.shape[1]
    C = max(1, min(N, LANES))                                 # states per chunk: one block of the lane kernels
    M, Z = np.empty((C, nv, nv)), np.zeros((C, nv))
    H = np.empty((C, nv))                                     # h of the chunk's states
    for s in range(N):
        if first_nonfinite(Tau, s) >= 0:
            return bad_input(s)
    for s0 in range(0, N, C):
        s1 = min(N, s0 + C)
        n = s1 - s0
        code = crba_lanes(I, F, Q[s0:s1], M[:n, :, :]) if lanes else crba_steps_one(I, F, Q[s0], M[0][:, :])
        if code <= -2 - nb:                                   # a non-finite M: reported in its state's q̈
            s = s0 + (-2 - nb - code) // (nv * nv)
            out[s, 0] = np.nan
            return bad_result(nb, s * nv)
        if code == -1 and not lanes:                          # h (views: the one-state entry's layout)
            code = rnea_steps_one(I, F, Q[s0], V[s0], Z[0][::1], X[s0 if X.shape[0] > 1 else 0], body, point, world,
                                  H[0][::1], steps_scratch(nb, Q.shape[1], nv))
        elif code == -1:                                      # (X: a row a state, or one row for every state)
            code = rnea_lanes(I, F, Q[s0:s1], V[s0:s1], Z[:n, :], X[s0:s1] if X.shape[0] > 1 else X, body, point,
                              world, H[:n, :])
        if code != -1:                                        # a non-finite input, or h: in out, where the
            out[s0:s1, :] = H[:n, :]                          # error reads the entry at fault
            return shift(code, s0, nb, nv)
        for s in range(s0, s1):
            L = M[s - s0]
            for r in range(nv):                               # τ − h
                out[s, r] = Tau[s, r] - H[s - s0, r]
            k = cholesky(L, nv, 0.0)
            if k >= 0:
                if not np.isfinite(L[k, k]):
                    return bad_result(nb, s * nv + k)
                return singular_row(I, k)                     # the joint whose row lost its pivot
            cholesky_solve(L, nv, out[s])
            k = first_nonfinite(out, s)
            if k >= 0:
                return bad_result(nb, s * nv + k)
    return OK


@njit(cache=True)
def cholesky_one(I, F, q, v, tau, out):
    """One state without external wrenches: cholesky_states with N = 1, by the one-lane drivers ((I, F) in z-aligned
    frames, ``Model.kernel.lane_arrays``)."""
    if not sized(I, q, (v, tau, out)):
        return WRONG_SIZES
    X, xb, xp, world = no_wrenches(I, F)
    return cholesky_states(I, F, q[np.newaxis, :], v[np.newaxis, :], tau[np.newaxis, :], X, xb, xp, world,
                           out[np.newaxis, :], np.bool_(False))


@njit(cache=True)
def cholesky_fext_one(I, F, q, v, tau, f, m, P, world, out):
    """One state with one external wrench in ``arguments.fast_wrenches``' form: cholesky_states with N = 1, (I, F) and
    the wrench in z-aligned frames (M by ``crba.crba_steps_one``; h by ``rnea.rnea_steps_one``)."""
    X, xb, xp = wrench_rows_of(f, m, P)
    return cholesky_states(I, F, q[np.newaxis, :], v[np.newaxis, :], tau[np.newaxis, :], X, xb, xp, world,
                           out[np.newaxis, :], np.bool_(False))


# -- the public calls: each is its route (dynamics/route.py) ---------------------------------------------------

_QVT, _FD = ("q", "v", "tau"), (*MODEL, A2, A2, A2, A3, I1, A2, FLAG, A2)      # (the batch kernels' types)
_ONE, _FEXT_ONE = (*MODEL, A1, A1, A1, A1), (*MODEL, A1, A1, A1, A1, A1, A1, FLAG, A1)


ABA = entry(aba_lanes, *_FD)          # the batch entry (also the derivatives' q̈: derivatives.py)


@route("aba", _QVT, "q̈", "v", entry(aba_one, *_ONE), ABA, wrenches=True,
       lanes=True, one_lanes=True, wrench_one=entry(aba_fext_one, *_FEXT_ONE), mimic=lambda mm, *x, **kw: mimic.forward_dynamics(mm, rnea, crba, *x, **kw))
def aba(model, q, v, tau, *, f_ext=None, f_ext_frame="local", threads=None, out=None):
    """q̈ (nv,) or (N, nv) by the articulated-body algorithm (RBDA Table 7.1).

    Parameters
    ----------
    q : (nq,) or (N, nq) configuration; v, tau : (nv,) or (N, nv) velocities and generalized forces (a free
        flyer's: [linear; angular] in the body frame, as Pinocchio's).
    f_ext : {link or frame name: (force (3,)|(N, 3), moment (3,)|(N, 3))}, the wrench the environment applies
        on that body about the frame's origin, in the frame's axes (f_ext_frame="local") or the world's.
    threads : a batch's threads (``rnea``'s).
    out : (nv,) or (N, nv) float64 array to write q̈ into (``rnea``'s).
    Returns
    -------
    qdd : (nv,) or (N, nv) (``out`` when given).

    Raises SingularError naming the joint whose articulated inertia D_i = S_iᵀ I^A_i S_i is singular (a
    moving subtree without mass or inertia: M is singular there).
    """


@route("forward_dynamics", _QVT, "q̈", "v", entry(cholesky_one, *_ONE), entry(cholesky_kernel, *_FD), wrenches=True,
       lanes=True, one_lanes=True, wrench_one=entry(cholesky_fext_one, *_FEXT_ONE),
       mimic=lambda mm, *x, **kw: mimic.forward_dynamics(mm, rnea, crba, *x, **kw))
def cholesky_route(model, q, v, tau, *, f_ext=None, f_ext_frame="local", threads=None, out=None):
    """q̈ (nv,) or (N, nv) by the M⁻¹ route (``cholesky_kernel``): ``forward_dynamics(..., method="cholesky")``.
    threads, out: ``rnea``'s."""


def passive_torques(model, v):
    """damping ⊙ q̇ + friction ⊙ tanh(q̇ / ε) (nv,) or (N, nv), the torques a joint's own losses take from the drive
    (``model.damping``, ``model.friction``; ε = ``model.FRICTION_EPS`` = 1e-3 rad/s: Coulomb friction regularised,
    within 1 − tanh(5) = 9e-5 of ±friction beyond |q̇| = 5 ε, and no stiction: at q̇ = 0 it is 0, so a joint
    below the friction level creeps at ~ε·τ/friction instead of sticking). A MimicModel: Gᵀ of the full model's at
    G q̇. None when the model has no damping or friction, or v is not an array of velocities (the caller's checks
    then name it)."""
    full = model.full if type(model) is MimicModel else model
    if not full.passive:
        return None
    try:
        V = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        return None
    if V.ndim not in (1, 2) or V.shape[-1] != model.nv:
        return None
    if type(model) is MimicModel:
        Vf = V @ model.G.T
        return (full.damping * Vf + full.friction * np.tanh(Vf / FRICTION_EPS)) @ model.G
    return full.damping * V + full.friction * np.tanh(V / FRICTION_EPS)


def forward_dynamics(model, q, v, tau, *, f_ext=None, f_ext_frame="local", method="aba", threads=None,
                     joint_dynamics=True, out=None):
    """q̈ by ``method``: "aba" (articulated bodies) or "cholesky" (M⁻¹ route: Cholesky of the CRBA mass
    matrix, right-hand side τ − rnea(q, q̇, 0, f_ext) = τ − C q̇ − g + Σ Jᵀ f_ext). threads: a batch's threads;
    out: an array to write q̈ into (both ``rnea``'s).

    Joint dynamics (docs/design.md §3): M includes diag(model.armature) always (as ``aba`` and ``crba``); with
    joint_dynamics=True (default) the joints' damping and Coulomb friction act too, q̈ = aba(q, q̇, τ_joint) with
    τ_joint = τ − damping ⊙ q̇ − friction ⊙ tanh(q̇ / ε) (``passive_torques``); joint_dynamics=False gives the
    rigid bodies' q̈ = aba(q, q̇, τ) (Pinocchio's aba with armature).
    """
    if joint_dynamics:
        loss = passive_torques(model, v)
        if loss is not None:
            try:
                tau = np.asarray(tau, dtype=float) - loss
            except (TypeError, ValueError):
                pass                                     # (the route names a bad τ)
    if isinstance(method, str) and method == "aba":
        return aba(model, q, v, tau, f_ext=f_ext, f_ext_frame=f_ext_frame, threads=threads, out=out)
    if not (isinstance(method, str) and method == "cholesky"):          # (an array compares elementwise)
        raise InputError(f"forward_dynamics method must be 'aba' or 'cholesky', not {method!r}")
    return cholesky_route(model, q, v, tau, f_ext=f_ext, f_ext_frame=f_ext_frame, threads=threads, out=out)
