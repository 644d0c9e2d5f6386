"""The bench report's sections: each returns rows of plain dicts (time and error side by side)."""
from __future__ import annotations

import functools
import time
import timeit
import warnings
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from ..constraints import constrained_forward_dynamics
from ..errors import ManipdynError
from ..dynamics.aba import aba, forward_dynamics
from ..dynamics.derivatives import aba_derivatives, rnea_derivatives
from ..dynamics.energy import kinetic_energy, potential_energy
from ..dynamics.kinematics import frame_jacobian, frame_jacobian_dot, frame_placement
from ..dynamics.coriolis import coriolis_matrix
from ..dynamics.crba import mass_matrix
from ..dynamics.rnea import gravity_torques
from ..dynamics.regressor import joint_torque_regressor
from ..dynamics.rnea import nonlinear_effects, rnea
from ..io.urdf import load_urdf
from ..validation.compare import random_states
from ..validation.measure import error
from ..validation.reference import Reference, pin
from .timing import per_call, per_call_pair, random_chain


def _load(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_urdf(path, **kw)


class Setup(NamedTuple):
    """One robot to time: our model, Pinocchio's model of the same file, and our q -> Pinocchio's q."""
    label: str
    model: object
    pm: object
    to_pin: Callable


def setups(paths=(), chain=None, open_trees=()):
    """The robots of the latency and batched sections: each URDF of ``paths``, the random serial chain of
    ``chain`` joints (timing.random_chain(chain, seed=chain)), and the open tree of each closed model in
    ``open_trees`` (its loop closures ignored: the tree calls apply to it, Pinocchio loads the same tree)."""
    out = []
    for path, suffix in [(p, "") for p in paths] + [(p, " (open tree)") for p in open_trees]:
        model = _load(path)
        ref = Reference(model, path)
        out.append(Setup(model.name + suffix, model, ref.pm, ref.to_pin_q))
    if chain:
        model, pm = random_chain(chain, seed=chain)
        out.append(Setup(model.name, model, pm, lambda q: q))   # revolute and prismatic only: same q
    return out


def floating_setups(paths=(), mjcf=()):
    """The robots of the floating section: each URDF of ``paths`` on a free-flyer root (label: the file's name, and
    "(free flyer)" where the robot is an arm), against buildModelFromUrdf(path, JointModelFreeFlyer()); each MJCF file
    of ``mjcf`` (its free and ball joints from the file), against buildModelFromMJCF of it (q the same: its ball and
    free joints are Pinocchio's, a body's several hinges its composite joint)."""
    from ..io.mjcf_read import load_mjcf
    out = []
    for path in paths:
        model = _load(path, root_joint="free_flyer")
        ref = Reference(model, path)
        label = Path(path).stem.replace("_robot", "")
        out.append(Setup(label + (" (free flyer)" if label == "ur5" else ""), model, ref.pm, ref.to_pin_q))
    for path in mjcf:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = load_mjcf(path)
        pm = pin().buildModelFromMJCF(str(path))
        pm.armature = np.asarray(model.armature, float)
        pm.gravity.linear = np.asarray(model.gravity, float)
        out.append(Setup(Path(path).stem + " (MJCF)", model, pm, lambda q: q))
    return out


class Case(NamedTuple):
    """One public call against Pinocchio's cheapest route to the same numbers."""
    ours: Callable          # (q, v, a) -> result: one state or a batch (N, nv), as the user calls it
    theirs: Callable        # s -> Pinocchio's result for state s (its q and fext converted beforehand)
    route: str              # Pinocchio's route, as timed
    parallel: str | None    # pin.<parallel>InParallel exists for this call (batches)
    as_ours: Callable = np.asarray      # result -> array, for the error only
    as_pin: Callable = np.asarray
    by_cond: bool = False   # a solve: the error is divided by cond(M)
    call: Callable | None = None  # s -> (Pinocchio's function, its arguments) when its route is one call: timed
    #                               as functools.partial(function, *arguments), the call as a user writes it


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


def _sym(M):
    return np.triu(M) + np.triu(M, 1).T


def cases(P, st, Q, V, A, f_ext=True, threads=None):
    """Every public call that takes a state, with Pinocchio's route for states Q, V, A (A is τ for the forward
    calls); the conversions (q in Pinocchio's order, fext per joint) are made here, outside any timing.
    ``f_ext=False`` leaves out the two f_ext calls (and their conversions); ``threads``: the threads of the
    calls that spread a batch over threads (dynamics/route.py; None: their default, every core).
    Returns ({call: Case}, Pinocchio's q per state, cond(s) = cond(M) of state s)."""
    model, pm = st.model, st.pm
    rnea_, aba_, mass_matrix_, coriolis_matrix_, gravity_torques_, nonlinear_effects_, forward_dynamics_, \
        joint_torque_regressor_, rnea_derivatives_, aba_derivatives_ = (
            f if threads is None else functools.partial(f, threads=threads) for f in (
                rnea, aba, mass_matrix, coriolis_matrix, gravity_torques, nonlinear_effects, forward_dynamics,
                joint_torque_regressor, rnea_derivatives, aba_derivatives))   # (threads=None: the functions
    #                                                                            themselves, no keyword to pass)
    pd = pm.createData()
    frame = model.body_names[-1]
    fid = pm.getFrameId(frame)
    fx = {frame: (np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.4]))}
    PQ = [st.to_pin(q) for q in Q]
    V, A = list(V), list(A)    # rows made once: a call indexes a list, as a user's loop over prepared states would
    LWA, nv, nb = P.LOCAL_WORLD_ALIGNED, model.nv, pm.njoints - 1

    def placement(s):
        P.forwardKinematics(pm, pd, PQ[s])
        return P.updateFramePlacement(pm, pd, fid)

    def jdot(s):
        P.computeJointJacobiansTimeVariation(pm, pd, PQ[s], V[s])
        return P.getFrameJacobianTimeVariation(pm, pd, fid, LWA)

    out = {
        "rnea": Case(lambda q, v, a, **k: rnea_(model, q, v, a, **k), lambda s: P.rnea(pm, pd, PQ[s], V[s], A[s]),
                     "rnea", "rnea"),
        "aba": Case(lambda q, v, a, **k: aba_(model, q, v, a, **k), lambda s: P.aba(pm, pd, PQ[s], V[s], A[s]), "aba",
                    "aba"),
        "mass_matrix (crba)": Case(lambda q, v, a, **k: mass_matrix_(model, q, **k), lambda s: P.crba(pm, pd, PQ[s]),
                                   "crba", None, as_pin=_sym),
        "mass_matrix (lagrange)": Case(lambda q, v, a: mass_matrix(model, q, method="lagrange"),
                                       lambda s: P.crba(pm, pd, PQ[s]), "crba", None, as_pin=_sym),
        "coriolis_matrix": Case(lambda q, v, a, **k: coriolis_matrix_(model, q, v, **k),
                                lambda s: P.computeCoriolisMatrix(pm, pd, PQ[s], V[s]), "computeCoriolisMatrix", None),
        "gravity_torques": Case(lambda q, v, a, **k: gravity_torques_(model, q, **k),
                                lambda s: P.computeGeneralizedGravity(pm, pd, PQ[s]), "computeGeneralizedGravity",
                                None),
        "nonlinear_effects": Case(lambda q, v, a, **k: nonlinear_effects_(model, q, v, **k),
                                  lambda s: P.nonLinearEffects(pm, pd, PQ[s], V[s]), "nonLinearEffects", None),
        "frame_placement": Case(lambda q, v, a: frame_placement(model, q, frame), placement,
                                "forwardKinematics + updateFramePlacement", None,
                                as_ours=lambda x: np.r_[x[0].ravel(), x[1]],
                                as_pin=lambda X: np.r_[X.rotation.ravel(), X.translation]),
        "frame_jacobian": Case(lambda q, v, a: frame_jacobian(model, q, frame),
                               lambda s: P.computeFrameJacobian(pm, pd, PQ[s], fid, LWA), "computeFrameJacobian", None),
        "frame_jacobian_dot": Case(lambda q, v, a: frame_jacobian_dot(model, q, v, frame), jdot,
                                   "computeJointJacobiansTimeVariation + getFrameJacobianTimeVariation", None),
        "kinetic_energy": Case(lambda q, v, a: kinetic_energy(model, q, v),
                               lambda s: P.computeKineticEnergy(pm, pd, PQ[s], V[s]), "computeKineticEnergy", None,
                               as_ours=np.atleast_1d, as_pin=np.atleast_1d),
        "potential_energy": Case(lambda q, v, a: potential_energy(model, q),
                                 lambda s: P.computePotentialEnergy(pm, pd, PQ[s]), "computePotentialEnergy", None,
                                 as_ours=np.atleast_1d, as_pin=np.atleast_1d),
        "forward_dynamics (cholesky)": Case(lambda q, v, a, **k: forward_dynamics_(model, q, v, a, method="cholesky",
                                                                                   joint_dynamics=False, **k),  # as P.aba
                                            lambda s: P.aba(pm, pd, PQ[s], V[s], A[s]), "aba", None, by_cond=True),
        "rnea_derivatives": Case(lambda q, v, a: rnea_derivatives_(model, q, v, a),
                                 lambda s: P.computeRNEADerivatives(pm, pd, PQ[s], V[s], A[s]),
                                 "computeRNEADerivatives", None),
        "aba_derivatives": Case(lambda q, v, a: aba_derivatives_(model, q, v, a),
                                lambda s: P.computeABADerivatives(pm, pd, PQ[s], V[s], A[s]),
                                "computeABADerivatives", None),
        "joint_torque_regressor": Case(lambda q, v, a, **k: joint_torque_regressor_(model, q, v, a, **k),
                                       lambda s: P.computeJointTorqueRegressor(pm, pd, PQ[s], V[s], A[s]),
                                       "computeJointTorqueRegressor", None,
                                       as_pin=lambda Y: np.reshape(Y, (nv, 10 * nb))),   # eigenpy: 1 × n is (n,)
    }
    one_call = {"rnea": lambda s: (P.rnea, (pm, pd, PQ[s], V[s], A[s])),
                "aba": lambda s: (P.aba, (pm, pd, PQ[s], V[s], A[s])),
                "mass_matrix (crba)": lambda s: (P.crba, (pm, pd, PQ[s])),
                "mass_matrix (lagrange)": lambda s: (P.crba, (pm, pd, PQ[s])),
                "coriolis_matrix": lambda s: (P.computeCoriolisMatrix, (pm, pd, PQ[s], V[s])),
                "gravity_torques": lambda s: (P.computeGeneralizedGravity, (pm, pd, PQ[s])),
                "nonlinear_effects": lambda s: (P.nonLinearEffects, (pm, pd, PQ[s], V[s])),
                "frame_jacobian": lambda s: (P.computeFrameJacobian, (pm, pd, PQ[s], fid, LWA)),
                "kinetic_energy": lambda s: (P.computeKineticEnergy, (pm, pd, PQ[s], V[s])),
                "potential_energy": lambda s: (P.computePotentialEnergy, (pm, pd, PQ[s])),
                "forward_dynamics (cholesky)": lambda s: (P.aba, (pm, pd, PQ[s], V[s], A[s])),
                "rnea_derivatives": lambda s: (P.computeRNEADerivatives, (pm, pd, PQ[s], V[s], A[s])),
                "aba_derivatives": lambda s: (P.computeABADerivatives, (pm, pd, PQ[s], V[s], A[s])),
                "joint_torque_regressor": lambda s: (P.computeJointTorqueRegressor, (pm, pd, PQ[s], V[s], A[s]))}
    out = {name: c._replace(call=one_call.get(name)) for name, c in out.items()}
    if f_ext:
        PF = [_pin_fext(P, pm, pd, pq, fx) for pq in PQ]
        out["rnea with f_ext"] = Case(lambda q, v, a: rnea_(model, q, v, a, f_ext=fx),
                                      lambda s: P.rnea(pm, pd, PQ[s], V[s], A[s], PF[s]), "rnea(fext)", None)
        out["aba with f_ext"] = Case(lambda q, v, a: aba_(model, q, v, a, f_ext=fx),
                                     lambda s: P.aba(pm, pd, PQ[s], V[s], A[s], PF[s]), "aba(fext)", None,
                                     by_cond=True, call=lambda s: (P.aba, (pm, pd, PQ[s], V[s], A[s], PF[s])))
        out["rnea with f_ext"] = out["rnea with f_ext"]._replace(
            call=lambda s: (P.rnea, (pm, pd, PQ[s], V[s], A[s], PF[s])))
    return out, PQ, lambda s: float(np.linalg.cond(_sym(P.crba(pm, pd, PQ[s]))))


