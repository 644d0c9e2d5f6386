"""``out=``: the dynamics calls write their result into a caller's array (dynamics/route.py; the check:
``arguments.check_out``). Held to Pinocchio on one state and on a batch (split over threads, into an array of any
memory layout) for trees of every joint kind, on the lane steps and off them; one state's ``out`` may be one of its
own inputs (its kernels read every input before they write); a batch's may not, and a wrong ``out`` is refused by
name. Measured (this VM): the results equal those without ``out=`` bit for bit; against Pinocchio ≤ 2e-15."""
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, err
from joint_kinds import kinds_robot

import manipdyn as md
from manipdyn.validation.reference import Reference

N, TOL = 300, 1e-12          # N: two chunks of a two-thread batch (route.MIN_CHUNK = 128)


def sym(M):
    return np.triu(M) + np.triu(M, 1).T


def _robot(name):
    """(model, Pinocchio model, q → Pinocchio's q, states Q, V, A)."""
    rng = np.random.default_rng(3)
    if name == "aau_arm":
        model = md.load_urdf(AAU)
        ref = Reference(model, AAU)
        pm, to_pin = ref.pm, ref.to_pin_q
    else:
        text, pm = kinds_robot(name, 1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = md.load_urdf_string(text, source=f"{name}.urdf")
        to_pin = np.asarray
    Q = md.random_configuration(model, rng, N)
    return model, pm, to_pin, Q, rng.normal(0, 2, (N, model.nv)), rng.normal(0, 5, (N, model.nv))


# call name → (ours(model, q, v, a, **kw), Pinocchio's (pm, pd, q, v, a) or None: equal to the call without out=;
# the Coriolis matrix: C q̇ against Pinocchio's h − g, as test_joint_kinds — C itself is not unique)
CALLS = {
    "rnea": (lambda m, q, v, a, **k: md.rnea(m, q, v, a, **k), pin.rnea),
    "nonlinear_effects": (lambda m, q, v, a, **k: md.nonlinear_effects(m, q, v, **k),
                          lambda pm, pd, q, v, a: pin.nonLinearEffects(pm, pd, q, v)),
    "gravity_torques": (lambda m, q, v, a, **k: md.gravity_torques(m, q, **k),
                        lambda pm, pd, q, v, a: pin.computeGeneralizedGravity(pm, pd, q)),
    "aba": (lambda m, q, v, a, **k: md.aba(m, q, v, a, **k), pin.aba),
    "forward_dynamics cholesky": (lambda m, q, v, a, **k: md.forward_dynamics(m, q, v, a, method="cholesky", **k),
                                  pin.aba),
    "mass_matrix": (lambda m, q, v, a, **k: md.mass_matrix(m, q, **k), lambda pm, pd, q, v, a: sym(pin.crba(pm, pd, q))),
    "mass_matrix lagrange": (lambda m, q, v, a, **k: md.mass_matrix(m, q, method="lagrange", **k),
                             lambda pm, pd, q, v, a: sym(pin.crba(pm, pd, q))),
    "coriolis_matrix": (lambda m, q, v, a, **k: md.coriolis_matrix(m, q, v, **k),
                        lambda pm, pd, q, v, a: pin.nonLinearEffects(pm, pd, q, v) - pin.computeGeneralizedGravity(pm, pd, q)),
    "joint_torque_regressor": (lambda m, q, v, a, **k: md.joint_torque_regressor(m, q, v, a, **k), None),
}
ROBOTS = ("aau_arm", "screw_floating", "planar_root")     # the lane steps; every kind but planar; off the lanes


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    return _robot(request.param)


@pytest.mark.parametrize("name", CALLS)
def test_out_holds_pinocchios_numbers(robot, name):
    model, pm, to_pin, Q, V, A = robot
    ours, theirs = CALLS[name]
    pd = pm.createData()
    fresh = ours(model, Q, V, A, threads=2)
    big = np.full((2 * N,) + fresh.shape[:0:-1], np.nan)           # every other row, each one transposed
    out = big[::2].transpose(0, *range(fresh.ndim - 1, 0, -1))
    assert out.shape == fresh.shape and not out.flags.c_contiguous
    assert ours(model, Q, V, A, threads=2, out=out) is out
    assert np.array_equal(out, fresh) and np.isnan(big[1::2]).all()   # its rows only, the numbers of a new array
    one = np.empty(fresh.shape[1:])
    for s in (0, 150, N - 1):
        assert ours(model, Q[s], V[s], A[s], out=one) is one
        assert np.array_equal(one, ours(model, Q[s], V[s], A[s]))
        if theirs is not None:
            ref = theirs(pm, pd, to_pin(Q[s]), V[s], A[s])
            mine = (out[s], one) if name != "coriolis_matrix" else (out[s] @ V[s], one @ V[s])
            assert err(mine[0], ref) <= TOL and err(mine[1], ref) <= TOL, (name, s)


@pytest.mark.parametrize("name", ["rnea", "aba", "forward_dynamics cholesky", "nonlinear_effects", "gravity_torques"])
def test_one_states_out_may_be_its_own_input(robot, name):
    """The one-state kernels read every input before they write: out = v (or q, a, τ) gives the same numbers."""
    model, _, _, Q, V, A = robot
    ours = CALLS[name][0]
    want = ours(model, Q[5], V[5], A[5])
    for j in ([0] if model.nq == model.nv else []) + [1, 2]:        # (q: when it has nv entries)
        x = [Q[5].copy(), V[5].copy(), A[5].copy()]
        got = ours(model, *x, out=x[j])
        assert got is x[j] and np.array_equal(got, want), (name, j)
    tip = model.body_names[-1]
    if name in ("rnea", "aba"):                                      # one state with one wrench: its own entry
        f = {tip: (np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.4]))}
        want = ours(model, Q[5], V[5], A[5], f_ext=f)
        v = V[5].copy()
        assert np.array_equal(ours(model, Q[5], v, A[5], f_ext=f, out=v), want)


