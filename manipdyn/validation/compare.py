"""Term-by-term comparison of our Newton–Euler terms with Pinocchio's, and the report it produces.

Each term is scored by the error measure of validation/measure.py (docs/design.md §3) over the whole term
(every link, every component) of one state; a run reports the worst state. Accelerations from a solve are reported as err/κ: κ = cond(M) for a tree,
κ = cond(M)·cond(Φ_q)² (independent rows) for a closed chain, the conditioning of the solve. Random states: q uniform in [−π, π] (revolute) or within the limits
(prismatic; [−0.5, 0.5] m when unbounded), a free-flyer root at a position uniform in [−1, 1]³ m with a
uniformly random orientation (unit quaternion), q̇ ~ N(0, 2²), q̈ ~ N(0, 5²), seeded.

On a floating model (free-flyer root) a term whose computation raises is reported "not supported" (with the
reason in the notes) instead of stopping the run; such a term does not pass. On a fixed-base model every
error propagates as before.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from ..dynamics.aba import aba, forward_dynamics
from ..dynamics.derivatives import aba_derivatives, rnea_derivatives
from ..dynamics.kinematics import frame_jacobian, frame_jacobian_dot
from ..dynamics.coriolis import coriolis_matrix
from ..dynamics.crba import mass_matrix
from ..dynamics.rnea import gravity_torques
from ..dynamics.regressor import joint_torque_regressor
from ..dynamics.rnea import rnea, rnea_terms
from ..configuration import FREE_RANGE
from ..joints import BALL, FREEFLYER, PLANAR, PRISMATIC
from .closed import PROXIMAL, closed_chain_terms
from .measure import error
from .reference import Reference

# term key -> (label, kind); kinematics and inertial terms are a link's own, transmitted ones are not
TERMS = {
    "w": ("angular velocity ω'", "kinematics"), "v": ("linear velocity v'", "kinematics"),
    "dw": ("angular acceleration ω̇'", "kinematics"), "acc": ("linear acceleration v̇' (no g)", "kinematics"),
    "fc": ("inertial force m v̇'_C", "inertial"), "nO": ("inertial moment about origin", "inertial"),
    "f": ("joint force f'", "transmitted"), "n": ("joint moment n'", "transmitted"),
    "tau": ("torque τ", "torque"),
    "f_ext": ("joint force f' with f_ext", "transmitted"), "n_ext": ("joint moment n' with f_ext", "transmitted"),
    "tau_ext": ("torque τ with f_ext", "torque"),
}
# Lagrange route and forward dynamics (no per-link fault location: they are whole-robot terms)
DYN_TERMS = {
    "M_crba": "M (CRBA) vs crba", "M_lagrange": "M (Lagrange, Eq. 23) vs crba",
    "C": "C (O(n²) recursion) vs computeCoriolisMatrix", "g": "g vs computeGeneralizedGravity",
    "nle": "C q̇ + g vs nonLinearEffects", "lagrange_ne": "M q̈ + C q̇ + g vs our Newton–Euler τ",
    "qdd_aba": "q̈ (ABA) vs aba, err/cond(M)", "qdd_cholesky": "q̈ (Cholesky) vs aba, err/cond(M)",
    "J_local_world_aligned": "J world-aligned vs getFrameJacobian", "J_local": "J local vs getFrameJacobian",
    "dJ_local_world_aligned": "J̇ world-aligned vs ...TimeVariation", "dJ_local": "J̇ local vs ...TimeVariation",
    "Y": "regressor Y vs computeJointTorqueRegressor",
    "dtau_dq": "∂τ/∂q vs computeRNEADerivatives", "dtau_dv": "∂τ/∂q̇ vs computeRNEADerivatives",
    "dqdd_dq": "∂q̈/∂q vs computeABADerivatives, err/cond(M)",
    "dqdd_dv": "∂q̈/∂q̇ vs computeABADerivatives, err/cond(M)",
}
CLOSED_TERMS = {"phi": "closure gaps Φ (p_A − p_B) vs Pinocchio placements",
                "qdd_closed": "closed q̈ vs constraintDynamics, err/κ"}   # κ = cond(M) cond(Φ_q)²


@dataclass
class TermResult:
    term: str
    label: str
    max_abs: float
    err: float
    tol: float
    supported: bool = True     # False: our side could not compute it (the report's notes say why)

    @property
    def passed(self) -> bool:
        return bool(self.supported and self.err <= self.tol)


@dataclass
class Report:
    """Outcome of one robot's validation; ``fault`` names the first link whose own terms diverge."""
    name: str
    source: str
    nv: int
    n_states: int
    seed: int
    terms: list = field(default_factory=list)
    fault: str | None = None
    transmitted_differ: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return all(t.passed for t in self.terms)

    def as_dict(self) -> dict:
        d = asdict(self)
        for t, td in zip(self.terms, d["terms"]):
            td["passed"] = t.passed
            if not t.supported:              # NaN is not JSON
                td["max_abs"] = td["err"] = None
        d["passed"] = self.passed
        return d


