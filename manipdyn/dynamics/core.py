"""The compiled core every algorithm shares: the model in kernel form, 3-vector helpers, and forward
kinematics — the one pass that places the bodies in the world (and gives their velocities), which
placements, Jacobians, J̇, energies, playback and the loop closures all read.

Kernel form (``kernel_arrays``, built once per model): two arrays instead of many (each array argument
of a compiled call costs ~30 ns of dispatch, each reshape inside a kernel as much again):
  I (5, nb) int64        = rows parent, kind, idx_q, idx_v, nv_j (one column per joint: rows are contiguous
                           views, ~40 ns cheaper per call to unpack than strided columns)
  F (4 nb + 1 + m, 3, 3) = blocks of 3×3 numbers:  F[0:nb] R0,  F[nb:2nb] inertia (about the CoM, body axes),
                           F[2nb:3nb] rows [axis; p0; com],  F[3nb:4nb, 0, 0] mass,  F[3nb:4nb, 0, 1] pitch,  F[4nb, 0] −g,
                           F[4nb+1:4nb+1+m] S (nv, 6), padded to m = max(2, 2⌈nv/3⌉) blocks,
                           F[4nb+1+m:] the armature (nv,), padded to whole blocks,
viewed again by ``unpack`` inside the kernels (slices, one reshape).
S holds one row per joint velocity, [linear; angular] in the body frame (``joints.motion_subspace``).

Placement convention (owned here): R maps body coordinates into the parent's (or the world's), x_parent
= R x_body + p; so the chapter's R^i_{i−1} x is Rᵀ x.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .._jit import njit
from ..joints import PRISMATIC, REVOLUTE, joint_placement, joint_velocity, multi_dof, quat_layout, quat_rotation
from ..spatial import SINCOS_MAX, first_nonfinite, sincos


def kernel_arrays(model):
    """(I, F): the model in the kernels' two-array form (``model.Model.kernel``, built with the model)."""
    return model.kernel.arrays


ModelArrays = namedtuple("ModelArrays", "parent kind iq iv nvj S axis R0 p0 mass com inertia mg armature pitch")
ModelArrays.__doc__ = """The model as every kernel reads it (``unpack``), views of Model.kernel's (I, F):
    parent (nb,) int   λ(i), −1 for the fixed base (parent[i] < i)
    kind (nb,) int     the joint's code in the registry (joints.KINDS, joints.IN_MODEL)
    iq, iv (nb,) int   joint i's first entry in q and in v
    nvj (nb,) int      joint i's number of velocities
    S (nv, 6)          motion subspace rows [linear; angular] in the body frame (joints.motion_subspace)
    axis (nb, 3)       joint axis in the body frame
    R0 (nb, 3, 3)      joint frame in the parent body at q = 0;   p0 (nb, 3) its origin
    mass (nb,)         body mass;   com (nb, 3) centre of mass (body frame);   inertia (nb, 3, 3) about the CoM
    mg (3,)            −g, the base acceleration that stands for gravity
    armature (nv,)     rotor inertia per velocity (Model.armature): M + diag(armature), τ += armature ⊙ q̈
    pitch (nb,)        a helical joint's pitch, m/rad (0 for every other kind)"""


