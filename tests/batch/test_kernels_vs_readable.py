"""Every compiled kernel against an independent reference (docs/design.md §4b, §5), output array by output
array, one state (the *_one kernels) and batches of 1 and 7 (the batch kernels), on the bundled models, the
example-robot-data arms, random trees and random spatial loops — closed-chain kernels also off the closures
(random q, q̇ that violate them).

The kernels are called directly (dynamics/fast.py, constraints/closures.py, constraints/fast.py), so no
wrapper can route around them. (Newton–Euler, the CRBA and the ABA have one
source each, held to Pinocchio and to themselves uncompiled in tests/crosscheck/.) References: for the closure rows (closure_kernel, the one source of Φ, Φ_q,
Φ̇_q q̇) Pinocchio's frame placements, Jacobians and their time variation (tests/pin_closures.py); for the
KKT kernel the KKT solve of constraints/dynamics.py with independent_rows, fed by the Lagrange-route M and
by rnea.
"""
import functools
import warnings

import numpy as np
import pytest
from conftest import ROOT, err, inertial_xml, urdf, zoo_paths

import manipdyn as md
from manipdyn.constraints.closures import RANK_RTOL, closure_terms, independent_rows
from manipdyn.constraints.dynamics import _kkt
from manipdyn.constraints.closures import CLOSURE, closure_arrays
from manipdyn.constraints.fast import CONSTRAINED_FD
from manipdyn.dynamics.model_arrays import kernel_arrays as core_arrays
from manipdyn.spatial import rpy_matrix
from manipdyn.validation import random_states
from manipdyn.validation.reference import Reference, pin
from pin_closures import PinClosures

SHAPES = (None, 1, 7)                     # None: one state (nv,) through *_one; else a batch (N, nv)


# ---- models ---------------------------------------------------------------------------------------------

def _random_tree_text(seed, n, kinds=("revolute", "continuous", "prismatic", "fixed"), parents=None):
    """URDF of a random tree of n joints: random parents (unless given: link index, -1 = base), axes,
    placements, inertias."""
    rng = np.random.default_rng(seed)
    links, joints = {"base": ""}, []
    for k in range(n):
        parent = "base" if k == 0 or rng.random() < 0.2 else f"L{rng.integers(0, k)}"
        if parents is not None:
            parent = "base" if parents[k] < 0 else f"L{parents[k]}"
        d = rng.uniform(0.05, 1.0, 3)                                # principal moments from a valid body
        m = rng.uniform(0.1, 3.0)
        I = np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]]) * m / 10
        links[f"L{k}"] = inertial_xml(m, rng.uniform(-0.3, 0.3, 3), (*I, 0, 0, 0), rng.uniform(-np.pi, np.pi, 3))
        axis = rng.normal(size=3)
        joints.append((f"j{k:02d}", kinds[rng.integers(len(kinds))] if k else "revolute", parent, f"L{k}",
                       rng.uniform(-0.5, 0.5, 3), rng.uniform(-np.pi, np.pi, 3), axis / np.linalg.norm(axis)))
    return urdf(links, joints, name=f"random{seed}")


def _rpy(R):
    """URDF roll-pitch-yaw of R = Rz(y) Ry(p) Rx(r)."""
    return np.arctan2(R[2, 1], R[2, 2]), -np.arcsin(np.clip(R[2, 0], -1, 1)), np.arctan2(R[1, 0], R[0, 0])


def _num(x):
    return " ".join(repr(float(t)) for t in x)


