"""The bench report's sections: each returns rows of plain dicts (time and error side by side)."""
from __future__ import annotations

import time
import warnings

import numpy as np

from ..constraints import constrained_forward_dynamics
from ..dynamics.aba import aba, forward_dynamics
from ..dynamics.derivatives import aba_derivatives, rnea_derivatives
from ..dynamics.energy import kinetic_energy, potential_energy
from ..dynamics.kinematics import frame_jacobian, frame_jacobian_dot, frame_placement
from ..dynamics.lagrange import coriolis_matrix, gravity_torques, mass_matrix
from ..dynamics.regressor import joint_torque_regressor
from ..dynamics.rnea import nonlinear_effects, rnea
from ..io.urdf import load_urdf
from ..validation.compare import random_states
from ..validation.measure import error
from ..validation.reference import Reference, pin
from .timing import per_call, random_chain


def _load(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_urdf(path, **kw)


def latency(paths, quick=False):
    """a. Single-state latency of the public, input-checked calls vs Pinocchio's Python calls, with errors."""
    P, rows = pin(), []
    for path in paths:
        model = _load(path)
        ref = Reference(model, path)
        pm, pd = ref.pm, ref.pd
        Q, V, A = random_states(model, 50 if quick else 200, np.random.default_rng(0))
        q, v, a = Q[0], V[0], A[0]
        pq = ref.to_pin_q(q)
        cases = [
            ("rnea", lambda: rnea(model, q, v, a), lambda: P.rnea(pm, pd, pq, v, a),
             lambda s: (rnea(model, Q[s], V[s], A[s]), P.rnea(pm, pd, ref.to_pin_q(Q[s]), V[s], A[s]))),
            ("mass_matrix (crba)", lambda: mass_matrix(model, q), lambda: P.crba(pm, pd, pq),
             lambda s: (mass_matrix(model, Q[s]), P.crba(pm, pd, ref.to_pin_q(Q[s])))),
            ("mass_matrix (lagrange)", lambda: mass_matrix(model, q, method="lagrange"), lambda: P.crba(pm, pd, pq),
             lambda s: (mass_matrix(model, Q[s], method="lagrange"), P.crba(pm, pd, ref.to_pin_q(Q[s])))),
            ("coriolis_matrix", lambda: coriolis_matrix(model, q, v),
             lambda: P.computeCoriolisMatrix(pm, pd, pq, v),
             lambda s: (coriolis_matrix(model, Q[s], V[s]), P.computeCoriolisMatrix(pm, pd, ref.to_pin_q(Q[s]), V[s]))),
            ("gravity_torques", lambda: gravity_torques(model, q), lambda: P.computeGeneralizedGravity(pm, pd, pq),
             lambda s: (gravity_torques(model, Q[s]), P.computeGeneralizedGravity(pm, pd, ref.to_pin_q(Q[s])))),
            ("aba", lambda: aba(model, q, v, a), lambda: P.aba(pm, pd, pq, v, a),
             lambda s: (aba(model, Q[s], V[s], A[s]), P.aba(pm, pd, ref.to_pin_q(Q[s]), V[s], A[s]))),
            ("joint_torque_regressor", lambda: joint_torque_regressor(model, q, v, a),
             lambda: P.computeJointTorqueRegressor(pm, pd, pq, v, a),
             lambda s: (joint_torque_regressor(model, Q[s], V[s], A[s]), ref.regressor(Q[s], V[s], A[s]))),
            ("rnea_derivatives", lambda: rnea_derivatives(model, q, v, a),
             lambda: P.computeRNEADerivatives(pm, pd, pq, v, a),
             lambda s: (rnea_derivatives(model, Q[s], V[s], A[s]),
                        P.computeRNEADerivatives(pm, pd, ref.to_pin_q(Q[s]), V[s], A[s]))),
            ("aba_derivatives", lambda: aba_derivatives(model, q, v, a),
             lambda: P.computeABADerivatives(pm, pd, pq, v, a),
             lambda s: (aba_derivatives(model, Q[s], V[s], A[s]),
                        P.computeABADerivatives(pm, pd, ref.to_pin_q(Q[s]), V[s], A[s]))),
        ]
        for name, ours, theirs, pair in cases:
            ours(), theirs()
            t_ours, t_pin = per_call(ours, repeat=3 if quick else 7), per_call(theirs, repeat=3 if quick else 7)
            err = max(error(*[np.array(x) for x in pair(s)]) for s in range(len(Q)))
            rows.append(dict(robot=model.name, call=name, ours_us=t_ours * 1e6, pin_us=t_pin * 1e6,
                             ratio=t_ours / t_pin, err=err))
    return rows + compiled_term_latency(paths, quick)


def _pin_fext(P, pm, pd, pq, f_ext):
    """Pinocchio's per-joint fext (StdVec_Force) of our {frame: (force, moment)} in the frames' axes."""
    P.framesForwardKinematics(pm, pd, pq)
    out = [P.Force.Zero() for _ in range(pm.njoints)]
    for name, (f, m) in f_ext.items():
        fid = pm.getFrameId(name)
        out[pm.frames[fid].parentJoint] += pm.frames[fid].placement.act(P.Force(f, m))
    vec = P.StdVec_Force()
    for f in out:
        vec.append(f)
    return vec


def compiled_term_latency(paths, quick=False, chain=32):
    """a (continued). The other public calls, one state, against Pinocchio's cheapest Python route to the same
    numbers (conversions — q, fext — outside the timing): on each arm of ``paths`` and a random chain of
    ``chain`` joints. Errors: the worst over the states (Cholesky route and aba with f_ext: divided by cond(M))."""
    P, rows = pin(), []
    setups = []
    for path in paths:
        model = _load(path)
        ref = Reference(model, path)
        setups.append((model, ref.pm, ref.to_pin_q))
    model, pm = random_chain(chain, seed=chain)
    setups.append((model, pm, lambda q: q))
    for model, pm, to_pin in setups:
        pd = pm.createData()
        Q, V, A = random_states(model, 5 if quick else 20, np.random.default_rng(0))
        frame = model.body_names[-1]
        fid = pm.getFrameId(frame)
        wrench = (np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.4]))
        fx = {frame: wrench}
        PQ = [to_pin(q) for q in Q]
        PF = [_pin_fext(P, pm, pd, pq, fx) for pq in PQ]
        LWA = P.LOCAL_WORLD_ALIGNED

        def sym(M):
            return np.triu(M) + np.triu(M, 1).T

        def placement(pq):
            P.forwardKinematics(pm, pd, pq)
            return P.updateFramePlacement(pm, pd, fid)

        def jdot(pq, v):
            P.computeJointJacobiansTimeVariation(pm, pd, pq, v)
            return P.getFrameJacobianTimeVariation(pm, pd, fid, LWA)

        def cond(s):
            return np.linalg.cond(P.crba(pm, pd, PQ[s]))

        # name: (ours(s), Pinocchio's(s), error scale(s))
        cases = {
            "coriolis_matrix": (lambda s: coriolis_matrix(model, Q[s], V[s]),
                                lambda s: P.computeCoriolisMatrix(pm, pd, PQ[s], V[s]), None),
            "nonlinear_effects": (lambda s: nonlinear_effects(model, Q[s], V[s]),
                                  lambda s: P.nonLinearEffects(pm, pd, PQ[s], V[s]), None),
            "gravity_torques": (lambda s: gravity_torques(model, Q[s]),
                                lambda s: P.computeGeneralizedGravity(pm, pd, PQ[s]), None),
            "mass_matrix (lagrange)": (lambda s: mass_matrix(model, Q[s], method="lagrange"),
                                       lambda s: P.crba(pm, pd, PQ[s]), None),
            "frame_placement": (lambda s: frame_placement(model, Q[s], frame), lambda s: placement(PQ[s]), None),
            "frame_jacobian": (lambda s: frame_jacobian(model, Q[s], frame),
                               lambda s: P.computeFrameJacobian(pm, pd, PQ[s], fid, LWA), None),
            "frame_jacobian_dot": (lambda s: frame_jacobian_dot(model, Q[s], V[s], frame),
                                   lambda s: jdot(PQ[s], V[s]), None),
            "kinetic_energy": (lambda s: kinetic_energy(model, Q[s], V[s]),
                               lambda s: P.computeKineticEnergy(pm, pd, PQ[s], V[s]), None),
            "potential_energy": (lambda s: potential_energy(model, Q[s]),
                                 lambda s: P.computePotentialEnergy(pm, pd, PQ[s]), None),
            "forward_dynamics (cholesky) vs aba": (
                lambda s: forward_dynamics(model, Q[s], V[s], A[s], method="cholesky"),
                lambda s: P.aba(pm, pd, PQ[s], V[s], A[s]), cond),
            "rnea with f_ext": (lambda s: rnea(model, Q[s], V[s], A[s], f_ext=fx),
                                lambda s: P.rnea(pm, pd, PQ[s], V[s], A[s], PF[s]), None),
            "aba with f_ext": (lambda s: aba(model, Q[s], V[s], A[s], f_ext=fx),
                               lambda s: P.aba(pm, pd, PQ[s], V[s], A[s], PF[s]), cond),
        }
        # the results as arrays, for the errors only (outside the timing)
        as_ours = {"frame_placement": lambda x: np.r_[x[0].ravel(), x[1]]}
        as_pin = {"frame_placement": lambda X: np.r_[X.rotation.ravel(), X.translation], "mass_matrix (lagrange)": sym}
        for name, (ours, theirs, scale) in cases.items():
            ours(0), theirs(0)
            t_ours = per_call(lambda: ours(0), repeat=3 if quick else 7)
            t_pin = per_call(lambda: theirs(0), repeat=3 if quick else 7)
            fo, fp = as_ours.get(name, np.asarray), as_pin.get(name, np.asarray)
            err = max(error(np.atleast_1d(np.asarray(fo(ours(s)), float)), np.atleast_1d(np.asarray(fp(theirs(s)), float)))
                      / (scale(s) if scale else 1.0) for s in range(len(Q)))
            rows.append(dict(robot=model.name, call=name + (" (err / cond M)" if scale else ""), ours_us=t_ours * 1e6,
                             pin_us=t_pin * 1e6, ratio=t_ours / t_pin, err=err))
    return rows


