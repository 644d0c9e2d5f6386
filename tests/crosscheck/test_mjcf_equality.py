"""MJCF <equality> read as the model's closures (io/mjcf_read.py): connect, weld, joint and tendon equalities.

References: (1) the closed-chain models the project has (urdf/spm.urdf, urdf/fourbar.urdf, tests/data/loops/*),
written by to_mjcf and read back — the closures (type, bodies, frames, axes, ratio) and the constrained forward
dynamics of the URDF model (manipdyn's constrained_forward_dynamics on the URDF reader's closures, a different
reader); (2) MuJoCo 4.0 on the same MJCF text: its constrained qacc against ours, at the hardest impedance and
extrapolated to rigid constraints, exactly as tests/crosscheck/test_mjcf_export.py does (MuJoCo's softness explains
the residue, see there); (3) MuJoCo's constraint rows (efc_pos, efc_J) on hand-written files using each form of
each element (body semantic with a computed anchor and relpose at a qpos0 away from zero, explicit relpose, sites,
the world as body2, torquescale 0, joint polycoef with ref) at random configurations.

Measured (MuJoCo 4.0): the round trip's closures ≤ 2.8e-16 in every frame, point and axis (a revolute closure is
written as two connects and read back as one revolute); constrained q̈ of the read model against the URDF model's
≤ 1.3e-14 (spm_urdfplus; the §3 measure); MuJoCo's qacc against ours on the read model exactly as on the URDF model
(solimp 0.9999: 1.4e-6..1.9e-2, weld7 the largest; extrapolated to rigid constraints 3.5e-14..2.5e-5, each at least
750 times smaller); MuJoCo's efc_pos and efc_J against Φ and Φ_q (position and coupling rows) ≤ 7.3e-16, weld
orientation rows spanning the same space (sine of the largest principal angle ≤ 3.0e-15).
"""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from conftest import ROOT, err

import manipdyn as md
from manipdyn.constraints import closure_terms, complete_state, constrained_forward_dynamics
from manipdyn.errors import MJCFError
from manipdyn.io.mjcf import to_mjcf
from manipdyn.io.mjcf_read import load_mjcf_string

mujoco = pytest.importorskip("mujoco")
from test_mjcf_export import _check_closed, _fourbar_states, _spm_states  # noqa: E402

LOOPS = ROOT / "tests" / "data" / "loops"
SPEC = json.loads((LOOPS / "manifest.json").read_text())
FRAMES = 1e-14           # measured ≤ 2.8e-16 (closure frames, points, axes after the text round trip)
QDD = 1e-12              # measured ≤ 1.3e-14 (constrained q̈, read model against the URDF model)
ROWS = 5e-14             # measured ≤ 7.3e-16 (MuJoCo's efc_pos and efc_J against Φ, Φ_q)
SPAN = 1e-13             # measured ≤ 3.0e-15 (sine of the largest principal angle between the row spaces)


def _quiet(f, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*a, **kw)


def _closed_models():
    out = {"spm": (ROOT / "urdf" / "spm.urdf", None), "fourbar": (ROOT / "urdf" / "fourbar.urdf", None),
           "gear": (LOOPS / "gear_pair.urdf.in", "b")}
    for name, spec in SPEC.items():
        out[name] = (LOOPS / spec["file"], None)
    for p in sorted(LOOPS.glob("*.urdf")):                  # every loop file, listed in the manifest or not
        out.setdefault(p.stem, (p, None))
    return out


MODELS = _closed_models()


def _urdf(name):
    path, child = MODELS[name]
    if child is None:
        return _quiet(md.load_urdf, path)
    return _quiet(md.load_urdf_string, path.read_text().replace("{child}", child))


def _states(name, model):
    if name == "fourbar":
        return _fourbar_states(model)
    if name in ("spm", "spm_urdfplus"):
        return _spm_states(model)
    if name == "gear":
        return [(np.array([0.4, -1.0, 0.3]), np.array([1.5, -3.75, -0.7])), (np.array([-1.0, 2.5, 2.0]), np.zeros(3))]
    if name == "fourbar_urdfplus":
        return _fourbar_states(model)
    spec = SPEC[name]
    out = []
    for w in (0.0, 1.5):
        q, v, _, _ = complete_state(model, spec["q0"], [w] * len(spec["actuated"]), [0.0] * len(spec["actuated"]))
        out.append((q, v))
    return out


