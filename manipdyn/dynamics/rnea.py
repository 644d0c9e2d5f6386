"""Recursive Newton–Euler inverse dynamics (Luh, Walker & Paul 1980), in the chapter's vector form.

One source: the steps below are the chapter's recursion (Eqs. 3–18 with the errata of docs/design.md §6) on a body's
record — placement (lanes.py), ``motion_lane``, ``inertial_lane``, ``lanes.external_lane``, ``inward_lane`` and their
multi-dof forms — driven across a block of states (``rnea_lanes``, the batch), for one state (``rnea_steps_one``) and
by a GPU thread (gpu.py); compiled by numba, and the same text runs as plain Python under MANIPDYN_NOJIT=1. Every
vector is a 3-vector in its own body frame (the chapter's primes), the frame turned so that a one-dof joint's axis is
z (kernel_form.z_aligned; ``terms_kernel`` turns the per-link terms back into the URDF link frames). (R, p) is body
i in its parent λ(i), so the chapter's R^i_{i−1} x is Rᵀ x (``mul3t``). A tree replaces "link i+1" by the children
of link i; parent[i] < i, so one sweep each way suffices.

The joint enters through its motion subspace S (``joints``: rows [linear; angular], constant in the body frame):
with (vl, va) = S q̇ and (al, aa) = S q̈ of joint i, and w_in, dw_in, dv_in the parent's ω', ω̇', v̇' moved to
body i's origin and axes, the chapter's revolute (Eqs. 3–6) and prismatic (Eqs. 9–12) cases are one formula:

    ω'_i  = w_in + va                                    (Eq. 3; prismatic Eq. 9)
    ω̇'_i  = dw_in + aa + w_in × va                       (Eq. 5; prismatic Eq. 10)
    v̇'_i  = dv_in + al + 2 w_in × vl + va × vl           (Eq. 6; prismatic Eq. 12; free flyer: al + va × vl)
    τ_i   = Sᵀ [f'_i; n'_i]                              (Eqs. 17, 18)

Gravity enters as a base acceleration: ω'_0 = ω̇'_0 = 0, v̇'_0 = −g (docs/design.md §6). A free-flyer root (q = [x y z
qx qy qz qw], v = [linear; angular] in the body frame) is the same recursion: its τ entries are the wrench
[f'; n'] the root body needs, in its own frame about its origin.

External wrenches (f_ext = {frame: (force, moment)}: what the environment applies on that body, about the
frame's origin, in the frame's axes or in world axes) reach the kernel as rows (``arguments.wrench_rows``): the
wrench (N, K, 6) = [force; moment] in body axes ("local") or world axes ("world": turned into the body with the
placements of the outward pass, ``lanes.external_lanes``), the body (K,) and the frame's origin in body axes (K, 3),
about which the moment is taken.
"""
from __future__ import annotations


import numpy as np

from .._jit import A1, A2, A3, CONTRACT, FLAG, I1, MODEL, entry, njit
from ..joints import HELICAL, PLANAR
from . import mimic
from ..spatial import SINCOS_MAX, add, cross, first_nonfinite, mul3, mul3t, put, rot_t, scale, sub, vec
from .kernel_inputs import finite_state, no_wrenches, sized, wrench_rows_of
from .lanes import (LANES, external_lane, external_lanes, gather_lanes, get3, get_rotation, inertial_model, lane_record,
                    motion_model, multi_model, multi_rates, on_lanes, one_lane, placement_lane, placement_lanes,
                    placement_model, planar_placement_lane, quat_model, quat_placement_lane, quat_placement_lanes,
                    scatter_lanes, screw_placement_one, selected, set3, tree_depth, wrench_in_body)
from .model_arrays import unpack
from .route import route
from .arguments import as_batch, check_output, quiet, raise_kernel_error, unbatch, wrench_rows
from .status import OK, WRONG_SIZES, bad_input, bad_result, shift

TERMS = ("w", "dw", "v", "dv", "acc", "dvc", "fc", "nc", "f", "n")   # 3-vectors per link, then R (3, 3)
NT = 3 * len(TERMS) + 9                                            # columns of the per-link terms array
_QVA = ("q", "v", "a")


