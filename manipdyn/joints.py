"""The joint model: every joint type manipdyn knows, described once.

A joint connects body i to its parent λ(i). Its placement at q = 0 is (R0, p0) (joint frame = body i's
frame, in λ(i)'s frame); its motion X_J(q) = (R_J, p_J) is applied in that frame, so body i sits in its
parent at

    R = R0 R_J(q),   p = p0 + R0 p_J(q)                                                   (joint_placement)

Its velocity is v_J = S q̇ with the motion subspace S (6 × nv_j, rows [linear; angular] as in Pinocchio),
constant in body i's frame for every type here; so its acceleration is S q̈ (no Ṡ term).

| type        | nq | nv | q                              | X_J(q)                       | S (columns)       |
|-------------|----|----|--------------------------------|------------------------------|-------------------|
| revolute    | 1  | 1  | angle θ (continuous: unbounded)| (Rot(z, θ), 0)               | [0; z]            |
| prismatic   | 1  | 1  | displacement d                 | (1, d z)                     | [z; 0]            |
| free_flyer  | 7  | 6  | [x y z, quaternion qx qy qz qw]| (R(quat), [x y z])           | 1₆ (body frame)   |
| ball        | 4  | 3  | quaternion qx qy qz qw         | (R(quat), 0)                 | [0; 1₃]           |

z is the joint's unit axis in body i's frame. A free flyer's v = [linear; angular] velocity of the body
in its own frame (Pinocchio's convention), so q moves by ``integrate`` (q ⊕ v = M(q) exp6(v)), never by
q + v dt. A ball (spherical) joint is the free flyer's rotation alone (Pinocchio's ``JointModelSpherical``,
MuJoCo's ``ball``): v = ω, the body's angular velocity relative to its parent, in the body's own frame, and q moves
by quat ⊗ exp(ω). A continuous joint is one angle (Pinocchio stores cos/sin; ``validation`` converts); its
``difference`` is the shortest angle, as Pinocchio's. Fixed joints are not joints here: the loader merges
the bodies they hold together. A free flyer hangs from the fixed base (a free body: the floating-base root, or
an MJCF object beside the robot); a ball joint anywhere.

Everything below that a compiled kernel calls is written for numba (``_jit.njit``): scalar loops over
3-vectors, no allocation per call.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._jit import njit
from .spatial import cross3


class JointKind(NamedTuple):
    """One kind of joint, described once (the registry ``KINDS``, indexed by the kind's code)."""
    code: int              # the integer tag the model's ``kind`` array holds
    name: str              # manipdyn's name (Model.describe, errors)
    nq: int                # configuration entries
    nv: int                # velocity entries
    quat_at: int           # where the unit quaternion (qx qy qz qw) starts in the joint's q block (-1: none)
    omega_at: int          # where the body-frame angular velocity starts in its v block (-1: none)
    coords: tuple          # names of its q entries (a 1-dof joint's one entry is named by the joint: ())
    rates: tuple           # names of its v entries
    urdf: tuple            # URDF type names the loader reads as this kind
    mjcf: str              # MJCF joint type ("" where MJCF has none)
    pinocchio: str         # Pinocchio's joint model of the same motion


REVOLUTE, PRISMATIC, FREEFLYER, BALL = 0, 1, 2, 3
KINDS = (
    JointKind(REVOLUTE, "revolute", 1, 1, -1, -1, (), (), ("revolute", "continuous"), "hinge",
              "JointModelRevoluteUnaligned"),
    JointKind(PRISMATIC, "prismatic", 1, 1, -1, -1, (), (), ("prismatic",), "slide", "JointModelPrismaticUnaligned"),
    JointKind(FREEFLYER, "free_flyer", 7, 6, 3, 3, ("x", "y", "z", "qx", "qy", "qz", "qw"),
              ("vx", "vy", "vz", "wx", "wy", "wz"), (), "free", "JointModelFreeFlyer"),   # (URDF's "floating" type:
    #                                                  still refused by the loader; root_joint="free_flyer" makes one)
    JointKind(BALL, "ball", 4, 3, 0, 0, ("qx", "qy", "qz", "qw"), ("wx", "wy", "wz"), ("spherical",), "ball",
              "JointModelSpherical"),
)
TYPE_NAMES = tuple(k.name for k in KINDS)
NQ = tuple(k.nq for k in KINDS)             # configuration size per kind
NV = tuple(k.nv for k in KINDS)             # velocity size per kind
QUAT_AT = tuple(k.quat_at for k in KINDS)
OMEGA_AT = tuple(k.omega_at for k in KINDS)
COORDS = tuple(k.coords for k in KINDS)
RATES = tuple(k.rates for k in KINDS)


def kind_of(code) -> JointKind:
    """The registry's entry for a kind's code; ValueError for a code it does not hold (never a fall-through)."""
    c = int(code)
    if not 0 <= c < len(KINDS):
        raise ValueError(f"unknown joint kind {code!r}: the registry holds {', '.join(TYPE_NAMES)} (manipdyn.joints)")
    return KINDS[c]


def motion_subspace(kind: int, axis) -> np.ndarray:
    """S (nv_j, 6): one row per joint velocity, [linear; angular] in the body's frame."""
    kind = kind_of(kind).code
    if kind == REVOLUTE:
        return np.concatenate([np.zeros(3), axis])[None]
    if kind == PRISMATIC:
        return np.concatenate([axis, np.zeros(3)])[None]
    if kind == BALL:
        return np.eye(6)[3:]
    if kind == FREEFLYER:
        return np.eye(6)
    raise AssertionError(kind)             # every code of KINDS has its branch above


@njit(cache=True, inline="always")
def multi_dof(kind):
    """True for the kinds whose S selects the last nv_j entries of [linear; angular] (a free flyer's 1₆, a ball's
    [0; 1₃]) and whose rotation is a quaternion: what the lane steps take beside the screw joints (core.on_lanes)."""
    return kind == FREEFLYER or kind == BALL


@njit(cache=True, inline="always")
def quat_layout(kind):
    """(k, lin): the quaternion's offset in the joint's q block and 1.0 if the joint also translates by its first three
    entries (a free flyer), 0.0 if not (a ball). A kind without a quaternion raises (the lanes take only these two)."""
    if kind == FREEFLYER:
        return 3, 1.0
    if kind == BALL:
        return 0, 0.0
    raise ValueError("quat_layout: not a free flyer or a ball joint (manipdyn.joints.KINDS)")


# -- the joint's motion X_J(q), compiled --------------------------------------------------------------

@njit(cache=True, inline="always")
def quat_rotation(x, y, z, w):
    """The 9 entries (row by row) of the rotation of the unit quaternion (x, y, z, w) (scalar last, as
    Pinocchio/Eigen store it)."""
    return (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y))


