"""Argument checks shared by every public algorithm: one state (nv,) or a batch (N, nv), finite values."""
from __future__ import annotations

import numpy as np

from ..errors import InputError


def as_batch(model, **arrays):
    """Check named state arrays and return (batches (N, nv) in the given order, single: bool).

    Every array must be (nv,) or (N, nv) with the same N, finite. Errors name the array and the
    offending shape, row or joint.
    """
    out, shape = [], None
    for name, x in arrays.items():
        try:
            x = np.asarray(x, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{name}: cannot be read as an array of floats ({exc})") from None
        if x.ndim not in (1, 2) or x.shape[-1] != model.nv:
            raise InputError(f"{name} has shape {x.shape}; expected ({model.nv},) or (N, {model.nv}) "
                             f"for model {model.name!r} (q order: {', '.join(model.joint_names)})")
        if shape is not None and x.shape != shape:
            raise InputError(f"{name} has shape {x.shape} but {next(iter(arrays))} has {shape}")
        shape = x.shape
        check_finite(name, x, model.joint_names)
        out.append(np.atleast_2d(x))
    return out, len(shape) == 1


def check_finite(name, x, labels=None):
    """Raise InputError naming the first non-finite entry of x (by label of its last index if given)."""
    bad = ~np.isfinite(x)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        what = f" (joint {labels[idx[-1]]!r})" if labels is not None and x.ndim >= 1 else ""
        raise InputError(f"{name}{list(idx)}{what} is {x[idx]}: inputs must be finite")


def unbatch(x: np.ndarray, single: bool) -> np.ndarray:
    """Drop the batch axis again for a single-state call."""
    return x[0] if single else x


def external_wrenches(model, f_ext, f_ext_frame, N, R_world=None):
    """Convert f_ext = {frame: (force, moment)} to per-body (force, moment about the body origin) in body axes.

    The wrench is what the environment applies on the body, about the named frame's origin, expressed in
    that frame (f_ext_frame="local") or in world axes ("world"). Returns F, Mo of shape (nv, N, 3), or None.
    R_world (nv, N, 3, 3) is the bodies' orientation, needed for "world". Wrenches on the fixed base
    (frames of the root body) change no joint torque and are dropped.
    """
    if not f_ext:
        return None
    if f_ext_frame not in ("local", "world"):
        raise InputError(f"f_ext_frame must be 'local' or 'world', not {f_ext_frame!r}")
    F, Mo = np.zeros((model.nv, N, 3)), np.zeros((model.nv, N, 3))
    for name, wrench in f_ext.items():
        fr = model.frame(name)
        try:
            f, m = (np.broadcast_to(np.asarray(w, float), (N, 3)) for w in wrench)
        except (TypeError, ValueError):
            raise InputError(f"f_ext[{name!r}] must be (force, moment), each (3,) or ({N}, 3)") from None
        check_finite(f"f_ext[{name!r}]", np.stack([f, m]))
        if fr.body < 0:
            continue
        if f_ext_frame == "world":       # world axes -> body axes, then -> frame-independent below
            f = np.einsum("nji,nj->ni", R_world[fr.body], f)
            m = np.einsum("nji,nj->ni", R_world[fr.body], m)
        else:                            # frame axes -> body axes
            f, m = f @ fr.R.T, m @ fr.R.T
        F[fr.body] += f
        Mo[fr.body] += m + np.cross(fr.p, f)   # moment about the body origin
    return F, Mo


_F64 = np.dtype(np.float64)


def fast_shape(model, *arrays):
    """1 or 2 when every array is a float64 ndarray of one shape (nv,) or (N, nv) — the compiled kernels
    then take them as they are (any memory layout) and check finiteness themselves; 0 otherwise (take
    as_batch's checks and conversions)."""
    x0 = arrays[0]
    if type(x0) is not np.ndarray or x0.dtype is not _F64:
        return 0
    shape = x0.shape
    for x in arrays[1:]:
        if type(x) is not np.ndarray or x.dtype is not _F64 or x.shape != shape:
            return 0
    nd = len(shape)
    return nd if 1 <= nd <= 2 and shape[-1] == len(model.joint_names) else 0


def raise_kernel_error(model, code, names, batches):
    """Turn a kernel's return code into the InputError/SingularError the reference code would raise."""
    from ..errors import SingularError
    if code <= -2:
        i = -2 - code
        raise SingularError(f"mass matrix is singular: joint {model.joint_names[i]!r} moves a subtree "
                            f"without mass or inertia about its axis")
    s, i = divmod(code, model.nv)
    for name, x in zip(names, batches):
        x = np.atleast_2d(x)
        if not np.isfinite(x[s, i]):
            idx = [i] if x.shape[0] == 1 else [s, i]
            raise InputError(f"{name}{idx} (joint {model.joint_names[i]!r}) is {x[s, i]}: inputs must be finite")
