"""Joint dynamics (docs/design.md §3, Joint dynamics): armature as Pinocchio applies ``model.armature`` — M +
diag(armature) in the CRBA, τ += armature ⊙ q̈ in the RNEA, D_i = Sᵀ Iᵃ S + armature_i in the ABA — held to Pinocchio
with ``pm.armature`` set, one state and batches (the lane kernels), on random trees, the AAU arm and a free flyer;
the derivatives (∂τ/∂q̈ = M, ∂q̈/∂τ = M⁻¹) against ``computeRNEADerivatives`` / ``computeABADerivatives``; damping
and Coulomb friction against MuJoCo's qacc on the exported MJCF, read back by our MJCF reader.

Measured (Pinocchio 4.1, MuJoCo 4.0, §3 measure): M ≤ 3.2e-15, τ ≤ 4.6e-15, q̈ ≤ 4.3e-16 · cond(M) (random trees, the
AAU arm; 70 states in lanes and one by one); free flyer M 1.2e-16, τ 2.5e-16, q̈ 7.5e-17 · cond(M); derivatives
∂τ/∂q̈ ≤ 5.3e-16, M⁻¹ ≤ 3.5e-17 · cond(M); against MuJoCo, with every friction row saturated: q̈ ≤ 4.0e-16 · cond(M)
(ABA, Cholesky, one state), against 1.4 (relative) without the joint dynamics."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.errors import InputError
from tests.conftest import AAU, assert_close, err, mujoco_full_m
from tests.crosscheck.test_crba import _pin_q, random_tree_text

pin = pytest.importorskip("pinocchio")

CASES = {"tree5": (5, 12), "tree6": (6, 20), "tree7": (7, 30)}


def _models(name):
    """(our model with armature, Pinocchio's with pm.armature set, q -> Pinocchio's q)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name == "aau_arm":
            text = AAU.read_text()
        else:
            text = random_tree_text(*CASES[name])
        model = md.load_urdf_string(text)
        pm = pin.buildModelFromXML(text)
    arm = np.random.default_rng(7).uniform(0.05, 2.0, model.nv)       # of the order of the links' inertias
    model = dataclasses.replace(model, armature=arm)
    pm.armature = arm.copy()
    return model, pm, lambda q: _pin_q(model, pm, q)


def _states(model, n, seed):
    rng = np.random.default_rng(seed)
    Q = np.stack([md.random_configuration(model, rng=rng) for _ in range(n)])
    return Q, rng.normal(0, 2, (n, model.nv)), rng.normal(0, 5, (n, model.nv))


@pytest.mark.parametrize("name", [*CASES, "aau_arm"])
def test_armature_rnea_crba_aba_match_pinocchio(name):
    model, pm, to_pin = _models(name)
    pd = pm.createData()
    Q, V, A = _states(model, 70, 3)                 # 70 states: a full block of 64 lanes and a partial one
    M, tau = md.mass_matrix(model, Q), md.rnea(model, Q, V, A)
    qdd = md.aba(model, Q, V, tau)
    qdd_ch = md.forward_dynamics(model, Q, V, tau, method="cholesky")
    Ml = md.mass_matrix(model, Q, method="lagrange")
    e = dict(M=0.0, M1=0.0, tau=0.0, tau1=0.0, qdd=0.0, qdd1=0.0, ch=0.0, ch1=0.0, ch1w=0.0, lag=0.0)
    zero = {model.body_names[-1]: (np.zeros(3), np.zeros(3))}       # a wrench of 0: the one-state wrench path
    for s in range(len(Q)):
        pq = to_pin(Q[s])
        Mp = pin.crba(pm, pd, pq)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        tp = pin.rnea(pm, pd, pq, V[s], A[s])
        ap = pin.aba(pm, pd, pq, V[s], tau[s])
        c = np.linalg.cond(Mp)
        e["M"] = max(e["M"], _err(M[s], Mp))
        e["M1"] = max(e["M1"], _err(md.mass_matrix(model, Q[s]), Mp))
        e["tau"] = max(e["tau"], _err(tau[s], tp))
        e["tau1"] = max(e["tau1"], _err(md.rnea(model, Q[s], V[s], A[s]), tp))
        e["qdd"] = max(e["qdd"], _err(qdd[s], ap) / c)
        e["qdd1"] = max(e["qdd1"], _err(md.aba(model, Q[s], V[s], tau[s]), ap) / c)
        e["ch"] = max(e["ch"], _err(qdd_ch[s], ap) / c)
        e["ch1"] = max(e["ch1"], _err(md.forward_dynamics(model, Q[s], V[s], tau[s], method="cholesky"), ap) / c)
        e["ch1w"] = max(e["ch1w"], _err(md.forward_dynamics(model, Q[s], V[s], tau[s], method="cholesky", f_ext=zero),
                                         ap) / c)
        e["lag"] = max(e["lag"], _err(Ml[s], Mp))
    print(name, {k: f"{v:.1e}" for k, v in e.items()})
    for k in ("M", "M1", "lag"):
        assert e[k] < 1e-13, (k, e[k])          # measured ≤ 3.2e-15 (tree5–7, aau arm; lanes and one state)
    for k in ("tau", "tau1"):
        assert e[k] < 1e-13, (k, e[k])          # measured ≤ 4.6e-15
    for k in ("qdd", "qdd1", "ch", "ch1", "ch1w"):    # ch1: one state, the CRBA's one-lane steps; ch1w: with a
    #                                                     wrench, on the model as it is: the scalar CRBA
        assert e[k] < 1e-14, (k, e[k])          # scaled by cond(M); measured ≤ 4.3e-16 (tree6)


