"""joint_torque_regressor, dynamic_parameters and model_with_parameters (dynamics/regressor.py) against
independent references:

- Pinocchio's computeJointTorqueRegressor and Inertia.toDynamicParameters, on the bundled models (AAU arm,
  SPM and four-bar as trees), every example-robot-data arm, floating robots (free-flyer root: body 0 is the
  root, merged links included) and random trees with revolute, prismatic and fixed joints;
- Y π against our rnea and Pinocchio's rnea (gravity included);
- model_with_parameters: Pinocchio's Inertia.FromDynamicParameters, and rnea of the rebuilt model against
  Y π for a different, physical π (two routes that share no code but the outward pass);
- batches against stacked single states, the source run uncompiled (MANIPDYN_NOJIT=1) against the compiled
  kernel, and bad input.
Every tolerance is within 100× of the error measured on correct code (written beside it).
"""
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, ROOT, err, zoo_paths
from nojit import assert_uncompiled_equals_compiled
from test_aba import case

import manipdyn as md
from manipdyn.validation import random_states, robots_dir
from manipdyn.validation.reference import Reference

BUNDLED = {"aau_arm": AAU, "spm": ROOT / "urdf" / "spm.urdf", "fourbar": ROOT / "urdf" / "fourbar.urdf"}
FLOATING = {"solo12": "solo_description/robots/solo12.urdf",
            "anymal": "anymal_b_simple_description/robots/anymal.urdf",     # base mass on a fixed child link
            "pr2": "pr2_description/urdf/pr2.urdf",                          # continuous and prismatic joints
            "talos_reduced": "talos_data/robots/talos_reduced.urdf"}         # 32 joints under the root


def reference(name):
    """(our model, Pinocchio model, our q -> Pinocchio's q) of a bundled model, a zoo arm, a floating robot
    (free-flyer root) or a random tree (test_aba's builder)."""
    if name.startswith("tree"):
        c = case(name)
        return c.model, c.pm, c.to_pin
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name in FLOATING:
            path = robots_dir() / FLOATING[name]
            model = md.load_urdf(path, root_joint="free_flyer")
        else:
            path = BUNDLED.get(name) or next(p for p in zoo_paths() if p.stem == name)
            model = md.load_urdf(path)
    ref = Reference(model, path)
    return model, ref.pm, ref.to_pin_q


CASES = list(BUNDLED) + [p.stem for p in zoo_paths()] + list(FLOATING) + ["tree3", "tree4", "tree7"]


def test_the_cases_cover_the_zoo():
    # a missing robot must fail loudly, not shrink the cross-check silently
    assert len(zoo_paths()) >= 18 and len(CASES) == len(set(CASES))


def pin_parameters(pm):
    """π from Pinocchio: its bodies' Inertia.toDynamicParameters, joints 1 … njoints − 1 in order."""
    return np.concatenate([pm.inertias[i].toDynamicParameters() for i in range(1, pm.njoints)])


@pytest.mark.parametrize("name", CASES)
def test_regressor_and_parameters_match_pinocchio(name):
    model, pm, to_pin = reference(name)
    pd = pm.createData()
    Q, V, A = random_states(model, 6, np.random.default_rng(3))
    pi = md.dynamic_parameters(model)
    assert pi.shape == (10 * model.njoints,)
    assert err(pi, pin_parameters(pm)) <= 1e-14                     # measured ≤ 1.4e-16 (tree4)
    Y = md.joint_torque_regressor(model, Q, V, A)
    assert Y.shape == (6, model.nv, 10 * model.njoints)
    for s in range(6):
        pq = to_pin(Q[s])
        Yp = pin.computeJointTorqueRegressor(pm, pd, pq, V[s], A[s])
        assert err(Y[s], Yp) <= 1e-13, f"state {s}: Y"               # measured ≤ 2.9e-15 (xarm7)
        tau = Y[s] @ pi
        assert err(tau, md.rnea(model, Q[s], V[s], A[s])) <= 5e-14, f"state {s}: Y π vs rnea"   # ≤ 6.7e-16
        assert err(tau, pin.rnea(pm, pd, pq, V[s], A[s])) <= 1e-13, f"state {s}: Y π vs pin.rnea"  # ≤ 2.6e-15


