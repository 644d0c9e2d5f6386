"""Spatial closed chains whose closure rows are all independent, against independent references.

The mechanisms (tests/data/loops, written by make_loops.py there) are a spatial RUSR four-bar closed by a
revolute closure (rank 5 of 5), two spatial branches welded by a fixed closure (6 of 6), a spatial RUSR
with a spherical closure (3 of 3), a spatial slider-crank with an actuated prismatic slider (3 of 3), and
the first two side by side (11 of 11, the fixed closure's rows at offset 5). Unlike the planar four-bar and
the spherical SPM, no closure row is redundant here, so every orientation row and every pair of the fixed
closure shows in the dynamics.

References, none of them manipdyn's closure code:
- ``PinLoops``: Φ, Φ_q and Φ̇_q q̇ from Pinocchio's kinematics (joint placements, Jacobians, and
  accelerations at q̈ = 0) and the closure frames read from the URDF XML here, with the row convention
  written out again from closures.py's docstring; Φ̇_q q̇ as the second derivative of each row
  (ä·b + 2ȧ·ḃ + a·b̈), not the library's (a × b)·(ω_A − ω_B) form.
- the KKT system [M Φ_qᵀ; Φ_q 0] solved densely with Pinocchio's crba and rnea (off the manifold, where
  Pinocchio's own closure rows are different functions and so give a different q̈);
- Pinocchio's constraintDynamics (CONTACT_6D for fixed, CONTACT_3D for spherical, two 3-D points on the
  axis for revolute; Baumgarte gains 0) on the manifold, and off it for spherical closures, whose 3-D
  point rows are the same functions as ours;
- ``PinClosures`` (tests/pin_closures.py): the same rows from Pinocchio's frame placements, frame Jacobians
  and their time variation at operational frames added on the closure points (Φ_q = J_A − J_B);
- central finite differences of Φ and of Φ_q along q̇; the law of energy conservation.
The same loops with a free-flyer root (the base link floating) are held to PinClosures on Pinocchio's
free-flyer model and to differences along q ⊕ t v. The compiled KKT kernel (constraints/fast.py, the route
``constrained_forward_dynamics`` takes without f_ext) is compared with the readable KKT solve (dynamics.py).
"""
import functools
import json
import zlib
from xml.etree import ElementTree

import numpy as np
import pytest
from conftest import ROOT, assert_close, err
from free_flyer import integrate, random_floating_states, with_free_flyer
from pin_closures import PinClosures, _perp

import manipdyn as md
from manipdyn.constraints import (closure_terms, complete_state, constrained_forward_dynamics,
                                  constrained_inverse_dynamics, rank_report)
from manipdyn.constraints.dynamics import constrained_forward_dynamics_reference
from manipdyn.constraints.fast import constrained_fd_fast
from manipdyn.validation.closed import ClosedReference, actuator_torques_by_inversion
from manipdyn.validation.reference import Reference, pin

LOOPS = ROOT / "tests" / "data" / "loops"
MANIFEST = json.loads((LOOPS / "manifest.json").read_text())
NAMES = list(MANIFEST)
SPHERICAL_ONLY = ["rusr_spherical", "slider_crank"]
FD_STEP = 1e-6


# ------------------------------------------------------------------ Pinocchio-based closure rows
def _vec(el, key, default):
    return np.array([float(x) for x in (default if el is None else el.get(key, default)).split()])


