"""Mimic joints as a user meets them: the public rnea / mass_matrix / gravity_torques / aba / forward_dynamics
given a MimicModel (``load_urdf(path, mimic=True)``), against Pinocchio 4.1's ``buildModelFromUrdf(path,
mimic=True)``: τ = rnea, g = rnea(q, 0, 0), M = crba(Convention.WORLD) (its default crba and aba refuse mimic
joints), q̈ = M⁻¹(τ − rnea(q, q̇, 0)) (err/cond(M)). Robots: every example-robot-data arm or robot with <mimic>
that Pinocchio loads with mimic=True (panda, baxter, pr2 with continuous joints, tiago_pro, the talos
models), and a hand-made tree whose mimic joints have offsets and multipliers ≠ ±1 (the zoo's are all 0 and ±1).
"""
import warnings

import numpy as np
import pytest
from conftest import inertial_xml, urdf

import manipdyn as md
from manipdyn import InputError, MimicModel
from manipdyn.validation.measure import error
from manipdyn.validation.mimic import MimicReference, independent_states, validate_mimic
from manipdyn.validation.reference import pin
from manipdyn.validation.zoo import robots_dir

P = pin()
ZOO = ["panda_description/urdf/panda.urdf", "baxter_description/urdf/baxter.urdf",
       "pr2_description/urdf/pr2.urdf", "tiago_pro_description/robots/tiago_pro.urdf"]


def _tree_with_offsets():
    I = (0.02, 0.03, 0.04, 0.001, -0.002, 0.003)
    links = {"base": "", **{f"l{k}": inertial_xml(0.5 + 0.2 * k, (0.1, 0.02 * k, -0.03), I) for k in range(1, 6)}}
    joints = [("j1", "revolute", "base", "l1", (0, 0, 0.1), (0.1, 0, 0), (0, 0, 1)),
              ("j2", "revolute", "l1", "l2", (0.3, 0, 0), (0, 0.2, 0), (0, 1, 0)),
              ("j3", "prismatic", "l2", "l3", (0.2, 0.1, 0), (0, 0, 0.3), (1, 0, 0)),
              ("j4", "revolute", "base", "l4", (0, 0.2, 0), (0, 0, 0), (0.6, 0, 0.8)),
              ("j5", "revolute", "l3", "l5", (0.1, 0, 0), (0.3, 0, 0), (0, 0, 1))]
    text = urdf(links, joints, name="mimic_tree")
    for j, m in (("j2", '<mimic joint="j1" multiplier="-2.5" offset="0.3"/>'),
                 ("j4", '<mimic joint="j1" multiplier="0.5" offset="-0.2"/>')):
        i = text.index(f'<joint name="{j}"')
        k = text.index("</joint>", i)
        text = text[:k] + m + text[k:]
    return text


@pytest.fixture(scope="module")
def tree_path(tmp_path_factory):
    p = tmp_path_factory.mktemp("mimic") / "mimic_tree.urdf"
    p.write_text(_tree_with_offsets())
    return p


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_urdf(path, mimic=True)


@pytest.mark.parametrize("rel", ZOO + ["talos_data/robots/talos_reduced.urdf", "<tree>"])
def test_public_functions_take_a_mimic_model_and_match_pinocchio(rel, tree_path):
    path = tree_path if rel == "<tree>" else robots_dir() / rel
    mm = _load(path)
    assert isinstance(mm, MimicModel)
    ref = MimicReference(mm, path)
    Q, V, A, T = independent_states(mm, 10, np.random.default_rng(3))
    worst = dict(tau=0.0, g=0.0, M=0.0, qdd=0.0, chol=0.0)
    for q, v, a, tau in zip(Q, V, A, T):
        y = ref.terms(q, v, a, tau)
        kappa = np.linalg.cond(y["M"])
        worst["tau"] = max(worst["tau"], error(md.rnea(mm, q, v, a), y["tau"]))
        worst["g"] = max(worst["g"], error(md.gravity_torques(mm, q), y["g"]))
        worst["M"] = max(worst["M"], error(md.mass_matrix(mm, q), y["M"]))
        worst["qdd"] = max(worst["qdd"], error(md.aba(mm, q, v, tau), y["qdd"]) / kappa)
        worst["chol"] = max(worst["chol"], error(md.forward_dynamics(mm, q, v, tau, method="cholesky",
                                                                           joint_dynamics=False), y["qdd"]) / kappa)
    # measured (10 states, six models): τ ≤ 1.5e-15, g ≤ 1.5e-15, M ≤ 7.5e-16, q̈/cond(M) ≤ 1.1e-17 (panda)
    assert max(worst["tau"], worst["g"], worst["M"]) < 1e-13, worst
    assert max(worst["qdd"], worst["chol"]) < 1e-15, worst