def random_states(model, n, rng):
    """Seeded random (q (n, nq), q̇ (n, nv), q̈ (n, nv)), following docs/design.md §3 (see the module docstring)."""
    one = np.flatnonzero(model.nqs == 1)                    # 1-dof joints
    kind, lower, upper = model.kind[one], model.lower[one], model.upper[one]
    lo = np.where(kind == PRISMATIC, np.where(np.isfinite(lower), lower, -0.5), -np.pi)
    hi = np.where(kind == PRISMATIC, np.where(np.isfinite(upper), upper, 0.5), np.pi)
    q = np.empty((n, model.nq))
    q[:, model.idx_q[one]] = rng.uniform(lo, hi, (n, one.size))
    for i in np.flatnonzero(model.nqs > 1):                # free flyer: position in a cube; orientations uniform
        k = model.idx_q[i]
        if model.kind[i] == PLANAR:                         # planar: position in a square, angle uniform
            th = rng.uniform(-np.pi, np.pi, n)
            q[:, k:k + 4] = np.column_stack([rng.uniform(-FREE_RANGE, FREE_RANGE, (n, 2)), np.cos(th), np.sin(th)])
            continue
        if model.kind[i] not in (FREEFLYER, BALL):          # every kind has its branch
            raise ValueError(f"random_states: joint kind {int(model.kind[i])} has no branch (manipdyn.joints)")
        if model.kind[i] == FREEFLYER:
            q[:, k:k + 3] = rng.uniform(-FREE_RANGE, FREE_RANGE, (n, 3))
            k += 3
        u = rng.normal(size=(n, 4))
        q[:, k:k + 4] = u / np.linalg.norm(u, axis=1, keepdims=True)
    return q, rng.normal(0.0, 2.0, (n, model.nv)), rng.normal(0.0, 5.0, (n, model.nv))


def random_wrenches(model, rng, k=3):
    """Up to k random external wrenches on random non-base frames (merged frames included)."""
    names = sorted(n for n, fr in model.frames.items() if fr.body >= 0)
    pick = rng.choice(len(names), size=min(k, len(names)), replace=False) if names else []
    return {names[i]: (rng.normal(0, 10, 3), rng.normal(0, 2, 3)) for i in pick}


def validate(model, urdf_path, *, n_states=1000, seed=0, tol=1e-12, progress=None, lagrange=True) -> Report:
    """Compare every Newton–Euler term of ``model`` with Pinocchio's model of ``urdf_path``.

    ``model`` may differ from the file (a planted fault, a reduced model): the report then names the
    first link, from the root outward, whose own kinematics or inertial terms diverge.
    """
    t0 = time.perf_counter()
    ref, rng = Reference(model, urdf_path), np.random.default_rng(seed)
    Q, V, A = random_states(model, n_states, rng)
    guard = _Guard(model)
    worst, link_err = _newton_euler_terms(model, ref, Q, V, A, rng, guard, progress)
    rep = Report(model.name, str(urdf_path), model.nv, n_states, seed, seconds=0.0)
    if model.floating:
        rep.notes.append(f"free-flyer root {model.joint_names[0]!r}: nq = {model.nq}, nv = {model.nv}; q compared "
                         f"with Pinocchio's buildModelFromUrdf(path, JointModelFreeFlyer())")
    rep.terms = [_result(k, TERMS[k][0], worst, guard, tol) for k in TERMS]
    if lagrange:
        dyn = _lagrange_terms(model, ref, Q, V, A, rng.normal(0.0, 5.0, V.shape), progress, guard)
        rep.terms += [_result(k, DYN_TERMS[k], dyn, guard, tol) for k in DYN_TERMS]
    if model.constraints:
        cl, rank = closed_chain_terms(model, ref, Q, rng, progress)
        rep.notes.append(f"closures: {rank}; Pinocchio constraintDynamics with ProximalSettings{PROXIMAL}")
        rep.terms += [TermResult(k, CLOSED_TERMS[k], cl[k][0], cl[k][1], tol) for k in CLOSED_TERMS]
    if link_err is not None:
        rep.fault, rep.transmitted_differ = _locate(model, link_err, tol)
    rep.notes += guard.notes()
    rep.seconds = time.perf_counter() - t0
    return rep


