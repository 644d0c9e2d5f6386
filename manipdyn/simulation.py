"""Forward simulation: semi-implicit (symplectic) Euler, RK4, and scipy's solve_ivp as the adaptive reference.

State x = (q, q̇); q̈ = f(t, q, q̇) from forward dynamics (ABA or the Cholesky route for trees; Lagrange's
equations of the 1st kind for closed chains, optionally Baumgarte-stabilised or projected back onto the
closures after every step). The fixed-step integrators take a batch (N, nv) at once.

Configurations move by the joint model's ``integrate`` (q ⊕ ξ), never by q + ξ: for revolute and
prismatic joints the two are the same, for a free-flyer root ξ is a body-frame twist and q ⊕ ξ =
M(q) exp6(ξ), for a ball joint a body-frame rotation vector and q ⊕ ξ = quat ⊗ exp(ξ). RK4 is then the
Runge–Kutta–Munthe-Kaas method: the stages live in the tangent space at q_k, where ξ̇ = dexp⁻¹_{−ξ}(v) =
v + ½ [ξ, v] + 1/12 [ξ, [ξ, v]] (fourth order; the brackets vanish for 1-dof joints; se(3)'s for a free
flyer, ξ × v for a ball joint). The adaptive reference integrates q̇ = (R v_lin, ½ quat ⊗ ω) for a free
flyer, ½ quat ⊗ ω for a ball joint.

This module sits above dynamics/ and constraints/ (it calls both), so neither of them imports it.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .configuration import check_quaternions
from .constraints import constrained_forward_dynamics, project
from .dynamics.aba import forward_dynamics, passive_torques
from .dynamics.arguments import as_batch, as_real, check_finite, check_scalar
from .errors import DivergenceError, InputError, NumericalError
from .joints import BALL, FREEFLYER, PLANAR, motion_subspace, quat_rotation


@dataclass(frozen=True)
class SimResult:
    """A simulated trajectory: t (T,), q and v (T, nv) — or (N, T, nv) for a batch of N initial states."""
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    integrator: str       # "euler", "rk4" or "adaptive"
    dt: float
    n_steps: int
    wall_time: float


class _TorqueError(InputError):
    """tau(t, q, v) returned something that is not a torque array of the state's shape (``shape``) or a
    non-finite torque."""

    def __init__(self, message, shape=False):
        super().__init__(message)
        self.shape = shape


def _torque(tau, shape, single, names):
    """τ(t, q, v) for None, a constant (nv,) or (N, nv) array or a callable, checked on every call: the
    callable must return real values of the state's shape ((nv,) for one state), finite."""
    if tau is None:
        return lambda t, q, v: np.zeros_like(v)
    if not callable(tau):
        tau = as_real("tau", tau)
        if tau.shape not in (shape[1:], shape):
            raise InputError(f"tau has shape {tau.shape}; expected {shape[1:]}"
                             + ("" if single else f" or {shape}") + ", None or a callable tau(t, q, v)")
        check_finite("tau", tau)
        return lambda t, q, v: np.broadcast_to(tau, v.shape)
    user = tau

    def checked(t, q, v):
        try:
            out = as_real(f"tau(t, q, v) at t = {t:.6g} s", user(t, q[0], v[0]) if single else user(t, q, v))
        except InputError as exc:
            raise _TorqueError(str(exc), True) from None
        want = v.shape[1:] if single else v.shape
        if out.shape != want:
            raise _TorqueError(f"tau(t, q, v) returned shape {out.shape} at t = {t:.6g} s; expected {want}", True)
        bad = ~np.isfinite(out)
        if bad.any():
            i = np.argwhere(bad)[0]
            raise _TorqueError(f"tau(t, q, v) returned {out[tuple(i)]} at t = {t:.6g} s"
                               + ("" if single else f", initial state {i[0]}") + f", joint {names[i[-1]]!r}")
        return out.reshape(v.shape)
    return checked


def accelerations(model, method="aba", stabilization="none", baumgarte=(10.0, 10.0), joint_dynamics=True):
    """q̈ = f(t, q, q̇, τ) for this model: tree forward dynamics by ``method`` ("aba" or "cholesky"), or the
    closed-chain KKT solve; with joint_dynamics the joints' damping and friction act (τ − ``passive_torques``)."""
    if model.constraints:
        bg = baumgarte if stabilization == "baumgarte" else None

        def closed(q, v, tau):
            loss = passive_torques(model, v) if joint_dynamics else None
            return constrained_forward_dynamics(model, q, v, tau if loss is None else tau - loss, baumgarte=bg)[0]
        return closed
    return lambda q, v, tau: forward_dynamics(model, q, v, tau, method=method, joint_dynamics=joint_dynamics)


