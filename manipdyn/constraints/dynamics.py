"""Lagrange's equations of the 1st kind (chapter Eqs. 19–27) on the spanning tree plus loop closures.

    M q̈ + h + Φ_qᵀ λ = τ          (Eq. 25; h = C q̇ + g − Σ Jᵀ f_ext, from the Newton–Euler code)
    Φ_q q̈ = c,  c = −Φ̇_q q̇        (Eq. 26, corrected: a time derivative on the second Φ_q)
    Baumgarte:  c = −Φ̇_q q̇ − 2α Φ_q q̇ − β² Φ
The reaction generalized force is −Φ_qᵀ λ. Closures are rank-deficient as the normal case (every revolute
closure of a spherical mechanism has rank 2 of 5), so Eq. 27 is solved on the independent rows only
(``independent_rows``); the multipliers of redundant rows are set to zero — λ is not unique, q̈ is.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.crba import mass_matrix
from ..dynamics.rnea import rnea
from ..dynamics.arguments import (as_batch, as_real, check_f_ext, check_finite, check_model, check_output, check_scalar,
                                  fast, joint_indices, raise_kernel_error, unbatch)
from ..errors import ConstraintError, InputError, SingularError
from ..joints import FREEFLYER
from .closures import RANK_RTOL, closure_terms, independent_rows, row_labels


@dataclass(frozen=True)
class RankReport:
    """What a rank-revealing solve found: rank of Φ_q, its rows, and the redundant ones by name."""
    rank: int
    rows: int
    redundant: tuple      # labels of rows dependent on earlier rows
    cond: float           # condition number of Φ_q restricted to its independent rows

    def __str__(self):
        red = f"; redundant: {', '.join(self.redundant)}" if self.redundant else ""
        return f"closure Jacobian rank {self.rank} of {self.rows} rows (cond {self.cond:.3g}){red}"


def rank_report(model, J, rtol=None) -> RankReport:
    """Rank of one state's Φ_q (m, nv), naming the redundant rows."""
    labels = row_labels(model)
    J = as_real("J", J)
    if J.shape != (len(labels), model.nv):
        raise InputError(f"J has shape {J.shape}; expected one state's closure Jacobian "
                         f"({len(labels)}, {model.nv}) of {model.name!r}")
    check_finite("J", J)
    rtol = None if rtol is None else check_scalar("rtol", rtol, positive=True)
    keep, labels = independent_rows(J, RANK_RTOL if rtol is None else rtol), row_labels(model)
    sv = np.linalg.svd(J[keep], compute_uv=False) if keep else np.ones(1)
    return RankReport(len(keep), J.shape[0], tuple(l for k, l in enumerate(labels) if k not in keep),
                      float(sv[0] / sv[-1]))


def constrained_forward_dynamics(model, q, v, tau, *, baumgarte=None, f_ext=None, f_ext_frame="local"):
    """(q̈, λ) of the KKT system of Eq. 27 on the independent closure rows.

    Parameters: q (nq,) or (N, nq), v, tau (nv,) or (N, nv) — tau is the full generalized force of the
    spanning tree (zero on passive joints; a free-flyer root's six entries are a wrench on the base, body
    frame); baumgarte=(alpha, beta) stabilises drift; f_ext as in ``rnea``.
    Returns q̈ (nv,)/(N, nv), λ (m,)/(N, m) in the rows of ``row_labels(model)``. The rank of one
    state's closure rows: ``rank_report(model, closure_terms(model, q)[1])`` for q (nq,).
    Without f_ext this runs the compiled kernel (constraints/fast.py), held by the tests to
    ``constrained_forward_dynamics_reference``, the readable solve below.
    """
    from .fast import constrained_fd_fast
    if f_ext is None and f_ext_frame == "local" and fast(model, q, v, tau) is not None:   # one float64 state
        code, qdd, lam, _ = constrained_fd_fast(model, q[None], v[None], tau[None], _baumgarte(baumgarte))
        if code == -1 and np.isfinite(qdd).all() and np.isfinite(lam).all():
            return qdd[0], lam[0]                              # else the checked path below says what is wrong
    (Q, V, T), single = as_batch(model, q=q, v=v, tau=tau)
    baumgarte = _baumgarte(baumgarte)
    if check_f_ext(model, f_ext, f_ext_frame, Q.shape[0]) is not None or not model.nv:
        return constrained_forward_dynamics_reference(model, q, v, tau, baumgarte=baumgarte, f_ext=f_ext,
                                                      f_ext_frame=f_ext_frame)
    code, qdd, lam, _ = constrained_fd_fast(model, Q, V, T, baumgarte)
    if code != -1:                      # a non-finite input or a joint that moves no mass (q̈'s entries: below)
        raise_kernel_error(model, code, ("q", "v", "tau"), (Q, V, T), "constrained_forward_dynamics")
    _check_results("constrained_forward_dynamics", model, qdd, lam, dict(q=Q, v=V, tau=T))
    return unbatch(qdd, single), unbatch(lam, single)


