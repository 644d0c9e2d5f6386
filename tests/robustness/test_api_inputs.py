"""Every public function refuses bad arguments with InputError naming the argument, before any work;
models without moving joints (nv = 0) work and return empty arrays of the documented shapes."""
import numpy as np
import pytest
from conftest import AAU, ROOT, inertial_xml, urdf
from nojit import run_probe

import manipdyn as md
from manipdyn import constraints as mc

ARM = md.load_urdf(AAU)
FOURBAR = md.load_urdf(ROOT / "urdf" / "fourbar.urdf")
N5, N3 = ARM.nv, FOURBAR.nv
Z, ZF = np.zeros(N5), np.zeros(N3)
QF = np.array([0.0, -0.94796974, -1.89593948])        # a four-bar state near the closures (assembled)

# public function -> (call with the state argument x in first place, the argument's name)
TREE = {
    "rnea": (lambda x: md.rnea(ARM, x, Z, Z), "q"),
    "rnea_terms": (lambda x: md.rnea_terms(ARM, x, Z, Z), "q"),
    "aba": (lambda x: md.aba(ARM, x, Z, Z), "q"),
    "forward_dynamics_cholesky": (lambda x: md.forward_dynamics(ARM, x, Z, Z, method="cholesky"), "q"),
    "mass_matrix": (lambda x: md.mass_matrix(ARM, x), "q"),
    "mass_matrix_lagrange": (lambda x: md.mass_matrix(ARM, x, method="lagrange"), "q"),
    "coriolis_matrix": (lambda x: md.coriolis_matrix(ARM, x, Z), "q"),
    "gravity_torques": (lambda x: md.gravity_torques(ARM, x), "q"),
    "frame_placement": (lambda x: md.frame_placement(ARM, x, "tool"), "q"),
    "frame_jacobian": (lambda x: md.frame_jacobian(ARM, x, "tool"), "q"),
    "frame_jacobian_dot": (lambda x: md.frame_jacobian_dot(ARM, x, Z, "tool"), "q"),
    "kinetic_energy": (lambda x: md.kinetic_energy(ARM, x, Z), "q"),
    "potential_energy": (lambda x: md.potential_energy(ARM, x), "q"),
    "simulate": (lambda x: md.simulate(ARM, x, Z, (0, 0.01)), "q0"),
    "rnea_v": (lambda x: md.rnea(ARM, Z, x, Z), "v"),
    "aba_tau": (lambda x: md.aba(ARM, Z, Z, x), "tau"),
    "kinetic_energy_v": (lambda x: md.kinetic_energy(ARM, Z, x), "v"),
    "joint_torque_regressor": (lambda x: md.joint_torque_regressor(ARM, x, Z, Z), "q"),
    "joint_torque_regressor_a": (lambda x: md.joint_torque_regressor(ARM, Z, Z, x), "a"),
}
CLOSED = {
    "assemble": (lambda x: md.assemble(FOURBAR, x), "q"),
    "complete_state": (lambda x: md.complete_state(FOURBAR, x, [1.0], [0.0]), "q"),
    "project": (lambda x: md.project(FOURBAR, x, ZF), "q"),
    "constrained_forward_dynamics": (lambda x: md.constrained_forward_dynamics(FOURBAR, x, ZF, ZF), "q"),
    "constrained_inverse_dynamics": (lambda x: md.constrained_inverse_dynamics(FOURBAR, x, ZF, ZF), "q"),
    "closure_terms": (lambda x: mc.closure_terms(FOURBAR, x), "q"),
    "actuation_status": (lambda x: mc.actuation_status(FOURBAR, x), "q"),
}


def bad_inputs(nv):
    """Readable id -> a bad value for a state argument of a model with nv joints."""
    return {
        "complex": np.zeros(nv) + 1j,
        "object": np.array([None] * nv, dtype=object),
        "object_floats": np.array([0.0] * nv, dtype=object),
        "string": np.array(["0"] * nv),
        "None": None,
        "ragged": [[0.0] * nv, [0.0]],
        "wrong_length": np.zeros(nv + 1),
        "scalar": 0.0,
        "3d": np.zeros((2, 2, nv)),
        "nan": np.r_[np.zeros(nv - 1), np.nan],
        "inf": np.r_[-np.inf, np.zeros(nv - 1)],
        "nan_in_batch_row": np.vstack([np.zeros(nv), np.r_[np.nan, np.zeros(nv - 1)]]),
        "masked": np.ma.masked_array(np.zeros(nv), mask=[True] + [False] * (nv - 1)),
    }