def _step(integrator, accel, torque, t, q, v, h, plus=np.add, dexpinv=None):
    """One step of size h: semi-implicit Euler or classical RK4 (RKMK on a free flyer: q ⊕ ξ = plus(q, ξ),
    ξ̇ = dexpinv(ξ, v); for 1-dof joints plus is + and dexpinv returns v)."""
    if integrator == "euler":                   # v_{k+1} = v_k + h q̈(q_k, v_k); q_{k+1} = q_k ⊕ h v_{k+1}
        v1 = v + h * accel(q, v, torque(t, q, v))
        return plus(q, h * v1), v1
    rate = (lambda xi, w: w) if dexpinv is None else dexpinv
    k1q, k1v = v, accel(q, v, torque(t, q, v))
    x2, v2 = 0.5 * h * k1q, v + 0.5 * h * k1v
    q2 = plus(q, x2)
    k2q, k2v = rate(x2, v2), accel(q2, v2, torque(t + 0.5 * h, q2, v2))
    x3, v3 = 0.5 * h * k2q, v + 0.5 * h * k2v
    q3 = plus(q, x3)
    k3q, k3v = rate(x3, v3), accel(q3, v3, torque(t + 0.5 * h, q3, v3))
    x4, v4 = h * k3q, v + h * k3v
    q4 = plus(q, x4)
    k4q, k4v = rate(x4, v4), accel(q4, v4, torque(t + h, q4, v4))
    return plus(q, h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)), v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)


def _group_ops(model):
    """(plus, dexpinv) of the configuration space: (np.add, None) where q ⊕ v is q + v (no quaternion, no planar
    joint); else q ⊕ ξ by the joint model's integrate and ξ̇ = v + ½ ad_ξ v + 1/12 ad_ξ² v on the entries of every
    joint of several velocities (free flyer, ball, planar): ad_ξ w = S ad6(Sᵀ ξ) Sᵀ w with the joint's motion
    subspace S (nv_j, 6) and se(3)'s ad6(ξ) w = [ξ_ω × w_v + ξ_v × w_ω; ξ_ω × w_ω] (twists [linear; angular]): a
    ball joint's ξ × w, a planar joint's se(2) bracket."""
    if not model.unit_q.size:
        return np.add, None
    from .configuration import _arrays
    from .joints import integrate_kernel
    kind, _, iq, iv = _arrays(model)

    def plus(Q, X):
        out = np.empty_like(Q)
        integrate_kernel(kind, iq, iv, np.ascontiguousarray(Q), np.ascontiguousarray(X), out)
        return out

    S = np.concatenate([motion_subspace(k, a, h) for k, a, h in zip(model.kind, model.axis, model.pitch)])
    blocks = [slice(int(b), int(b) + int(n)) for b, n in zip(model.idx_v, model.nvs) if n > 1]

    def ad(Sb, xi, w):
        x, y = xi @ Sb, w @ Sb
        return np.concatenate([np.cross(x[:, 3:6], y[:, :3]) + np.cross(x[:, :3], y[:, 3:6]),
                               np.cross(x[:, 3:6], y[:, 3:6])], axis=1) @ Sb.T

    def dexpinv(xi, v):
        out = v.copy()
        for b in blocks:
            a1 = ad(S[b], xi[:, b], v[:, b])
            out[:, b] += 0.5 * a1 + ad(S[b], xi[:, b], a1) / 12.0
        return out
    return plus, dexpinv


INTEGRATORS = ("euler", "rk4", "adaptive")
MAX_POSITION = 1e6  # |q| (rad, m) and |q̇| (rad/s, m/s) beyond any manipulator's range: a runaway (at
MAX_RATE = 1e4      # |q| = 1e6 a double resolves 1e-10, the default rtol; 1e4 rad/s ≈ 95 000 rpm)