@njit(cache=True, inline="always")
def quat_to_matrix(x, y, z, w, R):
    """R (3, 3) of the unit quaternion (x, y, z, w) (``quat_rotation`` into an array)."""
    R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2] = quat_rotation(x, y, z, w)


@njit(cache=True, inline="always")
def joint_placement(i, kind, iq, axis, R0, p0, q, R, p):
    """R[i] = R0_i R_J(q), p[i] = p0_i + R0_i p_J(q): body i in its parent (Eqs. 8–12 for prismatic joints: p
    evaluated at the current d), from the model's per-joint arrays (kind, iq: q's first entry of the joint,
    axis, R0, p0; core.unpack) and the whole configuration q."""
    # Indexed, not handed rows: a row view per body costs a reference-count pair (17 ns per body of forward
    # kinematics, measured). Every array is read before the branches, which then hold scalars only: an array
    # whose last use lies inside a branch makes numba keep an atomic reference-count pair per call.
    kind, iq = kind[i], iq[i]
    last = q.shape[0] - 1
    q0, q1, q2 = q[iq], q[min(iq + 1, last)], q[min(iq + 2, last)]          # q1..q6: a free flyer's, ball's
    q3, q4, q5, q6 = q[min(iq + 3, last)], q[min(iq + 4, last)], q[min(iq + 5, last)], q[min(iq + 6, last)]
    x, y, z = axis[i, 0], axis[i, 1], axis[i, 2]
    if kind == REVOLUTE:                       # Rodrigues, written out: R_J = Rot(z, θ), p_J = 0
        s, c = np.sin(q0), np.cos(q0)
        t = 1.0 - c
        r00, r01, r02 = c + t * x * x, t * x * y - s * z, t * x * z + s * y
        r10, r11, r12 = t * x * y + s * z, c + t * y * y, t * y * z - s * x
        r20, r21, r22 = t * x * z - s * y, t * y * z + s * x, c + t * z * z
        px = py = pz = 0.0
    elif kind == PRISMATIC:                    # R_J = 1, p_J = d z
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        px, py, pz = q0 * x, q0 * y, q0 * z
    elif kind == BALL:                         # ball: R_J = R(quat), p_J = 0
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = quat_rotation(q0, q1, q2, q3)
        px = py = pz = 0.0
    elif kind == FREEFLYER:                    # free flyer: R_J = R(quat), p_J = [x y z]
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = quat_rotation(q3, q4, q5, q6)
        px, py, pz = q0, q1, q2
    else:                                      # a code outside the registry: never placed as another kind
        raise ValueError("joint_placement: unknown joint kind (manipdyn.joints.KINDS)")
    for a in range(3):
        b0, b1, b2 = R0[i, a, 0], R0[i, a, 1], R0[i, a, 2]
        R[i, a, 0] = b0 * r00 + b1 * r10 + b2 * r20
        R[i, a, 1] = b0 * r01 + b1 * r11 + b2 * r21
        R[i, a, 2] = b0 * r02 + b1 * r12 + b2 * r22
        p[i, a] = p0[i, a] + b0 * px + b1 * py + b2 * pz


