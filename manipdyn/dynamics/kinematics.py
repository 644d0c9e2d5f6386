"""Frame placements, geometric Jacobians and their time derivatives, for any tree and joint type — read
off the one forward kinematics (forward_kinematics.fk_pass), compiled.

Jacobian rows are [linear; angular] as in Pinocchio. Two references:
- ``"local_world_aligned"`` (default): world-aligned axes at the frame's origin (Pinocchio's
  LOCAL_WORLD_ALIGNED): J q̇ = [ṗ; ω], the velocity of the frame's origin and its angular velocity, in
  world coordinates. (Pinocchio's WORLD — the twist of the body point at the world origin — is another
  thing; ``"world"`` is refused for that reason.)
- ``"local"``: the same twist in the frame's own axes (Pinocchio's LOCAL), J_l = diag(Rᵀ, Rᵀ) J.

Column of velocity r of joint j (Eqs. 29–30, for every joint type): the joint's motion subspace column
S_r = [s_l; s_a] (body j's frame, joints.motion_subspace) turned into the world, l = R_j s_l, a = R_j s_a,
moves a point x fixed to a body that joint j supports with  ẋ = l + a × (x − o_j),  ω = a
(o_j = body j's origin): revolute [z × (x − o_j); z], prismatic [z; 0], free flyer six columns. Zero for a
joint that does not support the body. J̇ is the exact time derivative along the motion (Pinocchio's
getFrameJacobianTimeVariation): S_r is constant in body j's frame, so ȧ = ω_j × a and l̇ = ω_j × l, and
    J̇ column = [l̇ + ȧ × (x − o_j) + a × (ẋ − ȯ_j); ȧ];   local: J̇_l = diag(Rᵀ, Rᵀ) J̇ − [ω']× J_l blockwise,
with ω' = Rᵀ ω the frame's angular velocity in its own axes (its axes turn with it).
"""
from __future__ import annotations

import numba
import numpy as np

from .._jit import A1, A2, A3, CONTRACT, MODEL, entry, njit
from ..errors import InputError
from ..model import Model
from ..spatial import (SINCOS_MAX, add, compose, cross, first_nonfinite, first_nonfinite_entry, mul3, mul3t, rotate6,
                       sandwich3, sub)
from .forward_kinematics import fk_pass, fk_path
from .kernel_inputs import nonfinite_input
from .lanes import (LANES, gather_lanes, get3, get_rotation, lane_record, on_lanes, placement_lanes,
                    quat_placement_lanes, set3, tree_depth)
from .model_arrays import kernel_arrays, unpack
from .arguments import as_batch, check_output, fast, frame_of, quiet, raise_kernel_error, unbatch
from .status import OK, bad_input, bad_result, shift

REFERENCES = ("local_world_aligned", "local")


# -- the columns, compiled (inlined into every kernel that needs a Jacobian) -------------------------------

@njit(cache=True, inline="always")
def point_jacobian(parent, iv, nvj, S, b, Rw, pw, x, J):
    """J (6, nv) = world-aligned Jacobian of the world point x (3,) fixed to body b (-1: the fixed base,
    J = 0): column r of every joint j supporting b is [l + a × (x − o_j); a], (l; a) = R_j S_r."""
    J[:, :] = 0.0
    j = b
    while j >= 0:
        dx, dy, dz = x[0] - pw[j, 0], x[1] - pw[j, 1], x[2] - pw[j, 2]
        for r in range(iv[j], iv[j] + nvj[j]):
            lx, ly, lz, ax, ay, az = rotate6(Rw[j], S[r])
            J[0, r] = lx + ay * dz - az * dy
            J[1, r] = ly + az * dx - ax * dz
            J[2, r] = lz + ax * dy - ay * dx
            J[3, r], J[4, r], J[5, r] = ax, ay, az
        j = parent[j]


