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


# ---- floating bases: a free-flyer root (nq = nv + 1) --------------------------------------------------------
FLOAT = {"solo12": "solo_description/robots/solo12.urdf", "anymal": "anymal_b_simple_description/robots/anymal.urdf",
         "talos": "talos_data/robots/talos_reduced.urdf"}
POSE = (0.3, -0.2, 0.8, *np.array([0.2, -0.5, 0.3, 0.7]) / np.linalg.norm([0.2, -0.5, 0.3, 0.7]))
TALOS_ARMS = {f"arm_{s}_{k}_joint": 0.1 * k * (1 if s == "left" else -1) for s in ("left", "right") for k in range(1, 8)}
FLOAT_CASES = {    # name -> (robot, reduction, free flyer kept)
    "solo12 one leg and a knee locked": ("solo12", dict(locked={"FL_HAA": 0.1, "FL_HFE": -0.7, "FL_KFE": 1.2,
                                                                "HR_KFE": -0.4}), True),
    "anymal two joints locked": ("anymal", dict(locked={"LF_HFE": 0.4, "RH_KFE": -0.9}), True),
    "talos arms locked": ("talos", dict(locked=TALOS_ARMS), True),
    "talos tips, no root (free flyer on the chain)": ("talos", dict(tips=["arm_left_7_link", "leg_right_6_link"]), True),
    "anymal root at the base (free flyer locked at neutral)": ("anymal", dict(root="base", tips=["LF_SHANK"]), False),
    "talos root/tips below the free flyer": ("talos", dict(root="torso_2_link", tips=["arm_left_7_link"]), False),
    "solo12 free flyer locked at a pose": ("solo12", dict(locked={"root_joint": POSE, "HL_HAA": 0.3}), False),
}


def _float_path(name):
    from manipdyn.validation.zoo import robots_dir
    return robots_dir() / FLOAT[name]


