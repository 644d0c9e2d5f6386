"""rnea_derivatives and aba_derivatives (dynamics/derivatives.py, one compiled source) against independent
references:

- Pinocchio's computeRNEADerivatives / computeABADerivatives on the bundled models (the AAU arm, the SPM and
  the four-bar as trees), every zoo arm, floating robots (free-flyer root: q-derivatives in the tangent
  space, q ⊕ δ) and random trees — one state and batches; with f_ext in the frames' axes (Pinocchio's fext,
  constant in the joint frame);
- central finite differences of our own rnea and aba (q moved by integrate on a free flyer), which also
  hold f_ext in world axes, a wrench Pinocchio cannot express (its direction stays fixed while its point
  moves with the body);
- identities with our other algorithms: ∂τ/∂q̈ = M (crba), ∂q̈/∂τ = M⁻¹ (numpy's inverse of crba's M),
  ∂q̈/∂q = −M⁻¹ ∂τ/∂q at q̈ = aba(q, q̇, τ);
- batches against stacked single states; the same source run uncompiled (MANIPDYN_NOJIT=1); bad input.

Error measure of docs/design.md §3 (``err``); q̈ derivatives (from a solve) scaled by cond(M). Each tolerance is
within 100× of the worst error measured on correct code over its cases (written beside it).
"""
import functools
import os
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, ROOT, err, zoo_paths
from nojit import assert_uncompiled_equals_compiled
from test_aba import _random_tree_text

import manipdyn as md
from manipdyn.validation import random_states, robots_dir
from manipdyn.validation.reference import Reference

FLOATING = {"solo12": "solo_description/robots/solo12.urdf",
            "anymal": "anymal_b_simple_description/robots/anymal.urdf",
            "talos_reduced": "talos_data/robots/talos_reduced.urdf"}
BUNDLED = {"aau_arm": AAU, "spm": ROOT / "urdf" / "spm.urdf", "fourbar": ROOT / "urdf" / "fourbar.urdf"}
CASES = list(BUNDLED) + [p.stem for p in zoo_paths()] + list(FLOATING) + ["tree3", "tree4", "tree5"]


@functools.cache
def ref(name):
    """(our model, Reference) — Pinocchio's model of the same file, our q mapped to its q."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name.startswith("tree"):
            text = _random_tree_text(int(name[4:]))
            path = Path(os.environ.get("TMPDIR", "/tmp")) / f"manipdyn_deriv_{name}_{os.getpid()}.urdf"
            path.write_text(text)
            try:
                return md.load_urdf_string(text), Reference(md.load_urdf_string(text), path)
            finally:
                path.unlink()
        if name in FLOATING:
            path = robots_dir() / FLOATING[name]
            model = md.load_urdf(path, root_joint="free_flyer")
        else:
            path = BUNDLED.get(name) or next(p for p in zoo_paths() if p.stem == name)
            model = md.load_urdf(path)
        return model, Reference(model, path)


def pin_derivatives(r, Q, V, X, fd, fext=None):
    """Pinocchio's three derivative matrices (copied: the binding returns views of its data) per state."""
    fn = pin.computeABADerivatives if fd else pin.computeRNEADerivatives
    out = []
    for s in range(len(Q)):
        args = (r.pm, r.pd, r.to_pin_q(Q[s]), V[s], X[s]) + (() if fext is None else (fext[s],))
        out.append([np.array(x) for x in fn(*args)])
    return [np.array(x) for x in zip(*out)]


# ---- against Pinocchio ------------------------------------------------------------------------------------

# Measured over every case of CASES (3 states each, seed 5), worst: ∂τ/∂q 2.8e-15 (panda), ∂τ/∂q̇ 4.4e-15
# (baxter), ∂τ/∂q̈ 1.9e-15 (tree4); q̈ derivatives / cond(M): 9.0e-16, 4.0e-15, 2.2e-16 (all finger_edu).
TOL_RNEA, TOL_ABA = 1e-13, 5e-14


