"""Closed chains on a free-flyer root (nq = nv + 1): assembly, completion, projection, KKT forward and
inverse dynamics, rank and actuation reports, simulation — against independent references.

The mechanisms: the spatial loops of tests/data/loops (every closure row independent) and the planar
four-bar (urdf/fourbar.urdf, 3 of its 5 rows redundant), each with its base link given a mass of 2 kg
(their base links are massless: floating, a massless base on one revolute joint leaves M singular) and
loaded with root_joint="free_flyer"; the closures are internal to the robot. References:
- Pinocchio's constraintDynamics on buildModelFromUrdf(path, JointModelFreeFlyer()) (validation.closed:
  the repo's RigidConstraintModels), and the inversion of its forward map for the actuator forces;
- the fixed-base model of the same file: internal closures do not care where the base is, so the joints
  assemble to the same values, with the same rates;
- central differences of Φ along q ⊕ t e_k (configuration.integrate): Φ_q's columns are v-space;
- physical laws: closure residuals after assembly and projection, the projection's impulse −Φ_qᵀλ is
  internal (the base's generalized momentum (M v)[:6] is unchanged), energy over a simulate() run (RK4,
  fourth order in dt), linear momentum R_base (M v)[:3] conserved without gravity, changing by m g t with it.
"""
import functools
import json
import re
import warnings

import numpy as np
import pytest
from conftest import ROOT, assert_close, err

import manipdyn as md
from manipdyn.constraints import (actuation_status, assemble, closure_terms, complete_state,
                                  constrained_forward_dynamics, constrained_inverse_dynamics, project, rank_report)
from manipdyn.constraints.dynamics import constrained_forward_dynamics_reference, dofs
from manipdyn.joints import quat_to_matrix

pin = pytest.importorskip("pinocchio")
from manipdyn.validation.closed import ClosedReference, actuator_torques_by_inversion  # noqa: E402
from manipdyn.validation.reference import Reference  # noqa: E402

LOOPS = ROOT / "tests" / "data" / "loops"
MANIFEST = json.loads((LOOPS / "manifest.json").read_text())
SPECS = {**{n: (LOOPS / s["file"], s["q0"], s["rank"]) for n, s in MANIFEST.items()},
         "fourbar": (ROOT / "urdf" / "fourbar.urdf", [0.3, -1.3, -2.0], 2)}
NAMES = list(SPECS)
BASE = ('<link name="base"><inertial><origin xyz="0.05 -0.02 0.1"/><mass value="2.0"/><inertia ixx="0.02" '
        'iyy="0.03" izz="0.04" ixy="0.001" ixz="0" iyz="0"/></inertial>')
BASE_MASS = 2.0


@functools.lru_cache(maxsize=None)
def mech(name):
    """Floating model, fixed-base model, Pinocchio's closure reference, and 3 seeded completed states."""
    import tempfile
    from pathlib import Path
    src, q0, rank = SPECS[name]
    path = Path(tempfile.mkdtemp(prefix="floatloop")) / src.name
    text = src.read_text()
    text, n = re.subn(r'<link name="base"\s*/>', BASE + "</link>", text)   # a bare base link, or one with
    if not n:                                                                # visuals only: add the inertial
        text, n = re.subn(r'<link name="base">', BASE, text)
    assert n == 1 and text.count("<inertial>", text.index('<link name="base">'),
                                 text.index("</link>", text.index('<link name="base">'))) == 1
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model, fixed = md.load_urdf(path, root_joint="free_flyer"), md.load_urdf(path)
    cref = ClosedReference(Reference(model, path))
    rng = np.random.default_rng(sum(map(ord, name)))
    act = [model.joint_index(j) for j in model.actuated]
    G, VA, AA = [], [], []
    for _ in range(3):
        g = md.random_configuration(model, rng)
        g[7:] = np.array(q0) + rng.normal(0.0, 0.03, model.nv - 6)
        G.append(g)
        VA.append(rng.normal(0.0, 2.0, len(act)))
        AA.append(rng.normal(0.0, 5.0, len(act)))
    return dict(model=model, fixed=fixed, cref=cref, path=path, rank=rank, act=act, G=np.array(G),
                VA=np.array(VA), AA=np.array(AA), rng=rng)


