"""Closed chains through the registry's newer kinds — a screw (helical), a universal and a planar joint in one loop,
and a loop on a URDF ``floating`` root — against Pinocchio 4.1's constraint dynamics.

The mechanisms (seeded random placements, axes, pitches, masses and inertias: tests/joint_kinds.py's kinds_robot):
  screw_loop     world -screw- l0 -universal- l1,  world -planar- l2 -revolute- l3,  a spherical closure l1 ~ l3
  floating_loop  world -floating- l0 -screw- l1 -universal- l2,  l0 -planar- l3,  a spherical closure l2 ~ l3
(mobility 7 − 3 = 4 and 6 + 6 − 3 = 9). Ours: the URDF text with a ``<constraint type="spherical">`` through
load_urdf_string. Pinocchio's: the same numbers through JointModelHelicalUnaligned, JointModelUniversal,
JointModelPlanar, JointModelFreeFlyer, with a RigidConstraintModel (CONTACT_3D) between the same two points.
The closure point on the second body is placed where the first body's point is at a random configuration, so the
loop closes there; the states are assembled from guesses around it (constraints.assemble, velocities projected).

Compared at each state: Pinocchio sees the loop closed (the points' world gap); Φ_q and Φ̇_q q̇ against the two
points' frame Jacobians and classical accelerations at q̈ = 0 (LOCAL_WORLD_ALIGNED) and the second difference of Φ
along q ⊕ t q̇; the constrained q̈ of both routes (the compiled
one and the readable one) against constraintDynamics, and it keeps Φ̈ = 0; a batch equals single calls.
Measured (2 mechanisms × seeds 0-2, 3 states each), conftest's err: Pinocchio's gap − Φ ≤ 6.7e-16, Φ_q ≤ 7.3e-16,
Φ̇_q q̇ ≤ 3.1e-15 (≤ 1.6e-9 against the differences), q̈ ≤ 1.7e-14 (both routes), |Φ_q q̈ + Φ̇_q q̇| ≤ 3.6e-14.
(Pinocchio 4.1's getFrameJacobianTimeVariation gives (J̇_A − J̇_B) q̇ off by ~0.1 here, where its classical
accelerations, the differences and ours agree: hence the accelerations as the reference. The joint at fault is its
JointModelUniversal: on a universal joint carrying a revolute one, J̇ q̇ − the classical acceleration is 9.3e-2, on a
helical, planar, prismatic, revolute or free-flyer joint ≤ 8.9e-16, measured.)
"""
from __future__ import annotations

import functools
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import err
from joint_kinds import kinds_robot

import manipdyn as md
from manipdyn.constraints import assemble, closure_terms, constrained_forward_dynamics, project
from manipdyn.constraints.dynamics import constrained_forward_dynamics_reference
from manipdyn.errors import ConstraintError
from manipdyn.validation.closed import PROXIMAL

LOOPS = {
    "screw_loop": ([("screw", -1), ("universal", 0), ("planar", -1), ("revolute", 2)], ("l1", "l3")),
    "floating_loop": ([("floating", -1), ("screw", 0), ("universal", 1), ("planar", 0)], ("l2", "l3")),
}
CASES = [(name, seed) for name in LOOPS for seed in range(3)]
TOL = dict(gap=5e-14, J=5e-14, acc=3e-13, diff=1e-7, qdd=1e-12, keep=3e-12)     # ≤ 100× the worst measured (the docstring)
H = 1e-3            # the differences' step (truncation ~H⁴, rounding ~1e-16 / H²)


def _closed_text(text, a, pa, b, pb):
    v = lambda x: " ".join(f"{c:.17g}" for c in x)     # noqa: E731
    return text.replace("</robot>", f'<constraint name="ball" type="spherical"><parent link="{a}"/>'
                        f'<parent_origin xyz="{v(pa)}"/><child link="{b}"/><child_origin xyz="{v(pb)}"/>'
                        f'</constraint></robot>')