@pytest.mark.parametrize("name", CASES)
def test_rnea_and_aba_derivatives_match_pinocchio(name):
    model, r = ref(name)
    Q, V, A = random_states(model, 3, np.random.default_rng(5))
    for fd, tol in ((False, TOL_RNEA), (True, TOL_ABA)):
        fn = md.aba_derivatives if fd else md.rnea_derivatives
        theirs = pin_derivatives(r, Q, V, A, fd)
        batch, one = fn(model, Q, V, A), fn(model, Q[0], V[0], A[0])
        cond = np.linalg.cond(theirs[2]) if not fd else np.linalg.cond(np.linalg.inv(theirs[2]))
        for k, (x, y) in enumerate(zip(batch, theirs)):
            assert x.shape == (3, model.nv, model.nv) and one[k].shape == (model.nv, model.nv)
            for s in range(3):
                scale = cond[s] if fd else 1.0
                assert err(x[s], y[s]) <= tol * scale, f"{fn.__name__}[{k}] state {s}: {err(x[s], y[s]):.2e}"
            assert err(one[k], x[0]) == 0.0                # the one-state entry: the same kernel, N = 1


def _wrenches(model, N, rng):
    """f_ext on the last body, on a frame with an offset in its body (a merged link) when the model has one,
    and per-state (N, 3) on the first body."""
    merged = [f.name for f in model.frames.values() if f.body >= 0 and np.any(f.p)]
    names = [model.body_names[-1]] + merged[:1]
    out = {n: (rng.normal(size=3), rng.normal(size=3)) for n in names}
    out[model.body_names[0]] = (rng.normal(size=(N, 3)), rng.normal(size=(N, 3)))
    return out


def _row(fx, s):
    return {k: (np.broadcast_to(f, (3, 3))[s], np.broadcast_to(m, (3, 3))[s]) for k, (f, m) in fx.items()}


# measured (worst of the four): ∂τ 2.7e-15 (baxter), q̈ derivatives / cond 1.3e-16 (baxter)
@pytest.mark.parametrize("name", ["ur5_robot", "baxter", "tree4", "solo12"])
def test_local_f_ext_matches_pinocchio_fext(name):
    model, r = ref(name)
    Q, V, A = random_states(model, 3, np.random.default_rng(6))
    fx = _wrenches(model, 3, np.random.default_rng(7))
    fext = [r.fext(Q[s], _row(fx, s)) for s in range(3)]
    for fd, tol in ((False, TOL_RNEA), (True, TOL_ABA)):
        fn = md.aba_derivatives if fd else md.rnea_derivatives
        theirs = pin_derivatives(r, Q, V, A, fd, fext)
        ours = fn(model, Q, V, A, f_ext=fx)
        for k in range(3):
            for s in range(3):
                scale = np.linalg.cond(theirs[2][s]) if fd else 1.0
                assert err(ours[k][s], theirs[k][s]) <= tol * scale, f"{fn.__name__}[{k}] state {s}"
        one = fn(model, Q[1], V[1], A[1], f_ext=_row(fx, 1))
        assert all(err(one[k], ours[k][1]) == 0.0 for k in range(3))


# ---- against central finite differences of our own rnea and aba -------------------------------------------

def central(model, fn, q, v, x, h, f_ext=None, frame="local"):
    """Central differences of fn(q, v, x) in q (q ⊕ ±h e_j, integrate), v and x, step h: three (nv, nv)."""
    kw = {"f_ext": f_ext, "f_ext_frame": frame}
    E = np.eye(model.nv) * h
    dq = [(fn(model, md.integrate(model, q, e), v, x, **kw) - fn(model, md.integrate(model, q, -e), v, x, **kw))
          for e in E]
    dv = [fn(model, q, v + e, x, **kw) - fn(model, q, v - e, x, **kw) for e in E]
    dx = [fn(model, q, v, x + e, **kw) - fn(model, q, v, x - e, **kw) for e in E]
    return [np.array(d).T / (2 * h) for d in (dq, dv, dx)]


