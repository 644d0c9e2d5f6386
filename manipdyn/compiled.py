"""The dynamics from inside your own ``numba.njit`` code: a simulation loop, a sampling-MPC rollout, an estimator
run at kernel speed with no Python between the steps.

    import numba, numpy as np, manipdyn as md
    from manipdyn import compiled

    model = md.load_urdf("urdf/aau_arm.urdf")
    I, F = compiled.arrays(model)                     # the model as the kernels read it

    @numba.njit
    def rollout(I, F, q, v, tau, dt, steps, Q):       # semi-implicit Euler, Q (steps, nq) the trajectory
        qdd, dq, nxt = np.empty(v.shape[0]), np.empty(v.shape[0]), np.empty(q.shape[0])
        for k in range(steps):
            status = compiled.aba(I, F, q, v, tau, qdd)
            if status != compiled.OK:
                return k, status                      # the step that failed, and why (``check``)
            for i in range(v.shape[0]):
                v[i] += dt * qdd[i]
                dq[i] = dt * v[i]
            compiled.integrate(I, q, dq, nxt)         # q ⊕ dt v (quaternions of free and ball joints stay unit)
            q[:] = nxt
            Q[k] = q
        return steps, compiled.OK

Each function takes the arrays of ``arrays(model)`` and one state, writes its result into the array given last,
and returns a status: ``OK`` when the result is computed, anything else when an input is not finite, a joint
moves no mass or the result overflowed (dynamics/status.py). These are the kernels of the public calls (a Python
call of ``manipdyn.aba`` runs the same machine code), so the numbers are the public calls' to the last bit.
``check(model, name, status, *state)`` turns a status into the typed error the public call raises on that state.

    rnea(I, F, q, v, a, tau)               τ = M q̈ + C q̇ + g                       (``manipdyn.rnea``)
    nonlinear_effects(I, F, q, v, h)       h = C q̇ + g                              (``manipdyn.nonlinear_effects``)
    gravity_torques(I, F, q, g)            g(q)                                     (``manipdyn.gravity_torques``)
    mass_matrix(I, F, q, M)                M(q), (nv, nv), by the CRBA              (``manipdyn.mass_matrix``)
    aba(I, F, q, v, tau, qdd)              q̈ by the articulated-body algorithm      (``manipdyn.aba``)
    integrate(I, q, v, out)                q ⊕ v (unit time; OK or WRONG_SIZES)     (``manipdyn.integrate``)
    rnea_fext(I, F, q, v, a, f, n, W, tau) τ with one wrench (f, n) at W's frame     (``manipdyn.rnea``, ``f_ext``)
    aba_fext(I, F, q, v, tau, f, n, W, qdd) q̈ with one wrench                        (``manipdyn.aba``, ``f_ext``)
    frame_placement(I, F, q, X, R, p)      the pose of X's frame: R (3, 3), p (3,)  (``manipdyn.frame_placement``)
    frame_jacobian(I, F, q, X, J)          its Jacobian J (6, nv)                   (``manipdyn.frame_jacobian``)
    kinetic_energy(I, F, q, v)             T (a float; NaN: not finite)            (``manipdyn.kinetic_energy``)
    potential_energy(I, F, q)              V                                        (``manipdyn.potential_energy``)
    rnea_derivatives(I, F, q, v, a, dq, dv, da)   ∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈ (nv, nv)     (``manipdyn.rnea_derivatives``)
    aba_derivatives(I, F, q, v, tau, qdd, dq, dv, Minv)  q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹  (``manipdyn.aba_derivatives``)

W = ``wrench_row(model, frame, f_ext_frame)`` (14,) and X = ``frame_row(model, frame, reference)`` (5, 3) name a frame
for compiled code, in the arrays' frames (made once, in Python). The wrench calls take one wrench [force f; moment n]
(3,) each, applied by the environment on the frame's body about the frame's origin, in the frame's axes ("local") or
the world's ("world") — the public calls' ``f_ext={frame: (f, n)}``, to the last bit. The frame calls, the
energies and the derivatives give the public calls' numbers to rounding (they run in the z-aligned body frames of
``arrays``); the derivatives' matrices are C-ordered (nv, nv) arrays (another layout compiles the kernel anew).

q is (nq,) in Pinocchio's order, v, a, τ (nv,); arrays of any strides. Every call checks the sizes of its arrays
against the model's before it reads one, and returns ``WRONG_SIZES`` (NaN for an energy) for another size (numba
checks the dtypes and dimensions when your function compiles; ``check_shapes`` names a wrong array, in Python). Models with mimic
joints (``MimicModel``) are refused by ``arrays``; a closed chain's arrays give its spanning tree's dynamics
(its closures are ``manipdyn.constrained_forward_dynamics``').

Compiling: the kernels come from manipdyn's disk cache (``manipdyn warmup``); your function compiles once with
them inlined or linked. numba caches a function (``cache=True``) by its own source file only: after upgrading
manipdyn, clear your functions' caches (their ``__pycache__/*.nbi``, ``*.nbc``) so that they link the new kernels.
"""
from __future__ import annotations

