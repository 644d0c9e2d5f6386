"""The configuration space: neutral, integrate, difference, random and normalized configurations.

Names and meaning are Pinocchio's (``pin.neutral``, ``pin.integrate``, ``pin.difference``,
``pin.randomConfiguration``, ``pin.normalize``), on manipdyn's q (docs/design.md §3: a continuous joint is one
angle, where Pinocchio stores cos/sin; a free-flyer root is [x y z qx qy qz qw], a ball joint [qx qy qz qw], as in
Pinocchio):

    q ⊕ v         integrate: 1-dof joints q + v; ball quat ⊗ exp(ω); free flyer M(q) exp6(v), v = [linear;
                  angular] body frame; planar M(q) exp(v) in SE(2), v = [vx vy wz] body frame
    q1 ⊖ q0       difference: the v with q0 ⊕ v = q1 (continuous joints: the shortest angle; ball
                  log(quat0⁻¹ quat1); free flyer log6(M(q0)⁻¹ M(q1)); rotation angles ≤ π)

The joint formulas are those of ``manipdyn.joints`` (compiled ``integrate_kernel``/``difference_kernel``);
this module checks the arguments and handles the batch. Every function takes one state (nq,) / (nv,) or a
batch (N, nq) / (N, nv) and returns the matching shape. A free flyer's or ball joint's quaternion must be of unit norm
within ``QUAT_TOL`` (InputError naming the row otherwise; ``normalize`` fixes it): the placement formulas
read it as a rotation.
"""
from __future__ import annotations

import numpy as np

import numba

from .errors import InputError
from ._jit import A1, A2, entry
from .joints import (BALL, FREEFLYER, HELICAL, PLANAR, PRISMATIC, REVOLUTE, difference_kernel, difference_one,
                     integrate_kernel, integrate_one, normalize_kernel, normalize_one)
from .dynamics.arguments import as_batch, check_model, check_scalar, unbatch
from .model import QUAT_TOL, Model

__all__ = ["neutral", "integrate", "difference", "random_configuration", "normalize", "QUAT_TOL"]

REVOLUTE_RANGE = np.pi   # random_configuration: unbounded revolute joints in [−π, π] rad
PRISMATIC_RANGE = 0.5    # ... unbounded prismatic joints in [−0.5, 0.5] m
FREE_RANGE = 1.0         # ... a free flyer's position in [−1, 1]³ m


def _arrays(model):
    """(kind, continuous, idx_q, idx_v) as contiguous arrays (``model.kernel.config``)."""
    return model.kernel.config


# One state: float64 arrays of the model's shapes go straight to a compiled kernel that checks finiteness and the
# unit norms itself (``joints.state_ok``); anything else, or a state it refuses, takes the checked path below,
# which converts, or names the fault.
_F64, _ND = np.dtype(np.float64), np.ndarray
C1 = numba.types.Array(numba.int64, 1, "C")              # KernelForm.config_one
INTEGRATE_ONE = entry(integrate_one, C1, A1, A1, A1)
DIFFERENCE_ONE = entry(difference_one, C1, A1, A1, A1)
NORMALIZE = entry(normalize_kernel, C1, A2, A2)
NORMALIZE_ONE = entry(normalize_one, C1, A1, A1)


def _unit_name(model, k, n):
    """'root_joint.(qx qy qz qw)' or 'base.(c s)': a unit block of q by its joint's name and its entries'."""
    joint = model.q_names[k].rsplit(".", 1)[0]
    what = "quaternion" if n == 4 else "rotation (cos θ, sin θ) of the planar joint"
    return f"{what} {joint}.({' '.join(x.rsplit('.', 1)[1] for x in model.q_names[k:k + n])})"


def check_quaternions(model, Q, name="q"):
    """Refuse a quaternion (free flyer, ball joint) or a planar joint's (cos θ, sin θ) whose norm is not 1 within
    QUAT_TOL (Q in batch form (N, nq)): the placement formulas read them as rotations."""
    for k, m in model.unit_q:
        n = np.linalg.norm(Q[:, k:k + m], axis=1)
        bad = np.flatnonzero(np.abs(n - 1.0) > QUAT_TOL)
        if bad.size:
            r = int(bad[0])
            row = f"[{r}]" if Q.shape[0] > 1 else ""
            raise InputError(f"{name}{row}: the {_unit_name(model, k, m)} = {Q[r, k:k + m].tolist()} has norm "
                             f"{n[r]:.12g}, not 1 (within {QUAT_TOL:g}); normalize it first (manipdyn.normalize)")


def neutral(model) -> np.ndarray:
    """q_neutral (nq,): every joint at 0, a free flyer at the origin, every quaternion the identity (0 0 0 1), a planar
    joint at the origin with (cos θ, sin θ) = (1, 0)."""
    if type(model) is not Model:
        check_model(model)
    return model.kernel.neutral.copy()


def integrate(model, q, v) -> np.ndarray:
    """q ⊕ v (nq,) or (N, nq): the configuration reached from q by moving with velocity v for unit time.

    1-dof joints q + v; a ball joint quat ⊗ exp(ω) (ω in the body frame); a free flyer M(q) exp6(v) with
    v = [linear; angular] in the body frame (SE(3) exponential, Lie group integration as Pinocchio's integrate).
    q (nq,) or (N, nq), v (nv,) or (N, nv).
    """
    if type(model) is Model and type(q) is _ND and type(v) is _ND and q.dtype is _F64 and v.dtype is _F64 and \
            q.ndim == 1 and v.ndim == 1:                # (the kernel checks the lengths: False, then the checked path)
        k = model.kernel
        out = np.empty(k.q_shape)
        if INTEGRATE_ONE.call(k.config_one, q, v, out):
            return out
    (Q, V), single = as_batch(model, q=q, v=v)
    check_quaternions(model, Q)
    kind, _, iq, iv = _arrays(model)
    out = np.empty(Q.shape)
    integrate_kernel(kind, iq, iv, np.ascontiguousarray(Q), np.ascontiguousarray(V), out)
    return unbatch(out, single)