def _same_closures(a, b):
    """Largest difference between two models' closures (type, bodies and ratio must be equal)."""
    assert len(a.constraints) == len(b.constraints)
    worst = 0.0
    for c, d in zip(a.constraints, b.constraints):
        assert (c.name, c.type, c.parent, c.child) == (d.name, d.type, d.parent, d.child), (c, d)
        assert c.ratio == d.ratio
        if c.type != "coupling":
            worst = max(worst, *(err(getattr(d, k), getattr(c, k)) for k in ("pp", "pc")))
        if c.type == "fixed":
            worst = max(worst, err(d.Rp, c.Rp), err(d.Rc, c.Rc))
        if c.type == "revolute":
            worst = max(worst, err(d.axis_p, c.axis_p), err(d.axis_c, c.axis_c))
    return worst


@pytest.mark.parametrize("name", sorted(MODELS))
def test_round_trip_closures_and_constrained_qdd(name):
    model = _urdf(name)
    assert model.constraints
    back = _quiet(load_mjcf_string, to_mjcf(model))
    assert back.joint_names == model.joint_names
    frames = _same_closures(model, back)
    rng = np.random.default_rng(2)
    qdd = 0.0
    for q, v in _states(name, model):
        tau = rng.normal(size=model.nv)
        qdd = max(qdd, err(constrained_forward_dynamics(back, q, v, tau)[0],
                           constrained_forward_dynamics(model, q, v, tau)[0]))
    print(f"\n{name}: closures {frames:.1e}, constrained q̈ {qdd:.1e}")
    assert frames <= FRAMES and qdd <= QDD


@pytest.mark.parametrize("name", sorted(MODELS))
def test_read_model_against_mujoco(name):
    # the model read from the MJCF text, against MuJoCo on the same text (the softness explained as in
    # test_mjcf_export.py: the extrapolation to rigid constraints must remove it)
    model = _urdf(name)
    back = _quiet(load_mjcf_string, to_mjcf(model))
    _check_closed(name, back, _states(name, model))


# ---- each form of each element against MuJoCo's own constraint rows ------------------------------------------

BODIES = """<mujoco><compiler angle="radian"/>
  <worldbody>
    <body name="c" pos="-1 0 1"><freejoint name="root"/><inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
      <site name="sc" pos="0.1 0 0" euler="0.5 0 0"/></body>
    <body name="a" pos="0 0 1"><joint name="j1" axis="0 1 0" ref="0.3"/>
      <inertial pos="0.2 0 0" mass="1" diaginertia="0.01 0.02 0.02"/>
      <body name="a2" pos="0.5 0.1 0" euler="0.1 0.2 0.3"><joint name="j2" axis="0 0 1" ref="-0.4"/>
        <inertial pos="0.2 0 0" mass="1" diaginertia="0.01 0.02 0.02"/>
        <body name="tipA" pos="0.4 0 0.1" euler="0.3 0 0.2"/></body></body>
    <body name="b" pos="1.2 0 1"><joint name="j3" axis="1 0 0"/><joint name="j4" axis="0 1 0" pos="0 0.1 0"/>
      <inertial pos="0 0 -0.2" mass="1" diaginertia="0.02 0.02 0.01"/>
      <body name="b2" pos="0 0 -0.5"><joint name="j5" type="slide" axis="0 0 1" ref="0.05"/>
        <inertial pos="0 0 0" mass="0.5" diaginertia="0.01 0.01 0.01"/>
        <site name="sb" pos="0.1 0.2 0" euler="0 1 0"/></body>
      <body name="b3" pos="0 0 -0.5"><joint name="j6" axis="0 0 1" ref="0.25"/>
        <inertial pos="0 0 0" mass="0.5" diaginertia="0.01 0.01 0.01"/></body>
      <body name="b4" pos="0.1 0 -0.5"><joint name="j7" axis="0 0 1" ref="0.5"/>
        <inertial pos="0 0 0" mass="0.5" diaginertia="0.01 0.01 0.01"/></body></body>
    <site name="sw" pos="0 1 0"/>
  </worldbody>
  <equality>
    <connect name="ab" body1="tipA" body2="b2" anchor="0.1 0.05 -0.02"/>
    <connect name="toworld" body1="a2" anchor="0.3 0 0"/>
    <weld name="w0" body1="a2" body2="b" anchor="0.05 0 0.1"/>
    <weld name="w1" body1="tipA" body2="c" anchor="0.1 0 0" relpose="0.2 0.1 0 0.9 0.1 0.3 0.1" torquescale="2"/>
    <weld name="wsite" site1="sb" site2="sc"/>
    <weld name="point" body1="b" body2="c" torquescale="0"/>
    <connect name="csite" site1="sw" site2="sc" solref="0.01 1"/>
    <joint name="gear" joint1="j6" joint2="j7" polycoef="-1 -1.5 0 0 0"/>
    <joint name="lock" joint1="j5" polycoef="-0.05 0 0 0 0"/>
    <joint name="off" joint1="j3" active="false"/>
  </equality>
</mujoco>"""