CASES = [pytest.param(call, name, bad, id=f"{fn}-{kind}")
         for table, nv in ((TREE, N5), (CLOSED, N3)) for fn, (call, name) in table.items()
         for kind, bad in bad_inputs(nv).items()]


@pytest.mark.parametrize("call,name,bad", CASES)
def test_bad_state_is_refused_naming_the_argument(call, name, bad):
    with pytest.raises(md.InputError) as exc:
        call(bad)
    assert str(exc.value).startswith(name), str(exc.value)


def test_int_and_bool_arrays_are_read_as_float():
    # independent reference: the same call on the float array
    q = np.array([1, 0, -1, 2, 0])
    assert np.array_equal(md.rnea(ARM, q, Z, Z), md.rnea(ARM, q.astype(float), Z, Z))
    # one state rounds the same in either form (the batch entries' fused multiply-adds are for batches only)
    assert np.array_equal(md.rnea_terms(ARM, q, Z, Z)["tau"], md.rnea(ARM, q.astype(float), Z, Z))
    assert np.array_equal(md.forward_dynamics(ARM, q, Z, Z, method="cholesky"),
                          md.forward_dynamics(ARM, q.astype(float), Z, Z, method="cholesky"))
    b = np.array([True, False, True, False, True])
    assert np.array_equal(md.mass_matrix(ARM, b), md.mass_matrix(ARM, b.astype(float)))


EMPTY = {   # public function -> call on a state argument x (one state or a batch)
    "rnea": lambda x: md.rnea(ARM, x, x, x),
    "rnea_f_ext": lambda x: md.rnea(ARM, x, x, x, f_ext={"tool": (np.zeros(3), np.zeros(3))}),
    "rnea_terms": lambda x: md.rnea_terms(ARM, x, x, x)["R"],
    "aba": lambda x: md.aba(ARM, x, x, x),
    "forward_dynamics_cholesky": lambda x: md.forward_dynamics(ARM, x, x, x, method="cholesky"),
    "mass_matrix": lambda x: md.mass_matrix(ARM, x),
    "coriolis_matrix": lambda x: md.coriolis_matrix(ARM, x, x),
    "gravity_torques": lambda x: md.gravity_torques(ARM, x),
    "frame_placement": lambda x: md.frame_placement(ARM, x, "tool")[1],
    "frame_jacobian_dot": lambda x: md.frame_jacobian_dot(ARM, x, x, "tool"),
    "kinetic_energy": lambda x: md.kinetic_energy(ARM, x, x),
    "simulate": lambda x: md.simulate(ARM, x, x, (0, 0.01)).q,
    "project": lambda x: md.project(FOURBAR, np.broadcast_to(QF, x.shape[:-1] + (N3,)), x[..., :N3])[0],
    "constrained_forward_dynamics": lambda x: md.constrained_forward_dynamics(
        FOURBAR, np.broadcast_to(QF, x.shape[:-1] + (N3,)), x[..., :N3], x[..., :N3])[1],
    "closure_terms": lambda x: mc.closure_terms(FOURBAR, np.broadcast_to(QF, x.shape[:-1] + (N3,)))[1],
    "joint_torque_regressor": lambda x: md.joint_torque_regressor(ARM, x, x, x),
}


@pytest.mark.parametrize("fn", list(EMPTY))
def test_empty_batch_gives_empty_result_of_the_batch_shape(fn):
    # the documented choice: N = 0 is a batch like any other; its result has the one-state shape after N
    one = np.asarray(EMPTY[fn](np.zeros(N5)))
    out = np.asarray(EMPTY[fn](np.zeros((0, N5))))
    assert out.shape == (0,) + one.shape