def simulate(model, q0, v0, t_span, *, tau=None, dt=1e-3, integrator="rk4", method="aba", rtol=1e-10,
             atol=1e-12, stabilization="none", baumgarte=(10.0, 10.0), max_steps=None, max_position=MAX_POSITION,
             max_rate=MAX_RATE, joint_dynamics=True):
    """Integrate the equations of motion from (q0, v0) over t_span = (t0, t1).

    tau: None, a constant (nv,) (or (N, nv)) array or a callable tau(t, q, v) (batches: (N, nv) in and out).
    integrator: "euler" (semi-implicit), "rk4" (fixed dt; the last step is shortened to end at t1), or
    "adaptive" (scipy DOP853 at rtol/atol, one state at a time, every internal step returned).
    method: the forward-dynamics route of a tree, as in ``forward_dynamics``: "aba" (default) or "cholesky";
    closed chains always solve the KKT system of ``constrained_forward_dynamics``.
    joint_dynamics: the model's damping and Coulomb friction act on the joints (τ − damping ⊙ q̇ − friction ⊙
    tanh(q̇ / ε), ε = model.FRICTION_EPS; ``forward_dynamics``); False leaves them out. Armature is part of M
    either way.
    Closed chains: stabilization "none", "baumgarte" (alpha, beta) or "projection" (after every step).

    The work is bounded: fixed-step runs refuse a dt whose step count (t1 − t0)/dt exceeds ``max_steps``
    (default 10⁷) with InputError before starting; adaptive runs stop after ``max_steps`` steps (default
    10⁵) with DivergenceError. A non-finite state, |q| beyond ``max_position`` (default 10⁶ rad or m) or
    |q̇| beyond ``max_rate`` (default 10⁴ rad/s or m/s) raise DivergenceError naming the time, the joint
    (and the initial state of a batch): huge torques end there within a few steps instead of driving
    the adaptive integrator into ever smaller steps.
    tau(t, q, v) must return real values of the state's shape: InputError otherwise (a non-finite
    torque at t0 is an InputError; later, DivergenceError: the controller followed a diverging state).
    """
    (Q, V), single = as_batch(model, q0=q0, v0=v0)
    check_quaternions(model, Q, "q0")
    t0, t1 = _span(t_span)
    if not isinstance(integrator, str) or integrator not in INTEGRATORS:
        raise InputError(f"integrator must be 'euler', 'rk4' or 'adaptive', not {integrator!r}")
    if isinstance(method, str) and method in INTEGRATORS:
        raise InputError(f"method={method!r} names an integrator: use integrator={method!r} (method is the "
                         f"forward-dynamics route, 'aba' or 'cholesky', as in forward_dynamics)")
    if not isinstance(method, str) or method not in ("aba", "cholesky"):
        raise InputError(f"method must be 'aba' or 'cholesky' (the forward-dynamics route), not {method!r}")
    if not isinstance(stabilization, str) or stabilization not in ("none", "baumgarte", "projection"):
        raise InputError(f"stabilization must be 'none', 'baumgarte' or 'projection', not {stabilization!r}")
    if stabilization == "baumgarte":
        baumgarte = _pair("baumgarte", baumgarte)
    bounds = tuple(check_scalar(n, x, positive=True) for n, x in (("max_position", max_position),
                                                                   ("max_rate", max_rate)))
    max_steps = check_scalar("max_steps", (10**5 if integrator == "adaptive" else 10**7) if max_steps is None
                             else max_steps, positive=True, integer=True)
    accel, torque = accelerations(model, method, stabilization, baumgarte, joint_dynamics), _torque(tau, V.shape, single, model.v_names)
    watch = _Watch(model, single, bounds, t0)
    try:
        watch(t0, Q, V)
    except DivergenceError as exc:
        raise InputError(f"initial state: {str(exc).split(': ', 1)[1]}") from None
    start = time.perf_counter()
    if integrator == "adaptive":
        if not single:
            raise InputError("integrator='adaptive' runs one initial state at a time; pass q0, v0 of shape (nv,)")
        rtol, atol = (check_scalar(n, x, positive=True) for n, x in (("rtol", rtol), ("atol", atol)))
        T, Qs, Vs = _adaptive(model, accel, torque, Q[0], V[0], t0, t1, rtol, atol, max_steps, watch)
        return SimResult(T, Qs, Vs, integrator, float("nan"), len(T) - 1, time.perf_counter() - start)
    T = _grid(t0, t1, check_scalar("dt", dt, positive=True), max_steps)
    n = len(T) - 1
    Qs, Vs = np.empty((n + 1,) + Q.shape), np.empty((n + 1,) + V.shape)
    Qs[0], Vs[0] = Q, V
    project = _projector(model) if stabilization == "projection" else None
    plus, dexpinv = _group_ops(model)
    for k in range(n):
        try:
            Q, V = _step(integrator, accel, torque, T[k], Q, V, T[k + 1] - T[k], plus, dexpinv)
            if project is not None:
                Q, V = project(Q, V)
        except _TorqueError as exc:
            watch.torque(T[k], exc)
        except (InputError, NumericalError) as exc:     # a non-finite state met inside the step
            raise DivergenceError(f"simulation of {model.name!r} diverged at t = {T[k]:.6g} s: {exc}") from None
        watch(T[k + 1], Q, V)
        Qs[k + 1], Vs[k + 1] = Q, V
    Qs, Vs = np.moveaxis(Qs, 0, 1), np.moveaxis(Vs, 0, 1)       # (N, T, nq), (N, T, nv)
    return SimResult(T, Qs[0] if single else Qs, Vs[0] if single else Vs, integrator, float(dt), n,
                     time.perf_counter() - start)