class PinLoops:
    """Closure rows of a URDF from Pinocchio's kinematics; the closure frames parsed from the XML."""

    def __init__(self, path):
        P = pin()
        self.pm = P.buildModelFromUrdf(str(path))
        self.pd = self.pm.createData()
        self.sides = []      # per closure: type, and for each side (joint id, placement in the joint frame, axis)
        for e in ElementTree.parse(path).getroot().findall("constraint"):
            sides = []
            for s in ("parent", "child"):
                fr = self.pm.frames[self.pm.getFrameId(e.find(s).get("link"))]
                org = e.find(f"{s}_origin")
                X = fr.placement * P.SE3(P.rpy.rpyToMatrix(*_vec(org, "rpy", "0 0 0")), _vec(org, "xyz", "0 0 0"))
                ax = fr.placement.rotation @ _vec(e.find(f"{s}_axis"), "xyz", "0 0 1")
                sides.append((fr.parentJoint, X, ax / np.linalg.norm(ax)))
            self.sides.append((e.get("type"), sides))

    def _side(self, j, X):
        """World point, point Jacobian (3, nv), angular Jacobian (3, nv), ω, α, point acceleration at q̈ = 0."""
        P, pd = pin(), self.pd
        if j == 0:
            z = np.zeros((3, self.pm.nv))
            return X.translation, z, z, np.zeros(3), np.zeros(3), np.zeros(3)
        M = pd.oMi[j]
        x = M.act(X.translation)
        J = P.getJointJacobian(self.pm, pd, j, P.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        Jp = J[:3] - np.cross(x - M.translation, J[3:].T).T        # linear velocity of x = v_o + ω × r
        v, a, r = pd.v[j], pd.a[j], X.translation                   # local; a: spatial, at q̈ = 0
        acc = a.linear + np.cross(a.angular, r) + np.cross(v.angular, v.linear + np.cross(v.angular, r))
        R = M.rotation
        return x, Jp, J[3:], R @ v.angular, R @ a.angular, R @ acc

    def terms(self, q, v):
        """Φ (m,), Φ_q (m, nv), Φ̇_q q̇ (m,): position rows p_A − p_B, then the orientation rows a·b."""
        P, pm, pd = pin(), self.pm, self.pd
        P.forwardKinematics(pm, pd, q, v, np.zeros(pm.nv))
        P.computeJointJacobians(pm, pd, q)
        phi, jac, bias = [], [], []
        for kind, ((ja, XA, eA), (jb, XB, eB)) in self.sides:
            xA, JpA, JwA, wA, alA, accA = self._side(ja, XA)
            xB, JpB, JwB, wB, alB, accB = self._side(jb, XB)
            phi += list(xA - xB)
            jac += list(JpA - JpB)
            bias += list(accA - accB)
            if kind == "revolute":     # a ⊥ the parent axis, b = the child axis (both in joint frames)
                pairs = [(n, eB) for n in _perp(eA)]
            elif kind == "fixed":
                A, B = XA.rotation, XB.rotation
                pairs = [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 1])]
            else:
                pairs = []
            for a0, b0 in pairs:
                a, b = pd.oMi[ja].rotation @ a0, pd.oMi[jb].rotation @ b0
                da, db = np.cross(wA, a), np.cross(wB, b)
                dda = np.cross(alA, a) + np.cross(wA, da)
                ddb = np.cross(alB, b) + np.cross(wB, db)
                phi.append(a @ b)
                jac.append(np.cross(a, b) @ (JwA - JwB))
                bias.append(dda @ b + 2.0 * da @ db + a @ ddb)
        return np.array(phi), np.array(jac), np.array(bias)

    def phi(self, q):
        return self.terms(q, np.zeros(self.pm.nv))[0]


# ------------------------------------------------------------------ the mechanisms and their states
@functools.lru_cache(maxsize=None)
def loop(name):
    """Model, Pinocchio references and seeded states of one mechanism (cached per module run)."""
    spec, path = MANIFEST[name], LOOPS / MANIFEST[name]["file"]
    model = md.load_urdf(path)
    ref = Reference(model, path)
    cref = ClosedReference(ref)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    act = [model.joint_index(j) for j in model.actuated]
    q0 = np.array(spec["q0"])
    on = []
    for _ in range(3):            # on the closures: actuators moved from q0, passive joints completed
        g = q0 + rng.normal(0.0, 0.03, model.nv)
        g[act] += [rng.uniform(-0.15, 0.15) * (1.0 if model.kind[i] == 0 else 0.2) for i in act]
        on.append(complete_state(model, g, rng.normal(0.0, 2.0, len(act)), rng.normal(0.0, 5.0, len(act)))[:3])
    Q, V, A = (np.array(x) for x in zip(*on))
    Voff = rng.normal(0.0, 2.0, Q.shape)                       # velocities off Φ_q q̇ = 0
    Qnear = Q + rng.normal(0.0, 1e-4, Q.shape)                 # |Φ| ~ 1e-4: every row still kept
    Qfar = np.where(model.kind == 0, rng.uniform(-np.pi, np.pi, Q.shape), rng.uniform(-0.5, 0.5, Q.shape))
    return dict(model=model, ref=ref, cref=cref, pin=PinLoops(path), act=act, rank=spec["rank"], Q=Q, V=V, A=A,
                Voff=Voff, Qnear=Qnear, Qfar=Qfar, Vfar=rng.normal(0.0, 2.0, Q.shape),
                tau=rng.normal(0.0, 1.0, Q.shape))