def _err(x, y):
    return float(np.max(np.abs(np.asarray(x) - y)) / max(np.max(np.abs(y)), 1.0))


def test_armature_without_it_differs():
    """The armature is felt: with it M's diagonal grows by exactly the armature (the CRBA with and without it)."""
    model, _, _ = _models("tree5")
    bare = dataclasses.replace(model, armature=None)
    Q, _, _ = _states(model, 5, 1)
    d = md.mass_matrix(model, Q) - md.mass_matrix(bare, Q)
    assert_close(d, np.broadcast_to(np.diag(model.armature), d.shape), 1e-14, "ΔM")   # measured 4.4e-16


@pytest.mark.parametrize("name", ["tree6", "aau_arm"])
def test_armature_derivatives_match_pinocchio(name):
    model, pm, to_pin = _models(name)
    pd = pm.createData()
    Q, V, A = _states(model, 4, 5)
    for s in range(len(Q)):
        pq = to_pin(Q[s])
        dq, dv, da = md.rnea_derivatives(model, Q[s], V[s], A[s])
        pin.computeRNEADerivatives(pm, pd, pq, V[s], A[s])
        Mp = np.triu(pd.M) + np.triu(pd.M, 1).T
        assert_close(da, Mp, 3e-14, "∂τ/∂q̈")           # measured ≤ 5.3e-16
        tau = md.rnea(model, Q[s], V[s], A[s])
        fq, fv, Minv = md.aba_derivatives(model, Q[s], V[s], tau)
        pin.computeABADerivatives(pm, pd, pq, V[s], tau)
        Mi = np.triu(pd.Minv) + np.triu(pd.Minv, 1).T
        c = np.linalg.cond(Mp)
        assert_close(Minv, Mi, 3e-15 * c, "∂q̈/∂τ")     # measured ≤ 3.5e-17 · cond(M)
        assert_close(fq, pd.ddq_dq, 2e-14 * c, "∂q̈/∂q")       # measured ≤ 1.6e-16 · cond(M)
        assert_close(fv, pd.ddq_dv, 2e-14 * c, "∂q̈/∂q̇")       # measured ≤ 2.2e-16 · cond(M)


