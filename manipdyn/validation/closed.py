"""Closed chains against Pinocchio's constraintDynamics (it has no closed-loop inverse dynamics).

Each closure becomes Pinocchio RigidConstraintModels built from the same URDF frames: a revolute closure is
two 3-D point constraints on its axis (at the closure origin and 0.1 m along the axis: together exactly the
shared origin and axis — a single point at the origin would miss the axis, and placed where every axis of a
spherical mechanism meets it would constrain nothing), a spherical closure one 3-D point, a fixed closure one
6-D constraint. Pinocchio copes with the redundant rows through its proximal regularisation
(ProximalSettings below).
"""
from __future__ import annotations

import numpy as np

from ..configuration import integrate, neutral
from ..constraints import closure_terms, constrained_forward_dynamics, project, rank_report
from ..constraints.dynamics import dofs
from ..dynamics.crba import mass_matrix
from ..errors import ConstraintError, ModelError
from .measure import error
from .reference import pin

PROXIMAL = dict(accuracy=1e-12, mu=1e-8, max_iter=50)   # mu = 1e-12 stalls at 1e-9 on the SPM (measured)
AXIS_OFFSET = 0.1


class ClosedReference:
    """Pinocchio constraint models of a model's closures, on a Reference's Pinocchio model."""

    def __init__(self, ref):
        P = pin()
        self.ref, self.models, self.datas = ref, P.StdVec_RigidConstraintModel(), P.StdVec_RigidConstraintData()
        self.points = []          # (body_a, point_a, body_b, point_b) of each 3-D point, our frames
        for c in ref.model.constraints:
            if c.type == "coupling":
                raise ModelError(f"closure {c.name!r}: Pinocchio has no coupling (gear) constraint model; a "
                                 f"coupling is checked against Pinocchio's mimic joints instead")
            if c.type == "fixed":
                self._add(P.ContactType.CONTACT_6D, c.parent, P.SE3(c.Rp, c.pp), c.child, P.SE3(c.Rc, c.pc))
                continue
            offsets = (0.0, AXIS_OFFSET) if c.type == "revolute" else (0.0,)
            for off in offsets:
                pa, pb = c.pp + off * c.axis_p, c.pc + off * c.axis_c
                self._add(P.ContactType.CONTACT_3D, c.parent, P.SE3(np.eye(3), pa), c.child, P.SE3(np.eye(3), pb))
                if off == 0.0:
                    self.points.append((c.parent, pa, c.child, pb))
        P.initConstraintDynamics(ref.pm, ref.pd, self.models, self.datas)
        self.settings = P.ProximalSettings(PROXIMAL["accuracy"], PROXIMAL["mu"], PROXIMAL["max_iter"])

    def _add(self, kind, a, Ma, b, Mb):
        P = pin()
        cm = P.RigidConstraintModel(kind, self.ref.pm, a + 1, Ma, b + 1, Mb, P.ReferenceFrame.LOCAL)
        self.models.append(cm)
        self.datas.append(cm.createData())

    def qdd(self, q, v, tau):
        P, r = pin(), self.ref
        return P.constraintDynamics(r.pm, r.pd, r.to_pin_q(q), v, tau, self.models, self.datas, self.settings).copy()

    def point_gaps(self, q):
        """p_A − p_B (world) at every closure origin (fixed closures excluded), from Pinocchio: (k, 3)."""
        P, r = pin(), self.ref
        P.forwardKinematics(r.pm, r.pd, r.to_pin_q(q))
        gap = lambda b, x: r.pd.oMi[b + 1].act(x) if b >= 0 else x  # noqa: E731
        return np.array([gap(a, pa) - gap(b, pb) for a, pa, b, pb in self.points])


