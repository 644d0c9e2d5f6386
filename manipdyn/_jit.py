"""The decorator of every compiled kernel: numba's ``njit``, with an on-disk cache that no edit can outlive,
and a switch to run the kernels as plain Python.

numba stamps a cached function with its own source file only. constraints/fast.py calls (and inlines)
kernels of dynamics/ and joints.py, so after an edit to joints.py numba would load the closed-chain
kernel's stale machine code. Here every kernel's cache lives in a folder named by a hash of all the kernel
sources (``KERNEL_SOURCES``): editing any of them selects a fresh folder, and everything recompiles.

Cache folder: ``<base>/numba-<sha256[:16]>``, base = numba's ``NUMBA_CACHE_DIR`` if the user set it, else
``manipdyn/__pycache__`` if writable, else the user cache directory (``~/.cache/manipdyn``). If none is
writable the kernels compile without a disk cache. Importing reads the kernel sources (to hash them) and
changes nothing but the cache folder it picks (numba creates it); ``prune_stale()`` — run by ``manipdyn
warmup`` — removes the in-tree folders of earlier sources.

Switches (environment, read at import):
  MANIPDYN_NOJIT=1     the kernels run uncompiled, as the Python functions they are written as (slow: for
                       reading, stepping through with pdb, or checking the compiled code against itself)
  NUMBA_DISABLE_JIT=1  numba's own switch: the same for every numba function in the process
"""
from __future__ import annotations

import hashlib
import os
import re
import shutil
from contextlib import contextmanager
from pathlib import Path

import numba

PACKAGE = Path(__file__).resolve().parent
KERNEL_SOURCES = ("_jit.py", "spatial.py", "joints.py", "dynamics/model_arrays.py", "dynamics/forward_kinematics.py",
                  "dynamics/kernel_inputs.py", "dynamics/lanes.py", "dynamics/status.py",
                  "dynamics/rnea.py", "dynamics/crba.py", "dynamics/aba.py",
                  "dynamics/derivatives.py", "dynamics/regressor.py", "dynamics/coriolis.py", "dynamics/energy.py",
                  "dynamics/kinematics.py", "dynamics/lagrange.py", "constraints/closures.py", "constraints/fast.py",
                  "compiled.py")   # every file a kernel's code lives in
NOJIT = os.environ.get("MANIPDYN_NOJIT", "") not in ("", "0")
_FOLDER = re.compile(r"numba-[0-9a-f]{16}")


def source_hash(root=PACKAGE, files=KERNEL_SOURCES):
    """sha256 (hex) over the names and bytes of the kernel sources, or None if one cannot be read."""
    h = hashlib.sha256()
    try:
        for name in files:
            h.update(name.encode() + b"\0" + (Path(root) / name).read_bytes() + b"\0")
    except OSError:
        return None
    return h.hexdigest()


def _writable(path):
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.getpid()}"
        probe.touch()
        probe.unlink()
        return True
    except OSError:
        return False


def cache_dir(root=PACKAGE, user_base=None):
    """The folder every kernel of this source tree caches into (Path), or None (no disk cache)."""
    digest = source_hash(root)
    if digest is None:
        return None
    name = f"numba-{digest[:16]}"
    user_base = numba.config.CACHE_DIR if user_base is None else user_base
    if user_base:
        return Path(user_base) / name if _writable(Path(user_base) / name) else None
    in_tree = Path(root) / "__pycache__"
    if _writable(in_tree / name):
        return in_tree / name
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "manipdyn"
    return home / name if _writable(home / name) else None


def prune_stale(root=PACKAGE):
    """Remove the in-tree cache folders (``manipdyn/__pycache__/numba-*``) of earlier kernel sources, keeping the
    current one (never a user-given NUMBA_CACHE_DIR). Returns the folders removed."""
    keep, base, gone = cache_dir(root), Path(root) / "__pycache__", []
    for p in base.iterdir() if base.is_dir() else ():
        if (keep is None or p != keep) and _FOLDER.fullmatch(p.name) and p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
            gone.append(p)
    return gone


@contextmanager
def _numba_cache_dir(path):
    """numba.config.CACHE_DIR = path while a dispatcher picks its cache locator (at decoration)."""
    old = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(path)
    try:
        yield
    finally:
        numba.config.CACHE_DIR = old