def completed(name):
    """(q, v, a) on the closures from the seeded guesses; the base at rest (then given a random twist for
    the dynamics tests, which the closures allow: their base columns vanish on the manifold)."""
    M = mech(name)
    q, v, a, asm = complete_state(M["model"], M["G"], M["VA"], M["AA"])
    return q, v, a, asm


# ------------------------------------------------------------------ kinematics: assembly, completion, projection
@pytest.mark.parametrize("name", NAMES)
def test_complete_state_on_a_floating_base(name):
    """Φ = 0, Φ_q q̇ = 0, Φ_q q̈ + Φ̇_q q̇ = 0 after completion; the base stays at the guess and at rest; the
    joints take the values and rates the fixed-base model of the same file gives from the same guess."""
    M = mech(name)
    model, fixed = M["model"], M["fixed"]
    q, v, a, asm = completed(name)
    Phi, Jc, bias = closure_terms(model, q, v)
    res = dict(phi=np.abs(Phi).max(), vel=np.abs(np.einsum("nij,nj->ni", Jc, v)).max(),
               acc=np.abs(np.einsum("nij,nj->ni", Jc, a) + bias).max())
    fq, fv, fa, _ = complete_state(fixed, M["G"][:, 7:], M["VA"], M["AA"])
    same = dict(q=err(q[:, 7:], fq), v=err(v[:, 6:], fv), a=err(a[:, 6:], fa))
    print(f"\n{name}: residuals {res}; against the fixed base {same}; iterations {asm.iterations.tolist()}")
    assert res["phi"] <= 1e-11 and res["vel"] <= 1e-12 and res["acc"] <= 1e-11   # measured ≤ 8.1e-13, 1.8e-14, 4.5e-13
    assert all(e <= 1e-12 for e in same.values()), same                           # measured ≤ 2.3e-14
    assert np.array_equal(q[:, :3], M["G"][:, :3]) and np.abs(q[:, 3:7] - M["G"][:, 3:7]).max() <= 4e-16
    assert not v[:, :6].any() and not a[:, :6].any()


@pytest.mark.parametrize("name", NAMES)
def test_closure_jacobian_columns_are_derivatives_along_integrate(name):
    """Column k of Φ_q (m, nv) = dΦ(q ⊕ t e_k)/dt at t = 0 (central differences, h = 1e-6), base columns too."""
    model = mech(name)["model"]
    q = completed(name)[0][0]
    q = md.integrate(model, q, np.random.default_rng(3).normal(0.0, 0.05, model.nv))      # off the closures too
    _, Jc, _ = closure_terms(model, q)
    h, E = 1e-6, np.eye(model.nv)
    fd = np.array([(closure_terms(model, md.integrate(model, q, h * e))[0]
                    - closure_terms(model, md.integrate(model, q, -h * e))[0]) / (2 * h) for e in E]).T
    print(f"\n{name}: Φ_q vs differences along q ⊕ t e_k: {err(Jc, fd):.1e}")
    assert_close(Jc, fd, 1e-8, "Φ_q")      # measured ≤ 1.5e-10 (h = 1e-6: round-off ε/h)
    assert np.abs(Jc[:, :3]).max() == 0.0   # sliding the whole robot moves no closure


@pytest.mark.parametrize("name", NAMES)
def test_assemble_from_a_poor_guess_keeps_the_base(name):
    """Every joint free (fixed=[]), guesses 0.3 rad off: Φ = 0 reached by tangent-space Newton steps."""
    M = mech(name)
    model = M["model"]
    rng = np.random.default_rng(11)
    q = completed(name)[0][0]
    for _ in range(3):
        g = md.integrate(model, q, np.concatenate([rng.normal(0.0, 0.5, 6), rng.normal(0.0, 0.3, model.nv - 6)]))
        asm = assemble(model, g, fixed=[])
        phi = np.abs(closure_terms(model, asm.q)[0]).max()
        assert phi <= 1e-11, phi                                           # measured ≤ 9.3e-13
        assert np.abs(asm.q[:7] - g[:7]).max() <= 4e-16                   # the base: only renormalised
    with pytest.raises(md.InputError, match=r"quaternion root_joint.\(qx qy qz qw\) .* has norm 2"):
        assemble(model, np.concatenate([q[:3], 2.0 * q[3:7], q[7:]]))