def states(L, which):
    """(Q, V) of a state set: on the closures, velocity off, position and velocity off (near), far off."""
    return {"on": (L["Q"], L["V"]), "v_off": (L["Q"], L["Voff"]), "near": (L["Qnear"], L["Voff"]),
            "far": (L["Qfar"], L["Vfar"])}[which]


ALL_SETS = ["on", "v_off", "near", "far"]


# ------------------------------------------------------------------ kinematics of the closures
@pytest.mark.parametrize("name", NAMES)
def test_closures_hold_at_q0_and_rank(name):
    """Φ(q0) = 0 per Pinocchio; the rank of Φ_q is the mobility count's, by SVD of Pinocchio's rows too."""
    L = loop(name)
    model = L["model"]
    q0 = np.array(MANIFEST[name]["q0"])
    assert np.abs(L["pin"].phi(q0)).max() < 1e-14                    # measured ≤ 6e-16
    for s in range(len(L["Q"])):
        _, Jc, _ = closure_terms(model, L["Q"][s:s + 1])
        rep = rank_report(model, Jc[0])
        assert (rep.rank, rep.rows, rep.redundant) == (L["rank"], L["rank"], ()), str(rep)
        sv = np.linalg.svd(L["pin"].terms(L["Q"][s], L["V"][s])[1], compute_uv=False)
        assert sv[-1] / sv[0] > 0.01 and len(sv) == L["rank"]           # measured ≥ 0.063: well-conditioned
    _, _, _, rank = constrained_fd_fast(model, L["Q"], L["V"], L["tau"])
    assert list(rank) == [L["rank"]] * len(L["Q"])


@pytest.mark.parametrize("which", ALL_SETS)
@pytest.mark.parametrize("name", NAMES)
def test_closure_terms_against_pinocchio(name, which):
    """Φ, Φ_q, Φ̇_q q̇ of closures.py equal the rows built from Pinocchio's kinematics, on and off."""
    L = loop(name)
    Q, V = states(L, which)
    Phi, Jc, bias = closure_terms(L["model"], Q, V)
    for s in range(len(Q)):
        phi_r, J_r, b_r = L["pin"].terms(L["ref"].to_pin_q(Q[s]), V[s])
        assert_close(Phi[s], phi_r, 5e-14, "Φ")            # measured ≤ 6.7e-16
        assert_close(Jc[s], J_r, 5e-14, "Φ_q")              # measured ≤ 6.7e-16
        assert_close(bias[s], b_r, 1e-13, "Φ̇_q q̇")         # measured ≤ 2.0e-15


@pytest.mark.parametrize("which", ALL_SETS)
@pytest.mark.parametrize("name", NAMES)
def test_jacobian_and_bias_against_finite_differences(name, which):
    """Φ_q against central differences of Φ; Φ̇_q q̇ against central differences of Φ_q(q + t q̇) q̇."""
    L = loop(name)
    model = L["model"]
    Q, V = states(L, which)
    h = FD_STEP
    for s in range(len(Q)):
        q, v = Q[s], V[s]
        E = np.eye(model.nv) * h
        Phi_p = closure_terms(model, q + E)[0]
        Phi_m = closure_terms(model, q - E)[0]
        J_fd = ((Phi_p - Phi_m) / (2 * h)).T
        _, Jc, bias = closure_terms(model, q[None], v[None])
        assert_close(Jc[0], J_fd, 1e-8, "Φ_q vs FD")         # measured ≤ 2.1e-10 (h = 1e-6: round-off ε/h)
        Jp, Jm = closure_terms(model, np.array([q + h * v, q - h * v]))[1]
        b_fd = (Jp - Jm) @ v / (2 * h)
        assert_close(bias[0], b_fd, 1e-8, "Φ̇_q q̇ vs FD")     # measured ≤ 1.2e-10
        # the Pinocchio-based rows, differentiated the same way: the reference's own check
        P = L["pin"]
        Pp = np.array([P.phi(L["ref"].to_pin_q(x)) for x in q + E])
        Pm = np.array([P.phi(L["ref"].to_pin_q(x)) for x in q - E])
        J_pin = P.terms(L["ref"].to_pin_q(q), v)[1]
        assert_close(J_pin, ((Pp - Pm) / (2 * h)).T, 1e-8, "Pinocchio Φ_q vs FD")   # measured ≤ 2.6e-10


