"""The one-state fast paths (arguments.fast_shape, configuration's, check_out) hand a kernel only what it reads as
declared — float64 arrays of the model's shapes — and everything else goes through the checked path with the same
numbers: other dtypes, strided views, a model changed after an earlier call (its own kernel arrays, never a stale
one)."""
import dataclasses
import warnings

import numpy as np
import pytest

from conftest import AAU

import manipdyn as md
from manipdyn.validation import random_states

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    MODEL = md.load_urdf(AAU)
TIP = MODEL.body_names[-1]
CALLS = {
    "rnea": lambda m, q, v, a: md.rnea(m, q, v, a),
    "aba": lambda m, q, v, a: md.aba(m, q, v, a),
    "mass_matrix": lambda m, q, v, a: md.mass_matrix(m, q),
    "gravity_torques": lambda m, q, v, a: md.gravity_torques(m, q),
    "nonlinear_effects": lambda m, q, v, a: md.nonlinear_effects(m, q, v),
    "frame_placement": lambda m, q, v, a: np.concatenate([x.ravel() for x in md.frame_placement(m, q, TIP)]),
    "frame_jacobian": lambda m, q, v, a: md.frame_jacobian(m, q, TIP),
    "integrate": lambda m, q, v, a: md.integrate(m, q, v),
    "difference": lambda m, q, v, a: md.difference(m, q, a),
    "normalize": lambda m, q, v, a: md.normalize(m, q),
}


@pytest.mark.parametrize("dtype", [np.float32, np.int64])
@pytest.mark.parametrize("name", sorted(CALLS))
def test_another_dtype_gives_the_float64_numbers(name, dtype):
    Q, V, A = random_states(MODEL, 1, np.random.default_rng(5))
    q, v, a = (3 * Q[0]).astype(dtype), (3 * V[0]).astype(dtype), (3 * A[0]).astype(dtype)
    want = CALLS[name](MODEL, *(x.astype(np.float64) for x in (q, v, a)))
    assert np.array_equal(CALLS[name](MODEL, q, v, a), want)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_strided_and_read_only_views_give_the_numbers_of_contiguous_arrays(name):
    Q, V, A = random_states(MODEL, 2, np.random.default_rng(6))
    wide = [np.repeat(x[0], 2) for x in (Q, V, A)]                      # every other entry: a strided view
    views = [x[::2] for x in wide]
    for x in views:
        x.flags.writeable = False
    assert np.array_equal(CALLS[name](MODEL, *views), CALLS[name](MODEL, Q[0], V[0], A[0]))


def test_a_changed_model_is_computed_with_its_own_arrays():
    """A model made from another after calls on it (dataclasses.replace: heavier links) gives its own numbers in
    one-state calls, not the first model's."""
    Q, V, A = random_states(MODEL, 1, np.random.default_rng(7))
    q, v, a = Q[0], V[0], A[0]
    before = md.rnea(MODEL, q, v, a)
    heavy = dataclasses.replace(MODEL, mass=2 * MODEL.mass, inertia=2 * MODEL.inertia)
    assert np.allclose(md.rnea(heavy, q, v, a), 2 * before, rtol=1e-13, atol=0)   # τ is linear in the inertias
    assert np.array_equal(md.rnea(heavy, q, v, a), md.rnea(heavy, Q, V, A)[0]) or \
        np.allclose(md.rnea(heavy, q, v, a), md.rnea(heavy, Q, V, A)[0], rtol=1e-14, atol=0)
    assert np.allclose(md.mass_matrix(heavy, q), 2 * md.mass_matrix(MODEL, q), rtol=1e-13, atol=0)
    assert np.array_equal(md.rnea(MODEL, q, v, a), before)                   # the first model unchanged


@pytest.mark.parametrize("which", [0, 1, 2])
@pytest.mark.parametrize("name", ["rnea", "aba", "nonlinear_effects", "frame_jacobian"])
def test_one_argument_of_another_dtype_gives_the_float64_numbers(name, which):
    """One of q, v, a of another dtype (the others float64): each is checked on its own before the kernel."""
    Q, V, A = random_states(MODEL, 1, np.random.default_rng(8))
    x = [3 * Q[0], 3 * V[0], 3 * A[0]]
    x[which] = x[which].astype(np.float32)
    want = CALLS[name](MODEL, *(y.astype(np.float64) for y in x))
    assert np.array_equal(CALLS[name](MODEL, *x), want)


@pytest.mark.parametrize("name, which", [("rnea", "q"), ("rnea", "v"), ("rnea", "a"), ("aba", "q"), ("aba", "v"),
                                         ("aba", "tau"), ("nonlinear_effects", "q"), ("nonlinear_effects", "v")])
def test_one_argument_of_another_length_is_named(name, which):
    """One of q, v, a one entry short (the others right): an InputError naming it, never a kernel reading past it."""
    Q, V, A = random_states(MODEL, 1, np.random.default_rng(9))
    x = [Q[0], V[0], A[0]]
    k = ("q", "v").index(which) if which in ("q", "v") else 2
    x[k] = x[k][:-1]
    with pytest.raises(md.InputError, match=rf"^{which} has shape \({x[k].size},\)"):
        CALLS[name](MODEL, *x)


@pytest.mark.parametrize("kinds", ["HHB", "B"])
def test_a_model_ending_in_a_ball_joint_takes_the_one_state_kernels(kinds, tmp_path):
    """The one-state kernels check the arrays' lengths against the model's nq, nv, counted from its last joint in q
    order: with a ball joint there (4 entries of q, 3 of v), one state gives the batch's numbers."""
    from ball_models import random_tree
    path = tmp_path / "tree.xml"
    path.write_text(random_tree(3, kinds))
    model = md.load_mjcf(path)
    assert model.kind[-1] == 3 and model.nq == model.nv + kinds.count("B")
    Q, V, A = random_states(model, 3, np.random.default_rng(10))
    for name in ("rnea", "aba", "mass_matrix", "gravity_torques", "nonlinear_effects"):
        batch = CALLS[name](model, Q, V, A)
        for s in range(3):
            assert np.allclose(CALLS[name](model, Q[s], V[s], A[s]), batch[s], rtol=1e-12, atol=1e-12), (name, s)


@pytest.mark.parametrize("name, which", [("integrate", "q"), ("integrate", "v"), ("difference", "q0"),
                                         ("difference", "q1"), ("normalize", "q")])
def test_a_configuration_argument_of_another_length_is_named(name, which):
    """The one-state configuration kernels check the lengths (Python checks types and dimensions): one argument
    one entry short is named by the checked path, never read past its end."""
    Q, V, _ = random_states(MODEL, 2, np.random.default_rng(12))
    args = {"integrate": {"q": Q[0], "v": V[0]}, "difference": {"q0": Q[0], "q1": Q[1]}, "normalize": {"q": Q[0]}}[name]
    args[which] = args[which][:-1]
    with pytest.raises(md.InputError, match=rf"^{which} has shape \({args[which].size},\)"):
        getattr(md, name)(MODEL, *args.values())