@functools.lru_cache(maxsize=None)
def mechanism(name, seed):
    """(our model, Pinocchio's model, its constraint models, the two points' frame ids, assembled states)."""
    tree, (a, b) = LOOPS[name]
    text, pm = kinds_robot(name, seed, tree=tree)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        open_model = md.load_urdf_string(text, source=f"{name}.urdf")
    rng = np.random.default_rng(seed + 10)
    q0 = md.random_configuration(open_model, rng)
    ja, jb = pm.getJointId("j" + a[1:]), pm.getJointId("j" + b[1:])
    pd = pm.createData()
    pin.forwardKinematics(pm, pd, q0)
    pa = rng.uniform(-0.2, 0.2, 3)
    pb = pd.oMi[jb].actInv(pd.oMi[ja].act(pa))                  # the loop closes at q0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_urdf_string(_closed_text(text, a, pa, b, pb), source=f"{name}.urdf")
    assert model.nq == pm.nq and model.nv == pm.nv and len(model.constraints) == 1
    cms = pin.StdVec_RigidConstraintModel()
    cms.append(pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pm, ja, pin.SE3(np.eye(3), pa), jb,
                                        pin.SE3(np.eye(3), pb), pin.ReferenceFrame.LOCAL))
    frames = [pm.addFrame(pin.Frame(f"side{k}", j, pm.getFrameId(f"j{j_name[1:]}"), pin.SE3(np.eye(3), p),
                                    pin.FrameType.OP_FRAME))
              for k, (j, j_name, p) in enumerate(((ja, a, pa), (jb, b, pb)))]
    states = []
    for _ in range(30):
        guess = md.integrate(model, q0, rng.normal(0.0, 0.1, model.nv))
        try:
            q = assemble(model, guess, fixed=[], restarts=0).q
        except ConstraintError:
            continue
        q, v = project(model, q, rng.normal(0.0, 1.0, model.nv))
        states.append((q, v, rng.normal(0.0, 1.0, model.nv)))
        if len(states) == 3:
            return model, pm, cms, frames, states
    raise AssertionError(f"{name} seed {seed}: {len(states)} of 3 guesses assembled")   # measured: every guess


@pytest.mark.parametrize("name, seed", CASES)
def test_closure_rows_against_pinocchio_frames(name, seed):
    """Φ = p_A − p_B, Φ_q = J_A,v − J_B,v at the two points' frames (LOCAL_WORLD_ALIGNED), and Φ̇_q q̇ = the
    difference of the two points' classical accelerations at q̈ = 0 — and the second derivative of Φ along
    q ⊕ t q̇ (a path of constant q̇), by fourth-order central differences."""
    model, pm, _, frames, states = mechanism(name, seed)
    pd = pm.createData()
    for q, v, _ in states:
        pin.computeJointJacobians(pm, pd, q)
        pin.forwardKinematics(pm, pd, q, v, 0.0 * v)
        pin.updateFramePlacements(pm, pd)
        J = [pin.getFrameJacobian(pm, pd, f, pin.LOCAL_WORLD_ALIGNED)[:3] for f in frames]
        acc = [pin.getFrameClassicalAcceleration(pm, pd, f, pin.LOCAL_WORLD_ALIGNED).linear for f in frames]
        gap = pd.oMf[frames[0]].translation - pd.oMf[frames[1]].translation
        Phi, Phi_q, bias = closure_terms(model, q, v)
        assert np.abs(Phi).max() < 1e-11                    # assembled (assemble's tol 1e-12 on its Newton step)
        assert np.abs(gap - Phi).max() < TOL["gap"]         # Pinocchio's gap is ours
        assert err(J[0] - J[1], Phi_q) < TOL["J"]
        assert err(acc[0] - acc[1], bias) < TOL["acc"]
        f = lambda t: closure_terms(model, md.integrate(model, q, t * v))[0]     # noqa: E731
        second = (-f(2 * H) + 16 * f(H) - 30 * f(0.0) + 16 * f(-H) - f(-2 * H)) / (12 * H * H)
        assert err(second, bias) < TOL["diff"]


@pytest.mark.parametrize("name, seed", CASES)
def test_constrained_qdd_against_pinocchio(name, seed):
    model, pm, cms, _, states = mechanism(name, seed)
    pd = pm.createData()
    cds = pin.StdVec_RigidConstraintData()
    cds.append(cms[0].createData())
    pin.initConstraintDynamics(pm, pd, cms, cds)
    settings = pin.ProximalSettings(PROXIMAL["accuracy"], PROXIMAL["mu"], PROXIMAL["max_iter"])
    Q, V, T = (np.array(x) for x in zip(*states))
    for q, v, tau in states:
        ref = pin.constraintDynamics(pm, pd, q, v, tau, cms, cds, settings).copy()
        fast = constrained_forward_dynamics(model, q, v, tau)[0]
        readable = constrained_forward_dynamics_reference(model, q, v, tau)[0]
        assert err(ref, fast) < TOL["qdd"] and err(ref, readable) < TOL["qdd"]
        assert np.abs(closure_terms(model, q, v)[1] @ fast + closure_terms(model, q, v)[2]).max() < TOL["keep"]
    batch = constrained_forward_dynamics(model, Q, V, T)[0]
    for k, (q, v, tau) in enumerate(states):
        assert err(constrained_forward_dynamics(model, q, v, tau)[0], batch[k]) < 1e-14
