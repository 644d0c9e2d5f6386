"""Floating-base kinematics and the Lagrange route against Pinocchio and finite differences.

Our model: the fixed-base model of a URDF with a free-flyer root prepended (tests/free_flyer.py); Pinocchio's:
buildModelFromXML(text, JointModelFreeFlyer()) — the same q = [x y z qx qy qz qw, joints] and v = [root twist
in its own frame (linear; angular), joint rates]. References: Pinocchio's frame placements, getFrameJacobian
and getFrameJacobianTimeVariation (LOCAL_WORLD_ALIGNED and LOCAL), kinetic and potential energy, crba,
computeGeneralizedGravity and computeCoriolisMatrix; and central differences along the motion
(q(±h) = q ⊕ ±h v, joints.integrate), which need no Pinocchio at all.
"""
import functools

import numpy as np
import pytest
from conftest import assert_close, err, inertial_xml, urdf
from free_flyer import integrate, random_floating_states, with_free_flyer

import manipdyn as md
from manipdyn.dynamics.lagrange import mass_matrix_derivatives
from manipdyn.validation.reference import pin

ROOT_INERTIA = dict(mass=4.0, com=(0.1, -0.05, 0.02), I=(0.3, 0.2, 0.25, 0.01, 0.02, -0.01))


def _chain():
    """Root + revolute (tilted frame) + prismatic (unaligned axis) + a fixed tool frame."""
    links = {"base": inertial_xml(ROOT_INERTIA["mass"], ROOT_INERTIA["com"], ROOT_INERTIA["I"]),
             "a": inertial_xml(1.5, (0.0, 0.1, 0.3), (0.05, 0.04, 0.03, 0, 0, 0), (0.2, 0.1, 0.0)),
             "b": inertial_xml(1.0, (0.2, 0.0, 0.1), (0.02, 0.03, 0.015, 0.001, 0, 0), (0.1, 0, 0)), "tool": ""}
    joints = [("j1", "revolute", "base", "a", (0.2, 0.1, 0.3), (0.3, -0.2, 0.5), (0, 1, 0)),
              ("j2", "prismatic", "a", "b", (0.1, 0.4, -0.2), (0.1, 0.2, 0.3), (0.6, 0, 0.8)),
              ("jt", "fixed", "b", "tool", (0.1, 0.2, 0.3), (0.4, 0.5, 0.6), None)]
    return urdf(links, joints, name="ff_chain")


def _tree(seed=3, n=9):
    """Root + a random branching tree of revolute and prismatic joints with unaligned axes."""
    rng = np.random.default_rng(seed)
    links = {"base": inertial_xml(ROOT_INERTIA["mass"], ROOT_INERTIA["com"], ROOT_INERTIA["I"])}
    joints = []
    for k in range(n):
        parent = "base" if k < 2 or rng.random() < 0.2 else f"L{rng.integers(0, k)}"
        d, m = rng.uniform(0.05, 1.0, 3), rng.uniform(0.1, 3.0)
        I = np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]]) * m / 10
        links[f"L{k}"] = inertial_xml(m, rng.uniform(-0.3, 0.3, 3), (*I, 0, 0, 0), rng.uniform(-np.pi, np.pi, 3))
        axis = rng.normal(size=3)
        joints.append((f"j{k}", ("revolute", "prismatic")[int(rng.random() < 0.3)], parent, f"L{k}",
                       rng.uniform(-0.5, 0.5, 3), rng.uniform(-np.pi, np.pi, 3), axis / np.linalg.norm(axis)))
    return urdf(links, joints, name="ff_tree")


TEXTS = {"chain": _chain(), "tree": _tree()}


@functools.lru_cache(maxsize=None)
def mechanism(name):
    """(our floating model, Pinocchio model, data, 8 states (Q, V)) of one mechanism."""
    text, P = TEXTS[name], pin()
    ixx, iyy, izz, ixy, ixz, iyz = ROOT_INERTIA["I"]
    I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    model = with_free_flyer(md.load_urdf_string(text), ROOT_INERTIA["mass"], ROOT_INERTIA["com"], I)
    pm = P.buildModelFromXML(text, P.JointModelFreeFlyer())
    assert tuple(pm.names[1:]) == model.joint_names and (pm.nq, pm.nv) == (model.nq, model.nv)
    pm.gravity.linear = model.gravity
    Q, V = random_floating_states(model, 8, np.random.default_rng(7))
    return model, pm, pm.createData(), Q, V


