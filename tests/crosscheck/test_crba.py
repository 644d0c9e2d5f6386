"""The composite-rigid-body algorithm (dynamics/crba.py) against independent references:

- Pinocchio's crba (its upper triangle, filled symmetric) on the bundled models, every arm of the zoo and
  random trees with revolute, continuous and prismatic joints — one state (the single-state entry) and a
  batch (the batch kernel);
- free-flyer robots of example-robot-data against Pinocchio's model built with a JointModelFreeFlyer
  root (same q layout: [x y z qx qy qz qw] then the joints);
- the same source run uncompiled (MANIPDYN_NOJIT=1, in a subprocess) on small models, to 1e-14.

Tolerances: the §3 error measure (conftest.err), the measured error beside each (×30 or more, rounded up).
"""
import dataclasses
import functools
import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT, err, inertial_xml, urdf, zoo_paths

import manipdyn as md
from manipdyn.joints import FREEFLYER, PRISMATIC
from manipdyn.validation import random_states
from manipdyn.validation.reference import Reference
from manipdyn.validation.zoo import robots_dir


def random_tree_text(seed, n):
    """URDF of a random tree of n joints (revolute, continuous, prismatic, fixed; random parents, axes,
    placements, CoMs, inertias)."""
    rng = np.random.default_rng(seed)
    kinds = ("revolute", "continuous", "prismatic", "fixed")
    links, joints = {"base": ""}, []
    for k in range(n):
        parent = "base" if k == 0 or rng.random() < 0.2 else f"L{rng.integers(0, k)}"
        d, m = rng.uniform(0.05, 1.0, 3), rng.uniform(0.1, 3.0)
        I = np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]]) * m / 10        # a physical body's moments
        links[f"L{k}"] = inertial_xml(m, rng.uniform(-0.3, 0.3, 3), (*I, 0, 0, 0), rng.uniform(-np.pi, np.pi, 3))
        axis = rng.normal(size=3)
        joints.append((f"j{k:02d}", kinds[rng.integers(4)] if k else "revolute", parent, f"L{k}",
                       rng.uniform(-0.5, 0.5, 3), rng.uniform(-np.pi, np.pi, 3), axis / np.linalg.norm(axis)))
    return urdf(links, joints, name=f"random{seed}")


RANDOM_TREES = {"tree5": (5, 12), "tree6": (6, 20), "tree7": (7, 30)}


@functools.lru_cache(maxsize=None)
def fixed_base(name):
    """(our model, Pinocchio model, our q -> Pinocchio's q)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name in RANDOM_TREES:
            text = random_tree_text(*RANDOM_TREES[name])
            model = md.load_urdf_string(text)
            pm = pin.buildModelFromXML(text)
            return model, pm, lambda q: _pin_q(model, pm, q)
        path = ROOT / "urdf" / f"{name}.urdf"
        path = path if path.is_file() else next(p for p in zoo_paths() if p.stem == name)
        model = md.load_urdf(path)
    ref = Reference(model, path)
    return model, ref.pm, ref.to_pin_q


def _pin_q(model, pm, q):
    """Our q (nq,) -> Pinocchio's: a free flyer's 7 entries as they are, continuous joints as (cos, sin)."""
    assert model.joint_names == tuple(pm.names[1:])
    pq = np.zeros(pm.nq)
    for i in range(model.njoints):
        jm, a = pm.joints[i + 1], model.idx_q[i]
        pq[jm.idx_q:jm.idx_q + jm.nq] = q[a:a + 7] if model.kind[i] == FREEFLYER else \
            (np.cos(q[a]), np.sin(q[a])) if jm.nq == 2 else q[a]
    return pq


def pin_crba(pm, pq):
    """Pinocchio's M: its upper triangle, filled symmetric."""
    M = pin.crba(pm, pm.createData(), pq)
    return np.triu(M) + np.triu(M, 1).T


