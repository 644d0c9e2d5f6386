"""The compiled Lagrange terms, energies, frame kinematics and f_ext fast paths against Pinocchio:

coriolis_matrix (dynamics/coriolis.py, O(n²)) = computeCoriolisMatrix, nonlinear_effects = nonLinearEffects,
gravity_torques = computeGeneralizedGravity, kinetic/potential_energy = computeKineticEnergy/PotentialEnergy,
mass_matrix(method="lagrange") = crba, forward_dynamics(method="cholesky") = aba (× cond(M)), the single-state
frame calls = Pinocchio's frame placement, getFrameJacobian and getFrameJacobianTimeVariation, and one-state
rnea/aba/cholesky with f_ext (the per-model wrench rows) = Pinocchio with its per-joint fext — on the AAU arm,
zoo arms, random trees and solo12 on a free-flyer root; one single-state call and a batch per case. Then the
second route to C (the chapter's Christoffel symbols, lagrange.christoffel_coriolis), and the same kernels run
uncompiled (MANIPDYN_NOJIT=1) against the compiled ones.
"""

import numpy as np
import pinocchio as pin
import pytest
from conftest import err
from nojit import assert_uncompiled_equals_compiled
from test_aba import _wrenches, case, pin_fext

import manipdyn as md
from manipdyn.dynamics.lagrange import christoffel_coriolis

CASES = ["aau_arm", "ur5_robot", "panda", "kinova", "baxter", "allegro_right_hand", "tree3", "tree4", "solo12_floating"]

# Worst error over CASES (7 batched states + 1 single each), §3 measure; tolerance ≈ 30× the measured worst.
TOL = {
    "C": (1e-13, "2.9e-15"), "h": (5e-14, "1.8e-15"), "g": (5e-14, "2.0e-15"), "T": (5e-14, "1.4e-15"),
    "V": (5e-14, "1.7e-15"), "M_lagrange": (5e-14, "2.2e-15"), "R": (2e-14, "7.8e-16"), "p": (2e-14, "6.7e-16"),
    "J": (3e-14, "1.2e-15"), "dJ": (2e-13, "6.9e-15"),
}


def _pin_terms(c, q, v, frame):
    pm, pd, pq = c.pm, c.pm.createData(), c.to_pin(q)
    M = pin.crba(pm, pd, pq)
    out = dict(C=pin.computeCoriolisMatrix(pm, pd, pq, v).copy(), h=pin.nonLinearEffects(pm, pd, pq, v).copy(),
               g=pin.computeGeneralizedGravity(pm, pd, pq).copy(), T=pin.computeKineticEnergy(pm, pd, pq, v),
               V=pin.computePotentialEnergy(pm, pd, pq), M_lagrange=np.triu(M) + np.triu(M, 1).T)
    fid = pm.getFrameId(frame)
    pin.computeJointJacobians(pm, pd, pq)
    pin.computeJointJacobiansTimeVariation(pm, pd, pq, v)
    pin.updateFramePlacements(pm, pd)
    out.update(R=pd.oMf[fid].rotation.copy(), p=pd.oMf[fid].translation.copy())
    for ref, pref in (("local_world_aligned", pin.LOCAL_WORLD_ALIGNED), ("local", pin.LOCAL)):
        out["J", ref] = pin.getFrameJacobian(pm, pd, fid, pref).copy()
        out["dJ", ref] = pin.getFrameJacobianTimeVariation(pm, pd, fid, pref).copy()
    return out


def _ours(m, q, v, frame):
    R, p = md.frame_placement(m, q, frame)
    out = dict(C=md.coriolis_matrix(m, q, v), h=md.nonlinear_effects(m, q, v), g=md.gravity_torques(m, q),
               T=md.kinetic_energy(m, q, v), V=md.potential_energy(m, q),
               M_lagrange=md.mass_matrix(m, q, method="lagrange"), R=R, p=p)
    for ref in ("local_world_aligned", "local"):
        out["J", ref] = md.frame_jacobian(m, q, frame, ref)
        out["dJ", ref] = md.frame_jacobian_dot(m, q, v, frame, ref)
    return out