@njit(cache=True, inline="always")
def point_jacobian_dot(parent, iv, nvj, S, b, Rw, pw, ww, vw, x, xd, dJ):
    """J̇ (6, nv) of point_jacobian along the motion: ω_j = ww[j], ȯ_j = vw[j] (world angular velocity of
    body j and velocity of its origin, forward_kinematics.fk_pass), ẋ = xd; column [l̇ + ȧ × (x − o_j) + a × (ẋ − ȯ_j); ȧ]
    with ȧ = ω_j × a, l̇ = ω_j × l."""
    dJ[:, :] = 0.0
    j = b
    while j >= 0:
        dx, dy, dz = x[0] - pw[j, 0], x[1] - pw[j, 1], x[2] - pw[j, 2]
        ux, uy, uz = xd[0] - vw[j, 0], xd[1] - vw[j, 1], xd[2] - vw[j, 2]      # ẋ − ȯ_j
        wx, wy, wz = ww[j, 0], ww[j, 1], ww[j, 2]
        for r in range(iv[j], iv[j] + nvj[j]):
            lx, ly, lz, ax, ay, az = rotate6(Rw[j], S[r])
            bx, by, bz = wy * az - wz * ay, wz * ax - wx * az, wx * ay - wy * ax   # ȧ = ω_j × a
            dJ[0, r] = wy * lz - wz * ly + by * dz - bz * dy + ay * uz - az * uy
            dJ[1, r] = wz * lx - wx * lz + bz * dx - bx * dz + az * ux - ax * uz
            dJ[2, r] = wx * ly - wy * lx + bx * dy - by * dx + ax * uy - ay * ux
            dJ[3, r], dJ[4, r], dJ[5, r] = bx, by, bz
        j = parent[j]


@njit(cache=True, inline="always")
def point_velocity(b, pw, ww, vw, x, xd):
    """xd = ẋ of the world point x fixed to body b: ȯ_b + ω_b × (x − o_b) (zero on the fixed base)."""
    if b < 0:
        xd[:] = 0.0
        return
    dx, dy, dz = x[0] - pw[b, 0], x[1] - pw[b, 1], x[2] - pw[b, 2]
    xd[0] = vw[b, 0] + ww[b, 1] * dz - ww[b, 2] * dy
    xd[1] = vw[b, 1] + ww[b, 2] * dx - ww[b, 0] * dz
    xd[2] = vw[b, 2] + ww[b, 0] * dy - ww[b, 1] * dx


@njit(cache=True, inline="always")
def body_point(b, Rw, pw, Rl, pl, R, p):
    """(R, p) = world placement of a frame (Rl, pl) given in body b's frame (b = -1: in the world)."""
    for a in range(3):
        for c in range(3):
            R[a, c] = Rl[a, c] if b < 0 else Rw[b, a, 0] * Rl[0, c] + Rw[b, a, 1] * Rl[1, c] + Rw[b, a, 2] * Rl[2, c]
        p[a] = pl[a] if b < 0 else pw[b, a] + Rw[b, a, 0] * pl[0] + Rw[b, a, 1] * pl[1] + Rw[b, a, 2] * pl[2]


@njit(cache=True, inline="always")
def _to_local(Rf, w, J, dJ, with_dot):
    """In place: J ← diag(Rᵀ, Rᵀ) J; J̇ ← diag(Rᵀ, Rᵀ) J̇ − [ω']× J_l blockwise, ω' = Rᵀ ω (w: the frame's
    world angular velocity)."""
    wl, t, u = np.empty(3), np.empty(6), np.empty(6)
    for k in range(3):
        wl[k] = Rf[0, k] * w[0] + Rf[1, k] * w[1] + Rf[2, k] * w[2]
    for r in range(J.shape[1]):
        for k in range(6):                                    # t = diag(Rᵀ, Rᵀ) J, u = diag(Rᵀ, Rᵀ) J̇
            o, c = k - k % 3, k % 3
            t[k] = Rf[0, c] * J[o, r] + Rf[1, c] * J[o + 1, r] + Rf[2, c] * J[o + 2, r]
            if with_dot:
                u[k] = Rf[0, c] * dJ[o, r] + Rf[1, c] * dJ[o + 1, r] + Rf[2, c] * dJ[o + 2, r]
        if with_dot:
            for o in (0, 3):                                  # − ω' × (each block of J_l)
                dJ[o, r] = u[o] - (wl[1] * t[o + 2] - wl[2] * t[o + 1])
                dJ[o + 1, r] = u[o + 1] - (wl[2] * t[o] - wl[0] * t[o + 2])
                dJ[o + 2, r] = u[o + 2] - (wl[0] * t[o + 1] - wl[1] * t[o])
        J[:3, r], J[3:, r] = t[:3], t[3:]