def _errors(model, pm, to_pin, Q):
    """err of M for each state of Q, the single-state call and the batch call."""
    ref = [pin_crba(pm, to_pin(q)) for q in Q]
    batch = md.mass_matrix(model, Q)
    return max(max(err(md.mass_matrix(model, q), r), err(b, r)) for q, b, r in zip(Q, batch, ref))


# §3 error against Pinocchio, 20 states: tolerance, measured (worst of the single-state and batch calls)
FIXED_TOL = {
    "aau_arm":                        7e-15,   # 2.2e-16
    "spm":                            3e-17,   # 8.7e-19
    "fourbar":                        3e-16,   # 6.9e-18
    "ur5_robot":                      2e-14,   # 3.5e-16
    "ur10_robot":                     2e-14,   # 3.4e-16
    "ur3_robot":                      1e-14,   # 3.3e-16
    "ur5_gripper":                    2e-14,   # 3.5e-16
    "panda":                          2e-14,   # 6.4e-16
    "kinova":                         2e-14,   # 4.4e-16
    "xarm7":                          3e-14,   # 9.4e-16
    "z1":                             2e-14,   # 3.9e-16
    "so100":                          5e-16,   # 1.4e-17
    "so101":                          3e-16,   # 6.9e-18
    "double_pendulum":                2e-16,   # 5.2e-18
    "double_pendulum_continuous":     2e-16,   # 5.2e-18
    "TwoDofs":                        3e-16,   # 6.9e-18
    "finger_edu":                     6e-17,   # 1.7e-18
    "allegro_right_hand":             2e-17,   # 6.5e-19
    "allegro_left_hand":              2e-17,   # 4.3e-19
    "baxter":                         3e-14,   # 6.7e-16
    "talos_left_arm":                 2e-14,   # 6.4e-16
    "tree5":                          4e-14,   # 1.2e-15
    "tree6":                          3e-14,   # 8.0e-16
    "tree7":                          6e-14,   # 2.0e-15
}
FIXED = ["aau_arm", "spm", "fourbar"] + [p.stem for p in zoo_paths()] + list(RANDOM_TREES)


@pytest.mark.parametrize("name", FIXED)
def test_crba_matches_pinocchio(name):
    model, pm, to_pin = fixed_base(name)
    Q = random_states(model, 20, np.random.default_rng(7))[0]
    e = _errors(model, pm, to_pin, Q)
    assert e <= FIXED_TOL[name], f"{name}: err {e:.2e} > tol {FIXED_TOL[name]:.0e}"


# ---- free-flyer root ---------------------------------------------------------------------------------------