PROBE_EMPTY = """
import json, sys, numpy as np
sys.path[:0] = [{tests!r}, {here!r}]
from manipdyn import _jit
import test_api_inputs as T
out = {{"nojit": _jit.NOJIT}}
for name in {names!r}:
    out[name] = list(np.asarray(T.EMPTY[name](np.zeros((0, T.N5)))).shape)
print(json.dumps(out))
"""


def test_empty_batch_runs_uncompiled_too():
    # the kernels' source run as plain Python (MANIPDYN_NOJIT=1) sizes its scratch from the arrays' shapes, never
    # from a first row an empty batch does not have
    plain = run_probe(PROBE_EMPTY, __file__, list(EMPTY), True)
    assert plain["nojit"]
    for fn, call in EMPTY.items():
        assert tuple(plain[fn]) == np.asarray(call(np.zeros((0, N5)))).shape, fn


def test_empty_batch_of_guesses_in_the_iterative_solvers():
    asm = md.assemble(FOURBAR, np.zeros((0, N3)))
    assert asm.q.shape == (0, N3) and asm.residual.shape == asm.same_branch.shape == (0,)
    q, v, a, asm = md.complete_state(FOURBAR, np.zeros((0, N3)), np.zeros((0, 1)), np.zeros((0, 1)))
    assert q.shape == v.shape == a.shape == asm.q.shape == (0, N3) and asm.iterations.shape == (0,)


TOOL = (np.zeros(3), np.zeros(3))
F_EXT_BAD = {
    "list": ([("tool", TOOL)], "f_ext must be None or a dict"),
    "string": ("tool", "f_ext must be None or a dict"),
    "empty_list": ([], "f_ext must be None or a dict"),
    "value_not_pair": ({"tool": 3.0}, r"f_ext\['tool'\] must be a pair"),
    "value_triple": ({"tool": (np.zeros(3),) * 3}, r"f_ext\['tool'\] must be a pair"),
    "value_dict": ({"tool": {"f": np.zeros(3)}}, r"f_ext\['tool'\] must be a pair"),
    "value_string": ({"tool": "ab"}, r"f_ext\['tool'\] must be a pair"),
    "force_length_2": ({"tool": (np.zeros(2), np.zeros(3))}, r"f_ext\['tool'\] force has shape \(2,\)"),
    "moment_2d": ({"tool": (np.zeros(3), np.zeros((2, 3)))}, r"f_ext\['tool'\] moment has shape \(2, 3\)"),
    "force_complex": ({"tool": (np.zeros(3) + 1j, np.zeros(3))}, r"f_ext\['tool'\] force: .*complex"),
    "force_none": ({"tool": (None, np.zeros(3))}, r"f_ext\['tool'\] force is None"),
    "moment_nan": ({"tool": (np.zeros(3), np.array([0, np.nan, 0]))}, r"f_ext\['tool'\] moment\[1\] is nan"),
    "unknown_frame": ({"toool": TOOL}, r"no link or frame named 'toool'; closest: tool"),
    "frame_not_string": ({3: TOOL}, "a frame name must be a string"),
}
F_EXT_CALLS = {
    "rnea": lambda f, fr: md.rnea(ARM, Z, Z, Z, f_ext=f, f_ext_frame=fr),
    "rnea_terms": lambda f, fr: md.rnea_terms(ARM, Z, Z, Z, f_ext=f, f_ext_frame=fr),
    "aba": lambda f, fr: md.aba(ARM, Z, Z, Z, f_ext=f, f_ext_frame=fr),
    "forward_dynamics_cholesky": lambda f, fr: md.forward_dynamics(ARM, Z, Z, Z, f_ext=f, f_ext_frame=fr,
                                                                   method="cholesky"),
    "constrained_forward_dynamics": lambda f, fr: md.constrained_forward_dynamics(
        FOURBAR, QF, ZF, ZF, f_ext=None if f is None else {("coupler" if k == "tool" else k): w
                                                            for k, w in f.items()} if isinstance(f, dict) else f,
        f_ext_frame=fr),
}


