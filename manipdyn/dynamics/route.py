"""The one path from a public call to its compiled kernel.

A public algorithm that maps states to one array per state (``rnea``, the bias forces, ``aba``, the Cholesky
route, the CRBA, the Coriolis matrix, the regressor) is its signature and docstring under ``@route(...)``, the
declaration of its path: the compiled entries that compute it (``_jit.entry``: one state, a batch), the names of
its state arguments (``q…`` has nq entries, every other name nv: ``arguments.is_config``), the name and shape of one
state's result, whether it takes external wrenches, and how a MimicModel maps onto it. The path, the same for
every such call (docs/design.md §2):

  1. one float64 state of a plain Model (``arguments.fast``): the one-state entry, no checks in Python — the
     kernel checks finiteness itself and returns its status (dynamics/status.py);
  2. one state with one wrench {frame: (force (3,), moment (3,))} of float64 arrays: the one-state wrench entry;
  3. float64 batches of the model's shapes (``arguments.fast_shape``): the batch entry;
  4. a MimicModel: the route's map onto the full model (``dynamics/mimic.py``; the calls that have one are
     ``mimic.TAKES_MIMIC``, every other refuses it by name);
  5. anything else: ``arguments.as_batch``'s checks and conversions (an error names the argument), the wrenches
     checked and laid out (``arguments.wrench_rows``), then the batch entry (one state without wrenches: the
     one-state entry, so that a state's numbers do not depend on its dtype) — except Dask arrays of states
     (N, n): a Dask array of the results comes back, each chunk of rows a batch of this call computed when
     asked, on the scheduler's workers (``Route.lazy``; the Dask extra);
  6. a status other than OK: ``arguments.raise_kernel_error``, the typed error naming the input, the joint or
     the result entry at fault.

A batch of N ≥ 2 · MIN_CHUNK states is cut into contiguous chunks, one per thread (``threads``, default: every
core this process may run on, ``CORES``), each run by the same batch entry on its rows — the kernels release
Python's lock (``_jit.njit``: nogil) — so every state gets the numbers a one-thread call gives, bit for bit.
``out=``: the array the result is written into and returned (``arguments.check_out``: the result's exact shape,
float64, writeable; a batch's may not share memory with its states), instead of a new one.
A chunk's status is read as the whole batch's (``status.shift``: a state index or a result's flat index moved by
the chunk's first row); the first failing chunk's is the one reported, as one thread would stop at it.

The kernels' convention: ``one(I, F, *state, out)`` and ``batch(I, F, *states, [X, body, point, world,] out,
*tail)`` return their status; (I, F) = ``Model.kernel.arrays`` (``lane_arrays`` for a lane entry: ``Route.lanes``,
``one_lanes``); every array of any strides (``_jit.A1``…).
"""
from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor
from numbers import Integral

import numpy as np

from ..errors import InputError, ManipdynError
from ..extras import require
from ..model import MimicModel, Model
from .status import OK, WRONG_SIZES, shift
from .arguments import (as_batch, check_f_ext, check_out, fast, fast_shape, fast_wrenches, is_config,
                        raise_kernel_error, unbatch, wrench_rows)


_MISSING = NotImplemented      # a state argument the call was not given (arguments.fast's sentinel too)
_ND, _F64, _NO_V = np.ndarray, np.dtype(np.float64), (0,)   # (a model without velocities: the checked path)
SHAPES = ("v", "vv", "regressor")   # one state's result: (nv,), (nv, nv), (nv, 10 nb) — Model.kernel.result_shapes
CORES = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
MIN_CHUNK = 128     # states per thread at least (on average): a thread's start and join cost ~20 µs, 128 ABA states ~80 µs
CALLER_SHARE = 1.06  # the calling thread's chunk against a worker's: 2 threads on N = 1e4 ur5 rnea states took
#                     0.53–0.54 of one thread's time with equal chunks, 0.50–0.53 with this (a 2-core VM, where a
#                     worker starts 30–50 µs after the caller and a sleeping caller wakes ~50 µs after the last
#                     worker ends)
MAX_THREADS = 1024  # the most threads= takes; at most max(4 · CORES, 8) run at once (the pool's size)
_POOL = []          # the worker threads, started on the first batch that is split (no import side effect)