@njit(cache=True, inline="always")
def joint_velocity(S, iv, nvj, x):
    """(l, a): the linear and angular parts (3-tuples) of S x[iv:iv+nvj] (x = q̇ or q̈ of the whole model), as
    scalars — no scratch arrays, no branch."""
    l0 = l1 = l2 = a0 = a1 = a2 = 0.0
    for r in range(iv, iv + nvj):
        xr = x[r]
        l0 += S[r, 0] * xr
        l1 += S[r, 1] * xr
        l2 += S[r, 2] * xr
        a0 += S[r, 3] * xr
        a1 += S[r, 4] * xr
        a2 += S[r, 5] * xr
    return (l0, l1, l2), (a0, a1, a2)


@njit(cache=True, inline="always")
def joint_force(S, iv, nvj, f, n, out):
    """out[iv:iv+nvj] = Sᵀ [f; n]: the joint's generalized force from the wrench (force f, moment n about
    the body origin, body frame) transmitted across it (Eqs. 17, 18)."""
    for r in range(iv, iv + nvj):
        out[r] = (S[r, 0] * f[0] + S[r, 1] * f[1] + S[r, 2] * f[2]
                  + S[r, 3] * n[0] + S[r, 4] * n[1] + S[r, 5] * n[2])


# -- the configuration space: integrate, difference, compiled -----------------------------------------

@njit(cache=True, inline="always")
def _exp_quat(wx, wy, wz):
    """The unit quaternion (x, y, z, w) of the rotation vector ω = θ u: (sin(θ/2) u, cos(θ/2))."""
    t2 = wx * wx + wy * wy + wz * wz
    th = np.sqrt(t2)
    if th < 1e-4:                              # Taylor: sin(θ/2)/θ = ½ − θ²/48 + θ⁴/3840
        k = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0
        c = 1.0 - t2 / 8.0 + t2 * t2 / 384.0
    else:
        k = np.sin(0.5 * th) / th
        c = np.cos(0.5 * th)
    return k * wx, k * wy, k * wz, c


