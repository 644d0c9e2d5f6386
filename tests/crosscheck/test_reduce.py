"""Reduced models equal Pinocchio's buildReducedModel (rnea, M, aba at 1e-12), and say what they did."""
import warnings

import numpy as np
import pytest
from conftest import ROOT, assert_close, zoo_paths

import manipdyn as md
from manipdyn.cli import main
from manipdyn.validation import random_states, validate

ZOO = {p.name: p for p in zoo_paths()}


def _load(name, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_urdf(ZOO[name], **kw)


def _allegro_three_fingers_locked():
    full = _load("allegro_right_hand.urdf")
    return {j: 0.1 * k for k, j in enumerate(full.joint_names) if int(float(j.split("_")[1])) < 12}


CASES = {
    "panda fingers locked": ("panda.urdf", dict(locked={"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.03})),
    "baxter one arm (root/tips)": ("baxter.urdf", dict(root="torso", tips=["left_gripper"])),
    "allegro three fingers locked": ("allegro_right_hand.urdf", dict(locked=_allegro_three_fingers_locked())),
}


@pytest.mark.parametrize("case", list(CASES))
def test_reduced_model_matches_pinocchio(case):
    name, kw = CASES[case]
    model = _load(name, **kw)
    full = _load(name)
    assert model.nv < full.nv and set(model.locked) == set(full.joint_names) - set(model.joint_names)
    rep = validate(model, ZOO[name], n_states=300, seed=3)      # against pin.buildReducedModel
    bad = [f"{t.label}: {t.err:.1e}" for t in rep.terms if not t.passed]
    assert not bad, bad
    for t in ("tau", "M_crba", "qdd_aba"):
        assert {x.term: x for x in rep.terms}[t].err <= 1e-12


def test_reduced_equals_full_with_joints_held():
    # independent of Pinocchio: the full model with the locked joints at their values and zero rates
    full = _load("panda.urdf")
    locked = {"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.03}
    red = md.reduce(full, locked=locked)
    Q, V, A = random_states(red, 20, np.random.default_rng(5))
    idx = [full.joint_index(j) for j in red.joint_names]
    Qf, Vf, Af = (np.zeros((20, full.nv)) for _ in range(3))
    Qf[:, idx], Vf[:, idx], Af[:, idx] = Q, V, A
    for j, val in locked.items():
        Qf[:, full.joint_index(j)] = val
    assert_close(md.rnea(red, Q, V, A), md.rnea(full, Qf, Vf, Af)[:, idx], 5e-15, "rnea")  # measured 9.5e-17
    assert_close(md.mass_matrix(red, Q), md.mass_matrix(full, Qf)[:, idx][:, :, idx], 2e-15, "M")  # measured 3.4e-17


def test_prune_drops_massless_leaves_and_errors_name_things():
    model = md.load_urdf(ROOT / "urdf" / "fourbar.urdf")
    with pytest.raises(md.ModelError, match="closure 'loop' cannot be kept"):
        md.reduce(model, locked={"j2_coupler": 0.0, "j3_rocker": 0.0, "j1_crank": 0.0})
    with pytest.raises(md.InputError, match="no moving joint named 'nope'"):
        md.reduce(model, locked={"nope": 0.0})
    romeo_like = md.load_urdf_string(
        '<robot name="r"><link name="b"/><link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" '
        'izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link><link name="tip"/>'
        '<joint name="ja" type="continuous"><parent link="b"/><child link="a"/><axis xyz="0 0 1"/></joint>'
        '<joint name="jt" type="continuous"><parent link="a"/><child link="tip"/><axis xyz="1 0 0"/></joint></robot>')
    assert md.reduce(romeo_like, prune=True).joint_names == ("ja",)


def test_cli_accepts_reduction_options(capsys):
    code = main(["validate", str(ZOO["panda.urdf"]), "--lock", "panda_finger_joint1=0.02",
                 "--lock", "panda_finger_joint2=0.01", "--states", "20", "--quiet"])
    assert code == 0 and "nv=7" in capsys.readouterr().out
    assert main(["inspect", str(ZOO["baxter.urdf"]), "--root", "torso", "--tips", "right_gripper"]) == 0
    assert "locked joints" in capsys.readouterr().out
    assert main(["inspect", str(ZOO["panda.urdf"]), "--lock", "oops"]) == 2


def test_dynamics_path_never_loads_geometry(tmp_path):
    # visual and collision meshes that do not exist: loading for dynamics must not care (or read them)
    text = ('<robot name="r"><link name="b"/><link name="a"><inertial><mass value="1"/><inertia ixx="1" '
            'iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial><visual><geometry><mesh '
            'filename="package://nowhere/missing.dae"/></geometry></visual><collision><geometry><mesh '
            'filename="missing.stl"/></geometry></collision></link><joint name="j" type="continuous">'
            '<parent link="b"/><child link="a"/><axis xyz="0 0 1"/></joint></robot>')
    (tmp_path / "r.urdf").write_text(text)
    model = md.load_urdf(tmp_path / "r.urdf")
    assert model.nv == 1 and np.isfinite(md.rnea(model, [0.1], [0.2], [0.3])).all()
