"""The lane kernels' model: every 1-dof body frame turned so that its joint axis is z (kernel_form.z_aligned,
Model.kernel.lane_arrays; docs/design.md §4c). Held to the model itself through the derivative kernel, which takes
any axis: the same ∂τ/∂q, ∂τ/∂q̇ and M from both forms on a tree with unaligned axes; the rotation C_i that turns e_z into the
axis; the batch routes reaching the lane steps only with that form (another raises)."""
import numpy as np
import pytest
from conftest import AAU, assert_close
from test_lanes import _tree

import manipdyn as md
from manipdyn.dynamics.lanes import on_lanes
from manipdyn.dynamics.model_arrays import unpack
from manipdyn.dynamics.derivatives import rnea_derivatives_kernel
from manipdyn.dynamics.arguments import wrench_rows
from manipdyn.kernel_form import z_turn
from manipdyn.validation import random_states


@pytest.mark.parametrize("k", [(0, 0, 1), (0, 0, -1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), "random"])
def test_z_turn_is_a_rotation_taking_z_to_the_axis(k):
    rng = np.random.default_rng(3)
    axes = [np.array(k, float)] if k != "random" else [x / np.linalg.norm(x) for x in rng.normal(size=(50, 3))]
    for a in axes:
        C = z_turn(a)
        assert np.abs(C.T @ C - np.eye(3)).max() < 1e-15 and abs(np.linalg.det(C) - 1) < 1e-15   # ≤ 4.4e-16
        assert np.abs(C[:, 2] - a).max() < 3e-16                      # C e_z = k
        if k != "random":
            assert np.array_equal(C[:, 2], a) and set(np.unique(C)) <= {-1.0, 0.0, 1.0}   # exact, no rounding


def _scalar(I, F, Q, V, A):
    """(∂τ/∂q, ∂τ/∂q̇, M) by the derivative kernel, which takes any axis (the world-frame recursion)."""
    D = np.empty((3,) + V.shape + V.shape[1:])
    code = rnea_derivatives_kernel(I, F, Q, V, A, np.zeros((1, 0, 6)), np.zeros(0, np.int64), np.zeros((0, 3)), False,
                                   D[0], D[1], D[2])
    assert code == -1
    return D


@pytest.mark.parametrize("name", ["aau_arm", "tree"])
def test_the_lane_form_is_the_same_model(name):
    """The derivative kernel on both forms: ∂τ/∂q, ∂τ/∂q̇ and M agree to rounding (the turn changes only what is
    written in a body's own axes), and the lane form's joint axes are exactly z."""
    model = md.load_urdf(AAU) if name == "aau_arm" else md.load_urdf_string(_tree())
    Q, V, A = random_states(model, 200, np.random.default_rng(4))
    D, Dz = _scalar(*model.kernel.arrays, Q, V, A), _scalar(*model.kernel.lane_arrays, Q, V, A)
    for k, what in enumerate(("∂τ/∂q", "∂τ/∂q̇", "M")):
        assert_close(Dz[k], D[k], 1e-14, f"{name} {what}")          # measured ≤ 1.9e-15 (0 on the AAU arm)
    mdl = unpack(*model.kernel.lane_arrays)
    assert np.array_equal(mdl.axis, np.tile([0.0, 0.0, 1.0], (model.njoints, 1)))
    assert on_lanes(mdl, model.nq)
    # the model's own arrays reach the lane steps only where every axis is z already (the AAU arm's D-H frames)
    assert on_lanes(unpack(*model.kernel.arrays), model.nq) == (name == "aau_arm")
    if name == "aau_arm":
        assert np.array_equal(model.kernel.lane_arrays[1], model.kernel.arrays[1])   # no turn: the same numbers


def test_frames_and_wrenches_in_the_lane_form_are_the_same_points():
    """A frame's placement in its body, turned into the body's z-aligned frame, is the same point and axes in the
    world: C_b (Cᵀ R, Cᵀ p) = (R, p); so is a wrench laid out for the lane kernels (``arguments.wrench_rows``)."""
    model = md.load_urdf_string(_tree(tool=True))
    k = model.kernel
    for name, (b, X) in k.frame_rows.items():
        C = k.lane_turns[b] if b >= 0 else np.eye(3)
        Xz = k.lane_frame_rows[name][1]
        assert np.abs(C @ Xz[:3] - X[:3]).max() < 1e-15 and np.abs(C @ Xz[3] - X[3]).max() < 1e-15, name  # ≤ 6.7e-16
    rng = np.random.default_rng(2)
    fx = {n: (rng.normal(size=(5, 3)), rng.normal(size=(5, 3))) for n in ("tool", "L3", "L0")}
    for axes in ("local", "world"):
        X, body, point = wrench_rows(model, fx, axes, 5)
        Xz, body_z, point_z = wrench_rows(model, fx, axes, 5, lanes=True)
        C = k.lane_turns[body]                                        # (K, 3, 3)
        assert np.array_equal(body_z, body) and np.abs(np.einsum("kij,kj->ki", C, point_z) - point).max() < 1e-15
        if axes == "local":                                           # body axes: turned; world axes: as given
            Xz = np.concatenate([np.einsum("kij,nkj->nki", C, Xz[..., :3]),
                                 np.einsum("kij,nkj->nki", C, Xz[..., 3:])], axis=2)
        assert np.abs(Xz - X).max() < 1e-14 * np.abs(X).max(), axes
