"""The Newton–Euler kernel (dynamics/rnea.py, the one source of rnea and rnea_terms) against independent
references: Pinocchio (pin.rnea with fext per joint, its per-joint velocities, forces, placements and
forwardKinematics accelerations) on fixed-base and free-flyer models — revolute, continuous, prismatic and
free-flyer joints, branching trees, external wrenches in local and world axes, one state and batches — and
the same source run uncompiled (MANIPDYN_NOJIT=1, in a subprocess), which must give the compiled numbers.

The free-flyer models are Pinocchio's buildModelFromUrdf/XML(..., JointModelFreeFlyer()) against ours of the
same file with a free-flyer root (conftest.free_flyer_model): solo12 of example-robot-data, and a random tree
with prismatic and continuous joints.
"""
import functools
import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, ROOT, err, free_flyer_model, inertial_xml, urdf

import manipdyn as md
from manipdyn.joints import FREEFLYER, PRISMATIC
from manipdyn.validation.compare import random_wrenches
from manipdyn.validation.zoo import robots_dir


def _tree_text(seed, n):
    """URDF text of a random tree: n joints (revolute, continuous, prismatic, fixed), random parents,
    unaligned axes, placements, inertias with rotated principal axes."""
    rng = np.random.default_rng(seed)
    links, joints = {"base": ""}, []
    kinds = ("revolute", "continuous", "prismatic", "fixed")
    for k in range(n):
        parent = "base" if k == 0 or rng.random() < 0.2 else f"L{rng.integers(0, k)}"
        d, m = rng.uniform(0.05, 1.0, 3), rng.uniform(0.1, 3.0)
        inertia = np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]]) * m / 10
        links[f"L{k}"] = inertial_xml(m, rng.uniform(-0.3, 0.3, 3), (*inertia, 0, 0, 0), rng.uniform(-np.pi, np.pi, 3))
        axis = rng.normal(size=3)
        joints.append((f"j{k:02d}", kinds[rng.integers(4)] if k else "revolute", parent, f"L{k}",
                       rng.uniform(-0.5, 0.5, 3), rng.uniform(-np.pi, np.pi, 3), axis / np.linalg.norm(axis)))
    return urdf(links, joints, name=f"tree{seed}")


SOLO12 = "solo_description/robots/solo12.urdf"
MODELS = {   # name -> (URDF text source, free-flyer root)
    "aau_arm": (lambda: AAU.read_text(), False),
    "spm": (lambda: (ROOT / "urdf" / "spm.urdf").read_text(), False),    # its tree (closures unused here)
    "tree5": (lambda: _tree_text(5, 12), False),
    "tree6": (lambda: _tree_text(6, 20), False),
    "solo12_ff": (lambda: (robots_dir() / SOLO12).read_text(), True),
    "tree7_ff": (lambda: _tree_text(7, 10), True),
}