@pytest.mark.parametrize("name", NAMES)
def test_project_on_a_floating_base(name):
    """Drifted states back to Φ = 0, Φ_q q̇ = 0; the base pose stays; the velocity change is the response
    to an internal impulse: M (v⁺ − v) = −Φ_qᵀ λ has no component on the base ((M v)[:6] unchanged)."""
    M = mech(name)
    model = M["model"]
    rng = np.random.default_rng(12)
    q0 = completed(name)[0]
    Q = md.integrate(model, q0, rng.normal(0.0, 1e-3, (len(q0), model.nv)))
    V = rng.normal(0.0, 2.0, (len(q0), model.nv))
    Qp, Vp = project(model, Q, V)
    Phi, Jc, _ = closure_terms(model, Qp)
    phi, vel = np.abs(Phi).max(), np.abs(np.einsum("nij,nj->ni", Jc, Vp)).max()
    Mm = md.mass_matrix(model, Qp)
    p, pp = np.einsum("nij,nj->ni", Mm, V), np.einsum("nij,nj->ni", Mm, Vp)
    mom = err(pp[:, :6], p[:, :6])
    imp = max(np.abs(Jc[s].T @ np.linalg.lstsq(Jc[s].T, pp[s] - p[s], rcond=None)[0] - (pp[s] - p[s])).max()
              for s in range(len(Q)))
    print(f"\n{name}: |Φ| {phi:.1e}, |Φ_q v| {vel:.1e}, base momentum {mom:.1e}, impulse off range(Φ_qᵀ) {imp:.1e}")
    assert phi <= 1e-11 and vel <= 1e-11                    # measured ≤ 6.3e-13, 1.3e-12 (fourbar)
    assert mom <= 1e-12 and imp <= 1e-13                    # measured ≤ 7.2e-14, 3.6e-15
    assert np.abs(Qp[:, :7] - Q[:, :7]).max() <= 4e-16


# ------------------------------------------------------------------ dynamics
def moving(name):
    """Completed states with a random base twist and random forces on every entry (the base's: a wrench)."""
    M = mech(name)
    q, v, _, _ = completed(name)
    rng = np.random.default_rng(13)
    v = v.copy()
    v[:, :6] = rng.normal(0.0, 1.0, (len(v), 6))
    return q, v, rng.normal(0.0, 1.0, v.shape), M


@pytest.mark.parametrize("name", NAMES)
def test_forward_dynamics_against_pinocchio(name):
    """q̈ against Pinocchio's constraintDynamics with the free flyer; the compiled and readable KKT solves."""
    q, v, tau, M = moving(name)
    model = M["model"]
    qdd, _ = constrained_forward_dynamics(model, q, v, tau)
    r_qdd, _ = constrained_forward_dynamics_reference(model, q, v, tau)
    worst = max(err(qdd[s], M["cref"].qdd(q[s], v[s], tau[s])) for s in range(len(q)))
    print(f"\n{name}: q̈ vs Pinocchio {worst:.1e}, compiled vs readable {err(qdd, r_qdd):.1e}")
    assert worst <= 1e-11                                 # measured ≤ 5.9e-13 (Pinocchio's proximal solver)
    assert_close(qdd, r_qdd, 2e-13, "compiled vs readable")   # measured ≤ 2.5e-15
    for s in range(len(q)):
        rep = rank_report(model, closure_terms(model, q[s])[1])
        assert rep.rank == M["rank"], str(rep)
        _, Jc, bias = closure_terms(model, q[s], v[s])
        assert np.abs(Jc @ qdd[s] + bias).max() <= 1e-9   # Eq. 26 holds: measured ≤ 3.6e-11


