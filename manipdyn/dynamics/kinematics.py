"""Placements, geometric Jacobians and their time derivatives, for any tree and joint type.

Jacobian rows are [linear; angular] as in Pinocchio. ``reference="world"`` means world-aligned axes at the
frame's origin (Pinocchio's LOCAL_WORLD_ALIGNED), ``"local"`` the frame's own axes. Column j of the
world-aligned Jacobian of a point p (Eqs. 29–30 generalised): revolute j: [z_j × (p − o_j); z_j];
prismatic j: [z_j; 0]; zero unless joint j supports the frame. z_j is joint j's axis and o_j its origin
(body j's origin) in world coordinates.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import REVOLUTE
from ..spatial import cross, skew
from .core import joint_placements
from .state import as_batch, check_output, frame_of, quiet, unbatch


def placements(model, Q):
    """World placement of every body for a batch Q (N, nv): R (nv, N, 3, 3), p (nv, N, 3)."""
    Rp, pp = joint_placements(model, Q)
    R, p = np.empty_like(Rp), np.empty_like(pp)
    for i in range(model.nv):
        j = model.parent[i]
        R[i], p[i] = (Rp[i], pp[i]) if j < 0 else (R[j] @ Rp[i], p[j] + np.einsum("nij,nj->ni", R[j], pp[i]))
    return R, p


def supports(model) -> np.ndarray:
    """(nv, nv) bool: supports[b, j] is True when joint j moves body b (j is b or one of its ancestors)."""
    S = np.eye(model.nv, dtype=bool)
    for i in range(model.nv):
        if model.parent[i] >= 0:
            S[i] |= S[model.parent[i]]
    return S


def support_path(model, body) -> list:
    """The joints that move ``body``: body, parent[body], ... up to the base (iterative, O(depth))."""
    out = []
    while body >= 0:
        out.append(int(body))
        body = model.parent[body]
    return out


def axes_world(model, R):
    """z_j in world coordinates: (nv, N, 3)."""
    return np.einsum("jnab,jb->jna", R, model.axis)


def point_jacobian(model, R, p, z, body, point):
    """World-aligned Jacobian (N, 6, nv) of a point (N, 3) rigidly attached to ``body``."""
    N = point.shape[0]
    J = np.zeros((N, 6, model.nv))
    if body < 0:
        return J
    for j in sorted(support_path(model, body)):
        if model.kind[j] == REVOLUTE:
            J[:, :3, j], J[:, 3:, j] = cross(z[j], point - p[j]), z[j]
        else:
            J[:, :3, j] = z[j]
    return J


def _frame_world(model, R, p, frame):
    """(body, R_frame (N, 3, 3), p_frame (N, 3)) of a named frame in world coordinates."""
    fr = frame_of(model, frame)
    if fr.body < 0:
        N = R.shape[1]
        return fr.body, np.broadcast_to(fr.R, (N, 3, 3)), np.broadcast_to(fr.p, (N, 3))
    return fr.body, R[fr.body] @ fr.R, p[fr.body] + np.einsum("nij,j->ni", R[fr.body], fr.p)


@quiet
def frame_placement(model, q, frame):
    """Pose of a link or frame in the world: (R (3, 3) or (N, 3, 3), p (3,) or (N, 3))."""
    (Q,), single = as_batch(model, q=q)
    frame_of(model, frame)
    _, Rf, pf = _frame_world(model, *placements(model, Q), frame)
    Rf, pf = (check_output("frame_placement", k, np.array(x), model, dict(q=Q))
              for k, x in (("R", Rf), ("p", pf)))
    return unbatch(Rf, single), unbatch(pf, single)


def _to_local(J, Rf):
    """Rotate both 3-row blocks of a world-aligned Jacobian into the frame's axes."""
    Jl = np.empty_like(J)
    Jl[:, :3], Jl[:, 3:] = np.swapaxes(Rf, 1, 2) @ J[:, :3], np.swapaxes(Rf, 1, 2) @ J[:, 3:]
    return Jl


@quiet
def frame_jacobian(model, q, frame, reference="world"):
    """J (6, nv) or (N, 6, nv), rows [linear; angular]: twist of ``frame`` = J q̇ (Eqs. 29–30)."""
    _check_reference(reference)
    (Q,), single = as_batch(model, q=q)
    frame_of(model, frame)
    R, p = placements(model, Q)
    body, Rf, pf = _frame_world(model, R, p, frame)
    J = point_jacobian(model, R, p, axes_world(model, R), body, pf)
    J = J if reference == "world" else _to_local(J, Rf)
    return unbatch(check_output("frame_jacobian", "J", J, model, dict(q=Q), axis=2), single)


@quiet
def frame_jacobian_dot(model, q, v, frame, reference="world"):
    """J̇ (6, nv) or (N, 6, nv), exact time derivative of frame_jacobian along q̇.

    World-aligned: ż_j = ω_j × z_j; revolute column d/dt[z_j × (p − o_j)] = ż_j × (p − o_j) + z_j × (ṗ − ȯ_j);
    prismatic column ż_j. Local: J̇_l = Rᵀ J̇_w − [ω'_f]× Rᵀ J_w (the frame's axes turn with it).
    """
    _check_reference(reference)
    (Q, V), single = as_batch(model, q=q, v=v)
    frame_of(model, frame)
    R, p = placements(model, Q)
    z = axes_world(model, R)
    body, Rf, pf = _frame_world(model, R, p, frame)
    J = point_jacobian(model, R, p, z, body, pf)
    w, vel = body_twists(model, p, z, V)
    dJ = point_jacobian_dot(model, p, z, w, vel, body, pf)
    if reference == "local":
        W = skew(np.einsum("nji,nj->ni", Rf, w[body]) if body >= 0 else np.zeros_like(pf))   # [ω'_f]×
        Jl = _to_local(J, Rf)
        dJ = _to_local(dJ, Rf) - np.concatenate([W @ Jl[:, :3], W @ Jl[:, 3:]], axis=1)
    return unbatch(check_output("frame_jacobian_dot", "J̇", dJ, model, dict(q=Q, v=V), axis=2), single)


def point_jacobian_dot(model, p, z, w, vel, body, point):
    """J̇ (N, 6, nv) of a point (N, 3) fixed to ``body``, world-aligned, from world twists (w, vel)."""
    dJ = np.zeros(point.shape[:1] + (6, model.nv))
    if body < 0:
        return dJ
    vp = vel[body] + cross(w[body], point - p[body])            # velocity of the point
    for j in sorted(support_path(model, body)):
        dz = cross(w[j], z[j])                                  # ż_j = ω_j × z_j
        if model.kind[j] == REVOLUTE:
            dJ[:, :3, j] = cross(dz, point - p[j]) + cross(z[j], vp - vel[j])
            dJ[:, 3:, j] = dz
        else:
            dJ[:, :3, j] = dz
    return dJ


def body_twists(model, p, z, V):
    """World angular velocity and world velocity of each body origin: (nv, N, 3) each."""
    w, vel = np.zeros_like(p), np.zeros_like(p)
    for i in range(model.nv):
        j = model.parent[i]
        w0, v0 = (0.0, 0.0) if j < 0 else (w[j], vel[j] + cross(w[j], p[i] - p[j]))
        if model.kind[i] == REVOLUTE:
            w[i], vel[i] = w0 + V[:, i, None] * z[i], v0
        else:
            w[i], vel[i] = w0, v0 + V[:, i, None] * z[i]
    return w, vel


def _check_reference(reference):
    if not isinstance(reference, str) or reference not in ("world", "local"):
        raise InputError(f"reference must be 'world' or 'local', not {reference!r}")
