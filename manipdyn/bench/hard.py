"""Hard cases with a high-precision reference: ill-conditioned mass matrices against mpmath (50 digits).

The mechanism is a planar chain of n revolute joints about parallel y axes carrying point masses that span
1e-6 … 1e3 kg (zero rotational inertia): its equations of motion have a closed form that mpmath evaluates
at 50 digits, independently of every manipdyn and Pinocchio algorithm:
    p_k = Σ_{l ≤ k} L_l e(φ_l),  φ_l = q_1 + … + q_l,  e(φ) = (cos φ, −sin φ) in the x–z plane
    M_ij = Σ_k m_k J_ki · J_kj,  J_ki = ∂p_k/∂q_i = Σ_{i ≤ l ≤ k} L_l e'(φ_l)
    h_i  = Σ_k m_k J_ki · (−Σ_{l ≤ k} L_l e(φ_l) φ̇_l² − g)
and q̈ = M⁻¹(τ − h) is solved in mpmath.
"""
from __future__ import annotations

import numpy as np

from ..extras import require
from ..io.urdf import load_urdf_string


def planar_chain_urdf(masses, lengths):
    """URDF of the planar point-mass chain (joint i about y at the end of link i − 1)."""
    out = ['<?xml version="1.0"?><robot name="planar_chain"><link name="l0"/>']
    masses, lengths = [float(x) for x in masses], [float(x) for x in lengths]
    for k, (m, L) in enumerate(zip(masses, lengths), start=1):
        out.append(f'<link name="l{k}"><inertial><origin xyz="{L!r} 0 0" rpy="0 0 0"/><mass value="{m!r}"/>'
                   f'<inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial></link>')
        x = 0.0 if k == 1 else lengths[k - 2]
        out.append(f'<joint name="j{k:02d}" type="continuous"><parent link="l{k - 1}"/><child link="l{k}"/>'
                   f'<origin xyz="{x!r} 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/></joint>')
    return "".join(out) + "</robot>"


def mp_forward(masses, lengths, q, v, tau, g=9.81, dps=50):
    """q̈ of the planar chain at ``dps`` digits (mpmath), and cond(M) in double."""
    mp = require("mpmath", "validate", "manipdyn bench (its 50-digit reference)")
    mp.mp.dps = dps
    n = len(masses)
    m, L = [mp.mpf(x) for x in masses], [mp.mpf(x) for x in lengths]
    phi = [mp.fsum(mp.mpf(x) for x in q[:k + 1]) for k in range(n)]
    dphi = [mp.fsum(mp.mpf(x) for x in v[:k + 1]) for k in range(n)]
    e = lambda a: (mp.cos(a), -mp.sin(a))  # noqa: E731
    de = lambda a: (-mp.sin(a), -mp.cos(a))  # noqa: E731
    J = [[tuple(mp.fsum(L[l] * de(phi[l])[c] for l in range(i, k + 1)) for c in range(2)) if i <= k
          else (mp.mpf(0), mp.mpf(0)) for i in range(n)] for k in range(n)]
    acc = [tuple(-mp.fsum(L[l] * e(phi[l])[c] * dphi[l] ** 2 for l in range(k + 1)) for c in range(2))
           for k in range(n)]
    grav = (mp.mpf(0), mp.mpf(-g))                       # gravity along −z
    M = mp.matrix(n, n)
    h = mp.matrix(n, 1)
    for i in range(n):
        for j in range(n):
            M[i, j] = mp.fsum(m[k] * (J[k][i][0] * J[k][j][0] + J[k][i][1] * J[k][j][1]) for k in range(n))
        h[i] = mp.fsum(m[k] * mp.fsum(J[k][i][c] * (acc[k][c] - grav[c]) for c in range(2)) for k in range(n))
    rhs = mp.matrix([mp.mpf(x) for x in tau]) - h
    qdd = mp.lu_solve(M, rhs)
    Md = np.array(M.tolist(), dtype=float)
    return np.array([float(x) for x in qdd]), float(np.linalg.cond(Md))


def _pin_cholesky(pin, pm, pd, pq, v, tau):
    """Pinocchio's M⁻¹ route: q̈ = M⁻¹ (τ − h) with crba and its own sparse Cholesky (cholesky.decompose)."""
    h = pin.nonLinearEffects(pm, pd, pq, v)
    pin.crba(pm, pd, pq)
    pin.cholesky.decompose(pm, pd)
    return pin.cholesky.solve(pm, pd, tau - h)


def ill_conditioned(n=6, spread=(1e-6, 1e3), seed=0, states=5, light_root=False, lengths=(0.05, 0.5)):
    """Errors of q̈ from ABA and the Cholesky (M⁻¹) route, ours and Pinocchio's, against the 50-digit reference; and
    from the lane ABA (``aba_lanes``: all states in one batch)."""
    pin = require("pinocchio", "validate", "manipdyn bench")

    from ..dynamics.aba import aba, forward_dynamics
    from ..validation.measure import error
    rng = np.random.default_rng(seed)
    masses = np.geomspace(spread[0], spread[1], n) if light_root else np.geomspace(spread[1], spread[0], n)
    lengths = rng.uniform(lengths[0], lengths[1], n)
    text = planar_chain_urdf(masses, lengths)
    model, pm = load_urdf_string(text), pin.buildModelFromXML(text)
    pd = pm.createData()
    rows, batch = [], []
    for _ in range(states):
        q, v, tau = rng.uniform(-np.pi, np.pi, n), rng.normal(0, 2, n), rng.normal(0, 1, n) * masses
        exact, cond = mp_forward(masses, lengths, q, v, tau)
        batch.append((q, v, tau, exact))
        pq = np.ravel(np.column_stack([np.cos(q), np.sin(q)]))
        rows.append(dict(n=n, mass_ratio=spread[1] / spread[0], cond_M=cond,
                         aba=error(aba(model, q, v, tau), exact),
                         cholesky=error(forward_dynamics(model, q, v, tau, method="cholesky", joint_dynamics=False),
                                        exact),
                         pinocchio=error(pin.aba(pm, pd, pq, v, tau), exact),
                         pinocchio_cholesky=error(_pin_cholesky(pin, pm, pd, pq, v, tau), exact)))
    Q, V, T = (np.array([b[k] for b in batch]) for k in range(3))      # one batch: the lane kernel's blocks
    for row, qdd, b in zip(rows, aba(model, Q, V, T, threads=1), batch):
        row["aba_lanes"] = error(qdd, b[3])
    return rows