import numpy as np

from ._jit import njit
from .dynamics.aba import aba_fext_one, aba_one
from .dynamics.arguments import frame_of
from .dynamics.crba import crba_one
from .dynamics.derivatives import aba_derivatives_one, rnea_derivatives_one
from .dynamics.energy import energy_one
from .dynamics.kinematics import REFERENCES, jacobian_one, placement_one
from .dynamics.rnea import bias_one, gravity_one, rnea_fext_one, rnea_one
from .dynamics.kernel_inputs import model_sizes, q_sized, sized
from .dynamics.status import OK, WRONG_SIZES
from .errors import InputError, NumericalError
from .joints import integrate_kernel
from .model import MimicModel, Model

__all__ = ["OK", "WRONG_SIZES", "arrays", "check", "check_shapes", "rnea", "nonlinear_effects", "gravity_torques",
           "mass_matrix", "aba", "integrate", "rnea_fext", "aba_fext", "frame_placement", "frame_jacobian", "kinetic_energy",
           "potential_energy", "rnea_derivatives", "aba_derivatives", "wrench_row", "frame_row"]

# Each function hands the kernel full slices of its arrays (x[::1], M[:, :]): a view of layout "any strides",
# the type the kernels are compiled and cached for (_jit's A1, A2), so that a caller's C-ordered arrays reach the
# cached machine code instead of compiling the kernels again for another layout.


@njit(inline="always")
def square(I, M):
    """True for an (nv, nv) matrix of the model of I."""
    nv = model_sizes(I)[1]
    return M.shape[0] == nv and M.shape[1] == nv


@njit(inline="always")
def frame_fits(I, X):
    """True for a frame row X (5, 3) of ``frame_row`` on a body of the model of I (or its base, −1)."""
    return X.shape[0] == 5 and X.shape[1] == 3 and -1 <= X[4, 0] < I.shape[1]


@njit(inline="always")
def row_fits(I, W, n, at):
    """True for a row W (n,) of ``wrench_row`` whose body (W[at]) is one of the model of I (or its base, −1)."""
    return W.shape[0] == n and -1 <= W[at] < I.shape[1]


@njit(inline="always")
def rnea(I, F, q, v, a, tau):
    """τ (nv,) into tau for one state (the public ``rnea``'s kernel); its status."""
    return rnea_one(I, F, q[::1], v[::1], a[::1], tau[::1])


@njit(inline="always")
def nonlinear_effects(I, F, q, v, h):
    """h = C q̇ + g (nv,) into h; its status."""
    return bias_one(I, F, q[::1], v[::1], h[::1])


@njit(inline="always")
def gravity_torques(I, F, q, g):
    """g(q) (nv,) into g; its status."""
    return gravity_one(I, F, q[::1], g[::1])


@njit(inline="always")
def mass_matrix(I, F, q, M):
    """M(q) (nv, nv) into M, both triangles; its status."""
    return crba_one(I, F, q[::1], M[:, :])


@njit(inline="always")
def aba(I, F, q, v, tau, qdd):
    """q̈ (nv,) into qdd by the articulated-body algorithm; its status."""
    return aba_one(I, F, q[::1], v[::1], tau[::1], qdd[::1])


@njit(inline="always")
def integrate(I, q, v, out):
    """out (nq,) = q ⊕ v (Pinocchio's integrate, unit time: pass dt · v for a step); OK (WRONG_SIZES)."""
    if not (sized(I, q, (v,)) and out.shape[0] == q.shape[0]):
        return WRONG_SIZES
    integrate_kernel(I[1], I[2], I[3], q[np.newaxis, :], v[np.newaxis, :], out[np.newaxis, :])
    return OK


@njit(inline="always")
def rnea_fext(I, F, q, v, a, f, n, W, tau):
    """τ (nv,) into tau with one external wrench [f; n] at the frame of W (``wrench_row``); its status."""
    if not row_fits(I, W, 14, 12):
        return WRONG_SIZES
    return rnea_fext_one(I, F, q[::1], v[::1], a[::1], f[::1], n[::1], W[:13], W[13] > 0.0, tau[::1])