@pytest.mark.parametrize("fn", list(F_EXT_CALLS))
@pytest.mark.parametrize("kind", list(F_EXT_BAD))
def test_bad_f_ext_is_refused(fn, kind):
    f, match = F_EXT_BAD[kind]
    if fn == "constrained_forward_dynamics":
        match = match.replace("tool", "coupler").replace("; closest: coupler", "")
    with pytest.raises(md.InputError, match=match):
        F_EXT_CALLS[fn](f, "local")


@pytest.mark.parametrize("fn", list(F_EXT_CALLS))
def test_bad_f_ext_frame_is_refused_even_without_f_ext(fn):
    with pytest.raises(md.InputError, match="f_ext_frame must be 'local' or 'world'"):
        F_EXT_CALLS[fn](None, "base")


def test_f_ext_batch_rows_must_match():
    Q = np.zeros((3, N5))
    with pytest.raises(md.InputError, match=r"force has shape \(2, 3\); expected \(3,\) or \(3, 3\)"):
        md.rnea(ARM, Q, Q, Q, f_ext={"tool": (np.zeros((2, 3)), np.zeros(3))})


@pytest.mark.parametrize("call", [
    pytest.param(lambda: md.frame_placement(ARM, Z, "tol"), id="frame_placement"),
    pytest.param(lambda: md.frame_jacobian(ARM, Z, "tol"), id="frame_jacobian"),
    pytest.param(lambda: md.frame_jacobian_dot(ARM, Z, Z, "tol"), id="frame_jacobian_dot"),
])
def test_unknown_frame_lists_close_names(call):
    with pytest.raises(md.InputError, match="no link or frame named 'tol'; closest: tool"):
        call()


@pytest.mark.parametrize("call,match", [
    pytest.param(lambda: md.rnea("urdf/aau_arm.urdf", Z, Z, Z), "model must be a manipdyn Model", id="model_path"),
    pytest.param(lambda: md.rnea(ARM, Z, np.zeros((2, N5)), Z), r"v has shape \(2, 5\) but q has \(5,\)",
                 id="mixed_shapes"),
    pytest.param(lambda: md.frame_jacobian(ARM, Z, "tool", reference=None), "reference must be", id="reference"),
    pytest.param(lambda: md.mass_matrix(ARM, Z, method="cholesky"), "method must be", id="mm_method"),
    pytest.param(lambda: md.forward_dynamics(ARM, Z, Z, Z, method=None), "method must be", id="fd_method"),
    pytest.param(lambda: md.assemble(FOURBAR, QF, fixed="j1_crank"), "must be a list of joint names",
                 id="fixed_string"),
    pytest.param(lambda: md.assemble(FOURBAR, QF, fixed=["j1_crnk"]), "closest: j1_crank", id="fixed_unknown"),
    pytest.param(lambda: md.assemble(FOURBAR, QF, tol=np.nan), "tol is nan", id="assemble_tol"),
    pytest.param(lambda: md.assemble(FOURBAR, QF, max_iter=2.5), "max_iter must be an integer", id="max_iter"),
    pytest.param(lambda: md.complete_state(FOURBAR, QF, [1.0, 2.0], [0.0]), r"v_act has shape \(2,\)",
                 id="v_act_length"),
    pytest.param(lambda: md.complete_state(FOURBAR, QF, [1.0], [np.inf]), r"a_act\[0\] is inf", id="a_act_inf"),
    pytest.param(lambda: md.complete_state(FOURBAR, QF, [1j], [0.0]), "v_act: .*complex", id="v_act_complex"),
    pytest.param(lambda: md.project(FOURBAR, QF, ZF, max_iter=-1), "max_iter is -1", id="project_max_iter"),
    pytest.param(lambda: md.constrained_forward_dynamics(FOURBAR, QF, ZF, ZF, baumgarte=(1.0, np.nan)),
                 r"baumgarte\[1\] is nan", id="baumgarte_nan"),
    pytest.param(lambda: md.constrained_inverse_dynamics(FOURBAR, QF, ZF, ZF, actuated=["nope"]),
                 "no moving joint named 'nope'", id="actuated_unknown"),
    pytest.param(lambda: mc.rank_report(FOURBAR, np.zeros((4, N3))), r"J has shape \(4, 3\)", id="rank_shape"),
    pytest.param(lambda: mc.rank_report(FOURBAR, np.full((5, N3), np.nan)), r"J\[0, 0\] is nan", id="rank_nan"),
    pytest.param(lambda: mc.independent_rows(np.zeros(3)), r"J has shape \(3,\)", id="independent_rows_1d"),
    pytest.param(lambda: mc.closure_terms(FOURBAR, QF, np.zeros(2)), r"v has shape \(2,\)", id="closure_v"),
])
def test_other_bad_arguments(call, match):
    with pytest.raises(md.InputError, match=match):
        call()


