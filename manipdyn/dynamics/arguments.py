"""Argument and result checks shared by every public algorithm.

What every public function accepts (and refuses with InputError naming the argument):
- a state array is one state (nv,) or a batch (N, nv), all arrays of one call of one shape; an empty batch
  (N = 0) is computed like any other and gives empty results of the matching shape (N = 0 leading);
- real numbers only: float arrays as they are, integer and bool arrays converted to float64; complex,
  object, string, datetime and masked arrays, and None, are refused (nothing is dropped silently);
- finite values; frame and joint names that exist (the error lists the closest names);
- f_ext = None or {frame name: (force, moment)}, each (3,) or (N, 3), finite.
What every public function returns: finite numbers, or NumericalError naming the call, the array, the
row and the joint or link of the first non-finite entry (an intermediate overflowed).
"""
from __future__ import annotations

import difflib
import functools
from collections.abc import Mapping

import numpy as np

from ..errors import InputError, NumericalError, SingularError
from ..model import MimicModel, Model
from ..kernel_form import wrench_axes
from .mimic import TAKES_MIMIC
from .status import reading

_REAL_KINDS = "fiub"       # float, signed/unsigned integer, bool: read as float64


def check_model(model):
    """Refuse anything but a Model (a path or a Pinocchio model are common mistakes)."""
    if isinstance(model, MimicModel):
        raise InputError(f"{model!r}: a MimicModel (load_urdf(..., mimic=True)) is taken by "
                         f"{', '.join(TAKES_MIMIC)} only; for other functions use model.full at "
                         f"model.full_state(q, v, a)")
    if not isinstance(model, Model):
        raise InputError(f"model must be a manipdyn Model (from load_urdf), not {type(model).__name__}")


def as_real(name, x):
    """x as a float64 ndarray; InputError naming ``name`` for None, complex, object, string or masked input."""
    if x is None:
        raise InputError(f"{name} is None; expected an array of real numbers")
    if isinstance(x, np.ma.MaskedArray) and np.ma.getmaskarray(x).any():
        raise InputError(f"{name} is a masked array with masked entries; fill them first")
    try:
        a = np.asarray(x)
    except (TypeError, ValueError) as exc:          # ragged nesting, unconvertible objects
        raise InputError(f"{name}: cannot be read as an array of real numbers ({exc})") from None
    if a.dtype.kind not in _REAL_KINDS:
        kind = {"c": "complex", "O": "object", "U": "string", "S": "bytes", "M": "datetime",
                "m": "timedelta", "V": "structured"}.get(a.dtype.kind, str(a.dtype))
        raise InputError(f"{name}: cannot be read as real numbers: dtype {a.dtype} ({kind}); expected float, "
                         f"int or bool values")
    return a.astype(np.float64, copy=False)


def as_batch(model, **arrays):
    """Check named state arrays and return (batches (N, n) in the given order, single: bool).

    Arrays named q, q0, q1, q_… are configurations, (nq,) or (N, nq); every other array is a velocity,
    acceleration or torque, (nv,) or (N, nv). All of one call share N (N = 0 allowed) and their number of
    dimensions; each is real and finite. Errors name the array and the offending shape, row or entry.
    """
    check_model(model)
    out, lead, first = [], None, None
    for name, x in arrays.items():
        x = as_real(name, x)
        config = is_config(name)
        n = model.nq if config else model.nv
        if x.ndim not in (1, 2) or x.shape[-1] != n:
            order = ", ".join(model.q_names if config else model.v_names)
            raise InputError(f"{name} has shape {x.shape}; expected ({n},) or (N, {n}) for model "
                             f"{model.name!r} ({'nq' if config else 'nv'} = {n}; order: {order})")
        if lead is not None and x.shape[:-1] != lead:
            raise InputError(f"{name} has shape {x.shape} but {first[0]} has {first[1]}")
        if lead is None:
            lead, first = x.shape[:-1], (name, x.shape)
        check_finite(name, x, model.q_names if config else model.v_names)
        out.append(x[None] if x.ndim == 1 else x)
    return out, len(lead) == 0


def is_config(name: str) -> bool:
    """A state array named q, q0, q1, q_guess, ... is a configuration (nq entries); others have nv."""
    return name == "q" or (name.startswith("q") and name[1:2] in ("0", "1", "_", ""))


def check_finite(name, x, labels=None):
    """Raise InputError naming the first non-finite entry of x (by label of its last index if given)."""
    bad = ~np.isfinite(x)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        what = f" (joint {labels[idx[-1]]!r})" if labels is not None and x.ndim >= 1 else ""
        raise InputError(f"{name}{list(idx)}{what} is {x[idx]}: inputs must be finite")