@functools.lru_cache(maxsize=None)
def _load(name):
    """(our model, Pinocchio's model of the same text)."""
    text, floating = MODELS[name][0](), MODELS[name][1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = free_flyer_model(text) if floating else md.load_urdf_string(text)
        pm = pin.buildModelFromXML(text, pin.JointModelFreeFlyer()) if floating else pin.buildModelFromXML(text)
    assert tuple(pm.names[1:]) == model.joint_names
    pm.gravity.linear = np.asarray(model.gravity, float)
    return model, pm


def _states(model, n, rng):
    """n random states (q (n, nq), v, a (n, nv)), docs/design.md §3; a free flyer's position ~ N(0, 1), its
    orientation a random unit quaternion."""
    Q = np.empty((n, model.nq))
    for i in range(model.njoints):
        k, iq = model.kind[i], model.idx_q[i]
        if k == FREEFLYER:
            quat = rng.normal(size=(n, 4))
            Q[:, iq:iq + 7] = np.hstack([rng.normal(size=(n, 3)), quat / np.linalg.norm(quat, axis=1, keepdims=True)])
        else:
            Q[:, iq] = rng.uniform(-0.5, 0.5, n) if k == PRISMATIC else rng.uniform(-np.pi, np.pi, n)
    return Q, rng.normal(0.0, 2.0, (n, model.nv)), rng.normal(0.0, 5.0, (n, model.nv))


def _pin_q(model, pm, q):
    """Our q -> Pinocchio's: continuous joints as (cos, sin); free flyer and others as they are."""
    pq = np.empty(pm.nq)
    for i in range(model.njoints):
        jm, iq = pm.joints[i + 1], model.idx_q[i]
        pq[jm.idx_q:jm.idx_q + jm.nq] = (np.cos(q[iq]), np.sin(q[iq])) if jm.nq == 2 and not model.kind[i] \
            else q[iq:iq + model.nqs[i]]
    return pq


def pin_terms(model, pm, q, v, a, f_ext=None, frame="local"):
    """Pinocchio's τ and per-link terms (our names, rnea_terms' meaning) for one state."""
    pd, pq = pm.createData(), _pin_q(model, pm, q)
    pin.framesForwardKinematics(pm, pd, pq)
    fext = [pin.Force.Zero() for _ in range(pm.njoints)]
    for name, (f, m) in (f_ext or {}).items():          # the frame's axes (or the world's), about its origin
        fid = pm.getFrameId(name, pin.FrameType.BODY)
        if frame == "world":
            R = pd.oMf[fid].rotation
            f, m = R.T @ f, R.T @ m
        fext[pm.frames[fid].parentJoint] += pm.frames[fid].placement.act(pin.Force(f, m))
    tau = pin.rnea(pm, pd, pq, v, a, fext).copy()
    J = range(1, pm.njoints)
    inertial = [pm.inertias[i] * pd.a_gf[i] + pd.v[i].cross(pm.inertias[i] * pd.v[i]) for i in J]
    out = dict(w=[pd.v[i].angular for i in J], v=[pd.v[i].linear for i in J],
               dv=[pd.a_gf[i].linear + np.cross(pd.v[i].angular, pd.v[i].linear) for i in J],
               fc=[x.linear for x in inertial], nO=[x.angular for x in inertial],
               f=[pd.f[i].linear for i in J], n=[pd.f[i].angular for i in J],
               R=[pd.oMi[i].rotation for i in J])
    pin.forwardKinematics(pm, pd, pq, v, a)                 # gravity-free accelerations
    out["dw"] = [pd.a[i].angular for i in J]
    out["acc"] = [pd.a[i].linear + np.cross(pd.v[i].angular, pd.v[i].linear) for i in J]
    out = {k: np.array(x, float) for k, x in out.items()}
    out["tau"] = tau
    return out


def _ours(model, terms):
    """Our terms in Pinocchio's set: the inertial moment about the origin nO = n_C + p_C × f_C."""
    out = {k: terms[k] for k in ("w", "v", "dv", "fc", "f", "n", "R", "dw", "acc", "tau")}
    out["nO"] = terms["nc"] + np.cross(model.com, terms["fc"])
    return out


def _wrenches(model, rng, N):
    """Random wrenches on up to 3 frames of moving bodies, batched (N, 3), plus one on the fixed base of a
    fixed-base model (it must change nothing)."""
    out = {k: (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3))) for k in random_wrenches(model, rng)}
    if not model.floating:
        out[model.root_link] = (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3)))
    return out


# §3 error measure, worst over every term, state and case, as measured on correct code, × 30 rounded up
TOL = {                            # measured
    "aau_arm": 3e-14,              # 8.1e-16
    "spm": 6e-14,                  # 1.8e-15
    "tree5": 6e-14,                # 1.8e-15
    "tree6": 9e-14,                # 2.9e-15
    "solo12_ff": 3e-14,            # 9.4e-16
    "tree7_ff": 5e-14,             # 1.4e-15
}