def floating_model(path):
    """Our model of a URDF with a free-flyer root, built by hand until the loader offers it: the root link
    is hung from a prismatic joint named root_joint (so that the loader makes it body 0, with its
    fixed-joint children merged into it), and that joint is then made a free flyer."""
    text = path.read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        root = md.load_urdf(path).root_link
        text = text.replace("</robot>", f'<link name="_world"/><joint name="root_joint" type="prismatic">'
                            f'<parent link="_world"/><child link="{root}"/><axis xyz="0 0 1"/>'
                            f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
        model = md.load_urdf_string(text, source=str(path))
    assert model.joint_names[0] == "root_joint" and model.body_names[0] == root
    kind, axis, lower, upper = model.kind.copy(), model.axis.copy(), model.lower.copy(), model.upper.copy()
    kind[0], axis[0], lower[0], upper[0] = FREEFLYER, 0.0, -np.inf, np.inf
    dyn = {k: np.concatenate([np.zeros(6), getattr(model, k)[1:]]) for k in ("armature", "damping", "friction")}
    return dataclasses.replace(model, kind=kind, axis=axis, lower=lower, upper=upper, **dyn)


def floating_states(model, n, rng):
    """n configurations (docs/design.md §3): base position N(0, 3²) m, a uniformly random unit quaternion, the
    other (1-dof) joints uniform in [−π, π] (prismatic: within limits, or [−0.5, 0.5] m)."""
    Q = np.empty((n, model.nq))
    Q[:, :3] = rng.normal(0.0, 3.0, (n, 3))
    quat = rng.normal(size=(n, 4))
    Q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    kind, lower, upper = model.kind[1:], model.lower[1:], model.upper[1:]
    lo = np.where(kind == PRISMATIC, np.where(np.isfinite(lower), lower, -0.5), -np.pi)
    hi = np.where(kind == PRISMATIC, np.where(np.isfinite(upper), upper, 0.5), np.pi)
    Q[:, 7:] = rng.uniform(lo, hi, (n, model.nq - 7))
    return Q


FLOATING = {                                       # URDF: tolerance, measured (10 states)
    "solo_description/robots/solo12.urdf": 5e-16,             # 1.4e-17
    "anymal_b_simple_description/robots/anymal.urdf": 2e-15,  # 4.4e-17
    "hyq_description/robots/hyq_no_sensors.urdf": 2e-15,      # 4.1e-17
    "talos_data/robots/talos_reduced.urdf": 2e-15,            # 5.9e-17
}


@pytest.mark.parametrize("rel", list(FLOATING), ids=lambda r: r.split("/")[-1][:-5])
def test_free_flyer_crba_matches_pinocchio(rel):
    path = robots_dir() / rel
    model = floating_model(path)
    pm = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    assert (model.nq, model.nv) == (pm.nq, pm.nv) and model.joint_names == tuple(pm.names[1:])
    Q = floating_states(model, 10, np.random.default_rng(11))
    assert md.mass_matrix(model, Q).shape == (10, model.nv, model.nv)
    e = _errors(model, pm, lambda q: _pin_q(model, pm, q), Q)
    assert e <= FLOATING[rel], f"err {e:.2e} > tol {FLOATING[rel]:.0e}"


def test_free_flyer_bad_q_is_named():
    model = floating_model(robots_dir() / "solo_description/robots/solo12.urdf")
    q = floating_states(model, 1, np.random.default_rng(3))[0]
    q[5] = np.nan
    with pytest.raises(md.InputError, match=r"q\[5\] \(joint 'root_joint\.qz'\) is nan"):
        md.mass_matrix(model, q)


# ---- the same source, uncompiled ---------------------------------------------------------------------------

NOJIT_MODELS = ("double_pendulum", "tree5", "solo12")


def _nojit_model(name):
    if name == "solo12":
        return floating_model(robots_dir() / "solo_description/robots/solo12.urdf")
    return fixed_base(name)[0]


def _nojit_states(model, name):
    rng = np.random.default_rng(5)
    return floating_states(model, 3, rng) if model.floating else random_states(model, 3, rng)[0]


NOJIT_SCRIPT = """
import json, sys
sys.path.insert(0, {tests!r})
from manipdyn import _jit
assert _jit.NOJIT
from manipdyn.dynamics import crba
assert not hasattr(crba.crba_steps_one, "py_func"), "compiled"
import test_crba as t
import numpy as np
out = {{}}
for name in {names!r}:
    model = t._nojit_model(name)
    out[name] = crba.crba(model, t._nojit_states(model, name)).tolist()
print(json.dumps(out))
"""


def test_uncompiled_source_gives_the_same_numbers():
    """MANIPDYN_NOJIT=1 runs the CRBA's steps (crba_steps_one, crba_lanes) as the Python functions they are written as."""
    script = NOJIT_SCRIPT.format(tests=str(ROOT / "tests" / "crosscheck"), names=NOJIT_MODELS)
    path = os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p])   # this source tree
    env = dict(os.environ, MANIPDYN_NOJIT="1", PYTHONWARNINGS="ignore", PYTHONPATH=path)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=600,
                       cwd=ROOT / "tests")
    assert r.returncode == 0, r.stderr[-3000:]
    plain = json.loads(r.stdout.strip().splitlines()[-1])
    for name in NOJIT_MODELS:
        model = _nojit_model(name)
        e = err(md.mass_matrix(model, _nojit_states(model, name)), np.array(plain[name]))
        assert e <= 1e-14, f"{name}: compiled vs uncompiled err {e:.2e}"     # measured 0.0 (all three)