@pytest.mark.parametrize("name", CASES)
def test_terms_match_pinocchio_one_state_and_batch(name):
    c = case(name)
    m = c.model
    Q, V, _ = c.states(7, 51)
    frame = m.body_names[-1]
    batch = _ours(m, Q, V, frame)
    worst = {}
    for s in range(len(Q)):
        ref = _pin_terms(c, Q[s], V[s], frame)
        one = _ours(m, Q[s], V[s], frame) if s == 0 else None
        for k in ref:
            key = k[0] if isinstance(k, tuple) else k
            mine = [batch[k][s]] + ([one[k]] if one is not None else [])
            if s == 0:
                assert np.shape(one[k]) == np.shape(ref[k]), k
            worst[key] = max([worst.get(key, 0.0)] + [err(x, ref[k]) for x in mine])
    print(f"\n{name}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    for k, e in worst.items():
        assert e <= TOL[k][0], f"{k}: err {e:.2e} > {TOL[k][0]:.0e} (measured worst {TOL[k][1]})"


def _layouts(x):
    """x as a strided view (every other entry of a buffer whose gaps hold 7.0: read as if contiguous, they would
    give finite, wrong numbers), a reversed view of a reversed copy (negative strides), a read-only array and
    one whose data is not 8-byte aligned."""
    buf = np.full(2 * x.size, 7.0)
    buf[::2] = x
    ro = x.copy()
    ro.flags.writeable = False
    odd = np.frombuffer(bytearray(8 * x.size + 1), np.float64, x.size, offset=1)
    odd[...] = x
    assert not odd.flags.aligned
    return buf[::2], x[::-1].copy()[::-1], ro, odd


@pytest.mark.parametrize("name", ["aau_arm", "tree4"])
def test_one_state_calls_read_any_layout(name):
    """The one-state calls hand q and v to the compiled code as they are (_jit.entry: declared with any strides,
    read only): a strided, a reversed, a read-only and an unaligned state give Pinocchio's numbers as a plain
    array does."""
    c = case(name)
    m = c.model
    Q, V, _ = c.states(1, 57)
    frame = m.body_names[-1]
    ref = _pin_terms(c, Q[0], V[0], frame)
    for q, v in zip(_layouts(Q[0]), _layouts(V[0])):
        ours = _ours(m, q, v, frame)
        for k in ref:
            key = k[0] if isinstance(k, tuple) else k
            assert err(ours[k], ref[k]) <= TOL[key][0], (k, q.strides, q.flags.writeable)


# × cond(M) of each state: q̈ of the Cholesky route vs pin.aba; one-state f_ext calls vs Pinocchio's fext.
TOL_FD = 4e-16           # measured 1.3e-17 × cond (tree4)
TOL_FEXT = dict(rnea=5e-14, aba=5e-16, cholesky=3e-16)      # measured 1.5e-15 (τ), 1.7e-17, 1.0e-17 × cond (tree4)


@pytest.mark.parametrize("frame", ["local", "world"])
@pytest.mark.parametrize("name", ["ur5_robot", "baxter", "tree4", "solo12_floating"])
def test_forward_dynamics_cholesky_and_f_ext_one_state(name, frame):
    c = case(name)
    m = c.model
    Q, V, T = c.states(5, 53)
    fx = _wrenches(c, 5, np.random.default_rng(54))
    pd = c.pm.createData()
    qdd = md.forward_dynamics(m, Q, V, T, method="cholesky", joint_dynamics=False)   # Pinocchio's aba: no damping
    worst = dict(fd=0.0, rnea=0.0, aba=0.0, cholesky=0.0)
    for s in range(5):
        pq = c.to_pin(Q[s])
        cond = np.linalg.cond(pin.crba(c.pm, pd, pq))
        ref = pin.aba(c.pm, pd, pq, V[s], T[s]).copy()
        worst["fd"] = max(worst["fd"], err(qdd[s], ref) / cond)
        every = {k: (np.broadcast_to(f, (5, 3))[s].copy(), np.broadcast_to(n, (5, 3))[s].copy())
                 for k, (f, n) in fx.items()}
        # all wrenches at once (the checked path), and each alone (one wrench: the one-state fast path),
        # among them one on a frame turned and offset in its body
        for one in [every] + [{k: w} for k, w in every.items()]:
            pf = pin_fext(c, Q[s], one, frame)
            got = dict(rnea=md.rnea(m, Q[s], V[s], T[s], f_ext=one, f_ext_frame=frame),
                       aba=md.aba(m, Q[s], V[s], T[s], f_ext=one, f_ext_frame=frame),
                       cholesky=md.forward_dynamics(m, Q[s], V[s], T[s], f_ext=one, f_ext_frame=frame,
                                                    method="cholesky", joint_dynamics=False))   # (baxter: damping)
            want = dict(rnea=pin.rnea(c.pm, pd, pq, V[s], T[s], pf).copy(),
                        aba=pin.aba(c.pm, pd, pq, V[s], T[s], pf).copy())
            want["cholesky"] = want["aba"]
            for k in got:
                assert got[k].shape == (m.nv,)
                worst[k] = max(worst[k], err(got[k], want[k]) / (1.0 if k == "rnea" else cond))
    print(f"\n{name} ({frame}): " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    assert worst["fd"] <= TOL_FD
    for k in ("rnea", "aba", "cholesky"):
        assert worst[k] <= TOL_FEXT[k], k


@pytest.mark.parametrize("frame", ["local", "world"])
@pytest.mark.parametrize("name", ["tree4", "solo12_floating"])
def test_forward_dynamics_cholesky_batch_across_chunks(name, frame):
    """The Cholesky route works LANES = 64 states at a time: a batch of 150 (three chunks, the last partial) with
    a wrench that differs per state equals Pinocchio's aba with its fext, state by state."""
    c = case(name)
    m = c.model
    N = 150
    Q, V, T = c.states(N, 61)
    fx = _wrenches(c, N, np.random.default_rng(62))
    qdd = md.forward_dynamics(m, Q, V, T, f_ext=fx, f_ext_frame=frame, method="cholesky")
    assert qdd.shape == (N, m.nv)
    pd = c.pm.createData()
    worst = 0.0
    for s in range(N):
        pq = c.to_pin(Q[s])
        one = {k: (np.broadcast_to(f, (N, 3))[s].copy(), np.broadcast_to(n, (N, 3))[s].copy())
               for k, (f, n) in fx.items()}
        ref = pin.aba(c.pm, pd, pq, V[s], T[s], pin_fext(c, Q[s], one, frame)).copy()
        worst = max(worst, err(qdd[s], ref) / np.linalg.cond(pin.crba(c.pm, pd, pq)))
    print(f"\n{name} ({frame}): cholesky batch {worst:.1e} x cond")
    assert worst <= TOL_FEXT["cholesky"]


@pytest.mark.parametrize("name", ["aau_arm", "baxter", "tree3", "solo12_floating"])
def test_coriolis_two_routes_and_its_identities(name):
    """The O(n²) kernel against the chapter's Christoffel symbols of M (an independent route: ∂M/∂q from the
    link Jacobians' derivatives, numpy); C q̇ = h − g (Newton–Euler)."""
    c = case(name)
    m = c.model
    Q, V, _ = c.states(6, 55)
    C = md.coriolis_matrix(m, Q, V)
    e1 = err(C, christoffel_coriolis(m, Q, V))
    e2 = err(np.einsum("nij,nj->ni", C, V), md.nonlinear_effects(m, Q, V) - md.gravity_torques(m, Q))
    print(f"\n{name}: C vs Christoffel {e1:.1e}, C q̇ vs h − g {e2:.1e}")
    assert e1 <= 3e-14 and e2 <= 3e-14                 # measured ≤ 7.4e-16, 9.2e-16


def test_kinetic_energy_is_half_qdot_M_qdot():
    c = case("solo12_floating")
    Q, V, _ = c.states(6, 56)
    M = md.mass_matrix(c.model, Q)
    e = err(md.kinetic_energy(c.model, Q, V), 0.5 * np.einsum("ni,nij,nj->n", V, M, V))
    print(f"\nT vs ½ q̇ᵀ M q̇: {e:.1e}")
    assert e <= 3e-14                                  # measured 7.8e-16


# ---- the same sources, uncompiled --------------------------------------------------------------------------

NOJIT_CASES = ["double_pendulum", "tree4", "solo12_floating"]
PROBE = """
import json, sys
import numpy as np
sys.path[:0] = [{tests!r}, {here!r}]
import manipdyn as md
from manipdyn import _jit
import test_aba as T
out = {{"nojit": _jit.NOJIT}}
for name in {names!r}:
    c = T.case(name)
    m = c.model
    Q, V, Tau = c.states(3, 57)
    f = m.body_names[-1]
    fx = {{f: (np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.4]))}}
    out[name] = [x.tolist() for x in (
        md.coriolis_matrix(m, Q, V), md.coriolis_matrix(m, Q[0], V[0]), md.nonlinear_effects(m, Q, V),
        md.gravity_torques(m, Q[1]), np.atleast_1d(md.kinetic_energy(m, Q, V)), np.atleast_1d(md.potential_energy(m, Q[2])),
        md.mass_matrix(m, Q, method="lagrange"), md.frame_placement(m, Q[0], f)[0], md.frame_jacobian(m, Q[1], f, "local"),
        md.frame_jacobian_dot(m, Q[2], V[2], f), md.forward_dynamics(m, Q, V, Tau, method="cholesky"),
        md.forward_dynamics(m, Q[0], V[0], Tau[0], method="cholesky", f_ext=fx),
        md.rnea(m, Q[1], V[1], Tau[1], f_ext=fx, f_ext_frame="world"), md.aba(m, Q[2], V[2], Tau[2], f_ext=fx))]
print(json.dumps(out))
"""



def test_uncompiled_source_gives_the_compiled_numbers():
    assert_uncompiled_equals_compiled(PROBE, __file__, NOJIT_CASES, tol=1e-14)   # measured 2.2e-16 (fma/ordering)
