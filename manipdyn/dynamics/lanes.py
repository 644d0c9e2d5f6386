"""Lane blocks: a batch as blocks of LANES states, the state index last (the lane kernels, docs/design.md §4c).

A block's numbers live in records, rows of L numbers each (L = LANES on the CPU, the batch size on a GPU): a
state's q, q̇, q̈ (``gather_lanes``, ``gather_lane`` for a GPU thread), a body's placement and motion (``placement_lane``,
``quat_placement_lane``), read and written a 3- or 6-tuple at a time (``get3``, ``set3``…). What a body's step takes
from the model is read once per block (``placement_model``, ``motion_model``, ``inertial_model``); ``on_lanes`` says
which models the lane steps take.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import CONTRACT, njit
from ..joints import HELICAL, PLANAR, PRISMATIC, REVOLUTE, multi_dof, quat_layout, quat_rotation
from ..spatial import SINCOS_MAX, add, cross, mul3t, sincos, sub


FINITE = 1.7976931348623157e308   # the largest float64: Σ|x| ≤ FINITE means every x is finite (gather_lanes)
LANES = 64     # states per block: the lane kernels' innermost loops run over them (measured on ur5: 32 → 64 → 128
#                lanes 118 → 116 → 115 ns per state; 8 lanes 385: too short a loop to vectorise)


@njit(cache=True, inline="always")
def gather_lanes(X, s0, n, Z, row, limit=FINITE):
    """Z[(row + k)·LANES + l] = X[s0 + l, k] for the block's n states (l < n; lanes n … LANES − 1 repeat its last
    state, so that every lane computes finite numbers). Returns False unless every state's Σ_k |X[s, k]| ≤ limit:
    for the default, every entry is finite; for q with ``spatial.SINCOS_MAX``, every angle is also within the
    range where ``sincos`` keeps libm's accuracy. Four states a pass (their rows read side by side, each column's
    four lanes stored together) and one sum and one test a state, not one test a number (ur5's q, N = 10⁴: 3.8
    against 5.6 ns a state, and no pass of its own for the angles). A block that fails (a sum of large finite
    numbers included) runs through the kernel's one-state form, which checks each number."""
    bad, last = 0.0, s0 + n - 1
    for l in range(0, LANES, 4):                       # (LANES is a multiple of 4)
        sa, sb, sc, sd = min(s0 + l, last), min(s0 + l + 1, last), min(s0 + l + 2, last), min(s0 + l + 3, last)
        a0 = a1 = a2 = a3 = 0.0
        for k in range(X.shape[1]):
            x0, x1, x2, x3 = X[sa, k], X[sb, k], X[sc, k], X[sd, k]
            o = (row + k) * LANES + l
            Z[o], Z[o + 1], Z[o + 2], Z[o + 3] = x0, x1, x2, x3
            a0, a1, a2, a3 = a0 + abs(x0), a1 + abs(x1), a2 + abs(x2), a3 + abs(x3)
        bad += (0.0 if a0 <= limit else 1.0) + (0.0 if a1 <= limit else 1.0) \
            + (0.0 if a2 <= limit else 1.0) + (0.0 if a3 <= limit else 1.0)     # NaN fails the test too
    return bad == 0.0


@njit(cache=True, inline="always")
def scatter_lanes(Z, n, Y, s0):
    """Y[s0 + l, k] = Z[k·LANES + l] for the block's n states (``gather_lanes`` undone), four states a pass. Returns
    False if an entry is not finite: a state's row is summed, and b − b is 0 for a finite sum (ur5's τ: 3.1 against
    5.6 ns a state)."""
    bad, l = 0.0, 0
    while l + 4 <= n:
        b0 = b1 = b2 = b3 = 0.0
        for k in range(Y.shape[1]):
            o = k * LANES + l
            y0, y1, y2, y3 = Z[o], Z[o + 1], Z[o + 2], Z[o + 3]
            Y[s0 + l, k], Y[s0 + l + 1, k], Y[s0 + l + 2, k], Y[s0 + l + 3, k] = y0, y1, y2, y3
            b0, b1, b2, b3 = b0 + y0, b1 + y1, b2 + y2, b3 + y3
        bad += (b0 - b0) + (b1 - b1) + (b2 - b2) + (b3 - b3)
        l += 4
    for r in range(l, n):                              # the last n mod 4 states
        b = 0.0
        for k in range(Y.shape[1]):
            y = Z[k * LANES + r]
            Y[s0 + r, k] = y
            b += y
        bad += b - b
    return bad == 0.0