def constrained_forward_dynamics_reference(model, q, v, tau, *, baumgarte=None, f_ext=None,
                                           f_ext_frame="local"):
    """The readable KKT solve of Eq. 27 (same contract as constrained_forward_dynamics)."""
    (Q, V, T), single = as_batch(model, q=q, v=v, tau=tau)
    baumgarte = _baumgarte(baumgarte)
    check_f_ext(model, f_ext, f_ext_frame, Q.shape[0])
    Phi, Jc, bias = closure_terms(model, Q, V)
    c = -bias
    if baumgarte is not None:
        alpha, beta = baumgarte
        c = c - 2.0 * alpha * np.einsum("nij,nj->ni", Jc, V) - beta**2 * Phi
    rhs = T - rnea(model, Q, V, np.zeros_like(V), f_ext=f_ext, f_ext_frame=f_ext_frame)   # τ − h
    M = mass_matrix(model, Q)
    qdd, lam = np.empty_like(V), np.zeros_like(Phi)
    for s in range(Q.shape[0]):
        keep = independent_rows(Jc[s], phi=Phi[s])
        qdd[s], lam[s, keep] = _kkt(M[s], Jc[s, keep], rhs[s], c[s, keep], model)
    _check_results("constrained_forward_dynamics", model, qdd, lam, dict(q=Q, v=V, tau=T))
    return unbatch(qdd, single), unbatch(lam, single)


def _baumgarte(baumgarte):
    """None, or (alpha, beta): two finite real numbers ≥ 0."""
    if baumgarte is None:
        return None
    try:
        a, b = baumgarte
    except (TypeError, ValueError):
        raise InputError(f"baumgarte must be None or a pair (alpha, beta), not {baumgarte!r}") from None
    return tuple(check_scalar(f"baumgarte[{k}]", x, nonnegative=True) for k, x in enumerate((a, b)))


def _check_results(call, model, qdd, lam, inputs):
    """NumericalError naming the call, row and joint (q̈) or closure row (λ) of a non-finite result."""
    check_output(call, "q̈", qdd, model, inputs)
    check_output(call, "λ", lam, model, inputs, what="closure row", labels=row_labels(model))


def _kkt(M, G, r, c, model):
    """Solve [M Gᵀ; G 0][q̈; λ] = [r; c] for full-row-rank G by the Schur complement with Cholesky of M."""
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise SingularError(f"mass matrix of the spanning tree of {model.name!r} is not positive definite") from None
    Minv_r = np.linalg.solve(L.T, np.linalg.solve(L, r))
    if G.shape[0] == 0:
        return Minv_r, np.zeros(0)
    Minv_Gt = np.linalg.solve(L.T, np.linalg.solve(L, G.T))
    try:
        lam = np.linalg.solve(G @ Minv_Gt, G @ Minv_r - c)
    except np.linalg.LinAlgError:
        raise SingularError(f"closed-chain dynamics of {model.name!r}: Φ_q M⁻¹ Φ_qᵀ is singular") from None
    return Minv_r - Minv_Gt @ lam, lam


def actuation(model, actuated=None):
    """Indices of the actuated joints (default: joints with a <transmission>)."""
    check_model(model)
    names = model.actuated if actuated is None else actuated
    idx = joint_indices(model, names, "actuated joints")
    if not idx:
        raise InputError(f"model {model.name!r} has no actuated joints: pass actuated=[joint names] "
                         f"or mark them with <transmission> in the URDF")
    return idx


def dofs(model, joints):
    """The entries of v (and q̇, q̈, τ) of the given joint indices, in order: one per 1-dof joint, six for a
    free flyer (v = [linear; angular]), three for a ball joint (body-frame ω). On a model of 1-dof joints
    they are the joint indices themselves."""
    return [int(model.idx_v[j]) + k for j in joints for k in range(int(model.nvs[j]))]


def moving_dofs(model, held=()):
    """The entries of v that assembly and projection move: every joint not in ``held`` (joint indices) —
    but a free flyer only when a closure ties a body to the world (body −1); a ball joint moves as any joint.
    Otherwise every closure is internal to the robot: it holds whatever the base pose (on the closures its columns of Φ_q vanish), so
    the base stays where the caller put it instead of taking a share of the minimum-norm steps."""
    world = any(c.parent < 0 or c.child < 0 for c in model.constraints)
    return dofs(model, [j for j in range(model.njoints) if j not in held
                        and (world or model.kind[j] != FREEFLYER)])


