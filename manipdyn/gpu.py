"""Batched dynamics on an NVIDIA GPU, in float64: the lane kernels' per-lane steps compiled for CUDA by numba-cuda
(the ``[gpu]`` extra), one thread per state.

    import manipdyn.gpu as gpu
    tau = gpu.rnea(model, q, v, a)     # q (N, nq), v, a (N, nv); f_ext= {frame: (force, moment)} as on the CPU
    h = gpu.nonlinear_effects(model, q, v);  g = gpu.gravity_torques(model, q)
    M = gpu.mass_matrix(model, q);  qdd = gpu.aba(model, q, v, tau)
    R, p = gpu.frame_placement(model, q, "tool0");  J = gpu.frame_jacobian(model, q, "tool0")

The states are device arrays — anything with ``__cuda_array_interface__`` (CuPy, PyTorch, numba; JAX's GPU arrays),
read where they lie, or with ``__dlpack__`` (through CuPy) — or numpy arrays, copied to the device. The result is
a numba device array (N, nv): ``cupy.asarray(tau)`` or ``torch.as_tensor(tau, device="cuda")`` take it without a
copy, ``tau.copy_to_host()`` brings it back.

The same source as the CPU (docs/design.md §4c): a lane kernel's step for one state — ``lanes.placement_lane``,
``rnea.motion_lane``, ``rnea.inertial_lane``, ``rnea.inward_lane``, with a record's rows L numbers long — is the
innermost loop's body on the CPU (L = LANES, a block) and one thread's work here (L = N, the whole batch), so that
a warp's 32 threads read and write 32 consecutive numbers (coalesced). What differs is only the driver below: which
thread runs which state, and scratch in device memory (kept between calls of the same size).

Checks as on the CPU, on the device: a non-finite input or result, or a revolute or helical angle beyond
``spatial.SINCOS_MAX`` (where the GPU, unlike the CPU, has no one-state fallback: reduce the angle modulo 2π),
raises the typed error naming the first such row. Every call takes every joint of the registry: revolute,
prismatic, helical, planar, free and ball joints.
Tested on numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, tests/gpu/), compiled to PTX where NVVM is installed,
and timed by ``scripts/gpu_bench.py`` on a GPU.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .dynamics.aba import (_A, _V, ARTICULATED, MULTI, acceleration_lane, acceleration_multi, articulated_lane,
                           articulated_model, articulated_multi, bias_lane, bias_up_lane, handed_lane, handed_multi,
                           inertia_up_lane, rigid_model, singular_threshold, velocity_lane, velocity_multi_lane)
from .dynamics.lanes import (body_placement_lane, external_lane, gather_lane, get3, get_rotation, inertial_model,
                             motion_model, multi_model, on_lanes, scatter_lane, selected)
from .dynamics.model_arrays import unpack
from .dynamics.crba import (COMPOSITE, block_lane, column_lane, column_model, column_up_lane, column_up_multi_lane,
                            merge_lane, merge_weights, own_inertia_lane, own_inertia_model)
from .dynamics.kinematics import (WORLD, _check_reference, frame_point_lane, frame_row, jacobian_lane, jacobian_model,
                                  local_lane, world_lane)
from .dynamics.rnea import (_F, _W, RECORD, inertial_lane, inward_lane, motion_lane, motion_lane_multi,
                            torque_multi_lane, wrench_up_lane)
from .dynamics.arguments import as_real, check_finite, frame_of
from .errors import InputError, ManipdynError, NumericalError
from .extras import missing, require
from .joints import BALL, FREEFLYER, HELICAL, PLANAR, PRISMATIC, REVOLUTE, TYPE_NAMES
from .kernel_form import wrench_axes
from .model import Model
from .spatial import SINCOS_MAX, mul3t

try:                          # numba-cuda (the [gpu] extra); a kernel's ``cuda`` must be this module's global (the
    from numba import cuda    # simulator swaps it for its own while a kernel runs)
except ImportError:           # pragma: no cover - without the extra: _cuda() names it
    cuda = None

THREADS = 128                 # threads per block
_BIG = 2 ** 62                # "no row": the flags' start value
_KERNELS, _SCRATCH = {}, {}


def _cuda():
    """numba.cuda, or MissingExtraError naming the [gpu] extra."""
    if cuda is None:
        raise missing("numba_cuda", "gpu", "manipdyn.gpu")
    return cuda


# -- the drivers: one thread per state ----------------------------------------------------------------------------
# Each thread s gathers its state into Z (index last), checks it (flags[0] ← the first bad row: a non-finite input or
# an angle beyond SINCOS_MAX, left uncomputed), runs the lane steps with L = N, writes its result and flags a
# non-finite one (flags[1]) or, in the ABA, a singular articulated inertia (flags[2]).

def _rnea_threads(I, F, Q, V, A, X, xb, xp, paths, poff, world, rec, base, spare, Z, TB, tau, angle, flags, with_v,
                  with_a):
    """Thread s: state s's τ by the Newton–Euler recursion (``rnea.rnea_lanes``' steps); without v (a), q̇ (q̈) = 0.
    External wrenches (``_wrenches``): wrench k, rows 6k … 6k + 5 of X (rows N long), on body xb[k] about xp[k]; in
    world axes (world) it is turned into the body by the placements of the bodies paths[poff[k]:poff[k + 1]], from
    the base out (as ``lanes.external_lanes``)."""
    s = cuda.grid(1)
    N, nb, nq, nv = tau.shape[0], I.shape[1], Q.shape[1], tau.shape[1]
    if s >= N:
        return
    mdl = unpack(I, F)
    bad = gather_lane(Q, Z, s, N, 0, angle, True)
    if with_v:
        bad += gather_lane(V, Z, s, N, nq, angle, False)
    if with_a:
        bad += gather_lane(A, Z, s, N, nq + nv, angle, False)
    for k in range(nv):
        if not with_v:
            Z[(nq + k) * N + s] = 0.0
        if not with_a:
            Z[(nq + nv + k) * N + s] = 0.0
    if not bad == 0.0:
        cuda.atomic.min(flags, 0, s)
        return
    for k in range(3):                                    # the base as a parent: ω' = ω̇' = 0, v̇' = −g
        base[k * N + s], base[(3 + k) * N + s], base[(6 + k) * N + s] = 0.0, 0.0, mdl.mg[k]
    for k in range(6):
        spare[k * N + s] = 0.0
    for i in range(nb):                                   # outward, Eqs. 3–14
        j = mdl.parent[i]
        B = rec[i * RECORD * N:(i + 1) * RECORD * N]
        par = base if j < 0 else rec[(j * RECORD + _W) * N:(j * RECORD + _W + 9) * N]
        body_placement_lane(i, mdl, B, Z, s, N)
        if mdl.nvj[i] > 1:                                # a free flyer or a ball joint
            motion_lane_multi(multi_model(i, mdl, nq), B, par, Z, s, N)
        else:
            motion_lane(motion_model(i, mdl, nq), B, par, Z, s, N)
        inertial_lane(inertial_model(i, mdl), B, s, N)
    for k in range(xb.shape[0]):                          # external wrenches
        fe, ne = get3(X, 6 * k, s, N), get3(X, 6 * k + 3, s, N)
        if world:
            for t in range(poff[k], poff[k + 1]):         # x ← R_jᵀ x, from the base out
                R = get_rotation(rec[paths[t] * RECORD * N:(paths[t] + 1) * RECORD * N], s, N)
                fe, ne = mul3t(R, fe), mul3t(R, ne)
        b = xb[k]
        external_lane(rec[b * RECORD * N:(b + 1) * RECORD * N], _F, fe, ne, (xp[k, 0], xp[k, 1], xp[k, 2]), s, N)
    for i in range(nb - 1, -1, -1):                       # inward, Eqs. 15–18
        j = mdl.parent[i]
        B = rec[i * RECORD * N:(i + 1) * RECORD * N]
        to = spare if j < 0 else rec[(j * RECORD + _F) * N:(j * RECORD + _F + 6) * N]
        if mdl.nvj[i] > 1:
            mm = multi_model(i, mdl, nq)
            for k in range(mdl.nvj[i]):
                src = _F + selected(mm[5], mdl.kind[i] == PLANAR, k)
                torque_multi_lane(mm, k, src, mdl.armature[mdl.iv[i] + k], B, TB, Z, s, N)
            if j >= 0:
                wrench_up_lane(B, to, s, N)
        else:
            inward_lane(motion_model(i, mdl, nq), mdl.armature[mdl.iv[i]], B, to, TB, Z, s, N)
    if not scatter_lane(TB, tau, s, N) == 0.0:
        cuda.atomic.min(flags, 1, s)


def _crba_threads(I, F, Q, W, mC, rec, Z, Fw, Mb, M, angle, flags):
    """Thread s: state s's M by the composite-rigid-body algorithm (``crba.crba_lanes``' steps)."""
    s = cuda.grid(1)
    N, nb, nv = M.shape[0], I.shape[1], M.shape[1]
    if s >= N:
        return
    mdl = unpack(I, F)
    if not gather_lane(Q, Z, s, N, 0, angle, True) == 0.0:
        cuda.atomic.min(flags, 0, s)
        return
    for i in range(nb):                                   # pass 1: placements, own inertias
        B = rec[i * COMPOSITE * N:(i + 1) * COMPOSITE * N]
        body_placement_lane(i, mdl, B, Z, s, N)
        own_inertia_lane(own_inertia_model(i, mdl), B, s, N)
    for i in range(nb - 1, -1, -1):                       # leaves → root: C_λ(i) ← C_λ(i) ∪ C_i
        j = mdl.parent[i]
        if j >= 0:
            merge_lane((W[i, 0], W[i, 1], W[i, 2]), rec[i * COMPOSITE * N:(i + 1) * COMPOSITE * N],
                       rec[j * COMPOSITE * N:(j + 1) * COMPOSITE * N], s, N)
    for k in range(nv * nv):                              # bodies on different branches do not couple
        Mb[k * N + s] = 0.0
    for i in range(nb):                                   # pass 2: columns iv_i + r of M (crba.column_lanes)
        for r in range(mdl.nvj[i]):
            column_lane(column_model(i, r, i, r, mdl), mC[i], rec[i * COMPOSITE * N:(i + 1) * COMPOSITE * N], Fw, Mb,
                        s, N)
            for c in range(r):
                block_lane(column_model(i, r, i, c, mdl), Fw, Mb, s, N)
            k = i
            while mdl.parent[k] >= 0:
                j, Bk = mdl.parent[k], rec[k * COMPOSITE * N:(k + 1) * COMPOSITE * N]
                if mdl.nvj[j] == 1 or mdl.kind[j] == PLANAR:   # (crba.column_multi_lanes)
                    column_up_lane(column_model(i, r, j, 0, mdl), Bk, Fw, Mb, s, N)
                    for c in range(1, mdl.nvj[j]):
                        block_lane(column_model(i, r, j, c, mdl), Fw, Mb, s, N)
                else:                                     # a free flyer or ball ancestor
                    column_up_multi_lane((mdl.iv[i] + r) * nv + mdl.iv[j], mdl.nvj[j], Bk, Fw, Mb, s, N)
                k = j
    bad = 0.0
    for a in range(nv):
        for b in range(a + 1):
            y = Mb[(a * nv + b) * N + s]
            M[s, a, b] = y
            M[s, b, a] = y
            bad += y - y
    if not bad == 0.0:
        cuda.atomic.min(flags, 1, s)


def _aba_threads(I, F, Q, V, T, dmin, rec, base, Z, QDD, G, slot, out, angle, flags):
    """Thread s: state s's q̈ by the articulated-body algorithm (``aba.aba_lanes``' steps); G: the multi-dof joints'
    records (aba.MULTI rows each; slot[i]: body i's)."""
    s = cuda.grid(1)
    N, nb, nq, nv = out.shape[0], I.shape[1], Q.shape[1], out.shape[1]
    if s >= N:
        return
    mdl = unpack(I, F)
    bad = gather_lane(Q, Z, s, N, 0, angle, True) + gather_lane(V, Z, s, N, nq, angle, False) + \
        gather_lane(T, Z, s, N, nq + nv, angle, False)
    if not bad == 0.0:
        cuda.atomic.min(flags, 0, s)
        return
    for k in range(3):                                    # the base: v_0 = 0, a_0 = [−g; 0]
        base[k * N + s], base[(3 + k) * N + s], base[(6 + k) * N + s], base[(9 + k) * N + s] = 0.0, 0.0, mdl.mg[k], 0.0
    for i in range(nb):                                   # pass 1 (outward)
        j = mdl.parent[i]
        B = rec[i * ARTICULATED * N:(i + 1) * ARTICULATED * N]
        par = base[:6 * N] if j < 0 else rec[(j * ARTICULATED + _V) * N:(j * ARTICULATED + _V + 6) * N]
        body_placement_lane(i, mdl, B, Z, s, N)
        if mdl.nvj[i] > 1:
            velocity_multi_lane(multi_model(i, mdl, nq), B, par, Z, s, N)
        else:
            velocity_lane(motion_model(i, mdl, nq), B, par, Z, s, N)
        bias_lane(rigid_model(i, mdl), inertial_model(i, mdl), B, s, N)
    singular = 0
    for i in range(nb - 1, -1, -1):                       # pass 2 (inward)
        j = mdl.parent[i]
        B = rec[i * ARTICULATED * N:(i + 1) * ARTICULATED * N]
        n, r = mdl.nvj[i], mdl.iv[i]
        Gi = G[slot[i] * MULTI * N:(slot[i] + 1) * MULTI * N]
        if n > 1:
            singular += articulated_multi(n, mdl.armature[r:r + n], nq + nv + r, dmin, B, Gi, Z, s, s + 1, N,
                                          mdl.kind[i] == PLANAR)
        else:
            singular += articulated_lane(articulated_model(i, mdl, nq), dmin, B, Z, s, N)
        if j >= 0:
            P = rec[j * ARTICULATED * N:(j + 1) * ARTICULATED * N]
            if n > 1:
                handed_multi(n, B, Gi, s, s + 1, N)
            else:
                handed_lane(B, s, N)
            inertia_up_lane(B, P, s, N)
            bias_up_lane(B, P, s, N)
    if singular > 0:
        cuda.atomic.min(flags, 2, s)
        return
    for i in range(nb):                                   # pass 3 (outward)
        j = mdl.parent[i]
        par = base[6 * N:] if j < 0 else rec[(j * ARTICULATED + _A) * N:(j * ARTICULATED + _A + 6) * N]
        B = rec[i * ARTICULATED * N:(i + 1) * ARTICULATED * N]
        if mdl.nvj[i] > 1:
            acceleration_multi(mdl.nvj[i], mdl.iv[i], B, G[slot[i] * MULTI * N:(slot[i] + 1) * MULTI * N], par,
                               QDD, s, s + 1, N, mdl.kind[i] == PLANAR)
        else:
            acceleration_lane(articulated_model(i, mdl, nq), B, par, QDD, s, N)
    if not scatter_lane(QDD, out, s, N) == 0.0:
        cuda.atomic.min(flags, 1, s)


def _frame_threads(I, F, Q, b, path, n, Rl, pl, rec, base, Z, Fb, Jb, Rf, pf, J, jac, local, angle, flags):
    """Thread s: the world placement of the frame (Rl, pl) on body b and, with ``jac``, its Jacobian (in the frame's
    axes with ``local``) (``kinematics.frame_lanes``' steps); path[:n]: b, its parent, …, the root."""
    s = cuda.grid(1)
    N = Rf.shape[0]
    if s >= N:
        return
    mdl = unpack(I, F)
    if not gather_lane(Q, Z, s, N, 0, angle, True) == 0.0:
        cuda.atomic.min(flags, 0, s)
        return
    for a in range(3):                                    # the world as a parent: Rw = 1, pw = 0
        for c in range(3):
            base[(12 + 3 * a + c) * N + s] = 1.0 if a == c else 0.0
        base[(21 + a) * N + s] = 0.0
    for k in range(n - 1, -1, -1):                        # root → b: placements
        i, j = path[k], mdl.parent[path[k]]
        B = rec[i * WORLD * N:(i + 1) * WORLD * N]
        body_placement_lane(i, mdl, B, Z, s, N)
        world_lane(B, base if j < 0 else rec[j * WORLD * N:(j + 1) * WORLD * N], s, N)
    X = ((Rl[0, 0], Rl[0, 1], Rl[0, 2]), (Rl[1, 0], Rl[1, 1], Rl[1, 2]), (Rl[2, 0], Rl[2, 1], Rl[2, 2])), \
        (pl[0], pl[1], pl[2])
    frame_point_lane(X, rec[b * WORLD * N:(b + 1) * WORLD * N], Fb, s, N)
    bad = 0.0
    for a in range(3):
        for c in range(3):
            x = Fb[(3 * a + c) * N + s]
            Rf[s, a, c] = x
            bad += x - x
        x = Fb[(9 + a) * N + s]
        pf[s, a] = x
        bad += x - x
    if jac:
        nv = J.shape[2]
        for k in range(6 * nv):                           # joints that do not move b
            Jb[k * N + s] = 0.0
        for k in range(n):
            i = path[k]
            for c in range(mdl.nvj[i]):
                jacobian_lane(jacobian_model(i, c, mdl), rec[i * WORLD * N:(i + 1) * WORLD * N], Fb, Jb, s, N)
        for r in range(nv):
            if local:
                local_lane(Fb, Jb, nv, r, s, N)
            for k in range(6):
                x = Jb[(k * nv + r) * N + s]
                J[s, k, r] = x
                bad += x - x
    if not bad == 0.0:
        cuda.atomic.min(flags, 1, s)


def _kernel(name, func):
    """func compiled by numba-cuda, once per process."""
    if name not in _KERNELS:
        _KERNELS[name] = _cuda().jit(func)
    return _KERNELS[name]


def _scratch(key, shape):
    """A device array of the shape, kept between calls (``key``: its use); calls from several threads at once
    would share it: one host thread at a time per process."""
    x = _SCRATCH.get(key)
    if x is None or x.shape != shape:
        x = _SCRATCH[key] = _cuda().device_array(shape)
    return x


# -- states in and out -------------------------------------------------------------------------------------------

def to_device(x, name, n, call):
    """A state array x (N, n) float64 on the device: a numba device array as it is, a ``__cuda_array_interface__``
    object viewed where it lies, a ``__dlpack__`` one through CuPy, a numpy array copied in. InputError names a
    wrong shape or dtype."""
    _cuda()
    if hasattr(x, "copy_to_host"):
        d = x
    elif hasattr(x, "__cuda_array_interface__"):
        d = cuda.as_cuda_array(x)
    elif hasattr(x, "__dlpack__") and not isinstance(x, np.ndarray):
        cp = require("cupy", "gpu", f"{call} on a DLPack array")
        d = cuda.as_cuda_array(cp.from_dlpack(x))
    else:
        try:
            h = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{call}: {name} must be an (N, {n}) array of numbers: {exc}") from None
        if h.ndim != 2 or h.shape[1] != n:
            raise InputError(f"{call}: {name} must be (N, {n}), it is {h.shape}")
        return cuda.to_device(np.ascontiguousarray(h))
    if len(d.shape) != 2 or d.shape[1] != n:
        raise InputError(f"{call}: {name} must be (N, {n}), it is {tuple(d.shape)}")
    if np.dtype(d.dtype) != np.float64:
        raise InputError(f"{call}: {name} must be float64 on the GPU (the CPU's precision), it is {d.dtype}")
    return d


def _model(model, call):
    """The lane steps' model (z-aligned frames, kernel_form.z_aligned) of a Model whose joints they take: every kind
    of the registry (``lanes.on_lanes`` with its planar joints; a kind outside it would be refused by name)."""
    if type(model) is not Model:
        raise InputError(f"{call}: the GPU kernels take a Model, not a {type(model).__name__}")
    I, F = model.kernel.lane_arrays
    if not on_lanes(unpack(I, F), model.nq, True):
        taken = (REVOLUTE, PRISMATIC, HELICAL, FREEFLYER, BALL, PLANAR)
        others = [f"{n} ({TYPE_NAMES[int(k)]})" for n, k in zip(model.joint_names, model.kind) if k not in taken]
        raise InputError(f"{call}: the GPU kernels do not take the joints {', '.join(others)} (they take revolute, "
                         f"prismatic, helical, planar, free and ball joints; use the CPU call)")
    return I, F


def _angles(model):
    """angle (nq,) int64 on the device: 1 where q's entry is an angle (``_angle_mask``: the sincos range check)."""
    return _cuda().to_device(_angle_mask(model).astype(np.int64))


def _angle_mask(model):
    """(nq,) bool: True where q's entry is a revolute or helical joint's angle, which the lane steps turn by
    ``spatial.sincos``."""
    a = np.zeros(model.nq, bool)
    a[model.idx_q[(model.kind == REVOLUTE) | (model.kind == HELICAL)]] = True
    return a


def _raise(model, call, flags, states, cpu):
    """The typed error of the first flagged row: an angle past the GPU's sincos range by name, else the error the
    CPU call gives on that row (``cpu``: the row's host states → the CPU call), prefixed with the row."""
    first = min(int(x) for x in flags.copy_to_host())
    rows = [d[first:first + 1].copy_to_host()[0] for _, d in states]
    q = rows[0]
    angle = _angle_mask(model)
    for k, x in enumerate(q):
        if np.isfinite(x) and angle[k] and abs(x) > SINCOS_MAX:
            raise InputError(f"{call}: q[{first}, {k}] (joint {model.q_names[k]!r}) is {x:.6g}, beyond "
                             f"{SINCOS_MAX:.0e} rad, the GPU's sin and cos range: reduce it modulo 2π (the CPU call takes it)")
    try:
        cpu(*rows)
    except ManipdynError as exc:
        raise type(exc)(f"{call} on the GPU, row {first}: {exc}") from None
    raise NumericalError(f"{call} on the GPU, row {first}: the result is not finite (an intermediate overflowed on "
                         f"the GPU, not on the CPU)")


def _launch(name, func, N, *args):
    if N:
        _kernel(name, func)[(N + THREADS - 1) // THREADS, THREADS](*args)


def _states(model, call, given):
    """[(name, device array)] of the given states (name → array or None), one number of rows."""
    out = []
    for name, x in given:
        if x is not None:
            out.append((name, to_device(x, name, model.nq if name == "q" else model.nv, call)))
    N = out[0][1].shape[0]
    for name, d in out[1:]:
        if d.shape[0] != N:
            raise InputError(f"{call}: {name} has {d.shape[0]} rows, q has {N}")
    return out, N


def _flags():
    return _cuda().to_device(np.full(3, _BIG, np.int64))


def _on_device(x):
    return hasattr(x, "copy_to_host") or hasattr(x, "__cuda_array_interface__") or \
        (hasattr(x, "__dlpack__") and not isinstance(x, np.ndarray))


def _put_wrench(X, k, f, m, R):
    """Thread s: rows 6k … 6k + 5 of X (rows N long) ← [R f_s; R m_s] (R, 9 numbers by rows: the frame's axes in
    the body's, or 1 for world axes)."""
    s = cuda.grid(1)
    N = f.shape[0]
    if s >= N:
        return
    for r in range(3):
        X[(6 * k + r) * N + s] = R[3 * r] * f[s, 0] + R[3 * r + 1] * f[s, 1] + R[3 * r + 2] * f[s, 2]
        X[(6 * k + 3 + r) * N + s] = R[3 * r] * m[s, 0] + R[3 * r + 1] * m[s, 1] + R[3 * r + 2] * m[s, 2]


def _wrenches(model, f_ext, f_ext_frame, N, call):
    """f_ext = {link or frame name: (force, moment)} (each (N, 3) on the device, or (3,) or (N, 3) on the host) laid
    out for ``_rnea_threads`` on the device: X (6K·N), bodies (K,), points (K, 3), the bodies' paths from the base
    (flat) and their offsets (K + 1,); and [(name, device array (N, 3))] of the forces and moments, for the CPU's
    error on a flagged row. Frames of the fixed base are dropped (they change no torque)."""
    if f_ext_frame not in ("local", "world"):
        raise InputError(f"{call}: f_ext_frame must be 'local' or 'world', not {f_ext_frame!r}")
    if f_ext is not None and not isinstance(f_ext, Mapping):
        raise InputError(f"{call}: f_ext must be None or a dict {{link or frame name: (force, moment)}}, "
                         f"not {type(f_ext).__name__}")
    c, rows = _cuda(), []
    for name, pair in (f_ext or {}).items():
        fr = frame_of(model, name)
        if isinstance(pair, (str, bytes, Mapping)) or not hasattr(pair, "__len__") or len(pair) != 2:
            raise InputError(f"{call}: f_ext[{name!r}] must be a pair (force, moment)")
        d = []
        for what, w in zip(("force", "moment"), pair):
            label = f"f_ext[{name!r}] {what}"
            if _on_device(w):
                w = to_device(w, label, 3, call)
                if w.shape[0] != N:
                    raise InputError(f"{call}: {label} has {w.shape[0]} rows, q has {N}")
            else:
                w = as_real(label, w)
                if w.shape not in ((3,), (N, 3)):
                    raise InputError(f"{call}: {label} has shape {w.shape}; expected (3,) or ({N}, 3)")
                check_finite(label, w)
                w = c.to_device(np.ascontiguousarray(np.broadcast_to(w, (N, 3))))
            d.append(w)
        if fr.body >= 0:
            rows.append((name, fr, d[0], d[1]))
    K, parent = len(rows), model.kernel.arrays[0][0]
    X = c.device_array((max(6 * K * N, 1),))
    paths, poff = [], [0]
    for k, (name, fr, f, m) in enumerate(rows):
        R = wrench_axes(model.kernel.lane_turns[fr.body], fr, f_ext_frame)[0]   # into the z-aligned axes
        _launch("put_wrench", _put_wrench, N, X, k, f, m, c.to_device(np.ascontiguousarray(R, float).ravel()))
        path, j = [], fr.body
        while j >= 0:
            path.append(j)
            j = int(parent[j])
        paths += path[::-1]
        poff.append(len(paths))
    xb = np.array([fr.body for _, fr, _, _ in rows], np.int64)
    xp = np.array([wrench_axes(model.kernel.lane_turns[fr.body], fr, f_ext_frame)[1] for _, fr, _, _ in rows],
                  float).reshape(K, 3)
    extra = [(f"f_ext[{name!r}] {what}", x) for name, _, f, m in rows for what, x in (("force", f), ("moment", m))]
    return (X, c.to_device(xb), c.to_device(xp), c.to_device(np.array(paths or [0], np.int64)),
            c.to_device(np.array(poff, np.int64)), f_ext_frame == "world"), extra, [name for name, *_ in rows]


def _run_rnea(model, call, q, v, a, f_ext=None, f_ext_frame="local"):
    import manipdyn as md
    I, F = _model(model, call)
    states, N = _states(model, call, (("q", q), ("v", v), ("a", a)))
    nb, nq, nv, Q = model.njoints, model.nq, model.nv, states[0][1]
    V, A = (dict(states).get(n, Q) for n in ("v", "a"))
    ext, extra, names = _wrenches(model, f_ext, f_ext_frame, N, call)
    tau, flags = _cuda().device_array((N, nv)), _flags()
    _launch("rnea", _rnea_threads, N, _cuda().to_device(I), _cuda().to_device(F), Q, V, A, *ext,
            _scratch("rec", (nb * RECORD * N,)), _scratch("base", (9 * N,)), _scratch("spare", (6 * N,)),
            _scratch("Z", ((nq + 2 * nv) * N,)), _scratch("T", (nv * N,)), tau, _angles(model), flags, v is not None,
            a is not None)
    if N and (flags.copy_to_host() < _BIG).any():
        n = len(states)

        def cpu(*x):       # the row's states, then its wrenches' forces and moments (``_wrenches``' extra)
            w = {name: (x[n + 2 * k], x[n + 2 * k + 1]) for k, name in enumerate(names)}
            return getattr(md, call)(model, *x[:n], **(dict(f_ext=w, f_ext_frame=f_ext_frame) if w else {}))
        _raise(model, call, flags, states + extra, cpu)
    return tau


def rnea(model, q, v, a, *, f_ext=None, f_ext_frame="local"):
    """τ (N, nv) on the GPU for device (or numpy) arrays q (N, nq), v, a (N, nv): ``manipdyn.rnea``'s numbers
    (tests/gpu/), a device array. f_ext = {link or frame name: (force, moment)}, as ``manipdyn.rnea`` takes it:
    each (N, 3) on the device, or (3,) or (N, 3) on the host; f_ext_frame "local" (the frame's axes) or "world"."""
    return _run_rnea(model, "rnea", q, v, a, f_ext, f_ext_frame)


def nonlinear_effects(model, q, v):
    """h = C q̇ + g (N, nv) on the GPU (``rnea`` with q̈ = 0)."""
    return _run_rnea(model, "nonlinear_effects", q, v, None)


def gravity_torques(model, q):
    """g(q) (N, nv) on the GPU (``rnea`` with q̇ = q̈ = 0)."""
    return _run_rnea(model, "gravity_torques", q, None, None)


def mass_matrix(model, q):
    """M(q) (N, nv, nv) on the GPU by the composite-rigid-body algorithm (``manipdyn.mass_matrix``'s numbers)."""
    import manipdyn as md
    I, F = _model(model, "mass_matrix")
    states, N = _states(model, "mass_matrix", (("q", q),))
    nb, nq, nv = model.njoints, model.nq, model.nv
    mdl = unpack(I, F)
    mC, W = np.empty(nb), np.zeros((nb, 3))
    merge_weights(mdl.parent, mdl.mass, mC, W)
    M, flags, cuda = _cuda().device_array((N, nv, nv)), _flags(), _cuda()
    _launch("crba", _crba_threads, N, cuda.to_device(I), cuda.to_device(F), states[0][1], cuda.to_device(W),
            cuda.to_device(mC), _scratch("rec", (nb * COMPOSITE * N,)), _scratch("Z", (nq * N,)),
            _scratch("F", (6 * N,)), _scratch("M", (nv * nv * N,)), M, _angles(model), flags)
    if N and (flags.copy_to_host() < _BIG).any():
        _raise(model, "mass_matrix", flags, states, lambda q: md.mass_matrix(model, q))
    return M


def aba(model, q, v, tau):
    """q̈ (N, nv) on the GPU by the articulated-body algorithm (``manipdyn.aba``'s numbers)."""
    import manipdyn as md
    I, F = _model(model, "aba")
    states, N = _states(model, "aba", (("q", q), ("v", v), ("tau", tau)))
    nb, nq, nv, cuda = model.njoints, model.nq, model.nv, _cuda()
    mdl = unpack(I, F)
    multi = np.asarray(model.nvs) > 1
    slot = np.cumsum(multi) - multi                       # body i's record among the multi-dof joints'
    out, flags = cuda.device_array((N, nv)), _flags()
    _launch("aba", _aba_threads, N, cuda.to_device(I), cuda.to_device(F), *(d for _, d in states),
            float(singular_threshold(mdl.inertia, mdl.mass)), _scratch("rec", (nb * ARTICULATED * N,)),
            _scratch("base", (12 * N,)), _scratch("Z", ((nq + 2 * nv) * N,)), _scratch("T", (nv * N,)),
            _scratch("G", (max(int(multi.sum()), 1) * MULTI * N,)), cuda.to_device(slot.astype(np.int64)), out,
            _angles(model), flags)
    if N and (flags.copy_to_host() < _BIG).any():
        _raise(model, "aba", flags, states, lambda q, v, t: md.aba(model, q, v, t))
    return out


def _run_frame(model, call, q, frame, jac, reference):
    import manipdyn as md
    I, F = _model(model, call)
    _check_reference(reference)
    b, X = frame_row(model, frame, lanes=True)
    states, N = _states(model, call, (("q", q),))
    nb, nv, c = model.njoints, model.nv, _cuda()
    if b < 0:                                             # a frame on the fixed base: constant, no joint moves it
        R, p = np.broadcast_to(X[:3], (N, 3, 3)), np.broadcast_to(X[3], (N, 3))
        return c.to_device(np.ascontiguousarray(R)), c.to_device(np.ascontiguousarray(p)), \
            c.to_device(np.zeros((N, 6, nv)))
    path, j = [], b
    while j >= 0:
        path.append(j)
        j = model.kernel.arrays[0][0][j]
    Rf, pf = c.device_array((N, 3, 3)), c.device_array((N, 3))
    J, flags = c.device_array((N, 6, nv) if jac else (N, 0, 0)), _flags()
    _launch("frame", _frame_threads, N, c.to_device(I), c.to_device(F), states[0][1], b,
            c.to_device(np.array(path, np.int64)), len(path), c.to_device(np.ascontiguousarray(X[:3])),
            c.to_device(np.ascontiguousarray(X[3])), _scratch("rec", (nb * WORLD * N,)), _scratch("base", (WORLD * N,)),
            _scratch("Z", (model.nq * N,)), _scratch("F", (12 * N,)), _scratch("J", (max(6 * nv * N, 1) if jac else 1,)),
            Rf, pf, J, jac, reference == "local", _angles(model), flags)
    if N and (flags.copy_to_host() < _BIG).any():
        cpu = (lambda x: md.frame_jacobian(model, x, frame, reference=reference)) if jac else \
            (lambda x: md.frame_placement(model, x, frame))
        _raise(model, call, flags, states, cpu)
    return Rf, pf, J


def frame_placement(model, q, frame):
    """The frame's pose in the world on the GPU: device arrays R (N, 3, 3), p (N, 3) (``manipdyn.frame_placement``'s
    numbers)."""
    return _run_frame(model, "frame_placement", q, frame, False, "local_world_aligned")[:2]


def frame_jacobian(model, q, frame, reference="local_world_aligned"):
    """J (N, 6, nv) on the GPU, rows [linear; angular], world-aligned at the frame's origin or in its axes
    (``reference="local"``) (``manipdyn.frame_jacobian``'s numbers)."""
    return _run_frame(model, "frame_jacobian", q, frame, True, reference)[2]


def ptx(name, cc=(9, 0)):
    """The PTX that numba-cuda makes of a driver ("rnea", "crba", "aba", "frame") for compute capability ``cc`` — without a GPU
    (it needs NVVM, ``pip install "cuda-toolkit[nvvm,nvrtc]"``): the check that the CPU kernels' lane steps compile for
    CUDA as they are, where the simulator would run them as Python."""
    from numba import types
    c = _cuda()
    i2, f3 = types.Array(types.int64, 2, "C"), types.Array(types.float64, 3, "C")
    a2, c1, c2 = types.Array(types.float64, 2, "A"), types.Array(types.float64, 1, "C"), \
        types.Array(types.float64, 2, "C")
    flags = types.Array(types.int64, 1, "C")
    i1, c3, a1 = types.Array(types.int64, 1, "C"), types.Array(types.float64, 3, "C"), types.Array(types.float64, 1, "A")
    sigs = {"frame": (_frame_threads, (i2, f3, a2, types.int64, i1, types.int64, c2, a1, c1, c1, c1, c1, c1, c3, c2,
                                       c3, types.boolean, types.boolean, i1, flags)),
            "rnea": (_rnea_threads, (i2, f3, a2, a2, a2, c1, i1, c2, i1, i1, types.boolean, c1, c1, c1, c1, c1, c2,
                                     i1, flags, types.boolean, types.boolean)),
            "crba": (_crba_threads, (i2, f3, a2, c2, c1, c1, c1, c1, c1, f3, i1, flags)),
            "aba": (_aba_threads, (i2, f3, a2, a2, a2, types.float64, c1, c1, c1, c1, c1, i1, c2, i1, flags))}
    func, sig = sigs[name]
    return c.compile_ptx(func, sig, device=False, cc=cc)[0]