def is_dask(x):
    """True for a Dask array (recognised without importing dask)."""
    return type(x).__module__.partition(".")[0] == "dask" and hasattr(x, "map_blocks")


def thread_count(threads, call):
    """The threads a batch may use: ``threads`` (a positive integer) or, for None, CORES."""
    if threads is None:
        return CORES
    if isinstance(threads, Integral) and not isinstance(threads, bool) and 1 <= threads <= MAX_THREADS:
        return int(threads)
    raise InputError(f"{call}: threads must be a positive integer (at most {MAX_THREADS}) or None (every core), "
                     f"not {threads!r}")


def _codes(run, parts):
    """``run(a, b)`` for every chunk (a, b) of ``parts``, at once: the calling thread runs the first, the pool's
    worker threads (started on first use; at most max(4 · CORES, 8), more chunks wait their turn) the rest.
    Returns their codes in chunk order."""
    workers = min(max(len(parts) - 1, CORES - 1, 1), max(4 * CORES, 8))
    if not _POOL or _POOL[0][0] < workers:
        _POOL[:] = [(workers, ThreadPoolExecutor(workers, "manipdyn"))]
    rest = [_POOL[0][1].submit(run, a, b) for a, b in parts[1:]]
    return [run(*parts[0])] + [f.result() for f in rest]


