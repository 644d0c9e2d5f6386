"""Compile every kernel ahead of use, and measure the cold start.

The kernels are numba functions cached on disk (``_jit``): the first call of each one in a fresh install
compiles it (minutes in all: the README gives the measured figure), every later process loads the machine code from the cache. ``warmup``
makes that first call for every public function — one state and a batch, with and without external
wrenches, an open and a closed chain — so that a user's first call only loads. ``manipdyn warmup`` runs it
(the README's setup command does), spread over the cores: each worker compiles its own kernels, so no two
processes write one kernel's cache index.

    first_calls(group=None)  every public call once (or only those of one group), on the bundled models
    warmup(jobs=2)           first_calls over ``jobs`` worker processes; seconds taken
    cold_start()             {warmup_s, import_s, first_calls_s, total_s, ...} from fresh processes (bench)
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import warnings

import numpy as np

# Each group compiles its own kernels, in about equal time on this machine: a kernel that both workers need
# would be compiled twice (and, with different signatures, only one worker's entry would survive in its cache
# index). The kernels several calls share stay within one group: rnea_steps_one and crba_steps_one (rnea, the bias
# forces, the Cholesky route, the closed chain) in the first, aba_steps_one (aba, the derivatives) in the second.
GROUPS = (("rnea", "bias", "crba", "fd", "fext", "closed", "regressor", "coriolis", "energy"),
          ("aba", "aba_fext", "derivatives", "frames", "lagrange", "config"))


def _models(closed=True):
    """The AAU arm and (if ``closed``) the four-bar linkage, a closed chain; else None in its place."""
    from .io.urdf import load_urdf
    from .paths import bundled_dir
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return (load_urdf(bundled_dir() / "aau_arm.urdf"),
                load_urdf(bundled_dir() / "fourbar.urdf") if closed else None)


def _calls(arm, closed):
    """{group: [(name, thunk)]}: every public call that reaches a kernel, one state and a batch of 3."""
    import manipdyn as md
    from .constraints import assemble
    rng = np.random.default_rng(0)
    Q, V, A = rng.uniform(-1, 1, (3, arm.nq)), rng.normal(0, 1, (3, arm.nv)), rng.normal(0, 1, (3, arm.nv))
    q, v, a = Q[0].copy(), V[0].copy(), A[0].copy()
    tip = arm.body_names[-1]
    fx = {tip: (np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.1, 0.0]))}
    FX = {tip: (np.ones((3, 3)), np.zeros((3, 3)))}

    def both(name, f, **kw):                      # one state and a batch of the call f(arm, q, v, a, **kw)
        return [(name, lambda: f(arm, q, v, a, **kw)), (name + " batch", lambda: f(arm, Q, V, A, **kw))]

    def with_wrenches(f):                         # f(arm, q, v, a, f_ext=...) in both frames, one state and a batch
        return [(f"{f.__name__} f_ext {frame}{n}", lambda w=w, frame=frame, x=x: f(arm, *x, f_ext=w, f_ext_frame=frame))
                for frame in ("local", "world") for n, w, x in (("", fx, (q, v, a)), (" batch", FX, (Q, V, A)))]

    def closed_calls():
        qc = assemble(closed, md.neutral(closed)).q
        tau = np.zeros(closed.nv)
        return [("constrained_forward_dynamics", lambda: md.constrained_forward_dynamics(closed, qc, 0 * tau, tau)),
                ("constrained_forward_dynamics batch",
                 lambda: md.constrained_forward_dynamics(closed, qc[None], tau[None], tau[None]))]

    return dict(
        rnea=both("rnea", md.rnea) + [("rnea_terms", lambda: md.rnea_terms(arm, q, v, a))],
        aba=both("aba", md.aba),
        crba=[("mass_matrix", lambda: md.mass_matrix(arm, q)), ("mass_matrix batch", lambda: md.mass_matrix(arm, Q))],
        fd=both("forward_dynamics cholesky", md.forward_dynamics, method="cholesky"),
        fext=with_wrenches(md.rnea)
        + [("forward_dynamics cholesky f_ext", lambda: md.forward_dynamics(arm, q, v, a, f_ext=fx, method="cholesky"))],
        aba_fext=with_wrenches(md.aba),
        closed=closed_calls() if closed is not None else [],
        bias=[("gravity_torques", lambda: md.gravity_torques(arm, q)), ("gravity_torques batch",
                                                                        lambda: md.gravity_torques(arm, Q)),
              ("nonlinear_effects", lambda: md.nonlinear_effects(arm, q, v)),
              ("nonlinear_effects batch", lambda: md.nonlinear_effects(arm, Q, V))],
        derivatives=both("rnea_derivatives", md.rnea_derivatives) + both("aba_derivatives", md.aba_derivatives),
        regressor=both("joint_torque_regressor", md.joint_torque_regressor),
        coriolis=[("coriolis_matrix", lambda: md.coriolis_matrix(arm, q, v)),
                  ("coriolis_matrix batch", lambda: md.coriolis_matrix(arm, Q, V))],
        lagrange=[("mass_matrix lagrange", lambda: md.mass_matrix(arm, q, method="lagrange")),
                  ("mass_matrix lagrange batch", lambda: md.mass_matrix(arm, Q, method="lagrange"))],
        frames=[(f"{f.__name__} {ref}{n}", lambda f=f, x=x, ref=ref: f(arm, *x, tip, reference=ref))
                for f, one, many in ((md.frame_jacobian, (q,), (Q,)), (md.frame_jacobian_dot, (q, v), (Q, V)))
                for ref in ("local_world_aligned", "local") for n, x in (("", one), (" batch", many))]
        + [("frame_placement", lambda: md.frame_placement(arm, q, tip)),
           ("frame_placement batch", lambda: md.frame_placement(arm, Q, tip))],
        energy=[("kinetic_energy", lambda: md.kinetic_energy(arm, q, v)),
                ("kinetic_energy batch", lambda: md.kinetic_energy(arm, Q, V)),
                ("potential_energy", lambda: md.potential_energy(arm, q)),
                ("potential_energy batch", lambda: md.potential_energy(arm, Q))],
        config=[("integrate batch", lambda: md.integrate(arm, Q, V)), ("difference batch", lambda: md.difference(arm, Q, Q)),
                ("integrate", lambda: md.integrate(arm, q, v)), ("difference", lambda: md.difference(arm, q, q)),
                ("normalize", lambda: md.normalize(arm, q)), ("normalize batch", lambda: md.normalize(arm, Q))],
    )


def first_calls(group=None, progress=None):
    """Make every public call once (group None: all; else the groups of GROUPS[group]); {name: seconds}.
    ``progress(name, total)`` is told of each call made (total: how many there are)."""
    keys = [k for g in (GROUPS if group is None else (GROUPS[group],)) for k in g]
    arm, closed = _models("closed" in keys)
    calls = _calls(arm, closed)
    out, total = {}, sum(len(calls[k]) for k in keys)
    for k in keys:
        for name, f in calls[k]:
            t0 = time.perf_counter()
            f()
            out[name] = time.perf_counter() - t0
            if progress is not None:
                progress(name, total)
    return out


def _run_python(code, env=None, timeout=900, on_line=None):
    """Run ``python -c code`` in a fresh process; its last stdout line as JSON. ``on_line(total)`` is called for
    each line "call <total>" (a worker's progress) as it comes."""
    with tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=err, text=True,
                             env={**os.environ, **(env or {})})
        timer = threading.Timer(timeout, p.kill)    # (a kernel that never finishes compiling)
        timer.start()
        try:
            lines = []
            for line in p.stdout:
                if line.startswith("call "):
                    if on_line is not None:
                        on_line(int(line.split()[1]))
                elif line.strip():
                    lines.append(line)
            code = p.wait()
        finally:
            timer.cancel()
        if code != 0:
            err.seek(0)
            tail = (err.read().strip().splitlines() or [f"exit code {code}, no message"])[-1]
            tail = f"killed after {timeout} s" if timer.finished.is_set() and code < 0 else tail
            raise RuntimeError(f"a fresh Python process failed: {tail}")
    return json.loads(lines[-1])


