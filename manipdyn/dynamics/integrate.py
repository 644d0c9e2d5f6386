"""Forward simulation: semi-implicit (symplectic) Euler, RK4, and scipy's solve_ivp as the adaptive reference.

State x = (q, q̇); q̈ = f(t, q, q̇) from forward dynamics (ABA or the Cholesky route for trees; Lagrange's
equations of the 1st kind for closed chains, optionally Baumgarte-stabilised or projected back onto the
closures after every step). Fixed-step methods integrate a batch (N, nv) at once.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import DivergenceError, InputError
from .aba import forward_dynamics
from .state import as_batch


@dataclass(frozen=True)
class SimResult:
    """A simulated trajectory: t (T,), q and v (T, nv) — or (N, T, nv) for a batch of N initial states."""
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    method: str
    dt: float
    n_steps: int
    wall_time: float


def _torque(tau, nv):
    """τ(t, q, v) for None, a constant (nv,) array or a callable."""
    if tau is None:
        return lambda t, q, v: np.zeros_like(q)
    if callable(tau):
        return tau
    tau = np.asarray(tau, float)
    if tau.shape != (nv,):
        raise InputError(f"tau has shape {tau.shape}; expected ({nv},), None or a callable tau(t, q, v)")
    return lambda t, q, v: np.broadcast_to(tau, q.shape)


def accelerations(model, forward="aba", stabilization="none", baumgarte=(10.0, 10.0)):
    """q̈ = f(t, q, q̇, τ) for this model: tree forward dynamics, or the closed-chain KKT solve."""
    if model.constraints:
        from ..constraints import constrained_forward_dynamics
        bg = baumgarte if stabilization == "baumgarte" else None
        return lambda q, v, tau: constrained_forward_dynamics(model, q, v, tau, baumgarte=bg)[0]
    return lambda q, v, tau: forward_dynamics(model, q, v, tau, method=forward)


def _step(method, accel, torque, t, q, v, h):
    """One step of size h: semi-implicit Euler or classical RK4."""
    if method == "euler":                       # v_{k+1} = v_k + h q̈(q_k, v_k); q_{k+1} = q_k + h v_{k+1}
        v1 = v + h * accel(q, v, torque(t, q, v))
        return q + h * v1, v1
    k1q, k1v = v, accel(q, v, torque(t, q, v))
    k2q, k2v = v + 0.5 * h * k1v, accel(q + 0.5 * h * k1q, v + 0.5 * h * k1v, torque(t + 0.5 * h, q + 0.5 * h * k1q, v + 0.5 * h * k1v))
    k3q, k3v = v + 0.5 * h * k2v, accel(q + 0.5 * h * k2q, v + 0.5 * h * k2v, torque(t + 0.5 * h, q + 0.5 * h * k2q, v + 0.5 * h * k2v))
    k4q, k4v = v + h * k3v, accel(q + h * k3q, v + h * k3v, torque(t + h, q + h * k3q, v + h * k3v))
    return q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q), v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)


def simulate(model, q0, v0, t_span, *, tau=None, dt=1e-3, method="rk4", rtol=1e-10, atol=1e-12,
             forward="aba", stabilization="none", baumgarte=(10.0, 10.0)):
    """Integrate the equations of motion from (q0, v0) over t_span = (t0, t1).

    tau: None, a constant (nv,) array or a callable tau(t, q, v) (batches: (N, nv) in and out).
    method: "euler" (semi-implicit), "rk4" (fixed dt; the last step is shortened to end at t1), or
    "adaptive" (scipy DOP853 at rtol/atol, one state at a time, every internal step returned).
    Closed chains: stabilization "none", "baumgarte" (alpha, beta) or "projection" (after every step).
    Raises DivergenceError naming the time (and row) at which the state stops being finite.
    """
    (Q, V), single = as_batch(model, q0=q0, v0=v0)
    t0, t1 = (float(x) for x in t_span)
    if not t1 > t0:
        raise InputError(f"t_span {t_span}: the end must come after the start")
    if stabilization not in ("none", "baumgarte", "projection"):
        raise InputError(f"stabilization must be 'none', 'baumgarte' or 'projection', not {stabilization!r}")
    accel, torque = accelerations(model, forward, stabilization, baumgarte), _torque(tau, model.nv)
    if single and callable(tau):               # a single state: the callable sees (nv,) arrays
        user = torque
        torque = lambda t, q, v: np.asarray(user(t, q[0], v[0]), float).reshape(1, -1)  # noqa: E731
    start = time.perf_counter()
    if method == "adaptive":
        if not single:
            raise InputError("method='adaptive' runs one initial state at a time; pass q0, v0 of shape (nv,)")
        T, Qs, Vs = _adaptive(model, accel, torque, Q[0], V[0], t0, t1, rtol, atol)
        return SimResult(T, Qs, Vs, method, float("nan"), len(T) - 1, time.perf_counter() - start)
    if method not in ("euler", "rk4"):
        raise InputError(f"method must be 'euler', 'rk4' or 'adaptive', not {method!r}")
    n = int(np.ceil((t1 - t0) / dt - 1e-9))
    T = np.minimum(t0 + dt * np.arange(n + 1), t1)
    Qs, Vs = np.empty((n + 1,) + Q.shape), np.empty((n + 1,) + V.shape)
    Qs[0], Vs[0] = Q, V
    project = _projector(model) if stabilization == "projection" else None
    for k in range(n):
        try:
            Q, V = _step(method, accel, torque, T[k], Q, V, T[k + 1] - T[k])
        except InputError as exc:               # a non-finite state or torque met inside the step
            raise DivergenceError(f"simulation of {model.name!r} diverged at t = {T[k]:.6g} s: {exc}") from None
        if project is not None:
            Q, V = project(Q, V)
        if not (np.all(np.isfinite(Q)) and np.all(np.isfinite(V))):
            row = int(np.argwhere(~np.isfinite(np.hstack([Q, V])))[0][0])
            raise DivergenceError(f"simulation of {model.name!r} diverged at t = {T[k + 1]:.6g} s"
                                  + ("" if single else f" (initial state {row})") + ": state is not finite")
        Qs[k + 1], Vs[k + 1] = Q, V
    Qs, Vs = np.moveaxis(Qs, 0, 1), np.moveaxis(Vs, 0, 1)       # (N, T, nv)
    return SimResult(T, Qs[0] if single else Qs, Vs[0] if single else Vs, method, dt, n,
                     time.perf_counter() - start)


def _projector(model):
    from ..constraints import project
    return lambda Q, V: project(model, Q, V)


def _adaptive(model, accel, torque, q0, v0, t0, t1, rtol, atol):
    """scipy solve_ivp (DOP853) on x = (q, q̇); raises DivergenceError on a non-finite state."""
    from scipy.integrate import solve_ivp
    nv = model.nv

    def rhs(t, x):
        q, v = x[:nv], x[nv:]
        try:
            a = accel(q, v, np.asarray(torque(t, q[None], v[None]), float).reshape(-1))
        except InputError as exc:
            raise DivergenceError(f"simulation of {model.name!r} diverged at t = {t:.6g} s: {exc}") from None
        if not np.all(np.isfinite(a)):
            raise DivergenceError(f"simulation of {model.name!r} diverged at t = {t:.6g} s: q̈ is not finite")
        return np.concatenate([v, a])

    sol = solve_ivp(rhs, (t0, t1), np.concatenate([q0, v0]), method="DOP853", rtol=rtol, atol=atol)
    if sol.status != 0:
        raise DivergenceError(f"simulation of {model.name!r} stopped at t = {sol.t[-1]:.6g} s: {sol.message}")
    return sol.t, sol.y[:nv].T, sol.y[nv:].T