def _err(case, ours, theirs, cond):
    """The error measure (docs/design.md §3) of one state's result; divided by cond(M) for a solve."""
    e = error(np.asarray(case.as_ours(ours), float), np.asarray(case.as_pin(theirs), float))
    return e / cond if case.by_cond else e


def _row(x, s):
    """Row s of a batched result (a tuple of arrays for frame_placement and the derivatives)."""
    return tuple(y[s] for y in x) if isinstance(x, tuple) else x[s]


ERR_NOTE = "err ÷ cond(M)"


def latency(sts, quick=False):
    """a. Single-state latency of every public, input-checked call against Pinocchio's cheapest Python route to
    the same numbers (conversions outside the timing), with the worst error over the states."""
    P, rows = pin(), []
    for st in sts:
        Q, V, A = random_states(st.model, 20 if quick else 100, np.random.default_rng(0))
        table, PQ, cond = cases(P, st, Q, V, A)
        conds = [cond(s) for s in range(len(Q))]
        for name, c in table.items():
            err = max(_err(c, c.ours(Q[s], V[s], A[s]), c.theirs(s), conds[s]) for s in range(len(Q)))
            q, v, a = Q[0], V[0], A[0]
            theirs = functools.partial(c.call(0)[0], *c.call(0)[1]) if c.call else functools.partial(c.theirs, 0)
            t_ours, t_pin = per_call_pair(functools.partial(c.ours, q, v, a), theirs, repeat=3 if quick else 7)
            rows.append(dict(robot=st.label, call=name, pin_route=c.route, ours_us=t_ours * 1e6, pin_us=t_pin * 1e6,
                             ratio=t_ours / t_pin, err=err, note=ERR_NOTE if c.by_cond else ""))
            if name in PLAIN:                    # Pinocchio's figure against a plain timeit of its call, as written
                t_plain = plain_timeit(PLAIN[name], P, st, PQ[0], V[0], A[0], repeat=3 if quick else 7)
                rows[-1].update(pin_plain_us=t_plain * 1e6, pin_deviation=abs(t_pin / t_plain - 1.0))
    return rows