@njit(cache=True)
def frame_kernel(I, F, Q, V, b, Rl, pl, want, local, Rf, pf, J, dJ):
    """For every state of Q (N, nq) [and V (N, nv)]: the world placement Rf (N, 3, 3), pf (N, 3) of the frame
    (Rl, pl) on body b; want ≥ 1: its Jacobian J (N, 6, nv); want = 2: J̇ (N, 6, nv); local: in the frame's
    axes. Returns its status (dynamics/status.py)."""
    mdl = unpack(I, F)
    parent, iv, nvj, S = mdl.parent, mdl.iv, mdl.nvj, mdl.S
    N, nb = Q.shape[0], I.shape[1]
    # scratch as slices of two arrays, never as separate small arrays: measured 2.3x faster per state (0.28
    # against 0.65 µs on ur5; the same kernel text, only the allocations differ)
    R3, B3, path = np.empty((2 * nb, 3, 3)), np.zeros((4 * nb + 2, 3)), np.empty(nb, np.int64)
    Rp, Rw, pp, pw, ww, vw = R3[:nb], R3[nb:], B3[:nb], B3[nb:2 * nb], B3[2 * nb:3 * nb], B3[3 * nb:4 * nb]
    xd, w0 = B3[4 * nb], B3[4 * nb + 1]
    for s in range(N):
        bad = nonfinite_input(Q, V, s)
        if bad >= 0:
            return bad
        fk_path(mdl, Q[s], V[s], b, path, Rp, pp, Rw, pw, ww, vw)       # the frame's support only
        body_point(b, Rw, pw, Rl, pl, Rf[s], pf[s])
        if want >= 1:
            point_jacobian(parent, iv, nvj, S, b, Rw, pw, pf[s], J[s])
        if want == 2:
            point_velocity(b, pw, ww, vw, pf[s], xd)
            point_jacobian_dot(parent, iv, nvj, S, b, Rw, pw, ww, vw, pf[s], xd, dJ[s])
        if local and want >= 1:
            _to_local(Rf[s], ww[b] if b >= 0 else w0, J[s], dJ[s], want == 2)
    return -1


# -- the lane kernel: placements and Jacobians across a block of states ------------------------------------------
# As the dynamics' lane kernels (docs/design.md §4c): blocks of LANES states, the state index last, steps and a
# driver. A path body's record (WORLD rows of LANES numbers): R, p in its parent (lanes.placement_lane), then its
# world placement Rw (9), pw (3); two arrays by depth parity. The frame's block: Rf (9), pf (3); J's block: 6 × nv
# rows (row-major).
WORLD = 24