NAMES = list(TEXTS)
REFS = ["local_world_aligned", "local"]


def _frames(model, pm):
    return [f for f in model.frames if pm.existFrame(f)]


@pytest.mark.parametrize("name", NAMES)
def test_placements_and_jacobians_against_pinocchio(name):
    """Every frame, both references: placement, J and J̇ equal Pinocchio's (J̇ = getFrameJacobianTimeVariation)."""
    model, pm, pd, Q, V = mechanism(name)
    P = pin()
    frames = _frames(model, pm)
    assert "base" in frames and len(frames) == len(model.frames)
    worst = {"R": 0.0, "p": 0.0, "J": 0.0, "dJ": 0.0}
    for q, v in zip(Q, V):
        P.computeJointJacobians(pm, pd, q)
        P.computeJointJacobiansTimeVariation(pm, pd, q, v)
        P.updateFramePlacements(pm, pd)
        for f in frames:
            fid = pm.getFrameId(f)
            R, p = md.frame_placement(model, q, f)
            worst["R"] = max(worst["R"], err(R, pd.oMf[fid].rotation))
            worst["p"] = max(worst["p"], err(p, pd.oMf[fid].translation))
            for ref, pref in zip(REFS, (P.LOCAL_WORLD_ALIGNED, P.LOCAL)):
                worst["J"] = max(worst["J"], err(md.frame_jacobian(model, q, f, ref), P.getFrameJacobian(pm, pd, fid, pref)))
                worst["dJ"] = max(worst["dJ"], err(md.frame_jacobian_dot(model, q, v, f, ref),
                                                   P.getFrameJacobianTimeVariation(pm, pd, fid, pref)))
    print(f"\n{name}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    tol = {"R": 1e-14, "p": 1e-14, "J": 1e-14, "dJ": 5e-14}      # measured ≤ 1.4e-15, 1.1e-15, 2.4e-15, 6.1e-15
    assert all(worst[k] <= tol[k] for k in tol), worst


@pytest.mark.parametrize("name", NAMES)
def test_jacobians_against_finite_differences(name):
    """Without Pinocchio: J v = the frame's twist from central differences of its placement along q ⊕ t v,
    and J̇ = the central difference of J along the same path (h = 1e-6), in both references."""
    model, _, _, Q, V = mechanism(name)
    h = 1e-6
    worst = {"Jv": 0.0, "dJ": 0.0}
    for q, v in zip(Q, V):
        qp, qm = integrate(model, q, h * v)[0], integrate(model, q, -h * v)[0]
        for f in model.frames:
            (Rp, pp), (Rm, pm_), (R, _) = (md.frame_placement(model, x, f) for x in (qp, qm, q))
            W = (Rp - Rm) @ R.T / (2 * h)                               # Ṙ Rᵀ = [ω]× (world)
            twist = np.r_[(pp - pm_) / (2 * h), W[2, 1], W[0, 2], W[1, 0]]
            worst["Jv"] = max(worst["Jv"], err(md.frame_jacobian(model, q, f) @ v, twist))
            for ref in REFS:
                fd = (md.frame_jacobian(model, qp, f, ref) - md.frame_jacobian(model, qm, f, ref)) / (2 * h)
                worst["dJ"] = max(worst["dJ"], err(md.frame_jacobian_dot(model, q, v, f, ref), fd))
    print(f"\n{name}: J v vs FD {worst['Jv']:.1e}, J̇ vs FD {worst['dJ']:.1e}")
    assert worst["Jv"] <= 1e-8 and worst["dJ"] <= 1e-8, worst    # measured ≤ 1.8e-10, 6.1e-10 (h = 1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_lagrange_route_against_pinocchio(name):
    """T, V (from the links' motion), M (Lagrange route), g and C (Christoffel symbols of M on the tangent
    space, with the free flyer's bracket terms) equal Pinocchio's; M q̈ + C q̇ + g = rnea."""
    model, pm, pd, Q, V = mechanism(name)
    P = pin()
    M, C = md.mass_matrix(model, Q, method="lagrange"), md.coriolis_matrix(model, Q, V)
    g, T, U = md.gravity_torques(model, Q), md.kinetic_energy(model, Q, V), md.potential_energy(model, Q)
    worst = dict.fromkeys(("T", "V", "M", "g", "C", "tau"), 0.0)
    A = np.random.default_rng(3).normal(0.0, 5.0, V.shape)
    for s, (q, v, a) in enumerate(zip(Q, V, A)):
        Mp = P.crba(pm, pd, q)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        ref = dict(T=P.computeKineticEnergy(pm, pd, q, v), V=P.computePotentialEnergy(pm, pd, q), M=Mp,
                   g=P.computeGeneralizedGravity(pm, pd, q), C=P.computeCoriolisMatrix(pm, pd, q, v),
                   tau=P.rnea(pm, pd, q, v, a))
        ours = dict(T=T[s], V=U[s], M=M[s], g=g[s], C=C[s], tau=M[s] @ a + C[s] @ v + g[s])
        for k in worst:
            worst[k] = max(worst[k], err(ours[k], ref[k]))
    print(f"\n{name}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert all(e <= 5e-14 for e in worst.values()), worst          # measured ≤ 4.4e-15 (C), 2.4e-15 (τ)


@pytest.mark.parametrize("name", NAMES)
def test_mass_matrix_derivatives_along_each_velocity(name):
    """X_k(M) (the derivative of M along the k-th velocity direction: the free flyer's body twists, the
    joints' ∂/∂q_k) against central differences of M along q ⊕ ±h e_k (h = 1e-5); the root directions give 0 (M does
    not depend on where the robot floats); Ṁ − 2C is skew-symmetric."""
    model, _, _, Q, V = mechanism(name)
    h = 1e-5                                     # round-off ~ε|M|/h and truncation ~h² balance here
    dM = mass_matrix_derivatives(model, Q)
    for s, q in enumerate(Q[:4]):
        E = np.eye(model.nv) * h
        Mp = md.mass_matrix(model, integrate(model, np.tile(q, (model.nv, 1)), E), method="lagrange")
        Mm = md.mass_matrix(model, integrate(model, np.tile(q, (model.nv, 1)), -E), method="lagrange")
        assert_close(dM[s], (Mp - Mm) / (2 * h), 1e-8, "X_k(M) vs FD")   # measured ≤ 6.2e-10
    assert np.abs(dM[:, :6]).max() < 1e-14 * np.abs(dM).max()                # measured ≤ 5.1e-15 of 10.4
    N = np.einsum("nkij,nk->nij", dM, V) - 2 * md.coriolis_matrix(model, Q, V)
    assert_close(N, -np.swapaxes(N, 1, 2), 1e-14, "Ṁ − 2C skew")                # measured ≤ 1.6e-16


def test_world_reference_is_refused():
    """"world" would read as Pinocchio's WORLD (the twist at the world origin), which this is not."""
    model, _, _, Q, V = mechanism("chain")
    for call in (lambda: md.frame_jacobian(model, Q[0], "tool", reference="world"),
                 lambda: md.frame_jacobian_dot(model, Q[0], V[0], "tool", "world")):
        with pytest.raises(md.InputError, match="use 'local_world_aligned'"):
            call()
    assert_close(md.frame_jacobian(model, Q[0], "tool"),
                 md.frame_jacobian(model, Q[0], "tool", reference="local_world_aligned"), 0.0, "default")


def test_root_frame_jacobian_is_the_rotation():
    """The root's own frame: J_local = 1₆ (v is its body twist), J_lwa = diag(R, R); both J̇ follow from
    R's motion alone: J̇_local = 0, J̇_lwa = diag([ω]× R, [ω]× R)."""
    model, _, _, Q, V = mechanism("tree")
    for q, v in zip(Q, V):
        R, _ = md.frame_placement(model, q, "base")
        w = R @ v[3:6]
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        Z = np.zeros((3, 3))
        assert_close(md.frame_jacobian(model, q, "base", "local")[:, :6], np.eye(6), 1e-15, "J local")
        assert_close(md.frame_jacobian(model, q, "base")[:, :6], np.block([[R, Z], [Z, R]]), 1e-15, "J lwa")
        assert_close(md.frame_jacobian_dot(model, q, v, "base", "local")[:, :6], np.zeros((6, 6)), 1e-14, "J̇ local")
        assert_close(md.frame_jacobian_dot(model, q, v, "base")[:, :6], np.block([[W @ R, Z], [Z, W @ R]]), 1e-14, "J̇ lwa")
        assert not np.any(md.frame_jacobian(model, q, "base")[:, 6:])            # the joints do not move it