def test_a_wrong_out_is_refused_by_name():
    model, _, _, Q, V, A = _robot("aau_arm")
    nv = model.nv
    ro = np.empty(nv)
    ro.flags.writeable = False
    for bad, why in ((np.empty(nv + 1), r"an array of shape \(6,\)"), (np.empty((1, nv)), r"an array of shape \(1, 5\)"),
                     (np.empty(nv, np.float32), "an array of dtype float32"), ([0.0] * nv, "a builtins.list"),
                     (ro, "a read-only array"), (np.empty(nv).view(np.recarray), r"a numpy.rec.recarray")):
        for call in (lambda: md.rnea(model, Q[0], V[0], A[0], out=bad),
                     lambda: md.rnea(model, list(Q[0]), V[0], A[0], out=bad),        # the checked path
                     lambda: md.aba(model, Q[0], V[0], A[0], f_ext={"link5": (np.ones(3), np.ones(3))}, out=bad)):
            with pytest.raises(md.InputError, match=r"(rnea|aba): out must be a writeable float64 numpy.ndarray of "
                                                    rf"shape \(5,\) \(room for (tau|q̈)\), not {why}$"):
                call()
    with pytest.raises(md.InputError, match=r"mass_matrix: out must be .* shape \(300, 5, 5\) \(room for M\), not an "
                                            r"array of shape \(300, 5\)"):
        md.mass_matrix(model, Q, out=np.empty((N, nv)))
    with pytest.raises(md.InputError, match="mass_matrix: out must .* shape \\(5, 5\\)"):
        md.mass_matrix(model, Q[0], method="lagrange", out=np.empty((nv, nv + 1)))
    for out in (V, V[::-1], A):
        with pytest.raises(md.InputError, match="rnea: out shares memory with an input array of the batch"):
            md.rnea(model, Q, V, A, out=out)
    with pytest.raises(md.InputError, match="aba: out shares memory"):
        md.aba(model, Q, V, A, out=A, f_ext={"link5": (np.ones(3), np.ones(3))})
    with pytest.raises(md.InputError, match=r"q\[3, 1\]"):                      # a bad state, as without out=
        bad = Q.copy()
        bad[3, 1] = np.nan
        md.rnea(model, bad, V, A, out=np.empty((N, nv)))


def test_out_without_moving_joints_and_on_a_mimic_model(tmp_path):
    from conftest import inertial_xml, urdf
    still = md.load_urdf_string(urdf({"base": "", "a": inertial_xml(1.0)}, [("j", "fixed", "base", "a", (0, 0, 0),
                                                                               (0, 0, 0), (0, 0, 1))]))
    out = np.full((3, 0), 7.0)
    assert md.rnea(still, np.zeros((3, 0)), np.zeros((3, 0)), np.zeros((3, 0)), out=out) is out
    text = urdf({"base": "", "a": inertial_xml(1.0, (0, 0, 0.1), (0.1, 0.1, 0.1, 0, 0, 0)),
                 "b": inertial_xml(2.0, (0.1, 0, 0), (0.1, 0.2, 0.1, 0, 0, 0))},
                [("j1", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
                 ("j2", "revolute", "a", "b", (0, 0, 0.2), (0, 0, 0), (0, 1, 0))])
    text = text.replace('<joint name="j2" type="revolute">',
                        '<joint name="j2" type="revolute"><mimic joint="j1" multiplier="-2" offset="0.1"/>')
    path = tmp_path / "mimic.urdf"
    path.write_text(text)
    mm = md.load_urdf(path, mimic=True)
    assert isinstance(mm, md.MimicModel) and mm.nv == 1
    q, v, a = np.array([0.3]), np.array([-0.7]), np.array([1.1])
    for f in (lambda **k: md.rnea(mm, q, v, a, **k), lambda **k: md.mass_matrix(mm, q, **k),
              lambda **k: md.aba(mm, q, v, a, **k)):
        want = f()
        out = np.empty_like(want)
        assert f(out=out) is out and np.array_equal(out, want)
    with pytest.raises(md.InputError, match=r"shape \(1,\)"):
        md.rnea(mm, q, v, a, out=np.empty(2))


def test_dask_states_refuse_out():
    da = pytest.importorskip("dask.array")
    model, _, _, Q, V, A = _robot("aau_arm")
    with pytest.raises(md.InputError, match="rnea: out= with Dask arrays of states is not supported"):
        md.rnea(model, da.from_array(Q, chunks=100), V, A, out=np.empty((N, model.nv)))
