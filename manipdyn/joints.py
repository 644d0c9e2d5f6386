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
| helical     | 1  | 1  | angle θ                        | (Rot(z, θ), h θ z)           | [h z; z]          |
| planar      | 4  | 3  | [x y, cos θ, sin θ]            | (Rot(z, θ), x e₁ + y e₂)     | [e₁;0] [e₂;0] [0;z] |
| universal   | 2  | 2  | angles θ₁ θ₂                   | Rot(z₁, θ₁) Rot(z₂, θ₂)      | (two revolutes)   |

z is the joint's unit axis in body i's frame. A free flyer's v = [linear; angular] velocity of the body
in its own frame (Pinocchio's convention), so q moves by ``integrate`` (q ⊕ v = M(q) exp6(v)), never by
q + v dt. A ball (spherical) joint is the free flyer's rotation alone (Pinocchio's ``JointModelSpherical``,
MuJoCo's ``ball``): v = ω, the body's angular velocity relative to its parent, in the body's own frame, and q moves
by quat ⊗ exp(ω). A continuous joint is one angle (Pinocchio stores cos/sin; ``validation`` converts); its
``difference`` is the shortest angle, as Pinocchio's. Fixed joints are not joints here: the loader merges
the bodies they hold together. A free flyer hangs from the fixed base (a free body: the floating-base root, or
an MJCF object beside the robot); a ball joint anywhere.

A helical (screw) joint turns by θ about z and slides h θ along it (h, the pitch: metres per radian, Pinocchio's
``JointModelHelicalUnaligned``; Drake's ``screw_thread_pitch`` is 2π h, metres per turn). A planar joint moves in
the plane normal to z (URDF's ``planar``, Pinocchio's ``JointModelPlanar`` for z = e_z): q = [x y cos θ sin θ] as
Pinocchio stores it, v = [v_x v_y ω] in the body frame (the SE(2) twist: q moves by ``integrate``, the SE(2)
exponential), e₁ e₂ the plane's axes (``plane_axes``: e₁ = x, e₂ = y for z = e_z). A universal joint (two axes
meeting at a point, Pinocchio's ``JointModelUniversal``) is loaded as what it is: a revolute joint about z₁
carrying a massless body, then a revolute joint about z₂ in that body (how MuJoCo chains the joints of one body);
the loaders expand it (``universal_pair``), so no kernel sees its code. Every constant S above has no Ṡ term.
Everything below that a compiled kernel calls is written for numba (``_jit.njit``): scalar loops over
3-vectors, no allocation per call.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._jit import njit
from .spatial import cross


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


REVOLUTE, PRISMATIC, FREEFLYER, BALL, HELICAL, PLANAR, UNIVERSAL = 0, 1, 2, 3, 4, 5, 6
KINDS = (
    JointKind(REVOLUTE, "revolute", 1, 1, -1, -1, (), (), ("revolute", "continuous"), "hinge",
              "JointModelRevoluteUnaligned"),
    JointKind(PRISMATIC, "prismatic", 1, 1, -1, -1, (), (), ("prismatic",), "slide", "JointModelPrismaticUnaligned"),
    JointKind(FREEFLYER, "free_flyer", 7, 6, 3, 3, ("x", "y", "z", "qx", "qy", "qz", "qw"),
              ("vx", "vy", "vz", "wx", "wy", "wz"), ("floating",), "free", "JointModelFreeFlyer"),
    JointKind(BALL, "ball", 4, 3, 0, 0, ("qx", "qy", "qz", "qw"), ("wx", "wy", "wz"), ("spherical",), "ball",
              "JointModelSpherical"),
    JointKind(HELICAL, "helical", 1, 1, -1, -1, (), (), ("screw",), "", "JointModelHelicalUnaligned"),
    JointKind(PLANAR, "planar", 4, 3, -1, -1, ("x", "y", "c", "s"), ("vx", "vy", "wz"), ("planar",), "",
              "JointModelPlanar"),
    JointKind(UNIVERSAL, "universal", 2, 2, -1, -1, (), (), ("universal",), "", "JointModelUniversal"),
)
# Kinds a Model holds (a universal joint is expanded by the loaders into two revolute joints: ``universal_pair``)
IN_MODEL = (REVOLUTE, PRISMATIC, FREEFLYER, BALL, HELICAL, PLANAR)
UNIT_AT = (-1, -1, 3, 0, -1, 2, -1)      # where a unit-norm block starts in q (a quaternion, planar's cos/sin)
UNIT_LEN = (0, 0, 4, 4, 0, 2, 0)         # its length
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


def motion_subspace(kind: int, axis, pitch=0.0) -> np.ndarray:
    """S (nv_j, 6): one row per joint velocity, [linear; angular] in the body's frame."""
    kind, axis = kind_of(kind).code, np.asarray(axis, float)
    if kind == REVOLUTE:
        return np.concatenate([np.zeros(3), axis])[None]
    if kind == PRISMATIC:
        return np.concatenate([axis, np.zeros(3)])[None]
    if kind == BALL:
        return np.eye(6)[3:]
    if kind == FREEFLYER:
        return np.eye(6)
    if kind == HELICAL:
        return np.concatenate([pitch * axis, axis])[None]
    if kind == PLANAR:
        e1, e2 = (np.array(e) for e in plane_axes(axis[0], axis[1], axis[2]))
        return np.array([[*e1, 0, 0, 0], [*e2, 0, 0, 0], [0, 0, 0, *axis]], float)
    raise ValueError(f"motion_subspace: a {KINDS[kind].name} joint is not in a Model (the loaders expand it)")


def neutral_q(kind: int) -> np.ndarray:
    """The joint's neutral q block (nq_j,): zeros, every unit block at the identity (a quaternion (0 0 0 1), a planar
    joint's (cos, sin) = (1, 0))."""
    k = kind_of(kind)
    q = np.zeros(k.nq)
    if UNIT_LEN[k.code]:
        q[UNIT_AT[k.code] + UNIT_LEN[k.code] - 1 if UNIT_LEN[k.code] == 4 else UNIT_AT[k.code]] = 1.0
    return q


def universal_pair(axis1, axis2):
    """A universal joint as the two revolute joints it is: ((REVOLUTE, axis1 in the joint frame), (REVOLUTE,
    axis2 in the frame turned by the first)); the first one's body is massless and sits where the second turns
    (X_J = Rot(axis1, θ₁) Rot(axis2, θ₂), Pinocchio's ``JointModelUniversal``)."""
    return (REVOLUTE, np.asarray(axis1, float)), (REVOLUTE, np.asarray(axis2, float))


@njit(cache=True, inline="always")
def plane_axes(nx, ny, nz):
    """(e₁, e₂): the axes of the plane normal to the unit vector n: e₁ = the x axis projected onto the plane (the y
    axis where n is within 45° of x), e₂ = n × e₁; (x, y) for n = z. A planar joint's x and y run along them."""
    if abs(nx) <= 0.7071067811865476:
        tx, ty, tz = 1.0 - nx * nx, -nx * ny, -nx * nz
    else:
        tx, ty, tz = -ny * nx, 1.0 - ny * ny, -ny * nz
    k = 1.0 / np.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = k * tx, k * ty, k * tz
    return (tx, ty, tz), (ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx)


@njit(cache=True, inline="always")
def multi_dof(kind):
    """True for the kinds whose S selects the last nv_j entries of [linear; angular] (a free flyer's 1₆, a ball's
    [0; 1₃]) and whose rotation is a quaternion: what the lane steps take beside the screw joints (lanes.on_lanes)."""
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
def rodrigues(x, y, z, s, c):
    """The 9 entries (row by row) of Rot(z, θ) about the unit axis (x, y, z), from s = sin θ, c = cos θ:
    c 1 + s [z]× + (1 − c) z zᵀ, written out."""
    t = 1.0 - c
    return (c + t * x * x, t * x * y - s * z, t * x * z + s * y,
            t * x * y + s * z, c + t * y * y, t * y * z - s * x,
            t * x * z - s * y, t * y * z + s * x, c + t * z * z)


@njit(cache=True, inline="always")
def joint_placement(i, kind, iq, axis, pitch, R0, p0, q, R, p):
    """R[i] = R0_i R_J(q), p[i] = p0_i + R0_i p_J(q): body i in its parent (Eqs. 8–12 for prismatic joints: p
    evaluated at the current d), from the model's per-joint arrays (kind, iq: q's first entry of the joint,
    axis, pitch (helical joints), R0, p0; model_arrays.unpack) and the whole configuration q."""
    # Indexed, not handed rows: a row view per body costs a reference-count pair (17 ns per body of forward
    # kinematics, measured). Every array is read before the branches, which then hold scalars only: an array
    # whose last use lies inside a branch makes numba keep an atomic reference-count pair per call.
    kind, iq = kind[i], iq[i]
    last = q.shape[0] - 1
    q0, q1, q2 = q[iq], q[min(iq + 1, last)], q[min(iq + 2, last)]          # q1..q6: a free flyer's, ball's
    q3, q4, q5, q6 = q[min(iq + 3, last)], q[min(iq + 4, last)], q[min(iq + 5, last)], q[min(iq + 6, last)]
    x, y, z, h = axis[i, 0], axis[i, 1], axis[i, 2], pitch[i]
    if kind == REVOLUTE or kind == HELICAL:    # R_J = Rot(z, θ), p_J = h θ z (a revolute joint's pitch h is 0)
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rodrigues(x, y, z, np.sin(q0), np.cos(q0))
        px, py, pz = h * q0 * x, h * q0 * y, h * q0 * z
    elif kind == PRISMATIC:                    # R_J = 1, p_J = d z
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        px, py, pz = q0 * x, q0 * y, q0 * z
    elif kind == BALL:                         # ball: R_J = R(quat), p_J = 0
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = quat_rotation(q0, q1, q2, q3)
        px = py = pz = 0.0
    elif kind == FREEFLYER:                    # free flyer: R_J = R(quat), p_J = [x y z]
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = quat_rotation(q3, q4, q5, q6)
        px, py, pz = q0, q1, q2
    elif kind == PLANAR:                       # planar: R_J = Rot(z, θ) from q's cos θ, sin θ; p_J = x e₁ + y e₂
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rodrigues(x, y, z, q3, q2)
        (e0, e1, e2), (f0, f1, f2) = plane_axes(x, y, z)
        px, py, pz = q0 * e0 + q1 * f0, q0 * e1 + q1 * f1, q0 * e2 + q1 * f2
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


@njit(cache=True, inline="always")
def _se2_coeffs(w):
    """(a, b) of SE(2)'s V(ω) = [[a, −b], [b, a]], a = sin ω / ω, b = (1 − cos ω) / ω (exp's translation V v)."""
    if abs(w) < 1e-4:                          # Taylor
        w2 = w * w
        return 1.0 - w2 / 6.0 + w2 * w2 / 120.0, w * (0.5 - w2 / 24.0)
    return np.sin(w) / w, (1.0 - np.cos(w)) / w


@njit(cache=True, inline="always")
def _turn_planar(Q, s, a, vx, vy, w, out):
    """out[s, a:a+4] = a planar joint's q ⊕ v: M(q) exp(v) in SE(2), v = (v_x, v_y, ω) in the body frame:
    p ← p + R(θ) V(ω) (v_x, v_y), (cos, sin) ← R(θ) (cos ω, sin ω), normalised."""
    x, y, c, sn = Q[s, a], Q[s, a + 1], Q[s, a + 2], Q[s, a + 3]
    ka, kb = _se2_coeffs(w)
    tx, ty = ka * vx - kb * vy, kb * vx + ka * vy
    cw, sw = np.cos(w), np.sin(w)
    c1, s1 = c * cw - sn * sw, sn * cw + c * sw
    nrm = np.sqrt(c1 * c1 + s1 * s1)
    out[s, a], out[s, a + 1] = x + c * tx - sn * ty, y + sn * tx + c * ty
    out[s, a + 2], out[s, a + 3] = c1 / nrm, s1 / nrm


@njit(cache=True, inline="always")
def _log_planar(Q0, Q1, s, a):
    """(v_x, v_y, ω): the SE(2) log of M(q0)⁻¹ M(q1) for a planar joint at Q0[s, a:a+4], Q1[s, a:a+4] (|ω| ≤ π):
    ω = the angle from θ₀ to θ₁, v = V(ω)⁻¹ R(θ₀)ᵀ (p₁ − p₀) with V(ω)⁻¹ = [[α, ω/2], [−ω/2, α]],
    α = (ω/2) cot(ω/2)."""
    c0, s0, c1, s1 = Q0[s, a + 2], Q0[s, a + 3], Q1[s, a + 2], Q1[s, a + 3]
    w = np.arctan2(c0 * s1 - s0 * c1, c0 * c1 + s0 * s1)
    dx, dy = Q1[s, a] - Q0[s, a], Q1[s, a + 1] - Q0[s, a + 1]
    px, py = c0 * dx + s0 * dy, -s0 * dx + c0 * dy
    al = 1.0 - w * w / 12.0 if abs(w) < 1e-4 else 0.5 * w / np.tan(0.5 * w)
    return al * px + 0.5 * w * py, -0.5 * w * px + al * py, w


@njit(cache=True)
def integrate_kernel(kind, iq, iv, Q, V, out):
    """out = Q ⊕ V for every row (N, nq) ⊕ (N, nv): 1-dof joints q + v; a ball joint quat ⊗ exp(ω); a free flyer
    M(q) exp6(v) with v = [linear; angular] in the body frame; a planar joint M(q) exp(v) in SE(2) (Pinocchio's
    integrate)."""
    for s in range(Q.shape[0]):                # (tuples, not scratch arrays: one state allocates nothing)
        for j in range(kind.shape[0]):
            a, b = iq[j], iv[j]
            if kind[j] == BALL:
                _turn_quat(Q, s, a, V[s, b], V[s, b + 1], V[s, b + 2], out)
                continue
            if kind[j] == REVOLUTE or kind[j] == PRISMATIC or kind[j] == HELICAL:
                out[s, a] = Q[s, a] + V[s, b]
                continue
            if kind[j] == PLANAR:
                _turn_planar(Q, s, a, V[s, b], V[s, b + 1], V[s, b + 2], out)
                continue
            if kind[j] != FREEFLYER:               # a code outside the registry
                raise ValueError("integrate: unknown joint kind (manipdyn.joints.KINDS)")
            w, vl = (V[s, b + 3], V[s, b + 4], V[s, b + 5]), (V[s, b], V[s, b + 1], V[s, b + 2])
            ca, cb = _V_coeffs(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])    # exp6 translation: V(ω) v
            t1 = cross(w, vl)
            t2 = cross(w, t1)
            u = (vl[0] + ca * t1[0] + cb * t2[0], vl[1] + ca * t1[1] + cb * t2[1], vl[2] + ca * t1[2] + cb * t2[2])
            R = quat_rotation(Q[s, a + 3], Q[s, a + 4], Q[s, a + 5], Q[s, a + 6])
            for k in range(3):                 # p ← p + R V(ω) v
                out[s, a + k] = Q[s, a + k] + R[3 * k] * u[0] + R[3 * k + 1] * u[1] + R[3 * k + 2] * u[2]
            _turn_quat(Q, s, a + 3, w[0], w[1], w[2], out)   # quat ← quat ⊗ exp(ω)


@njit(cache=True)
def difference_kernel(kind, continuous, iq, iv, Q0, Q1, out):
    """out (N, nv) = Q1 ⊖ Q0, the velocity that integrate turns Q0 into Q1 in unit time: q1 − q0
    (continuous joints: the shortest angle); ball log(quat0⁻¹ quat1); free flyer log6(M(q0)⁻¹ M(q1)); planar
    the SE(2) log of M(q0)⁻¹ M(q1)."""
    for s in range(Q0.shape[0]):
        for j in range(kind.shape[0]):
            a, b = iq[j], iv[j]
            if kind[j] == BALL:
                out[s, b], out[s, b + 1], out[s, b + 2] = _log_quat(Q0, Q1, s, a)
                continue
            if kind[j] == PLANAR:
                out[s, b], out[s, b + 1], out[s, b + 2] = _log_planar(Q0, Q1, s, a)
                continue
            if kind[j] == REVOLUTE or kind[j] == PRISMATIC or kind[j] == HELICAL:
                x = Q1[s, a] - Q0[s, a]
                if continuous[j]:              # wrapped into [−π, π]
                    x = np.arctan2(np.sin(x), np.cos(x))
                out[s, b] = x
                continue
            if kind[j] != FREEFLYER:               # a code outside the registry
                raise ValueError("difference: unknown joint kind (manipdyn.joints.KINDS)")
            w = _log_quat(Q0, Q1, s, a + 3)
            x0, y0, z0, w0 = Q0[s, a + 3], Q0[s, a + 4], Q0[s, a + 5], Q0[s, a + 6]
            n0 = x0 * x0 + y0 * y0 + z0 * z0 + w0 * w0
            R = quat_rotation(x0 / np.sqrt(n0), y0 / np.sqrt(n0), z0 / np.sqrt(n0), w0 / np.sqrt(n0))
            dp = (Q1[s, a] - Q0[s, a], Q1[s, a + 1] - Q0[s, a + 1], Q1[s, a + 2] - Q0[s, a + 2])
            d = (R[0] * dp[0] + R[3] * dp[1] + R[6] * dp[2], R[1] * dp[0] + R[4] * dp[1] + R[7] * dp[2],
                 R[2] * dp[0] + R[5] * dp[1] + R[8] * dp[2])          # d = R0ᵀ (p1 − p0)
            cc = _Vinv_coeff(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
            t1 = cross(w, d)
            t2 = cross(w, t1)
            for c in range(3):                 # log6: linear part V(ω)⁻¹ d
                out[s, b + c] = d[c] - 0.5 * t1[c] + cc * t2[c]
                out[s, b + 3 + c] = w[c]


# -- one state, checked in compiled code (the public calls' fast path: configuration.py) ---------------------------

QUAT_TOL = 1e-8      # | ‖quat‖ − 1 | accepted in a free flyer's or ball joint's q, and for a planar joint's
#                     (cos θ, sin θ) (integrate's output: ~1e-16); the checked path's (model.py) and the one-state
#                     kernels' below


@njit(cache=True, inline="always")
def config_views(C):
    """(kind, continuous, iq, iv, units) of the one-state configuration kernels' packed ints C = [nb, u, kind (nb),
    continuous (nb), idx_q (nb), idx_v (nb), units (u, 2) row by row] (``kernel_form.KernelForm.config_one``: one
    array for one argument, ~30 ns of dispatch each)."""
    nb, u = C[0], C[1]
    return (C[2:2 + nb], C[2 + nb:2 + 2 * nb], C[2 + 2 * nb:2 + 3 * nb], C[2 + 3 * nb:2 + 4 * nb],
            C[2 + 4 * nb:2 + 4 * nb + 2 * u])


@njit(cache=True, inline="always")
def state_ok(q, units, v):
    """True when every entry of q and v is finite (Σ|x| ≤ the largest float: NaN and ±inf fail) and every block of
    q of unit norm (units: [start, length] pairs, flat: a quaternion, a planar joint's (cos θ, sin θ)) has norm 1
    within QUAT_TOL."""
    total = 0.0
    for k in range(q.shape[0]):
        total += abs(q[k])
    for k in range(v.shape[0]):
        total += abs(v[k])
    if not total <= 1.7976931348623157e308:
        return False
    for u in range(0, units.shape[0], 2):
        n2 = 0.0
        for k in range(units[u], units[u] + units[u + 1]):
            n2 += q[k] * q[k]
        if not abs(np.sqrt(n2) - 1.0) <= QUAT_TOL:
            return False
    return True


@njit(cache=True, inline="always")
def config_sizes(kind, iq, iv):
    """(nq, nv) of a model from its joints' kinds and first entries of q and v (joints in q order: the last joint's
    first entries plus its sizes, NQ and NV)."""
    nb = kind.shape[0]
    if nb == 0:
        return 0, 0
    return iq[nb - 1] + NQ[kind[nb - 1]], iv[nb - 1] + NV[kind[nb - 1]]


@njit(cache=True)
def integrate_one(C, q, v, out):
    """One state: out (nq,) = q ⊕ v (``integrate_kernel``) if the arrays have the model's sizes (``config_sizes``:
    Python checks only their types and dimensions) and ``state_ok(q, units, v)`` (C: ``config_views``); whether it
    did (else the checked path names the fault)."""
    kind, _, iq, iv, units = config_views(C)
    nq, nv = config_sizes(kind, iq, iv)
    if not (q.shape[0] == nq and v.shape[0] == nv and out.shape[0] == nq and state_ok(q, units, v)):
        return False
    integrate_kernel(kind, iq, iv, q[np.newaxis, :], v[np.newaxis, :], out[np.newaxis, :])
    return True


@njit(cache=True)
def difference_one(C, q0, q1, out):
    """One state: out (nv,) = q1 ⊖ q0 (``difference_kernel``) if the arrays have the model's sizes and both pass
    ``state_ok``; whether it did."""
    kind, continuous, iq, iv, units = config_views(C)
    nq, nv = config_sizes(kind, iq, iv)
    if not (q0.shape[0] == nq and q1.shape[0] == nq and out.shape[0] == nv and state_ok(q0, units, q1)
            and state_ok(q1, units, q0[:0])):
        return False
    difference_kernel(kind, continuous, iq, iv, q0[np.newaxis, :], q1[np.newaxis, :], out[np.newaxis, :])
    return True


@njit(cache=True)
def normalize_one(C, q, out):
    """One state q (nq,) into out: ``normalize_kernel`` on row views if both have the model's size; −1 when it is
    done (else the checked path names the fault)."""
    kind, _, iq, iv, _ = config_views(C)
    nq = config_sizes(kind, iq, iv)[0]
    if not (q.shape[0] == nq and out.shape[0] == nq):
        return 0
    return normalize_kernel(C, q[np.newaxis, :], out[np.newaxis, :])


@njit(cache=True)
def normalize_kernel(C, Q, out):
    """out = Q with every block of unit norm (C: ``config_views``) divided by its norm, row by row; the first row
    with a block of norm 0 (no rotation) or a non-finite entry, or −1."""
    units = config_views(C)[4]
    for s in range(Q.shape[0]):
        total = 0.0
        for k in range(Q.shape[1]):
            out[s, k] = Q[s, k]
            total += abs(Q[s, k])
        if not total <= 1.7976931348623157e308:
            return s
        for u in range(0, units.shape[0], 2):
            a, b = units[u], units[u] + units[u + 1]
            n2 = 0.0
            for k in range(a, b):
                n2 += Q[s, k] * Q[s, k]
            if n2 == 0.0:
                return s
            n = np.sqrt(n2)
            for k in range(a, b):
                out[s, k] = Q[s, k] / n
    return -1