@njit(cache=True, inline="always")
def get3(B, r, l, L):
    """Rows r … r + 2 of a lane record (rows of L numbers: L = LANES on the CPU, the batch size on a GPU) at lane l,
    a 3-tuple."""
    return B[r * L + l], B[(r + 1) * L + l], B[(r + 2) * L + l]


@njit(cache=True, inline="always")
def get6(B, r, l, L):
    """Rows r … r + 5 of a lane record at lane l, a 6-tuple (``get3``)."""
    return (B[r * L + l], B[(r + 1) * L + l], B[(r + 2) * L + l], B[(r + 3) * L + l], B[(r + 4) * L + l],
            B[(r + 5) * L + l])


@njit(cache=True, inline="always")
def set3(B, r, l, L, x):
    """Rows r … r + 2 of a lane record at lane l ← the 3-tuple x (``get3``)."""
    B[r * L + l], B[(r + 1) * L + l], B[(r + 2) * L + l] = x[0], x[1], x[2]


@njit(cache=True, inline="always")
def set6(B, r, l, L, x):
    """Rows r … r + 5 of a lane record at lane l ← the 6-tuple x (``get3``)."""
    B[r * L + l], B[(r + 1) * L + l], B[(r + 2) * L + l] = x[0], x[1], x[2]
    B[(r + 3) * L + l], B[(r + 4) * L + l], B[(r + 5) * L + l] = x[3], x[4], x[5]


@njit(cache=True, inline="always")
def get_sym3(B, r, l, L):
    """A symmetric 3×3 stored in rows r … r + 5 of a lane record (xx, yy, zz, xy, xz, yz) at lane l, as a tuple
    of its rows (``get3``)."""
    xx, yy, zz, xy, xz, yz = get6(B, r, l, L)
    return (xx, xy, xz), (xy, yy, yz), (xz, yz, zz)


@njit(cache=True, inline="always")
def add_sym3(B, r, l, L, X):
    """Rows r … r + 5 of a lane record (``get_sym3``) at lane l += the upper triangle of X (a tuple of rows)."""
    B[r * L + l] += X[0][0]
    B[(r + 1) * L + l] += X[1][1]
    B[(r + 2) * L + l] += X[2][2]
    B[(r + 3) * L + l] += X[0][1]
    B[(r + 4) * L + l] += X[0][2]
    B[(r + 5) * L + l] += X[1][2]


@njit(cache=True, inline="always")
def get_rotation(B, l, L):
    """R, rows 0–8 of a lane record (``placement_lane``) at lane l, as a tuple of its rows."""
    return get3(B, 0, l, L), get3(B, 3, l, L), get3(B, 6, l, L)


@njit(cache=True, inline="always")
def one_lane(q, v, x, Z, base, mg):
    """One state as a block of one lane (the one-state drivers): Z ← [q; q̇; x] (x: q̈ or τ), and the base's record
    zero but for rows 6–8, −g (the RNEA's v̇'_0, the linear part of the ABA's a_0: docs/design.md §6)."""
    nq, nv = q.shape[0], v.shape[0]
    for k in range(nq):
        Z[k] = q[k]
    for k in range(nv):
        Z[nq + k], Z[nq + nv + k] = v[k], x[k]
    for k in range(base.shape[0]):
        base[k] = 0.0
    base[6], base[7], base[8] = mg[0], mg[1], mg[2]


