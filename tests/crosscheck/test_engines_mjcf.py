"""The engines referee (manipdyn.validation.referee) on MJCF files with ball joints: MuJoCo compiles the file itself
and its joints are mapped to ours by name (a ball's qpos [qw qx qy qz] against our [qx qy qz qw], its qvel the same
body-frame ω); Pinocchio reads it with buildModelFromMJCF (refused by name when it makes one body's joints a
composite joint); PyBullet and Drake, whose adapters load URDF, refuse naming the ball joints.

References: MuJoCo 4.0 (mj_inverse, mj_fullM, mj_forward) and Pinocchio 4.1 (rnea, crba, aba) through the adapters;
the files: tests/crosscheck/test_mjcf_import.py's ball snippets and tests/data/humanoid_ball.xml.
Measured (20 states, seed 3): MuJoCo τ, M, q̈/cond(M) ≤ 2.2e-15 (balls 2.2e-15, free_ball 1.6e-15, humanoid
1.5e-15); Pinocchio on free_ball ≤ 2.8e-16 — RAW = 1e-13.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from conftest import ROOT
from test_mjcf_import import BALLS, FREE_BALL

import manipdyn as md
from manipdyn.validation.adapters import MODULES
from manipdyn.validation.referee import referee

RAW = 1e-13              # measured ≤ 2.2e-15 (τ, M, q̈/cond(M); MuJoCo and Pinocchio)
N = 20
HUMANOID = ROOT / "tests" / "data" / "humanoid_ball.xml"


def _file(tmp_path, name):
    if name == "humanoid":
        return HUMANOID
    p = tmp_path / f"{name}.xml"
    p.write_text({"balls": BALLS, "free_ball": FREE_BALL}[name])
    return p


def _referee(path, engines, model=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = model or md.load_mjcf(path)
        return model, referee(model, path, engines, n_states=N, seed=3)


@pytest.mark.parametrize("name", ["balls", "free_ball", "humanoid"])
def test_mujoco_agrees_on_ball_joints(name, tmp_path):
    pytest.importorskip("mujoco")
    model, rep = _referee(_file(tmp_path, name), ["mujoco"])
    res = rep.engines[0]
    assert np.any(model.kind == md.BALL) and res.status == "ok", res.reason
    print(f"\n{name}: mujoco τ {res.err['tau']:.1e}, M {res.err['M']:.1e}, q̈/κ {res.err['qdd']:.1e}")
    assert res.worst <= RAW and res.worst_neutral <= RAW and not res.causes and rep.explained


def test_mujoco_names_a_ball_joints_armature():
    # our armature on the third of one ball's dofs changed: the referee names that joint and MuJoCo's number
    pytest.importorskip("mujoco")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_mjcf(HUMANOID)
    k = model.idx_v[model.joint_index("left_hip")]
    arm = model.armature.copy()
    arm[k + 2] = 0.5
    _, rep = _referee(HUMANOID, ["mujoco"], dataclasses.replace(model, armature=arm))
    res = rep.engines[0]
    assert [c["link"] for c in res.causes if c["kind"] == "armature"] == ["left_hip"]
    assert "adds armature 0.01 kg m² to joint 'left_hip' (M's diagonal); ours [0.01, 0.01, 0.5]" in res.causes[0]["text"]
    assert res.worst > 1e-3 and res.worst_neutral <= RAW and rep.explained


def test_pinocchio_on_mjcf_and_its_composite_joints(tmp_path):
    pytest.importorskip("pinocchio")
    _, rep = _referee(_file(tmp_path, "free_ball"), ["pinocchio"])
    res = rep.engines[0]
    print(f"\nfree_ball: pinocchio worst {res.worst:.1e}")
    assert res.status == "ok" and res.worst <= RAW and res.worst_neutral <= RAW and not res.causes
    _, rep = _referee(HUMANOID, ["pinocchio"])                   # the abdomen's two joints in one body
    res = rep.engines[0]
    assert res.status == "refused" and "composite joint (Composite_abdomen_z)" in res.reason and rep.explained


@pytest.mark.parametrize("engine", ["pybullet", "drake"])
def test_urdf_engines_refuse_ball_joints_by_name(engine, tmp_path):
    pytest.importorskip(MODULES[engine])
    _, rep = _referee(_file(tmp_path, "balls"), [engine])
    res = rep.engines[0]
    assert res.status == "refused" and res.reason.startswith(f"{engine}: ball joints ('shoulder', 'wrist')")
    assert rep.explained


def test_cli_against_mujoco_on_an_mjcf_file(capsys):
    pytest.importorskip("mujoco")
    from manipdyn.cli import main
    assert main(["validate", str(HUMANOID), "--against", "mujoco", "--states", "5"]) == 0
    out = capsys.readouterr().out
    assert "mujoco     ok" in out and "agrees" in out
    assert main(["validate", str(HUMANOID), "--against", "mujoco", "--root-joint", "free_flyer"]) == 2
    assert "its free joint, if any, is in the file" in capsys.readouterr().err