@njit(inline="always")
def aba_fext(I, F, q, v, tau, f, n, W, qdd):
    """q̈ (nv,) into qdd with one external wrench [f; n] at the frame of W (``wrench_row``); its status."""
    if not row_fits(I, W, 14, 12):
        return WRONG_SIZES
    return aba_fext_one(I, F, q[::1], v[::1], tau[::1], f[::1], n[::1], W[:13], W[13] > 0.0, qdd[::1])


@njit(inline="always")
def frame_placement(I, F, q, X, R, p):
    """The world pose of the frame of X (``frame_row``): R (3, 3), p (3,), x_world = R x + p; its status."""
    if not (frame_fits(I, X) and q_sized(I, q) and R.shape[0] == 3 and R.shape[1] == 3 and p.shape[0] == 3):
        return WRONG_SIZES
    return placement_one(I, F, q[::1], X[:, :], R[:, :], p[::1])


@njit(inline="always")
def frame_jacobian(I, F, q, X, J):
    """J (6, nv) into J: the frame of X's velocity [linear; angular] = J q̇ (``frame_row``'s reference); its status."""
    if not (frame_fits(I, X) and q_sized(I, q) and J.shape[0] == 6 and J.shape[1] == model_sizes(I)[1]):
        return WRONG_SIZES
    return jacobian_one(I, F, q[::1], X[:, :], J[:, :])


@njit(inline="always")
def rnea_derivatives(I, F, q, v, a, dq, dv, da):
    """∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈ = M (nv, nv, C-ordered) into dq, dv, da; its status."""
    if not (sized(I, q, (v, a)) and square(I, dq) and square(I, dv) and square(I, da)):
        return WRONG_SIZES
    return rnea_derivatives_one(I, F, q[::1], v[::1], a[::1], dq, dv, da)


@njit(inline="always")
def aba_derivatives(I, F, q, v, tau, qdd, dq, dv, Minv):
    """q̈ (nv,) into qdd, ∂q̈/∂q, ∂q̈/∂q̇ and M⁻¹ (nv, nv, C-ordered) into dq, dv, Minv; its status."""
    if not (sized(I, q, (v, tau, qdd)) and square(I, dq) and square(I, dv) and square(I, Minv)):
        return WRONG_SIZES
    return aba_derivatives_one(I, F, I, F, q[::1], v[::1], tau[::1], qdd[::1], dq, dv, Minv)


@njit(inline="always")
def kinetic_energy(I, F, q, v):
    """T of one state (a float; NaN or ±inf for a non-finite input, NaN for arrays of other sizes)."""
    if not sized(I, q, (v,)):
        return np.nan
    return energy_one(I, F, q[::1], v[::1])


@njit(inline="always")
def potential_energy(I, F, q):
    """V of one state (a float; NaN or ±inf for a non-finite input, NaN for a q of another size)."""
    if not q_sized(I, q):
        return np.nan
    return energy_one(I, F, q[::1], q[:0])


def arrays(model):
    """(I, F): the model's arrays as the compiled calls take them — an int64 (5, nb) and a float64 (·, 3, 3) array,
    C-ordered and writable (copies: the kernels never write them), laid out as ``dynamics/model_arrays.py``
    describes, in the z-aligned body frames of the lane steps. A new model (``with_joint_dynamics``, another
    file) has arrays of its own: take them again."""
    if isinstance(model, MimicModel):
        raise InputError("compiled.arrays: a model with mimic joints has no compiled form of its own; use its "
                         "public calls (or manipdyn.reduce's model without the mimic joints)")
    if not isinstance(model, Model):
        raise InputError(f"compiled.arrays: expected a manipdyn Model, got {type(model).__name__}")
    I, F = model.kernel.lane_arrays
    return np.array(I, np.int64, order="C"), np.array(F, np.float64, order="C")


def wrench_row(model, frame, f_ext_frame="local"):
    """W (14,): where ``rnea_fext`` and ``aba_fext`` apply a wrench — the link or frame ``frame``, the wrench given in
    its axes ("local") or the world's ("world") — for the arrays of ``arrays(model)``."""
    if f_ext_frame not in ("local", "world"):
        raise InputError(f"compiled.wrench_row: f_ext_frame must be 'local' or 'world', not {f_ext_frame!r}")
    P = model.kernel.wrench_rows[frame_of(model, frame).name, f_ext_frame]
    return np.append(P, 1.0 if f_ext_frame == "world" else 0.0)


def frame_row(model, frame, reference="local_world_aligned"):
    """X (5, 3): the link or frame ``frame`` for ``frame_placement`` and ``frame_jacobian`` (``reference``: the
    Jacobian's axes, "local_world_aligned" or "local", as the public calls'), for the arrays of ``arrays(model)``."""
    if reference not in REFERENCES:
        raise InputError(f"compiled.frame_row: reference must be one of {', '.join(REFERENCES)}, not {reference!r}")
    b, X = model.kernel.lane_frame_rows[frame_of(model, frame).name]
    return np.vstack([X, [float(b), 0.0, float(reference == "local")]])


