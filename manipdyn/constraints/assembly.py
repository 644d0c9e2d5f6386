"""Assembly (Newton–Raphson on Φ(q) = 0), projection of drifted states, completion of passive coordinates.

Singular configurations are detected from the condition number of the closure Jacobian restricted to the
coordinates being solved for; they raise a clear error (or, with ``damping``, take damped least-squares
steps and flag the result) — never a silent NaN.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.lagrange import mass_matrix
from ..dynamics.state import as_batch
from ..errors import ConstraintError, SingularError
from .closures import RANK_RTOL, closure_terms, independent_rows, row_labels
from .dynamics import actuation


@dataclass(frozen=True)
class Assembly:
    """Result of ``assemble``: the assembled q and how it was reached."""
    q: np.ndarray          # (nv,)
    iterations: int
    residual: float        # max |Φ(q)|
    cond: float            # condition number of the solved block of Φ_q at q
    branch: int            # ±1: sign of det(Uᵀ Φ_q,free), U the row space of Φ_q,free at the guess
    same_branch: bool      # the guess had the same sign: no singularity crossed
    damped: bool           # damped least-squares steps were needed


def _solve_block(model, q, free, rtol=RANK_RTOL):
    """Φ, the independent rows of Φ_q restricted to the free coordinates, and that block's cond."""
    Phi, Jc, _ = closure_terms(model, q[None])
    G = Jc[0][:, free]
    keep = independent_rows(G, rtol)
    sv = np.linalg.svd(G[keep], compute_uv=False) if keep else np.ones(1)
    return Phi[0], keep, G[keep], float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf


def _branch(model, q, free, U):
    """Branch label: sign of det(Uᵀ Φ_q,free), U the row space at the guess (±1; 0 if not square).

    It keeps its sign while Newton moves within one assembly branch; it flips only through a singularity.
    """
    G = closure_terms(model, q[None])[1][0][:, free]
    B = U.T @ G
    return int(np.sign(np.linalg.det(B))) if B.shape[0] == B.shape[1] and B.size else 0


def assemble(model, q_guess, *, fixed=None, tol=1e-12, max_iter=50, max_step=0.5, max_cond=1e10,
             damping=None) -> Assembly:
    """Newton–Raphson for Φ(q) = 0 moving only the coordinates not in ``fixed`` (default: the actuated
    joints stay at the guess), from the guess, so the solution stays on the guess's assembly branch.

    Raises ConstraintError when it does not converge, SingularError when the Jacobian block is singular
    (cond > max_cond) unless ``damping`` (λ of damped least squares) is given, which flags ``damped``.
    """
    (q,), _ = as_batch(model, q=q_guess)
    q = q[0].copy()
    hold = actuation(model, fixed) if fixed is None or len(fixed) else []
    free = [i for i in range(model.nv) if i not in hold]
    G0 = closure_terms(model, q[None])[1][0][:, free]
    U0 = np.linalg.svd(G0)[0][:, :len(independent_rows(G0))]      # row space at the guess
    sign0, damped = _branch(model, q, free, U0), False
    for it in range(max_iter + 1):
        Phi, keep, G, cond = _solve_block(model, q, free)
        if np.max(np.abs(Phi), initial=0.0) <= tol:
            sign = _branch(model, q, free, U0)
            return Assembly(q, it, float(np.max(np.abs(Phi), initial=0.0)), cond, sign, sign == sign0, damped)
        if cond > max_cond and damping is None:
            raise SingularError(f"assembly of {model.name!r}: closure Jacobian is singular (cond {cond:.3g}) "
                                f"at iteration {it}; pass damping= for a damped least-squares step")
        Gall = closure_terms(model, q[None])[1][0][:, free]     # every row: off the closures the ideally
        if damping is not None and cond > max_cond:             # redundant rows still carry Φ
            step = -Gall.T @ np.linalg.solve(Gall @ Gall.T + damping**2 * np.eye(len(Phi)), Phi)
            damped = True
        else:
            step = -np.linalg.lstsq(Gall, Phi, rcond=1e-10)[0]
        q[free] += step * min(1.0, max_step / max(np.max(np.abs(step)), 1e-300))
    labels = row_labels(model)
    k = int(np.argmax(np.abs(Phi)))
    raise ConstraintError(f"assembly of {model.name!r} did not converge in {max_iter} iterations: closure row "
                          f"{labels[k]!r} still at {Phi[k]:.3g} (the closures may not be assemblable here)")


def project(model, q, v, *, tol=1e-12, max_iter=20):
    """(q, v) returned to Φ = 0 (minimum-norm Newton steps) and Φ_q q̇ = 0 (kinetic-energy-minimal:
    q̇ ← q̇ − M⁻¹Φ_qᵀ(Φ_q M⁻¹ Φ_qᵀ)⁻¹ Φ_q q̇). One state (nv,) or a batch (N, nv), row by row."""
    from .fast import closure_rows
    (Q, V), single = as_batch(model, q=q, v=v)
    Q, V = Q.copy(), V.copy()
    for s in range(Q.shape[0]):
        for _ in range(max_iter):
            Phi, Jc, _ = closure_rows(model, Q[s])
            if np.max(np.abs(Phi), initial=0.0) <= tol:
                break
            Q[s] -= np.linalg.lstsq(Jc, Phi, rcond=1e-10)[0]   # all rows: off the manifold the
            #                                                    "redundant" ones still carry Φ
        else:
            raise ConstraintError(f"projection of state {s} did not converge (|Φ| = {np.max(np.abs(Phi)):.3g})")
        G = Jc[independent_rows(Jc)]
        if G.shape[0]:
            Minv_Gt = np.linalg.solve(mass_matrix(model, Q[s]), G.T)
            V[s] -= Minv_Gt @ np.linalg.solve(G @ Minv_Gt, G @ V[s])
    return (Q[0], V[0]) if single else (Q, V)


def complete_state(model, q_guess, v_act, a_act, *, actuated=None, **assemble_kw):
    """Full (q, q̇, q̈) from the actuated joints' rates and accelerations: assemble q (actuated coordinates
    held at the guess), then solve Φ_q q̇ = 0 and Φ_q q̈ = −Φ̇_q q̇ for the passive coordinates."""
    idx = actuation(model, actuated)
    asm = assemble(model, q_guess, fixed=[model.joint_names[i] for i in idx], **assemble_kw)
    q = asm.q
    free = [i for i in range(model.nv) if i not in idx]
    v, a = np.zeros(model.nv), np.zeros(model.nv)
    v[idx], a[idx] = v_act, a_act
    _, Jc, _ = closure_terms(model, q[None])
    keep = independent_rows(Jc[0][:, free])
    G, Ga = Jc[0][keep][:, free], Jc[0][keep][:, idx]
    v[free] = np.linalg.lstsq(G, -Ga @ v[idx], rcond=None)[0]
    _, _, bias = closure_terms(model, q[None], v[None])
    a[free] = np.linalg.lstsq(G, -Ga @ a[idx] - bias[0][keep], rcond=None)[0]
    return q, v, a, asm
