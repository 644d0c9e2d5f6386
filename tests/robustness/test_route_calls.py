"""The routed public calls (dynamics/route.py) take their arguments as their signatures say: the third state by
its name, and a wrong count or a stray keyword as a TypeError naming the call, as Python's own would."""
import inspect

import numpy as np
import pytest

import manipdyn as md
from manipdyn.errors import InputError
from manipdyn.paths import bundled_dir

ARM = md.load_urdf(bundled_dir() / "aau_arm.urdf")
RNG = np.random.default_rng(5)
Q, V, T = RNG.uniform(-1, 1, ARM.nq), RNG.normal(size=ARM.nv), RNG.normal(size=ARM.nv)


def test_signatures_and_keywords_are_the_public_ones():
    assert list(inspect.signature(md.aba).parameters) == ["model", "q", "v", "tau", "f_ext", "f_ext_frame", "threads",
                                                        "out"]
    assert list(inspect.signature(md.gravity_torques).parameters) == ["model", "q", "threads", "out"]
    by_name = md.aba(ARM, q=Q, v=V, tau=T)
    assert np.array_equal(by_name, md.aba(ARM, Q, V, T))                      # the same compiled code
    assert np.array_equal(md.rnea(ARM, Q, V, a=T), md.rnea(ARM, Q, V, T))
    assert np.array_equal(md.forward_dynamics(ARM, Q, V, tau=T, method="cholesky"),
                          md.forward_dynamics(ARM, Q, V, T, method="cholesky"))


@pytest.mark.parametrize("call, message", [
    (lambda: md.aba(ARM, Q, V), "aba() takes the model and 3 state arrays"),
    (lambda: md.gravity_torques(ARM, Q, V), "gravity_torques() takes the model and 1 state array "),
    (lambda: md.rnea(ARM, Q, V, T, tau=T), "rnea() got an unexpected keyword argument 'tau'"),
    (lambda: md.aba(ARM, Q, V, T, tau=T), "aba() got an unexpected keyword argument 'tau'"),
    (lambda: md.nonlinear_effects(ARM, Q, V, f_ext={}), "nonlinear_effects() takes no external wrenches"),
    (lambda: md.mass_matrix(ARM, Q, Q), "mass_matrix method must be"),       # an array as the method
    (lambda: md.forward_dynamics(ARM, Q, V, T, method=V), "forward_dynamics method must be"),
])
def test_wrong_arguments_are_refused_by_name(call, message):
    with pytest.raises((TypeError, InputError)) as exc:
        call()
    assert message in str(exc.value)