_SHAPES = {"rnea": ("q", "v", "a", "tau"), "nonlinear_effects": ("q", "v", "h"), "gravity_torques": ("q", "g"),
           "mass_matrix": ("q", "M"), "aba": ("q", "v", "tau", "qdd"), "integrate": ("q", "v", "out"),
           "rnea_fext": ("q", "v", "a", "f", "n", "tau"), "aba_fext": ("q", "v", "tau", "f", "n", "qdd"),
           "frame_placement": ("q", "R", "p"), "frame_jacobian": ("q", "J"), "kinetic_energy": ("q", "v"),
           "potential_energy": ("q",), "rnea_derivatives": ("q", "v", "a", "dq", "dv", "da"),
           "aba_derivatives": ("q", "v", "tau", "qdd", "dq", "dv", "Minv")}
_SIZES = {**{m: ("nv", "nv") for m in ("M", "dq", "dv", "da", "Minv")}, "J": (6, "nv"), "R": (3, 3), "p": (3,),
          "f": (3,), "n": (3,), "q": ("nq",), "out": ("nq",)}     # every other array: (nv,)


def check_shapes(model, name, *state):
    """InputError unless the arrays of a compiled call ``name`` (in its order, the result last) have the model's
    shapes and dtype float64 — the check the compiled code does not make. Returns None."""
    if name not in _SHAPES:
        raise InputError(f"compiled.check_shapes: no compiled call {name!r} (one of {', '.join(_SHAPES)})")
    names = _SHAPES[name]
    if len(state) != len(names):
        raise InputError(f"compiled.{name} takes {', '.join(names)}: {len(names)} arrays, not {len(state)}")
    for label, x in zip(names, state):
        want = tuple(getattr(model, d) if isinstance(d, str) else d for d in _SIZES.get(label, ("nv",)))
        if not isinstance(x, np.ndarray) or x.dtype != np.float64 or x.shape != want:
            got = f"{x.dtype} {x.shape}" if isinstance(x, np.ndarray) else type(x).__name__
            raise InputError(f"compiled.{name}: {label} must be a float64 array of shape {want}, not {got}")


def check(model, name, status, *state, frame=None, f_ext_frame="local", reference="local_world_aligned"):
    """Nothing if ``status`` is ``OK``; else the typed error that the public call ``name`` raises on the same state
    (the inputs, without the result array; for ``rnea_fext`` and ``aba_fext`` q, v, a or τ, f, n): it is made again,
    in Python, and names the array, entry, joint or result at fault. ``frame`` (and ``f_ext_frame``, ``reference``):
    the frame of a wrench or frame call, as given to ``wrench_row`` or ``frame_row``."""
    if int(status) == OK:
        return
    import manipdyn as md
    if name not in _SHAPES or name in ("kinetic_energy", "potential_energy") or \
            (name == "integrate" and int(status) != WRONG_SIZES):
        raise InputError(f"compiled.check: no compiled call {name!r} that returns a failing status (the energies "
                         f"return their value: NaN or ±inf for a non-finite input)")
    if name in ("rnea_fext", "aba_fext", "frame_placement", "frame_jacobian") and frame is None:
        raise InputError(f"compiled.check: {name} needs frame=, the frame given to "
                         f"{'wrench_row' if name.endswith('fext') else 'frame_row'}")
    if int(status) == WRONG_SIZES:
        _public(md, name, model, state, frame, f_ext_frame, reference)       # names a state array of another size
        raise InputError(f"compiled.{name}: an array is not of the model's sizes (the result, or the frame's or "
                         f"wrench's row); compiled.check_shapes names it")
    _public(md, name, model, state, frame, f_ext_frame, reference)
    raise NumericalError(f"compiled.{name} returned status {int(status)} where manipdyn.{name.removesuffix('_fext')} "
                         f"computes the state")


def _public(md, name, model, state, frame, f_ext_frame, reference):
    """The public call of compiled call ``name`` on a state (check's)."""
    if name.endswith("_fext"):
        q, v, x, f, n = state
        getattr(md, name[:-5])(model, q, v, x, f_ext={frame: (f, n)}, f_ext_frame=f_ext_frame)
    elif name == "frame_placement":
        md.frame_placement(model, *state, frame)
    elif name == "frame_jacobian":
        md.frame_jacobian(model, *state, frame, reference)
    else:
        getattr(md, name)(model, *state)