@njit(cache=True, inline="always")
def external_lane(B, row, fe, ne, p, l, L):
    """Rows row … row + 5 of a lane record, a wrench [f; n] about the body's origin (the RNEA's f'_i, n'_i, the ABA's
    p^A_i), at lane l −= the wrench (f_e, n_e) the environment applies on the body about its point p, all in body
    axes: f −= f_e, n −= n_e + p × f_e (the one place an external wrench enters a lane record)."""
    set3(B, row, l, L, sub(get3(B, row, l, L), fe))
    set3(B, row + 3, l, L, sub(get3(B, row + 3, l, L), add(ne, cross(p, fe))))


@njit(cache=True, fastmath=CONTRACT)
def external_lanes(parent, even, odd, depth, rows, row, X, s0, n, xb, xp, world, W, path):
    """``external_lane`` for every lane of the block, on rows row … row + 5 of the records (``rows`` numbers each;
    ``lane_record``) of the bodies xb: for each wrench k, (f_e, n_e) = X[s, k] on body xb[k] about its point xp[k]
    (body axes). A wrench in world axes is first turned into the body, Rw_bᵀ x = R_bᵀ ⋯ R_1ᵀ x with the placements R
    of the bodies on the path from the base to b (their records, rows 0–8), applied from the base out. W: scratch
    of 6 rows, path: of nb entries."""
    for k in range(xb.shape[0]):
        b = xb[k]
        for c in range(6):
            for l in range(LANES):
                W[c * LANES + l] = X[s0 + min(l, n - 1), k, c]
        if world:
            m, j = 0, b
            while j >= 0:                                   # the path b, λ(b), …, up to a child of the base
                path[m] = j
                m, j = m + 1, parent[j]
            for t in range(m - 1, -1, -1):                  # from the base out: x ← R_jᵀ x
                Bj = lane_record(even, odd, depth, path[t], rows)
                for l in range(LANES):
                    R = get_rotation(Bj, l, LANES)
                    set3(W, 0, l, LANES, mul3t(R, get3(W, 0, l, LANES)))
                    set3(W, 3, l, LANES, mul3t(R, get3(W, 3, l, LANES)))
        B, p = lane_record(even, odd, depth, b, rows), (xp[k, 0], xp[k, 1], xp[k, 2])
        for l in range(LANES):
            external_lane(B, row, get3(W, 0, l, LANES), get3(W, 3, l, LANES), p, l, LANES)


@njit(cache=True, inline="always")
def wrench_in_body(parent, Rec, rows, X, k, b, world):
    """(f_e, n_e): row k of X (K, 6), [force; moment] on body b, in b's axes — as given, or (``world``) turned from
    world axes, R_bᵀ ⋯ R_1ᵀ x, with the placements R (rows 0–8) of the bodies from the base out to b, read from
    one-lane records of ``rows`` numbers each (Rec, the one-state drivers')."""
    fe, ne = (X[k, 0], X[k, 1], X[k, 2]), (X[k, 3], X[k, 4], X[k, 5])
    if world:
        path, m, j = np.empty(parent.shape[0], np.int64), 0, b
        while j >= 0:                                   # the path b, λ(b), …, up to a child of the base
            path[m] = j
            m, j = m + 1, parent[j]
        for t in range(m - 1, -1, -1):                  # from the base out: x ← R_jᵀ x
            R = get_rotation(Rec[path[t] * rows:(path[t] + 1) * rows], 0, 1)
            fe, ne = mul3t(R, fe), mul3t(R, ne)
    return fe, ne


@njit(cache=True, inline="always")
def tree_depth(parent):
    """depth (nb,) int: 0 for a child of the base, λ(i)'s + 1 else (the lane records' parity, ``lane_record``)."""
    depth = np.zeros(parent.shape[0], np.int64)
    for i in range(parent.shape[0]):
        depth[i] = 0 if parent[i] < 0 else depth[parent[i]] + 1
    return depth


@njit(cache=True, inline="always")
def lane_record(even, odd, depth, i, rows):
    """Body i's record (rows × LANES numbers) in the array of its depth's parity: a body's loop reads its parent's
    record and writes its own, in two arrays the compiler checks for overlap once, where rows of one array at
    run-time offsets made it give up vectorising (docs/design.md §4c)."""
    X = even if depth[i] % 2 == 0 else odd
    return X[i * rows * LANES:(i + 1) * rows * LANES]


