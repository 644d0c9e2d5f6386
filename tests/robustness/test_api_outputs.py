"""Results are finite or refused: NumericalError names the call, the row and the joint; gravity is checked
when a model is built; huge but representable inputs still give right numbers."""
import dataclasses

import numpy as np
import pytest
from conftest import AAU, ROOT, assert_close

import manipdyn as md
from manipdyn import constraints as mc

ARM = md.load_urdf(AAU)
FOURBAR = md.load_urdf(ROOT / "urdf" / "fourbar.urdf")
N5 = ARM.nv
Z = np.zeros(N5)
BIG = np.full(N5, 1e200)                 # ω² overflows: 1e400
TOOL_BIG = {"tool": (np.full(3, 1e308), np.full(3, 1e308))}
HUGE_I = dataclasses.replace(ARM, inertia=np.repeat(np.eye(3)[None] * 1e308, ARM.njoints, 0))  # composites overflow

OVERFLOW = {
    "rnea": lambda: md.rnea(ARM, Z, BIG, Z),
    "rnea_f_ext": lambda: md.rnea(ARM, Z, BIG, Z, f_ext=TOOL_BIG),
    "rnea_terms": lambda: md.rnea_terms(ARM, Z, BIG, Z),
    "aba": lambda: md.aba(ARM, Z, BIG, Z),
    "aba_f_ext": lambda: md.aba(ARM, Z, Z, np.full(N5, 1e308), f_ext=TOOL_BIG),
    "aba_huge_inertia": lambda: md.aba(HUGE_I, Z, Z, Z),       # a NaN pivot of D_i: not a singular joint
    "aba_huge_inertia_batch": lambda: md.aba(HUGE_I, np.zeros((3, N5)), np.zeros((3, N5)), np.zeros((3, N5))),
    "forward_dynamics": lambda: md.forward_dynamics(ARM, Z, BIG, Z, method="cholesky"),
    "mass_matrix": lambda: md.mass_matrix(HUGE_I, Z),
    "mass_matrix_batch": lambda: md.mass_matrix(HUGE_I, np.zeros((3, N5))),
    "coriolis_matrix": lambda: md.coriolis_matrix(ARM, Z, np.full(N5, 1.7e308)),
    "kinetic_energy": lambda: md.kinetic_energy(ARM, Z, BIG),
    "frame_jacobian_dot": lambda: md.frame_jacobian_dot(ARM, Z, np.full(N5, 1e308), "tool"),
    "constrained_forward_dynamics": lambda: md.constrained_forward_dynamics(FOURBAR, np.zeros(3), np.full(3, 1e200),
                                                                            np.zeros(3)),
}
CALL_NAME = {"rnea_f_ext": "rnea", "aba_f_ext": "aba", "mass_matrix_batch": "mass_matrix", "aba_huge_inertia": "aba",
             "aba_huge_inertia_batch": "aba"}


@pytest.mark.parametrize("fn", list(OVERFLOW))
def test_overflow_raises_numerical_error_naming_the_call(fn):
    with pytest.raises(md.NumericalError, match=rf"^{CALL_NAME.get(fn, fn)}\b.*the result .* is (nan|-?inf)"):
        OVERFLOW[fn]()


@pytest.mark.parametrize("fn,call", [
    ("rnea", lambda Q, V: md.rnea(ARM, Q, V, Q)),
    ("aba", lambda Q, V: md.aba(ARM, Q, V, Q)),
    ("mass_matrix", lambda Q, V: md.mass_matrix(ARM, Q + V)),      # huge q: sin, cos stay finite
    ("rnea_terms", lambda Q, V: md.rnea_terms(ARM, Q, V, Q)),
    ("kinetic_energy", lambda Q, V: md.kinetic_energy(ARM, Q, V)),
])
def test_error_names_the_first_offending_row_and_joint(fn, call):
    Q, V = np.zeros((4, N5)), np.zeros((4, N5))
    V[2, 1] = 1e200
    if fn == "mass_matrix":
        assert np.all(np.isfinite(call(Q, V)))
        return
    with pytest.raises(md.NumericalError, match=rf"^{fn}: .*row 2.*largest input of that row: \|v\| = 1e\+200"):
        call(Q, V)


def test_numerical_error_is_a_manipdyn_arithmetic_error():
    assert issubclass(md.NumericalError, md.ManipdynError) and issubclass(md.NumericalError, ArithmeticError)
    assert "NumericalError" in md.__all__


@pytest.mark.parametrize("gravity", [[np.nan, 0, 0], [0, 0, np.inf], [0, -np.inf, 0]],
                         ids=["nan", "inf", "-inf"])
def test_non_finite_gravity_is_refused_at_load(gravity):
    with pytest.raises(md.InputError, match="gravity must be 3 finite real numbers"):
        md.load_urdf(AAU, gravity=gravity)


@pytest.mark.parametrize("gravity", [np.array([0, 0, np.nan]), np.zeros(2), np.zeros(3, complex), [0.0, 0.0, 1.0]],
                         ids=["nan", "length2", "complex", "list"])
def test_gravity_is_checked_by_every_model_constructor(gravity):
    with pytest.raises(md.InputError, match="gravity"):
        dataclasses.replace(ARM, gravity=gravity)


@pytest.mark.parametrize("scale", [1e50, 1e100, 1e150])
def test_huge_representable_rates_give_exact_quadratic_scaling(scale):
    # τ(q, s q̇, 0) − g(q) = s² (τ(q, q̇, 0) − g(q)): velocity terms are quadratic in q̇ (a physical law);
    # measured err ≤ 3e-16 at every scale
    rng = np.random.default_rng(5)
    q, v = rng.uniform(-np.pi, np.pi, N5), rng.normal(0, 2, N5)
    g = md.rnea(ARM, q, Z, Z)
    assert_close((md.rnea(ARM, q, scale * v, Z) - g) / scale**2, md.rnea(ARM, q, v, Z) - g, 1e-13, "C q̇ scaling")
    qdd = md.aba(ARM, q, scale * v, Z)
    assert np.all(np.isfinite(qdd))


def test_closure_terms_of_huge_rates_are_refused_not_nan():
    with pytest.raises(md.NumericalError, match=r"^closure_terms: the result Φ̇_q q̇"):
        mc.closure_terms(FOURBAR, np.zeros(3), np.full(3, 1e200))
