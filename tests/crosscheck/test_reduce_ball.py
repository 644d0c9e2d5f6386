"""reduce with ball joints locked at a quaternion [qx qy qz qw]: the reduced model's rnea, M and aba equal
Pinocchio's buildReducedModel of its buildModelFromMJCF model with the same joints locked at the same values
(Pinocchio's spherical joint takes q = [x y z w] as ours)."""
import numpy as np
import pytest

from ball_models import random_tree
from conftest import err

import manipdyn as md
from manipdyn.errors import InputError

P = pytest.importorskip("pinocchio")
TEXT = random_tree(4, "BHBBHB", one_root=True)     # joints j0 ball, j1 hinge, j2 ball, j4 hinge, j5 ball, j3 ball


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    path = tmp_path_factory.mktemp("ball") / "tree.xml"
    path.write_text(TEXT)
    return md.load_mjcf_string(TEXT), P.buildModelFromMJCF(str(path))


@pytest.mark.parametrize("lock", [["j2"], ["j2", "j1"], ["j0"], ["j5", "j3"]], ids="+".join)
def test_locked_ball_matches_pinocchio(models, lock):
    model, pm = models
    assert tuple(pm.names[1:]) == model.joint_names
    rng = np.random.default_rng(len(lock) + sum(map(ord, lock[0])))
    values, qref = {}, P.neutral(pm)
    for j in lock:
        i, k = model.joint_index(j), pm.joints[pm.getJointId(j)].idx_q
        x = md.random_configuration(model, rng)[model.idx_q[i]:model.idx_q[i] + model.nqs[i]]
        values[j] = x if len(x) == 4 else float(x[0])
        qref[k:k + len(x)] = x
    reduced = md.reduce(model, locked=values)
    pr = P.buildReducedModel(pm, [pm.getJointId(j) for j in lock], qref)
    pd = pr.createData()
    assert tuple(pr.names[1:]) == reduced.joint_names and pr.nq == reduced.nq and pr.nv == reduced.nv
    worst = np.zeros(3)
    for _ in range(10):
        q = md.random_configuration(reduced, rng)
        v, a = rng.normal(size=reduced.nv), rng.normal(size=reduced.nv)
        worst = np.maximum(worst, [err(md.rnea(reduced, q, v, a), P.rnea(pr, pd, q, v, a)),
                                   err(md.mass_matrix(reduced, q), P.crba(pr, pd, q)),
                                   err(md.aba(reduced, q, v, a), P.aba(pr, pd, q, v, a))])
    assert np.all(worst < 1e-13), worst     # measured ≤ 1.3e-15 (rnea), 1.3e-15 (M), 2.0e-15 (aba)


def test_locked_ball_value_is_checked(models):
    model, _ = models
    with pytest.raises(InputError, match=r"'j2'.*norm 2"):
        md.reduce(model, locked={"j2": [0.0, 0.0, 0.0, 2.0]})
    with pytest.raises(InputError, match=r"'j2'.*quaternion \[qx qy qz qw\]"):
        md.reduce(model, locked={"j2": 0.3})