@njit(cache=True, inline="always")
def on_lanes(mdl, nq, multi=False, helical=True):
    """True when the lane steps apply to the model (nq: a state's q entries): every joint is revolute, prismatic or
    helical about z — the z-aligned form the batch routes pass (``Model.kernel.lane_arrays``, kernel_form.z_aligned) —
    or, for a kernel whose steps take several velocities a joint (``multi``: every algorithm's), a free flyer, a ball
    joint (``joints.multi_dof``) or a planar joint in the x–y plane; without ``helical``, no helical joint. A joint
    the steps do not take sends the batch to the lane kernel's scalar kernel, which takes every joint of the
    registry."""
    nb = mdl.parent.shape[0]
    ok = True
    for i in range(nb):
        k = mdl.kind[i]
        if k == REVOLUTE or k == PRISMATIC or (helical and k == HELICAL) or (multi and k == PLANAR):
            ok &= mdl.axis[i, 0] == 0.0 and mdl.axis[i, 1] == 0.0 and mdl.axis[i, 2] == 1.0
        else:
            ok &= multi and multi_dof(k)
    return ok and (multi or nq == nb)


@njit(cache=True, inline="always")
def placement_model(i, mdl):
    """What body i's placement takes from the model, once per block (``placement_lane``): in z-aligned frames
    (``on_lanes``) R^{i−1}_i = R0 Rot(z, q), whose rows are (c a_x + s a_y, c a_y − s a_x, a_z) for each row a of
    R0, and p = p0 + d R0 z (R0's last column) for a prismatic joint (its rotation is 1: s = 0, c = 1 from an
    angle of 0); a helical joint turns as a revolute one and slides h θ after it (``slide_lane``). Returns (a0, a1,
    a2: R0's rows, p0, turn: 1 revolute or helical / 0 prismatic, q's row). (One number for both: a fourteenth
    constant in the loop spilled AVX2's 16 registers, 4–10 % slower.)"""
    R0 = mdl.R0
    a0, a1, a2 = (R0[i, 0, 0], R0[i, 0, 1], R0[i, 0, 2]), (R0[i, 1, 0], R0[i, 1, 1], R0[i, 1, 2]), \
        (R0[i, 2, 0], R0[i, 2, 1], R0[i, 2, 2])
    return a0, a1, a2, (mdl.p0[i, 0], mdl.p0[i, 1], mdl.p0[i, 2]), 0.0 if mdl.kind[i] == PRISMATIC else 1.0, mdl.iq[i]


@njit(cache=True, inline="always")
def quat_model(i, mdl):
    """What a free flyer's or a ball joint's placement takes from the model (``quat_placement_lane``): (R0's rows,
    p0, q's row, the quaternion's row, 1.0 for a joint that translates by its first three entries (a free flyer))."""
    R0, (kq, lin) = mdl.R0, quat_layout(mdl.kind[i])
    a0, a1, a2 = (R0[i, 0, 0], R0[i, 0, 1], R0[i, 0, 2]), (R0[i, 1, 0], R0[i, 1, 1], R0[i, 1, 2]), \
        (R0[i, 2, 0], R0[i, 2, 1], R0[i, 2, 2])
    return a0, a1, a2, (mdl.p0[i, 0], mdl.p0[i, 1], mdl.p0[i, 2]), mdl.iq[i], mdl.iq[i] + kq, lin


@njit(cache=True, inline="always")
def placement_lane(pm, B, Z, l, L):
    """Rows 0–11 of a body's lane record B at lane l: R^{i−1}_i (9, row-major) and p^{i−1}_i (3) (``joints.
    joint_placement`` for a revolute or prismatic joint about z, the lane kernels' form; pm: ``placement_model``;
    Z: q in its first rows). Records are rows of L numbers: L = LANES on the CPU, the batch size on a GPU."""
    a0, a1, a2, o, turn, iq = pm
    qi = Z[iq * L + l]
    s, c = sincos(turn * qi)
    d = (1.0 - turn) * qi
    turned_lane(a0, a1, a2, c, s, B, l, L)
    B[9 * L + l], B[10 * L + l], B[11 * L + l] = o[0] + d * a0[2], o[1] + d * a1[2], o[2] + d * a2[2]