def _load_float(name, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_urdf(_float_path(name), root_joint="free_flyer", **kw)


@pytest.mark.parametrize("case", list(FLOAT_CASES))
def test_reduced_floating_model_matches_pinocchio(case):
    """rnea, crba, aba of the reduced model against pin.buildReducedModel of Pinocchio's free-flyer model
    (validate's reference: the locked free flyer enters buildReducedModel with its pose as the reference q)."""
    name, kw, floating = FLOAT_CASES[case]
    model, full = _load_float(name, **kw), _load_float(name)
    assert model.floating == floating and model.nv < full.nv
    assert set(model.locked) == set(full.joint_names) - set(model.joint_names)
    if not floating:
        assert model.nq == model.nv and isinstance(model.locked["root_joint"], tuple)
    rep = validate(model, _float_path(name), n_states=40, seed=4)
    got = {t.term: t for t in rep.terms}
    tol = {"tau": 1e-13, "M_crba": 5e-14, "qdd_aba": 5e-15}   # measured ≤ 1.2e-15, 7.8e-16, 5.7e-17 (all cases)
    for t in tol:
        assert got[t].supported and got[t].err <= tol[t], (t, got[t].err, rep.notes)


def test_locked_free_flyer_against_pinocchio_directly():
    """The same without validate: Pinocchio's reduced model built here, the free flyer locked at POSE."""
    P = pytest.importorskip("pinocchio")
    path = _float_path("solo12")
    model = md.reduce(_load_float("solo12"), locked={"root_joint": POSE, "FR_KFE": 0.5})
    pm = P.buildModelFromUrdf(str(path), P.JointModelFreeFlyer())
    qref = P.neutral(pm)
    qref[:7] = POSE
    qref[pm.joints[pm.getJointId("FR_KFE")].idx_q] = 0.5
    pr = P.buildReducedModel(pm, [pm.getJointId("root_joint"), pm.getJointId("FR_KFE")], qref)
    pd = pr.createData()
    assert tuple(pr.names[1:]) == model.joint_names and pr.nq == model.nq == 11
    Q, V, A = random_states(model, 20, np.random.default_rng(8))
    T = md.rnea(model, Q, V, A)
    Mq, qdd = md.mass_matrix(model, Q), md.aba(model, Q, V, T + 1.0)
    for s in range(20):
        assert_close(T[s], P.rnea(pr, pd, Q[s], V[s], A[s]), 5e-15, "rnea")          # measured 8.3e-17
        assert_close(Mq[s], P.crba(pr, pd, Q[s]), 1e-16, "crba")                       # measured 1.7e-18
        assert_close(qdd[s], P.aba(pr, pd, Q[s], V[s], T[s] + 1.0), 1e-13, "aba")     # measured 1.3e-15


def test_reduced_floating_equals_full_with_joints_held():
    # independent of Pinocchio: the full floating model with locked joints at their values and at rest
    full = _load_float("anymal")
    locked = {"LF_HFE": 0.4, "RH_KFE": -0.9}
    red = md.reduce(full, locked=locked)
    Q, V, A = random_states(red, 20, np.random.default_rng(6))
    iq = np.concatenate([np.arange(7)] + [[full.idx_q[full.joint_index(j)]] for j in red.joint_names[1:]])
    iv = np.concatenate([np.arange(6)] + [[full.idx_v[full.joint_index(j)]] for j in red.joint_names[1:]])
    Qf, Vf, Af = np.zeros((20, full.nq)), np.zeros((20, full.nv)), np.zeros((20, full.nv))
    Qf[:, iq], Vf[:, iv], Af[:, iv] = Q, V, A
    for j, val in locked.items():
        Qf[:, full.idx_q[full.joint_index(j)]] = val
    assert_close(md.rnea(red, Q, V, A), md.rnea(full, Qf, Vf, Af)[:, iv], 5e-15, "rnea")   # measured 4.7e-17
    assert_close(md.mass_matrix(red, Q), md.mass_matrix(full, Qf)[:, iv][:, :, iv], 1e-15, "M")  # measured 1.5e-17


def test_free_flyer_locked_equals_the_floating_model_held_at_the_pose():
    # a fixed base at POSE = the floating model whose base is held there (zero base rates): rnea's joint
    # rows equal, and the world placement of every frame too
    full = _load_float("solo12")
    red = md.reduce(full, locked={"root_joint": POSE})
    Q, V, A = random_states(red, 20, np.random.default_rng(7))
    Qf = np.hstack([np.tile(POSE, (20, 1)), Q])
    Vf, Af = np.hstack([np.zeros((20, 6)), V]), np.hstack([np.zeros((20, 6)), A])
    assert_close(md.rnea(red, Q, V, A), md.rnea(full, Qf, Vf, Af)[:, 6:], 3e-15, "rnea")   # measured 2.8e-17
    for link in ("base_link", "FL_FOOT", "HR_UPPER_LEG"):
        R1, p1 = md.frame_placement(red, Q[3], link)
        R2, p2 = md.frame_placement(full, Qf[3], link)
        assert_close(R1, R2, 1e-14, link)
        assert_close(p1, p2, 1e-14, link)                   # measured ≤ 4.0e-16


def test_locking_a_free_flyer_needs_a_pose():
    full = _load_float("solo12")
    with pytest.raises(md.InputError, match=r"'root_joint' is 0.0: expected a pose \[x y z qx qy qz qw\]"):
        md.reduce(full, locked={"root_joint": 0.0})
    with pytest.raises(md.InputError, match="quaternion .* has norm 2"):
        md.reduce(full, locked={"root_joint": [0, 0, 0, 0, 0, 0, 2.0]})
    with pytest.raises(md.InputError, match="'FL_HAA' is .*expected a real number"):
        md.reduce(full, locked={"FL_HAA": [0.1, 0.2]})
    with pytest.raises(md.InputError, match="must be finite"):
        md.reduce(full, locked={"FL_HAA": np.nan})
    neutral = md.reduce(full, locked={"root_joint": None})            # None: the neutral pose
    assert neutral.locked["root_joint"] == (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    assert "root_joint = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]" in neutral.summary()
    assert neutral.frames["base_link"].body == -1 and neutral.merged["base_link"] == full.merged["base_link"]