def closed_latency(spm_path, quick=False):
    """a (closed chains). SPM constrained forward dynamics vs pin.constraintDynamics, per call, with error."""
    from ..validation.closed import ClosedReference, manifold_states
    model = _load(spm_path)
    cref = ClosedReference(Reference(model, spm_path))
    rng = np.random.default_rng(1)
    Qm, Vm = manifold_states(model, 20 if quick else 100, rng)
    tau = np.zeros(model.nv)
    tau[[model.joint_index(j) for j in model.actuated]] = 0.1
    q, v = Qm[0], Vm[0]
    t_ours = per_call(lambda: constrained_forward_dynamics(model, q, v, tau), repeat=3)
    t_pin = per_call(lambda: cref.qdd(q, v, tau), repeat=3)
    err = max(error(constrained_forward_dynamics(model, Qm[s], Vm[s], tau)[0], cref.qdd(Qm[s], Vm[s], tau))
              for s in range(len(Qm)))
    return [dict(robot=model.name, call="constrained_forward_dynamics", ours_us=t_ours * 1e6,
                 pin_us=t_pin * 1e6, ratio=t_ours / t_pin, err=err)]


def throughput(paths, sizes, quick=False):
    """b. Time per state of batched calls: ours vs a Pinocchio loop and pin.*InParallel (1 and all cores)."""
    P, rows = pin(), []
    import os
    cores = os.cpu_count() or 1
    for path in paths:
        model = _load(path)
        ref = Reference(model, path)
        pm, pd = ref.pm, ref.pd
        pool = P.ModelPool(pm, cores)
        for N in sizes:
            Q, V, A = random_states(model, N, np.random.default_rng(2))
            PQ = np.asfortranarray(np.array([ref.to_pin_q(x) for x in Q]).T)
            PV, PA = np.asfortranarray(V.T), np.asfortranarray(A.T)
            out = np.asfortranarray(np.zeros((model.nv, N)))
            reps = 1 if (quick or N >= 10000) else 3
            loop_n = min(N, 2000)           # the Python loop is timed on at most 2000 states
            for call, ours, loop, par in (
                ("rnea", lambda: rnea(model, Q, V, A),
                 lambda: [P.rnea(pm, pd, PQ[:, s], PV[:, s], PA[:, s]) for s in range(loop_n)],
                 lambda th: P.rneaInParallel(th, pool, PQ, PV, PA, out)),
                ("aba", lambda: aba(model, Q, V, A),
                 lambda: [P.aba(pm, pd, PQ[:, s], PV[:, s], PA[:, s]) for s in range(loop_n)],
                 lambda th: P.abaInParallel(th, pool, PQ, PV, PA, out)),
                ("mass_matrix", lambda: mass_matrix(model, Q),
                 lambda: [P.crba(pm, pd, PQ[:, s]) for s in range(loop_n)], None)):
                ours()
                row = dict(robot=model.name, call=call, N=N,
                           ours_us=per_call(ours, repeat=reps, min_time=0.02) / N * 1e6,
                           pin_loop_us=per_call(loop, repeat=reps, min_time=0.02) / loop_n * 1e6)
                if par is not None:
                    row["pin_par1_us"] = per_call(lambda: par(1), repeat=reps, min_time=0.02) / N * 1e6
                    row["pin_par_all_us"] = per_call(lambda: par(cores), repeat=reps, min_time=0.02) / N * 1e6
                    row["ratio_par1"] = row["ours_us"] / row["pin_par1_us"]
                row["ratio_loop"] = row["ours_us"] / row["pin_loop_us"]
                rows.append(row)
    return rows