@njit(cache=True, inline="always")
def screw_placement_one(i, mdl, B, Z):
    """Rows 0–11 of body i's record for one state (L = 1: the one-state drivers) for a revolute, prismatic or helical
    joint: ``placement_lane``, with libm's sin and cos for an angle beyond ``spatial.SINCOS_MAX`` (sincos' range: a
    lane block holding one runs state by state through here), then a helical joint's slide (``slide_lane``)."""
    pm = placement_model(i, mdl)
    a0, a1, a2, o, turn, iq = pm
    if turn == 1.0 and abs(Z[iq]) > SINCOS_MAX:
        turned_lane(a0, a1, a2, math.cos(Z[iq]), math.sin(Z[iq]), B, 0, 1)
        B[9], B[10], B[11] = o[0], o[1], o[2]
    else:
        placement_lane(pm, B, Z, 0, 1)
    if mdl.kind[i] == HELICAL:
        slide_lane(pm, mdl.pitch[i], B, Z, 0, 1)


@njit(cache=True, inline="always")
def turned_lane(a0, a1, a2, c, s, B, l, L):
    """Rows 0–8 of a body's lane record at lane l: R0 Rot(z, θ) from R0's rows a0, a1, a2 and c, s = cos θ, sin θ
    (row a of R0 turned: (c a_x + s a_y, c a_y − s a_x, a_z))."""
    B[0 * L + l], B[1 * L + l], B[2 * L + l] = c * a0[0] + s * a0[1], c * a0[1] - s * a0[0], a0[2]
    B[3 * L + l], B[4 * L + l], B[5 * L + l] = c * a1[0] + s * a1[1], c * a1[1] - s * a1[0], a1[2]
    B[6 * L + l], B[7 * L + l], B[8 * L + l] = c * a2[0] + s * a2[1], c * a2[1] - s * a2[0], a2[2]


@njit(cache=True, inline="always")
def planar_placement_lane(pm, B, Z, l, L):
    """``placement_lane`` for a planar joint in z-aligned frames (its plane the body's x–y plane: kernel_form.
    planar_turn): R^{i−1}_i = R0 Rot(z, θ) with cos θ, sin θ q's entries 2, 3 as they are, p^{i−1}_i = p0 + R0 (x, y,
    0) (``joints.joint_placement``'s planar branch); pm: ``placement_model``."""
    a0, a1, a2, o, _, iq = pm
    x, y, c, s = Z[iq * L + l], Z[(iq + 1) * L + l], Z[(iq + 2) * L + l], Z[(iq + 3) * L + l]
    turned_lane(a0, a1, a2, c, s, B, l, L)
    B[9 * L + l], B[10 * L + l] = o[0] + x * a0[0] + y * a0[1], o[1] + x * a1[0] + y * a1[1]
    B[11 * L + l] = o[2] + x * a2[0] + y * a2[1]


@njit(cache=True, inline="always")
def slide_lane(pm, h, B, Z, l, L):
    """A helical joint's slide along its axis, after ``placement_lane`` has turned it: p^{i−1}_i += h θ R0 z at lane l
    (h: the pitch, ``joints.joint_placement``'s p_J = h θ z)."""
    a0, a1, a2, _, _, iq = pm
    d = h * Z[iq * L + l]
    B[9 * L + l] += d * a0[2]
    B[10 * L + l] += d * a1[2]
    B[11 * L + l] += d * a2[2]