H = 1e-5       # step: the best of 1e-4, 1e-5, 1e-6 (worst ∂τ errors 3.7e-9, 5.2e-10, 4.1e-9)

# (model, f_ext frame): tolerances of (rnea, aba / cond(M)) derivatives against central differences with
# step H, 2 states each, ≈ 30× the worst error measured:                    measured: rnea   aba / cond
FD_CASES = {("aau_arm", None): (8e-9, 2e-10),                             # 2.6e-10   5.9e-12
            ("tree4", "local"): (1e-8, 3e-11),                            # 3.3e-10   7.8e-13
            ("tree4", "world"): (1e-8, 3e-11),                            # 3.2e-10   7.4e-13
            ("solo12", "local"): (5e-9, 1e-10),                           # 1.6e-10   3.2e-12
            ("solo12", "world"): (4e-9, 8e-11),                           # 1.3e-10   2.4e-12
            ("baxter", "world"): (2e-8, 1e-10)}                           # 5.2e-10   3.4e-12


@pytest.mark.parametrize("name,frame", list(FD_CASES), ids=lambda x: str(x))
def test_derivatives_match_central_differences(name, frame):
    model, _ = ref(name)
    Q, V, A = random_states(model, 2, np.random.default_rng(8))
    tol_id, tol_fd = FD_CASES[(name, frame)]
    for s in range(2):
        fx = None if frame is None else _row(_wrenches(model, 3, np.random.default_rng(9)), s)
        kw = {"f_ext": fx, "f_ext_frame": frame or "local"}
        ours = md.rnea_derivatives(model, Q[s], V[s], A[s], **kw)
        fd = central(model, md.rnea, Q[s], V[s], A[s], H, fx, frame or "local")
        for k in range(3):
            assert err(ours[k], fd[k]) <= tol_id, f"∂τ[{k}] state {s}: {err(ours[k], fd[k]):.2e}"
        tau = A[s]                                                  # a τ ~ N(0, 5²) as random_states draws
        ours = md.aba_derivatives(model, Q[s], V[s], tau, **kw)
        fd = central(model, md.aba, Q[s], V[s], tau, H, fx, frame or "local")
        cond = np.linalg.cond(md.mass_matrix(model, Q[s]))
        for k in range(3):
            assert err(ours[k], fd[k]) <= tol_fd * cond, f"∂q̈[{k}] state {s}: {err(ours[k], fd[k]) / cond:.2e}"


def test_world_f_ext_derivative_differs_from_the_local_one():
    # the two frames give the same τ at this q but not the same ∂τ/∂q: a world-fixed force does not turn
    # with the body. (Guards the world term against being dropped: the FD test above would catch it too.)
    model, _ = ref("tree4")
    q, v, a = (x[0] for x in random_states(model, 1, np.random.default_rng(10)))
    f, n = np.array([3.0, -1.0, 2.0]), np.array([0.5, 0.2, -0.4])
    body = model.body_names[-1]
    R = md.frame_placement(model, q, body)[0]
    world = md.rnea_derivatives(model, q, v, a, f_ext={body: (f, n)}, f_ext_frame="world")
    local = md.rnea_derivatives(model, q, v, a, f_ext={body: (R.T @ f, R.T @ n)})
    assert err(md.rnea(model, q, v, a, f_ext={body: (f, n)}, f_ext_frame="world"),
               md.rnea(model, q, v, a, f_ext={body: (R.T @ f, R.T @ n)})) <= 1e-14      # measured 0
    assert err(world[1], local[1]) <= 1e-14 and err(world[2], local[2]) == 0.0          # measured 0
    assert err(world[0], local[0]) > 1e-3                                               # measured 6.2e-3