def scaling(ns, quick=False):
    """c. Random serial chains of n joints: time per call against n, ours vs Pinocchio, single-state (vs
    its Python call) and batched (vs pin.*InParallel, 1 thread)."""
    P, rows = pin(), []
    N = 1000 if quick else 10000
    for n in ns:
        model, pm = random_chain(n, seed=n)
        pd, pool = pm.createData(), P.ModelPool(pm, 1)
        Q, V, A = random_states(model, N, np.random.default_rng(n))
        q, v, a = Q[0], V[0], A[0]
        QT, VT, AT = (np.asfortranarray(x.T) for x in (Q, V, A))
        out = np.asfortranarray(np.zeros((model.nv, N)))
        for call, ours, theirs in (
            ("rnea", lambda: rnea(model, q, v, a), lambda: P.rnea(pm, pd, q, v, a)),
            ("aba", lambda: aba(model, q, v, a), lambda: P.aba(pm, pd, q, v, a)),
            ("mass_matrix (crba)", lambda: mass_matrix(model, q), lambda: P.crba(pm, pd, q)),
            ("mass_matrix (lagrange)", lambda: mass_matrix(model, q, method="lagrange"), lambda: P.crba(pm, pd, q)),
            ("rnea batch/state", lambda: rnea(model, Q, V, A), lambda: P.rneaInParallel(1, pool, QT, VT, AT, out)),
            ("aba batch/state", lambda: aba(model, Q, V, A), lambda: P.abaInParallel(1, pool, QT, VT, AT, out)),
        ):
            ours()
            t_o, t_p = per_call(ours, repeat=3), per_call(theirs, repeat=3)
            if call.endswith("batch/state"):
                t_o, t_p = t_o / N, t_p / N
            rows.append(dict(n=n, call=call, ours_us=t_o * 1e6, pin_us=t_p * 1e6, ratio=t_o / t_p))
    return rows