# the calls whose Pinocchio figure is checked against a plain timeit of the call as a user writes it
PLAIN = {"rnea": "pin.rnea(model, data, q, v, a)", "aba": "pin.aba(model, data, q, v, a)",
         "mass_matrix (crba)": "pin.crba(model, data, q)"}


def plain_timeit(statement, P, st, q, v, a, repeat=7):
    """Seconds per call of ``statement`` (Pinocchio's call as a user writes it: ``pin``, ``model``, ``data``, q,
    v, a as plain names), by ``timeit``: the best of ``repeat`` runs of a loop calibrated to ~0.05 s."""
    g = dict(pin=P, model=st.pm, data=st.pm.createData(), q=np.array(q), v=np.array(v), a=np.array(a))
    timer = timeit.Timer(statement, globals=g)
    number, _ = timer.autorange()
    number = max(1, int(number * 0.25))          # autorange: ≥ 0.2 s; a quarter of it a run
    return min(timer.repeat(repeat, number)) / number



def _plain(statement, g, repeat):
    """Seconds per run of ``statement`` (names from g) by a plain ``timeit``: the best of ``repeat`` runs of a loop
    of ~0.05 s."""
    timer = timeit.Timer(statement, globals=g)
    number, _ = timer.autorange()
    number = max(1, int(number * 0.25))
    return min(timer.repeat(repeat, number)) / number