@pytest.mark.parametrize("name", ["aau_arm", "ur5_robot", "baxter", "tree4", "solo12", "pr2"])
def test_one_state_equals_a_batch_row(name):
    model = reference(name)[0]
    Q, V, A = random_states(model, 4, np.random.default_rng(5))
    Y = md.joint_torque_regressor(model, Q, V, A)
    one = np.stack([md.joint_torque_regressor(model, Q[s], V[s], A[s]) for s in range(4)])
    assert err(Y, one) <= 1e-15                                       # measured 0 (the same kernel, N = 1)
    slow = md.joint_torque_regressor(model, Q.tolist(), V.tolist(), A.tolist())       # lists: as_batch first
    assert err(slow, Y) <= 1e-15                                      # the checked path: measured 0
    empty = md.joint_torque_regressor(model, Q[:0], V[:0], A[:0])
    assert empty.shape == (0, model.nv, 10 * model.njoints)


@pytest.mark.parametrize("name", ["aau_arm", "baxter", "tree4", "solo12"])
def test_model_with_parameters_round_trip(name):
    model = reference(name)[0]
    Q, V, A = random_states(model, 5, np.random.default_rng(7))
    back = md.model_with_parameters(model, md.dynamic_parameters(model))
    assert back is not model and back.joint_names == model.joint_names
    assert err(md.rnea(back, Q, V, A), md.rnea(model, Q, V, A)) <= 1e-15   # measured ≤ 1.7e-17
    # each body's (m, c, I_C) against Pinocchio's Inertia.FromDynamicParameters of the same π
    for i, p in enumerate(md.dynamic_parameters(model).reshape(-1, 10)):
        if p[0] <= 0:
            continue
        ref = pin.Inertia.FromDynamicParameters(p)
        assert err(back.mass[i], ref.mass) <= 1e-15                   # measured 0
        assert err(back.com[i], ref.lever) <= 1e-15                   # measured 0
        assert err(back.inertia[i], ref.inertia) <= 5e-15             # measured ≤ 5.6e-17


@pytest.mark.parametrize("name", ["aau_arm", "tree3", "solo12"])
def test_a_new_parameter_vector_gives_the_model_that_the_regressor_predicts(name):
    # a different physical π (scaled masses, moved CoMs, new inertias): rnea of model_with_parameters(π)
    # and Y π are two routes that share only the outward pass
    model = reference(name)[0]
    rng = np.random.default_rng(11)
    nb = model.njoints
    m = model.mass * rng.uniform(0.5, 2.0, nb) + 0.1
    c = model.com + rng.uniform(-0.1, 0.1, (nb, 3))
    L = rng.normal(size=(nb, 3, 3)) * 0.1
    Ic = L @ np.transpose(L, (0, 2, 1)) + 1e-3 * np.eye(3)            # positive definite
    I = Ic + m[:, None, None] * (np.einsum("bk,bk->b", c, c)[:, None, None] * np.eye(3)
                                 - np.einsum("bi,bj->bij", c, c))
    pi = np.column_stack([m, m[:, None] * c, I[:, 0, 0], I[:, 0, 1], I[:, 1, 1], I[:, 0, 2], I[:, 1, 2],
                          I[:, 2, 2]]).ravel()
    new = md.model_with_parameters(model, pi)
    assert err(new.mass, m) <= 1e-15 and err(new.com, c) <= 1e-15   # measured 0, 2.8e-17
    assert err(new.inertia, Ic) <= 5e-15                              # measured 6.9e-17
    Q, V, A = random_states(model, 5, np.random.default_rng(12))
    Y = md.joint_torque_regressor(model, Q, V, A)
    assert err(np.einsum("nij,j->ni", Y, pi), md.rnea(new, Q, V, A)) <= 3e-14     # measured ≤ 3.2e-16
    assert err(md.dynamic_parameters(new), pi) <= 5e-16                          # measured ≤ 5.4e-18


def test_a_model_without_joints():
    model = md.load_urdf_string('<robot name="a"><link name="b"/></robot>')
    assert md.joint_torque_regressor(model, [], [], []).shape == (0, 0)
    assert md.joint_torque_regressor(model, np.zeros((3, 0)), np.zeros((3, 0)), np.zeros((3, 0))).shape == (3, 0, 0)
    assert md.dynamic_parameters(model).shape == (0,)
    assert md.model_with_parameters(model, []).njoints == 0