def slopes(rows):
    """Fitted log-log slope of time against n for each call (ours and Pinocchio)."""
    out = {}
    for call in sorted({r["call"] for r in rows}):
        pts = [(r["n"], r["ours_us"], r["pin_us"]) for r in rows if r["call"] == call]
        n, t_o, t_p = (np.log(np.array(x, float)) for x in zip(*pts))
        out[call] = dict(ours=float(np.polyfit(n, t_o, 1)[0]), pin=float(np.polyfit(n, t_p, 1)[0]))
    return out


def reduced(path, reduce_kw, quick=False):
    """Load time and per-call speed of a reduced model against the full one (what a scene needs)."""
    rows = []
    for label, kw in (("full", {}), ("reduced", reduce_kw)):
        t0 = time.perf_counter()
        for _ in range(3):
            model = _load(path, **kw)
        t_load = (time.perf_counter() - t0) / 3
        Q, V, A = random_states(model, 1000, np.random.default_rng(3))
        rnea(model, Q[0], V[0], A[0]), aba(model, Q[0], V[0], A[0])
        rows.append(dict(model=label, nv=model.nv, load_ms=t_load * 1e3,
                         rnea_us=per_call(lambda: rnea(model, Q[0], V[0], A[0]), repeat=3) * 1e6,
                         aba_us=per_call(lambda: aba(model, Q[0], V[0], A[0]), repeat=3) * 1e6,
                         rnea_batch_us=per_call(lambda: rnea(model, Q, V, A), repeat=3) / 1000 * 1e6))
    return rows


