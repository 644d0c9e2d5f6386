"""Flop counts of the lane kernels, counted by running them, and the arithmetic floor they set.

The lane kernels (docs/design.md §4c) run here as the plain Python they are written as (MANIPDYN_NOJIT=1, in a
subprocess), on one block of LANES states whose numbers are ``Flop`` floats: every +, −, × and ÷ with a Flop
operand counts one floating-point operation (a fused multiply-add is two, as written). What runs once per block
on the model's own numbers (a joint's rotation axis crossed with its frame, a body's rigid inertia) is not
counted: it is not per-state work. The count per state is the total over the block ÷ LANES, including the
finiteness checks of the gather and scatter (one subtraction per number moved).

The floor: flops ÷ (16 per cycle × the clock) — a core with two 256-bit fused multiply-add units (AVX2 + FMA)
does at most 16 double-precision flops a cycle, when every one is a fused multiply-add. No kernel reaches it
(loads, stores and sincos's branch-free selects cost cycles and no flops); the report prints how far each is.

    python -m manipdyn.bench.flops LABEL=URDF LABEL=chain:32 ...   # JSON {label: {rnea, aba, mass_matrix: flops}}
    counts({label: path or "chain:N"}) -> that dict (runs the line above)
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import numpy as np

PEAK_PER_CYCLE = 16          # double-precision flops a cycle: 2 FMA units × 4 lanes × 2 flops (AVX2 + FMA)
_COUNT = [0]


class Flop(float):
    """A float that counts the arithmetic done with it (``_COUNT``); results are Flops again."""

    def _op(self, y):
        _COUNT[0] += 1
        return Flop(y)

    def __add__(self, o): return self._op(float(self) + float(o))         # noqa: E704
    def __radd__(self, o): return self._op(float(o) + float(self))        # noqa: E704
    def __sub__(self, o): return self._op(float(self) - float(o))         # noqa: E704
    def __rsub__(self, o): return self._op(float(o) - float(self))        # noqa: E704
    def __mul__(self, o): return self._op(float(self) * float(o))         # noqa: E704
    def __rmul__(self, o): return self._op(float(o) * float(self))        # noqa: E704
    def __truediv__(self, o): return self._op(float(self) / float(o))     # noqa: E704
    def __rtruediv__(self, o): return self._op(float(o) / float(self))    # noqa: E704
    def __neg__(self): return Flop(-float(self))                          # noqa: E704  (a sign: no flop)
    def __abs__(self): return Flop(abs(float(self)))                      # noqa: E704


class _Numpy:
    """numpy, but float arrays made by ``empty``/``zeros`` hold Flops (object arrays), so that what the kernels
    store in their scratch keeps counting."""

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def _flops(shape, dtype, fill):
        if dtype is not None and np.dtype(dtype) != np.float64:
            return np.full(shape, fill, dtype)
        out = np.empty(shape, object)
        out.fill(Flop(fill))
        return out

    def empty(self, shape, dtype=None):
        return self._flops(shape, dtype, 0.0)

    def zeros(self, shape, dtype=None):
        return self._flops(shape, dtype, 0.0)


def _objects(x, flop=False):
    """x as an object array of Python floats (the model: its arithmetic with a Flop counts) or of Flops."""
    out = np.empty(x.shape, object)
    out.ravel()[:] = [Flop(v) if flop else float(v) for v in np.asarray(x, float).ravel()]
    return out


def _count(model):
    """{rnea, aba, mass_matrix: flops per state} of the lane kernels on one block of the model's states."""
    from .. import _jit, spatial
    from ..dynamics import aba, crba, kernel_inputs, lanes, rnea
    from ..validation import random_states
    if not _jit.NOJIT:
        raise RuntimeError("the flop count runs the kernels as Python: set MANIPDYN_NOJIT=1")
    L = lanes.LANES
    I, F = model.kernel.lane_arrays                 # the form the batch routes pass (z-aligned frames)
    F = _objects(F)
    Q, V, A = (_objects(x, flop=True) for x in random_states(model, L, np.random.default_rng(0)))
    X, xb, xp = F[:1, :0, :], I[0, :0], F[0, :0, :]
    mods = (aba, crba, kernel_inputs, lanes, rnea, spatial)
    saved = [m.np for m in mods]
    for m in mods:
        m.np = _Numpy()
    out = {}
    try:
        for name, run in (("rnea", lambda: rnea.rnea_lanes(I, F, Q, V, A, X, xb, xp, False, _objects(A))),
                          ("aba", lambda: aba.aba_lanes(I, F, Q, V, A, X, xb, xp, False, _objects(A))),
                          ("mass_matrix", lambda: crba.crba_lanes(I, F, Q, _objects(np.zeros((L, model.nv,
                                                                                               model.nv)))))):
            _COUNT[0] = 0
            code = run()
            if code != -1:
                raise RuntimeError(f"flop count: {name} returned code {code}")
            out[name] = _COUNT[0] / L
    finally:
        for m, n in zip(mods, saved):
            m.np = n
    return out


def counts(robots) -> dict:
    """{label: {call: flops per state}} for {label: URDF path, or "chain:N" for the bench's random chain},
    counted in a subprocess that runs the kernels uncompiled."""
    env = dict(os.environ, MANIPDYN_NOJIT="1")
    args = [f"{label}={path}" for label, path in robots.items()]
    res = subprocess.run([sys.executable, "-m", "manipdyn.bench.flops", *args], env=env,
                         capture_output=True, text=True, timeout=600)
    if res.returncode != 0:
        raise RuntimeError(f"flop count failed: {res.stderr.strip()[-2000:]}")
    return json.loads(res.stdout)


def clock_ghz() -> float | None:
    """The core's clock in GHz as /proc/cpuinfo reports it (None where it does not)."""
    try:
        with open("/proc/cpuinfo") as fh:
            mhz = [float(line.split(":", 1)[1]) for line in fh if line.startswith("cpu MHz")]
    except (OSError, ValueError):
        return None
    return max(mhz) / 1000 if mhz else None


def main(argv=None) -> int:
    import warnings

    from ..io.urdf import load_urdf, load_urdf_string
    from .timing import random_chain_urdf
    out = {}
    for arg in argv if argv is not None else sys.argv[1:]:
        label, _, path = arg.partition("=")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = load_urdf_string(random_chain_urdf(int(path[6:]))) if path.startswith("chain:") else \
                load_urdf(path)
        out[label] = _count(model)
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