_CACHE = None if NOJIT else cache_dir()


# Floating point: kernels round as written (no fast-math), so that for the same formula they give Pinocchio's
# numbers to the last bits. CONTRACT lets LLVM fuse a·b + c into one fused multiply-add (nothing else of
# fast-math: no reassociation, NaN and ±inf keep their meaning, so the finiteness checks stay exact); it is
# given to the kernels whose speed targets need it — the lane steps' drivers (rnea, crba, aba, the frame calls) and
# aba.cholesky_states (1.02x -> 0.98x Pinocchio's loop on chain32; the scalar RNEA then went 0.55x -> 0.48x
# rneaInParallel(1)) — and costs their results a rounding change of the order of 1e-16 (measured: batched rnea's
# worst error against Pinocchio 3.8e-16 -> 4.2e-16 on ur5). Each kernel is compiled once, so one state and a batch
# round alike; the derivative kernels do without it (derivatives.py, its note).
FASTMATH = False
CONTRACT = {"contract"}


class entry:
    """A kernel's machine code for one fixed list of argument types, called without numba's dispatch.

    numba's dispatcher resolves the type of every argument on every call (~25–35 ns per array, measured);
    a one-state call whose inputs are already checked (``arguments.fast``: float64 ndarrays of the model's
    shapes) calls ``entry.call`` instead: the compiled function for ``types``, loaded from the disk cache
    (or compiled) on first use. It checks nothing — an argument of another dtype or number of dimensions
    would be read as the declared type — so its callers pass exactly these types. Arrays are declared with
    any strides (``A1``…): a strided or read-only q is read correctly (no kernel writes its inputs). Under
    MANIPDYN_NOJIT ``call`` is the Python function."""
    __slots__ = ("kernel", "types", "call")

    def __init__(self, kernel, *types):
        self.kernel, self.types = kernel, types
        self.call = kernel if NOJIT else self._first

    def _first(self, *args):
        self.call = self.kernel.compile(self.types)
        return self.call(*args)


# The kernels' argument types. Every kernel is compiled for one list of types (its ``entry`` and every
# compiled caller pass exactly these), so that no kernel is compiled twice: the model's two arrays as
# Model.kernel holds them (C order), and every other array — inputs, results, scratch — of layout
# "A" (any strides): one state (a row view of it), a batch, a strided or read-only array and a kernel's own
# scratch all reach the same machine code. A compiled caller turns an array of its own into this layout with
# a full slice (``x[::1]``, ``x[:, :]``, ``x[:, :, :]``: a view, no copy).
MODEL = (numba.types.Array(numba.int64, 2, "C"),
         numba.types.Array(numba.float64, 3, "C"))   # Model.kernel's (I, F): read-only arrays, which no kernel
#                                                      writes; declared writable so that their empty views can
#                                                      stand for "no rows" (kernel_inputs.no_wrenches) without allocating
A1, A2, A3 = (numba.types.Array(numba.float64, n, "A") for n in (1, 2, 3))   # float64 arrays, any strides
I1 = numba.types.Array(numba.int64, 1, "A")                                   # int64 indices, any strides
C2, C3 = (numba.types.Array(numba.float64, n, "C") for n in (2, 3))   # results a call allocates itself, in C
#                                                                     order where BLAS writes into them
FLAG = numba.types.boolean


def njit(*args, cache=False, **options):
    """numba.njit with fastmath=FASTMATH and nogil (a kernel releases Python's lock while it runs, so that the
    chunks of a batch run on several threads at once: dynamics/route.py); with cache=True the disk cache is the
    keyed folder above. Under MANIPDYN_NOJIT=1 the function is returned as it is."""
    options.setdefault("fastmath", FASTMATH)
    options.setdefault("nogil", True)

    def decorate(func):
        if NOJIT:
            return func
        if not (cache and _CACHE is not None):
            return numba.njit(*sigs, **options)(func)
        with _numba_cache_dir(_CACHE):
            return numba.njit(*sigs, cache=True, **options)(func)
    if args and callable(args[0]):
        sigs = ()
        return decorate(args[0])
    sigs = args
    return decorate