@njit(cache=True, inline="always")
def _V_coeffs(th2):
    """(a, b) of V(ω) = 1 + a [ω]× + b [ω]×², the left Jacobian of SO(3): a = (1 − cos θ)/θ²,
    b = (θ − sin θ)/θ³ (exp6's translation part is V v)."""
    if th2 < 1e-6:
        return 0.5 - th2 / 24.0 + th2 * th2 / 720.0, 1.0 / 6.0 - th2 / 120.0 + th2 * th2 / 5040.0
    th = np.sqrt(th2)
    s = np.sin(0.5 * th)                       # 1 − cos θ = 2 sin²(θ/2): no cancellation at small θ
    return 2.0 * s * s / th2, (th - np.sin(th)) / (th2 * th)


@njit(cache=True, inline="always")
def _Vinv_coeff(th2):
    """c of V(ω)⁻¹ = 1 − ½ [ω]× + c [ω]×², c = (1 − θ sin θ / (2 (1 − cos θ))) / θ² = (1 − (θ/2) cot(θ/2)) / θ²
    (the second form: 1 − cos θ, computed as written, loses all digits of c below θ ≈ 1e-3)."""
    if th2 < 1e-6:
        return 1.0 / 12.0 + th2 / 720.0 + th2 * th2 / 30240.0
    th = np.sqrt(th2)
    return (1.0 - 0.5 * th / np.tan(0.5 * th)) / th2


@njit(cache=True, inline="always")
def _turn_quat(Q, s, a, wx, wy, wz, out):
    """out[s, a:a+4] = Q[s, a:a+4] ⊗ exp(ω): the unit quaternion turned by the body-frame rotation vector ω,
    of the sign nearest the start (as Pinocchio's free flyer; its ball joint keeps the product's sign: the same
    rotation), normalised."""
    x0, y0, z0, w0 = Q[s, a], Q[s, a + 1], Q[s, a + 2], Q[s, a + 3]
    ex, ey, ez, ew = _exp_quat(wx, wy, wz)
    x = w0 * ex + x0 * ew + y0 * ez - z0 * ey
    y = w0 * ey - x0 * ez + y0 * ew + z0 * ex
    z = w0 * ez + x0 * ey - y0 * ex + z0 * ew
    ww = w0 * ew - x0 * ex - y0 * ey - z0 * ez
    nrm = np.sqrt(x * x + y * y + z * z + ww * ww)
    if x * x0 + y * y0 + z * z0 + ww * w0 < 0.0:
        nrm = -nrm
    out[s, a], out[s, a + 1], out[s, a + 2], out[s, a + 3] = x / nrm, y / nrm, z / nrm, ww / nrm


@njit(cache=True, inline="always")
def _log_quat(Q0, Q1, s, a):
    """ω = log(quat0⁻¹ ⊗ quat1) (3-tuple), the body-frame rotation vector from Q0[s, a:a+4] to Q1[s, a:a+4],
    of angle ≤ π."""
    x0, y0, z0, w0 = Q0[s, a], Q0[s, a + 1], Q0[s, a + 2], Q0[s, a + 3]
    x1, y1, z1, w1 = Q1[s, a], Q1[s, a + 1], Q1[s, a + 2], Q1[s, a + 3]
    n0 = x0 * x0 + y0 * y0 + z0 * z0 + w0 * w0      # quat0⁻¹ = conj / |quat0|²
    rx = (w0 * x1 - x0 * w1 - y0 * z1 + z0 * y1) / n0
    ry = (w0 * y1 + x0 * z1 - y0 * w1 - z0 * x1) / n0
    rz = (w0 * z1 - x0 * y1 + y0 * x1 - z0 * w1) / n0
    rw = (w0 * w1 + x0 * x1 + y0 * y1 + z0 * z1) / n0
    if rw < 0.0:                               # the shorter of the two rotations (θ ≤ π)
        rx, ry, rz, rw = -rx, -ry, -rz, -rw
    sn = np.sqrt(rx * rx + ry * ry + rz * rz)
    th = 2.0 * np.arctan2(sn, rw)              # log3: ω = θ u
    k = th / sn if sn > 1e-300 else 2.0 / rw
    return k * rx, k * ry, k * rz