@pytest.mark.parametrize("name", list(MODELS))
def test_rnea_and_terms_match_pinocchio(name):
    model, pm = _load(name)
    rng = np.random.default_rng(17)
    N = 7
    Q, V, A = _states(model, N, rng)
    fx = _wrenches(model, rng, N)
    worst = {}
    tau_batch, tau_terms = md.rnea(model, Q, V, A), md.rnea_terms(model, Q, V, A)
    ext = {fr: (md.rnea(model, Q, V, A, f_ext=fx, f_ext_frame=fr),
                md.rnea_terms(model, Q, V, A, f_ext=fx, f_ext_frame=fr)) for fr in ("local", "world")}
    for s in range(N):
        ref = pin_terms(model, pm, Q[s], V[s], A[s])
        cases = {"rnea one": (md.rnea(model, Q[s], V[s], A[s]), ref["tau"]),
                 "rnea batch": (tau_batch[s], ref["tau"])}
        for k, y in ref.items():
            cases["terms " + k] = (_ours(model, {x: tau_terms[x][s] for x in tau_terms})[k], y)
        for fr, (tau, terms) in ext.items():
            one = {k: (f[s], m[s]) for k, (f, m) in fx.items()}
            ref = pin_terms(model, pm, Q[s], V[s], A[s], one, fr)
            cases[f"rnea f_ext {fr} one"] = (md.rnea(model, Q[s], V[s], A[s], f_ext=one, f_ext_frame=fr), ref["tau"])
            cases[f"rnea f_ext {fr} batch"] = (tau[s], ref["tau"])
            ours = _ours(model, {x: terms[x][s] for x in terms})
            for k in ("f", "n", "tau"):
                cases[f"terms f_ext {fr} {k}"] = (ours[k], ref[k])
        for k, (x, y) in cases.items():
            worst[k] = max(worst.get(k, 0.0), err(x, y))
    bad = {k: f"{e:.2e}" for k, e in worst.items() if not e <= TOL[name]}
    assert not bad, f"{name}: err > {TOL[name]:.0e}: {bad}"


def test_free_flyer_terms_have_one_row_per_body_and_tau_in_v_order():
    model, pm = _load("solo12_ff")
    Q, V, A = _states(model, 3, np.random.default_rng(2))
    terms = md.rnea_terms(model, Q[0], V[0], A[0])
    assert terms["w"].shape == (model.njoints, 3) and terms["R"].shape == (model.njoints, 3, 3)
    assert terms["tau"].shape == (model.nv,)
    # the root's six entries are the wrench [f'; n'] it needs, in its frame about its origin (S = 1₆)
    assert np.array_equal(terms["tau"][:6], np.concatenate([terms["f"][0], terms["n"][0]]))
    assert md.rnea_terms(model, Q, V, A)["f"].shape == (3, model.njoints, 3)


# ---- the same source, uncompiled ----------------------------------------------------------------------------

NOJIT_MODELS = ("aau_arm", "tree5", "solo12_ff")
PROBE = """
import json, sys, numpy as np
sys.path[:0] = [{tests!r}, {tests!r} + "/crosscheck"]
import manipdyn as md
from manipdyn import _jit
from manipdyn.dynamics import rnea as R
assert _jit.NOJIT and not hasattr(R.terms_kernel, "py_func"), "the kernel is compiled"
import test_rnea_kernel as T
out = {{}}
for name in {names!r}:
    model, _ = T._load(name)
    out[name] = T.nojit_case(model)
print(json.dumps(out))
"""


def nojit_case(model):
    """τ (one state and a batch of 3) and every per-link term with wrenches in local and world axes."""
    rng = np.random.default_rng(23)
    Q, V, A = _states(model, 3, rng)
    fx = _wrenches(model, rng, 3)
    out = {"one": md.rnea(model, Q[0], V[0], A[0]).tolist(), "batch": md.rnea(model, Q, V, A).tolist()}
    for fr in ("local", "world"):
        for k, x in md.rnea_terms(model, Q, V, A, f_ext=fx, f_ext_frame=fr).items():
            out[f"{fr} {k}"] = x.tolist()
    return out


def test_uncompiled_source_gives_the_compiled_numbers():
    env = {k: x for k, x in os.environ.items() if not k.startswith(("NUMBA_", "MANIPDYN_"))}
    env.update(MANIPDYN_NOJIT="1", PYTHONPATH=str(ROOT))
    probe = PROBE.format(tests=str(ROOT / "tests"), names=NOJIT_MODELS)
    run = subprocess.run([sys.executable, "-c", probe], env=env, cwd=ROOT, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    plain = json.loads(run.stdout.splitlines()[-1])
    for name in NOJIT_MODELS:
        compiled = nojit_case(_load(name)[0])
        assert plain[name].keys() == compiled.keys()
        for k in compiled:      # measured 0 (bit-identical) on every entry; 1e-14 allows operation reordering
            assert err(np.array(plain[name][k]), np.array(compiled[k])) <= 1e-14, f"{name} {k}"