@njit(cache=True, inline="always")
def unpack(I, F):
    """The named views (``ModelArrays``) of the two kernel arrays (the layout is Model.kernel's: KernelForm)."""
    nb = I.shape[1]
    nv = I[3, nb - 1] + I[4, nb - 1] if nb else 0        # velocities in body order: the last body's end
    m = max(2, 2 * ((nv + 2) // 3))                      # S's blocks (KernelForm.of)
    B = F[2 * nb:3 * nb]
    return ModelArrays(I[0], I[1], I[2], I[3], I[4], F[4 * nb + 1:4 * nb + 1 + m].reshape(-1, 6)[:nv],
                       B[:, 0], F[:nb], B[:, 1], F[3 * nb:4 * nb, 0, 0], B[:, 2], F[nb:2 * nb], F[4 * nb, 0],
                       F[4 * nb + 1 + m:].reshape(-1)[:nv], F[3 * nb:4 * nb, 0, 1])


# -- forward kinematics: the one pass -----------------------------------------------------------------

@njit(cache=True, inline="always")
def fk_pass(mdl, q, v, Rl, pl, Rw, pw, ww, vw):
    """Forward kinematics of one state (mdl = ``unpack(I, F)``, unpacked once per kernel call). Every body i:
      (Rl, pl)[i]  its placement in its parent (joints.joint_placement),
      (Rw, pw)[i]  in the world: Rw_i = Rw_λ Rl_i, pw_i = pw_λ + Rw_λ pl_i,
    and, when v has entries (len(v) = nv; pass an empty v to skip), its world angular velocity ww_i and
    the world velocity of its origin vw_i:  ω_i = ω_λ + Rw_i S_ang q̇_i,
    v_i = v_λ + ω_λ × (pw_i − pw_λ) + Rw_i S_lin q̇_i  (Eqs. 3–4, 9–11 in world axes)."""
    nb = mdl.parent.shape[0]
    for i in range(nb):
        fk_place(mdl, i, q, Rl, pl, Rw, pw)
    # velocities in a loop of their own: the velocity branch inside the placement loop tripled its cost
    for i in range(nb if v.shape[0] > 0 else 0):
        fk_velocity(mdl, i, v, Rw, pw, ww, vw)


@njit(cache=True, inline="always")
def fk_path(mdl, q, v, tip, path, Rl, pl, Rw, pw, ww, vw):
    """``fk_pass`` for the bodies from the root to body ``tip`` only (its support: what a frame on ``tip``
    depends on; path (nb,) int scratch). Other bodies' entries are left as they were."""
    parent = mdl.parent
    n, j = 0, tip
    while j >= 0:                                    # tip, its parent, …, the root
        path[n] = j
        n += 1
        j = parent[j]
    for k in range(n - 1, -1, -1):
        fk_place(mdl, path[k], q, Rl, pl, Rw, pw)
    for k in range(n - 1 if v.shape[0] > 0 else -1, -1, -1):
        fk_velocity(mdl, path[k], v, Rw, pw, ww, vw)


@njit(cache=True, inline="always")
def fk_place(mdl, i, q, Rl, pl, Rw, pw):
    """Body i's placement in its parent (Rl, pl)[i] and in the world (Rw, pw)[i] (its parent's done first)."""
    parent, kind, iq, axis, pitch, R0, p0 = mdl.parent, mdl.kind, mdl.iq, mdl.axis, mdl.pitch, mdl.R0, mdl.p0
    joint_placement(i, kind, iq, axis, pitch, R0, p0, q, Rl, pl)
    j = parent[i]
    if j < 0:
        for a in range(3):
            for b in range(3):
                Rw[i, a, b] = Rl[i, a, b]
            pw[i, a] = pl[i, a]
    else:
        for a in range(3):
            for b in range(3):
                Rw[i, a, b] = Rw[j, a, 0] * Rl[i, 0, b] + Rw[j, a, 1] * Rl[i, 1, b] + Rw[j, a, 2] * Rl[i, 2, b]
            pw[i, a] = pw[j, a] + Rw[j, a, 0] * pl[i, 0] + Rw[j, a, 1] * pl[i, 1] + Rw[j, a, 2] * pl[i, 2]


@njit(cache=True, inline="always")
def fk_velocity(mdl, i, v, Rw, pw, ww, vw):
    """Body i's world angular velocity ww[i] and origin velocity vw[i] (its parent's done first), without
    scratch arrays: (l, a) = S q̇ of the joint as scalars (joints.joint_velocity)."""
    parent, iv, nvj, S = mdl.parent, mdl.iv, mdl.nvj, mdl.S
    (l0, l1, l2), (a0, a1, a2) = joint_velocity(S, iv[i], nvj[i], v)
    j = parent[i]
    for a in range(3):
        wa = Rw[i, a, 0] * a0 + Rw[i, a, 1] * a1 + Rw[i, a, 2] * a2
        la = Rw[i, a, 0] * l0 + Rw[i, a, 1] * l1 + Rw[i, a, 2] * l2
        ww[i, a] = wa if j < 0 else ww[j, a] + wa
        vw[i, a] = la if j < 0 else vw[j, a] + la
    if j >= 0:                                   # ω_λ × (pw_i − pw_λ)
        dx, dy, dz = pw[i, 0] - pw[j, 0], pw[i, 1] - pw[j, 1], pw[i, 2] - pw[j, 2]
        vw[i, 0] += ww[j, 1] * dz - ww[j, 2] * dy
        vw[i, 1] += ww[j, 2] * dx - ww[j, 0] * dz
        vw[i, 2] += ww[j, 0] * dy - ww[j, 1] * dx


@njit(cache=True, inline="always")
def nonfinite_input(Q, V, s):
    """-1, or the flat index of state s's first non-finite input: s·nq + k in Q, N·nq + s·nv + k in V
    (``spatial.first_nonfinite`` on each row)."""
    k = first_nonfinite(Q, s)
    if k >= 0:
        return s * Q.shape[1] + k
    k = first_nonfinite(V, s)
    if k >= 0:
        return Q.shape[0] * Q.shape[1] + s * V.shape[1] + k
    return -1


@njit(cache=True, inline="always")
def wrench_rows_of(f, m, P):
    """One state's single external wrench as the kernels read it (state.fast_wrenches): X (1, K, 6) =
    [R f; R m], body (K,) and point (K, 3), from the force f (3,), the moment m (3,) and the frame's row P (13,)
    = [R row by row (R turns the frame's axes into the body's), its origin in the body, body]. K = 0 for a
    wrench on the fixed base (it changes no joint torque)."""
    K = 1 if P[12] >= 0 else 0
    X, body, point = np.empty((1, K, 6)), np.empty(K, np.int64), np.empty((K, 3))
    for k in range(K):
        body[k] = int(P[12])
        for r in range(3):
            X[0, k, r] = P[3 * r] * f[0] + P[3 * r + 1] * f[1] + P[3 * r + 2] * f[2]
            X[0, k, 3 + r] = P[3 * r] * m[0] + P[3 * r + 1] * m[1] + P[3 * r + 2] * m[2]
            point[k, r] = P[9 + r]
    return X[:, :, :], body[::1], point[:, :]          # views of the kernels' layout (_jit: "A")


@njit(cache=True, inline="always")
def no_wrenches(I, F):
    """X (1, 0, 3), body (0,), point (0, 3), world = False: no external wrench, in the layout of ``wrench_rows_of``
    — views with no rows of the model's arrays (I, F), so that a one-state call allocates nothing for them (X's
    entries are never read without a wrench); world a run-time bool, not the constant False, for which numba
    would compile anew."""
    return F[:1, :0, :], I[0, :0][::1], F[0, :0, :], np.bool_(False)


@njit(cache=True, inline="always")
def finite_state(Q, V, A, s):
    """True when state s's q, v and a (or τ) are all finite: the check every dynamics kernel makes on entry
    (``spatial.first_nonfinite`` on each row)."""
    return max(first_nonfinite(Q, s), first_nonfinite(V, s), first_nonfinite(A, s)) < 0   # no early exit


# -- lane blocks: a batch as blocks of LANES states, the state index last (the lane kernels, docs/design.md §4c)
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
def shift_code(code, s0, nb, step, size):
    """A kernel's code for the rows s0 … of a batch, as the code of the whole batch: an input's index (≥ 0) +
    s0 · step (1 where the code is a state index, nq where it is a flat index of q), a result's flat index (code
    −2 − nb − k) + s0 · size (the entries per state of the result); −1 as it is."""
    if code >= 0:
        return code + s0 * step
    if code <= -2 - nb:
        return code - s0 * size
    return code


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
def on_lanes(mdl, nq, multi=False):
    """True when the lane steps apply to the model (nq: a state's q entries): every joint is revolute or prismatic
    about z — the z-aligned form the batch routes pass (``Model.kernel.lane_arrays``, model.z_aligned) — or, for a
    kernel whose steps take them (``multi``), a free flyer or a ball joint (``joints.multi_dof``). Any other kind
    (helical, planar) sends the batch to the lane kernel's scalar kernel, which takes every joint of the registry."""
    nb = mdl.parent.shape[0]
    ok = True
    for i in range(nb):
        k = mdl.kind[i]
        if k == REVOLUTE or k == PRISMATIC:
            ok &= mdl.axis[i, 0] == 0.0 and mdl.axis[i, 1] == 0.0 and mdl.axis[i, 2] == 1.0
        else:
            ok &= multi and multi_dof(k)
    return ok and (multi or nq == nb)


@njit(cache=True, inline="always")
def placement_model(i, mdl):
    """What body i's placement takes from the model, once per block (``placement_lane``): in z-aligned frames
    (``on_lanes``) R^{i−1}_i = R0 Rot(z, q), whose rows are (c a_x + s a_y, c a_y − s a_x, a_z) for each row a of
    R0, and p = p0 + d R0 z (R0's last column) for a prismatic joint (its rotation is 1: s = 0, c = 1 from an
    angle of 0). Returns (a0, a1, a2: R0's rows, p0, turn: 1 revolute / 0 prismatic, q's row). (One number for
    both: a fourteenth constant in the loop spilled AVX2's 16 registers, 4–10 % slower.)"""
    R0 = mdl.R0
    a0, a1, a2 = (R0[i, 0, 0], R0[i, 0, 1], R0[i, 0, 2]), (R0[i, 1, 0], R0[i, 1, 1], R0[i, 1, 2]), \
        (R0[i, 2, 0], R0[i, 2, 1], R0[i, 2, 2])
    return a0, a1, a2, (mdl.p0[i, 0], mdl.p0[i, 1], mdl.p0[i, 2]), 1.0 if mdl.kind[i] == REVOLUTE else 0.0, mdl.iq[i]


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
    B[0 * L + l], B[1 * L + l], B[2 * L + l] = c * a0[0] + s * a0[1], c * a0[1] - s * a0[0], a0[2]
    B[3 * L + l], B[4 * L + l], B[5 * L + l] = c * a1[0] + s * a1[1], c * a1[1] - s * a1[0], a1[2]
    B[6 * L + l], B[7 * L + l], B[8 * L + l] = c * a2[0] + s * a2[1], c * a2[1] - s * a2[0], a2[2]
    B[9 * L + l], B[10 * L + l], B[11 * L + l] = o[0] + d * a0[2], o[1] + d * a1[2], o[2] + d * a2[2]


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
def multi_rates(mm, Z, row, l, L):
    """S x of a free flyer (S = 1₆) or a ball joint (S = [0; 1₃]) at lane l, x = q̇ or q̈ from its rows ``row`` … of Z
    (``motion_model``'s rv or ra): the 3-tuples (linear, angular), (x[0:3], x[3:6]) or (0, x[0:3]) — a ball's
    linear part is 0 × its own rates (finite: gather_lanes checked them), so that no branch sits in the lane loop."""
    n = mm[5]
    lin, o = 1.0 if n == 6 else 0.0, n - 3
    x = get3(Z, row, l, L)
    return (lin * x[0], lin * x[1], lin * x[2]), get3(Z, row + o, l, L)


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
    """``placement_lane`` for every lane of the block (a screw joint; a free flyer or ball: ``quat_placement_lanes``)."""
    pm = placement_model(i, mdl)
    for l in range(LANES):
        placement_lane(pm, B, Z, l, LANES)


@njit(cache=True, inline="always")
def quat_placement_lanes(i, mdl, B, Z):
    """``quat_placement_lane`` for every lane of the block."""
    pm = quat_model(i, mdl)
    for l in range(LANES):
        quat_placement_lane(pm, B, Z, l, LANES)


@njit(cache=True)
def fk_kernel(I, F, Q, V, Rw, pw, ww, vw):
    """fk_pass for every state: Q (N, nq), V (N, nv) or (N, 0); Rw (N, nb, 3, 3), pw, ww, vw (N, nb, 3).
    Returns -1, or the flat index (state·nq + entry) of the first non-finite entry of Q (V: + N·nq)."""
    N, nb, mdl = Q.shape[0], I.shape[1], unpack(I, F)
    Rl, pl = np.empty((nb, 3, 3)), np.empty((nb, 3))
    for s in range(N):
        bad = nonfinite_input(Q, V, s)
        if bad >= 0:
            return bad
        fk_pass(mdl, Q[s], V[s], Rl, pl, Rw[s], pw[s], ww[s], vw[s])
    return -1


@njit(cache=True)
def joint_placements_kernel(I, F, Q, R, p):
    """Placement of every body in its parent for every state: R (N, nb, 3, 3), p (N, nb, 3)."""
    mdl = unpack(I, F)
    kind, iq, axis, pitch, R0, p0 = mdl.kind, mdl.iq, mdl.axis, mdl.pitch, mdl.R0, mdl.p0
    for s in range(Q.shape[0]):
        q, Rs, ps = Q[s], R[s], p[s]
        for i in range(I.shape[1]):
            joint_placement(i, kind, iq, axis, pitch, R0, p0, q, Rs, ps)


# -- Python entry points --------------------------------------------------------------------------------

def joint_placements(model, Q):
    """Placement of every body in its parent for a checked batch Q (N, nq): R (nb, N, 3, 3), p (nb, N, 3)."""
    N, nb = Q.shape[0], model.njoints
    R, p = np.empty((N, nb, 3, 3)), np.empty((N, nb, 3))
    if nb:
        joint_placements_kernel(*kernel_arrays(model), np.ascontiguousarray(Q), R, p)
    return np.moveaxis(R, 1, 0), np.moveaxis(p, 1, 0)


def forward_kinematics(model, Q, V=None):
    """World placements of every body for a checked batch Q (N, nq) [and twists for V (N, nv)]:
    R (nb, N, 3, 3), p (nb, N, 3) [, ω (nb, N, 3), v (nb, N, 3) world velocity of each origin]."""
    N, nb = Q.shape[0], model.njoints
    Rw, pw = np.empty((N, nb, 3, 3)), np.empty((N, nb, 3))
    ww, vw = np.empty((N, nb, 3)), np.empty((N, nb, 3))
    Vk = np.empty((N, 0)) if V is None else np.ascontiguousarray(V, float)
    if nb:
        fk_kernel(*kernel_arrays(model), np.ascontiguousarray(Q, float), Vk, Rw, pw, ww, vw)
    out = (np.moveaxis(Rw, 1, 0), np.moveaxis(pw, 1, 0))
    return out if V is None else out + (np.moveaxis(ww, 1, 0), np.moveaxis(vw, 1, 0))
