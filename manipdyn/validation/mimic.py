"""A mimic model (``load_urdf(path, mimic=True)``) against Pinocchio's ``buildModelFromUrdf(path, mimic=True)``.

Pinocchio 4.1's aba refuses mimic joints and its default crba too; what works and is used as the reference:
    τ   = rnea(q, q̇, q̈)                      g = rnea(q, 0, 0)
    M   = crba(q, Convention.WORLD), symmetrised from its upper triangle
    q̈   = M⁻¹ (τ − rnea(q, q̇, 0))            reported as err / cond(M), the conditioning of the solve
Independent coordinates are Pinocchio's (the mimic joints carry none); its continuous joints are (cos, sin).
Random states: those of ``compare.random_states`` on the full tree, restricted to the independent joints.
"""
from __future__ import annotations

import time

import numpy as np

from ..dynamics.aba import aba
from ..dynamics.crba import mass_matrix
from ..dynamics.rnea import gravity_torques, rnea
from ..errors import ManipdynError
from ..model import MimicModel
from .compare import Report, TermResult, random_states
from .measure import error
from .reference import pin

MIMIC_TERMS = {"tau": "τ = Gᵀ τ_full vs rnea (mimic=True)", "g": "g vs rnea(q, 0, 0) (mimic=True)",
               "M": "M = Gᵀ M_full G vs crba WORLD (mimic=True)",
               "qdd": "q̈ vs M⁻¹(τ − h) (mimic=True), err/cond(M)"}


class MimicReference:
    """Pinocchio's mimic model of the same URDF, its joints checked against ours, and the q conversion."""

    def __init__(self, mm, urdf_path):
        P = pin()
        root = (P.JointModelFreeFlyer(),) if mm.full.floating else ()
        self.pm = P.buildModelFromUrdf(str(urdf_path), *root, mimic=True)
        self.pd = self.pm.createData()
        self.pm.gravity.linear = np.asarray(mm.full.gravity, float)
        names = tuple(self.pm.names[i] for i in range(1, self.pm.njoints) if self.pm.joints[i].nv)
        if names != mm.joint_names or self.pm.nv != mm.nv:
            raise ManipdynError(f"{urdf_path}: independent joints differ from Pinocchio's mimic model: ours "
                                f"{mm.joint_names}, Pinocchio {names}")
        full = mm.full
        self.blocks = []                      # (our q index, our nq, Pinocchio's idx_q, its nq)
        k = 0
        for n in mm.joint_names:
            i = full.joint_index(n)
            jm = self.pm.joints[self.pm.getJointId(n)]
            self.blocks.append((k, int(full.nqs[i]), jm.idx_q, jm.nq))
            k += int(full.nqs[i])

    def to_pin_q(self, q):
        pq = np.zeros(self.pm.nq)
        for a, n, b, m in self.blocks:
            pq[b:b + m] = (np.cos(q[a]), np.sin(q[a])) if m == 2 and n == 1 else q[a:a + n]
        return pq

    def terms(self, q, v, a, tau):
        """Pinocchio's τ, g, M, q̈ at our independent state (q, v, a, tau)."""
        P, pm, pd = pin(), self.pm, self.pd
        pq, z = self.to_pin_q(q), np.zeros(pm.nv)
        M = P.crba(pm, pd, pq, P.Convention.WORLD)
        M = np.triu(M) + np.triu(M, 1).T
        return dict(tau=P.rnea(pm, pd, pq, v, a).copy(), g=P.rnea(pm, pd, pq, z, z).copy(), M=M,
                    qdd=np.linalg.solve(M, tau - P.rnea(pm, pd, pq, v, z)))


def independent_states(mm, n, rng):
    """Seeded (q (n, nq), q̇ (n, nv), q̈ (n, nv), τ (n, nv)) of the independent joints (docs/design.md §3 ranges)."""
    full = mm.full
    Q, V, A = random_states(full, n, rng)
    iq = np.concatenate([np.arange(full.idx_q[i], full.idx_q[i] + full.nqs[i]) for i in map(full.joint_index, mm.joint_names)])
    iv = np.concatenate([np.arange(full.idx_v[i], full.idx_v[i] + full.nvs[i]) for i in map(full.joint_index, mm.joint_names)])
    return Q[:, iq], V[:, iv], A[:, iv], rng.normal(0.0, 5.0, (n, mm.nv))


def validate_mimic(mm, urdf_path, *, n_states=1000, seed=0, tol=1e-12, progress=None) -> Report:
    """Compare τ, g, M and q̈ of a MimicModel with Pinocchio's mimic model of ``urdf_path`` (module docstring)."""
    if not isinstance(mm, MimicModel):
        raise ManipdynError(f"validate_mimic takes a MimicModel (load_urdf(..., mimic=True)), not {type(mm).__name__}")
    t0 = time.perf_counter()
    ref, rng = MimicReference(mm, urdf_path), np.random.default_rng(seed)
    Q, V, A, T = independent_states(mm, n_states, rng)
    ours = dict(tau=rnea(mm, Q, V, A), g=gravity_torques(mm, Q), M=mass_matrix(mm, Q), qdd=aba(mm, Q, V, T))
    worst = {k: [0.0, 0.0] for k in MIMIC_TERMS}
    for s in range(n_states):
        theirs = ref.terms(Q[s], V[s], A[s], T[s])
        kappa = np.linalg.cond(theirs["M"])
        for k in MIMIC_TERMS:
            x, y = ours[k][s], theirs[k]
            e = error(x, y) / (kappa if k == "qdd" else 1.0)
            worst[k] = [max(worst[k][0], float(np.max(np.abs(x - y)))), max(worst[k][1], e)]
        if progress:
            progress(2)
    rep = Report(mm.name, str(urdf_path), mm.nv, n_states, seed)
    rep.terms = [TermResult(k, MIMIC_TERMS[k], worst[k][0], worst[k][1], tol) for k in MIMIC_TERMS]
    rep.notes.append(f"mimic joints honoured: {', '.join(f'{j} = {m:g} {t} + {o:g}' for j, t, m, o in mm.mimic)}; "
                     f"reference buildModelFromUrdf(path, mimic=True): nq = {ref.pm.nq}, nv = {ref.pm.nv}")
    rep.seconds = time.perf_counter() - t0
    return rep