def _row_spaces(A, B):
    """Sine of the largest principal angle between the row spaces of A and B (same rank)."""
    def basis(X):
        u, s, vt = np.linalg.svd(X)
        return vt[: int(np.sum(s > 1e-9 * s[0]))]
    P, Q = basis(A), basis(B)
    assert len(P) == len(Q)
    return np.linalg.norm(Q - (Q @ P.T) @ P, 2)


def _mj_state(model, m, q):
    """MuJoCo's qpos for our q (its free joint: [x y z qw qx qy qz]), and our v index of its dofs (identity here)."""
    qpos = np.empty(m.nq)
    for i, n in enumerate(model.joint_names):
        a, k = m.jnt_qposadr[m.joint(n).id], model.idx_q[i]
        if model.nqs[i] == 7:
            qpos[a:a + 7] = np.concatenate([q[k:k + 3], [q[k + 6]], q[k + 3:k + 6]])
        else:
            qpos[a] = q[k]
    return qpos


def test_each_form_against_mujocos_rows():
    model = _quiet(load_mjcf_string, BODIES)
    kinds = [(c.name, c.type) for c in model.constraints]
    assert kinds == [("ab", "spherical"), ("toworld", "spherical"), ("w0", "fixed"), ("w1", "fixed"),
                     ("wsite", "fixed"), ("point", "spherical"), ("csite", "spherical"), ("gear", "coupling"),
                     ("lock", "coupling")]
    quirks = {(q.kind, q.name) for q in model.quirks}
    assert {("inactive_equality", "off"), ("equality_softness", "w1"), ("equality_softness", "csite"),
            ("equality_softness", "point")} <= quirks
    m = mujoco.MjModel.from_xml_string(BODIES)
    d = mujoco.MjData(m)
    # MuJoCo's free joint's dofs are [linear (world); angular (body)]: ours [linear (body); angular (body)]
    rng = np.random.default_rng(3)
    pos_err = span = 0.0
    for _ in range(5):
        q = _random_q(model, rng)
        d.qpos[:] = _mj_state(model, m, q)
        mujoco.mj_forward(m, d)
        Phi, J = closure_terms(model, q)[:2]
        R = _base_rotation(q, model)
        T = np.eye(model.nv)
        f = model.idx_v[model.joint_names.index("root")]
        T[f:f + 3, f:f + 3] = R                          # MuJoCo's dof velocity = T · ours
        Jmj = d.efc_J.reshape(d.nefc, m.nv) @ T
        row, ours = 0, 0
        rows = {"connect": 3, "weld": 6, "joint": 1}       # a weld of torquescale 0 keeps its 3 (zero) rows
        assert d.nefc == sum(rows[c.source] for c in model.constraints) and not np.any(d.efc_type)
        for c in model.constraints:
            n = rows[c.source]
            if c.type == "coupling":                         # ours: ratio q_A − q_B; MuJoCo's: q1 − c0 − ... = −ours
                pos_err = max(pos_err, abs(d.efc_pos[row] + Phi[ours]), err(-Jmj[row], J[ours]))
            else:
                pos_err = max(pos_err, err(d.efc_pos[row:row + 3], Phi[ours:ours + 3]),
                              err(Jmj[row:row + 3], J[ours:ours + 3]))
            if c.type == "fixed":
                span = max(span, _row_spaces(Jmj[row + 3:row + 6], J[ours + 3:ours + 6]))
            row, ours = row + n, ours + c.n_rows
    print(f"\nMuJoCo's equality rows against Φ, Φ_q: {pos_err:.1e}; orientation row spaces {span:.1e}")
    assert pos_err <= ROWS and span <= SPAN