def chunks(N, threads):
    """Row bounds [(a, b)] of the chunks a batch of N states is run in: min(threads, N // MIN_CHUNK) chunks, at
    least one. The first, which the calling thread runs (``_codes``), is CALLER_SHARE times the size of the
    others: the workers start later (the hand-off), and a caller that finishes last collects their codes at
    once instead of sleeping until they end and waking up again."""
    n = max(1, min(threads, N // MIN_CHUNK))
    if n == 1:
        return [(0, N)]
    first = round(N * CALLER_SHARE / (n - 1 + CALLER_SHARE))
    edges = [0] + [first + (N - first) * k // (n - 1) for k in range(n)]
    return list(zip(edges[:-1], edges[1:]))


def run_chunks(run, N, threads):
    """``run(a, b)`` (a kernel call on rows a … b − 1 returning its code) over a batch of N states in chunks on up
    to ``threads`` threads at once, for kernels whose codes are not mapped chunk by chunk (the derivatives): −1
    when every chunk succeeds, else the code of ``run(0, N)`` on the calling thread — a rare second pass that
    gives exactly the code one thread gives."""
    parts = chunks(N, threads)
    if len(parts) == 1:
        return run(0, N)
    return -1 if all(c == -1 for c in _codes(run, parts)) else run(0, N)


def run_batch(batch, arrays, states, ext, out, tail, threads, nb):
    """``batch.call(*arrays, *states, *ext, out, *tail)`` over the rows of the states in chunks, on up to
    ``threads`` threads at once: ``status.OK``, or the first failing chunk's status read as the whole batch's
    (``status.shift``).
    ext = (X, body, point, world): X has one row per state (or none), the rest is shared."""
    parts = chunks(out.shape[0], threads)
    if len(parts) == 1:
        return batch.call(*arrays, *states, *ext, out, *tail)
    N, size = out.shape[0], out[0].size

    def part(a, b):
        x = (ext[0][a:b] if ext[0].shape[0] == N else ext[0], *ext[1:]) if ext else ()
        return batch.call(*arrays, *(y[a:b] for y in states), *x, out[a:b], *tail)
    for (a, _), code in zip(parts, _codes(part, parts)):
        if code != OK:
            return shift(code, a, nb, size)
    return OK


def lazy(call, names, public, model, x, f_ext, shape):
    """Dask arrays of states (N, n) (numpy arrays among them are wrapped): a Dask array of the results
    (N, *one state's shape), rows chunked as the first state's, each chunk computed when asked as a batch of
    this call on one thread (the scheduler runs chunks in parallel; a Model pickles as its description)."""
    da = require("dask.array", "dask", f"{call} on a Dask array")
    if f_ext is not None:
        raise InputError(f"{call}: f_ext with Dask arrays of states is not supported; pass numpy arrays "
                         f"(or call {call} per chunk with dask's map_blocks)")
    if type(model) is not Model:
        raise InputError(f"{call}: Dask arrays of states need a Model, not a {type(model).__name__}")
    states = [da.asarray(y) for y in x]
    N = states[0].shape[0] if states[0].ndim else None
    for name, y in zip(names, states):
        n = model.nq if is_config(name) else model.nv
        if y.ndim != 2 or y.shape[1] != n or y.shape[0] != N:
            raise InputError(f"{call}: a Dask array of states is (N, n), the same N for every state: {name} "
                             f"must be (N, {n}), it is {tuple(y.shape)}")
    rows = states[0].chunks[0]
    states = [y.rechunk((rows, -1)) for y in states]

    def block(*b, block_info=None):
        try:
            return public(model, *b, threads=1)
        except ManipdynError as exc:                        # name the chunk: its row indices start at 0
            if not block_info:
                raise
            a, z = block_info[0]["array-location"][0]
            raise type(exc)(f"in the chunk of rows {a}–{z - 1} of the Dask batch (row indices below count from "
                            f"{a}): {exc}") from None
    return da.map_blocks(block, *states, dtype=np.float64, chunks=(rows,) + tuple((n,) for n in shape),
                         new_axis=list(range(2, 1 + len(shape))) or None, meta=np.empty((0,) * (1 + len(shape))))


def route(call, names, result, shape, one, batch, **options):
    """Decorator: the public function below it — its signature and docstring — runs the path of
    ``Route(call, names, result, shape, one, batch, **options)`` (its body is not run: write the docstring only).
    Steps 1 and 2 run inside the returned function itself, with its arguments by name (q [, v [, a]]), so that a
    one-state call costs one Python frame and no argument packing. Step 1's checks are those numba's unboxing needs
    (numpy.ndarray, float64, one dimension), written out: the one-state kernels check the lengths themselves
    (``kernel_inputs.sized``), and an array of another length comes back as status.WRONG_SIZES, on which the call
    goes on to the checked path, which names it. (Measured on ur5, rnea, a plain timeit, A/B: 1.85 µs with
    ``arguments.fast``'s checks, 1.75 µs with them written out here, 1.72 µs with the lengths checked in the kernel;
    the kernel call alone, 1.26 µs with its result array.)"""
    r = Route(call, names, result, shape, one, batch, **options)
    no_v, no_a, shape = len(r.names) < 2, len(r.names) < 3, SHAPES.index(r.shape)
    wrench_one, one_lanes = r.wrench_one, r.one_lanes    # (every route with wrench_one has three states)

    def bind(public):
        def path(model, q=_MISSING, v=_MISSING, a=_MISSING, tau=_MISSING, f_ext=None, f_ext_frame="local",
                 threads=None, out=None):
            # (no keyword-only parameters: their defaults cost a dict lookup each per call; the public signature,
            # which inspect and the docs show, is the decorated function's)
            if tau is not _MISSING:                             # the third state by its name in aba's calls
                a = r.by_name(a, tau)
            if threads is not None:
                thread_count(threads, r.call)                   # (checked for one state too)
            if type(model) is Model:
                K = model.kernel
                if f_ext is None and f_ext_frame == "local":
                    if type(q) is _ND and q.dtype is _F64 and q.ndim == 1 and K.v_shape != _NO_V and \
                            (v is _MISSING if no_v else type(v) is _ND and v.dtype is _F64 and v.ndim == 1) and \
                            (a is _MISSING if no_a else type(a) is _ND and a.dtype is _F64 and a.ndim == 1):
                        I, F = K.lane_arrays if one_lanes else K.arrays    # 1. one float64 state: straight in
                        out = np.empty(K.result_shapes[shape]) if out is None else \
                            check_out(r.call, r.result, out, K.result_shapes[shape])
                        code = one.call(I, F, q, out) if no_v else one.call(I, F, q, v, out) if no_a else \
                            one.call(I, F, q, v, a, out)
                        if code == -1:
                            return out
                        if code != WRONG_SIZES:                 # (other lengths: the checked path names them)
                            r.fail(model, code, r.given(q, v, a), out)
                elif wrench_one is not None and v is not _MISSING and a is not _MISSING:
                    k = fast(model, q, v, a)
                    w = fast_wrenches(model, f_ext, f_ext_frame) if k is not None else None
                    if w is not None:                           # 2. one state, one wrench: straight in
                        I, F = K.lane_arrays                    # (every route with wrench_one has one_lanes)
                        out = np.empty(K.result_shapes[shape]) if out is None else \
                            check_out(r.call, r.result, out, K.result_shapes[shape])
                        if wrench_one.call(I, F, q, v, a, w[0], w[1], w[2], f_ext_frame == "world", out) == -1:
                            return out                          # else the checked path says what is wrong
            return r.checked(model, r.given(q, v, a), f_ext, f_ext_frame, threads, out)
        path = functools.wraps(public)(path)
        path.route, r.public = r, path
        return path
    return bind


class Route:
    """How one public call reaches its kernel (the module docstring gives the path; ``route`` binds it to
    the public function).

    call      the public name (errors name it)
    names     its state arguments in order, e.g. ("q", "v", "a")
    result    the result's name in errors ("tau", "q̈", "M", ...)
    shape     one state's result shape, one of SHAPES: "v" (nv,), "vv" (nv, nv), "regressor" (nv, 10 nb)
    one       entry of the one-state kernel: one(I, F, *state, out)
    one_lanes True: the one-state entry drives the lane steps too, and takes the model in z-aligned frames
              (``Model.kernel.lane_arrays``); so does its wrench entry (``Model.kernel.wrench_rows``: the
              wrench in those frames)
    batch     entry of the batch kernel: batch(I, F, *states, [X, body, point, world,] out, *tail)
    tail      constant arguments after out (rnea's empty per-link terms)
    wrenches  True: the call takes f_ext and f_ext_frame, passed to the batch kernel as ``arguments.wrench_rows``
    wrench_one  entry for one state with one wrench: (I, F, *state, force, moment, row, world, out)
    mimic     mimic(model, *states, **wrench keywords) for a MimicModel, or None (refused, by name)
    lanes     True: the batch entry is a lane kernel, which takes the model in z-aligned frames
              (``Model.kernel.lane_arrays``, and its wrenches in those frames)
    """
    __slots__ = ("call", "names", "result", "shape", "one", "batch", "tail", "wrenches", "wrench_one",
                 "mimic", "public", "lanes", "one_lanes")

    def __init__(self, call, names, result, shape, one, batch, *, tail=(), wrenches=False,
                 wrench_one=None, mimic=None, lanes=False, one_lanes=False):
        self.call, self.names, self.result, self.shape = call, tuple(names), result, shape
        self.one, self.batch, self.tail, self.lanes, self.one_lanes = one, batch, tuple(tail), lanes, one_lanes
        self.wrenches, self.wrench_one, self.mimic = wrenches, wrench_one, mimic
        if wrench_one is not None and not one_lanes:
            raise ValueError(f"{call}: a wrench entry takes the lane arrays (Model.kernel.wrench_rows' frames): "
                             f"one_lanes=True")

    def by_name(self, a, tau):
        """The third state argument given as ``tau=...`` (aba's and forward_dynamics' name for it)."""
        if len(self.names) < 3 or self.names[2] != "tau" or a is not _MISSING:
            raise TypeError(f"{self.call}() got an unexpected keyword argument 'tau'")
        return tau

    def given(self, *x):
        """The state arguments a call was given, in order (those not given left out)."""
        return tuple(y for y in x if y is not _MISSING)

    def checked(self, model, x, f_ext=None, f_ext_frame="local", threads=None, out=None):
        """Steps 3–6 of the path: batches, a MimicModel, checked and converted input; ``out``: the array to
        write the result into (``arguments.check_out``), or None (a new one)."""
        if len(x) != len(self.names):
            n = len(self.names)
            raise TypeError(f"{self.call}() takes the model and {n} state array{'s' * (n > 1)} "
                            f"({', '.join(self.names)}); {len(x)} given")
        if not self.wrenches and (f_ext is not None or f_ext_frame != "local"):
            raise TypeError(f"{self.call}() takes no external wrenches (f_ext, f_ext_frame)")
        if any(is_dask(y) for y in x):
            if out is not None:
                raise InputError(f"{self.call}: out= with Dask arrays of states is not supported (the result is "
                                 f"a Dask array, computed when asked)")
            return self.lazy(model, x, f_ext)
        if f_ext is None and f_ext_frame == "local" and fast_shape(model, *x) == 2:
            states, single = x, False                           # 3. float64 batches
        elif type(model) is MimicModel and self.mimic is not None:
            kw = dict(f_ext=f_ext, f_ext_frame=f_ext_frame) if self.wrenches else {}
            res = self.mimic(model, *x, **kw)                   # 4. a MimicModel (its inner calls: every core)
            if out is None:
                return res
            check_out(self.call, self.result, out, res.shape)[...] = res   # (after the call: no overlap)
            return out
        else:                                                   # 5. checked and converted
            states, single = as_batch(model, **dict(zip(self.names, x)))
        N, shape = states[0].shape[0], model.kernel.result_shapes[SHAPES.index(self.shape)]
        if out is not None:
            out = check_out(self.call, self.result, out, shape if single else (N,) + shape,
                            () if single and f_ext is None and f_ext_frame == "local" else x)   # (one state: the
        #                                                         one-state kernel, below, reads before it writes)
        if not model.nv:                                        # no moving joint: nothing to compute
            if out is None:
                return unbatch(np.zeros((N,) + shape), single)
            out[...] = 0.0
            return out
        if single and f_ext is None and f_ext_frame == "local":  # one state (converted): the one-state kernel, so
            out = np.empty(shape) if out is None else out       # that its numbers do not depend on its dtype (the
            arrays = model.kernel.lane_arrays if self.one_lanes else model.kernel.arrays
            code = self.one.call(*arrays, *(y[0] for y in states), out)   # batch kernels run lanes)
            if code != -1:
                self.fail(model, code, states, out[np.newaxis])
            return out
        if self.wrenches:
            with np.errstate(over="ignore", invalid="ignore"):  # (an overflow comes back as a kernel code)
                ext = (*wrench_rows(model, f_ext, f_ext_frame, N, self.lanes), f_ext_frame == "world")
        else:
            ext = ()
        given = out
        out = np.empty((N,) + shape) if out is None else out[np.newaxis] if single else out
        arrays = model.kernel.lane_arrays if self.lanes else model.kernel.arrays
        code = run_batch(self.batch, arrays, states, ext, out, self.tail, thread_count(threads, self.call),
                         model.njoints)
        if code != -1:
            self.fail(model, code, states, out, f_ext, f_ext_frame)
        return unbatch(out, single) if given is None else given

    def lazy(self, model, x, f_ext):
        """Dask arrays of states: ``lazy`` with this call's public function and one state's result shape."""
        return lazy(self.call, self.names, self.public, model, x, f_ext,
                    model.kernel.result_shapes[SHAPES.index(self.shape)])

    def fail(self, model, code, states, out, f_ext=None, f_ext_frame="local"):
        """6. Raise the error a kernel code stands for (a non-finite wrench first: it is the cause)."""
        if f_ext is not None:
            check_f_ext(model, f_ext, f_ext_frame, states[0].shape[0] if states[0].ndim == 2 else 1)
        raise_kernel_error(model, code, self.names, states, self.call, self.result, out)
