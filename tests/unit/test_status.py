"""Every kernel speaks one status convention (manipdyn/dynamics/status.py): a bad input is its state's row, a
joint is −2 − i, a non-finite result its flat index after −2 − nb; a chunk's status is read as the whole batch's.
Held here on each route's batch kernel itself (a NaN planted in one row of a batch long enough for several lane
blocks), on the two-thread path, and on the reading that turns a status back into the error."""
from __future__ import annotations

import numpy as np
import pytest
from manipdyn.paths import bundled_dir

import manipdyn as md
from manipdyn.dynamics import aba, coriolis, crba, regressor, rnea
from manipdyn.dynamics.arguments import wrench_rows
from manipdyn.dynamics.route import SHAPES, run_batch
from manipdyn.dynamics.status import OK, bad_input, bad_result, reading, shift, singular_joint

ROUTES = {"rnea": rnea.rnea, "nonlinear_effects": rnea.nonlinear_effects, "gravity_torques": rnea.gravity_torques,
          "aba": aba.aba, "forward_dynamics (cholesky)": aba.cholesky_route, "mass_matrix": crba.crba,
          "coriolis_matrix": coriolis.coriolis_matrix, "joint_torque_regressor": regressor.joint_torque_regressor}


def test_reading_and_shift_by_hand():
    nb = 5
    assert reading(OK, nb) == ("ok", -1)
    assert reading(bad_input(7), nb) == ("input", 7)
    assert reading(singular_joint(0), nb) == ("joint", 0) and reading(singular_joint(4), nb) == ("joint", 4)
    assert reading(bad_result(nb, 0), nb) == ("result", 0) and reading(bad_result(nb, 12), nb) == ("result", 12)
    # a chunk from row 100, results of 6 entries a state: state 3 → 103, entry 8 → 608, a joint stays
    assert shift(bad_input(3), 100, nb, 6) == 103
    assert reading(shift(bad_result(nb, 8), 100, nb, 6), nb) == ("result", 608)
    assert shift(singular_joint(2), 100, nb, 6) == singular_joint(2) and shift(OK, 100, nb, 6) == OK


def _batch(model, names, N, row, which):
    rng = np.random.default_rng(1)
    states = [md.random_configuration(model, rng, N) if n == "q" else rng.normal(size=(N, model.nv)) for n in names]
    states[which][row, -1] = np.nan
    return states


@pytest.mark.parametrize("call", sorted(ROUTES))
@pytest.mark.parametrize("robot", ["aau_arm.urdf", "spm.urdf", "planar_root"])
def test_a_bad_input_is_its_row_in_every_batch_kernel(call, robot):
    """On the bundled arms (the lane kernels, a bad block run state by state) and on a tree of every joint kind
    (helical, planar, universal: the scalar kernels run the whole batch)."""
    import dataclasses
    if robot == "planar_root":
        from joint_kinds import kinds_robot
        model = md.load_urdf_string(kinds_robot(robot)[0])
    else:
        model = md.load_urdf(bundled_dir() / robot)
    model = dataclasses.replace(model, constraints=()) if model.constraints else model
    r, N = ROUTES[call].route, 200                              # 4 lane blocks; the NaN in the third
    for which in range(len(r.names)):
        states = _batch(model, r.names, N, 150, which)
        ext = (*wrench_rows(model, None, "local", N, r.lanes), False) if r.wrenches else ()
        out = np.empty((N,) + model.kernel.result_shapes[SHAPES.index(r.shape)])
        arrays = model.kernel.lane_arrays if r.lanes else model.kernel.arrays
        assert r.batch.call(*arrays, *states, *ext, out, *r.tail) == bad_input(150), (call, r.names[which])
        # two threads: the second chunk's status read as the batch's
        N2 = 600
        states = _batch(model, r.names, N2, 450, which)
        ext = (*wrench_rows(model, None, "local", N2, r.lanes), False) if r.wrenches else ()
        out = np.empty((N2,) + model.kernel.result_shapes[SHAPES.index(r.shape)])
        code = run_batch(r.batch, arrays, states, ext, out, r.tail, 2, model.njoints)
        assert code == bad_input(450), (call, r.names[which])


def test_a_massless_joint_is_named_by_its_status():
    """aba on a model whose last body has no mass: status singular_joint(last), read back as SingularError
    naming that joint."""
    model = md.load_urdf(bundled_dir() / "aau_arm.urdf")
    import dataclasses
    mass, inertia = np.array(model.mass), np.array(model.inertia)
    mass[-1], inertia[-1] = 0.0, 0.0
    light = dataclasses.replace(model, mass=mass, inertia=inertia)
    q, v, tau = np.zeros(light.nq), np.zeros(light.nv), np.zeros(light.nv)
    out = np.empty(light.nv)
    code = aba.aba.route.one.call(*light.kernel.arrays, q, v, tau, out)
    assert reading(code, light.njoints) == ("joint", light.njoints - 1)
    with pytest.raises(md.SingularError, match=repr(light.joint_names[-1])):
        md.aba(light, q, v, tau)