def test_offsets_and_multipliers_reach_the_full_tree(tree_path):
    """q_full = Gq q + offset checked against Pinocchio's placements of the mimicking joints' bodies."""
    mm = _load(tree_path)
    assert mm.joint_names == ("j1", "j3", "j5") and mm.full.joint_names == ("j1", "j2", "j3", "j5", "j4")
    ref = MimicReference(mm, tree_path)
    pd = ref.pm.createData()
    q = np.array([0.7, 0.12, -0.4])
    qf, _, _ = mm.full_state(q)
    assert qf[1] == -2.5 * 0.7 + 0.3 and qf[4] == 0.5 * 0.7 - 0.2
    P.forwardKinematics(ref.pm, pd, ref.to_pin_q(q))
    P.updateFramePlacements(ref.pm, pd)
    worst = 0.0
    for link in ("l2", "l3", "l4", "l5"):
        R, p = md.frame_placement(mm.full, qf, link)
        M = pd.oMf[ref.pm.getFrameId(link)]
        worst = max(worst, error(R, M.rotation), error(p, M.translation))
    assert worst < 1e-14, worst          # measured 3.3e-16


def test_batches_equal_rows():
    mm = _load(robots_dir() / ZOO[2])
    Q, V, A, T = independent_states(mm, 5, np.random.default_rng(4))
    for f, args in ((md.rnea, (Q, V, A)), (md.mass_matrix, (Q,)), (md.aba, (Q, V, T)), (md.gravity_torques, (Q,))):
        batch = f(mm, *args)
        rows = np.stack([f(mm, *(x[s] for x in args)) for s in range(5)])
        assert error(batch, rows) < 1e-14, f.__name__       # measured ≤ 2.3e-20 (pr2)


def test_mimic_model_refusals_are_typed_and_named():
    mm = _load(robots_dir() / ZOO[0])
    q = np.zeros(mm.nq)
    with pytest.raises(InputError, match=r"MimicModel .*full_state"):
        md.frame_placement(mm, q, "panda_link7")
    with pytest.raises(InputError, match=r"q has shape \(9,\); expected \(8,\)"):
        md.rnea(mm, np.zeros(9), q, q)
    with pytest.raises(InputError, match="non-finite"):
        md.aba(mm, q, np.full(mm.nv, np.nan), q)
    with pytest.raises(InputError, match="method"):
        md.forward_dynamics(mm, q, q, q, method="rk4")
    with pytest.raises(InputError, match="cannot yet be combined with mimic=True"):
        md.load_urdf(robots_dir() / ZOO[0], mimic=True, locked={"panda_joint1": 0.0})


def test_validate_mimic_passes_and_a_wrong_multiplier_fails(tmp_path):
    path = robots_dir() / ZOO[1]
    rep = validate_mimic(_load(path), path, n_states=5, seed=1, tol=1e-13)
    assert rep.passed, rep
    bad = tmp_path / "baxter.urdf"                      # r_gripper_r_finger_joint = -0.9 (not -1) l_finger
    text = path.read_text()
    i = text.index('<mimic joint="r_gripper_l_finger_joint"')
    bad.write_text(text[:i] + text[i:].replace('multiplier="-1.0"', 'multiplier="-0.9"', 1))
    assert 'multiplier="-0.9"' in bad.read_text()
    rep = validate_mimic(_load(bad), path, n_states=5, seed=1, tol=1e-13)
    assert not rep.passed and {t.term for t in rep.terms if not t.passed} >= {"tau", "M"}
