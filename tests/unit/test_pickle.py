"""A Model pickles as its description and is rebuilt on loading (Model.__reduce__): worker processes get the
same model, computing the same numbers bit for bit."""
import pickle
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.paths import bundled_dir


@pytest.mark.parametrize("name, root", [("aau_arm.urdf", None), ("fourbar.urdf", None), ("aau_arm.urdf", "free_flyer")])
def test_a_pickled_model_computes_the_same_numbers(name, root):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(bundled_dir() / name, **({"root_joint": root} if root else {}))
    copy = pickle.loads(pickle.dumps(model))
    assert copy is not model and copy.name == model.name and copy.q_names == model.q_names
    assert len(copy.constraints) == len(model.constraints) and dict(copy.frames).keys() == dict(model.frames).keys()
    assert not copy.mass.flags.writeable and type(copy.frames) is type(model.frames)   # as immutable as the original
    rng = np.random.default_rng(3)
    q = md.random_configuration(model, rng=rng) if root else rng.uniform(-1, 1, model.nq)
    v, a = rng.normal(size=model.nv), rng.normal(size=model.nv)
    assert np.array_equal(md.rnea(copy, q, v, a), md.rnea(model, q, v, a))
    assert np.array_equal(md.mass_matrix(copy, q), md.mass_matrix(model, q))