@njit(cache=True, fastmath=CONTRACT)
def frame_lanes(I, F, Q, V, b, Rl, pl, want, local, Rf, pf, J, dJ):
    """``frame_kernel``'s placement and Jacobian (want ≤ 1) for a batch, block by block across lanes: the batch
    entry of frame_placement and frame_jacobian (free flyers, ball and helical joints included). Runs
    ``frame_kernel`` for J̇ (want = 2), a frame on the fixed base, a model with a planar joint, and a block with a
    non-finite q or an angle beyond ``spatial.SINCOS_MAX`` (its code then names the entry)."""
    N, nb, nq, nv = Q.shape[0], I.shape[1], Q.shape[1], J.shape[2]
    if want == 2 or V.shape[1] > 0 or b < 0 or not on_lanes(unpack(I, F), nq, True):
        return frame_kernel(I, F, Q, V, b, Rl, pl, want, local, Rf, pf, J, dJ)
    I, F = I.copy(), F.copy()                            # the model for this call alone (as rnea.rnea_lanes)
    mdl = unpack(I, F)
    parent, L = mdl.parent, LANES
    path, n = np.empty(nb, np.int64), 0                  # b, its parent, …, the root
    j = b
    while j >= 0:
        path[n] = j
        n += 1
        j = parent[j]
    even, odd = np.empty(nb * WORLD * L), np.empty(nb * WORLD * L)
    base = np.zeros(WORLD * L)                           # the world as a parent: Rw = 1, pw = 0
    for l in range(L):
        base[12 * L + l] = base[16 * L + l] = base[20 * L + l] = 1.0
    Z, Fb = np.empty(nq * L), np.empty(12 * L)
    Jb = np.empty(6 * nv * L if want >= 1 else 0)
    depth = tree_depth(parent)
    X = ((Rl[0, 0], Rl[0, 1], Rl[0, 2]), (Rl[1, 0], Rl[1, 1], Rl[1, 2]), (Rl[2, 0], Rl[2, 1], Rl[2, 2])), \
        (pl[0], pl[1], pl[2])
    for s0 in range(0, N, L):
        m = min(L, N - s0)
        ok = gather_lanes(Q, s0, m, Z, 0, SINCOS_MAX)
        if ok:
            for k in range(n - 1, -1, -1):                               # root → b: placements
                i = path[k]
                B = lane_record(even, odd, depth, i, WORLD)
                P = base if parent[i] < 0 else lane_record(even, odd, depth, parent[i], WORLD)
                if mdl.nvj[i] > 1:
                    world_multi_lanes(i, mdl, B, P, Z)
                else:
                    world_lanes(i, mdl, B, P, Z)
            B = lane_record(even, odd, depth, b, WORLD)
            for l in range(L):
                frame_point_lane(X, B, Fb, l, L)
            if want >= 1:
                Jb[:] = 0.0                                               # joints that do not move b
                for k in range(n):
                    for c in range(mdl.nvj[path[k]]):                     # a column per velocity
                        jacobian_lanes(path[k], c, mdl, lane_record(even, odd, depth, path[k], WORLD), Fb, Jb)
                if local:
                    local_lanes(Fb, Jb, nv)
            ok = scatter_frame(Fb, Jb, m, Rf, pf, J, s0, want >= 1)
        if not ok:                                    # the block's states one by one: the code names the culprit
            code = frame_kernel(I, F, Q[s0:s0 + m], V, b, Rl, pl, want, local, Rf[s0:s0 + m], pf[s0:s0 + m],
                                J[s0:s0 + m], dJ)
            if code != -1:
                return shift(code, s0, nb, 0)
    return OK


@njit(cache=True, fastmath=CONTRACT)
def world_lanes(i, mdl, B, P, Z):
    """Body i's placement in its parent (``lanes.placement_lanes``), then ``world_lane``, every lane of the block."""
    placement_lanes(i, mdl, B, Z)
    for l in range(LANES):
        world_lane(B, P, l, LANES)


@njit(cache=True, fastmath=CONTRACT)
def world_multi_lanes(i, mdl, B, P, Z):
    """``world_lanes`` for a free flyer, a ball or a planar joint (``lanes.quat_placement_lanes``). (A function of its own, as
    rnea.outward_multi_lanes: with both placements in one function the arms' frame_placement lanes measured 47 → 56
    ns a state on the AAU arm.)"""
    quat_placement_lanes(i, mdl, B, Z)
    for l in range(LANES):
        world_lane(B, P, l, LANES)


@njit(cache=True, inline="always")
def world_lane(B, P, l, L):
    """At lane l: a body's world placement Rw = Rw_λ R, pw = pw_λ + Rw_λ p (rows 12–23 of B) from its parent's (P)
    and its own in the parent (rows 0–11) (``forward_kinematics.fk_place``)."""
    Rw, pw = compose((get3(P, 12, l, L), get3(P, 15, l, L), get3(P, 18, l, L)), get3(P, 21, l, L),
                     get_rotation(B, l, L), get3(B, 9, l, L))
    set3(B, 12, l, L, Rw[0])
    set3(B, 15, l, L, Rw[1])
    set3(B, 18, l, L, Rw[2])
    set3(B, 21, l, L, pw)


@njit(cache=True, inline="always")
def frame_point_lane(X, B, Fb, l, L):
    """At lane l: the frame (X = (R, p) in body b) in the world, Rf = Rw_b R, pf = pw_b + Rw_b p, into Fb (rows
    0–11) (``body_point``)."""
    Rf, pf = compose((get3(B, 12, l, L), get3(B, 15, l, L), get3(B, 18, l, L)), get3(B, 21, l, L), X[0], X[1])
    set3(Fb, 0, l, L, Rf[0])
    set3(Fb, 3, l, L, Rf[1])
    set3(Fb, 6, l, L, Rf[2])
    set3(Fb, 9, l, L, pf)


@njit(cache=True, fastmath=CONTRACT)
def jacobian_lanes(j, c, mdl, B, Fb, Jb):
    """``jacobian_lane`` for joint j's column c, every lane of the block."""
    jm = jacobian_model(j, c, mdl)
    for l in range(LANES):
        jacobian_lane(jm, B, Fb, Jb, l, LANES)