def _random_q(model, rng):
    q = rng.uniform(-1, 1, model.nq)
    f = model.idx_q[model.joint_names.index("root")]
    quat = rng.normal(size=4)
    q[f + 3:f + 7] = quat / np.linalg.norm(quat)
    return q


def _base_rotation(q, model):
    f = model.idx_q[model.joint_names.index("root")]
    x, y, z, w = q[f + 3:f + 7]
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_closures_hold_at_qpos0():
    # MuJoCo computes a body connect's second anchor and a weld's relative pose at qpos0: there Φ = 0
    model = _quiet(load_mjcf_string, BODIES)
    m = mujoco.MjModel.from_xml_string(BODIES)
    q0 = np.empty(model.nq)
    for i, n in enumerate(model.joint_names):
        a, k = m.jnt_qposadr[m.joint(n).id], model.idx_q[i]
        q0[k:k + model.nqs[i]] = (np.concatenate([m.qpos0[a:a + 3], m.qpos0[a + 4:a + 7], [m.qpos0[a + 3]]])
                                  if model.nqs[i] == 7 else m.qpos0[a])
    Phi = closure_terms(model, q0)[0]
    labels = md.constraints.row_labels(model)
    held = [abs(Phi[r]) for r, lab in enumerate(labels) if lab.split(".")[0] in ("ab", "toworld", "w0", "point")]
    print(f"\nΦ at MuJoCo's qpos0: {max(held):.1e}")
    assert max(held) < 1e-14, max(held)               # measured 2.2e-16


@pytest.mark.parametrize("eq, words", [
    ('<tendon name="t" tendon1="x"/>', ("tendon1='x'", "no such tendon")),
    ('<flex name="f" flex="x"/>', ("flex", "not supported")),
    ('<joint name="p" joint1="j6" joint2="j7" polycoef="0 1 0.5 0 0"/>', ("'p'", "polynomial")),
    ('<joint name="o" joint1="j6" joint2="j7" polycoef="0.1 1 0 0 0"/>', ("'o'", "offset")),
    ('<joint name="n" joint1="j1" joint2="j2"/>', ("'n'", "siblings")),
    ('<joint name="f" joint1="root"/>', ("'f'", "free joint")),
    ('<connect name="s" body1="a2" anchor="0 0 0" body2="tipA"/>', ("'s'", "same rigid body")),
    ('<connect name="x" body1="nope" anchor="0 0 0"/>', ("'x'", "no such body")),
    ('<connect name="y" body1="a"/>', ("'y'", "site1 and site2")),
    ('<weld name="z" site1="sb" site2="a"/>', ("'z'", "no such site")),
])
def test_refused_by_name(eq, words):
    text = BODIES.replace('<joint name="off" joint1="j3" active="false"/>', eq)
    with pytest.raises(MJCFError) as e:
        _quiet(load_mjcf_string, text)
    for w in words:
        assert w in str(e.value), str(e.value)


# ---- tendon equalities: one fixed tendon coupling two fingers ------------------------------------------------

def _fingers(coupling, refs=("0", "0")):
    """A palm on a slide with two sibling finger hinges (refs: their ref), coupled by ``coupling`` (XML)."""
    return (f'<mujoco><compiler angle="radian"/><worldbody><body name="palm" pos="0 0 0.3"><joint name="lift" type="slide" axis="0 0 1"/>'
            f'<geom type="box" size="0.05 0.05 0.02" mass="0.8"/>'
            f'<body name="left" pos="0.04 0 0"><joint name="f1" axis="0 1 0" ref="{refs[0]}"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 -0.08" size="0.01" mass="0.05"/></body>'
            f'<body name="right" pos="-0.04 0 0"><joint name="f2" axis="0 1 0" ref="{refs[1]}"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 -0.08" size="0.01" mass="0.07"/></body></body></worldbody>'
            f'{coupling}</mujoco>')


@pytest.mark.parametrize("coefs, c0, refs", [((1.0, -1.0), 0.0, ("0", "0")), ((2.0, 3.0), 0.0, ("0", "0")),
                                             ((2.0, 2.0), 0.0, ("0.2", "-0.2")), ((1.0, -1.0), 0.5, ("0", "0.5")),
                                             ((1.5, -0.5), 0.25, ("0.5", "0.5"))])