@njit(cache=True, inline="always")
def body_placement_lane(i, mdl, B, Z, l, L):
    """Rows 0–11 of body i's record at lane l whatever its joint: a free flyer's or a ball's quaternion placement, a
    screw joint's turn, slide or both — for the GPU's drivers, one lane a thread (L = N). (The CPU's block loops run
    ``placement_lanes`` or ``quat_placement_lanes``, one kind a loop; its one-state drivers write these lines out:
    through this inlined function rnea's one-state steps measured 0.97 → 1.29 µs on the AAU arm.)"""
    if mdl.kind[i] == PLANAR:
        planar_placement_lane(placement_model(i, mdl), B, Z, l, L)
    elif mdl.nvj[i] > 1:
        quat_placement_lane(quat_model(i, mdl), B, Z, l, L)
    else:
        pm = placement_model(i, mdl)
        placement_lane(pm, B, Z, l, L)
        if mdl.kind[i] == HELICAL:
            slide_lane(pm, mdl.pitch[i], B, Z, l, L)


@njit(cache=True, inline="always")
def quat_placement_lane(pm, B, Z, l, L):
    """``placement_lane`` for a free flyer or a ball joint: R^{i−1}_i = R0 R(quat), p^{i−1}_i = p0 + R0 t, t = [x y z]
    for a free flyer (lin = 1), 0 for a ball (``joints.joint_placement``'s two quaternion branches); pm:
    ``quat_model``."""
    a0, a1, a2, o, iq, k, lin = pm
    r = quat_rotation(Z[k * L + l], Z[(k + 1) * L + l], Z[(k + 2) * L + l], Z[(k + 3) * L + l])
    t = (lin * Z[iq * L + l], lin * Z[(iq + 1) * L + l], lin * Z[(iq + 2) * L + l])
    for a in range(3):
        x = a0 if a == 0 else a1 if a == 1 else a2
        B[(3 * a) * L + l] = x[0] * r[0] + x[1] * r[3] + x[2] * r[6]
        B[(3 * a + 1) * L + l] = x[0] * r[1] + x[1] * r[4] + x[2] * r[7]
        B[(3 * a + 2) * L + l] = x[0] * r[2] + x[1] * r[5] + x[2] * r[8]
        B[(9 + a) * L + l] = o[a] + x[0] * t[0] + x[1] * t[1] + x[2] * t[2]


@njit(cache=True, inline="always")
def motion_model(i, mdl, nq):
    """What body i's motion and torque take from the model: (r: its first row of S and of τ, s_l, s_a: S's row r,
    rv, ra: the rows of q̇_r and q̈_r in the block's Z — q, q̇, q̈ stacked, nq + 2 nv rows —, n: its velocities)."""
    r, nv = mdl.iv[i], mdl.S.shape[0]
    return r, (mdl.S[r, 0], mdl.S[r, 1], mdl.S[r, 2]), (mdl.S[r, 3], mdl.S[r, 4], mdl.S[r, 5]), nq + r, \
        nq + nv + r, mdl.nvj[i]


@njit(cache=True, inline="always")
def selected(n, planar, r):
    """The entry of [linear; angular] that velocity r of a joint of n velocities moves (S's row r is that unit row):
    a free flyer's r, a ball's 3 + r, a planar joint's 0, 1, 5 (x, y, the turn about z in z-aligned frames). (Called
    outside the lane loops: reading S's masks inside them kept the loops scalar, the humanoid's lane RNEA 260 → 507
    ns a state.)"""
    return (r if r < 2 else 5) if planar else 6 - n + r


@njit(cache=True, inline="always")
def multi_model(i, mdl, nq):
    """``motion_model`` for a joint of several velocities whose S selects entries of [linear; angular] — a free
    flyer (S = 1₆), a ball (S = [0; 1₃]), a planar joint in z-aligned frames (S's rows e_x, e_y | e_z): (r, ml, ma:
    the masks of x[0:3] for the linear part and of x[o:o + 3] for the angular part, rv, ra, n, o), read from S's
    entries (``multi_rates``)."""
    r, nv, n, S = mdl.iv[i], mdl.S.shape[0], mdl.nvj[i], mdl.S
    o = 3 if n == 6 else 0
    return r, (S[r, 0], S[r + 1, 1], S[r + 2, 2]), (S[r + o, 3], S[r + o + 1, 4], S[r + o + 2, 5]), nq + r, \
        nq + nv + r, n, o


