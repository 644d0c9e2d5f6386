"""The MJCF export (manipdyn.io.mjcf.to_mjcf) loaded by MuJoCo: its open-tree dynamics are ours to round-off, its
closed chains (equality constraints) ours to MuJoCo's constraint softness, and hostile names survive.

References: MuJoCo 4.0 itself (mj_fullM, mj_inverse, mj_forward with the constraint solver) on the exported text;
manipdyn's mass_matrix / rnea / constrained_forward_dynamics on the Model the text was written from.

Measured (MuJoCo 4.0): open tree, the bundled models and four zoo arms, M and τ ≤ 2.2e-15 (ur5; ≤ 2.7e-15 over all
20 zoo arms, measured once); free-flyer roots (solo12, anymal; base axes on the world's) ≤ 3.5e-16 — OPEN = 1e-13. Closed chains (four-bar, SPM, a gear coupling, the loop files: revolute, spherical, weld, two loops),
assembled states (manipdyn's complete_state, q̇ on the constraint manifold, at rest and moving), random τ, at the
hardest impedance MuJoCo allows (solimp d = 0.9999): q̈ agrees to 1.4e-6..4.7e-5 (four-bar, SPM, gear) and up to
1.9e-2 (weld7; 3.4e-3 rusr_revolute) — HARD = 0.1. The residue is MuJoCo's softness, not a modelling
difference: its constraint force solves (A + R) f = a_ref − J a₀ with R = (1 − d)/d · diag(A), so q̈ is off by
about (1 − d) · diag(A)/λ_min(A) (that ratio: 7 for the slider-crank, 92 weld7, 382 rusr_revolute, 2245
two_loops). Proof: q̈ is a rational function of δ = (1 − d)/d; the quadratic through d = 0.9999, 0.9998, 0.9996
evaluated at δ = 0 (rigid constraints) agrees with ours to ≤ 3.5e-10 (four-bar, SPM, gear, spherical loops),
2.4e-7 (rusr_revolute), 2.5e-5 (weld7, two_loops: the largest δ·κ) — RIGID = 1e-3, and the extrapolation
must shrink the error at least GAIN = 100 times (measured ≥ 750 times). MuJoCo 4 includes −J̇q̇ in its
reference acceleration (efc_aref), so moving states agree as well as states at rest.
Ball joints (the MJCF reader's models: hand-written, under a free flyer, random trees with several joints per body,
armature and damping): to_mjcf -> MuJoCo M and τ ≤ 1.9e-15, -> load_mjcf_string the same joints and bodies (one
MJCF body with several joints again), parameters ≤ 5.6e-16, M and τ ≤ 1.1e-15 — OPEN.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import ROOT, err, mujoco_full_m

import manipdyn as md
from manipdyn.constraints import complete_state, constrained_forward_dynamics
from manipdyn.examples import spm_params as P
from manipdyn.examples.spm_urdf import tree_guess
from manipdyn.io.mjcf import EQ_SOLIMP, to_mjcf
from manipdyn.io.urdf import load_urdf_string
from manipdyn.validation.zoo import arm_paths

mujoco = pytest.importorskip("mujoco")

OPEN = 1e-13             # measured ≤ 2.2e-15 (M, τ), bundled models, zoo arms, free-flyer roots
HARD = 0.1               # measured ≤ 1.9e-2 (q̈ at solimp 0.9999, weld7)
RIGID = 1e-3             # measured ≤ 2.5e-5 (q̈ extrapolated to rigid constraints, weld7)
GAIN = 100               # extrapolation shrinks the error: measured ≥ 750x


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_urdf(path)


def _mujoco(model, **kw):
    """MuJoCo's model of the exported text, its data, and our joints' qpos / dof addresses."""
    m = mujoco.MjModel.from_xml_string(to_mjcf(model, **kw))
    iq = np.array([m.jnt_qposadr[m.joint(n).id] for n in model.joint_names], int)
    iv = np.array([m.jnt_dofadr[m.joint(n).id] for n in model.joint_names], int)
    return m, mujoco.MjData(m), iq, iv


ARMS = [ROOT / "urdf" / n for n in ("aau_arm.urdf", "fourbar.urdf", "spm.urdf")] + \
       [p for p in arm_paths() if p.stem in ("ur5_robot", "panda", "kinova", "baxter")]


@pytest.mark.parametrize("path", ARMS, ids=lambda p: p.stem)
def test_open_tree_m_and_tau(path):
    model = _load(path)
    m, d, iq, iv = _mujoco(model)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)     # the tree: closures off
    assert m.nv == model.nv and np.array_equal(m.dof_armature[iv], model.armature)     # <dynamics damping>: written,
    assert np.array_equal(m.dof_damping[iv], model.damping)                              # and mj_inverse adds d q̇
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(10):
        q, v, a = rng.uniform(-np.pi, np.pi, model.nv), rng.normal(size=model.nv), rng.normal(size=model.nv)
        d.qpos[iq], d.qvel[iv], d.qacc[iv] = q, v, a
        mujoco.mj_inverse(m, d)
        worst = max(worst, err(d.qfrc_inverse[iv], md.rnea(model, q, v, a) + model.damping * v),
                    err(mujoco_full_m(m, d)[np.ix_(iv, iv)], md.mass_matrix(model, q)))
    print(f"\n{path.stem}: M and τ against MuJoCo: {worst:.1e}")
    assert worst <= OPEN, f"{path.stem}: {worst:.2e}"


def _fourbar_states(model):
    out = []
    for guess, w in (([0.3, -1.3, -2.0], 0.0), ([1.0, -1.0, -1.5], 0.0), ([0.3, -1.3, -2.0], 3.0),
                     ([2.0, -2.0, -2.0], -2.0)):
        q, v, _, _ = complete_state(model, guess, [w], [0.0])
        out.append((q, v))
    return out


def _spm_states(model):
    Q0 = np.array([[np.cos(np.pi / 6), 0, np.sin(np.pi / 6)], [0, 1, 0], [-np.sin(np.pi / 6), 0, np.cos(np.pi / 6)]])
    guess = tree_guess(model, Q0, np.radians(P.THETA0_FIRST_BRANCH_DEG))
    out = []
    for w in (np.zeros(3), np.array([2.0, -1.5, 1.0])):
        q, v, _, _ = complete_state(model, guess, w, np.zeros(3))
        out.append((q, v))
    return out


IMPEDANCES = (0.9999, 0.9998, 0.9996)       # solimp d: MuJoCo's hardest, then twice and four times as soft


def _closed_errors(model, states):
    """err(MuJoCo's constrained q̈, ours) per assembled state (random τ), at the hardest impedance and
    extrapolated to rigid constraints: q̈ is a smooth (rational) function of δ = (1 − d)/d, so the quadratic
    through the three impedances, evaluated at δ = 0, removes the softness and leaves any modelling difference."""
    rng = np.random.default_rng(1)
    taus = rng.normal(size=(len(states), model.nv))
    runs = []
    for d0 in IMPEDANCES:
        m, d, iq, iv = _mujoco(model, solimp=(d0, d0) + EQ_SOLIMP[2:])
        m.opt.tolerance, m.opt.iterations = 1e-15, 1000       # the solver run to convergence
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT) | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        out = []
        for (q, v), tau in zip(states, taus):
            d.qpos[iq], d.qvel[iv], d.qfrc_applied[iv] = q, v, tau
            mujoco.mj_forward(m, d)
            assert np.abs(d.efc_pos).max() < 1e-10        # the exported sites coincide at our assembly
            out.append(d.qacc[iv].copy())
        runs.append(out)
    delta = np.array([(1 - d0) / d0 for d0 in IMPEDANCES])
    w = np.linalg.solve(np.vander(delta, 3, increasing=True).T, np.eye(3)[0])     # p(0) = Σ w_k p(δ_k)
    rigid = np.tensordot(w, np.array(runs), 1)
    ours = [constrained_forward_dynamics(model, q, v, tau)[0] for (q, v), tau in zip(states, taus)]
    return np.array([err(a, o) for a, o in zip(runs[0], ours)]), np.array([err(a, o) for a, o in zip(rigid, ours)])


def _check_closed(name, model, states):
    hard, rigid = _closed_errors(model, states)
    print(f"\n{name}: MuJoCo vs manipdyn constrained q̈, solimp 0.9999: {' '.join(f'{x:.1e}' for x in hard)}; "
          f"extrapolated to rigid: {' '.join(f'{x:.1e}' for x in rigid)}")
    assert hard.max() <= HARD
    assert rigid.max() <= RIGID and np.all(rigid <= hard / GAIN)


@pytest.mark.parametrize("name", ["fourbar", "spm"])
def test_closed_chain_qdd(name):
    model = _load(ROOT / "urdf" / f"{name}.urdf")
    _check_closed(name, model, (_fourbar_states if name == "fourbar" else _spm_states)(model))


HOSTILE = """<robot name='r"&lt;&amp;'>
  <link name='base&amp;"&lt;/body&gt;'/>
  <link name="l&lt;1&gt;&apos;"><inertial><mass value="1"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2 &quot;x&quot; &amp;amp;"><inertial><mass value="1"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j&quot;1&quot; /&gt;&lt;joint name=&quot;x" type="revolute">
    <parent link='base&amp;"&lt;/body&gt;'/><child link="l&lt;1&gt;&apos;"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2&lt;!--" type="continuous"><parent link="l&lt;1&gt;&apos;"/><child link="l2 &quot;x&quot; &amp;amp;"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/></joint>
</robot>"""


def test_hostile_names_round_trip():
    model = load_urdf_string(HOSTILE)
    text = to_mjcf(model)
    m = mujoco.MjModel.from_xml_string(text)
    assert [m.joint(j).name for j in range(m.njnt)] == list(model.joint_names)
    assert [m.body(b).name for b in range(1, m.nbody)] == list(model.body_names)
    assert m.njnt == 2 and m.nbody == 3                  # no element smuggled in by a name
    assert list(m.jnt_limited) == [1, 0]                 # the limited joint has its range, the continuous none


def test_coupling_joint_equality_qdd():
    # a gear q_b = −2.5 q_a (URDF+ <coupling>) as MuJoCo's joint equality, same softness as the closures
    text = (ROOT / "tests" / "data" / "loops" / "gear_pair.urdf.in").read_text()
    model = load_urdf_string(text.replace("{child}", "b"))
    states = [(np.array([0.4, -1.0, 0.3]), np.array([1.5, -3.75, -0.7])), (np.array([-1.0, 2.5, 2.0]), np.zeros(3))]
    _check_closed("coupling", model, states)


LOOPS = ROOT / "tests" / "data" / "loops"


@pytest.mark.parametrize("name", ["rusr_revolute", "rusr_spherical", "slider_crank", "weld7", "two_loops"])
def test_loop_files_qdd(name):
    # every closure type (revolute: 2 connects, spherical: connect, fixed: weld) and a prismatic joint
    import json
    spec = json.loads((LOOPS / "manifest.json").read_text())[name]
    model = _load(LOOPS / spec["file"])
    states = []
    for w in (0.0, 1.5):
        q, v, _, _ = complete_state(model, spec["q0"], [w] * len(spec["actuated"]), [0.0] * len(spec["actuated"]))
        states.append((q, v))
    _check_closed(name, model, states)


@pytest.mark.parametrize("stem", ["solo12", "anymal"])
def test_free_flyer_root_at_identity_orientation(stem):
    # <freejoint>: MuJoCo's q is [x y z qw qx qy qz] and v [linear (world); angular (body)]; with the base
    # axes on the world's, its v and force are ours entry for entry, and its linear acceleration is the
    # origin's p̈ = a_lin + ω × v_lin (ours is the spatial acceleration, d/dt of the body-frame velocity)
    from manipdyn.validation.zoo import floating_paths
    path = next(p for p in floating_paths() if p.stem == stem)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf(path, root_joint="free_flyer")
    m = mujoco.MjModel.from_xml_string(to_mjcf(model))
    assert [m.joint(j).name for j in range(m.njnt)] == list(model.joint_names)
    d, rng, worst = mujoco.MjData(m), np.random.default_rng(0), 0.0
    for _ in range(5):
        q = np.concatenate([rng.normal(size=3), [0, 0, 0, 1], rng.uniform(-1, 1, model.nq - 7)])
        v, a = rng.normal(size=model.nv), rng.normal(size=model.nv)
        d.qpos[:] = np.concatenate([q[:3], [1, 0, 0, 0], q[7:]])
        d.qvel[:], d.qacc[:] = v, a
        d.qacc[:3] = a[:3] + np.cross(v[3:6], v[:3])
        mujoco.mj_inverse(m, d)
        worst = max(worst, err(d.qfrc_inverse, md.rnea(model, q, v, a)), err(mujoco_full_m(m, d), md.mass_matrix(model, q)))
    print(f"\n{stem}: free-flyer root, M and τ against MuJoCo: {worst:.1e}")
    assert worst <= OPEN, f"{stem}: {worst:.2e}"


# ---- ball joints: the MJCF reader's models written back ----------------------------------------------------------

def _ball_cases():
    from test_mjcf_import import BALLS, FREE_BALL, random_mjcf
    return {"balls": BALLS, "free_ball": FREE_BALL, "random3": random_mjcf(3), "random5": random_mjcf(5)}


@pytest.mark.parametrize("name", ["balls", "free_ball", "random3", "random5"])
def test_ball_joints_round_trip_and_mujoco(name):
    # a model with ball joints (armature, damping) -> to_mjcf -> MuJoCo's M and τ are ours (test_mjcf_import's
    # conventions: ball qpos [qw qx qy qz], qvel the body-frame ω as ours), and -> load_mjcf_string -> the same model
    from test_mjcf_import import mujoco_errors, random_state
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_mjcf_string(_ball_cases()[name])
        text = to_mjcf(model)
        back = md.load_mjcf_string(text)
    assert np.any(model.kind == md.BALL)
    assert back.joint_names == model.joint_names and np.array_equal(back.kind, model.kind)
    assert (back.nq, back.nv) == (model.nq, model.nv) and np.array_equal(back.quat_q, model.quat_q)
    for key in ("armature", "damping", "friction"):          # a ball's three entries: one number in the file
        assert np.array_equal(getattr(back, key), getattr(model, key)), key
    assert back.body_names == model.body_names               # several joints of one body: one body again
    same = max(err(getattr(back, k), getattr(model, k)) for k in ("mass", "com", "inertia", "R0", "p0", "axis"))
    rng, worst = np.random.default_rng(0), 0.0
    for _ in range(10):
        q, v, a = random_state(model, rng)
        worst = max(worst, err(md.mass_matrix(back, q), md.mass_matrix(model, q)),
                    err(md.rnea(back, q, v, a), md.rnea(model, q, v, a)))
    m = mujoco.MjModel.from_xml_string(text)
    iv = np.concatenate([np.arange(m.jnt_dofadr[j], m.jnt_dofadr[j] + model.nvs[j]) for j in range(m.njnt)])
    assert np.array_equal(m.dof_armature[iv], model.armature) and np.array_equal(m.dof_damping[iv], model.damping)
    e = mujoco_errors(back, m)
    print(f"\n{name}: ball joints, round trip: parameters {same:.1e}, M, τ {worst:.1e}; MuJoCo on the export {e:.1e}")
    assert max(same, worst, e) <= OPEN       # measured ≤ 5.6e-16 (parameters), 1.1e-15 (M, τ), 1.9e-15 (MuJoCo)


def test_ball_joint_dynamics_are_one_number_per_joint():
    import dataclasses
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_mjcf_string(_ball_cases()["balls"])
    k = model.idx_v[model.joint_index("shoulder")]
    assert model.armature[k:k + 3].tolist() == [0.2] * 3 and model.damping[k:k + 3].tolist() == [1.0] * 3
    el = [e for e in to_mjcf(model).splitlines() if 'name="shoulder"' in e]
    assert len(el) == 1 and 'type="ball"' in el[0] and 'armature="0.2"' in el[0] and 'damping="1.0"' in el[0]
    arm = model.armature.copy()
    arm[k + 2] = 0.3
    with pytest.raises(md.ModelError, match=r"'shoulder': armature \[0.2, 0.2, 0.3\] differs"):
        to_mjcf(dataclasses.replace(model, armature=arm))