@njit(cache=True, inline="always")
def jacobian_model(j, c, mdl):
    """What joint j's Jacobian column c (c < nv_j) takes from the model: (its column r, nv, s_l, s_a)."""
    S, r = mdl.S, mdl.iv[j] + c
    return r, S.shape[0], (S[r, 0], S[r, 1], S[r, 2]), (S[r, 3], S[r, 4], S[r, 5])


@njit(cache=True, inline="always")
def jacobian_lane(jm, B, Fb, Jb, l, L):
    """At lane l: joint j's column of the frame's world-aligned Jacobian, [l + a × (pf − o_j); a], (l; a) = Rw_j s
    (``point_jacobian``; B: body j's record, jm: ``jacobian_model``)."""
    r, nv, sl, sa = jm
    W = (get3(B, 12, l, L), get3(B, 15, l, L), get3(B, 18, l, L))
    lw, aw = mul3(W, sl), mul3(W, sa)
    lin = add(lw, cross(aw, sub(get3(Fb, 9, l, L), get3(B, 21, l, L))))
    for k in range(3):
        Jb[(k * nv + r) * L + l] = lin[k]
        Jb[((3 + k) * nv + r) * L + l] = aw[k]


@njit(cache=True, fastmath=CONTRACT)
def local_lanes(Fb, Jb, nv):
    """``local_lane`` for every column and lane of the block."""
    for r in range(nv):
        for l in range(LANES):
            local_lane(Fb, Jb, nv, r, l, LANES)


@njit(cache=True, inline="always")
def local_lane(Fb, Jb, nv, r, l, L):
    """At lane l: column r of J ← diag(Rfᵀ, Rfᵀ) J, the Jacobian in the frame's axes (``_to_local``)."""
    Rf = get_rotation(Fb, l, L)
    lin = mul3t(Rf, (Jb[(0 * nv + r) * L + l], Jb[(1 * nv + r) * L + l], Jb[(2 * nv + r) * L + l]))
    ang = mul3t(Rf, (Jb[(3 * nv + r) * L + l], Jb[(4 * nv + r) * L + l], Jb[(5 * nv + r) * L + l]))
    for k in range(3):
        Jb[(k * nv + r) * L + l] = lin[k]
        Jb[((3 + k) * nv + r) * L + l] = ang[k]


@njit(cache=True, inline="always")
def scatter_frame(Fb, Jb, m, Rf, pf, J, s0, jac):
    """Rf[s0 + l], pf[s0 + l] (and J[s0 + l] with ``jac``) from the blocks, for their m states. Returns False if an
    entry is not finite."""
    bad, L = 0.0, LANES
    for l in range(m):
        for a in range(3):
            for c in range(3):
                x = Fb[(3 * a + c) * L + l]
                Rf[s0 + l, a, c] = x
                bad += x - x
            x = Fb[(9 + a) * L + l]
            pf[s0 + l, a] = x
            bad += x - x
        if jac:
            nv = J.shape[2]
            for k in range(6):
                for r in range(nv):
                    x = Jb[(k * nv + r) * L + l]
                    J[s0 + l, k, r] = x
                    bad += x - x
    return bad == 0.0