@njit(cache=True, inline="always")
def multi_rates(mm, Z, row, l, L):
    """S x of a free flyer, a ball or a planar joint at lane l, x = q̇ or q̈ from its rows ``row`` … of Z
    (``multi_model``'s rv or ra): the 3-tuples (linear, angular) = (ml ⊙ x[0:3], ma ⊙ x[o:o + 3]) — (x[0:3], x[3:6]),
    (0, x[0:3]), ((x0, x1, 0), (0, 0, x2)) — masks, not branches, in the lane loop (x is finite: gather_lanes
    checked it)."""
    ml, ma, o = mm[1], mm[2], mm[6]
    x, y = get3(Z, row, l, L), get3(Z, row + o, l, L)
    return (ml[0] * x[0], ml[1] * x[1], ml[2] * x[2]), (ma[0] * y[0], ma[1] * y[1], ma[2] * y[2])


@njit(cache=True, inline="always")
def inertial_model(i, mdl):
    """What body i's inertial wrench takes from the model: (m, its centre of mass, its inertia's rows)."""
    J = mdl.inertia
    return mdl.mass[i], (mdl.com[i, 0], mdl.com[i, 1], mdl.com[i, 2]), ((J[i, 0, 0], J[i, 0, 1], J[i, 0, 2]),
                                                                         (J[i, 1, 0], J[i, 1, 1], J[i, 1, 2]),
                                                                         (J[i, 2, 0], J[i, 2, 1], J[i, 2, 2]))


@njit(cache=True, inline="always")
def gather_lane(X, Z, s, N, row, angle, angles):
    """One state's row into a record of rows N long (a GPU thread's ``gather_lanes``): Z[(row + k)·N + s] = X[s, k].
    Returns 0.0, or inf/NaN for a non-finite entry or (``angles``: X is q) a revolute angle beyond SINCOS_MAX
    (angle (nq,): 1 where q's entry is a revolute joint's angle)."""
    bad = 0.0
    for k in range(X.shape[1]):
        x = X[s, k]
        Z[(row + k) * N + s] = x
        bad += x - x
        if angles and angle[k] == 1 and not abs(x) <= SINCOS_MAX:
            bad += np.inf
    return bad


@njit(cache=True, inline="always")
def scatter_lane(Z, Y, s, N):
    """Y[s, k] = Z[k·N + s] (``gather_lane`` undone). Returns 0.0, or inf/NaN if an entry is not finite."""
    bad = 0.0
    for k in range(Y.shape[1]):
        y = Z[k * N + s]
        Y[s, k] = y
        bad += y - y
    return bad


@njit(cache=True, inline="always")
def placement_lanes(i, mdl, B, Z):
    """``placement_lane`` for every lane of the block (a screw joint; a free flyer or ball: ``quat_placement_lanes``),
    then a helical joint's slide (``slide_lanes``)."""
    pm = placement_model(i, mdl)
    for l in range(LANES):
        placement_lane(pm, B, Z, l, LANES)
    if mdl.kind[i] == HELICAL:
        slide_lanes(i, mdl, B, Z)


@njit(cache=True)
def slide_lanes(i, mdl, B, Z):
    """``slide_lane`` for every lane of the block: a helical joint's slide (a function of its own, which the arms'
    kernels never call; rnea.outward_lanes, whose loops it slowed even so, leaves helical bodies to
    ``outward_multi_lanes``)."""
    pm, h = placement_model(i, mdl), mdl.pitch[i]
    for l in range(LANES):
        slide_lane(pm, h, B, Z, l, LANES)


@njit(cache=True, inline="always")
def quat_placement_lanes(i, mdl, B, Z):
    """``quat_placement_lane`` for every lane of the block; a planar joint's, ``planar_placement_lane``."""
    if mdl.kind[i] == PLANAR:
        pm = placement_model(i, mdl)
        for l in range(LANES):
            planar_placement_lane(pm, B, Z, l, LANES)
    else:
        qm = quat_model(i, mdl)
        for l in range(LANES):
            quat_placement_lane(qm, B, Z, l, LANES)
