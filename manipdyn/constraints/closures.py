"""Loop-closure kinematics: Φ(q), the constraint Jacobian Φ_q and the bias Φ̇_q q̇, exact.

For a closure between frame A (on the parent body) and frame B (on the child body), world coordinates:
  position rows (every type):  Φ = p_A − p_B,             Φ_q = J_A,v − J_B,v
  orientation rows:            Φ = a·b (a fixed in A, b in B, a ⊥ b when closed),
                               Φ_q = (a × b)ᵀ (J_A,ω − J_B,ω)   since d(a·b)/dt = (a × b)·(ω_A − ω_B)
  revolute: a ∈ {n1, n2} ⊥ the parent axis e_A, b = the child axis e_B (2 rows, 5 in all);
  fixed: (a, b) = (y_A, z_B), (z_A, x_B), (x_A, y_B) (3 rows, 6 in all); spherical: position only.
Φ̇_q q̇ is the same derivative taken once more at q̈ = 0 (chapter Eq. 26: Φ_q q̈ + Φ̇_q q̇ = 0).
Rows are labelled "<closure>.x|y|z" (position) and "<closure>.r1|r2|r3" (orientation).
"""
from __future__ import annotations

import numpy as np

from ..dynamics.kinematics import axes_world, body_twists, placements, point_jacobian, point_jacobian_dot
from ..dynamics.state import as_batch, as_real, check_finite, check_model, check_output, quiet, unbatch
from ..errors import InputError
from ..spatial import cross


def _perp_pair(e):
    """Two unit vectors completing e (3,) to a right-handed orthonormal basis."""
    t = np.eye(3)[np.argmin(np.abs(e))]
    n1 = np.cross(e, t)
    n1 /= np.linalg.norm(n1)
    return n1, np.cross(e, n1)


def _pairs(c):
    """(a, b) direction pairs of the orientation rows, a in the parent body frame, b in the child's."""
    if c.type == "revolute":
        n1, n2 = _perp_pair(c.axis_p)
        return [(n1, c.axis_c), (n2, c.axis_c)]
    if c.type == "fixed":
        A, B = c.Rp, c.Rc
        return [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 1])]
    return []


def row_labels(model):
    """Name of every constraint row, in order."""
    check_model(model)
    out = []
    for c in model.constraints:
        out += [f"{c.name}.{k}" for k in ("x", "y", "z")]
        out += [f"{c.name}.r{k + 1}" for k in range(len(_pairs(c)))]
    return out


def _pose(R, p, b, N):
    """World rotation and position of body b (the fixed base for b = -1): (N, 3, 3), (N, 3)."""
    return (np.broadcast_to(np.eye(3), (N, 3, 3)), np.zeros((N, 3))) if b < 0 else (R[b], p[b])


@quiet
def closure_terms(model, q, v=None):
    """Φ (N, m), Φ_q (N, m, nv) and, with v, Φ̇_q q̇ (N, m) (None without v) for a batch q, v (N, nv), or
    Φ (m,), Φ_q (m, nv), Φ̇_q q̇ (m,) for one state (nv,)."""
    if v is None:
        (Q,), single = as_batch(model, q=q)
        V = None
    else:
        (Q, V), single = as_batch(model, q=q, v=v)
    out = _closure_terms(model, Q, V)
    inputs = dict(q=Q) if V is None else dict(q=Q, v=V)
    for name, x in zip(("Φ", "Φ_q", "Φ̇_q q̇"), out):
        if x is not None:
            check_output("closure_terms", name, x, model, inputs, what="closure row", labels=row_labels(model))
    return tuple(None if x is None else unbatch(x, single) for x in out)


def _closure_terms(model, Q, V=None):
    """closure_terms on checked batches Q, V (N, nv)."""
    N = Q.shape[0]
    R, p = placements(model, Q)
    z = axes_world(model, R)
    tw = body_twists(model, p, z, V) if V is not None else None
    phi, jac, bias = [], [], []
    for c in model.constraints:
        (RA, oA), (RB, oB) = _pose(R, p, c.parent, N), _pose(R, p, c.child, N)
        pA, pB = oA + np.einsum("nij,j->ni", RA, c.pp), oB + np.einsum("nij,j->ni", RB, c.pc)
        JA, JB = point_jacobian(model, R, p, z, c.parent, pA), point_jacobian(model, R, p, z, c.child, pB)
        phi.append(pA - pB)
        jac.append(JA[:, :3] - JB[:, :3])
        if tw is not None:
            w, vel = tw
            dJA = point_jacobian_dot(model, p, z, w, vel, c.parent, pA)
            dJB = point_jacobian_dot(model, p, z, w, vel, c.child, pB)
            bias.append(np.einsum("nij,nj->ni", dJA[:, :3] - dJB[:, :3], V))
            wA, wB = (np.zeros((N, 3)) if b < 0 else w[b] for b in (c.parent, c.child))
        for a0, b0 in _pairs(c):
            a, b = np.einsum("nij,j->ni", RA, a0), np.einsum("nij,j->ni", RB, b0)
            axb = cross(a, b)
            phi.append(np.einsum("ni,ni->n", a, b)[:, None])
            jac.append(np.einsum("ni,nij->nj", axb, JA[:, 3:] - JB[:, 3:])[:, None])
            if tw is not None:   # d/dt[(a × b)·(ω_A − ω_B)] at q̈ = 0
                daxb = cross(cross(wA, a), b) + cross(a, cross(wB, b))
                dw0 = np.einsum("nij,nj->ni", dJA[:, 3:] - dJB[:, 3:], V)
                bias.append((np.einsum("ni,ni->n", daxb, wA - wB) + np.einsum("ni,ni->n", axb, dw0))[:, None])
    m = len(phi)
    if m == 0:
        empty = np.zeros((N, 0))
        return empty, np.zeros((N, 0, model.nv)), (empty if V is not None else None)
    Phi, Jac = np.concatenate(phi, axis=1), np.concatenate(jac, axis=1)
    return Phi, Jac, (np.concatenate(bias, axis=1) if V is not None else None)


RANK_RTOL = 1e-6   # rows whose new direction is below 1e-6 of the largest row are redundant: off the
#                    manifold (mid-step states) the ideally redundant rows keep components ~|Φ|, which a
#                    tighter tolerance would take as rank and make the KKT solve singular


def independent_rows(J, rtol=RANK_RTOL, phi=None):
    """Greedy rank-revealing row selection: indices of rows of J (m, nv) that add rank, in order.

    A row is kept when its component orthogonal to the rows kept so far exceeds rtol · max row norm;
    the rows left out are the redundant ones (dependent on earlier rows). Off the closures (|Φ| > 0, e.g.
    inside an integrator step) the ideally redundant rows gain spurious components of the order of |Φ|:
    given Φ, the tolerance is raised to 100 max|Φ| / (max row norm) so they are not taken as rank.
    """
    J = as_real("J", J)
    if J.ndim != 2:
        raise InputError(f"J has shape {J.shape}; expected one closure Jacobian (m, nv)")
    check_finite("J", J)
    scale = max(float(np.max(np.linalg.norm(J, axis=1), initial=0.0)), 1e-300)
    if phi is not None and len(phi):
        rtol = max(rtol, 100.0 * float(np.max(np.abs(phi))) / scale)
    basis, keep = [], []
    for k, row in enumerate(J):
        r = row.copy()
        for b in basis:
            r -= (r @ b) * b
        nr = np.linalg.norm(r)
        if nr > rtol * scale:
            basis.append(r / nr)
            keep.append(k)
    return keep
