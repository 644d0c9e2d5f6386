"""Forward kinematics: the one pass that places the bodies in the world (and gives their velocities), which
placements, Jacobians, J̇, energies, playback and the loop closures all read (``fk_pass``), and its batch calls.
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..joints import joint_placement, joint_velocity
from .kernel_inputs import nonfinite_input
from .model_arrays import kernel_arrays, unpack


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
def fk_scratch(nb):
    """Scratch of ``fk_pass`` for nb bodies: (Rl, pl, Rw, pw, ww, vw), views of two arrays."""
    R3, B3 = np.empty((2 * nb, 3, 3)), np.empty((4 * nb, 3))
    return R3[:nb], B3[:nb], R3[nb:], B3[nb:2 * nb], B3[2 * nb:3 * nb], B3[3 * nb:]


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


@njit(cache=True)
def fk_kernel(I, F, Q, V, Rw, pw, ww, vw):
    """fk_pass for every state: Q (N, nq), V (N, nv) or (N, 0); Rw (N, nb, 3, 3), pw, ww, vw (N, nb, 3).
    Returns its status (dynamics/status.py)."""
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