def manifold_states(model, n, rng, spread=0.3, tries=50):
    """n seeded states on the closures: a base configuration assembled from random starts, then random
    perturbations (N(0, spread²) rad or m, q ⊕ δ) projected back; q̇ ~ N(0, 2²) projected onto Φ_q q̇ = 0.
    Projection from an arbitrary q is not globally convergent (a revolute closure's dot-product rows have
    spurious least-squares minima with the axes flipped), hence the local sampling. A free-flyer root
    starts at its neutral pose and takes the perturbations' share of q ⊕ δ (projection leaves it there)."""
    base = None
    for _ in range(tries):
        try:
            q = rng.uniform(-np.pi, np.pi, model.nq)
            if model.floating:
                q[:7] = neutral(model)[:7]
            base, _ = project(model, q, np.zeros(model.nv))
            break
        except Exception:
            continue
    if base is None:
        raise ConstraintError(f"{model.name!r}: no assembled configuration found from {tries} random starts")
    out = []
    while len(out) < n:
        try:
            out.append(project(model, integrate(model, base, rng.normal(0.0, spread, model.nv)),
                               rng.normal(0.0, 2.0, model.nv)))
        except Exception:
            continue
    return np.array([q for q, _ in out]), np.array([v for _, v in out])


def closed_chain_terms(model, ref, Q, rng, progress=None):
    """Worst [abs, err] of the closure gaps (Φ at the raw random states Q) and of q̈ under the same random
    actuator torques at states on the closures (``manifold_states``)."""
    cref = ClosedReference(ref)
    worst = {"phi": [0.0, 0.0], "qdd_closed": [0.0, 0.0]}
    act = dofs(model, [model.joint_index(j) for j in model.actuated]) or list(range(model.nv))
    Qm, Vm = manifold_states(model, Q.shape[0], rng)
    for s in range(Q.shape[0]):
        Phi, _, _ = closure_terms(model, Q[s:s + 1])
        _update(worst["phi"], _point_rows(model, Phi[0]), cref.point_gaps(Q[s]))
        tau = np.zeros(model.nv)
        tau[act] = rng.normal(0.0, 1.0, len(act))
        qdd, _ = constrained_forward_dynamics(model, Qm[s], Vm[s], tau)
        rep = rank_report(model, closure_terms(model, Qm[s])[1])
        kappa = np.linalg.cond(mass_matrix(model, Qm[s])) * rep.cond ** 2   # conditioning of the solve
        _update(worst["qdd_closed"], qdd, cref.qdd(Qm[s], Vm[s], tau), kappa)
        if progress is not None:
            progress(1)
    _, Jc, _ = closure_terms(model, Qm[:1])
    return worst, rank_report(model, Jc[0])


def _point_rows(model, phi):
    """The position rows (p_A − p_B at each closure origin) of Φ, in closure order: (k, 3)."""
    rows, k = [], 0
    for c in model.constraints:
        if c.type not in ("fixed", "coupling"):
            rows.append(phi[k:k + 3])
        k += c.n_rows
    return np.array(rows).reshape(-1, 3)


def _update(w, x, y, scale=1.0):
    w[0] = max(w[0], float(np.max(np.abs(np.asarray(x) - y), initial=0.0)))
    w[1] = max(w[1], error(x, y) / scale)


def actuator_torques_by_inversion(model, cref, q, v, a_act, actuated, gen_force=None):
    """Pinocchio has no closed-loop inverse dynamics: invert its forward map, which is affine in τ.

    q̈(τ_a) = q̈(0) + Σ_k τ_a,k (q̈(e_k) − q̈(0)); solve the actuated rows for τ_a so that the actuated
    joints get the accelerations a_act. ``actuated``: entries of v (``constraints.dynamics.dofs`` of the
    actuated joints; the joint indices themselves on a fixed base). ``gen_force`` (nv,) is added to the joint torques (e.g. an
    external moment m on a body as J_ωᵀ m — constraintDynamics takes no external forces).
    """
    base = np.zeros(model.nv) if gen_force is None else np.asarray(gen_force, float)
    q0 = cref.qdd(q, v, base)
    G = np.empty((len(actuated), len(actuated)))
    for k, j in enumerate(actuated):
        tau = base.copy()
        tau[j] += 1.0
        G[:, k] = (cref.qdd(q, v, tau) - q0)[actuated]
    return np.linalg.solve(G, np.asarray(a_act) - q0[actuated])
