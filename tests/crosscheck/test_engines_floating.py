"""The engines referee on free-flyer robots (validation/adapters.py, FloatingBase): each engine's floating base mapped
to ours at the adapter, τ, M and q̈ compared as on fixed-base files (tests/crosscheck/test_engines.py).

Ours: q = [x y z qx qy qz qw], v = [linear; angular] in the body frame (docs/design.md §3). MuJoCo: a free joint added
to the root body (MjSpec; its URDF import welds the root), qpos [x y z qw qx qy qz], qvel [linear (world); angular
(body)]. Drake: the root is its floating body, q [qw qx qy qz x y z], v [angular (world); linear (world)]. PyBullet:
useFixedBase=False; calculateMassMatrix gives the base's dofs [angular; linear] in the root link's *inertial* frame
(Bullet's base frame); calculateInverseDynamics refuses a floating base, so PyBullet is held to M only.

Robots: solo12 and anymal (example-robot-data, validated against Pinocchio with root_joint="free_flyer" in
tests/crosscheck/test_floating_base.py) and tests/data/offset_base_free.urdf, a root whose inertial frame is offset
and turned (where a base taken at the link origin, or left in world axes, shows at once).

Measured (MuJoCo 4.0, Drake, PyBullet 3.2.7, Pinocchio 4.1; 10 states, seed 3): τ, M, q̈/κ ≤ 1.2e-15 raw for
Pinocchio, MuJoCo and Drake on solo12 and the offset base; PyBullet's M 1.7e-17 (solo12) and 1.7e-13 (offset base:
its own re-expression of the inertia, named as precision; 6.4e-17 neutralised). anymal's base inertia is flawed
(principal moment ≤ 0): MuJoCo refuses it, Drake and PyBullet alter it (named causes); neutralised ≤ 8.2e-16.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import ROOT

from manipdyn.io.urdf import load_urdf
from manipdyn.validation import adapters as A
from manipdyn.validation.referee import referee
from manipdyn.validation.zoo import floating_paths

RAW = 1e-13              # measured ≤ 1.2e-15 (τ, M, q̈/κ; Pinocchio, MuJoCo, Drake; no quirk)
RAW_PB = 1e-11           # measured ≤ 1.7e-13 (PyBullet's M: its inertia re-expressed)
NEUTRAL = 1e-13          # measured ≤ 8.2e-16 after neutralising
OFFSET = ROOT / "tests" / "data" / "offset_base_free.urdf"


def _path(stem):
    if stem == "offset_base":
        return OFFSET
    want = {"solo12": "solo_description/robots/solo12.urdf",
            "anymal": "anymal_b_simple_description/robots/anymal.urdf"}[stem]
    found = [p for p in floating_paths() if str(p).endswith(want)]
    if not found:
        pytest.skip(f"{stem} is not installed")
    return found[0]


def _run(stem, engine):
    pytest.importorskip(A.MODULES[engine])
    path = _path(stem)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = load_urdf(path, root_joint="free_flyer")
    rep = referee(model, path, [engine], n_states=10, seed=3)
    return model, rep


@pytest.mark.parametrize("stem", ["solo12", "offset_base"])
@pytest.mark.parametrize("engine", ["pinocchio", "mujoco", "drake"])
def test_tau_m_qdd_against_each_engine(stem, engine):
    _, rep = _run(stem, engine)
    res = rep.engines[0]
    print(f"\n{stem} {engine}: {res.err}")
    assert res.status == "ok" and res.causes == [], (res.reason, res.causes)
    assert all(res.err[k] is not None for k in ("tau", "M", "qdd"))
    assert res.worst <= RAW                          # measured ≤ 1.2e-15


@pytest.mark.parametrize("stem", ["solo12", "offset_base"])
def test_pybullet_mass_matrix_only(stem):
    _, rep = _run(stem, "pybullet")
    res = rep.engines[0]
    print(f"\n{stem} pybullet: {res.err}, neutralised {res.neutral}")
    assert res.status == "ok" and res.err["tau"] is None and res.err["qdd"] is None
    assert any("M only" in n for n in res.notes)
    assert res.err["M"] <= RAW_PB and res.neutral["M"] <= NEUTRAL   # measured 1.7e-13 / 6.4e-17 (offset base)
    assert res.explained


def test_flawed_base_inertia_is_named():
    # anymal's base: a principal moment ≤ 0 (docs/design.md §8); Drake and PyBullet alter it, MuJoCo refuses it
    for engine in ("mujoco", "drake", "pybullet"):
        _, rep = _run("anymal", engine)
        res = rep.engines[0]
        print(f"\nanymal {engine}: {res.status} {res.err} {res.neutral}")
        if res.status == "refused":
            assert engine == "mujoco" and "eigenvalues" in res.reason
            continue
        assert res.explained and res.worst_neutral <= NEUTRAL      # measured ≤ 8.2e-16
        assert any(c["link"] == "base" for c in res.causes)


def test_report_rows_for_a_floating_robot(capsys):
    from manipdyn.cli import main
    code = main(["validate", str(OFFSET), "--against", "pinocchio,mujoco,pybullet,drake", "--root-joint",
                 "free_flyer", "--states", "5"])
    out = capsys.readouterr().out
    print(out)
    assert code == 0
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.startswith("  ") and
            line.split()[0] in A.ENGINES}
    for e in ("pinocchio", "mujoco", "drake"):
        if A.available(e):
            assert rows[e][1] == "ok" and all(float(x) <= RAW for x in rows[e][2:5]), rows[e]
    if A.available("pybullet"):
        assert rows["pybullet"][1:5] == ["ok", "-", rows["pybullet"][3], "-"] and float(rows["pybullet"][3]) <= RAW_PB
    assert "every disagreement above" in out


def test_floating_base_map_is_the_engines_convention():
    # the 6x6 block alone, against a finite difference of each engine's own state: MuJoCo's qvel[:3] is the
    # origin's world velocity, Drake's v[:3] the world angular velocity (checked here from R and our v)
    rng = np.random.default_rng(0)
    u = rng.normal(size=4)
    q = np.concatenate([rng.normal(size=3), u / np.linalg.norm(u)])
    v = rng.normal(size=6)
    R = A._rotation_xyzw(q[3:7])
    fm = A.FloatingBase("mujoco", 0, [], 6)
    fd = A.FloatingBase("drake", 0, [], 6)
    assert np.allclose(fm.P(q) @ v, np.concatenate([R @ v[:3], v[3:]]), rtol=0, atol=1e-15)
    assert np.allclose(fd.P(q) @ v, np.concatenate([R @ v[3:], R @ v[:3]]), rtol=0, atol=1e-15)
    for f in (fm, fd):                                   # orthogonal: the FD map f = P τ is Pᵀ's inverse
        assert np.allclose(f.P(q).T @ f.P(q), np.eye(6), rtol=0, atol=1e-15)