# configuration operations: (ours, Pinocchio's), each as a user writes it
CONFIG_CALLS = {"integrate": ("md.integrate(model, q0, v)", "pin.integrate(pm, p0, v)"),
                "difference": ("md.difference(model, q0, q1)", "pin.difference(pm, p0, p1)"),
                "neutral": ("md.neutral(model)", "pin.neutral(pm)"),
                "normalize": ("md.normalize(model, q0)", "pin.normalize(pm, p0)")}
NJIT_CALL = "rnea, one step of a user's numba.njit loop"


def _njit_rnea_loop():
    """A user's own compiled loop (docs/api/compiled.md): compiled.rnea over the rows of a batch; the worst status."""
    import numba

    from .. import compiled

    @numba.njit
    def loop(I, F, Q, V, A, T):
        worst = compiled.OK
        for s in range(Q.shape[0]):
            worst = max(worst, compiled.rnea(I, F, Q[s], V[s], A[s], T[s]))
        return worst
    return loop


def one_state(sts, quick=False):
    """a'. The configuration operations of one state against Pinocchio's, and one rnea step inside a user's own
    numba.njit loop (``manipdyn.compiled``, 10⁴ states) against Pinocchio's plain Python call; every figure a
    plain ``timeit`` of the call as written (CONFIG_CALLS), err against Pinocchio's result."""
    import manipdyn as md
    from .. import compiled
    P, rows, repeat = pin(), [], 3 if quick else 7
    loop = _njit_rnea_loop()
    for st in sts:
        model, pm = st.model, st.pm
        rng = np.random.default_rng(0)
        q0, q1 = md.random_configuration(model, rng), md.random_configuration(model, rng)
        v = rng.normal(0.0, 1.0, model.nv)
        p0, p1 = st.to_pin(q0), st.to_pin(q1)
        g = dict(md=md, pin=P, model=model, pm=pm, q0=q0, q1=q1, v=v, p0=p0, p1=p1)
        results = {"integrate": (st.to_pin(md.integrate(model, q0, v)), P.integrate(pm, p0, v)),
                   "difference": (md.difference(model, q0, q1), P.difference(pm, p0, p1)),
                   "neutral": (st.to_pin(md.neutral(model)), P.neutral(pm)),
                   "normalize": (st.to_pin(md.normalize(model, q0)), P.normalize(pm, p0))}
        for call, (ours, theirs) in CONFIG_CALLS.items():
            t_ours, t_pin = _plain(ours, g, repeat), _plain(theirs, g, repeat)
            rows.append(dict(robot=st.label, call=call, ours_us=t_ours * 1e6, pin_us=t_pin * 1e6,
                             ratio=t_ours / t_pin, err=error(*(np.asarray(x, float) for x in results[call]))))
        if model.nv:
            N = 1000 if quick else 10_000
            Q, V, A = random_states(model, N, np.random.default_rng(1))
            T, (I, F) = np.empty((N, model.nv)), compiled.arrays(model)
            loop(I, F, Q, V, A, T)                                   # (compiles once)
            t_ours = _plain("loop(I, F, Q, V, A, T)", dict(loop=loop, I=I, F=F, Q=Q, V=V, A=A, T=T), repeat) / N
            g.update(data=pm.createData(), pq=st.to_pin(Q[0]), v0=V[0].copy(), a0=A[0].copy())
            t_pin = _plain("pin.rnea(pm, data, pq, v0, a0)", g, repeat)
            err = max(error(T[s], P.rnea(pm, pm.createData(), st.to_pin(Q[s]), V[s], A[s]))
                      for s in range(0, N, N // 20))
            rows.append(dict(robot=st.label, call=NJIT_CALL, ours_us=t_ours * 1e6, pin_us=t_pin * 1e6,
                             ratio=t_ours / t_pin, err=err))
    return rows


LANE_CALLS = ("rnea", "aba", "mass_matrix (crba)")      # the lane kernels' calls: timed at N = big too
# the batched calls that take out= (dynamics/route.py): timed writing into one array, as Pinocchio's batch writes into
# its out and its loop into data; into a new array each call too (fresh_us)
OUT_CALLS = ("rnea", "aba", "mass_matrix (crba)", "coriolis_matrix", "gravity_torques", "nonlinear_effects",
             "forward_dynamics (cholesky)", "joint_torque_regressor")


WP_STATES = 200      # the lane kernels' work–precision rows: states spread through the batch


def _work_precision(c, mine, pin_s, cond, Q, V, A, n):
    """Median and 95th percentile of the error of a batched result's states (the lane kernels) against Pinocchio
    and against the same call on one state (the scalar kernel), over n states spread through the batch."""
    picks = np.unique(np.linspace(0, len(Q) - 1, min(n, len(Q))).astype(int))
    e_pin, e_one = [], []
    for s in picks:
        k = cond(s) if c.by_cond else 1.0
        e_pin.append(_err(c, _row(mine, s), pin_s(s), k))
        one = c.ours(Q[s], V[s], A[s])
        e_one.append(error(np.asarray(c.as_ours(_row(mine, s)), float), np.asarray(c.as_ours(one), float)) / k)
    return dict(wp_states=len(picks), err_pin_median=float(np.median(e_pin)),
                err_pin_p95=float(np.percentile(e_pin, 95)), err_one_median=float(np.median(e_one)),
                err_one_p95=float(np.percentile(e_one, 95)))


def batched(sts, quick=False, sizes=(1000,), big=10_000, sample=20, precision=True):
    """b. Every public call on a batch (N, nv), time per state on one thread, against Pinocchio's C++ batch
    (pin.*InParallel, 1 thread) where it exists, else its cheapest Python loop over the same states
    (conversions outside the timing); at ``sizes``, and at ``big`` for the lane kernels' calls (LANE_CALLS).
    The error is the worst over ``sample`` states spread through the batch; ``precision``: the lane calls' rows at
    ``big`` also get their work–precision figures. (Every core: ``throughput``.)"""
    P, rows = pin(), []
    timed = (lambda f, g: per_call_pair(f, g, repeat=2, min_time=0)) if quick else \
        (lambda f, g: per_call_pair(f, g, repeat=11, min_time=0.02))   # short runs, many rounds: a burst of
    #                                            noise on this shared machine spoils a few rounds, not the best
    alone = (lambda f: per_call(f, repeat=2, min_time=0)) if quick else (lambda f: per_call(f, repeat=11, min_time=0.02))
    for st in sts:
        model, pm = st.model, st.pm
        pool = P.ModelPool(pm, 1)
        QA, VA, AA = random_states(model, max((*sizes, big)), np.random.default_rng(2))
        for N in sorted({*sizes, big}):
            Q, V, A = QA[:N], VA[:N], AA[:N]
            table, PQ, cond = cases(P, st, Q, V, A, f_ext=N in sizes, threads=1)
            picks = np.unique(np.linspace(0, N - 1, min(sample, N)).astype(int))
            conds = {s: cond(s) for s in picks}
            QT, VT, AT = (np.asfortranarray(np.array(x).T) for x in (PQ, V, A))
            for name, c in table.items():
                if N not in sizes and name not in LANE_CALLS:
                    continue
                try:
                    mine = c.ours(Q, V, A)
                except ManipdynError as exc:      # a call that refuses a batch is reported, not faked
                    rows.append(dict(robot=st.label, call=name, N=N, refused=f"{type(exc).__name__}: {exc}"))
                    continue
                if c.parallel:
                    out = np.asfortranarray(np.zeros((model.nv, N)))
                    par = getattr(P, c.parallel + "InParallel")
                    theirs, route = (lambda: par(1, pool, QT, VT, AT, out)), "InParallel(1)"
                    theirs()
                    pin_s = lambda s: out[:, s]  # noqa: E731
                else:
                    theirs, route, pin_s = (lambda: [c.theirs(s) for s in range(N)]), "loop", c.theirs
                err = max(_err(c, _row(mine, s), pin_s(s), conds[s]) for s in picks)
                row = dict(robot=st.label, call=name, N=N)
                if name in OUT_CALLS:
                    buf = np.empty_like(mine)
                    t_ours, t_pin = (t / N for t in timed(lambda: c.ours(Q, V, A, out=buf), theirs))
                    err = max(err, max(_err(c, buf[s], pin_s(s), conds[s]) for s in picks))
                    row["fresh_us"] = alone(lambda: c.ours(Q, V, A)) / N * 1e6
                else:
                    t_ours, t_pin = (t / N for t in timed(lambda: c.ours(Q, V, A), theirs))
                row.update(ours_us=t_ours * 1e6, pin_us=t_pin * 1e6, pin_route=route, ratio=t_ours / t_pin, err=err,
                           note=ERR_NOTE if c.by_cond else "")
                if N == big and name in LANE_CALLS and precision:
                    row.update(_work_precision(c, mine, pin_s, cond, Q, V, A, 20 if quick else WP_STATES))
                rows.append(row)
    return rows


def floating(sts, quick=False, big=10_000):
    """b (floating bases). The lane kernels' calls (rnea, aba, mass_matrix) at N = ``big`` on free-flyer robots and
    ball-jointed trees, one thread, against rneaInParallel(1), abaInParallel(1) and a loop of crba (``batched``'s
    rows)."""
    return batched(sts, quick, sizes=(), big=big, precision=False)


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
    for _ in range(100):             # first calls (kernels loaded, caches filled) and the CPU's clock settle first
        constrained_forward_dynamics(model, q, v, tau), cref.qdd(q, v, tau)
    t_ours, t_pin = per_call_pair(lambda: constrained_forward_dynamics(model, q, v, tau), lambda: cref.qdd(q, v, tau))
    err = max(error(constrained_forward_dynamics(model, Qm[s], Vm[s], tau)[0], cref.qdd(Qm[s], Vm[s], tau))
              for s in range(len(Qm)))
    return [dict(robot=model.name, call="constrained_forward_dynamics", ours_us=t_ours * 1e6,
                 pin_us=t_pin * 1e6, ratio=t_ours / t_pin, err=err)]


def throughput(paths, sizes, quick=False):
    """b. Time per state of batched calls on one thread and on every core (``threads``), against a Pinocchio
    loop and pin.*InParallel on 1 thread and on every core: ours_us / ours_all_us, all_over_one = ours_all_us ÷
    ours_us (the time a batch takes on every core as a share of one core's), ratio_par1 and ratio_par_all."""
    P, rows = pin(), []
    from ..dynamics.route import CORES as cores
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
                ("rnea", lambda th: rnea(model, Q, V, A, threads=th),
                 lambda: [P.rnea(pm, pd, PQ[:, s], PV[:, s], PA[:, s]) for s in range(loop_n)],
                 lambda th: P.rneaInParallel(th, pool, PQ, PV, PA, out)),
                ("aba", lambda th: aba(model, Q, V, A, threads=th),
                 lambda: [P.aba(pm, pd, PQ[:, s], PV[:, s], PA[:, s]) for s in range(loop_n)],
                 lambda th: P.abaInParallel(th, pool, PQ, PV, PA, out)),
                ("mass_matrix", lambda th: mass_matrix(model, Q, threads=th),
                 lambda: [P.crba(pm, pd, PQ[:, s]) for s in range(loop_n)], None)):
                ours(1), ours(cores)
                time.sleep(0.3)        # let the threads other libraries keep spinning after their last job
                pair = (lambda f, g: per_call_pair(f, g, repeat=2, min_time=0)) if quick else \
                    (lambda f, g: per_call_pair(f, g, repeat=31, min_time=0.005))   # one core and every core in
                one, every = (t / N * 1e6 for t in pair(lambda: ours(1), lambda: ours(cores)))   # alternation
                row = dict(robot=model.name, call=call, N=N, cores=cores, big=N >= 10_000, ours_us=one,
                           ours_all_us=every, all_over_one=every / one,
                           pin_loop_us=per_call(loop, repeat=reps, min_time=0.02) / loop_n * 1e6)
                if par is not None:
                    row["pin_par1_us"], row["pin_par_all_us"] = (t / N * 1e6 for t in pair(lambda: par(1),
                                                                                          lambda: par(cores)))
                    row["ratio_par1"] = row["ours_us"] / row["pin_par1_us"]
                    row["ratio_par_all"] = row["ours_all_us"] / row["pin_par_all_us"]
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
            t_o, t_p = per_call_pair(ours, theirs, repeat=3)
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
        exact = simulate(model, q0, v0, (0, horizon), integrator="adaptive", rtol=1e-13, atol=1e-14)
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
        r = simulate(model, q0, v0, (0, horizon), dt=5e-4, integrator="rk4", tau=pd_law, stabilization=stab,
                     baumgarte=(20.0, 20.0))
        phi = np.abs(closure_terms(model, r.q)[0]).max(axis=1)
        rows.append(dict(stabilization=stab, horizon_s=horizon, us_per_step=r.wall_time / r.n_steps * 1e6,
                         max_phi=float(phi.max()), final_phi=float(phi[-1])))
    return rows


def floors(batched_rows, robots, big=10_000):
    """The lane kernels against their arithmetic floor: flops per state counted by running them
    (bench/flops.py), the floor flops ÷ (16 × the clock), and ours at N = big (the batched rows) ÷ the floor.
    robots: {label: URDF path or "chain:N"}, the labels of the batched rows."""
    from .flops import PEAK_PER_CYCLE, clock_ghz, counts
    ghz, flops = clock_ghz(), counts(robots)
    ours = {(r["robot"], r["call"]): r["ours_us"] for r in batched_rows if r.get("N") == big and "ours_us" in r}
    rows = []
    for label, per in flops.items():
        for call, key in (("rnea", "rnea"), ("aba", "aba"), ("mass_matrix (crba)", "mass_matrix")):
            row = dict(robot=label, call=call, flops=per[key], ghz=ghz)
            if ghz:
                row["floor_ns"] = per[key] / (PEAK_PER_CYCLE * ghz)
                if (label, call) in ours:
                    row["ours_ns"] = ours[label, call] * 1e3
                    row["over_floor"] = row["ours_ns"] / row["floor_ns"]
            rows.append(row)
    return rows