def _closed_text(seed, n, closures):
    """A random spatial tree (revolute and prismatic joints) with <constraint>s (type, parent link, child
    link) that hold at a random configuration q0: the closure frame is a random world pose, written in each
    link's frame. Returns (URDF text, q0)."""
    text = _random_tree_text(seed, n, kinds=("revolute", "revolute", "prismatic"), parents=TWO_ARMS)
    tree = md.load_urdf_string(text)
    rng = np.random.default_rng(seed + 1000)
    q0 = rng.uniform(-1.0, 1.0, tree.nv)
    out = []
    for i, (kind, a, b) in enumerate(closures):
        x, Rw, e = rng.uniform(-0.5, 0.5, 3), rpy_matrix(rng.uniform(-np.pi, np.pi, 3)), rng.normal(size=3)
        side = []
        for role, link in (("parent", a), ("child", b)):
            R, p = md.frame_placement(tree, q0, link)
            xl, Rl, el = R.T @ (x - p), R.T @ Rw, R.T @ e / np.linalg.norm(e)
            side.append(f'<{role} link="{link}"/><{role}_origin xyz="{_num(xl)}" rpy="{_num(_rpy(Rl))}"/>'
                        f'<{role}_axis xyz="{_num(el)}"/>')
        out.append(f'<constraint name="c{i}" type="{kind}">{"".join(side)}</constraint>')
    return text.replace("</robot>", "".join(out) + "</robot>"), q0


# Spatial loops whose closure rows are all independent: a trunk L0-L3 carrying two arms L4-L10 and L11-L17
# (18 joints); a fixed closure between the arms' tips (14 joints in its loop), a spherical one from the
# base to arm 1 and a revolute one from the base to arm 2 (8 joints each): 6 + 3 + 5 = 14 rows, 4 dof.
TWO_ARMS = [-1, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 3, 11, 12, 13, 14, 15, 16]
SPATIAL_LOOPS = {name: (seed, 18, [("fixed", "L10", "L17"), ("spherical", "base", "L7"), ("revolute", "base", "L14")])
                 for name, seed in (("loops11", 11), ("loops12", 12))}
RANDOM_TREES = {"tree5": (5, 12), "tree6": (6, 20)}