# --- models without moving joints: everything works and returns empty arrays ---------------------------
FIXED = md.load_urdf_string(urdf({"base": "", "a": inertial_xml(1.0, I=(1, 1, 1, 0, 0, 0))},
                                 [("f", "fixed", "base", "a", (0, 0, 1), (0, 0, 0), None)], name="fixed_only"))
E = np.zeros(0)
NV0 = {
    "rnea": (lambda q: md.rnea(FIXED, q, q, q), (0,)),
    "rnea_f_ext": (lambda q: md.rnea(FIXED, q, q, q, f_ext={"a": (np.ones(3), np.ones(3))}), (0,)),
    "rnea_terms": (lambda q: md.rnea_terms(FIXED, q, q, q)["tau"], (0,)),
    "aba": (lambda q: md.aba(FIXED, q, q, q), (0,)),
    "forward_dynamics_cholesky": (lambda q: md.forward_dynamics(FIXED, q, q, q, method="cholesky"), (0,)),
    "mass_matrix": (lambda q: md.mass_matrix(FIXED, q), (0, 0)),
    "mass_matrix_lagrange": (lambda q: md.mass_matrix(FIXED, q, method="lagrange"), (0, 0)),
    "coriolis_matrix": (lambda q: md.coriolis_matrix(FIXED, q, q), (0, 0)),
    "gravity_torques": (lambda q: md.gravity_torques(FIXED, q), (0,)),
    "frame_jacobian": (lambda q: md.frame_jacobian(FIXED, q, "a"), (6, 0)),
    "frame_jacobian_dot": (lambda q: md.frame_jacobian_dot(FIXED, q, q, "a", reference="local"), (6, 0)),
    "kinetic_energy": (lambda q: md.kinetic_energy(FIXED, q, q), ()),
    "potential_energy": (lambda q: md.potential_energy(FIXED, q), ()),
    "simulate": (lambda q: md.simulate(FIXED, q, q, (0, 0.01)).q, (11, 0)),
    "constrained_forward_dynamics": (lambda q: md.constrained_forward_dynamics(FIXED, q, q, q)[0], (0,)),
    "closure_terms": (lambda q: mc.closure_terms(FIXED, q)[1], (0, 0)),
    "joint_torque_regressor": (lambda q: md.joint_torque_regressor(FIXED, q, q, q), (0, 0)),
}


@pytest.mark.parametrize("batch", [False, True], ids=["one", "batch3"])
@pytest.mark.parametrize("fn", list(NV0))
def test_model_without_moving_joints_works(fn, batch):
    call, shape = NV0[fn]
    out = np.asarray(call(np.zeros((3, 0)) if batch else E))
    want = ((3,) + shape if fn != "simulate" else (3,) + shape) if batch else shape
    assert out.shape == want and np.all(np.isfinite(out))


def test_model_without_moving_joints_frame_and_simulation_values():
    # the URDF places link a at z = 1 m, and there is nothing to move
    R, p = md.frame_placement(FIXED, E, "a")
    assert np.array_equal(R, np.eye(3)) and np.array_equal(p, [0.0, 0.0, 1.0])
    assert md.kinetic_energy(FIXED, E, E) == 0.0
    r = md.simulate(FIXED, E, E, (0, 0.01), integrator="adaptive")
    assert r.q.shape[1] == 0 and r.t[-1] == 0.01
    asm = md.assemble(FIXED, E, fixed=[])
    assert asm.q.shape == (0,) and asm.residual == 0.0
    with pytest.raises(md.InputError, match="no actuated joints"):
        md.assemble(FIXED, E)