# ------------------------------------------------------------------ a second Pinocchio route: frame Jacobians
@pytest.mark.parametrize("which", ALL_SETS)
@pytest.mark.parametrize("name", NAMES)
def test_closure_terms_against_pinocchio_frame_jacobians(name, which):
    """Φ, Φ_q = J_A − J_B, Φ̇_q q̇ from Pinocchio's frame Jacobians (PinClosures), batch and one state."""
    L = loop(name)
    Q, V = states(L, which)
    Phi, Jc, bias = closure_terms(L["model"], Q, V)
    ref = pin_closures(name)
    for s in range(len(Q)):
        phi_r, J_r, b_r = ref.rows(L["ref"].to_pin_q(Q[s]), V[s])
        one = closure_terms(L["model"], Q[s], V[s])
        for what, x, x1, y, tol in (("Φ", Phi[s], one[0], phi_r, 5e-14), ("Φ_q", Jc[s], one[1], J_r, 5e-14),
                                    ("Φ̇_q q̇", bias[s], one[2], b_r, 1e-13)):   # measured ≤ 4.4e-16, 7.8e-16, 1.1e-15
            assert_close(x, y, tol, what)
            assert np.array_equal(x, x1), what                  # one state = its row of the batch


@functools.lru_cache(maxsize=None)
def pin_closures(name):
    return PinClosures(loop(name)["model"], pin().buildModelFromUrdf(str(LOOPS / MANIFEST[name]["file"])))


# ------------------------------------------------------------------ the loops on a floating base
@functools.lru_cache(maxsize=None)
def floating(name):
    """The loop with its base link on a free flyer (mass 2 kg, unit inertia), Pinocchio's rows, 4 states."""
    P = pin()
    model = with_free_flyer(loop(name)["model"], 2.0, np.zeros(3), np.eye(3))
    ref = PinClosures(model, P.buildModelFromUrdf(str(LOOPS / MANIFEST[name]["file"]), P.JointModelFreeFlyer()))
    Q, V = random_floating_states(model, 4, np.random.default_rng(zlib.crc32(name.encode())))
    return model, ref, Q, V


@pytest.mark.parametrize("name", NAMES)
def test_floating_loops_against_pinocchio_and_differences(name):
    """With a free-flyer root, off the closures (random q, v): Φ, Φ_q, Φ̇_q q̇ equal Pinocchio's frame rows;
    and, along q(t) = q ⊕ t v (h = 1e-6), Φ_q v = dΦ/dt and Φ̇_q v = d(Φ_q v)/dt by central differences."""
    model, ref, Q, V = floating(name)
    Phi, Jc, bias = closure_terms(model, Q, V)
    h, worst = 1e-6, dict.fromkeys(("phi", "jac", "bias", "dphi", "dbias"), 0.0)
    for s in range(len(Q)):
        for k, x, y in zip(("phi", "jac", "bias"), (Phi[s], Jc[s], bias[s]), ref.rows(Q[s], V[s])):
            worst[k] = max(worst[k], err(x, y))
        qp, qm = integrate(model, Q[s], h * V[s])[0], integrate(model, Q[s], -h * V[s])[0]
        (Pp, Jp, _), (Pm, Jm, _) = closure_terms(model, qp), closure_terms(model, qm)
        worst["dphi"] = max(worst["dphi"], err(Jc[s] @ V[s], (Pp - Pm) / (2 * h)))
        worst["dbias"] = max(worst["dbias"], err(bias[s], (Jp - Jm) @ V[s] / (2 * h)))
    print(f"\n{name}: " + ", ".join(f"{k} {e:.1e}" for k, e in worst.items()))
    tol = dict(phi=3e-14, jac=3e-14, bias=1e-13, dphi=1e-8, dbias=1e-8)   # measured ≤ 3.3e-16, 4.4e-16, 1.8e-15,
    #                                                                          2.0e-10, 3.1e-10 (h = 1e-6)
    assert all(worst[k] <= tol[k] for k in tol), worst