def _span(t_span):
    """(t0, t1): two finite real numbers with t1 > t0."""
    try:
        t0, t1 = t_span
    except (TypeError, ValueError):
        raise InputError(f"t_span must be a pair (t0, t1), not {t_span!r}") from None
    t0, t1 = (check_scalar(f"t_span[{k}]", x) for k, x in enumerate((t0, t1)))
    if not t1 > t0:
        raise InputError(f"t_span {t_span}: the end must come after the start")
    return t0, t1


def _pair(name, x):
    """Two finite real numbers ≥ 0 (Baumgarte's alpha, beta)."""
    try:
        a, b = x
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a pair (alpha, beta), not {x!r}") from None
    return tuple(check_scalar(f"{name}[{k}]", y, nonnegative=True) for k, y in enumerate((a, b)))


def _grid(t0, t1, dt, max_steps):
    """Step times t0, t0 + dt, ..., t1 (the last step shortened), at most max_steps steps, increasing."""
    steps = (t1 - t0) / dt
    if not steps <= max_steps:
        raise InputError(f"dt = {dt:g} s over t_span ({t0:g}, {t1:g}) needs {steps:.3g} steps, more than "
                         f"max_steps = {max_steps}; take a larger dt or raise max_steps")
    n = max(int(np.ceil(steps - 1e-9)), 1)
    T = np.minimum(t0 + dt * np.arange(n + 1), t1)
    T[-1] = t1
    if np.any(np.diff(T) <= 0):
        raise InputError(f"dt = {dt:g} s is below the resolution of t near {t0:g} s: time would not advance")
    return T


class _Watch:
    """Raises DivergenceError when a state is non-finite or beyond max_state, naming time and row."""

    def __init__(self, model, single, bounds, t0):
        self.model, self.single, self.bounds, self.t0 = model, single, bounds, t0

    def __call__(self, t, Q, V):
        X = np.hstack([Q, V])
        nq = self.model.nq
        bad = ~(np.abs(X) <= np.repeat(self.bounds, (nq, self.model.nv)))      # NaN counts as bad
        if bad.any():
            row, col = (int(i) for i in np.argwhere(bad)[0])
            k = int(col >= nq)
            what, joint = ("q", "v")[k], (self.model.q_names[col] if k == 0 else self.model.v_names[col - nq])
            why = "is not finite" if not np.isfinite(X[row, col]) else \
                f"exceeds {('max_position', 'max_rate')[k]} = {self.bounds[k]:g}"
            raise DivergenceError(f"simulation of {self.model.name!r} diverged at t = {t:.6g} s"
                                  + ("" if self.single else f" (initial state {row})")
                                  + f": {what}[{joint!r}] = {X[row, col]:.3g} {why}")

    def torque(self, t, exc):
        """A bad torque: wrong shape always InputError; non-finite at t0 InputError, later divergence."""
        if exc.shape or t == self.t0:
            raise InputError(str(exc)) from None
        raise DivergenceError(f"simulation of {self.model.name!r} diverged at t = {t:.6g} s: {exc}") from None


def _projector(model):
    return lambda Q, V: project(model, Q, V)