class _Guard:
    """Runs our side of a term. On a floating model an exception marks the term "not supported" (its reason
    kept for the report) and the term is not tried again; on a fixed-base model errors propagate."""

    def __init__(self, model):
        self.floating, self.failed = model.floating, {}      # term key -> reason

    def __call__(self, keys, fn):
        if any(k in self.failed for k in keys):
            return None
        if not self.floating:
            return fn()
        try:
            return fn()
        except Exception as exc:                               # a bug shows in the report, not hidden
            why = f"{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"
            self.failed.update(dict.fromkeys(keys, why))
            return None

    def notes(self):
        by_reason = {}
        for k, why in self.failed.items():
            by_reason.setdefault(why, []).append(k)
        return [f"not supported on a floating base yet: {', '.join(ks)} ({why})" for why, ks in by_reason.items()]


def _result(k, label, worst, guard, tol):
    """The TermResult of term k: its worst [abs, err], or "not supported" when our side failed."""
    if k in guard.failed:
        return TermResult(k, label, float("nan"), float("nan"), tol, supported=False)
    return TermResult(k, label, worst[k][0], worst[k][1], tol)


def _newton_euler_terms(model, ref, Q, V, A, rng, guard, progress):
    """Worst [abs, err] of every Newton–Euler term (TERMS), and the per-link errors of a link's own terms
    (None when our side is not supported)."""
    plain = [k for k in TERMS if not k.endswith("ext")]
    ours = guard(plain, lambda: rnea_terms(model, Q, V, A))
    if ours is not None:
        ours["nO"] = ours["nc"] + np.cross(model.com, ours["fc"])  # inertial moment about the origin
    worst = {k: [0.0, 0.0] for k in TERMS}                         # term -> [max_abs, err]
    link_err = {k: np.zeros(model.njoints) for k in plain if TERMS[k][1] != "torque"}
    for s in range(Q.shape[0]):
        theirs = ref.terms(Q[s], V[s], A[s])
        fx, frame = random_wrenches(model, rng), ("local", "world")[s % 2]
        ext_ours = guard(("f_ext", "n_ext", "tau_ext"),
                         lambda: rnea_terms(model, Q[s], V[s], A[s], f_ext=fx, f_ext_frame=frame))
        pairs = {}
        if ours is not None:
            pairs = {k: (ours[k][s], theirs[k]) for k in link_err}
            pairs["tau"] = (ours["tau"][s], theirs["tau"])
        if ext_ours is not None:
            ext_theirs = ref.terms(Q[s], V[s], A[s], f_ext=fx, f_ext_frame=frame)
            for k in ("f", "n", "tau"):
                pairs[k + "_ext"] = (ext_ours[k], ext_theirs[k])
        for k, (x, y) in pairs.items():
            worst[k][0] = max(worst[k][0], float(np.max(np.abs(x - y))))
            worst[k][1] = max(worst[k][1], error(x, y))
            if k in link_err:   # per link, scaled by the whole term as the measure is
                scale = max(np.max(np.abs(y)), 1.0)
                link_err[k] = np.maximum(link_err[k], np.max(np.abs(x - y), axis=-1) / scale)
        if progress is not None:
            progress(1)
    return worst, (link_err if ours is not None else None)