@pytest.mark.parametrize("which", ALL_SETS)
@pytest.mark.parametrize("name", NAMES)
def test_kernel_dynamics_equal_readable_dynamics(name, which):
    """constrained_forward_dynamics takes the kernel (no f_ext); it equals constrained_fd_fast bit for bit
    and the readable KKT solve (q̈, λ, rank), batched and one state at a time, with and without Baumgarte."""
    L = loop(name)
    model = L["model"]
    Q, V = states(L, which)
    T = L["tau"]
    for bg in (None, (3.0, 4.0)):
        code, k_qdd, k_lam, k_rank = constrained_fd_fast(model, Q, V, T, bg)
        qdd, lam = constrained_forward_dynamics(model, Q, V, T, baumgarte=bg)
        assert code == -1 and np.array_equal(qdd, k_qdd) and np.array_equal(lam, k_lam)   # the kernel route
        r_qdd, r_lam = constrained_forward_dynamics_reference(model, Q, V, T, baumgarte=bg)
        for s in range(len(Q)):
            assert_close(qdd[s], r_qdd[s], 1e-12, "q̈ batched")     # measured ≤ 1.5e-14
            assert_close(lam[s], r_lam[s], 1e-12, "λ batched")     # measured ≤ 1.1e-14
            one = constrained_forward_dynamics(model, Q[s], V[s], T[s], baumgarte=bg)
            assert_close(one[0], r_qdd[s], 1e-12, "q̈ single")   # as batched
            assert_close(one[1], r_lam[s], 1e-12, "λ single")
            if which != "far":            # far off, rows are dropped by the |Φ| heuristic (see the xfail)
                assert k_rank[s] == L["rank"]


# ------------------------------------------------------------------ dynamics against references
def kkt_reference(L, q, v, tau):
    """q̈ of [M Φ_qᵀ; Φ_q 0][q̈; λ] = [τ − h; −Φ̇_q q̇], a dense solve: M, h from Pinocchio, rows from PinLoops."""
    P, ref = pin(), L["ref"]
    qp = ref.to_pin_q(q)
    M = P.crba(ref.pm, ref.pd, qp)
    M = np.triu(M) + np.triu(M, 1).T
    h = P.rnea(ref.pm, ref.pd, qp, v, np.zeros(len(v)))
    _, G, b = L["pin"].terms(qp, v)
    n, m = len(q), len(b)
    K = np.block([[M, G.T], [G, np.zeros((m, m))]])
    return np.linalg.solve(K, np.concatenate([tau - h, -b]))[:n]


@pytest.mark.parametrize("which", ["on", "v_off", "near"])
@pytest.mark.parametrize("name", NAMES)
def test_forward_dynamics_against_kkt_reference(name, which):
    """q̈ on and off the closures against the dense KKT system built from Pinocchio."""
    L = loop(name)
    Q, V = states(L, which)
    for s in range(len(Q)):
        qdd, _ = constrained_forward_dynamics(L["model"], Q[s], V[s], L["tau"][s])
        assert_close(qdd, kkt_reference(L, Q[s], V[s], L["tau"][s]), 5e-13, "q̈")   # measured ≤ 6.8e-15


def _gains_zero(cref):
    return all(cm.m_baumgarte_parameters.Kp == 0 and cm.m_baumgarte_parameters.Kd == 0 for cm in cref.models)


@pytest.mark.parametrize("name", NAMES)
def test_forward_dynamics_against_pinocchio_on_manifold(name):
    """q̈ on the closures against Pinocchio's constraintDynamics (proximal solver, gains 0)."""
    L = loop(name)
    assert _gains_zero(L["cref"])
    for s in range(len(L["Q"])):
        qdd, _ = constrained_forward_dynamics(L["model"], L["Q"][s], L["V"][s], L["tau"][s])
        ref = L["cref"].qdd(L["Q"][s], L["V"][s], L["tau"][s])
        assert_close(qdd, ref, 1e-10, "q̈")   # measured ≤ 1.4e-12 (Pinocchio's proximal solver)


@pytest.mark.parametrize("which", ["v_off", "near"])
@pytest.mark.parametrize("name", SPHERICAL_ONLY)
def test_forward_dynamics_against_pinocchio_off_manifold(name, which):
    """Off the closures, Pinocchio's 3-D point rows are our position rows: q̈ agrees there too.
    (Its 6-D and two-point rows are other functions than our a·b rows off the manifold: ~5 rad/s² apart.)"""
    L = loop(name)
    assert _gains_zero(L["cref"])
    Q, V = states(L, which)
    for s in range(len(Q)):
        qdd, _ = constrained_forward_dynamics(L["model"], Q[s], V[s], L["tau"][s])
        assert_close(qdd, L["cref"].qdd(Q[s], V[s], L["tau"][s]), 5e-13, "q̈")   # measured ≤ 8.0e-15