def check_scalar(name, x, *, positive=False, nonnegative=False, integer=False):
    """A finite real scalar (int when ``integer``), > 0 or ≥ 0 if asked; InputError naming ``name``."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise InputError(f"{name} must be a real number, not {type(x).__name__} {x!r}")
    if integer and not isinstance(x, (int, np.integer)):
        raise InputError(f"{name} must be an integer, not {x!r}")
    if not np.isfinite(x):
        raise InputError(f"{name} is {x}; it must be finite")
    if (positive and not x > 0) or (nonnegative and not x >= 0):
        raise InputError(f"{name} is {x}; it must be {'> 0' if positive else '≥ 0'}")
    return int(x) if integer else float(x)


def unbatch(x: np.ndarray, single: bool) -> np.ndarray:
    """Drop the batch axis again for a single-state call."""
    return x[0] if single else x


def _unknown(model, name, known, what):
    close = difflib.get_close_matches(str(name), known, n=5, cutoff=0.5)
    hint = f"closest: {', '.join(close)}" if close else f"known: {', '.join(sorted(known)[:20])}" + \
        (f" … ({len(known)} in all)" if len(known) > 20 else "")
    return InputError(f"model {model.name!r} has no {what} named {name!r}; {hint}")


def frame_of(model, name):
    """The Frame of a link or frame name; InputError lists the closest names."""
    check_model(model)
    if not isinstance(name, str):
        raise InputError(f"a frame name must be a string, not {type(name).__name__} {name!r}")
    fr = model.frames.get(name)
    if fr is None:
        raise _unknown(model, name, list(model.frames), "link or frame")
    return fr


def joint_indices(model, names, what="joints"):
    """Indices of a list of joint names in q order; InputError lists the closest names."""
    if isinstance(names, (str, bytes)) or not hasattr(names, "__iter__"):
        raise InputError(f"{what} must be a list of joint names, not {type(names).__name__} {names!r}")
    out = []
    for n in names:
        if n not in model.joint_names:
            raise _unknown(model, n, list(model.joint_names), "moving joint")
        out.append(model.joint_names.index(n))
    return out


def check_f_ext(model, f_ext, f_ext_frame, N):
    """Validated wrenches [(Frame, force (N, 3), moment (N, 3)), ...], or None for no f_ext.

    f_ext must be None or a dict {link or frame name: (force, moment)}, each (3,) or (N, 3), real, finite.
    """
    if f_ext_frame not in ("local", "world"):
        raise InputError(f"f_ext_frame must be 'local' or 'world', not {f_ext_frame!r}")
    if f_ext is None:
        return None
    if not isinstance(f_ext, Mapping):
        raise InputError(f"f_ext must be None or a dict {{link or frame name: (force, moment)}}, "
                         f"not {type(f_ext).__name__}")
    out = []
    for name, wrench in f_ext.items():
        fr = frame_of(model, name)
        if isinstance(wrench, (str, bytes, Mapping)) or not hasattr(wrench, "__len__") or len(wrench) != 2:
            raise InputError(f"f_ext[{name!r}] must be a pair (force, moment), each (3,) or ({N}, 3); "
                             f"got {type(wrench).__name__}")
        pair = []
        for what, w in zip(("force", "moment"), wrench):
            w = as_real(f"f_ext[{name!r}] {what}", w)
            if w.shape not in ((3,), (N, 3)):
                raise InputError(f"f_ext[{name!r}] {what} has shape {w.shape}; expected (3,) or ({N}, 3)")
            check_finite(f"f_ext[{name!r}] {what}", w)
            pair.append(np.broadcast_to(w, (N, 3)))
        out.append((fr, pair[0], pair[1]))
    return out or None


def wrench_rows(model, f_ext, f_ext_frame, N, lanes=False):
    """f_ext = {frame: (force, moment)} checked and laid out for the kernels: one row per wrench on a moving body.
    ``lanes``: for the lane kernels' form (``Model.kernel.lane_arrays``), "body axes" are the body's z-aligned ones.

    Returns X (N, K, 6) = [force; moment] of each wrench, body (K,) int64 and point (K, 3) = the frame's
    origin in body axes, about which the moment is taken. With f_ext_frame="local" the frame's axes are
    turned into the body's (x_body = R_frame x_frame), so X is in body axes; with "world" X stays in world
    axes (the kernel turns it with the body orientation it computes). Wrenches on the fixed base (frames of
    the root body) change no joint torque and are dropped; K = 0 for none.
    """
    rows = [w for w in (check_f_ext(model, f_ext, f_ext_frame, N) or ()) if w[0].body >= 0]
    X, body, point = np.empty((N, len(rows), 6)), np.empty(len(rows), np.int64), np.empty((len(rows), 3))
    for k, (fr, f, m) in enumerate(rows):
        R, p = wrench_axes(model.kernel.lane_turns[fr.body] if lanes else np.eye(3), fr, f_ext_frame)
        X[:, k, :3], X[:, k, 3:], body[k], point[k] = f @ R.T, m @ R.T, fr.body, p
    return X, body, point


def fast_wrenches(model, f_ext, f_ext_frame):
    """One state's f_ext in the kernels' compact form, when it is a dict of one wrench {frame name: (force (3,),
    moment (3,))} of float64 arrays: (force, moment, P) with P (13,) the frame's row for
    ``kernel_inputs.wrench_rows_of`` — [R (9, row by row): frame axes → body axes for "local" (identity for "world"),
    the frame's origin in body axes (3), the body (-1: the fixed base)], from ``model.kernel.wrench_rows``.
    None when anything is unusual (then ``wrench_rows`` checks and converts, and raises the error).
    Finiteness is left to the kernel: a non-finite wrench makes a non-finite result, and the caller then takes
    the checked path. (One wrench only: more would be a tuple type of their own, each count compiled anew.)"""
    if type(f_ext) is not dict or len(f_ext) != 1 or type(f_ext_frame) is not str:
        return None
    (name, pair), = f_ext.items()
    if type(pair) is not tuple or len(pair) != 2:
        return None
    f, m = pair
    if type(f) is not _ND or f.dtype is not _F64 or f.shape != (3,) or type(m) is not _ND or \
            m.dtype is not _F64 or m.shape != (3,):
        return None
    try:
        return f, m, model.kernel.wrench_rows[name, f_ext_frame]
    except (AttributeError, KeyError, TypeError):        # a MimicModel, an unknown name or frame word
        return None


_F64, _ND = np.dtype(np.float64), np.ndarray


def fast_shape(model, *arrays):
    """1 or 2 when the arrays are float64 ndarrays q (nq,) or (N, nq) and then (nv,) or (N, nv) of the
    same N, with nv ≥ 1 — the compiled kernels then take them as they are (any memory layout) and check
    finiteness themselves; 0 otherwise (take as_batch's checks and conversions). (Written for speed: it
    runs before every single-state call; one state costs ~100 ns here.)"""
    x0 = arrays[0]
    if type(x0) is not _ND or x0.dtype is not _F64 or type(model) is not Model:
        return 0
    sq, sv = model.kernel.q_shape, model.kernel.v_shape
    if x0.shape == sq:
        if not sv[0]:
            return 0
        for x in arrays[1:]:
            if type(x) is not _ND or x.dtype is not _F64 or x.shape != sv:
                return 0
        return 1
    shape = x0.shape
    if len(shape) != 2 or shape[1] != sq[0] or not sv[0]:
        return 0
    want = (shape[0], sv[0])
    for x in arrays[1:]:
        if type(x) is not _ND or x.dtype is not _F64 or x.shape != want:
            return 0
    return 2


def check_out(call, result, out, shape, inputs=()):
    """``out``, the array a call writes its result into (``out=``): a writeable float64 numpy.ndarray of exactly
    the result's shape (any memory layout). Returns it; InputError naming what is wrong otherwise. ``inputs``:
    the arrays of a batch, which ``out`` may not share memory with (a batch kernel writes a block's results before
    it reads the next block's states); one state's kernels read every input before they write ``out``, so one
    state's ``out`` may be one of its inputs (tests/batch/test_out.py) and is not checked for it (~0.2 µs a
    check). (Written for speed: a one-state call with out= runs it.)"""
    if type(out) is _ND and out.dtype is _F64 and out.shape == shape and out.flags.writeable:
        for x in inputs:
            if type(x) is _ND and np.may_share_memory(out, x):
                raise InputError(f"{call}: out shares memory with an input array of the batch; pass a separate "
                                 f"array for {result}")
        return out
    if type(out) is not _ND:                        # (a subclass too: the kernels take numpy.ndarray itself)
        got = f"a {type(out).__module__}.{type(out).__name__}"
    elif out.dtype != _F64:
        got = f"an array of dtype {out.dtype}"
    elif out.shape != shape:
        got = f"an array of shape {out.shape}"
    else:
        got = "a read-only array"
    raise InputError(f"{call}: out must be a writeable float64 numpy.ndarray of shape {shape} (room for {result}), "
                     f"not {got}")


def fast(model, q, v=NotImplemented, a=NotImplemented):
    """The model's kernel arrays (I, F) when q is one float64 configuration (nq,) — and v, a, when passed, float64
    (nv,) — of a plain Model with nv ≥ 1: the one-state kernels then take them as they are (any memory layout)
    and check finiteness themselves. None otherwise: the caller takes the checked path, which raises the right
    error. (Written for speed: it runs before every one-state call.)"""
    if type(q) is _ND and q.dtype is _F64 and type(model) is Model:
        k = model.kernel
        if q.shape != k.q_shape or not k.v_shape[0]:
            return None
        if v is not NotImplemented and (type(v) is not _ND or v.dtype is not _F64 or v.shape != k.v_shape):
            return None
        if a is not NotImplemented and (type(a) is not _ND or a.dtype is not _F64 or a.shape != k.v_shape):
            return None
        return k.arrays
    return None


def raise_kernel_error(model, code, names, batches, call="", out_name="", out=None):
    """Turn a kernel's status (dynamics/status.py) into the error the checks of ``as_batch`` and ``check_output``
    would raise: a non-finite input (InputError naming it), a joint that moves no mass (SingularError naming it),
    a non-finite result at a flat index of ``out`` in batch form (NumericalError naming its row and joint)."""
    nb = model.njoints
    for name, x in zip(names, batches):          # a bad input is the cause to report first
        check_finite(name, x, model.q_names if is_config(name) else model.v_names)
    what, k = reading(code, nb)
    if what == "sizes":                          # a kernel that disagrees with the Python checks: never expected
        raise NumericalError(f"{call}: the kernel refused the arrays' sizes, which are the model's (nq = {model.nq}, "
                             f"nv = {model.nv}): an inconsistency inside manipdyn, please report it")
    if what == "result":
        res = out[None] if batches[0].ndim == 1 else out
        idx = np.unravel_index(k, res.shape)
        raise_output_error(call, out_name, res, idx, model, dict(zip(names, batches)))
    if what == "joint":
        i = k
        multi = getattr(model, "nvs", (1,) * nb)[i] > 1
        along = "in some direction of its motion" if multi else "about or along its axis"
        raise SingularError(f"mass matrix is singular: joint {model.joint_names[i]!r} moves a subtree "
                            f"without mass or inertia {along}")
    raise InputError(f"{call}: a non-finite input (kernel status {code})")


def raise_output_error(call, name, x, idx, model=None, inputs=None, what="joint", axis=1, labels=None):
    """NumericalError naming the call, the result entry x[idx] (x in batch form (N, ...)), its row, the
    joint, link or other ``what`` (named by ``labels``) of index ``axis``, and the largest input magnitude
    of that row."""
    idx = tuple(int(i) for i in idx)
    row, single = idx[0], x.shape[0] == 1
    shown = idx[1:] if single else idx                       # one state: no row to name
    where = [] if single else [f"row {row}"]
    if labels is None and model is not None:
        labels = model.v_names if what == "joint" else model.body_names if what == "link" else None
    if labels is not None and len(idx) > axis and idx[axis] < len(labels):
        where.append(f"{what} {labels[idx[axis]]!r}")
    big = max(((float(np.max(np.abs(v.reshape(-1, v.shape[-1]) if v.ndim == 1 else v[row]), initial=0.0)), n)
               for n, v in (inputs or {}).items() if isinstance(v, np.ndarray) and v.size), default=None)
    hint = f"; largest input{'' if single else ' of that row'}: |{big[1]}| = {big[0]:.3g}" if big else ""
    grav = f"; model gravity {np.asarray(model.gravity).tolist()}" if model is not None else ""
    raise NumericalError(f"{call}: the result {name}{list(shown) if shown else ''}"
                         f"{' (' + ', '.join(where) + ')' if where else ''} "
                         f"is {x[idx]}: an intermediate overflowed or was undefined — the inputs or the model are "
                         f"out of scale{hint}{grav}")


def check_output(call, name, x, model=None, inputs=None, what="joint", axis=1, labels=None):
    """x (batch form (N, ...)) unchanged if finite; else NumericalError naming call, row and joint/link."""
    bad = ~np.isfinite(x)
    if bad.any():
        raise_output_error(call, name, x, np.argwhere(bad)[0], model, inputs, what, axis, labels)
    return x


def quiet(fn):
    """Run a numpy-path function without overflow/invalid warnings: its results are checked instead
    (check_output raises NumericalError), so the warnings would only repeat the error."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return fn(*args, **kwargs)
    return wrapper