def constrained_inverse_dynamics(model, q, v, a, actuated=None, *, tol=1e-9, f_ext=None, f_ext_frame="local"):
    """(τ_a, λ): actuator forces for a prescribed motion of a closed chain, τ_tree = Sᵀ τ_a − Φ_qᵀ λ.

    Solves ``[Sᵀ, −Φ_qᵀ] [τ_a; λ] = rnea(q, q̇, q̈)`` in the least-squares, minimum-norm sense (rank-revealing)
    and raises ConstraintError when (q, q̇, q̈) violates a closure (|Φ|, |Φ_q q̇| or |Φ_q q̈ + Φ̇_q q̇| above
    tol) or when the actuators cannot produce the motion (under-actuated: residual above tol).
    Whether the chain is "fully", "under" or "over" actuated at q: ``actuation_status(model, q, actuated)``.
    """
    (Q, V, A), single = as_batch(model, q=q, v=v, a=a)
    joints = actuation(model, actuated)
    idx = dofs(model, joints)                    # entries of τ the actuators drive (a free flyer: six)
    tol = check_scalar("tol", tol, positive=True)
    check_f_ext(model, f_ext, f_ext_frame, Q.shape[0])
    Phi, Jc, bias = closure_terms(model, Q, V)
    _check_consistent(model, Phi, Jc, bias, V, A, tol)
    tau_tree = rnea(model, Q, V, A, f_ext=f_ext, f_ext_frame=f_ext_frame)
    ta, lam = np.empty((Q.shape[0], len(idx))), np.zeros_like(Phi)
    for s in range(Q.shape[0]):
        keep = independent_rows(Jc[s])
        S = np.zeros((model.nv, len(idx)))
        S[idx, range(len(idx))] = 1.0
        K = np.hstack([S, -Jc[s, keep].T])
        x, *_ = np.linalg.lstsq(K, tau_tree[s], rcond=None)
        resid = K @ x - tau_tree[s]
        if np.max(np.abs(resid)) > tol * max(np.max(np.abs(tau_tree[s])), 1.0):
            raise ConstraintError(f"the actuators {[model.joint_names[i] for i in joints]} cannot produce this "
                                  f"motion (under-actuated; residual {np.max(np.abs(resid)):.3g})")
        ta[s], lam[s, keep] = x[:len(idx)], x[len(idx):]
    check_output("constrained_inverse_dynamics", "τ_a", ta, model, dict(q=Q, v=V, a=A), what="actuator",
                 labels=[model.v_names[i] for i in idx])
    check_output("constrained_inverse_dynamics", "λ", lam, model, dict(q=Q, v=V, a=A), what="closure row",
                 labels=row_labels(model))
    return unbatch(ta, single), unbatch(lam, single)


def _check_consistent(model, Phi, Jc, bias, V, A, tol):
    """Refuse states that violate the closures, naming the worst row (tolerances scale with the rates)."""
    labels = row_labels(model)
    vel, acc = np.einsum("nij,nj->ni", Jc, V), np.einsum("nij,nj->ni", Jc, A) + bias
    scale_v = max(1.0, float(np.max(np.abs(V), initial=0)))
    scale_a = max(1.0, float(np.max(np.abs(A), initial=0)), float(np.max(np.abs(bias), initial=0)))
    for what, res, scale in (("position Φ", Phi, 1.0), ("velocity Φ_q q̇", vel, scale_v),
                             ("acceleration Φ_q q̈ + Φ̇_q q̇", acc, scale_a)):
        if res.size and np.max(np.abs(res)) > tol * scale:
            s, k = np.unravel_index(np.argmax(np.abs(res)), res.shape)
            raise ConstraintError(f"state {s} violates closure row {labels[k]!r}: {what} = {res[s, k]:.3g} "
                                  f"(tolerance {tol * scale:.3g}); complete it with complete_state() or assemble()")


def actuation_status(model, q, actuated=None):
    """"fully", "under" or "over" actuated at q (nq,): compares the actuated entries of v plus rank(Φ_q)
    with nv; a batch (N, nq) gives a list, row by row. A free-flyer root counts as six unactuated degrees
    of freedom unless it is listed in ``actuated`` (a floating robot is under-actuated)."""
    (Q,), single = as_batch(model, q=q)
    na = len(dofs(model, actuation(model, actuated)))
    _, Jc, _ = closure_terms(model, Q)
    out = []
    for J in Jc:
        dof = model.nv - len(independent_rows(J))
        out.append("fully" if na == dof else ("under" if na < dof else "over"))
    return out[0] if single else out