@njit(cache=True)
def frame_one(I, F, q, v, X, want, out):
    """One state q (nq,) [v (nv,)]: for the frame row X (5, 3) = [R; p; (b, want, local)] (``one_state_row``:
    the frame's placement [R; p] in body b) — want = 1: its Jacobian into out (6, nv); want = 2: J̇ into out
    (6, nv); local: in the frame's axes. Returns its status (dynamics/status.py; a non-finite out: its flat
    index). Compiled once, for jacobian_one and jacobian_dot_one."""
    b, local = int(X[4, 0]), X[4, 2] > 0.0
    mdl = unpack(I, F)
    parent, iv, nvj, S = mdl.parent, mdl.iv, mdl.nvj, mdl.S
    nb, nv = I.shape[1], S.shape[0]
    if max(first_nonfinite(q[np.newaxis], 0), first_nonfinite(v[np.newaxis], 0)) >= 0:
        return bad_input(0)
    B3, R3, path = np.zeros((4 * nb + 3, 3)), np.empty((2 * nb + 1, 3, 3)), np.empty(nb, np.int64)   # cut below
    Rp, Rw, Rf = R3[:nb], R3[nb:2 * nb], R3[2 * nb]
    pp, pw, ww, vw = B3[:nb], B3[nb:2 * nb], B3[2 * nb:3 * nb], B3[3 * nb:4 * nb]
    pf, xd, w0 = B3[4 * nb], B3[4 * nb + 1], B3[4 * nb + 2]
    fk_path(mdl, q, v, b, path, Rp, pp, Rw, pw, ww, vw)                 # the frame's support only
    body_point(b, Rw, pw, X[:3], X[3], Rf, pf)
    J = out if want == 1 else np.empty((6, nv))
    point_jacobian(parent, iv, nvj, S, b, Rw, pw, pf, J)
    if want == 2:
        point_velocity(b, pw, ww, vw, pf, xd)
        point_jacobian_dot(parent, iv, nvj, S, b, Rw, pw, ww, vw, pf, xd, out)
    if local:
        _to_local(Rf, ww[b] if b >= 0 else w0, J, out, want == 2)
    k = first_nonfinite_entry(out)
    return OK if k < 0 else bad_result(nb, k)


@njit(cache=True)
def jacobian_one(I, F, q, X, out):
    """frame_one's J (6, nv) of one state q (nq,)."""
    return frame_one(I, F, q, q[:0], X, np.int64(1), out)   # (a run-time int: one compiled frame_one)


@njit(cache=True)
def jacobian_dot_one(I, F, q, v, X, out):
    """frame_one's J̇ (6, nv) of one state q (nq,), v (nv,)."""
    return frame_one(I, F, q, v, X, np.int64(2), out)


@njit(cache=True)
def placement_one(I, F, q, X, R, p):
    """One state q (nq,): the world placement R (3, 3), p (3,) of the frame row X (5, 3) = [R; p; (b, ·, ·)]
    (``one_state_row``). Returns its status (dynamics/status.py: a non-finite input gives a non-finite result,
    reported as R's first entry)."""
    nb, b = I.shape[1], int(X[4, 0])
    R3, B3, path = np.empty((2 * nb, 3, 3)), np.empty((2 * nb, 3)), np.empty(nb, np.int64)
    fk_path(unpack(I, F), q, q[:0], b, path, R3[:nb], B3[:nb], R3[nb:], B3[nb:], B3[:0], B3[:0])
    body_point(b, R3[nb:], B3[nb:], X[:3], X[3], R, p)
    return OK if max(first_nonfinite(p[np.newaxis], 0), first_nonfinite_entry(R)) < 0 else bad_result(nb, 0)


# The compiled code every call reaches (``_jit.entry``; arrays of any strides): batches, and one state with
# its frame row
FRAME = entry(frame_lanes, *MODEL, A2, A2, numba.int64, A2, A1, numba.int64, numba.boolean, A3, A2, A3, A3)
JACOBIAN_ONE = entry(jacobian_one, *MODEL, A1, A2, A2)
JACOBIAN_DOT_ONE = entry(jacobian_dot_one, *MODEL, A1, A1, A2, A2)
PLACEMENT_ONE = entry(placement_one, *MODEL, A1, A2, A2, A1)


@njit(cache=True)
def com_jacobians_kernel(I, F, Q, c, J, Iw):
    """For every state and body b: world CoM c (N, nb, 3), its world-aligned Jacobian J (N, nb, 6, nv) and
    the world inertia about the CoM Iw = R I Rᵀ (N, nb, 3, 3) — what the Lagrange route sums over."""
    mdl = unpack(I, F)
    parent, iv, nvj, S, com, inertia = mdl.parent, mdl.iv, mdl.nvj, mdl.S, mdl.com, mdl.inertia
    N, nb = Q.shape[0], I.shape[1]
    R3, B3, v0 = np.empty((2 * nb + 3, 3, 3)), np.empty((4 * nb, 3)), np.empty(0)   # scratch: slices of two
    Rp, Rw, tmp, Rc, eye = R3[:nb], R3[nb:2 * nb], R3[2 * nb], R3[2 * nb + 1], R3[2 * nb + 2]
    pp, pw, ww, vw = B3[:nb], B3[nb:2 * nb], B3[2 * nb:3 * nb], B3[3 * nb:]
    eye[:, :] = 0.0
    eye[0, 0] = eye[1, 1] = eye[2, 2] = 1.0
    for s in range(N):
        fk_pass(mdl, Q[s], v0, Rp, pp, Rw, pw, ww, vw)
        for b in range(nb):
            body_point(b, Rw, pw, eye, com[b], Rc, c[s, b])
            point_jacobian(parent, iv, nvj, S, b, Rw, pw, c[s, b], J[s, b])
            Iw[s, b] = 0.0
            sandwich3(Rw[b], inertia[b], tmp, Iw[s, b])