_GROUP_CODE = ("import json, sys, time; t0 = time.perf_counter(); from manipdyn.warmup import first_calls; "
               "t1 = time.perf_counter(); c = first_calls({group}, {progress}); "
               "print(json.dumps(dict(import_s=t1 - t0, first_calls_s=sum(c.values()), calls=c)))")
_TICK = "lambda name, total: print('call', total, flush=True)"    # a worker's line per call (warmup's progress)


def warmup(jobs=2, env=None, progress=None):
    """Compile every kernel into the disk cache: ``first_calls`` of each group in its own process, ``jobs`` at a
    time; the workers' compile notices are silenced (compile_notice.py). ``progress(done, total, seconds)`` is
    told of each call a worker has made (total: 0 until every worker has said how many it makes). Returns the
    wall-clock seconds."""
    from concurrent.futures import ThreadPoolExecutor

    from ._jit import prune_stale
    t0 = time.perf_counter()
    if env is None:
        prune_stale()                               # the package's own cache: drop earlier sources' folders
    env = {**(env or {}), "MANIPDYN_COMPILE_NOTICE": "0"}
    done, totals, lock = [0], {}, threading.Lock()

    def ticker(g):                                  # worker g made a call (of its ``total``)
        def tick(total):
            with lock:
                done[0], totals[g] = done[0] + 1, total
                progress(done[0], sum(totals.values()) if len(totals) == len(GROUPS) else 0,
                         time.perf_counter() - t0)
        return tick if progress is not None else None
    with ThreadPoolExecutor(max(1, min(int(jobs), len(GROUPS)))) as pool:
        list(pool.map(lambda g: _run_python(_GROUP_CODE.format(group=g, progress=_TICK if progress else None), env,
                                            on_line=ticker(g)), range(len(GROUPS))))
    return time.perf_counter() - t0


def cold_start(compile_too=True):
    """The cold start as a user meets it, each figure from fresh processes:
      warmup_s                          ``manipdyn warmup`` (2 worker processes) into an empty disk cache: the
                                        compile a fresh install pays once (the README's setup command runs it);
      import_s, first_calls_s, total_s  then import manipdyn + the first call of every public function, in a
                                        new process, the kernels loaded from that cache — the target.
    compile_too=False measures only the second (against the package's own cache, warmed up or not)."""
    out = {}
    with tempfile.TemporaryDirectory(prefix="manipdyn-cold-") as tmp:
        env = dict(NUMBA_CACHE_DIR=tmp) if compile_too else None
        if compile_too:
            out["warmup_s"] = warmup(2, env)
        r = _run_python(_GROUP_CODE.format(group=None, progress=None), env)
    out.update(import_s=r["import_s"], first_calls_s=r["first_calls_s"], total_s=r["import_s"] + r["first_calls_s"],
               calls=len(r["calls"]), slowest_call=max(r["calls"], key=r["calls"].get))
    return out
