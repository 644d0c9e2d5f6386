"""Assembly (Newton–Raphson on Φ(q) = 0), projection of drifted states, completion of passive coordinates.

Singular configurations are detected from the condition number of the closure Jacobian restricted to the
coordinates being solved for; they raise a clear error (or, with ``damping``, take damped least-squares
steps and flag the result) — never a silent NaN.

Every step is taken in the tangent space: Φ_q (m, nv) maps v-space steps δ, and q moves by q ⊕ δ
(``configuration.integrate``), which on a free-flyer root is the SE(3) exponential, on a ball joint quat ⊗ exp(δ)
(q + δ on 1-dof joints).
A free flyer takes no part in the steps unless a closure ties a body to the world (``dynamics.moving_dofs``):
closures inside the robot hold whatever the base pose, so the base stays where the caller put it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..configuration import check_quaternions, integrate
from ..dynamics.crba import mass_matrix
from ..dynamics.arguments import as_batch, as_real, check_finite, check_output, check_scalar, quiet
from ..errors import ConstraintError, InputError, SingularError
from ..joints import FREEFLYER, PRISMATIC
from .closures import RANK_RTOL, _closure_terms, independent_rows, row_labels
from .dynamics import actuation, dofs, moving_dofs


@dataclass(frozen=True)
class Assembly:
    """Result of ``assemble``: the assembled q and how it was reached. One guess (nq,) gives q (nq,) and a
    number per other field; a batch of N guesses (N, nq) gives q (N, nq) and (N,) arrays, row k the result
    of guess k."""
    q: np.ndarray          # (nq,) or (N, nq)
    iterations: int        # int or (N,) int
    residual: float        # max |Φ(q)|; float or (N,)
    cond: float            # condition number of the solved block of Φ_q at q; float or (N,)
    branch: int            # ±1: sign of det(Uᵀ Φ_q,free), U the row space of Φ_q,free at the guess; int or (N,)
    same_branch: bool      # the guess had the same sign: no singularity crossed; bool or (N,) bool
    damped: bool           # damped least-squares steps were needed; bool or (N,) bool


def _stack(model, rows):
    """One Assembly of (N, nq) and (N,) arrays from N one-guess results (row k from rows[k])."""
    return Assembly(np.array([a.q for a in rows], dtype=float).reshape(len(rows), model.nq),
                    *(np.array([getattr(a, f) for a in rows], dtype=t) for f, t in
                      (("iterations", int), ("residual", float), ("cond", float), ("branch", int),
                       ("same_branch", bool), ("damped", bool))))


def _solve_block(model, q, free, rtol=RANK_RTOL):
    """Φ, the independent rows of Φ_q restricted to the free coordinates, that block's cond, and every
    row of Φ_q restricted to the free coordinates."""
    Phi, Jc, _ = _closure_terms(model, q[None])
    Gall = Jc[0][:, free]
    keep = independent_rows(Gall, rtol)
    sv = np.linalg.svd(Gall[keep], compute_uv=False) if keep else np.ones(1)
    return Phi[0], keep, Gall[keep], float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf, Gall


def _branch(model, q, free, U):
    """Branch label: sign of det(Uᵀ Φ_q,free), U the row space at the guess (±1; 0 if not square).

    It keeps its sign while Newton moves within one assembly branch; it flips only through a singularity.
    """
    G = _closure_terms(model, q[None])[1][0][:, free]
    B = U.T @ G
    return int(np.sign(np.linalg.det(B))) if B.shape[0] == B.shape[1] and B.size else 0


def assemble(model, q_guess, *, fixed=None, tol=1e-12, max_iter=50, max_step=0.5, max_cond=1e10,
             damping=None, restarts=24, seed=0):
    """Newton–Raphson for Φ(q) = 0 moving only the coordinates not in ``fixed`` (default: the actuated
    joints stay at the guess), from the guess, so the solution stays on the guess's assembly branch.

    When Newton from the guess fails (a poor guess: a singular start such as the all-zero configuration
    of a four-bar, or a basin without a root), it restarts from ``restarts`` seeded perturbations of the
    guess's free coordinates, of growing spread (0.3, 1 and π rad; a tenth of that in metres for prismatic
    joints), and returns the first that converges (``same_branch`` then says whether it kept the guess's
    branch). A batch of guesses (N, nq) is assembled row by row and gives one Assembly whose fields have a
    leading axis N: q (N, nq), the others (N,) (row k: guess k). Steps are taken in v-space and applied by
    q ⊕ δ; a free-flyer root moves only if a closure ties the robot to the world (``moving_dofs``), else it
    stays at the guess whatever ``fixed`` says.

    Raises ConstraintError naming the closures still violated and the smallest residual reached when no
    start converges; SingularError when the Jacobian block is singular (cond > max_cond) from the guess
    and every restart, unless ``damping`` (λ of damped least squares) is given, which flags ``damped``.
    """
    (Q,), single = as_batch(model, q=q_guess)
    opts = dict(tol=check_scalar("tol", tol, positive=True),
                max_iter=check_scalar("max_iter", max_iter, nonnegative=True, integer=True),
                max_step=check_scalar("max_step", max_step, positive=True),
                max_cond=check_scalar("max_cond", max_cond, positive=True),
                damping=None if damping is None else check_scalar("damping", damping, positive=True))
    check_quaternions(model, Q, "q_guess")
    restarts = check_scalar("restarts", restarts, nonnegative=True, integer=True)
    seed = check_scalar("seed", seed, integer=True)
    hold = actuation(model, fixed) if fixed is None or len(fixed) else []
    free = moving_dofs(model, hold)                            # entries of v the Newton steps move
    out = [_assemble_one(model, q.copy(), free, opts, restarts, seed) for q in Q]
    return out[0] if single else _stack(model, out)


def _assemble_one(model, q, free, opts, restarts, seed):
    """assemble for one guess q (nq,): Newton from the guess, then from seeded restarts."""
    if not model.constraints or not free:
        Phi = _closure_terms(model, q[None])[0][0]
        if np.max(np.abs(Phi), initial=0.0) > opts["tol"]:
            raise ConstraintError(f"assembly of {model.name!r}: every coordinate is held fixed and "
                                  f"{_violated(model, Phi, opts['tol'])}")
        return Assembly(q, 0, float(np.max(np.abs(Phi), initial=0.0)), 1.0, 0, True, False)
    G0 = _closure_terms(model, q[None])[1][0][:, free]
    U0 = np.linalg.svd(G0)[0][:, :len(independent_rows(G0))]      # row space at the guess
    sign0 = _branch(model, q, free, U0)
    attempts, rng = [], np.random.default_rng(seed)
    spread = _spread(model)[free]
    for k in range(restarts + 1):
        start = q.copy()
        if k:                                                       # growing spread: near the guess first
            start = _step(model, q, free, rng.normal(0.0, (0.3, 1.0, np.pi)[3 * (k - 1) // restarts],
                                                     len(free)) * spread)
        try:
            return _newton(model, start, free, U0, sign0, **opts)
        except (ConstraintError, SingularError) as exc:
            attempts.append(exc)
    best = min(attempts, key=lambda e: e.residual)
    if all(isinstance(e, SingularError) for e in attempts):
        raise attempts[0]
    tried = f" nor from {restarts} seeded restarts" if restarts else ""
    raise ConstraintError(f"assembly of {model.name!r} did not converge in {opts['max_iter']} iterations from "
                          f"the guess{tried}: {_violated(model, best.phi, opts['tol'])} (smallest max|Φ| "
                          f"reached: {best.residual:.3g}; the closures may not be assemblable here)")


def _spread(model):
    """(nv,) scale of a restart's perturbation per entry of v: 1 rad for rotations (a ball joint's three
    included), 0.1 m for translations (prismatic joints, a free flyer's linear part)."""
    out = np.where(model.kind[model.v_joint] == PRISMATIC, 0.1, 1.0)
    for j in np.flatnonzero(model.kind == FREEFLYER):
        out[model.idx_v[j]:model.idx_v[j] + 3] = 0.1
    return out


def _step(model, q, free, delta):
    """q ⊕ δ for a step δ on the entries ``free`` of v (zero elsewhere): (nq,)."""
    d = np.zeros(model.nv)
    d[free] = delta
    return integrate(model, q, d)


def _violated(model, Phi, tol):
    """'closure(s) ... violated: row 'x' at ...' for the rows of Φ above tol, worst first."""
    labels = row_labels(model)
    bad = [k for k in np.argsort(-np.abs(Phi)) if abs(Phi[k]) > tol]
    names = list(dict.fromkeys(labels[k].rsplit(".", 1)[0] for k in bad))
    return (f"closure{'s' if len(names) > 1 else ''} {', '.join(repr(n) for n in names)} violated "
            f"(row {labels[bad[0]]!r} at {Phi[bad[0]]:.3g})")


def _newton(model, q, free, U0, sign0, *, tol, max_iter, max_step, max_cond, damping):
    """Newton–Raphson (least-squares steps, clipped to max_step) from q; Assembly, or ConstraintError /
    SingularError carrying ``residual`` (max|Φ| reached) and ``phi`` (Φ there)."""
    damped, best = False, (np.inf, None)
    for it in range(max_iter + 1):
        Phi, keep, G, cond, Gall = _solve_block(model, q, free)
        res = float(np.max(np.abs(Phi), initial=0.0))
        if not np.isfinite(res):
            break
        best = min(best, (res, Phi), key=lambda b: b[0])
        if res <= tol and (cond <= max_cond or damping is not None):
            sign = _branch(model, q, free, U0)
            return Assembly(q, it, res, cond, sign, sign == sign0, damped)
        if cond > max_cond and damping is None:                 # also on the closures: a singular q
            exc = SingularError(f"assembly of {model.name!r}: closure Jacobian is singular (cond {cond:.3g}) "
                                f"at iteration {it}; pass damping= for a damped least-squares step")
            exc.residual, exc.phi = best
            raise exc
        if damping is not None and cond > max_cond:             # every row: off the closures the ideally
            step = -Gall.T @ np.linalg.solve(Gall @ Gall.T + damping**2 * np.eye(len(Phi)), Phi)
            damped = True                                       # redundant rows still carry Φ
        else:
            step = -np.linalg.lstsq(Gall, Phi, rcond=1e-10)[0]
        q = _step(model, q, free, step * min(1.0, max_step / max(np.max(np.abs(step)), 1e-300)))
    exc = ConstraintError(f"assembly of {model.name!r} did not converge in {max_iter} iterations")
    exc.residual, exc.phi = best if best[1] is not None else (np.inf, np.full(len(row_labels(model)), np.inf))
    raise exc


@quiet
def project(model, q, v, *, tol=1e-12, max_iter=20):
    """(q, v) returned to Φ = 0 (minimum-norm Newton steps q ← q ⊕ δ, δ on the entries of v that
    ``moving_dofs`` gives: a free-flyer root stays put under closures internal to the robot) and
    Φ_q q̇ = 0 (kinetic-energy-minimal, every entry of v, the base's too:
    q̇ ← q̇ − M⁻¹Φ_qᵀ(Φ_q M⁻¹ Φ_qᵀ)⁻¹ Φ_q q̇). One state q (nq,), v (nv,) or a batch (N, nq), (N, nv),
    row by row."""
    (Q, V), single = as_batch(model, q=q, v=v)
    tol = check_scalar("tol", tol, positive=True)
    max_iter = check_scalar("max_iter", max_iter, nonnegative=True, integer=True)
    check_quaternions(model, Q)
    Q, V = Q.copy(), V.copy()
    free = moving_dofs(model)
    for s in range(Q.shape[0]):
        for it in range(max_iter + 1):
            Phi, Jc = (x[0] for x in _closure_terms(model, Q[s:s + 1])[:2])
            if np.max(np.abs(Phi), initial=0.0) <= tol:
                break
            if it == max_iter or not np.all(np.isfinite(Phi)):
                raise ConstraintError(f"projection of state {s} did not converge in {max_iter} iterations: "
                                      f"{_violated(model, Phi, tol)}")
            Q[s] = _step(model, Q[s], free, -np.linalg.lstsq(Jc[:, free], Phi, rcond=1e-10)[0])   # all rows:
            #                                           off the manifold the "redundant" ones still carry Φ
        G = Jc[independent_rows(Jc)]
        if G.shape[0]:
            Minv_Gt = np.linalg.solve(mass_matrix(model, Q[s]), G.T)
            try:
                V[s] -= Minv_Gt @ np.linalg.solve(G @ Minv_Gt, G @ V[s])
            except np.linalg.LinAlgError:
                raise SingularError(f"projection of state {s}: Φ_q M⁻¹ Φ_qᵀ is singular") from None
    for name, x in (("q", Q), ("v", V)):
        check_output("project", name, x, model, dict(q=Q, v=V))
    return (Q[0], V[0]) if single else (Q, V)


def complete_state(model, q_guess, v_act, a_act, *, actuated=None, **assemble_kw):
    """Full (q, q̇, q̈) from the actuated joints' rates and accelerations: assemble q (actuated coordinates
    held at the guess), then solve Φ_q q̇ = 0 and Φ_q q̈ = −Φ̇_q q̇ for the passive coordinates.

    q_guess (nq,) with v_act, a_act (n_act,) gives q (nq,), q̇, q̈ (nv,) and one Assembly; a batch q_guess
    (N, nq) with v_act, a_act (N, n_act) (or (n_act,) for every row) is completed row by row and gives
    (N, nq), (N, nv) arrays and one Assembly of (N, nq) and (N,) arrays, as ``assemble`` on the batch.
    n_act counts entries of v: one per actuated 1-dof joint, three for a ball joint (body-frame ω), six for a
    free flyer listed in ``actuated`` (its body-frame [linear; angular] rates).
    A free-flyer root not listed stays at the guess and at rest (q̇ = q̈ = 0 on its entries): under
    closures internal to the robot the passive rates do not depend on the base's."""
    (Q,), single = as_batch(model, q=q_guess)
    joints = actuation(model, actuated)
    idx = dofs(model, joints)
    rates = []
    for name, x in (("v_act", v_act), ("a_act", a_act)):
        x = as_real(name, x)
        if x.shape not in ((len(idx),), (Q.shape[0], len(idx))) or (single and x.ndim != 1):
            raise InputError(f"{name} has shape {x.shape}; expected ({len(idx)},)" + ("" if single else
                             f" or ({Q.shape[0]}, {len(idx)})") + f": the actuated joints' entries of v "
                             f"{[model.v_names[i] for i in idx]}")
        check_finite(name, x)
        rates.append(np.broadcast_to(x, (Q.shape[0], len(idx))))
    asm = assemble(model, Q[0] if single else Q, fixed=[model.joint_names[i] for i in joints], **assemble_kw)
    out = [_complete_one(model, q, joints, idx, va, aa) for q, va, aa in zip(asm.q.reshape(Q.shape), *rates)]
    N = Q.shape[0]
    q, v, a = ((np.array(x).reshape(N, n) for x, n in zip(zip(*out), (model.nq, model.nv, model.nv))) if out
               else (np.zeros((0, model.nq)), np.zeros((0, model.nv)), np.zeros((0, model.nv))))
    for name, x in (("q", q), ("v", v), ("a", a)):
        check_output("complete_state", name, x, model, dict(q=Q))
    return (q[0], v[0], a[0], asm) if single else (q, v, a, asm)


@quiet
def _complete_one(model, q, joints, idx, v_act, a_act):
    """q̇, q̈ (nv,) of one assembled q (nq,) from the actuated rates and accelerations (entries idx of v)."""
    free = moving_dofs(model, joints)
    v, a = np.zeros(model.nv), np.zeros(model.nv)
    v[idx], a[idx] = v_act, a_act
    _, Jc, _ = _closure_terms(model, q[None])
    keep = independent_rows(Jc[0][:, free])
    G, Ga = Jc[0][keep][:, free], Jc[0][keep][:, idx]
    v[free] = np.linalg.lstsq(G, -Ga @ v[idx], rcond=None)[0]
    _, _, bias = _closure_terms(model, q[None], v[None])
    a[free] = np.linalg.lstsq(G, -Ga @ a[idx] - bias[0][keep], rcond=None)[0]
    return q, v, a