def test_free_flyer_armature_matches_pinocchio():
    """A free-flyer root (load_urdf_string(root_joint="free_flyer")) with armature on all its six velocities."""
    text = random_tree_text(11, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf_string(text, root_joint="free_flyer")
        pm = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
    arm = np.random.default_rng(2).uniform(0.1, 1.0, model.nv)
    model = dataclasses.replace(model, armature=arm)
    pm.armature = arm.copy()
    pd = pm.createData()
    rng = np.random.default_rng(4)
    Q = np.stack([md.random_configuration(model, rng=rng) for _ in range(3)])
    V, A = rng.normal(0, 2, (3, model.nv)), rng.normal(0, 5, (3, model.nv))
    M, tau = md.mass_matrix(model, Q), md.rnea(model, Q, V, A)
    qdd = md.aba(model, Q, V, tau)
    for s in range(3):
        pq = _pin_q(model, pm, Q[s])
        Mp = pin.crba(pm, pd, pq)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        assert_close(M[s], Mp, 1e-14, "M")                                              # measured 1.2e-16
        assert_close(tau[s], pin.rnea(pm, pd, pq, V[s], A[s]), 1e-14, "tau")            # measured 2.5e-16
        assert_close(qdd[s], pin.aba(pm, pd, pq, V[s], tau[s]), 5e-15 * np.linalg.cond(Mp), "qdd")   # 7.5e-17 cond


def test_joint_dynamics_checked_and_kept():
    model = md.load_urdf(AAU)
    j = model.joint_names[1]
    m = md.load_urdf(AAU, joint_dynamics={j: dict(armature=0.5, damping=2.0, friction=0.3)})
    k = model.joint_index(j)
    assert (m.armature[k], m.damping[k], m.friction[k]) == (0.5, 2.0, 0.3)
    assert np.count_nonzero(m.armature) == 1
    with pytest.raises(InputError, match="nope"):
        md.load_urdf(AAU, joint_dynamics={"nope": dict(armature=1.0)})
    with pytest.raises(InputError, match="stiffness"):
        md.load_urdf(AAU, joint_dynamics={j: dict(stiffness=1.0)})
    for bad in (-1.0, np.nan, np.inf):
        with pytest.raises(InputError, match="armature"):
            dataclasses.replace(model, armature=np.full(model.nv, bad))
    with pytest.raises(InputError, match="damping"):
        dataclasses.replace(model, damping=np.zeros(model.nv + 1))
    import pickle
    p = pickle.loads(pickle.dumps(m))
    for key in ("armature", "damping", "friction"):
        assert np.array_equal(getattr(p, key), getattr(m, key))
    r = md.reduce(m, locked={model.joint_names[0]: 0.3})
    assert r.armature.tolist() == m.armature[1:].tolist() and r.damping.tolist() == m.damping[1:].tolist()


# -- damping and Coulomb friction against MuJoCo -----------------------------------------------------------------
# MuJoCo applies damping as a passive force (qfrc_damper = −damping q̇, explicit in mj_forward's qacc) and frictionloss
# as a constraint row of its solver, a soft one: the row's force is D (a_ref − J q̈) clamped to ±frictionloss, so where
# |q̇| is large (a_ref = −b J q̇, b = 2/(timeconst · dmax) ≈ 100/s) it is saturated at −frictionloss · sign(q̇) exactly,
# as ours is −friction · tanh(q̇ / ε), within 1 − tanh(|q̇|/ε) of it (0 in double precision beyond |q̇| = 19 ε).
# Below saturation the two differ by design (ours: a smooth tanh without stiction; MuJoCo's: a soft clamp).

def _dynamics_model():
    """The AAU arm with armature, damping and friction on every joint (the loader's joint_dynamics=), its MJCF
    (``to_mjcf``), our reading of that text and MuJoCo's."""
    mujoco = pytest.importorskip("mujoco")
    from manipdyn.io.mjcf import to_mjcf
    base = md.load_urdf(AAU)
    rng = np.random.default_rng(0)
    dyn = {j: dict(armature=rng.uniform(0.05, 0.5), damping=rng.uniform(0.5, 3.0), friction=rng.uniform(0.5, 2.0))
           for j in base.joint_names}
    model = md.load_urdf(AAU, joint_dynamics=dyn)
    text = to_mjcf(model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = md.load_mjcf_string(text)
    m = mujoco.MjModel.from_xml_string(text)
    return mujoco, model, ours, m


def test_exported_joint_dynamics_are_read_back_and_by_mujoco():
    mujoco, model, ours, m = _dynamics_model()
    iv = np.array([m.jnt_dofadr[m.joint(n).id] for n in model.joint_names], int)
    for key, attr in (("armature", "dof_armature"), ("damping", "dof_damping"), ("friction", "dof_frictionloss")):
        assert np.array_equal(getattr(m, attr)[iv], getattr(model, key)), key
        assert np.array_equal(getattr(ours, key), getattr(model, key)), key
    assert not [q for q in ours.quirks if q.kind == "joint_dynamics"]        # applied, not quirked


def test_damping_and_saturated_friction_match_mujoco():
    """q̈ = forward_dynamics (ABA and Cholesky, one state and a batch) of our reading of the exported MJCF against
    MuJoCo's qacc after mj_forward, at states where every |q̇| ≥ 0.5 rad/s (frictionloss saturated)."""
    mujoco, model, ours, m = _dynamics_model()
    d = mujoco.MjData(m)
    iq = np.array([m.jnt_qposadr[m.joint(n).id] for n in model.joint_names], int)
    iv = np.array([m.jnt_dofadr[m.joint(n).id] for n in model.joint_names], int)
    rng = np.random.default_rng(1)
    n = 20
    Q = np.stack([md.random_configuration(ours, rng=rng) for _ in range(n)])
    V = rng.choice([-1.0, 1.0], (n, model.nv)) * rng.uniform(0.5, 3.0, (n, model.nv))
    T = rng.normal(0, 5, (n, model.nv))
    ref, rigid, worst_sat = np.empty((n, model.nv)), np.empty(n), 0.0
    for s in range(n):
        d.qpos[iq], d.qvel[iv], d.qfrc_applied[iv] = Q[s], V[s], T[s]
        mujoco.mj_forward(m, d)
        ref[s] = d.qacc[iv]
        fr = np.asarray(d.efc_type) == int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF)
        sat = np.abs(np.abs(d.efc_force[fr]) - m.dof_frictionloss[d.efc_id[fr]]) / m.dof_frictionloss[d.efc_id[fr]]
        worst_sat = max(worst_sat, float(np.max(sat)))                   # saturated: |force| = frictionloss
        rigid[s] = np.linalg.cond(mujoco_full_m(m, d))
    worst = {}
    for how, qdd in (("aba", md.forward_dynamics(ours, Q, V, T)),
                     ("cholesky", md.forward_dynamics(ours, Q, V, T, method="cholesky")),
                     ("aba one", np.stack([md.forward_dynamics(ours, Q[s], V[s], T[s]) for s in range(n)]))):
        worst[how] = max(_err(qdd[s], ref[s]) / rigid[s] for s in range(n))
    off = max(_err(md.forward_dynamics(ours, Q[s], V[s], T[s], joint_dynamics=False), ref[s]) for s in range(n))
    print({k: f"{v:.1e}" for k, v in worst.items()}, f"without joint dynamics {off:.1e}", f"saturation {worst_sat:.1e}")
    assert worst_sat < 1e-12                         # every friction row at ±frictionloss
    for how, e in worst.items():
        assert e < 2e-14, (how, e)                   # scaled by cond(M); measured ≤ 4.0e-16 (cholesky)
    assert off > 1e-3                                # the damping and friction are felt


def test_mimic_model_joint_dynamics_act_through_the_map():
    """A MimicModel's damping and friction are the full model's, mapped: τ_ind −= Gᵀ (d ⊙ G q̇ + f ⊙ tanh(G q̇ / ε)) —
    panda, whose <dynamics damping> holds on every joint, its second finger mimicking the first."""
    from manipdyn.model import FRICTION_EPS
    from tests.conftest import zoo_paths
    path = next((p for p in zoo_paths() if p.stem == "panda"), None)
    if path is None:
        pytest.skip("example-robot-data is not installed")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mm = md.load_urdf(path, mimic=True, joint_dynamics={"panda_joint2": dict(friction=0.7)})
    assert mm.full.damping.any() and mm.full.friction.any()
    rng = np.random.default_rng(8)
    q, v, tau = rng.uniform(-0.5, 0.5, mm.nq), rng.normal(0, 2, mm.nv), rng.normal(0, 5, mm.nv)
    vf = mm.G @ v
    loss = mm.G.T @ (mm.full.damping * vf + mm.full.friction * np.tanh(vf / FRICTION_EPS))
    want = md.aba(mm, q, v, tau - loss)
    assert_close(md.forward_dynamics(mm, q, v, tau), want, 1e-15, "q̈")                 # the same solve: 0
    assert _err(md.forward_dynamics(mm, q, v, tau, joint_dynamics=False), want) > 1e-3


@pytest.mark.parametrize("method", ["aba", "cholesky"])
def test_simulate_loses_what_damping_and_friction_take(method):
    """Power balance over a simulated motion without gravity or torque: the energy T + ½ q̇ᵀ diag(armature) q̇ falls by
    ∫ q̇ᵀ (d ⊙ q̇ + f ⊙ tanh(q̇/ε)) dt (a physical law; the integral by the trapezoid rule on RK4's samples, so the
    residue is set by dt, not by rounding); with joint_dynamics=False the energy is conserved."""
    from manipdyn.model import FRICTION_EPS
    model = md.load_urdf(AAU, gravity=(0.0, 0.0, 0.0),
                         joint_dynamics={j: dict(armature=0.2, damping=0.4, friction=0.3) for j in
                                         md.load_urdf(AAU).joint_names})
    rng = np.random.default_rng(12)
    q0, v0 = md.random_configuration(model, rng=rng), rng.normal(0, 2, model.nv)

    def energy(r):
        return md.kinetic_energy(model, r.q, r.v) + 0.5 * np.sum(model.armature * r.v ** 2, axis=-1)

    r = md.simulate(model, q0, v0, (0.0, 0.5), dt=1e-3, integrator="rk4", method=method)
    E = energy(r)
    P = np.sum(r.v * (model.damping * r.v + model.friction * np.tanh(r.v / FRICTION_EPS)), axis=-1)
    lost = np.sum(0.5 * (P[1:] + P[:-1]) * np.diff(r.t))
    assert E[0] - E[-1] > 0.2 * E[0]                                  # the losses are felt: measured 58 %
    assert abs((E[0] - E[-1]) - lost) < 1e-5 * E[0], (E[0] - E[-1], lost)   # measured 3.1e-7 (the trapezoid rule
    #                                                                          across tanh's steep sign changes)
    free = md.simulate(model, q0, v0, (0.0, 0.5), dt=1e-3, integrator="rk4", method=method, joint_dynamics=False)
    Ef = energy(free)
    assert abs(Ef[-1] - Ef[0]) < 1e-11 * Ef[0]                       # conserved: measured 5.2e-13 (RK4, dt = 1e-3)


def test_regressor_is_the_rigid_bodies_and_armature_a_known_term():
    """Y π = rnea − armature ⊙ q̈: the regressor holds the bodies' parameters only (docs/derivatives.md)."""
    model, _, _ = _models("tree6")
    Q, V, A = _states(model, 5, 9)
    Y, pi = md.joint_torque_regressor(model, Q, V, A), md.dynamic_parameters(model)
    assert_close(Y @ pi + model.armature * A, md.rnea(model, Q, V, A), 1e-14, "Y π + armature q̈")   # measured 1.4e-16
    assert err(Y @ pi, md.rnea(model, Q, V, A)) > 1e-3                      # (1.6e-2: the armature counts)


def test_readers_refuse_negative_joint_dynamics_by_name():
    from manipdyn.errors import MJCFError, URDFError
    mj = ('<mujoco><worldbody><body name="b"><joint name="j" axis="0 0 1" {}/><inertial pos="0 0 0" mass="1" '
          'diaginertia="1 1 1"/></body></worldbody></mujoco>')
    with pytest.raises(MJCFError, match="joint 'j'.*armature"):
        md.load_mjcf_string(mj.format('armature="-1"'))
    assert md.load_mjcf_string(mj.format('damping="2" frictionloss="0.5"')).friction.tolist() == [0.5]
    text = AAU.read_text().replace('<joint name="joint2" type="revolute">',
                                   '<joint name="joint2" type="revolute"><dynamics damping="-0.5"/>', 1)
    assert text != AAU.read_text()
    with pytest.raises(URDFError, match="joint2.*damping"):
        md.load_urdf_string(text)
    ok = md.load_urdf_string(text.replace('damping="-0.5"', 'damping="0.5" friction="0.25"'))
    k = ok.joint_index("joint2")
    assert (ok.damping[k], ok.friction[k]) == (0.5, 0.25) and np.count_nonzero(ok.damping) == 1
