"""Property tests (hypothesis): random valid trees agree with Pinocchio; random invalid input raises
only manipdyn errors. 200+ examples per property in CI (fixed derandomized seed)."""
import numpy as np
import pinocchio as pin
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import manipdyn as md
from manipdyn.validation import error

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
names = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_0123456789", min_size=1, max_size=6)
finite = st.floats(-1.0, 1.0, allow_nan=False)


@st.composite
def trees(draw):
    """URDF text of a random tree: 1..30 moving joints (revolute, continuous, prismatic), some fixed."""
    n = draw(st.integers(1, 30))
    jnames = draw(st.lists(names, min_size=n, max_size=n, unique=True))
    links, joints = ['<link name="base"/>'], []
    for k in range(n):
        parent = "base" if k == 0 else f"L{draw(st.integers(-1, k - 1)) % k}" if k else "base"
        if draw(st.booleans()) and k > 0:
            parent = "base"
        kind = draw(st.sampled_from(["revolute", "continuous", "prismatic", "fixed"]))
        m = draw(st.one_of(st.just(0.0), st.floats(1e-3, 5.0)))   # extreme values: tests/hard
        d = np.array([draw(st.floats(0.01, 1.0)) for _ in range(3)])
        Ixx, Iyy, Izz = d[1] + d[2], d[0] + d[2], d[0] + d[1]          # physical principal moments
        links.append(f'<link name="L{k}"><inertial><origin xyz="{draw(finite)} {draw(finite)} {draw(finite)}" '
                     f'rpy="{draw(finite)} {draw(finite)} {draw(finite)}"/><mass value="{m}"/>'
                     f'<inertia ixx="{Ixx * m / 10}" iyy="{Iyy * m / 10}" izz="{Izz * m / 10}" ixy="0" ixz="0" '
                     f'iyz="0"/></inertial></link>')
        axis = [draw(finite) for _ in range(3)]
        if np.linalg.norm(axis) < 0.1:
            axis = [0.0, 0.0, 1.0]
        axis = np.array(axis) / np.linalg.norm(axis)                 # Pinocchio expects unit axes
        lim = '<limit lower="-1" upper="1" effort="1" velocity="1"/>' if kind in ("revolute", "prismatic") else ""
        joints.append(f'<joint name="{jnames[k]}" type="{kind}"><parent link="{parent}"/><child link="L{k}"/>'
                      f'<origin xyz="{draw(finite)} {draw(finite)} {draw(finite)}" rpy="{draw(finite)} '
                      f'{draw(finite)} {draw(finite)}"/><axis xyz="{float(axis[0])!r} {float(axis[1])!r} {float(axis[2])!r}"/>{lim}</joint>')
    return '<?xml version="1.0"?><robot name="random">' + "".join(links + joints) + "</robot>"


def _pin_q(pm, q):
    pq = np.zeros(pm.nq)
    for i in range(pm.njoints - 1):
        jm = pm.joints[i + 1]
        pq[jm.idx_q:jm.idx_q + jm.nq] = (np.cos(q[i]), np.sin(q[i])) if jm.nq == 2 else q[i]
    return pq


@SETTINGS
@given(trees(), st.integers(0, 2**31 - 1))
def test_random_tree_agrees_with_pinocchio(text, seed):
    model = md.load_urdf_string(text)
    pm = pin.buildModelFromXML(text)
    pd = pm.createData()
    assert model.joint_names == tuple(pm.names[1:])
    if model.nv == 0:
        return
    rng = np.random.default_rng(seed)
    q, v, a = rng.uniform(-np.pi, np.pi, model.nv), rng.normal(0, 2, model.nv), rng.normal(0, 5, model.nv)
    pq = _pin_q(pm, q)
    assert error(md.rnea(model, q, v, a), pin.rnea(pm, pd, pq, v, a)) <= 1e-12
    M = pin.crba(pm, pd, pq)
    assert error(md.mass_matrix(model, q), M) <= 1e-12
    if np.linalg.eigvalsh(M)[0] > 1e-9 * np.abs(M).max():            # forward dynamics needs M > 0
        tau = rng.normal(0, 5, model.nv)
        assert error(md.aba(model, q, v, tau), pin.aba(pm, pd, pq, v, tau)) <= 1e-12 * np.linalg.cond(M)


GOOD = ('<?xml version="1.0"?><robot name="r"><link name="b"/><link name="a"><inertial><origin xyz="0 0 0.1" '
        'rpy="0 0 0"/><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
        '</inertial></link><joint name="j" type="revolute"><parent link="b"/><child link="a"/><origin '
        'xyz="0 0 0.2" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
        '</joint></robot>')


@SETTINGS
@given(st.integers(0, len(GOOD) - 1), st.integers(0, 40), st.text(max_size=8))
def test_mangled_urdf_raises_only_manipdyn_errors(start, length, insert):
    text = GOOD[:start] + insert + GOOD[start + length:]
    try:
        md.load_urdf_string(text)
    except md.ManipdynError:
        pass


@SETTINGS
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4), st.integers(0, 3))
def test_bad_arrays_raise_only_input_errors(values, ndim):
    model = md.load_urdf_string(GOOD)
    flat = np.array(values, dtype=float)           # 0-D, 1-D (k,), 2-D (k, 1) or 3-D (1, k, 1) arrays
    x = [flat[0] if flat.size else flat, flat, flat.reshape(-1, 1), flat.reshape(1, -1, 1)][ndim]
    x = np.asarray(x)
    # valid: one state (1,) or a batch (N, 1), N = 0 included (an empty batch gives an empty result)
    ok = x.ndim in (1, 2) and x.shape[-1:] == (1,) and bool(np.all(np.isfinite(x)))
    try:
        md.rnea(model, x, x, x)
        md.aba(model, x, x, x)
        assert ok
    except md.InputError:
        assert not ok
    except md.NumericalError:       # finite but so large that ω² overflows (|x| ≳ 1e154): refused, not NaN
        assert ok and np.max(np.abs(x)) > 1e150


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(trees(), st.integers(0, 2**31 - 1))
def test_random_tree_dynamics_derivatives_agree_with_pinocchio(text, seed):
    # analytic ∂τ/∂q, ∂τ/∂q̇, ∂τ/∂q̈ (dynamics/derivatives.py) against pin.computeRNEADerivatives, massless
    # bodies and continuous joints included. (The binding returns views into the data: keep pd alive.)
    model = md.load_urdf_string(text)
    pm = pin.buildModelFromXML(text)
    pd = pm.createData()
    if model.nv == 0:
        return
    rng = np.random.default_rng(seed)
    q, v, a = rng.uniform(-np.pi, np.pi, model.nv), rng.normal(0, 2, model.nv), rng.normal(0, 5, model.nv)
    theirs = [np.array(x) for x in pin.computeRNEADerivatives(pm, pd, _pin_q(pm, q), v, a)]
    for x, y in zip(md.rnea_derivatives(model, q, v, a), theirs):
        assert error(x, y) <= 5e-13                                  # measured ≤ 7.5e-15 over the 60 examples