def difference(model, q0, q1) -> np.ndarray:
    """q1 ⊖ q0 (nv,) or (N, nv): the velocity v with integrate(q0, v) = q1.

    1-dof joints q1 − q0 (continuous joints wrapped into [−π, π]); a ball joint log(quat0⁻¹ quat1); a free flyer
    log6(M(q0)⁻¹ M(q1)); rotations of angle ≤ π (at exactly π either direction is a solution).
    """
    if type(model) is Model and type(q0) is _ND and type(q1) is _ND and q0.dtype is _F64 and q1.dtype is _F64 and \
            q0.ndim == 1 and q1.ndim == 1:
        k = model.kernel
        out = np.empty(k.v_shape)
        if DIFFERENCE_ONE.call(k.config_one, q0, q1, out):
            return out
    (Q0, Q1), single = as_batch(model, q0=q0, q1=q1)
    check_quaternions(model, Q0, "q0")
    check_quaternions(model, Q1, "q1")
    kind, continuous, iq, iv = _arrays(model)
    out = np.empty((Q0.shape[0], model.nv))
    difference_kernel(kind, continuous, iq, iv, np.ascontiguousarray(Q0), np.ascontiguousarray(Q1), out)
    return unbatch(out, single)


def random_configuration(model, rng=None, n=None) -> np.ndarray:
    """A random configuration (nq,), or n of them (n, nq), uniform per joint:

    revolute  within [lower, upper] when both are finite, else [−π, π] (continuous joints too);
    prismatic within [lower, upper] when both are finite, else [−0.5, 0.5] m;
    free flyer position uniform in [−1, 1]³ m, orientation uniform on SO(3): a unit quaternion from four
              independent standard normals, normalised (uniform on the sphere S³);
    ball      orientation uniform on SO(3), as the free flyer's;
    planar    position uniform in [−1, 1]² m, angle uniform in [−π, π];
    helical   as a revolute joint.
    rng: a numpy Generator, an int seed, or None (fresh entropy). Pinocchio's randomConfiguration also
    samples within the limits; its free-flyer position needs finite limits, hence the fixed cube here.
    """
    check_model(model)
    if not (rng is None or isinstance(rng, (np.random.Generator, int, np.integer))) or isinstance(rng, bool):
        raise InputError(f"rng must be a numpy Generator, an int seed or None, not {type(rng).__name__} {rng!r}")
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(None if rng is None else check_scalar("rng", rng, nonnegative=True,
                                                                           integer=True))
    N = 1 if n is None else check_scalar("n", n, nonnegative=True, integer=True)
    Q = np.empty((N, model.nq))
    for i in range(model.njoints):
        k = int(model.idx_q[i])
        if model.kind[i] == PLANAR:
            Q[:, k:k + 2] = rng.uniform(-FREE_RANGE, FREE_RANGE, (N, 2))
            th = rng.uniform(-np.pi, np.pi, N)
            Q[:, k + 2], Q[:, k + 3] = np.cos(th), np.sin(th)
            continue
        if model.kind[i] in (FREEFLYER, BALL):
            if model.kind[i] == FREEFLYER:
                Q[:, k:k + 3] = rng.uniform(-FREE_RANGE, FREE_RANGE, (N, 3))
                k += 3
            u = rng.normal(size=(N, 4))
            Q[:, k:k + 4] = u / np.linalg.norm(u, axis=1, keepdims=True)
            continue
        if model.kind[i] not in (REVOLUTE, PRISMATIC, HELICAL):      # every kind has its branch
            raise ValueError(f"random_configuration: joint kind {int(model.kind[i])} has no branch (manipdyn.joints)")
        lo, hi = float(model.lower[i]), float(model.upper[i])
        if not (np.isfinite(lo) and np.isfinite(hi)):
            r = PRISMATIC_RANGE if model.kind[i] == PRISMATIC else REVOLUTE_RANGE
            lo, hi = -r, r
        Q[:, k] = rng.uniform(lo, hi, N)
    return Q[0] if n is None else Q


def normalize(model, q) -> np.ndarray:
    """q (nq,) or (N, nq) with every quaternion (free flyer, ball joint) and every planar joint's (cos θ, sin θ) divided
    by its norm (the rest unchanged).

    InputError for a block of norm 0 (it names no rotation)."""
    if type(model) is Model and type(q) is _ND and q.dtype is _F64 and q.ndim == 1:
        k = model.kernel
        out = np.empty(k.q_shape)
        if NORMALIZE_ONE.call(k.config_one, q, out) < 0:
            return out
    (Q,), single = as_batch(model, q=q)
    if type(model) is Model:
        out = np.empty(Q.shape)
        if NORMALIZE.call(model.kernel.config_one, Q, out) < 0:
            return unbatch(out, single)
    Q = Q.copy()
    for k, m in model.unit_q:                   # (a MimicModel, or a row the kernel refused: the named error)
        n = np.linalg.norm(Q[:, k:k + m], axis=1, keepdims=True)
        if np.any(n == 0.0):
            r = int(np.flatnonzero(n[:, 0] == 0.0)[0])
            raise InputError(f"q{f'[{r}]' if Q.shape[0] > 1 else ''}: the {_unit_name(model, k, m)} is zero: it names "
                             f"no rotation")
        Q[:, k:k + m] /= n
    return unbatch(Q, single)