def _lagrange_terms(model, ref, Q, V, A, T, progress, guard, chunk=250):
    """M both ways, C, g, C q̇ + g, q̈ both ways, Jacobians and J̇ against Pinocchio; worst [abs, err]."""
    worst = {k: [0.0, 0.0] for k in DYN_TERMS}
    ours_of = dict(   # term -> our route on a chunk (q, v, t)
        M_crba=lambda q, v, t: mass_matrix(model, q),
        M_lagrange=lambda q, v, t: mass_matrix(model, q, method="lagrange"),
        C=lambda q, v, t: coriolis_matrix(model, q, v), g=lambda q, v, t: gravity_torques(model, q),
        qdd_aba=lambda q, v, t: aba(model, q, v, t),
        qdd_cholesky=lambda q, v, t: forward_dynamics(model, q, v, t, method="cholesky", joint_dynamics=False),
        J_local_world_aligned=lambda q, v, t: _jacobians(model, q, None, "local_world_aligned"),
        J_local=lambda q, v, t: _jacobians(model, q, None, "local"),
        dJ_local_world_aligned=lambda q, v, t: _jacobians(model, q, v, "local_world_aligned"),
        dJ_local=lambda q, v, t: _jacobians(model, q, v, "local"),
        Y=lambda q, v, t: joint_torque_regressor(model, q, v, a))          # a: this chunk's q̈
    for s0 in range(0, Q.shape[0], chunk):
        q, v, a, t = (X[s0:s0 + chunk] for X in (Q, V, A, T))
        ours = {k: guard((k,), lambda: f(q, v, t)) for k, f in ours_of.items()}
        d_tau = guard(("dtau_dq", "dtau_dv"), lambda: rnea_derivatives(model, q, v, a))
        d_qdd = guard(("dqdd_dq", "dqdd_dv"), lambda: aba_derivatives(model, q, v, t))
        ours.update(dict(zip(("dtau_dq", "dtau_dv"), d_tau or ())), **dict(zip(("dqdd_dq", "dqdd_dv"), d_qdd or ())))
        if ours["C"] is not None and ours["g"] is not None:
            ours["nle"] = np.einsum("nij,nj->ni", ours["C"], v) + ours["g"]
        tau_ne = guard(("lagrange_ne",), lambda: rnea(model, q, v, a))
        if ours.get("nle") is not None and ours["M_crba"] is not None:
            ours["lagrange_ne"] = np.einsum("nij,nj->ni", ours["M_crba"], a) + ours["nle"]
        for k in ("nle", "lagrange_ne"):                       # built from terms that failed
            if ours.get(k) is None and k not in guard.failed:
                guard.failed[k] = "built from a term that is not supported"
        for s in range(q.shape[0]):
            theirs = {**ref.dynamics(q[s], v[s], t[s]), **ref.jacobians(q[s], v[s]),
                      **ref.derivatives(q[s], v[s], a[s], t[s])}
            theirs.update(M_crba=theirs["M"], M_lagrange=theirs["M"], lagrange_ne=None if tau_ne is None else tau_ne[s],
                          qdd_aba=theirs["qdd"], qdd_cholesky=theirs["qdd"])
            theirs["Y"] = ref.regressor(q[s], v[s], a[s])
            for k in DYN_TERMS:
                if ours.get(k) is None:
                    continue
                x, y = ours[k][s], theirs[k]
                scale = theirs["cond"] if k.startswith(("qdd", "dqdd")) else 1.0
                worst[k][1] = max(worst[k][1], error(x, y) / scale)
                worst[k][0] = max(worst[k][0], float(np.max(np.abs(x - y))))
            if progress is not None:
                progress(1)
    return worst


def _jacobians(model, q, v, frame):
    """Every body frame's J (v None) or J̇, world-aligned or local: (N, nb, 6, nv)."""
    if v is None:
        return np.stack([frame_jacobian(model, q, b, frame) for b in model.body_names], 1)
    return np.stack([frame_jacobian_dot(model, q, v, b, frame) for b in model.body_names], 1)


def _locate(model, link_err, tol):
    """First link (q order: root outward) whose own terms fail: kinematics first, then inertial."""
    fault = None
    for i, body in enumerate(model.body_names):
        for kind in ("kinematics", "inertial"):
            bad = [TERMS[k][0] for k, e in link_err.items() if TERMS[k][1] == kind and e[i] > tol]
            if bad and fault is None:
                fault = f"link {body!r} (joint {model.joint_names[i]!r}): {kind} terms differ: {', '.join(bad)}"
    differ = [b for i, b in enumerate(model.body_names)
              if max(link_err["f"][i], link_err["n"][i]) > tol]
    return fault, differ


def format_report(rep: Report) -> str:
    """A readable table: term, max abs err, err measure, tolerance, pass/fail."""
    lines = [f"{rep.name}  ({rep.source})  nv={rep.nv}  states={rep.n_states}  seed={rep.seed}  "
             f"{rep.seconds:.1f} s",
             f"  {'term':<44} {'max abs err':>12} {'err measure':>12} {'tol':>8}  result"]
    for t in rep.terms:
        if not t.supported:
            lines.append(f"  {t.label:<44} {'-':>12} {'-':>12} {t.tol:8.0e}  not supported")
            continue
        lines.append(f"  {t.label:<44} {t.max_abs:12.3e} {t.err:12.3e} {t.tol:8.0e}  "
                     f"{'pass' if t.passed else 'FAIL'}")
    if rep.fault:
        lines.append(f"  first divergence: {rep.fault}")
        lines.append(f"  transmitted forces differ on: {', '.join(rep.transmitted_differ)} (ancestors confirm)")
    lines += [f"  {n}" for n in rep.notes]
    lines.append(f"  => {'PASS' if rep.passed else 'FAIL'}")
    return "\n".join(lines)