# -- Python entry points -----------------------------------------------------------------------------------

def frame_row(model, frame, lanes=False):
    """(body, X (4, 3) = [R; p]) of a link or frame name: the frame's placement in its body
    (``model.kernel.frame_rows``; ``lanes``: in the body's z-aligned frame, ``lane_frame_rows``); InputError lists
    the closest names."""
    rows = model.kernel.lane_frame_rows if lanes else model.kernel.frame_rows
    row = rows.get(frame) if type(frame) is str else None
    return row if row is not None else rows[frame_of(model, frame).name]


def one_state_row(model, frame, reference):
    """X (5, 3) = [R; p; (body, 0, local)] of a link or frame name for frame_one / placement_one
    (``model.kernel.one_state_rows``); InputError lists the closest names, or names a bad reference."""
    X = model.kernel.one_state_rows.get((frame, reference)) if type(frame) is str and type(reference) is str \
        else None
    if X is None:
        _check_reference(reference)
        X = model.kernel.one_state_rows[frame_of(model, frame).name, reference]
    return X


def _frame_terms(model, call, frame, Q, V, want, reference):
    """Run frame_kernel on checked batches; returns Rf, pf, J, J̇ (batch form; J, J̇ empty when not wanted)."""
    b, X = frame_row(model, frame, lanes=True)      # the batch entry is a lane kernel: the z-aligned form
    N, nv = Q.shape[0], model.nv
    Rf, pf = np.empty((N, 3, 3)), np.empty((N, 3))
    J = np.zeros((N, 6, nv)) if want >= 1 else np.empty((N, 0, 0))
    dJ = np.zeros((N, 6, nv)) if want == 2 else np.empty((N, 0, 0))
    Vk = np.empty((N, 0)) if V is None else V
    code = FRAME.call(*model.kernel.lane_arrays, Q, Vk, b, X[:3], X[3], want, reference == "local", Rf, pf, J, dJ)
    if code != -1:
        names, batches = ("q",) if V is None else ("q", "v"), (Q,) if V is None else (Q, V)
        raise_kernel_error(model, code, names, batches, call)
    return Rf, pf, J, dJ


def frame_placement(model, q, frame):
    """Pose of a link or frame in the world: (R (3, 3) or (N, 3, 3), p (3,) or (N, 3)), x_world = R x + p."""
    k = fast(model, q)
    if k is None and type(model) is Model:              # another dtype, a list: converted (or named), then
        (Q,), single = as_batch(model, q=q)             # one state takes the same kernel as a float64 one
        q, k = (Q[0], fast(model, Q[0])) if single else (q, None)
    if k is not None:                                   # one float64 state: straight into the kernel
        try:
            X = model.kernel.one_state_rows[frame, "local_world_aligned"]
        except (KeyError, TypeError):                   # an unknown name or reference: named in the error
            X = one_state_row(model, frame, "local_world_aligned")
        R, p = np.empty((3, 3)), np.empty(3)
        if PLACEMENT_ONE.call(k[0], k[1], q, X, R, p) == -1:
            return R, p
    return _frame_placement(model, q, frame)            # checked: names a bad input or result


@quiet
def _frame_placement(model, q, frame):
    (Q,), single = as_batch(model, q=q)
    Rf, pf, _, _ = _frame_terms(model, "frame_placement", frame, Q, None, 0, "local_world_aligned")
    Rf, pf = (check_output("frame_placement", k, x, model, dict(q=Q)) for k, x in (("R", Rf), ("p", pf)))
    return unbatch(Rf, single), unbatch(pf, single)