@pytest.mark.parametrize("name", NAMES)
def test_inverse_dynamics_against_pinocchio(name):
    """Actuator forces for a completed motion against the inverted forward map of constraintDynamics."""
    L = loop(name)
    for s in range(len(L["Q"])):
        q, v, a = L["Q"][s], L["V"][s], L["A"][s]
        ta, _ = constrained_inverse_dynamics(L["model"], q, v, a)
        ta_ref = actuator_torques_by_inversion(L["model"], L["cref"], q, v, a[L["act"]], L["act"])
        assert_close(ta, ta_ref, 1e-10, "τ_a")      # measured ≤ 1.5e-12


ENERGY_DRIFT = {"rusr_revolute": 4.0e-9, "weld7": 1.7e-10, "rusr_spherical": 6.2e-10, "slider_crank": 1.2e-5,
                "two_loops": 4.4e-9}   # measured max |E − E0| / max T over 1 s at dt = 0.5 ms


@pytest.mark.parametrize("name", NAMES)
def test_energy_conserved_torque_free(name):
    """1 s, RK4, no stabilization, gravity on, no actuation: T + V constant up to RK4's own error, which
    falls as dt⁴ (halving dt divides the drift and |Φ| by ~16; a wrong term in the dynamics would leave a
    drift that does not fall with dt)."""
    L = loop(name)
    model = L["model"]
    drift, phi = [], []
    for dt in (1e-3, 5e-4):
        r = md.simulate(model, L["Q"][0], L["V"][0], (0.0, 1.0), dt=dt, integrator="rk4")
        E = md.kinetic_energy(model, r.q, r.v) + md.potential_energy(model, r.q)
        drift.append(np.abs(E - E[0]).max() / md.kinetic_energy(model, r.q, r.v).max())
        phi.append(np.abs(closure_terms(model, r.q)[0]).max())
    print(f"\n{name}: energy drift {drift[0]:.2e} (dt 1 ms), {drift[1]:.2e} (0.5 ms); "
          f"max |Φ| {phi[0]:.2e}, {phi[1]:.2e}")
    assert drift[1] < 30 * ENERGY_DRIFT[name], drift
    assert 12 < drift[0] / drift[1] < 20, drift    # measured 15.3–16.0: fourth order
    assert 12 < phi[0] / phi[1] < 20, phi          # measured 15.5–16.4


POWER_GAP = {"weld7": 3e-10, "slider_crank": 1e-4}   # measured 5.1e-12, 2.0e-6 (RK4 and Simpson at 0.5 ms)


@pytest.mark.parametrize("name", ["weld7", "slider_crank"])
def test_power_balance_with_actuation(name):
    """Constant actuator force/torque τ_a for 0.5 s: E(t) − E(0) = ∫ τ_a · q̇_a dt (Simpson on the RK4 grid)."""
    L = loop(name)
    model, act = L["model"], L["act"]
    tau = np.zeros(model.nv)
    tau[act] = 2.0
    r = md.simulate(model, L["Q"][0], L["V"][0], (0.0, 0.5), dt=5e-4, integrator="rk4", tau=tau)
    E = md.kinetic_energy(model, r.q, r.v) + md.potential_energy(model, r.q)
    power = r.v @ tau
    simpson = (power[:-2:2] + 4 * power[1:-1:2] + power[2::2]) * (r.t[2] - r.t[0]) / 6
    work = np.concatenate([[0.0], np.cumsum(simpson)])
    gap = np.abs(E[::2] - E[0] - work).max() / max(np.abs(work).max(), 1.0)
    print(f"\n{name}: |E − E0 − W| / max|W| = {gap:.2e}, work {work[-1]:.3f} J")
    assert gap < POWER_GAP[name], gap


@pytest.mark.xfail(strict=True, reason="the |Φ|-scaled rank tolerance (100 max|Φ| / max row norm) drops "
                   "independent rows once |Φ| reaches ~1e-3 on these loops")
def test_independent_rows_kept_at_moderate_drift():
    """At |Φ| ≈ 1e-3 (q 1e-2 off the closures) every row of a well-conditioned spatial loop is independent."""
    L = loop("rusr_spherical")
    rng = np.random.default_rng(5)
    Q = L["Q"] + rng.normal(0.0, 1e-2, L["Q"].shape)
    _, _, _, rank = constrained_fd_fast(L["model"], Q, L["Voff"], L["tau"])
    assert list(rank) == [L["rank"]] * len(Q)