# ---- bad input ------------------------------------------------------------------------------------------

def test_bad_states_are_refused():
    model = reference("aau_arm")[0]
    q, z = np.zeros(5), np.zeros(5)
    with pytest.raises(md.InputError, match=r"v has shape \(4,\)"):
        md.joint_torque_regressor(model, q, z[:4], z)
    with pytest.raises(md.InputError, match=r"a has shape \(2, 5\) but q has \(5,\)"):
        md.joint_torque_regressor(model, q, z, np.zeros((2, 5)))
    for k, name in enumerate(("q", "v", "a")):
        bad = [q.copy(), z.copy(), z.copy()]
        bad[k][2] = np.nan
        with pytest.raises(md.InputError, match=rf"{name}\[2\] \(joint '{model.joint_names[2]}'\)"):
            md.joint_torque_regressor(model, *bad)
        with pytest.raises(md.InputError, match=rf"{name}\[1, 2\] \(joint '{model.joint_names[2]}'\)"):
            md.joint_torque_regressor(model, *[np.stack([x, x]) if j != k else np.stack([q * 0, x])
                                               for j, x in enumerate(bad)])
    with pytest.raises(md.InputError, match="complex"):
        md.joint_torque_regressor(model, q.astype(complex), z, z)
    with pytest.raises(md.InputError, match="must be a manipdyn Model"):
        md.joint_torque_regressor("aau_arm.urdf", q, z, z)


def test_an_overflow_is_a_numerical_error():
    model = reference("aau_arm")[0]
    with pytest.raises(md.NumericalError, match="joint_torque_regressor: the result Y"):
        md.joint_torque_regressor(model, np.zeros(5), np.full(5, 1e200), np.zeros(5))


def test_non_physical_parameters_are_refused_naming_the_body():
    model = reference("aau_arm")[0]
    pi = md.dynamic_parameters(model)
    body = model.body_names[2]
    for change, why in (({20: -1.0}, "mass -1.0 < 0"),
                        ({20: 0.0}, "mass 0 with a first moment"),
                        ({24: -5.0}, "not positive semi-definite")):
        bad = pi.copy()
        for k, x in change.items():
            bad[k] = x
        with pytest.raises(md.InputError, match=rf"pi\[20:30\] \(body '{body}'.*{why}"):
            md.model_with_parameters(model, bad)
    with pytest.raises(md.InputError, match=r"pi has shape \(49,\); expected \(50,\)"):
        md.model_with_parameters(model, pi[:-1])
    nan = pi.copy()
    nan[3] = np.inf
    with pytest.raises(md.InputError, match=r"pi\[3\] is inf"):
        md.model_with_parameters(model, nan)
    with pytest.raises(md.InputError, match="pi is None"):
        md.model_with_parameters(model, None)
    massless = pi.copy()
    massless[20:24] = 0.0                        # m = 0, h = 0: a massless body keeps its rotational inertia
    light = md.model_with_parameters(model, massless)
    assert light.mass[2] == 0 and not np.any(light.com[2])


# ---- the same source, uncompiled ------------------------------------------------------------------------

NOJIT_CASES = ["double_pendulum", "tree4", "solo12"]
PROBE = """
import json, sys
import numpy as np
sys.path[:0] = [{tests!r}, {here!r}]
import manipdyn as md
from manipdyn import _jit
import test_regressor as T
from manipdyn.validation import random_states
out = {{"nojit": _jit.NOJIT}}
for name in {names!r}:
    model = T.reference(name)[0]
    Q, V, A = random_states(model, 3, np.random.default_rng(13))
    out[name] = [md.joint_torque_regressor(model, Q, V, A).tolist(),
                 md.joint_torque_regressor(model, Q[0], V[0], A[0]).tolist()]
print(json.dumps(out))
"""



def test_uncompiled_source_gives_the_compiled_numbers():
    assert_uncompiled_equals_compiled(PROBE, __file__, NOJIT_CASES, tol=1e-14)   # measured 0 (bit-identical)