def rnea_terms(model, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """Every per-link intermediate of the Newton–Euler recursion, in link frames, from the records of the passes that
    give τ (``terms_kernel``).

    Returns a dict of arrays; per-link arrays have shape (N, nb, 3) (or (nb, 3) for one state), nb =
    model.njoints bodies in q order:
      w, dw    ω'_i, ω̇'_i                      (Eqs. 3, 5; prismatic 9, 10)
      v        v'_i, velocity of the frame origin (Eqs. 4, 11)
      dv       v̇'_i, including the −g base offset (Eqs. 6, 12)
      acc      v̇'_i without gravity: the origin's classical linear acceleration
      dvc      v̇'_Ci, including −g                (Eq. 7)
      fc, nc   inertial force m v̇'_Ci and moment I ω̇' + ω' × I ω' about the CoM (Eqs. 13, 14)
      f, n     force and moment link i−1 exerts on link i, about frame i's origin (Eqs. 15, 16)
      R        (N, nb, 3, 3) orientation of each link frame in the base frame
      tau      (N, nv) joint torques/forces (Eqs. 17, 18); a free-flyer root's six entries are its f, n
    """
    (Q, V, A), single = as_batch(model, q=q, v=v, a=a)
    tau, T = _run(model, Q, V, A, f_ext, f_ext_frame, "rnea_terms")
    out = {k: T[:, :, 3 * m:3 * m + 3] for m, k in enumerate(TERMS)}
    out["R"] = T[:, :, 3 * len(TERMS):].reshape(T.shape[:2] + (3, 3))
    inputs = dict(q=Q, v=V, a=A)
    for k, x in out.items():
        check_output("rnea_terms", k, x, model, inputs, "link")
    out["tau"] = tau
    return {k: unbatch(x, single) for k, x in out.items()}


@quiet
def _run(model, Q, V, A, f_ext, f_ext_frame, call):
    """``terms_kernel`` on checked batches Q (N, nq), V, A (N, nv): τ (N, nv) and the per-link terms (N, nb, NT);
    f_ext checked and converted first (in the z-aligned frames the kernel reads)."""
    N, nb = Q.shape[0], model.njoints
    X, body, point = wrench_rows(model, f_ext, f_ext_frame, N, True)
    tau, T = np.zeros((N, model.nv)), np.zeros((N, nb, NT))
    if nb == 0:
        return tau, T
    code = TERMS_ENTRY.call(*model.kernel.lane_arrays, Q, V, A, X, body, point, f_ext_frame == "world", tau, T)
    if code != -1:
        raise_kernel_error(model, code, _QVA, (Q, V, A), call, "tau", tau)
    return tau, T


# -- the kernel -----------------------------------------------------------------------------------------------
# 3-vectors inside the recursion are 3-tuples (spatial.py's vec, put, add, cross, rot, rot_t).


@njit(cache=True, inline="always")
def steps_scratch(nb, nq, nv):
    """The scratch of ``rnea_steps_one`` for nb bodies, nq coordinates and nv velocities: the bodies' records
    (nb · RECORD), then q, q̇, q̈ (nq + 2 nv), then the base (9). (Sizes, not a state's rows: a batch may have none.)"""
    return np.empty(nb * RECORD + nq + 2 * nv + 9)


@njit(cache=True)
def rnea_one(I, F, q, v, a, tau):
    """τ (nv,) of one state q (nq,), v, a (nv,), no external wrench, into tau: the lane kernel's steps driven for one
    state (``rnea_steps_one``; (I, F) in z-aligned frames, ``Model.kernel.lane_arrays``)."""
    if not sized(I, q, (v, a, tau)):
        return WRONG_SIZES
    X, xb, xp, world = no_wrenches(I, F)
    return rnea_steps_one(I, F, q, v, a, X[0], xb, xp, world, tau,
                          steps_scratch(I.shape[1], q.shape[0], v.shape[0]))


@njit(cache=True)
def rnea_fext_one(I, F, q, v, a, f, m, P, world, tau):
    """τ (nv,) of one state with one external wrench in ``arguments.fast_wrenches``' form (the wrench in z-aligned
    frames, as (I, F)): ``rnea_steps_one``."""
    if not (sized(I, q, (v, a, tau)) and f.shape[0] == 3 and m.shape[0] == 3 and P.shape[0] == 13):
        return WRONG_SIZES
    X, xb, xp = wrench_rows_of(f, m, P)
    return rnea_steps_one(I, F, q, v, a, X[0], xb, xp, world, tau,
                          steps_scratch(I.shape[1], q.shape[0], tau.shape[0]))


@njit(cache=True)
def bias_kernel(I, F, Q, V, tau):
    """τ = rnea(q, v, 0) for every state of a batch Q (N, nq), V (N, nv) — rnea(q, 0, 0) when V has no columns —
    into tau (N, nv): the batch kernel ``rnea_lanes`` with zero accelerations."""
    Z = np.zeros(tau.shape)[:, :]
    X, xb, xp, world = no_wrenches(I, F)
    return rnea_lanes(I, F, Q, Z if V.shape[1] == 0 else V, Z, X, xb, xp, world, tau)


@njit(cache=True)
def gravity_kernel(I, F, Q, tau):
    """τ = rnea(q, 0, 0) for every state of a batch Q (N, nq): ``bias_kernel`` without velocities."""
    return bias_kernel(I, F, Q, Q[:, :0], tau)


@njit(cache=True)
def bias_one(I, F, q, v, tau):
    """One state q (nq,), v, tau (nv,): ``bias_steps``."""
    if not sized(I, q, (v, tau)):
        return WRONG_SIZES
    return bias_steps(I, F, q, v, tau)


@njit(cache=True, inline="always")
def bias_steps(I, F, q, v, tau):
    """One state q (nq,), v (nv,) — or v with no entries: rnea(q, 0, 0) —, tau (nv,): ``rnea_steps_one`` with zero
    accelerations ((I, F) in z-aligned frames)."""
    Z = np.zeros((1, tau.shape[0]))[:, :][0]         # (a view of any layout, as the entry's arrays: one signature)
    X, xb, xp, world = no_wrenches(I, F)
    return rnea_steps_one(I, F, q, Z if v.shape[0] == 0 else v, Z, X[0], xb, xp, world, tau,
                          steps_scratch(I.shape[1], q.shape[0], tau.shape[0]))


@njit(cache=True)
def gravity_one(I, F, q, tau):
    """One state q (nq,), tau (nv,): ``bias_steps`` without velocities."""
    if not sized(I, q, (tau,)):
        return WRONG_SIZES
    return bias_steps(I, F, q, q[:0], tau)


@njit(cache=True, inline="always")
def outward_one(mdl, q, v, a, W):
    """The outward pass of one state (Eqs. 3–14) on one-lane records in W (``steps_scratch``: the bodies' records,
    then q, q̇, q̈, then the base): placement, ω'_i, ω̇'_i, v̇'_i and the inertial wrench of every body, in z-aligned
    frames (a model in another form raises). False for a non-finite q, q̇ or q̈. ``rnea_steps_one``'s first pass, and
    what the regressor reads (regressor.py)."""
    nb, nq, nv = mdl.parent.shape[0], q.shape[0], v.shape[0]
    if not on_lanes(mdl, nq, True):
        raise ValueError("the RNEA's steps take a model in z-aligned frames (Model.kernel.lane_arrays)")
    if not finite_state(q[np.newaxis, :], v[np.newaxis, :], a[np.newaxis, :], 0):
        return False
    Rec, Z, base = W[:nb * RECORD], W[nb * RECORD:nb * RECORD + nq + 2 * nv], W[nb * RECORD + nq + 2 * nv:]
    one_lane(q, v, a, Z, base, mdl.mg)
    mg = (mdl.mg[0], mdl.mg[1], mdl.mg[2])
    for i in range(nb):                                             # outward, Eqs. 3–14
        j, B = mdl.parent[i], Rec[i * RECORD:(i + 1) * RECORD]
        par = base if j < 0 else Rec[j * RECORD + _W:j * RECORD + _W + 9]
        if mdl.nvj[i] > 1:                                          # a free flyer, a ball, a planar joint
            if mdl.kind[i] == PLANAR:
                planar_placement_lane(placement_model(i, mdl), B, Z, 0, 1)
            else:
                quat_placement_lane(quat_model(i, mdl), B, Z, 0, 1)
            motion_lane_multi(multi_model(i, mdl, nq), B, par, Z, 0, 1)
        else:
            mm = motion_model(i, mdl, nq)
            screw_placement_one(i, mdl, B, Z)
            if j < 0:
                root_motion_lane(mm, B, mg, Z, 0, 1)
            else:
                motion_lane(mm, B, par, Z, 0, 1)
        inertial_lane(inertial_model(i, mdl), B, 0, 1)
    return True


@njit(cache=True, fastmath=CONTRACT)
def rnea_steps_one(I, F, q, v, a, X, xb, xp, world, tau, W):
    """τ (nv,) of one state by the steps of the lane kernel (``rnea_lanes``), driven for one lane: records of one
    number a row (L = 1), the same placement, motion, inertial, wrench and torque steps, the same z-aligned frames
    ((I, F) = ``Model.kernel.lane_arrays``: another form raises) — one source for a batch and for one state.
    Measured: AAU arm 411 against 905 ns a state for the scalar kernel in a compiled loop (docs/bench/measurements.md).
    External wrenches X (K, 6) on bodies xb about their points xp, in the bodies' z-aligned axes or (world) in world
    axes, between the passes (as ``external_lanes``; K = 0 for none: ``kernel_inputs.no_wrenches``). An angle beyond
    ``spatial.SINCOS_MAX`` is placed with libm's sin and cos (``lanes.screw_placement_one``). Returns its status
    (dynamics/status.py): a non-finite q, q̇ or q̈, or τ's first non-finite entry. W: scratch of ``steps_scratch``
    (its first nb · RECORD numbers, the bodies' records, are what ``terms_kernel`` reads after the passes)."""
    mdl = unpack(I, F)
    nb, nq, nv = I.shape[1], q.shape[0], v.shape[0]
    if not outward_one(mdl, q, v, a, W):                            # outward, Eqs. 3–14
        return bad_input(0)
    Rec, Z = W[:nb * RECORD], W[nb * RECORD:nb * RECORD + nq + 2 * nv]
    for k in range(xb.shape[0]):                                    # external wrenches (as external_lanes)
        fe, ne = wrench_in_body(mdl.parent, Rec, RECORD, X, k, xb[k], world)
        external_lane(Rec[xb[k] * RECORD:(xb[k] + 1) * RECORD], _F, fe, ne, (xp[k, 0], xp[k, 1], xp[k, 2]), 0, 1)
    for i in range(nb - 1, -1, -1):                                 # inward, Eqs. 15–18
        j, B = mdl.parent[i], Rec[i * RECORD:(i + 1) * RECORD]
        to = Rec[:0] if j < 0 else Rec[j * RECORD + _F:j * RECORD + _F + 6]
        r, n = mdl.iv[i], mdl.nvj[i]
        if n > 1:
            mm = multi_model(i, mdl, nq)
            for k in range(n):
                torque_multi_lane(mm, k, _F + selected(n, mdl.kind[i] == PLANAR, k), mdl.armature[r + k], B, tau, Z, 0, 1)
            if j >= 0:
                wrench_up_lane(B, to, 0, 1)
        elif j < 0:
            torque_lane(motion_model(i, mdl, nq), mdl.armature[r], B, tau, Z, 0, 1)
        else:
            inward_lane(motion_model(i, mdl, nq), mdl.armature[r], B, to, tau, Z, 0, 1)
    k = first_nonfinite(tau[np.newaxis, :], 0)                      # (an intermediate overflowed)
    return OK if k < 0 else bad_result(nb, k)


# -- the lane kernel: the same recursion across a block of states ------------------------------------------------
# A batch runs as blocks of LANES states (lanes.gather_lanes: the state index last). For each body, one loop over
# the block's lanes does what ``outward`` does for one state, and the compiler turns it into vector instructions
# (4 states per instruction with AVX2); ``sincos`` replaces libm's sin and cos, which would keep it scalar.
# A body's record (RECORD rows of LANES numbers): R^{i−1}_i (9, row-major), p^{i−1}_i (3), ω'_i, ω̇'_i, v̇'_i,
# f'_i, n'_i (3 each). Records live in two arrays by the parity of the body's depth in the tree: body i writes its
# own and reads its parent's, in the other array — two arrays the compiler can check for overlap once per loop,
# where rows of one array at run-time offsets made it give up vectorising (docs/design.md §4c).
RECORD = 27                 # rows of a body's record: R 0–8, p 9–11, ω' 12–14, ω̇' 15–17, v̇' 18–20, f' 21–23, n' 24–26
_W, _F = 12, 21             # the first rows of ω' (the motion a child reads) and of f' (the wrench a child adds to)


@njit(cache=True, fastmath=CONTRACT)
def rnea_lanes(I, F, Q, V, A, X, xb, xp, world, tau):
    """τ (N, nv) for every state, block by block across lanes: the batch entry of rnea (its status as
    ``rnea_steps_one``'s, the state shifted). X (N, K, 6): the wrenches of each state (``arguments.wrench_rows``), or
    one row for every state (K = 0: ``kernel_inputs.no_wrenches``).

    External wrenches are taken from the bodies between the two passes (``external_lanes``). (I, F): the model in
    z-aligned frames (``Model.kernel.lane_arrays``: another form raises). A block with a non-finite input or
    result or an angle beyond ``spatial.SINCOS_MAX`` runs its states one by one as a one-state call does
    (``rnea_steps_one``): its status names the state or entry. Every lane is computed alone, so a state's τ does not
    depend on the batch around it; it agrees with the one-state call's to rounding (tests/batch/test_lanes.py).
    """
    N, nb, nq, nv = Q.shape[0], I.shape[1], Q.shape[1], V.shape[1]
    if not on_lanes(unpack(I, F), nq, True):
        raise ValueError("the RNEA's steps take a model in z-aligned frames (Model.kernel.lane_arrays)")
    Im, Fm = I, F               # as given (read-only): the one-state steps' signature
    I, F = I.copy(), F.copy()   # the model for this call alone: its views, passed to the body functions, are counted
    mdl = unpack(I, F)          # references, and threads sharing one array contend for its count (measured: two
    #                             threads on one model 0.68–0.83 of one thread's time, on copies 0.53–0.55)
    parent = mdl.parent
    even, odd = np.empty(nb * RECORD * LANES), np.empty(nb * RECORD * LANES)   # records by depth parity
    base = np.zeros(9 * LANES)                  # the fixed base as a parent: ω' = ω̇' = 0, v̇' = −g (docs §6)
    for l in range(LANES):
        base[6 * LANES + l], base[7 * LANES + l], base[8 * LANES + l] = mdl.mg[0], mdl.mg[1], mdl.mg[2]
    Z, TB = np.empty((nq + 2 * nv) * LANES), np.empty(nv * LANES)  # q, q̇, q̈ and τ of the block, state index last
    W, path = np.empty(6 * LANES), np.empty(nb, np.int64)      # a wrench of the block, a body's path (external_lanes)
    depth = tree_depth(parent)
    for s0 in range(0, N, LANES):
        n = min(LANES, N - s0)
        ok = gather_lanes(Q, s0, n, Z, 0, SINCOS_MAX) & gather_lanes(V, s0, n, Z, nq) \
            & gather_lanes(A, s0, n, Z, nq + nv)
        if ok:
            for i in range(nb):                                          # outward, Eqs. 3–14
                j = parent[i]
                par = base if j < 0 else lane_record(even, odd, depth, j, RECORD)[_W * LANES:(_W + 9) * LANES]
                B = lane_record(even, odd, depth, i, RECORD)
                if mdl.nvj[i] > 1 or mdl.kind[i] == HELICAL:            # a free flyer, a ball, a planar, a helical
                    outward_multi_lanes(i, mdl, B, par, Z, nq)
                else:
                    outward_lanes(i, mdl, B, par, Z, nq)
            if xb.shape[0] > 0:
                external_lanes(mdl.parent, even, odd, depth, RECORD, _F, X, s0, n, xb, xp, world, W, path)
            for i in range(nb - 1, -1, -1):                              # inward, Eqs. 15–18
                j = parent[i]                                            # (a root's ``to`` is not read)
                to = TB if j < 0 else lane_record(even, odd, depth, j, RECORD)[_F * LANES:(_F + 6) * LANES]
                B = lane_record(even, odd, depth, i, RECORD)
                if mdl.nvj[i] > 1:
                    inward_multi_lanes(i, mdl, B, to, TB, Z, nq)
                else:
                    inward_lanes(i, mdl, B, to, TB, Z, nq)
            ok = scatter_lanes(TB, n, tau, s0)
        if not ok:                                  # each state as a one-state call computes it: its status
            for s in range(s0, s0 + n):             # names the culprit
                code = rnea_steps_one(Im, Fm, Q[s], V[s], A[s], X[s if X.shape[0] > 1 else 0], xb, xp, world, tau[s],
                                      steps_scratch(nb, nq, nv))
                if code != OK:
                    return shift(code, s, nb, nv)
    return OK


@njit(cache=True, fastmath=CONTRACT)
def outward_lanes(i, mdl, B, par, Z, nq):
    """Body i's record B for every lane of the block (Eqs. 3–14, as ``outward`` and ``inertial`` for one state):
    its placement, then ω'_i, ω̇'_i, v̇'_i from the parent's (par: 9 rows ω', ω̇', v̇'; the base's for a root), then
    f'_i = m v̇'_C and n'_i = I ω̇' + ω' × I ω' + p_C × f'_C. Z: the block's q, q̇, q̈ (lanes.gather_lanes; nq rows of
    q). Three loops, not one: the model's numbers that each needs fit in the vector registers (one loop spilled
    them: 13.7 → 11.5 ns per lane). A revolute or prismatic joint's placement is written out here
    (``lanes.placement_lane``); a helical joint's slide (``lanes.placement_lanes``) goes by ``outward_multi_lanes``:
    with it in this function, or in the kernel's body loop, the arms' RNEA measured 6–7 % slower."""
    pm = placement_model(i, mdl)
    for l in range(LANES):
        placement_lane(pm, B, Z, l, LANES)
    mm, im = motion_model(i, mdl, nq), inertial_model(i, mdl)
    if mdl.parent[i] < 0:
        mg = (mdl.mg[0], mdl.mg[1], mdl.mg[2])
        for l in range(LANES):
            root_motion_lane(mm, B, mg, Z, l, LANES)
    else:
        for l in range(LANES):
            motion_lane(mm, B, par, Z, l, LANES)
    for l in range(LANES):
        inertial_lane(im, B, l, LANES)


@njit(cache=True, fastmath=CONTRACT)
def outward_multi_lanes(i, mdl, B, par, Z, nq):
    """``outward_lanes`` for a free flyer, a ball or a planar joint: its quaternion (planar: cos, sin) placement
    (``lanes.quat_placement_lanes``), then ``motion_lane_multi`` and ``inertial_lane``; and for a helical joint, its turn and slide (``lanes.
    placement_lanes``), then ``motion_lane``. (A function of its own: the revolute and prismatic joints' loops
    compile as they would alone — with these in the same function the RNEA's lanes measured 4–7 % slower on ur5.)"""
    im = inertial_model(i, mdl)
    if mdl.nvj[i] > 1:
        quat_placement_lanes(i, mdl, B, Z)
        mm = multi_model(i, mdl, nq)
        for l in range(LANES):
            motion_lane_multi(mm, B, par, Z, l, LANES)
    else:
        mm = motion_model(i, mdl, nq)
        placement_lanes(i, mdl, B, Z)
        if mdl.parent[i] < 0:
            mg = (mdl.mg[0], mdl.mg[1], mdl.mg[2])
            for l in range(LANES):
                root_motion_lane(mm, B, mg, Z, l, LANES)
        else:
            for l in range(LANES):
                motion_lane(mm, B, par, Z, l, LANES)
    for l in range(LANES):
        inertial_lane(im, B, l, LANES)


@njit(cache=True, inline="always")
def motion_lane(mm, B, par, Z, l, L):
    """ω'_i, ω̇'_i, v̇'_i (Eqs. 3, 5, 6; prismatic 9, 10, 12, as ``outward``) into rows 12–20 of B at lane l, from the
    placement (rows 0–11) and the parent's (par: 9 rows ω', ω̇', v̇'); mm: ``motion_model``."""
    _, sl, sa, rv, ra, _ = mm
    R, p = get_rotation(B, l, L), get3(B, 9, l, L)
    w0, dw0, dv0 = get3(par, 0, l, L), get3(par, 3, l, L), get3(par, 6, l, L)
    w_in = mul3t(R, w0)                                    # R^i_{i−1} ω'_{i−1}
    dw_in = mul3t(R, dw0)
    dv_in = mul3t(R, add(dv0, add(cross(dw0, p), cross(w0, cross(w0, p)))))    # Eq. 6 (32c)
    qd, qdd = Z[rv * L + l], Z[ra * L + l]
    vl, va = qd * sl[2], qd * sa[2]             # the joint's rate along z'_i (z-aligned frames: S = [0 0 s_l; 0 0 s_a])
    w = (w_in[0], w_in[1], w_in[2] + va)                                          # Eq. 3
    dw = (dw_in[0] + w_in[1] * va, dw_in[1] - w_in[0] * va, dw_in[2] + qdd * sa[2])   # Eq. 5: + ω' × q̇ z'
    dv = (dv_in[0] + 2.0 * w_in[1] * vl, dv_in[1] - 2.0 * w_in[0] * vl, dv_in[2] + qdd * sl[2])   # Eqs. 6, 12
    set3(B, 12, l, L, w)
    set3(B, 15, l, L, dw)
    set3(B, 18, l, L, dv)


@njit(cache=True, inline="always")
def motion_in(B, par, l, L):
    """The parent's ω', ω̇', v̇' (par: 9 rows) moved to body i's origin and axes at lane l, from body i's placement
    (rows 0–11 of B): R^i_{i−1} ω'_{i−1}, R^i_{i−1} ω̇'_{i−1} and R^i_{i−1} (v̇'_{i−1} + ω̇'_{i−1} × p + ω'_{i−1} × (ω'_{i−1}
    × p)) (Eqs. 3, 5, 6; 32c)."""
    R, p = get_rotation(B, l, L), get3(B, 9, l, L)
    w0, dw0, dv0 = get3(par, 0, l, L), get3(par, 3, l, L), get3(par, 6, l, L)
    return mul3t(R, w0), mul3t(R, dw0), mul3t(R, add(dv0, add(cross(dw0, p), cross(w0, cross(w0, p)))))


@njit(cache=True, inline="always")
def motion_lane_multi(mm, B, par, Z, l, L):
    """``motion_lane`` for a free flyer (n = 6, S = 1₆), a ball (n = 3, S = [0; 1₃]) or a planar joint (S's rows
    e_x, e_y | e_z), rows 12–20 of B at lane l (mm: ``lanes.multi_model``): S q̇ = (v_l, v_a) (``lanes.multi_rates``),
    constant in the body's frame, in the general form of Eqs. 3, 5, 6 (``outward``):
    ω' = w_in + v_a,  ω̇' = ω̇_in + a_a + w_in × v_a,  v̇' = v̇_in + a_l + 2 w_in × v_l + v_a × v_l."""
    w_in, dw_in, dv_in = motion_in(B, par, l, L)
    vl, va = multi_rates(mm, Z, mm[3], l, L)
    al, aa = multi_rates(mm, Z, mm[4], l, L)
    set3(B, 12, l, L, add(w_in, va))                                              # Eq. 3
    set3(B, 15, l, L, add(add(dw_in, aa), cross(w_in, va)))                       # Eq. 5
    set3(B, 18, l, L, add(add(dv_in, al), add(scale(2.0, cross(w_in, vl)), cross(va, vl))))   # Eq. 6


@njit(cache=True, inline="always")
def root_motion_lane(mm, B, mg, Z, l, L):
    """``motion_lane`` for a body on the fixed base, whose ω' and ω̇' are 0 and v̇' = −g (mg, docs/design.md §6):
    ω' = q̇ z', ω̇' = q̈ z', v̇' = Rᵀ(−g) + q̈ z' (prismatic)."""
    _, sl, sa, rv, ra, _ = mm
    qd, qdd = Z[rv * L + l], Z[ra * L + l]
    dv_in = mul3t(get_rotation(B, l, L), mg)
    set3(B, 12, l, L, (0.0, 0.0, qd * sa[2]))
    set3(B, 15, l, L, (0.0, 0.0, qdd * sa[2]))
    set3(B, 18, l, L, (dv_in[0], dv_in[1], dv_in[2] + qdd * sl[2]))


@njit(cache=True, inline="always")
def inertial_lane(im, B, l, L):
    """f'_i = m v̇'_C and n'_i (about the origin) into rows 21–26 of B at lane l (Eqs. 7, 13, 14 and Eq. 16's CoM term,
    as ``inertial``); im: ``inertial_model``."""
    m, cm, J = im
    w, dw, dv = get3(B, 12, l, L), get3(B, 15, l, L), get3(B, 18, l, L)
    fc = scale(m, add(dv, add(cross(dw, cm), cross(w, cross(w, cm)))))          # Eqs. 7, 13
    nc = add(mul3(J, dw), cross(w, mul3(J, w)))                                  # Eq. 14
    set3(B, 21, l, L, fc)
    set3(B, 24, l, L, add(nc, cross(cm, fc)))


@njit(cache=True, fastmath=CONTRACT)
def inward_lanes(i, mdl, B, to, TB, Z, nq):
    """``inward_lane`` for every lane of the block; a body on the fixed base, whose wrench the base takes, its τ
    alone (``torque_lane``). (A free flyer or a ball: ``inward_multi_lanes``.)"""
    mm, ar = motion_model(i, mdl, nq), mdl.armature[mdl.iv[i]]
    if mdl.parent[i] < 0:
        for l in range(LANES):
            torque_lane(mm, ar, B, TB, Z, l, LANES)
    else:
        for l in range(LANES):
            inward_lane(mm, ar, B, to, TB, Z, l, LANES)


@njit(cache=True, fastmath=CONTRACT)
def inward_multi_lanes(i, mdl, B, to, TB, Z, nq):
    """``inward_lanes`` for a free flyer, a ball or a planar joint (n velocities): τ = Sᵀ [f'; n'] + armature ⊙ q̈,
    the rows of [f'; n'] that S selects plus the rotor terms (``torque_multi_lane``), then ``wrench_up_lane`` unless
    the base takes the wrench."""
    mm = multi_model(i, mdl, nq)
    r, n = mm[0], mm[5]
    for k in range(n):
        ak, src = mdl.armature[r + k], _F + selected(n, mdl.kind[i] == PLANAR, k)
        for l in range(LANES):
            torque_multi_lane(mm, k, src, ak, B, TB, Z, l, LANES)
    if mdl.parent[i] >= 0:
        for l in range(LANES):
            wrench_up_lane(B, to, l, LANES)


@njit(cache=True, inline="always")
def torque_multi_lane(mm, k, src, ak, B, TB, Z, l, L):
    """τ's row iv_i + k of a free flyer, a ball or a planar joint at lane l (mm: ``lanes.multi_model``): row src of
    the record, the entry of [f'_i; n'_i] that S's row k selects (``lanes.selected``), + armature · q̈ (Eqs. 17, 18 and
    ``rotor``); ak: the armature of that velocity."""
    r, ra = mm[0], mm[4]
    TB[(r + k) * L + l] = B[src * L + l] + ak * Z[(ra + k) * L + l]


@njit(cache=True, inline="always")
def torque_lane(mm, ar, B, TB, Z, l, L):
    """τ_i = z'ᵀ f'_i (prismatic) or z'ᵀ n'_i (revolute) + armature_i q̈_i (Eqs. 17, 18; the rotor term as ``rotor``)
    into row iv_i of TB at lane l (z-aligned frames: S = [0 0 s_l; 0 0 s_a]); mm: ``motion_model``."""
    r, sl, sa, _, ra, _ = mm
    TB[r * L + l] = sl[2] * B[(_F + 2) * L + l] + sa[2] * B[(_F + 5) * L + l] + ar * Z[ra * L + l]


@njit(cache=True, inline="always")
def inward_lane(mm, ar, B, to, TB, Z, l, L):
    """τ_i = Sᵀ [f'_i; n'_i] + armature_i q̈_i (Eqs. 17, 18; the rotor term as ``rotor``) into row iv_i of TB, and the
    parent's f', n' (``to``: 6 rows) += R f'_i, R n'_i + p × R f'_i (Eqs. 15, 16), at lane l, as ``inward`` and
    ``rotor`` for one state; mm: ``motion_model``, ar: joint i's armature, Z: the block's q, q̇, q̈. (``wrench_up_lane``
    written out, f' and n' loaded ahead of the torque: as torque_lane + wrench_up_lane, together with motion_lane
    calling motion_in, the lane RNEA measured 4–6 % slower on ur5; which of the two did it is not yet separated.)"""
    f, n = get3(B, 21, l, L), get3(B, 24, l, L)
    torque_lane(mm, ar, B, TB, Z, l, L)
    R = get_rotation(B, l, L)
    Rf, Rn = mul3(R, f), mul3(R, n)
    n_up = add(Rn, cross(get3(B, 9, l, L), Rf))
    to[l] += Rf[0]
    to[L + l] += Rf[1]
    to[2 * L + l] += Rf[2]
    to[3 * L + l] += n_up[0]
    to[4 * L + l] += n_up[1]
    to[5 * L + l] += n_up[2]


@njit(cache=True, inline="always")
def wrench_up_lane(B, to, l, L):
    """The parent's f', n' (``to``: 6 rows) += R f'_i, R n'_i + p × R f'_i at lane l (Eqs. 15, 16)."""
    f, n = get3(B, 21, l, L), get3(B, 24, l, L)
    R = get_rotation(B, l, L)
    Rf, Rn = mul3(R, f), mul3(R, n)
    n_up = add(Rn, cross(get3(B, 9, l, L), Rf))
    to[l] += Rf[0]
    to[L + l] += Rf[1]
    to[2 * L + l] += Rf[2]
    to[3 * L + l] += n_up[0]
    to[4 * L + l] += n_up[1]
    to[5 * L + l] += n_up[2]


@njit(cache=True, fastmath=CONTRACT)
def terms_kernel(I, F, Q, V, A, X, xb, xp, world, tau, T):
    """τ (N, nv) and the per-link terms T (N, nb, NT) = [TERMS, then the link's world orientation R row by row] of every
    state: the records of the one-lane driver's passes (``rnea_steps_one``, in z-aligned frames: (I, F) =
    ``Model.kernel.lane_arrays``, the wrenches in those frames) turned into each link's own axes, x = C_i x'
    (C_i: the model's ``turn``, ``model_arrays``; the origin is the link's), with what no torque needs accumulated
    outward from them: the origin's velocity v'_i = Rᵀ (v'_λ + ω'_λ × p) + S_l q̇ (Eqs. 4, 11), v̇'_C, f'_C and n'_C
    (Eqs. 7, 13, 14), the world orientation Rw_i = Rw_λ R and v̇' without the −g of v̇'_0. Its status as
    ``rnea_steps_one``'s, the state shifted."""
    mdl = unpack(I, F)
    N, nb, nv = Q.shape[0], I.shape[1], V.shape[1]
    W, Rw, vel = steps_scratch(nb, Q.shape[1], nv), np.empty((nb, 3, 3)), np.empty((nb, 3))
    mg = (mdl.mg[0], mdl.mg[1], mdl.mg[2])
    for s in range(N):
        code = rnea_steps_one(I, F, Q[s], V[s], A[s], X[s if X.shape[0] > 1 else 0], xb, xp, world, tau[s], W)
        if code != OK:
            return shift(code, s, nb, nv)
        for i in range(nb):
            j, B = mdl.parent[i], W[i * RECORD:(i + 1) * RECORD]
            R, p, w, dw, dv = get_rotation(B, 0, 1), get3(B, 9, 0, 1), get3(B, 12, 0, 1), get3(B, 15, 0, 1), \
                get3(B, 18, 0, 1)
            v = (0.0, 0.0, 0.0)
            for r in range(mdl.iv[i], mdl.iv[i] + mdl.nvj[i]):                       # S_l q̇
                v = add(v, scale(V[s, r], (mdl.S[r, 0], mdl.S[r, 1], mdl.S[r, 2])))
            if j >= 0:                                                              # Eq. 4
                v = add(v, mul3t(R, add(vec(vel, j), cross(get3(W[j * RECORD:(j + 1) * RECORD], 12, 0, 1), p))))
            put(vel, i, v)
            for r in range(3):
                for c in range(3):
                    Rw[i, r, c] = R[r][c] if j < 0 else \
                        Rw[j, r, 0] * R[0][c] + Rw[j, r, 1] * R[1][c] + Rw[j, r, 2] * R[2][c]
            m, cm, J = inertial_model(i, mdl)
            dvc = add(dv, add(cross(dw, cm), cross(w, cross(w, cm))))                # Eq. 7
            fc = scale(m, dvc)                                                       # Eq. 13
            nc = add(mul3(J, dw), cross(w, mul3(J, w)))                              # Eq. 14
            acc = sub(dv, rot_t(Rw, i, mg))
            C = mdl.turn[i]
            Ci = ((C[0, 0], C[0, 1], C[0, 2]), (C[1, 0], C[1, 1], C[1, 2]), (C[2, 0], C[2, 1], C[2, 2]))
            for k, x in enumerate((w, dw, v, dv, acc, dvc, fc, nc, get3(B, _F, 0, 1), get3(B, _F + 3, 0, 1))):
                T[s, i, 3 * k], T[s, i, 3 * k + 1], T[s, i, 3 * k + 2] = mul3(Ci, x)
            for r in range(3):                                                       # Rw_i C_iᵀ: the link's
                for c in range(3):
                    T[s, i, 30 + 3 * r + c] = Rw[i, r, 0] * C[c, 0] + Rw[i, r, 1] * C[c, 1] + Rw[i, r, 2] * C[c, 2]
    return OK


# The compiled code every batch reaches (``_jit.entry``; arrays of any strides). The scalar batch kernel had a
# second entry compiled for C-ordered arrays (4 % faster); the lane kernel reads its inputs once per block, and
# its C-ordered twin measured 4–6 % slower (ur5 109 vs 113 ns a state), so it has one entry like every kernel.
RNEA = entry(rnea_lanes, *MODEL, A2, A2, A2, A3, I1, A2, FLAG, A2)
TERMS_ENTRY = entry(terms_kernel, *MODEL, A2, A2, A2, A3, I1, A2, FLAG, A2, A3)



# -- the public calls: each is its route (dynamics/route.py) ---------------------------------------------------

@route("rnea", _QVA, "tau", "v", entry(rnea_one, *MODEL, A1, A1, A1, A1), RNEA,
       wrenches=True, lanes=True, one_lanes=True,
       wrench_one=entry(rnea_fext_one, *MODEL, A1, A1, A1, A1, A1, A1, FLAG, A1),
       mimic=lambda mm, *x, **kw: mimic.generalized_force(mm, rnea, *x, **kw))
def rnea(model, q, v, a, *, f_ext=None, f_ext_frame="local", threads=None, out=None):
    """τ = M(q) q̈ + C(q, q̇) q̇ + g(q) − Σ J_kᵀ f_ext,k, by the chapter's Eqs. 3–18 (32a–i).

    Parameters
    ----------
    q : (nq,) or (N, nq) configuration; v, a : (nv,) or (N, nv) rates and accelerations (model.v_names order).
    f_ext : {link or frame name: (force (3,)|(N, 3), moment (3,)|(N, 3))}, wrench the environment applies
        on that body about the frame's origin, in the frame's axes (f_ext_frame="local") or world axes.
    threads : a batch is cut into chunks run on this many threads at once (default None: every core; batches
        of fewer than 256 states run on one; dynamics/route.py); the numbers are those of one thread.
    out : a writeable float64 array of the result's shape ((nv,) or (N, nv)) to write tau into, and return:
        no new array a call (a loop's buffer, reused); any memory layout, no memory shared with q, v, a. If the
        call raises, its contents are undefined.
    Returns
    -------
    tau : (nv,) or (N, nv) joint torques (revolute), forces (prismatic), root wrench [f; n] (free flyer); ``out``
        when given.
    """


@route("nonlinear_effects", ("q", "v"), "h", "v", entry(bias_one, *MODEL, A1, A1, A1),
       entry(bias_kernel, *MODEL, A2, A2, A2), lanes=True, one_lanes=True,
       mimic=lambda mm, q, v: mimic.generalized_force(mm, rnea, q, v))
def nonlinear_effects(model, q, v, *, threads=None, out=None):
    """h = C(q, q̇) q̇ + g(q) (nv,) or (N, nv): the Newton–Euler recursion with q̈ = 0 (Pinocchio's
    nonLinearEffects), τ = M q̈ + h. threads, out: ``rnea``'s."""


@route("gravity_torques", ("q",), "g", "v", entry(gravity_one, *MODEL, A1, A1), entry(gravity_kernel, *MODEL, A2, A2),
       lanes=True, one_lanes=True, mimic=lambda mm, q: mimic.generalized_force(mm, rnea, q))
def gravity_torques(model, q, *, threads=None, out=None):
    """g(q) = ∂V/∂q (nv,) or (N, nv), V = −Σ_b m_b gᵀ c_b: the Newton–Euler recursion with q̇ = q̈ = 0.
    threads, out: ``rnea``'s."""
