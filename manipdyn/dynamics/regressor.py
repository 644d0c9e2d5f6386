"""The joint-torque regressor: τ = Y(q, q̇, q̈) π, linear in the dynamic parameters π (Atkeson, An &
Hollerbach 1986; Khalil & Dombre 2002 §9.3; Pinocchio's ``computeJointTorqueRegressor``).

The dynamic parameters (owned here) are ten numbers per moving body, in Pinocchio's order
(``pin.Inertia.toDynamicParameters``):

    π_i = (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz)

with c the centre of mass and I = I_C + m (c·c 1 − c cᵀ) the inertia about the body's origin, both in the
body frame (``model``: the joint frame after the joint's motion, merged fixed links folded in). Bodies are
the joints, in q order (a free-flyer root is body 0); π = (π_0, …, π_{nb−1}), 10 nb entries.

Why τ is linear in π: body i's inertial wrench about its origin, in its own axes, is (Eqs. 13–16 moved
to the origin, h = m c)

    f'_i = m v̇'_i + ω̇'_i × h + ω'_i × (ω'_i × h)
    n'_i = I ω̇'_i + ω'_i × I ω'_i + h × v̇'_i

with ω'_i, ω̇'_i, v̇'_i (gravity included: v̇'_0 = −g) from the Newton–Euler passes (the records of
``rnea.outward_one``, the RNEA's outward pass, not a copy; turned from their z-aligned axes into the link's, where the
parameters are written). So [f'_i; n'_i] = A_i π_i with the 6 × 10 block (rows [force; moment])

    A_i = [[v̇', [ω̇']× + [ω']×[ω']×, 0        ],
           [0,  −[v̇']×,              L(ω̇') + [ω']× L(ω')]],   I ω = L(ω) (I_xx, I_xy, I_yy, I_xz, I_yz, I_zz).

The wrench reaches joint j (i itself and every ancestor) moved into body j's frame, ʲX*_i A_i (Eqs. 15–16),
and joint j feels its motion-subspace component: the column block of body i in joint j's rows is

    Y_{j,i} = S_jᵀ ʲX*_i A_i = (ⁱX_j S_j)ᵀ A_i      (ʲX*_i = (ⁱX_j)ᵀ; j = i or an ancestor of i, else zero:
                                                    Y is block upper triangular)

The kernel takes the right-hand form: instead of carrying ten wrench columns inward once per ancestor, it
carries each ancestor's motion subspace outward once per body, ⁱX_j S_j = ⁱX_λ (^λX_j S_j)
(``spatial.motion_down``), and projects A_i onto it — one 6-vector moved per ancestor velocity instead of ten.

Single states (nv,), batches (N, nv); the kernel is compiled by numba and runs as plain Python under
MANIPDYN_NOJIT=1.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .._jit import A1, A2, A3, CONTRACT, MODEL, entry, njit
from ..errors import InputError
from ..spatial import first_nonfinite_entry, motion_down, mul3, mul3t
from .lanes import get3, get_rotation
from .model_arrays import unpack
from .rnea import RECORD, outward_one, steps_scratch
from .route import route
from .arguments import as_real, check_finite, check_model
from .kernel_inputs import model_sizes, sized
from .status import WRONG_SIZES, bad_input, bad_result

NP = 10                                          # dynamic parameters per body
PARAMETER_NAMES = ("m", "mc_x", "mc_y", "mc_z", "I_xx", "I_xy", "I_yy", "I_xz", "I_yz", "I_zz")
_QVA = ("q", "v", "a")


# -- the parameters, and back ---------------------------------------------------------------------------------

def dynamic_parameters(model):
    """π (10 nb,): per body (m, m c, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz) with I = I_C + m (c·c 1 − c cᵀ)
    about the body origin, body axes (Pinocchio's Inertia.toDynamicParameters; parallel-axis theorem)."""
    check_model(model)
    m, c, Ic = np.asarray(model.mass, float), np.asarray(model.com, float), np.asarray(model.inertia, float)
    I = Ic + m[:, None, None] * (np.einsum("bk,bk->b", c, c)[:, None, None] * np.eye(3)
                                 - np.einsum("bi,bj->bij", c, c))
    out = np.column_stack([m, m[:, None] * c, I[:, 0, 0], I[:, 0, 1], I[:, 1, 1], I[:, 0, 2], I[:, 1, 2],
                           I[:, 2, 2]]) if model.njoints else np.zeros((0, NP))
    return out.reshape(-1)


def model_with_parameters(model, pi, *, tol=1e-12):
    """A new Model (dataclasses.replace) whose bodies carry the dynamic parameters π (10 nb,): mass m,
    CoM c = h / m, inertia about the CoM I_C = I − m (c·c 1 − c cᵀ) (the inverse of ``dynamic_parameters``).

    Refused (InputError naming the body): m < 0; m = 0 with a first moment h ≠ 0 (a massless body has no
    CoM); I_C not positive semi-definite beyond round-off (smallest eigenvalue < −tol · trace − 1e-18, as the
    URDF loader checks). A body with m = 0 and h = 0 keeps c = 0 and I_C = I.
    """
    check_model(model)
    nb = model.njoints
    p = as_real("pi", pi)
    if p.shape != (NP * nb,):
        raise InputError(f"pi has shape {p.shape}; expected ({NP * nb},): 10 dynamic parameters for each of "
                         f"the {nb} bodies of model {model.name!r}")
    check_finite("pi", p)
    P = p.reshape(nb, NP)
    mass, com, inertia = np.empty(nb), np.zeros((nb, 3)), np.empty((nb, 3, 3))
    for i, (m, hx, hy, hz, xx, xy, yy, xz, yz, zz) in enumerate(P):
        h, I = np.array([hx, hy, hz]), np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        where = f"pi[{NP * i}:{NP * i + NP}] (body {model.body_names[i]!r}, joint {model.joint_names[i]!r})"
        if m < 0:
            raise InputError(f"{where}: mass {m} < 0 is not physical")
        if m == 0 and np.any(h != 0):
            raise InputError(f"{where}: mass 0 with a first moment m·c = {h.tolist()}: not physical")
        c = h / m if m > 0 else np.zeros(3)
        Ic = I - m * (c @ c * np.eye(3) - np.outer(c, c))
        lam = np.linalg.eigvalsh(Ic)
        if lam[0] < -tol * max(np.trace(Ic), 0.0) - 1e-18:
            raise InputError(f"{where}: inertia about the CoM is not positive semi-definite "
                             f"(eigenvalues {lam.tolist()})")
        mass[i], com[i], inertia[i] = m, c, Ic
    return dataclasses.replace(model, mass=mass, com=com, inertia=inertia)


# -- the kernel -----------------------------------------------------------------------------------------------

@njit(cache=True)
def regressor_one(I, F, q, v, a, Y):
    """Y (nv, 10 nb) of one state q (nq,), v, a (nv,): ``regressor_kernel`` with N = 1."""
    if not (sized(I, q, (v, a)) and Y.shape[0] == model_sizes(I)[1] and Y.shape[1] == 10 * I.shape[1]):
        return WRONG_SIZES
    return regressor_kernel(I, F, q[np.newaxis, :], v[np.newaxis, :], a[np.newaxis, :], Y[np.newaxis, :, :])


@njit(cache=True, fastmath=CONTRACT)
def regressor_kernel(I, F, Q, V, A, Y):
    """Y[s] = [(ⁱX_j S_j)ᵀ A_i]_{j, i} for every state s: the outward pass, then each body's block A_i
    projected onto its own and its ancestors' motion subspaces (module docstring).

    I, F: the model in z-aligned frames (``Model.kernel.lane_arrays``); Q (N, nq), V, A (N, nv); Y (N, nv, 10 nb)
    result. ω'_i, ω̇'_i, v̇'_i and the placements are the records of the RNEA's outward pass (``rnea.outward_one``,
    the one-lane driver's); A_i is built in the link's own axes, where its parameters are written (x = C_i x', ``turn``),
    and its wrenches turned back into the z-aligned axes of the records. Returns its status (dynamics/status.py): a
    non-finite input, or −2 − nb − k for a non-finite entry at flat index k of Y.
    """
    mdl = unpack(I, F)
    N, nb, nv = Q.shape[0], I.shape[1], V.shape[1]
    W, Sx = np.empty((NP, 6)), np.empty((nb, nv, 6))   # A_i's columns as wrenches [f; n]; S_j seen from i
    Rec, turned = steps_scratch(nb, Q.shape[1], nv), np.empty(nb, np.bool_)
    for i in range(nb):
        turned[i] = False
        for a in range(3):
            for b in range(3):
                turned[i] |= mdl.turn[i, a, b] != (1.0 if a == b else 0.0)
    for s in range(N):
        if not outward_one(mdl, Q[s], V[s], A[s], Rec):   # ω'_i, ω̇'_i, v̇'_i (v̇'_0 = −g): the RNEA's outward
            return bad_input(s)                           # pass, its records in Rec
        Y[s, :, :] = 0.0
        for i in range(nb):
            B, T = Rec[i * RECORD:(i + 1) * RECORD], mdl.turn[i]
            if turned[i]:
                C = ((T[0, 0], T[0, 1], T[0, 2]), (T[1, 0], T[1, 1], T[1, 2]), (T[2, 0], T[2, 1], T[2, 2]))
                body_block(mul3(C, get3(B, 12, 0, 1)), mul3(C, get3(B, 15, 0, 1)), mul3(C, get3(B, 18, 0, 1)), W)
                for k in range(NP):                        # [f; n] from the link's axes into the record's (f = 0
                    if k < 4:                              # for the inertias, n = 0 for the mass)
                        f = mul3t(C, (W[k, 0], W[k, 1], W[k, 2]))
                        W[k, 0], W[k, 1], W[k, 2] = f[0], f[1], f[2]
                    if k > 0:
                        n = mul3t(C, (W[k, 3], W[k, 4], W[k, 5]))
                        W[k, 3], W[k, 4], W[k, 5] = n[0], n[1], n[2]
            else:                                          # (a body whose frame is its link's: no turn)
                body_block(get3(B, 12, 0, 1), get3(B, 15, 0, 1), get3(B, 18, 0, 1), W)
            to_ancestors(mdl, Rec, i, W, Sx, Y[s])
        k = first_nonfinite_entry(Y[s])                   # finite result (else an intermediate overflowed)
        if k >= 0:
            return bad_result(nb, s * nv * NP * nb + k)
    return -1


@njit(cache=True, inline="always")
def body_block(w, dw, dv, W):
    """W (10, 6): column k of A_i as a wrench [f; n] about body i's origin, in its axes — the inertial
    wrench of a unit parameter k (module docstring; Atkeson et al. 1986, Eq. 9); w, dw, dv: ω'_i, ω̇'_i, v̇'_i
    (v̇' with −g) in the same axes."""
    wx, wy, wz = w
    ax, ay, az = dw
    gx, gy, gz = dv                                        # v̇'_i, with −g
    W[:, :] = 0.0
    W[0, 0], W[0, 1], W[0, 2] = gx, gy, gz                 # m: f = m v̇'
    for k in range(3):                                     # h = m c along e_k: f = ω̇ × e_k + ω × (ω × e_k)
        e0, e1, e2 = (1.0 if k == 0 else 0.0), (1.0 if k == 1 else 0.0), (1.0 if k == 2 else 0.0)
        u0, u1, u2 = wy * e2 - wz * e1, wz * e0 - wx * e2, wx * e1 - wy * e0          # ω × e_k
        W[1 + k, 0] = ay * e2 - az * e1 + wy * u2 - wz * u1
        W[1 + k, 1] = az * e0 - ax * e2 + wz * u0 - wx * u2
        W[1 + k, 2] = ax * e1 - ay * e0 + wx * u1 - wy * u0
        W[1 + k, 3] = e1 * gz - e2 * gy                    # n = e_k × v̇'
        W[1 + k, 4] = e2 * gx - e0 * gz
        W[1 + k, 5] = e0 * gy - e1 * gx
    # I about the origin: n = I ω̇ + ω × I ω, with I ω = L(ω) (I_xx, I_xy, I_yy, I_xz, I_yz, I_zz)
    inertia_column(W, 4, (ax, 0.0, 0.0), (wx, 0.0, 0.0), (wx, wy, wz))      # I_xx
    inertia_column(W, 5, (ay, ax, 0.0), (wy, wx, 0.0), (wx, wy, wz))        # I_xy
    inertia_column(W, 6, (0.0, ay, 0.0), (0.0, wy, 0.0), (wx, wy, wz))      # I_yy
    inertia_column(W, 7, (az, 0.0, ax), (wz, 0.0, wx), (wx, wy, wz))        # I_xz
    inertia_column(W, 8, (0.0, az, ay), (0.0, wz, wy), (wx, wy, wz))        # I_yz
    inertia_column(W, 9, (0.0, 0.0, az), (0.0, 0.0, wz), (wx, wy, wz))      # I_zz


@njit(cache=True, inline="always")
def inertia_column(W, k, Ia, Iw, w):
    """W[k] = [0; I_k ω̇ + ω × I_k ω] for the unit inertia I_k, given I_k ω̇ (Ia) and I_k ω (Iw)."""
    W[k, 3] = Ia[0] + w[1] * Iw[2] - w[2] * Iw[1]
    W[k, 4] = Ia[1] + w[2] * Iw[0] - w[0] * Iw[2]
    W[k, 5] = Ia[2] + w[0] * Iw[1] - w[1] * Iw[0]


@njit(cache=True, inline="always")
def to_ancestors(mdl, Rec, i, W, Sx, Y):
    """Y[r, columns of i] = (ⁱX_j S_j)ᵀ A_i = S_jᵀ ʲX*_i A_i for every velocity r of joint i and of each
    ancestor j: the ancestors' motion subspaces carried out to body i, Sx[i, r] = ⁱX_λ Sx[λ, r] (RBDA
    Table 2.2, ``spatial.motion_down`` with body i's placement from its record), rather than ten wrenches carried
    in."""
    parent, iv, nvj, S = mdl.parent, mdl.iv, mdl.nvj, mdl.S
    B = Rec[i * RECORD:(i + 1) * RECORD]
    R, p = get_rotation(B, 0, 1), get3(B, 9, 0, 1)
    lam = parent[i]
    for r in range(iv[i], iv[i] + nvj[i]):                # joint i's own S, in its body frame
        Sx[i, r, :] = S[r]
        project(Sx[i, r], W, Y, r, NP * i)
    j = lam
    while j >= 0:
        for r in range(iv[j], iv[j] + nvj[j]):
            l, w = motion_down(R, p, (Sx[lam, r, 0], Sx[lam, r, 1], Sx[lam, r, 2]),
                               (Sx[lam, r, 3], Sx[lam, r, 4], Sx[lam, r, 5]))
            Sx[i, r, 0], Sx[i, r, 1], Sx[i, r, 2], Sx[i, r, 3], Sx[i, r, 4], Sx[i, r, 5] = l[0], l[1], l[2], w[0], w[1], w[2]
            project(Sx[i, r], W, Y, r, NP * i)
        j = parent[j]


@njit(cache=True, inline="always")
def project(s, W, Y, r, c0):
    """Y[r, c0 + k] = sᵀ W[k], k < 10: the power of the wrench W[k] along the motion s (Eqs. 17–18)."""
    for k in range(NP):
        Y[r, c0 + k] = (s[0] * W[k, 0] + s[1] * W[k, 1] + s[2] * W[k, 2]
                        + s[3] * W[k, 3] + s[4] * W[k, 4] + s[5] * W[k, 5])


# -- the public call: its route (dynamics/route.py) -------------------------------------------------------------

@route("joint_torque_regressor", _QVA, "Y", "regressor", entry(regressor_one, *MODEL, A1, A1, A1, A2),
       entry(regressor_kernel, *MODEL, A2, A2, A2, A3), lanes=True, one_lanes=True)
def joint_torque_regressor(model, q, v, a, *, threads=None, out=None):
    """Y (nv, 10 nb) with τ = Y π = rnea(q, q̇, q̈) (gravity included), π = dynamic_parameters(model).

    Parameters
    ----------
    q : (nq,) or (N, nq) configuration; v, a : (nv,) or (N, nv) rates and accelerations.
    threads, out : ``rnea``'s (out: (nv, 10 nb) or (N, nv, 10 nb)).
    Returns
    -------
    Y : (nv, 10 nb) or (N, nv, 10 nb); columns 10 i … 10 i + 9 belong to body i (PARAMETER_NAMES order).
    References
    ----------
    Atkeson, An & Hollerbach (1986), Eq. 9; Pinocchio's computeJointTorqueRegressor (same layout).
    """