# ---- identities with our other algorithms ------------------------------------------------------------------

# measured (worst of the five, 4 states): ∂τ/∂q̈ vs crba 1.3e-15; M⁻¹ / cond 5.7e-17; ∂q̈/∂q, ∂q̈/∂q̇ / cond 6.7e-17,
# 7.2e-17
@pytest.mark.parametrize("name", ["aau_arm", "spm", "baxter", "tree5", "talos_reduced"])
def test_identities_with_crba_and_aba(name):
    model, _ = ref(name)
    Q, V, T = random_states(model, 4, np.random.default_rng(11))
    M = md.mass_matrix(model, Q)
    qdd = md.aba(model, Q, V, T)
    dq, dv, da = md.rnea_derivatives(model, Q, V, qdd)
    fq, fv, Minv = md.aba_derivatives(model, Q, V, T)
    for s in range(4):
        cond = np.linalg.cond(M[s])
        assert err(da[s], M[s]) <= 1e-13
        assert err(Minv[s], np.linalg.inv(M[s])) <= 5e-15 * cond
        assert err(fq[s], -np.linalg.solve(M[s], dq[s])) <= 5e-15 * cond
        assert err(fv[s], -np.linalg.solve(M[s], dv[s])) <= 5e-15 * cond


def test_batch_equals_stacked_single_states():
    model, _ = ref("solo12")
    Q, V, A = random_states(model, 5, np.random.default_rng(12))
    fx = _wrenches(model, 5, np.random.default_rng(13))
    for fn in (md.rnea_derivatives, md.aba_derivatives):
        for frame in ("local", "world"):
            batch = fn(model, Q, V, A, f_ext=fx, f_ext_frame=frame)
            for s in range(5):
                row = {k: (np.broadcast_to(f, (5, 3))[s], np.broadcast_to(m, (5, 3))[s]) for k, (f, m) in fx.items()}
                one = fn(model, Q[s], V[s], A[s], f_ext=row, f_ext_frame=frame)
                assert all(err(one[k], batch[k][s]) <= 1e-14 for k in range(3))    # measured 0
        lists = fn(model, Q.tolist(), V.tolist(), A.tolist())                      # the checked path
        assert all(err(x, y) == 0.0 for x, y in zip(lists, fn(model, Q, V, A)))


# ---- the same source, uncompiled ---------------------------------------------------------------------------

NOJIT_CASES = ["double_pendulum", "tree4", "solo12"]
PROBE = """
import json, sys
import numpy as np
sys.path[:0] = [{tests!r}, {here!r}]
import manipdyn as md
from manipdyn import _jit
from manipdyn.validation import random_states
import test_derivatives as T
out = {{"nojit": _jit.NOJIT}}
for name in {names!r}:
    model, _ = T.ref(name)
    Q, V, A = random_states(model, 2, np.random.default_rng(14))
    fx = T._wrenches(model, 2, np.random.default_rng(15))
    out[name] = [np.asarray(x).tolist() for x in
                 md.rnea_derivatives(model, Q, V, A, f_ext=fx, f_ext_frame="world")
                 + md.aba_derivatives(model, Q[0], V[0], A[0]) + md.aba_derivatives(model, Q, V, A, f_ext=fx)]
print(json.dumps(out))
"""



def test_uncompiled_source_gives_the_compiled_numbers():
    # The RNEA derivatives: measured 0 (bit-identical). The ABA derivatives differentiate at the q̈ of the ABA's lane
    # steps, which fuse multiply-adds when compiled (_jit.CONTRACT) and not uncompiled; ∂q̈ = −M⁻¹ ∂τ magnifies that
    # rounding by cond(M): measured ≤ 2.2e-16 on the double pendulum and tree4, 2.5e-14 (∂q̈/∂q) on solo12.
    assert_uncompiled_equals_compiled(PROBE, __file__, NOJIT_CASES, tol=[1e-15] * 3 + [1e-13] * 6)