def test_a_fixed_tendon_equality_is_the_joint_equality_and_mujocos_row(coefs, c0, refs):
    """L = a q_f1 + b q_f2, L − L₀ = c0 (a tendon equality on it): the coupling q_f1 − q_f1₀ = c0/a − (b/a)(q_f2 −
    q_f2₀), the closure the equivalent joint equality gives; Φ and Φ_q proportional to MuJoCo's efc_pos and efc_J
    (one row) at random configurations; the constrained q̈ against MuJoCo's (test_mjcf_export's measure)."""
    a, b = coefs
    tendon = (f'<tendon><fixed name="grip"><joint joint="f1" coef="{a!r}"/><joint joint="f2" coef="{b!r}"/></fixed>'
              f'</tendon><equality><tendon name="sync" tendon1="grip" polycoef="{c0!r} 0 0 0 0"/></equality>')
    joint = f'<equality><joint name="sync" joint1="f1" joint2="f2" polycoef="{c0 / a!r} {-b / a!r} 0 0 0"/></equality>'
    if c0 / a + float(refs[0]) + (b / a) * float(refs[1]) != 0:       # an offset: refused alike
        for text in (_fingers(tendon, refs), _fingers(joint, refs)):
            with pytest.raises(MJCFError, match="a coupling with an offset"):
                _quiet(load_mjcf_string, text)
        return
    ours, twin = (_quiet(load_mjcf_string, _fingers(x, refs)) for x in (tendon, joint))
    (c,), (t,) = ours.constraints, twin.constraints
    assert (c.type, c.parent, c.child, c.ratio, c.source) == (t.type, t.parent, t.child, t.ratio, "tendon")
    m = mujoco.MjModel.from_xml_string(_fingers(tendon, refs))
    d = mujoco.MjData(m)
    rng, worst = np.random.default_rng(11), 0.0
    for _ in range(5):
        q = rng.uniform(-1, 1, ours.nq)
        d.qpos[:] = _mj_state(ours, m, q)
        mujoco.mj_forward(m, d)
        Phi, J = closure_terms(ours, q)[:2]
        row, = np.flatnonzero(d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY)   # (contacts aside)
        Jmj = d.efc_J.reshape(d.nefc, m.nv)[row]
        s = Jmj @ J[0] / (J[0] @ J[0])                   # MuJoCo's row = s · ours (s = ±a)
        worst = max(worst, err(Jmj, s * J[0]), abs(d.efc_pos[row] - s * Phi[0]) / max(1.0, abs(s)))
    print(f"\nMuJoCo's tendon equality row against Φ, Φ_q: {worst:.1e}")
    assert worst <= ROWS
    r = -b / a                                           # q_f1 = r q_f2 (no offset): assembled states
    states = [(np.array([0.1, 0.4 * r, 0.4]), np.array([0.3, -1.2 * r, -1.2])),
              (np.array([-0.2, -0.7 * r, -0.7]), np.zeros(3))]
    _check_closed(f"tendon {a:g} {b:g}", ours, states)   # MuJoCo's constrained q̈, rigid-extrapolated, and ours


@pytest.mark.parametrize("tendon, eq, words", [
    ('<spatial name="t"><site site="s1"/><site site="s2"/></spatial>', '<tendon tendon1="t"/>', "a spatial tendon"),
    ('<fixed name="t"><joint joint="f1" coef="1"/><joint joint="f2" coef="1"/><joint joint="lift" coef="1"/></fixed>',
     '<tendon tendon1="t"/>', "a fixed tendon of 3 joints"),
    ('<fixed name="t"><joint joint="f1" coef="1"/></fixed><fixed name="u"><joint joint="f2" coef="1"/></fixed>',
     '<tendon tendon1="t" tendon2="u"/>', "between two tendons"),
    ('<fixed name="t"><joint joint="f1"/></fixed>', '<tendon tendon1="t"/>', "needs coef"),
    ('<fixed name="t"><joint joint="nope" coef="1"/><joint joint="f2" coef="1"/></fixed>', '<tendon tendon1="t"/>',
     "no such joint"),
])
def test_tendon_equalities_beyond_a_coupling_are_refused_by_name(tendon, eq, words):
    text = _fingers(f"<tendon>{tendon}</tendon><equality>{eq}</equality>").replace(
        '<geom type="box"', '<site name="s1"/><site name="s2" pos="0 0 0.1"/><geom type="box"')
    with pytest.raises(MJCFError, match=words):
        _quiet(load_mjcf_string, text)