def work_precision(aau_path, quick=False):
    """d. AAU arm, 5 s from a fixed state, without and with gravity: each integrator × step size →
    (wall time, final-state error against the adaptive reference at rtol 1e-13), with our aba and with
    Pinocchio's aba inside the same integrator loop."""
    from ..simulation import _step, simulate
    P = pin()
    horizon = 1.0 if quick else 5.0
    rows = []
    for gravity in ((0.0, 0.0, 0.0), (0.0, 0.0, -9.81)):
        model = _load(aau_path, gravity=gravity)
        ref = Reference(model, aau_path)
        q0, v0 = np.array([0.3, -0.5, 0.8, 0.2, -0.4]), np.array([0.5, -0.3, 0.2, 1.0, -0.5])
        exact = simulate(model, q0, v0, (0, horizon), method="adaptive", rtol=1e-13, atol=1e-14)
        x_ref = np.r_[exact.q[-1], exact.v[-1]]
        accels = {"manipdyn aba": lambda q, v, tau: aba(model, q, v, tau),
                  "Pinocchio aba": lambda q, v, tau: P.aba(ref.pm, ref.pd, q, v, tau)}
        zero = lambda t, q, v: np.zeros(5)  # noqa: E731
        for method, steps in (("rk4", (0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125, 0.000625, 0.0003125, 0.00015625)),
                              ("euler", (0.002, 0.001, 0.0005, 0.00025))):
            for dt in (steps[::2] if quick else steps):
                n = int(round(horizon / dt))
                for who, accel in accels.items():
                    t0 = time.perf_counter()
                    q, v = q0.copy(), v0.copy()
                    for k in range(n):
                        q, v = _step(method, accel, zero, k * dt, q, v, dt)
                    wall = time.perf_counter() - t0
                    rows.append(dict(gravity="on" if gravity[2] else "off", method=method, dt=dt, who=who,
                                     seconds=wall, error=float(np.abs(np.r_[q, v] - x_ref).max())))
    return rows


def cost_at_error(rows, target=1e-8):
    """Time to reach a final-state error of ``target``, interpolated on log axes, per (gravity, method, who)."""
    out = []
    keys = sorted({(r["gravity"], r["method"], r["who"]) for r in rows})
    for g, m, who in keys:
        pts = sorted((r["error"], r["seconds"]) for r in rows if (r["gravity"], r["method"], r["who"]) == (g, m, who))
        e, t = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
        if len(pts) >= 2 and e.min() <= np.log(target) <= e.max():
            out.append(dict(gravity=g, method=m, who=who, seconds_at_1e_8=float(np.exp(np.interp(np.log(target), e, t)))))
    return out


def spm_drift(spm_path, quick=False):
    """e. SPM held by a PD law around the Fig. 7 start: cost per step and max |Φ| over the run."""
    from ..constraints import closure_terms, complete_state
    from ..simulation import simulate
    from ..examples import spm_params as SP
    from ..examples.spm_urdf import tree_guess
    model = _load(spm_path)
    Q0 = np.array([[np.cos(np.pi / 6), 0, np.sin(np.pi / 6)], [0, 1, 0], [-np.sin(np.pi / 6), 0, np.cos(np.pi / 6)]])
    q0, v0, _, _ = complete_state(model, tree_guess(model, Q0, np.radians(SP.THETA0_FIRST_BRANCH_DEG)),
                                  np.array([2.0, -1.5, 1.0]), np.zeros(3))
    act = [model.joint_index(j) for j in model.actuated]

    def pd_law(t, q, v):
        tau = np.zeros_like(q)
        tau[..., act] = 2.0 * (q0[act] - q[..., act]) - 0.05 * v[..., act]
        return tau

    horizon, rows = (1.0 if quick else 10.0), []
    for stab in ("none", "baumgarte", "projection"):
        r = simulate(model, q0, v0, (0, horizon), dt=5e-4, method="rk4", tau=pd_law, stabilization=stab,
                     baumgarte=(20.0, 20.0))
        phi = np.abs(closure_terms(model, r.q)[0]).max(axis=1)
        rows.append(dict(stabilization=stab, horizon_s=horizon, us_per_step=r.wall_time / r.n_steps * 1e6,
                         max_phi=float(phi.max()), final_phi=float(phi[-1])))
    return rows