def frame_jacobian(model, q, frame, reference="local_world_aligned"):
    """J (6, nv) or (N, 6, nv), rows [linear; angular]: the frame's velocity and angular velocity = J q̇
    (Eqs. 29–30), world-aligned at the frame's origin or in the frame's axes (``reference="local"``)."""
    k = fast(model, q)
    if k is None and type(model) is Model:              # another dtype, a list: converted (or named), then
        (Q,), single = as_batch(model, q=q)             # one state takes the same kernel as a float64 one
        q, k = (Q[0], fast(model, Q[0])) if single else (q, None)
    if k is not None:                                   # one float64 state: straight into the kernel
        try:
            X = model.kernel.one_state_rows[frame, reference]
        except (KeyError, TypeError):                   # an unknown name or reference: named in the error
            X = one_state_row(model, frame, reference)
        J = np.empty((6, model.nv))
        if JACOBIAN_ONE.call(k[0], k[1], q, X, J) == -1:
            return J
    return _frame_jacobian(model, q, frame, reference)  # checked: names a bad input or result


@quiet
def _frame_jacobian(model, q, frame, reference):
    _check_reference(reference)
    (Q,), single = as_batch(model, q=q)
    J = _frame_terms(model, "frame_jacobian", frame, Q, None, 1, reference)[2]
    return unbatch(check_output("frame_jacobian", "J", J, model, dict(q=Q), axis=2), single)


def frame_jacobian_dot(model, q, v, frame, reference="local_world_aligned"):
    """J̇ (6, nv) or (N, 6, nv): the exact time derivative of frame_jacobian along q̇ (the module
    docstring gives the columns)."""
    k = fast(model, q, v)
    if k is None and type(model) is Model:              # another dtype, a list: converted (or named), then
        (Q, V), single = as_batch(model, q=q, v=v)      # one state takes the same kernel as a float64 one
        q, v, k = (Q[0], V[0], fast(model, Q[0], V[0])) if single else (q, v, None)
    if k is not None:                                   # one float64 state: straight into the kernel
        try:
            X = model.kernel.one_state_rows[frame, reference]
        except (KeyError, TypeError):                   # an unknown name or reference: named in the error
            X = one_state_row(model, frame, reference)
        dJ = np.empty((6, model.nv))
        if JACOBIAN_DOT_ONE.call(k[0], k[1], q, v, X, dJ) == -1:
            return dJ
    return _frame_jacobian_dot(model, q, v, frame, reference)   # checked: names a bad input or result


@quiet
def _frame_jacobian_dot(model, q, v, frame, reference):
    _check_reference(reference)
    (Q, V), single = as_batch(model, q=q, v=v)
    dJ = _frame_terms(model, "frame_jacobian_dot", frame, Q, V, 2, reference)[3]
    return unbatch(check_output("frame_jacobian_dot", "J̇", dJ, model, dict(q=Q, v=V), axis=2), single)


def com_jacobians(model, Q):
    """Per body, for a checked batch Q (N, nq): world CoM c (nb, N, 3), CoM Jacobian J (nb, N, 6, nv)
    (world-aligned), world inertia about the CoM Iw (nb, N, 3, 3)."""
    N, nb = Q.shape[0], model.njoints
    c, J, Iw = np.empty((N, nb, 3)), np.empty((N, nb, 6, model.nv)), np.empty((N, nb, 3, 3))
    if nb:
        com_jacobians_kernel(*kernel_arrays(model), np.ascontiguousarray(Q), c, J, Iw)
    return np.moveaxis(c, 1, 0), np.moveaxis(J, 1, 0), np.moveaxis(Iw, 1, 0)


def supports(model) -> np.ndarray:
    """(nb, nb) bool: supports[b, j] is True when joint j moves body b (j is b or one of its ancestors)."""
    S = np.eye(model.njoints, dtype=bool)
    for i in range(model.njoints):
        if model.parent[i] >= 0:
            S[i] |= S[model.parent[i]]
    return S


def _check_reference(reference):
    if isinstance(reference, str) and reference == "world":
        raise InputError("reference='world' is ambiguous: use 'local_world_aligned' (world-aligned axes at the "
                         "frame's origin, Pinocchio's LOCAL_WORLD_ALIGNED); Pinocchio's WORLD is another "
                         "convention (the twist at the world origin), not offered here")
    if not isinstance(reference, str) or reference not in REFERENCES:
        raise InputError(f"reference must be 'local_world_aligned' or 'local', not {reference!r}")