def _adaptive(model, accel, torque, q0, v0, t0, t1, rtol, atol, max_steps, watch):
    """scipy's DOP853 on x = (q, q̇), stepped here so every step is watched (non-finite, beyond the
    bounds) and counted (at most max_steps); returns every accepted step as solve_ivp does."""
    nq = model.nq
    qdot = _qdot(model)
    def rhs(t, x):
        q, v = x[:nq], x[nq:]
        if model.unit_q.size:                                # the solver's q drifts off ‖quat‖ = 1
            q = q.copy()
            for k, m in model.unit_q:
                q[k:k + m] /= np.linalg.norm(q[k:k + m])
        try:
            a = accel(q, v, torque(t, q[None], v[None])[0])
        except _TorqueError as exc:
            watch.torque(t, exc)
        except (InputError, NumericalError) as exc:
            raise DivergenceError(f"simulation of {model.name!r} diverged at t = {t:.6g} s: {exc}") from None
        return np.concatenate([qdot(q, v), a])

    with np.errstate(over="ignore", invalid="ignore"):       # the watch reports what overflows
        return _dop853(model, rhs, q0, v0, t0, t1, rtol, atol, max_steps, watch)


def _dop853(model, rhs, q0, v0, t0, t1, rtol, atol, max_steps, watch):
    """The stepping loop of _adaptive."""
    from scipy.integrate import DOP853
    nq = model.nq
    solver = DOP853(rhs, t0, np.concatenate([q0, v0]), t1, rtol=rtol, atol=atol)
    ts, ys = [t0], [solver.y.copy()]
    while solver.status == "running":
        if len(ts) > max_steps:
            raise DivergenceError(f"simulation of {model.name!r} did not reach t = {t1:g} s within max_steps = "
                                  f"{max_steps} adaptive steps (stopped at t = {solver.t:.6g} s, max |q̇| = "
                                  f"{np.max(np.abs(solver.y[nq:]), initial=0.0):.3g}); raise max_steps or rtol")
        msg = solver.step()
        if solver.status == "failed":
            raise DivergenceError(f"simulation of {model.name!r} stopped at t = {solver.t:.6g} s: {msg}")
        watch(solver.t, solver.y[None, :nq], solver.y[None, nq:])
        ts.append(solver.t)
        ys.append(solver.y.copy())
    Y = np.array(ys)
    for k, m in model.unit_q:
        Y[:, k:k + m] /= np.linalg.norm(Y[:, k:k + m], axis=1, keepdims=True)
    return np.array(ts), Y[:, :nq], Y[:, nq:]


def _qdot(model):
    """q̇(q, v) (nq,): v for 1-dof joints; a free flyer's position moves with R v_lin (world axes); every
    quaternion (free flyer, ball joint) with ½ quat ⊗ (ω, 0) (body-frame ω); a planar joint's (x, y) with R(θ) (v_x,
    v_y) and its (cos θ, sin θ) with ω (−sin θ, cos θ)."""
    if not model.unit_q.size:
        return lambda q, v: v
    odd = set(model.kind[model.nqs > 1].tolist()) - {FREEFLYER, BALL, PLANAR}
    if odd:                                              # every entry of q̇ below has its kind's formula
        raise ValueError(f"simulate: joint kinds {sorted(odd)} have no q̇(q, v) (manipdyn.joints)")
    one = np.flatnonzero(model.nqs == 1)
    one_q, one_v = model.idx_q[one], model.idx_v[one]
    free = np.flatnonzero(model.kind == FREEFLYER)
    free_q, free_v = model.idx_q[free], model.idx_v[free]
    plane = np.flatnonzero(model.kind == PLANAR)

    def qdot(q, v):
        out = np.empty(model.nq)
        out[one_q] = v[one_v]
        for k, r in zip(free_q, free_v):
            out[k:k + 3] = np.array(quat_rotation(*q[k + 3:k + 7])).reshape(3, 3) @ v[r:r + 3]
        for k, r in zip(model.quat_q, model.quat_v):
            x, y, z, w = q[k:k + 4]
            a, b, c = v[r:r + 3]
            out[k:k + 4] = 0.5 * np.array([w * a + y * c - z * b, w * b + z * a - x * c,
                                           w * c + x * b - y * a, -(x * a + y * b + z * c)])
        for j in plane:
            k, r = model.idx_q[j], model.idx_v[j]
            c, sn = q[k + 2], q[k + 3]
            out[k:k + 4] = (c * v[r] - sn * v[r + 1], sn * v[r] + c * v[r + 1], -sn * v[r + 2], c * v[r + 2])
        return out
    return qdot