@functools.lru_cache(maxsize=None)
def _load(name):
    """The model, and an assembled configuration for the spatial loops (else None)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name in RANDOM_TREES:
            return md.load_urdf_string(_random_tree_text(*RANDOM_TREES[name])), None
        if name in SPATIAL_LOOPS:
            text, q0 = _closed_text(*SPATIAL_LOOPS[name])
            return md.load_urdf_string(text), q0
        if (ROOT / "urdf" / f"{name}.urdf").is_file():
            return md.load_urdf(ROOT / "urdf" / f"{name}.urdf"), None
        return md.load_urdf(next(p for p in zoo_paths() if p.stem == name)), None


@functools.lru_cache(maxsize=None)
def _pin_closures(name):
    """(Pinocchio's closure rows of the model, our q -> Pinocchio's q)."""
    model, _ = _load(name)
    if name in SPATIAL_LOOPS:
        return PinClosures(model, pin().buildModelFromXML(_closed_text(*SPATIAL_LOOPS[name])[0])), np.asarray
    ref = Reference(model, ROOT / "urdf" / f"{name}.urdf")
    return PinClosures(model, ref.pm), ref.to_pin_q


OPEN = ["aau_arm", "spm", "fourbar"] + [p.stem for p in zoo_paths()] + list(RANDOM_TREES)
CLOSED = ["fourbar", "spm"] + list(SPATIAL_LOOPS)


# ---- the kernels, called directly, and their readable references ----------------------------------------

def _states(model, n, seed):
    Q, V, A = random_states(model, 7 if n is None else n, np.random.default_rng(seed))
    return (Q[0], V[0], A[0]) if n is None else (Q, V, A)


def _call(one, batch, n, *args, out):
    code = (one if n is None else batch)(*args, out)
    assert code == -1, f"kernel returned {code}"
    return out


def readable_constrained_fd(model, Q, V, T, baumgarte):
    """q̈, λ and rank of Eq. 27 by the readable KKT solve: M from the Lagrange route, h from rnea, the rows
    from closure_terms (held to Pinocchio in closed_chain_errors)."""
    Phi, Jc, bias = closure_terms(model, Q, V)
    c = -bias
    if baumgarte is not None:
        c = c - 2.0 * baumgarte[0] * np.einsum("nij,nj->ni", Jc, V) - baumgarte[1] ** 2 * Phi
    rhs = T - md.rnea(model, Q, V, np.zeros_like(V))
    M = md.mass_matrix(model, Q, method="lagrange")
    qdd, lam, rank = np.empty_like(Q), np.zeros_like(Phi), np.empty(len(Q), int)
    for s in range(len(Q)):
        keep = independent_rows(Jc[s], phi=Phi[s])
        qdd[s], lam[s, keep] = _kkt(M[s], Jc[s, keep], rhs[s], c[s, keep], model)
        rank[s] = len(keep)
    return qdd, lam, rank


def closed_states(model, q0, n, where, rng):
    """n states (q, q̇): "on" the closures (assembled, q̇ consistent), "near" them (q off by N(0, 1e-6²),
    as inside an integrator step, q̇ random) or "far" (random q and q̇; Φ of order 1)."""
    from manipdyn.validation.closed import manifold_states
    if where == "far":
        return random_states(model, n, rng)[:2]
    if q0 is None:
        Q, V = manifold_states(model, n, rng)
    else:                                              # local sampling around the assembled q0
        out = []
        while len(out) < n:
            try:
                out.append(md.project(model, q0 + rng.normal(0.0, 0.1, model.nv), rng.normal(0.0, 2.0, model.nv)))
            except md.ConstraintError:                 # Newton from too far: draw again
                continue
        Q, V = np.array([q for q, _ in out]), np.array([v for _, v in out])
    if where == "near":
        Q, V = Q + rng.normal(0.0, 1e-6, Q.shape), rng.normal(0.0, 2.0, Q.shape)
    return Q, V


def closed_chain_errors(model, name, q0, n, where, baumgarte):
    """err of Φ, Φ_q, Φ̇_q q̇ (closure_kernel) against Pinocchio's frame kinematics, state by state, and of
    q̈, λ (constrained_fd_kernel) against the readable KKT solve, for n states (None: one); the ranks must
    agree exactly. Returns the errors and the smallest rank."""
    N = 1 if n is None else n
    rng = np.random.default_rng(41)
    Q, V = closed_states(model, q0, N, where, rng)
    T = rng.normal(0.0, 5.0, Q.shape)
    I, F = core_arrays(model)
    CI, CF = closure_arrays(model)
    m = sum(c.n_rows for c in model.constraints)
    Phi, Jc, bias = np.empty((N, m)), np.empty((N, m, model.nv)), np.empty((N, m))
    assert CLOSURE.call(I, F, CI, CF, Q, V, Phi, Jc, bias) == -1
    ref, to_pin_q = _pin_closures(name)
    out = {"phi": 0.0, "jac": 0.0, "bias": 0.0}
    for s in range(N):
        for key, x, y in zip(("phi", "jac", "bias"), (Phi[s], Jc[s], bias[s]), ref.rows(to_pin_q(Q[s]), V[s])):
            out[key] = max(out[key], err(x, y))
    alpha, beta = (0.0, 0.0) if baumgarte is None else baumgarte
    QDD, LAM, RANK = np.empty(Q.shape), np.empty((N, m)), np.empty(N, np.int64)
    code = CONSTRAINED_FD.call(I, F, model.kernel.lane_arrays[1], CI, CF, m, Q, V, T, alpha, beta, RANK_RTOL, QDD, LAM,
                               RANK)
    assert code == -1, f"kernel returned {code}"
    qdd, lam, rank = readable_constrained_fd(model, Q, V, T, baumgarte)
    assert RANK.tolist() == rank.tolist(), f"rank {RANK} != readable {rank}"
    out["qdd"], out["lam"] = err(QDD, qdd), err(LAM, lam)
    return out, int(rank.min())


# ---- tolerances: §3 error measure, the worst over the three shapes (and both Baumgarte settings) as
# measured on correct code, × 30 rounded up; "measured" beside each (closed chains: the worst of two runs
# whose states differ by round-off, being assembled by projection through the rows under test) ----------
# q̈, λ: the readable side's M is the Lagrange route (no readable CRBA twin): the max of the tolerances
# measured with either M
CLOSED_TOL = {                                                          # measured: Φ, Φ_q, Φ̇_q q̇, q̈, λ
    ("fourbar", "on"): (3e-15, 2e-15, 2e-14, 6e-14, 4e-14),          # 0.0e+00 5.6e-17 3.1e-16 1.4e-15 1.3e-15
    ("fourbar", "near"): (3e-15, 3e-15, 2e-14, 7e-14, 4e-14),          # 0.0e+00 5.6e-17 4.9e-16 3.2e-16 1.0e-15
    ("fourbar", "far"): (2e-15, 2e-15, 9e-15, 1e-13, 0.0),            # 0.0e+00 5.6e-17 2.8e-16 0.0e+00 0.0e+00
    ("spm", "on"): (3e-14, 4e-14, 6e-14, 4e-13, 8e-14),          # 7.0e-16 1.2e-15 1.7e-15 1.3e-14 2.5e-15
    ("spm", "near"): (3e-14, 5e-14, 8e-14, 1e-13, 7e-14),          # 6.4e-16 1.4e-15 2.4e-15 2.4e-15 1.8e-15
    ("spm", "far"): (3e-14, 3e-14, 3e-14, 3e-14, 0.0),            # 7.8e-16 7.8e-16 9.6e-16 7.5e-16 0.0e+00
    ("loops11", "on"): (2e-13, 7e-14, 2e-13, 3e-12, 5e-12),          # 3.8e-15 2.3e-15 4.0e-15 6.5e-14 1.2e-13
    ("loops11", "near"): (2e-13, 7e-14, 2e-13, 4e-12, 5e-12),          # 3.5e-15 2.3e-15 4.7e-15 1.2e-13 1.5e-13
    ("loops11", "far"): (4e-14, 7e-14, 2e-13, 2e-13, 0.0),            # 1.1e-15 2.1e-15 6.2e-15 2.1e-15 0.0e+00
    ("loops12", "on"): (6e-14, 4e-14, 2e-13, 7e-13, 3e-13),          # 1.8e-15 1.3e-15 4.1e-15 2.1e-14 9.0e-15
    ("loops12", "near"): (7e-14, 4e-14, 3e-13, 7e-13, 3e-13),          # 2.0e-15 1.3e-15 8.5e-15 2.3e-14 9.7e-15
    ("loops12", "far"): (5e-14, 6e-14, 3e-13, 8e-14, 0.0),            # 1.5e-15 1.7e-15 9.5e-15 1.5e-15 0.0e+00
}
CLOSED_KEYS = ("phi", "jac", "bias", "qdd", "lam")
RANK = {"fourbar": 2, "spm": 4, "loops11": 14, "loops12": 14}     # on or near the closures; far: 0 rows kept


def _check(errors, tol, what):
    bad = [f"{k}: err {e:.2e} > tol {tol[k]:.0e}" for k, e in errors.items() if not e <= tol[k]]
    assert not bad, f"{what}: " + "; ".join(bad)


@pytest.mark.parametrize("baumgarte", [None, (3.0, 4.0)], ids=["plain", "baumgarte"])
@pytest.mark.parametrize("where", ["on", "near", "far"])
@pytest.mark.parametrize("n", SHAPES, ids=lambda n: "one" if n is None else f"N{n}")
@pytest.mark.parametrize("name", CLOSED)
def test_closed_chain_kernels_equal_readable(name, n, where, baumgarte):
    model, q0 = _load(name)
    errors, rank = closed_chain_errors(model, name, q0, n, where, baumgarte)
    _check(errors, dict(zip(CLOSED_KEYS, CLOSED_TOL[name, where])), f"{name}, {where}, {n} states")
    assert rank == (0 if where == "far" else RANK[name])
    if name in SPATIAL_LOOPS and where != "far":        # every closure row independent: no bug can hide
        assert rank == sum(c.n_rows for c in model.constraints)