@njit(cache=True)
def integrate_kernel(kind, iq, iv, Q, V, out):
    """out = Q ⊕ V for every row (N, nq) ⊕ (N, nv): 1-dof joints q + v; a ball joint quat ⊗ exp(ω); a free flyer
    M(q) exp6(v) with v = [linear; angular] in the body frame (Pinocchio's integrate)."""
    t1, t2, w = np.empty(3), np.empty(3), np.empty(3)
    R = np.empty((3, 3))
    for s in range(Q.shape[0]):
        for j in range(kind.shape[0]):
            a, b = iq[j], iv[j]
            if kind[j] == BALL:
                _turn_quat(Q, s, a, V[s, b], V[s, b + 1], V[s, b + 2], out)
                continue
            if kind[j] == REVOLUTE or kind[j] == PRISMATIC:
                out[s, a] = Q[s, a] + V[s, b]
                continue
            if kind[j] != FREEFLYER:               # a code outside the registry
                raise ValueError("integrate: unknown joint kind (manipdyn.joints.KINDS)")
            w[0], w[1], w[2] = V[s, b + 3], V[s, b + 4], V[s, b + 5]
            th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
            ca, cb = _V_coeffs(th2)            # exp6 translation: V(ω) v
            cross3(w, V[s, b:b + 3], t1)
            cross3(w, t1, t2)
            x0, y0, z0, w0 = Q[s, a + 3], Q[s, a + 4], Q[s, a + 5], Q[s, a + 6]
            quat_to_matrix(x0, y0, z0, w0, R)
            for k in range(3):
                t1[k] = V[s, b + k] + ca * t1[k] + cb * t2[k]
            for k in range(3):                 # p ← p + R V(ω) v
                out[s, a + k] = Q[s, a + k] + R[k, 0] * t1[0] + R[k, 1] * t1[1] + R[k, 2] * t1[2]
            _turn_quat(Q, s, a + 3, w[0], w[1], w[2], out)   # quat ← quat ⊗ exp(ω)


@njit(cache=True)
def difference_kernel(kind, continuous, iq, iv, Q0, Q1, out):
    """out (N, nv) = Q1 ⊖ Q0, the velocity that integrate turns Q0 into Q1 in unit time: q1 − q0
    (continuous joints: the shortest angle); ball log(quat0⁻¹ quat1); free flyer log6(M(q0)⁻¹ M(q1))."""
    R = np.empty((3, 3))
    d, w, t1, t2 = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for s in range(Q0.shape[0]):
        for j in range(kind.shape[0]):
            a, b = iq[j], iv[j]
            if kind[j] == BALL:
                out[s, b], out[s, b + 1], out[s, b + 2] = _log_quat(Q0, Q1, s, a)
                continue
            if kind[j] == REVOLUTE or kind[j] == PRISMATIC:
                x = Q1[s, a] - Q0[s, a]
                if continuous[j]:              # wrapped into [−π, π]
                    x = np.arctan2(np.sin(x), np.cos(x))
                out[s, b] = x
                continue
            if kind[j] != FREEFLYER:               # a code outside the registry
                raise ValueError("difference: unknown joint kind (manipdyn.joints.KINDS)")
            w[0], w[1], w[2] = _log_quat(Q0, Q1, s, a + 3)
            x0, y0, z0, w0 = Q0[s, a + 3], Q0[s, a + 4], Q0[s, a + 5], Q0[s, a + 6]
            n0 = x0 * x0 + y0 * y0 + z0 * z0 + w0 * w0
            quat_to_matrix(x0 / np.sqrt(n0), y0 / np.sqrt(n0), z0 / np.sqrt(n0), w0 / np.sqrt(n0), R)
            for c in range(3):                 # d = R0ᵀ (p1 − p0)
                d[c] = (R[0, c] * (Q1[s, a] - Q0[s, a]) + R[1, c] * (Q1[s, a + 1] - Q0[s, a + 1])
                        + R[2, c] * (Q1[s, a + 2] - Q0[s, a + 2]))
            cc = _Vinv_coeff(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
            cross3(w, d, t1)
            cross3(w, t1, t2)
            for c in range(3):                 # log6: linear part V(ω)⁻¹ d
                out[s, b + c] = d[c] - 0.5 * t1[c] + cc * t2[c]
                out[s, b + 3 + c] = w[c]