@pytest.mark.parametrize("name", NAMES)
def test_inverse_dynamics_on_a_floating_base(name):
    """Actuated joints only (the base free): the actuator forces that made a forward-dynamics motion are
    recovered; with the base listed as actuated (a wrench on it), against the inverted constraintDynamics.
    actuation_status: "under" with a free base, "fully" with it listed."""
    q, v, _, M = moving(name)
    model, act = M["model"], M["act"]
    rng = np.random.default_rng(14)
    for s in range(len(q)):
        ta = rng.normal(0.0, 1.0, len(act))
        tau = np.zeros(model.nv)
        tau[dofs(model, act)] = ta                         # entries of v: after the base's six
        a, _ = constrained_forward_dynamics(model, q[s], v[s], tau)
        got, _ = constrained_inverse_dynamics(model, q[s], v[s], a)
        assert_close(got, ta, 5e-13, "τ_a, base free")   # measured ≤ 6.5e-15
        names = list(model.actuated) + ["root_joint"]
        idx = dofs(model, [model.joint_index(j) for j in names])
        got, _ = constrained_inverse_dynamics(model, q[s], v[s], a, actuated=names)
        ref = actuator_torques_by_inversion(model, M["cref"], q[s], v[s], a[idx], idx)
        assert_close(got, ref, 5e-10, "τ_a, base actuated")   # measured ≤ 5.9e-12
        assert_close(got[:len(act)], ta, 5e-13, "τ_a")       # the same motion: the base needs no wrench
        assert np.abs(got[len(act):]).max() <= 3e-12         # measured ≤ 4.3e-14
        assert actuation_status(model, q[s]) == "under" and actuation_status(model, q[s], names) == "fully"
    with pytest.raises(md.ConstraintError, match="cannot produce this motion"):   # a base pushed by nothing
        constrained_inverse_dynamics(model, q[s], v[s], a + np.concatenate([np.ones(6), np.zeros(model.nv - 6)]))


# ------------------------------------------------------------------ simulation: physical laws
def _linear_momentum(model, r):
    """World linear momentum R_base (M v)[:3] along a trajectory (T, 3)."""
    p = np.einsum("nij,nj->ni", md.mass_matrix(model, r.q), r.v)[:, :3]
    R = np.empty((3, 3))
    out = []
    for k in range(len(r.t)):
        quat_to_matrix(*r.q[k, 3:7], R)
        out.append(R @ p[k])
    return np.array(out)


SIM_ERR = {"rusr_revolute": (2.2e-12, 6.4e-11, 1.5e-12), "weld7": (4.2e-10, 3.2e-9, 3.3e-10),
           "fourbar": (6.3e-14, 8.9e-14, 4.2e-14)}   # measured energy drift, max |Φ|, momentum error at dt 0.5 ms


@pytest.mark.parametrize("name", list(SIM_ERR))
def test_simulate_a_floating_closed_chain(name):
    """0.5 s torque-free, RK4, no stabilisation, the base tumbling, the actuators at 4 rad/s: T + V constant
    to RK4's error (falls by ~16 when dt halves), |Φ| likewise; linear momentum changes by m_total g t."""
    M = mech(name)
    model = M["model"]
    q, v, _, _ = complete_state(model, M["G"][0], np.full(len(M["act"]), 4.0), np.zeros(len(M["act"])))
    v[:6] = [0.3, -0.2, 0.1, 0.5, -0.4, 0.6]
    q, v = project(model, q, v)
    drift, phi, mom = [], [], []
    m_total = float(np.sum(model.mass))
    for dt in (1e-3, 5e-4):
        r = md.simulate(model, q, v, (0.0, 0.5), dt=dt, integrator="rk4")
        E = md.kinetic_energy(model, r.q, r.v) + md.potential_energy(model, r.q)
        drift.append(np.abs(E - E[0]).max() / md.kinetic_energy(model, r.q, r.v).max())
        phi.append(np.abs(closure_terms(model, r.q)[0]).max())
        P = _linear_momentum(model, r)
        mom.append(err(P - P[0], m_total * np.outer(r.t, model.gravity)))
    print(f"\n{name}: energy drift {drift}, |Φ| {phi}, momentum {mom}")
    assert all(x <= 30 * ref for x, ref in zip((drift[1], phi[1], mom[1]), SIM_ERR[name])), (drift, phi, mom)
    assert 12 < drift[0] / drift[1] < 20 and 12 < phi[0] / phi[1] < 20   # measured 15.4–16.2: fourth order
