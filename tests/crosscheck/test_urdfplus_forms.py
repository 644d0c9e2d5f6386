"""The bundled closed chains in both closure grammars: urdf/fourbar.urdf and urdf/spm.urdf (<constraint>,
<transmission>) and their URDF+ forms tests/data/loops/*_urdfplus.urdf (<loop> with a loop-frame axis turned
into each link by its side's <origin rpy>, independent=), written by scripts/make_urdfplus.py.

Both forms must be one mechanism: the same closures (bodies, points, axes), the same actuated joints, the same
closure rows Φ, Φ_q, Φ̇_q q̇ at random states and the same constrained q̈ on the closures; and the URDF+ form,
read by Pinocchio from the URDF+ file itself (urdfdom skips <loop>), against Pinocchio's frame rows
(tests/pin_closures.py) and its constraintDynamics, as the <constraint> forms are in test_spatial_loops.py.
The URDF+ SPM's loop frames are rotated on both sides (its axes are skew): a loader that ignored the rpy when
turning the loop axis into a link, or the origin, would differ here.
"""
import functools
import importlib.util
import sys

import re

import numpy as np
import pytest
from conftest import ROOT, assert_close, err
from pin_closures import PinClosures

from manipdyn import load_urdf
from manipdyn.constraints import closure_terms, constrained_forward_dynamics
from manipdyn.validation.closed import ClosedReference, manifold_states
from manipdyn.validation.reference import Reference, pin

PAIRS = {"fourbar": (ROOT / "urdf" / "fourbar.urdf", ROOT / "tests" / "data" / "loops" / "fourbar_urdfplus.urdf"),
         "spm": (ROOT / "urdf" / "spm.urdf", ROOT / "tests" / "data" / "loops" / "spm_urdfplus.urdf")}


def _script():
    spec = importlib.util.spec_from_file_location("make_urdfplus", ROOT / "scripts" / "make_urdfplus.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_urdfplus"] = mod
    spec.loader.exec_module(mod)
    return mod


@functools.lru_cache(maxsize=None)
def pair(name):
    a, b = (load_urdf(p) for p in PAIRS[name])
    rng = np.random.default_rng(sum(map(ord, name)))
    Q, V = manifold_states(a, 6, rng)
    act = [a.joint_index(j) for j in a.actuated]
    tau = np.zeros_like(V)
    tau[:, act] = rng.normal(0.0, 1.0, (len(Q), len(act)))
    return a, b, Q, V, tau


_NUMBER = re.compile(r"-?\d+\.\d+(?:e-?\d+)?")


def same_text_to_rounding(a, b, rel=1e-14):
    """a and b equal but for numbers that differ in their last digits (the rpy angles come from arctan2 and
    arcsin, whose last bit differs between CPUs' libm: measured 1 ulp between an Intel and an AMD machine)."""
    if _NUMBER.split(a) != _NUMBER.split(b):
        return False
    x, y = (np.array([float(t) for t in _NUMBER.findall(s)]) for s in (a, b))
    return x.shape == y.shape and bool(np.all(np.abs(x - y) <= rel * np.maximum(np.abs(y), 1.0)))


@pytest.mark.parametrize("name", PAIRS)
def test_stored_files_are_what_the_script_makes(name):
    src, dst = PAIRS[name]
    made, stored = _script().urdfplus(src.read_text(), f"urdf/{src.name}"), dst.read_text()
    assert same_text_to_rounding(made, stored)
    assert not same_text_to_rounding(made.replace("<loop", "<loop x=\"1.5\"", 1), stored)    # text differences count


@pytest.mark.parametrize("name", PAIRS)
def test_same_closures_and_actuated_joints(name):
    a, b, *_ = pair(name)
    assert b.joint_names == a.joint_names and b.actuated == a.actuated and len(a.actuated) >= 1
    assert [c.source for c in b.constraints] == ["loop"] * len(a.constraints)
    worst = 0.0
    for ca, cb in zip(a.constraints, b.constraints, strict=True):
        assert (cb.name, cb.type, cb.parent, cb.child) == (ca.name, ca.type, ca.parent, ca.child)
        assert np.array_equal(cb.pp, ca.pp) and np.array_equal(cb.pc, ca.pc)        # origins copied exactly
        worst = max(worst, err(cb.axis_p, ca.axis_p), err(cb.axis_c, ca.axis_c))
    assert worst < 1e-15, worst       # measured 2.2e-16 spm, 6.1e-17 fourbar (the axes pass through rpy and back)


@pytest.mark.parametrize("name", PAIRS)
def test_same_closure_rows_at_random_states(name):
    a, b, *_ = pair(name)
    rng = np.random.default_rng(2)
    Q, V = rng.uniform(-np.pi, np.pi, (20, a.nq)), rng.normal(0.0, 2.0, (20, a.nv))
    worst = [err(x, y) for x, y in zip(closure_terms(b, Q, V), closure_terms(a, Q, V))]
    assert max(worst) < 1e-14, worst  # measured Φ 3.9e-16, Φ_q 4.4e-16, Φ̇_q q̇ 4.2e-16 (spm)


@pytest.mark.parametrize("name", PAIRS)
def test_same_constrained_forward_dynamics(name):
    a, b, Q, V, tau = pair(name)
    worst = 0.0
    for s in range(len(Q)):
        qa, _ = constrained_forward_dynamics(a, Q[s], V[s], tau[s])
        qb, _ = constrained_forward_dynamics(b, Q[s], V[s], tau[s])
        worst = max(worst, err(qb, qa))
    assert worst < 1e-13, worst       # measured 0 on both (rows differing by ≤ 4.4e-16 leave q̈ unchanged here)


@pytest.mark.parametrize("name", PAIRS)
def test_urdfplus_form_against_pinocchio(name):
    """Pinocchio reads the URDF+ file; its frame rows (PinClosures) and constraintDynamics are the reference."""
    _, b, Q, V, tau = pair(name)
    path = PAIRS[name][1]
    ref = Reference(b, path)
    rows = PinClosures(b, pin().buildModelFromUrdf(str(path)))
    cref = ClosedReference(ref)
    rng = np.random.default_rng(9)
    Qr, Vr = rng.uniform(-np.pi, np.pi, (10, b.nq)), rng.normal(0.0, 2.0, (10, b.nv))
    worst = [0.0, 0.0, 0.0]
    for s in range(len(Qr)):
        ours = closure_terms(b, Qr[s], Vr[s])
        for k, (x, y) in enumerate(zip(ours, rows.rows(ref.to_pin_q(Qr[s]), Vr[s]))):
            worst[k] = max(worst[k], err(x, y))
    assert max(worst) < 5e-14, worst  # measured Φ 7.8e-16, Φ_q 8.9e-16, Φ̇_q q̇ 1.5e-15 (spm)
    for s in range(len(Q)):
        qdd, _ = constrained_forward_dynamics(b, Q[s], V[s], tau[s])
        assert_close(qdd, cref.qdd(Q[s], V[s], tau[s]), 5e-12, "q̈")   # measured 7.6e-14 spm, 1.7e-15 fourbar
