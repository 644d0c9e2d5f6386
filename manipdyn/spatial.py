"""THE spatial algebra: every 3- and 6-vector, rotation, cross product, spatial-inertia and small dense
solve that a kernel uses is written here, once, and imported by every kernel (no algorithm module defines
algebra of its own). Two parts:

1. **The compiled toolkit** (numba, ``inline="always"``: each helper is compiled into its caller, so it costs
   nothing per call and rounds exactly as if written in place):
   - 3-vectors as 3-tuples (values, no allocation): ``vec``, ``put``, ``add``, ``sub``, ``scale``, ``cross``,
     ``rot``, ``rot_t``, and with a 3×3 matrix as a tuple of rows ``mul3``, ``mul3t``; into arrays: ``rot3``, ``rot3t``, ``cross3``, ``sandwich3``;
   - 6-vectors, order [linear; angular] (the order of the motion subspace S and of Pinocchio), in a body's
     own frame about its origin — motion m = [v_O; ω], force f = [f; n_O]: ``row6``, ``dot6``,
     ``motion_cross`` (v ×), ``force_cross`` (v ×*), their array forms ``cross_motion`` / ``cross_force``,
     the transforms ``motion_down`` (ⁱX_λ), ``force_up`` (^λX*_i),
     ``compose`` (a placement in a placed frame), ``world_motion``
     (⁰X_i), ``rotate6`` (R on both halves);
   - spatial inertias: ``rigid_inertia`` (RBDA Eq. 2.63), ``world_inertia``, ``inertia_up``, ``block3``, ``congruence3``,
     ``mat6``, ``rigid6``, ``inertia_variation``, ``add_force_cross``, and the (m, c, I_C) form of the CRBA:
     ``merge_shift``, ``inertia_motion``;
   - small dense solves: ``cholesky``, ``cholesky_solve``, ``spd_inverse``;
   - the one finiteness check: ``first_nonfinite`` (a vector) and ``first_nonfinite_entry`` (a matrix, row
     by row through it);
   - ``sincos``: sin and cos of one angle in straight-line code, which the compiler vectorises across the
     lanes of a block of states (the lane kernels: docs/design.md §4c), where libm's sin/cos stay scalar calls.
2. **numpy helpers for the loaders** (URDF rpy, parallel axis, inertia merging, rotations between vectors).

Conventions owned here: ``R`` maps coordinates of the child frame into the parent frame (x_parent =
R x_child + p), so ``rot_t(R, i, x)`` is the chapter's R^i_{i−1} x (parent coordinates into the child
frame); URDF ``rpy`` means R = Rz(yaw) Ry(pitch) Rx(roll), about fixed axes. Spatial vectors follow
Featherstone's RBDA (§2) with the blocks in Pinocchio's order [linear; angular].
"""
from __future__ import annotations

import numpy as np

from ._jit import njit


def skew(w: np.ndarray) -> np.ndarray:
    """[w]× such that [w]× x = w × x; w (..., 3) -> (..., 3, 3)."""
    S = np.zeros(w.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return S


def axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: R = I + sin(θ) [k]× + (1 − cos θ) [k]×²; unit axis (3,), angle (N,) -> (N, 3, 3)."""
    K = skew(np.asarray(axis, float))
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def rpy_matrix(rpy) -> np.ndarray:
    """URDF roll-pitch-yaw (3,) -> R = Rz(y) Ry(p) Rx(r), (3, 3)."""
    r, p, y = (float(x) for x in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def parallel_axis(mass: float, d: np.ndarray) -> np.ndarray:
    """Inertia of a point mass at offset d about the origin: m (|d|² 1 − d dᵀ), (3, 3).

    The diagonal is formed as sums of the other two squares (m (y² + z²), ...), never |d|² − x²: a
    large offset along one axis must not wipe out the small moment about that axis by cancellation.
    """
    x, y, z = (float(t) for t in d)
    return mass * np.array([[y * y + z * z, -x * y, -x * z],
                            [-x * y, x * x + z * z, -y * z],
                            [-x * z, -y * z, x * x + y * y]])


def combine_inertias(parts):
    """Merge rigid parts [(m, c (3,), I_c (3, 3))] given in one frame into (m, c, I about c).

    I about the common CoM = Σ I_k + m_k (|d_k|² 1 − d_k d_kᵀ), d_k = c_k − c (parallel-axis theorem).
    A massless union keeps its CoM at the origin.
    """
    m = sum(p[0] for p in parts)
    c = sum(p[0] * np.asarray(p[1]) for p in parts) / m if m > 0 else np.zeros(3)
    I = sum(np.asarray(Ik) + parallel_axis(mk, np.asarray(ck) - c) for mk, ck, Ik in parts)
    return m, c, 0.5 * (I + I.T)


def matrix_rpy(R) -> np.ndarray:
    """Inverse of rpy_matrix: (3, 3) -> URDF (roll, pitch, yaw); at pitch = ±π/2 roll is set to 0."""
    R = np.asarray(R, float)
    p = np.arcsin(np.clip(-R[2, 0], -1.0, 1.0))
    if abs(R[2, 0]) < 1.0 - 1e-12:
        return np.array([np.arctan2(R[2, 1], R[2, 2]), p, np.arctan2(R[1, 0], R[0, 0])])
    return np.array([0.0, p, np.arctan2(-R[0, 1], R[1, 1])])


def rotation_between(a, b) -> np.ndarray:
    """The smallest rotation R with R a = b for unit vectors a, b (3,) -> (3, 3)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    k, c = np.cross(a, b), float(np.dot(a, b))
    s = np.linalg.norm(k)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        perp = np.cross(a, np.eye(3)[np.argmin(np.abs(a))])
        return axis_angle(perp / np.linalg.norm(perp), np.array([np.pi]))[0]
    return axis_angle(k / s, np.array([np.arctan2(s, c)]))[0]


# == 1. The compiled toolkit ==================================================================================

# -- 3-vectors as 3-tuples (values: no array views, no allocation in the loops) ------------------------------

@njit(cache=True, inline="always")
def vec(x, i):
    """Row i of x (n, 3) as a 3-tuple."""
    return x[i, 0], x[i, 1], x[i, 2]


@njit(cache=True, inline="always")
def put(x, i, a):
    """x[i] = a (a 3-tuple)."""
    x[i, 0], x[i, 1], x[i, 2] = a[0], a[1], a[2]


@njit(cache=True, inline="always")
def add(a, b):
    return a[0] + b[0], a[1] + b[1], a[2] + b[2]


@njit(cache=True, inline="always")
def sub(a, b):
    return a[0] - b[0], a[1] - b[1], a[2] - b[2]


@njit(cache=True, inline="always")
def scale(k, a):
    return k * a[0], k * a[1], k * a[2]


@njit(cache=True, inline="always")
def cross(a, b):
    """a × b."""
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@njit(cache=True, inline="always")
def rot(R, i, x):
    """R[i] x for R (n, 3, 3)."""
    return (R[i, 0, 0] * x[0] + R[i, 0, 1] * x[1] + R[i, 0, 2] * x[2],
            R[i, 1, 0] * x[0] + R[i, 1, 1] * x[1] + R[i, 1, 2] * x[2],
            R[i, 2, 0] * x[0] + R[i, 2, 1] * x[1] + R[i, 2, 2] * x[2])


@njit(cache=True, inline="always")
def rot_t(R, i, x):
    """R[i]ᵀ x for R (n, 3, 3): the chapter's R^i_{i−1} x when R[i] = R^{i−1}_i."""
    return (R[i, 0, 0] * x[0] + R[i, 1, 0] * x[1] + R[i, 2, 0] * x[2],
            R[i, 0, 1] * x[0] + R[i, 1, 1] * x[1] + R[i, 2, 1] * x[2],
            R[i, 0, 2] * x[0] + R[i, 1, 2] * x[1] + R[i, 2, 2] * x[2])


@njit(cache=True, inline="always")
def mul3(R, x):
    """R x for R a 3×3 matrix as a tuple of its rows (the lane kernels' form: values, not an array)."""
    return (R[0][0] * x[0] + R[0][1] * x[1] + R[0][2] * x[2],
            R[1][0] * x[0] + R[1][1] * x[1] + R[1][2] * x[2],
            R[2][0] * x[0] + R[2][1] * x[1] + R[2][2] * x[2])


@njit(cache=True, inline="always")
def mul3t(R, x):
    """Rᵀ x for R a 3×3 matrix as a tuple of its rows (``mul3``)."""
    return (R[0][0] * x[0] + R[1][0] * x[1] + R[2][0] * x[2],
            R[0][1] * x[0] + R[1][1] * x[1] + R[2][1] * x[2],
            R[0][2] * x[0] + R[1][2] * x[1] + R[2][2] * x[2])


@njit(cache=True, inline="always")
def congruence3(R, X):
    """R X Rᵀ for 3×3 R and X as tuples of their rows (``mul3``): row a is R (Xᵀ R_a)."""
    return mul3(R, mul3t(X, R[0])), mul3(R, mul3t(X, R[1])), mul3(R, mul3t(X, R[2]))


@njit(cache=True, inline="always")
def inertia_up(R, p, C, B, A):
    """^λX*_i Iᵃ ⁱX_λ for a symmetric Iᵃ = [[C, Bᵀ], [B, A]] (C linear, A angular; 3×3 tuples of rows): its three
    blocks in the parent (RBDA Table 7.1, pass 2). Rotated C' = R C Rᵀ, B' = R B Rᵀ, A' = R A Rᵀ, then shifted by
    P = [p]× (G = P C'): C' stays, B' + G, A' + P B'ᵀ − B' P − G P (P B'ᵀ − B' P = H + Hᵀ, H's columns p × B'_b;
    −G P's rows p × G_a)."""
    C1, B1, A1 = congruence3(R, C), congruence3(R, B), congruence3(R, A)
    px, py, pz = p[0], p[1], p[2]
    G = (sub(scale(py, C1[2]), scale(pz, C1[1])), sub(scale(pz, C1[0]), scale(px, C1[2])),
         sub(scale(px, C1[1]), scale(py, C1[0])))                      # rows of [p]× C'
    h0, h1, h2 = cross(p, B1[0]), cross(p, B1[1]), cross(p, B1[2])       # H's columns
    g0, g1, g2 = cross(p, G[0]), cross(p, G[1]), cross(p, G[2])          # rows of −G [p]×
    A2 = ((A1[0][0] + 2.0 * h0[0] + g0[0], A1[0][1] + h1[0] + h0[1] + g0[1], A1[0][2] + h2[0] + h0[2] + g0[2]),
          (A1[1][0] + h0[1] + h1[0] + g1[0], A1[1][1] + 2.0 * h1[1] + g1[1], A1[1][2] + h2[1] + h1[2] + g1[2]),
          (A1[2][0] + h0[2] + h2[0] + g2[0], A1[2][1] + h1[2] + h2[1] + g2[1], A1[2][2] + 2.0 * h2[2] + g2[2]))
    return C1, (add(B1[0], G[0]), add(B1[1], G[1]), add(B1[2], G[2])), A2


# -- 3-vectors and 3×3 matrices in arrays (out-parameters) ------------------------------------------------------

@njit(cache=True, inline="always")
def rot3(R, x, out):
    """out = R x (3,)."""
    a, b, c = x[0], x[1], x[2]
    for k in range(3):
        out[k] = R[k, 0] * a + R[k, 1] * b + R[k, 2] * c


@njit(cache=True, inline="always")
def rot3t(R, x, out):
    """out = Rᵀ x (3,)."""
    a, b, c = x[0], x[1], x[2]
    for k in range(3):
        out[k] = R[0, k] * a + R[1, k] * b + R[2, k] * c


@njit(cache=True, inline="always")
def cross3(a, b, out):
    """out = a × b (3,) (``cross``; every value is read before out is written, so out may alias a or b)."""
    out[0], out[1], out[2] = cross(a, b)


@njit(cache=True, inline="always")
def sandwich3(R, X, tmp, out):
    """out += R X Rᵀ for a symmetric 3×3 X (an inertia): the upper triangle, mirrored, so that the result is
    exactly symmetric (tmp is scratch)."""
    for a in range(3):
        for b in range(3):
            tmp[a, b] = R[a, 0] * X[0, b] + R[a, 1] * X[1, b] + R[a, 2] * X[2, b]
    for a in range(3):
        for b in range(a, 3):
            x = tmp[a, 0] * R[b, 0] + tmp[a, 1] * R[b, 1] + tmp[a, 2] * R[b, 2]
            out[a, b] += x
            if b != a:
                out[b, a] += x


# -- 6-vectors [linear; angular] ----------------------------------------------------------------------------

@njit(cache=True, inline="always")
def row6(X, i):
    """Row i of X (n, 6) as a 6-tuple."""
    return X[i, 0], X[i, 1], X[i, 2], X[i, 3], X[i, 4], X[i, 5]


@njit(cache=True, inline="always")
def dot6(a, b):
    """aᵀ b of two 6-vectors (tuples or arrays): the power of a force along a motion."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]


@njit(cache=True, inline="always")
def motion_cross(v, m):
    """v × m = [ω × m_lin + v_lin × m_ang; ω × m_ang] (RBDA §2.9), a 6-tuple."""
    return (v[4] * m[2] - v[5] * m[1] + v[1] * m[5] - v[2] * m[4],
            v[5] * m[0] - v[3] * m[2] + v[2] * m[3] - v[0] * m[5],
            v[3] * m[1] - v[4] * m[0] + v[0] * m[4] - v[1] * m[3],
            v[4] * m[5] - v[5] * m[4], v[5] * m[3] - v[3] * m[5], v[3] * m[4] - v[4] * m[3])


@njit(cache=True, inline="always")
def force_cross(v, f):
    """v ×* f = [ω × f_lin; ω × f_ang + v_lin × f_lin] (RBDA §2.9), a 6-tuple."""
    return (v[4] * f[2] - v[5] * f[1], v[5] * f[0] - v[3] * f[2], v[3] * f[1] - v[4] * f[0],
            v[4] * f[5] - v[5] * f[4] + v[1] * f[2] - v[2] * f[1],
            v[5] * f[3] - v[3] * f[5] + v[2] * f[0] - v[0] * f[2],
            v[3] * f[4] - v[4] * f[3] + v[0] * f[1] - v[1] * f[0])


@njit(cache=True, inline="always")
def cross_motion(v, m, out):
    """out = v × m (``motion_cross`` into an array; out must not alias v or m)."""
    out[0], out[1], out[2], out[3], out[4], out[5] = motion_cross(v, m)


@njit(cache=True, inline="always")
def cross_force(v, f, out):
    """out = v ×* f (``force_cross`` into an array; out must not alias v or f)."""
    out[0], out[1], out[2], out[3], out[4], out[5] = force_cross(v, f)


@njit(cache=True, inline="always")
def motion_down(R, p, l, w):
    """ⁱX_λ [l; w] = (Rᵀ (l + w × p), Rᵀ w): a motion of the parent, at its origin and in its axes, at body i's
    origin and in its axes (RBDA Table 2.2), R a tuple of rows (``block3``), two 3-tuples back."""
    u = (l[0] + w[1] * p[2] - w[2] * p[1], l[1] + w[2] * p[0] - w[0] * p[2], l[2] + w[0] * p[1] - w[1] * p[0])
    return mul3t(R, u), mul3t(R, w)


@njit(cache=True, inline="always")
def compose(Ra, pa, R, p):
    """(Ra R, pa + Ra p): a placement (R, p) in frame a, given with a's own (Ra, pa) in another, in that other
    (x = Ra (R x' + p) + pa); rotations as tuples of rows: row k of Ra R is Rᵀ (row k of Ra)."""
    return (mul3t(R, Ra[0]), mul3t(R, Ra[1]), mul3t(R, Ra[2])), add(pa, mul3(Ra, p))


@njit(cache=True, inline="always")
def force_up(R, p, fx, fy, fz, nx, ny, nz):
    """^λX*_i [f; n] = [R f; R n + p × R f] as six scalars: a wrench about body i's origin, in its axes, moved
    to its parent's origin and axes (RBDA Table 2.2; the chapter's Eqs. 15, 16); R as a tuple of rows (``block3``)."""
    gx = R[0][0] * fx + R[0][1] * fy + R[0][2] * fz
    gy = R[1][0] * fx + R[1][1] * fy + R[1][2] * fz
    gz = R[2][0] * fx + R[2][1] * fy + R[2][2] * fz
    mx = R[0][0] * nx + R[0][1] * ny + R[0][2] * nz + p[1] * gz - p[2] * gy
    my = R[1][0] * nx + R[1][1] * ny + R[1][2] * nz + p[2] * gx - p[0] * gz
    mz = R[2][0] * nx + R[2][1] * ny + R[2][2] * nz + p[0] * gy - p[1] * gx
    return gx, gy, gz, mx, my, mz


@njit(cache=True, inline="always")
def world_motion(R, p, s, out):
    """out = ⁰X_i s = [R s_lin + p × R s_ang; R s_ang] for body i at (R, p) in the world (RBDA Table 2.2)."""
    for a in range(3):
        out[3 + a] = R[a, 0] * s[3] + R[a, 1] * s[4] + R[a, 2] * s[5]
        out[a] = R[a, 0] * s[0] + R[a, 1] * s[1] + R[a, 2] * s[2]
    out[0] += p[1] * out[5] - p[2] * out[4]
    out[1] += p[2] * out[3] - p[0] * out[5]
    out[2] += p[0] * out[4] - p[1] * out[3]


@njit(cache=True, inline="always")
def rotate6(R, s):
    """(R s_lin, R s_ang) as six scalars: a 6-vector's halves turned by R (a motion-subspace column into the
    world)."""
    return (R[0, 0] * s[0] + R[0, 1] * s[1] + R[0, 2] * s[2], R[1, 0] * s[0] + R[1, 1] * s[1] + R[1, 2] * s[2],
            R[2, 0] * s[0] + R[2, 1] * s[1] + R[2, 2] * s[2], R[0, 0] * s[3] + R[0, 1] * s[4] + R[0, 2] * s[5],
            R[1, 0] * s[3] + R[1, 1] * s[4] + R[1, 2] * s[5], R[2, 0] * s[3] + R[2, 1] * s[4] + R[2, 2] * s[5])


# -- spatial inertias ---------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def rigid_inertia(m, c, Ic, out):
    """out (6, 6) = [[m 1, −m [c]×], [m [c]×, I_C − m [c]×²]]: a body of mass m, CoM c and inertia I_C about
    the CoM, about its frame origin (RBDA Eq. 2.63)."""
    cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    for a in range(3):
        for b in range(3):
            out[a, b] = m if a == b else 0.0
            out[3 + a, 3 + b] = Ic[a, b] + m * ((cc if a == b else 0.0) - c[a] * c[b])
    out[3, 0], out[3, 1], out[3, 2] = 0.0, -m * c[2], m * c[1]          # m [c]×
    out[4, 0], out[4, 1], out[4, 2] = m * c[2], 0.0, -m * c[0]
    out[5, 0], out[5, 1], out[5, 2] = -m * c[1], m * c[0], 0.0
    for a in range(3):
        for b in range(3):
            out[a, 3 + b] = out[3 + b, a]                                    # −m [c]× = (m [c]×)ᵀ


@njit(cache=True, inline="always")
def world_inertia(m, c, Ic, R, p, T, out):
    """out (6, 6) = Y_i in the world, about its origin: ``rigid_inertia`` of the CoM R c + p and of R I_C Rᵀ
    (T (6, 6) scratch)."""
    for a in range(3):
        for b in range(3):
            T[a, b] = R[a, 0] * Ic[0, b] + R[a, 1] * Ic[1, b] + R[a, 2] * Ic[2, b]          # R I_C
        T[3, a] = p[a] + R[a, 0] * c[0] + R[a, 1] * c[1] + R[a, 2] * c[2]                 # R c + p
    for a in range(3):
        for b in range(3):
            T[a, 3 + b] = T[a, 0] * R[b, 0] + T[a, 1] * R[b, 1] + T[a, 2] * R[b, 2]      # R I_C Rᵀ
    rigid_inertia(m, T[3, :3], T[:3, 3:], out)


@njit(cache=True, inline="always")
def block3(X, r0, c0):
    """X[r0:r0+3, c0:c0+3] as a tuple of its rows (values: the lane kernels' form, ``mul3``)."""
    return ((X[r0, c0], X[r0, c0 + 1], X[r0, c0 + 2]), (X[r0 + 1, c0], X[r0 + 1, c0 + 1], X[r0 + 1, c0 + 2]),
            (X[r0 + 2, c0], X[r0 + 2, c0 + 1], X[r0 + 2, c0 + 2]))


@njit(cache=True, inline="always")
def mat6(Y, x, out, add):
    """out = Y x (or out += Y x with ``add``) for Y (6, 6), x (6,)."""
    for a in range(6):
        s = Y[a, 0] * x[0] + Y[a, 1] * x[1] + Y[a, 2] * x[2] + Y[a, 3] * x[3] + Y[a, 4] * x[4] + Y[a, 5] * x[5]
        out[a] = out[a] + s if add else s


@njit(cache=True, inline="always")
def rigid6(Y, x, out, add):
    """``mat6`` for a spatial inertia Y = [[m 1, −[h]×], [[h]×, Ī]] (``rigid_inertia`` or a sum of them, which
    keep exact zeros where the structure has them): the 24 products that are not by zero, in mat6's order, so
    the result is the same to the bit (measured: ~1 µs per state less on a 32-link chain)."""
    y0 = Y[0, 0] * x[0] + Y[0, 4] * x[4] + Y[0, 5] * x[5]
    y1 = Y[1, 1] * x[1] + Y[1, 3] * x[3] + Y[1, 5] * x[5]
    y2 = Y[2, 2] * x[2] + Y[2, 3] * x[3] + Y[2, 4] * x[4]
    y3 = Y[3, 1] * x[1] + Y[3, 2] * x[2] + Y[3, 3] * x[3] + Y[3, 4] * x[4] + Y[3, 5] * x[5]
    y4 = Y[4, 0] * x[0] + Y[4, 2] * x[2] + Y[4, 3] * x[3] + Y[4, 4] * x[4] + Y[4, 5] * x[5]
    y5 = Y[5, 0] * x[0] + Y[5, 1] * x[1] + Y[5, 3] * x[3] + Y[5, 4] * x[4] + Y[5, 5] * x[5]
    if add:
        out[0] += y0
        out[1] += y1
        out[2] += y2
        out[3] += y3
        out[4] += y4
        out[5] += y5
    else:
        out[0], out[1], out[2], out[3], out[4], out[5] = y0, y1, y2, y3, y4, y5


@njit(cache=True, inline="always")
def add_force_cross(out, h, scale):
    """out (6, 6) += scale · h ×̄, h ×̄ = [[0, −[h_l]×], [−[h_l]×, −[h_a]×]] for the momentum h = [h_l; h_a]
    (Pinocchio's addForceCrossMatrix: h ×̄ m = −m ×* h)."""
    for r0, c0, k in ((0, 3, 0), (3, 0, 0), (3, 3, 3)):
        x, y, z = scale * h[k], scale * h[k + 1], scale * h[k + 2]
        out[r0, c0 + 1] += z
        out[r0, c0 + 2] -= y
        out[r0 + 1, c0] -= z
        out[r0 + 1, c0 + 2] += x
        out[r0 + 2, c0] += y
        out[r0 + 2, c0 + 1] -= x


@njit(cache=True, inline="always")
def inertia_variation(Y, v, h, P, out):
    """out = Ẏ = v ×* Y − Y v× + h ×̄ (Pinocchio's ``variation`` plus ``addForceCrossMatrix``): with the
    motion-cross matrix X = v× = [[ω×, v_l×], [0, ω×]] and v ×* = −Xᵀ, Y symmetric: −XᵀY − (XᵀY)ᵀ, plus
    h ×̄ = [[0, −[h_l]×], [−[h_l]×, −[h_a]×]] (h ×̄ m = −m ×* h, the v-derivative of v ×* h). P (6, 6) scratch."""
    wx, wy, wz, lx, ly, lz = v[3], v[4], v[5], v[0], v[1], v[2]
    for k in range(6):                       # P = Xᵀ Y, row by row: Xᵀ = [[−[ω]×, 0], [−[v_l]×, −[ω]×]]
        y0, y1, y2, y3, y4, y5 = Y[0, k], Y[1, k], Y[2, k], Y[3, k], Y[4, k], Y[5, k]
        P[0, k] = wz * y1 - wy * y2
        P[1, k] = wx * y2 - wz * y0
        P[2, k] = wy * y0 - wx * y1
        P[3, k] = lz * y1 - ly * y2 + wz * y4 - wy * y5
        P[4, k] = lx * y2 - lz * y0 + wx * y5 - wz * y3
        P[5, k] = ly * y0 - lx * y1 + wy * y3 - wx * y4
    for a in range(6):
        for k in range(6):
            out[a, k] = -P[a, k] - P[k, a]
    add_force_cross(out, h, 1.0)             # + h ×̄


@njit(cache=True, inline="always")
def merge_shift(k, d):
    """k (|d|² 1 − d dᵀ), a tuple of rows: what the union of two bodies adds to their inertia about the common
    centre of mass (``crba.merge_lane``; k = m₁m₂/m, d = c₁ − c₂). The diagonal is formed from sums of the other
    two squares (as ``parallel_axis``): a large offset along one axis keeps the small moment about it."""
    dx, dy, dz = d[0], d[1], d[2]
    xy, xz, yz = -k * dx * dy, -k * dx * dz, -k * dy * dz
    return ((k * (dy * dy + dz * dz), xy, xz), (xy, k * (dx * dx + dz * dz), yz),
            (xz, yz, k * (dx * dx + dy * dy)))


@njit(cache=True, inline="always")
def inertia_motion(m, c, J, sl, sa):
    """I s = (f, n) as six scalars, for a body (m, c, I_C; J: I_C as a tuple of rows, ``block3``) and the motion
    s = [s_l; s_a] (3-tuples), about the body's origin: f = m (s_l + s_a × c), its CoM's momentum;
    n = I_c s_a + c × f."""
    lx, ly, lz, ax, ay, az = sl[0], sl[1], sl[2], sa[0], sa[1], sa[2]
    fx = m * (lx + ay * c[2] - az * c[1])
    fy = m * (ly + az * c[0] - ax * c[2])
    fz = m * (lz + ax * c[1] - ay * c[0])
    nx = J[0][0] * ax + J[0][1] * ay + J[0][2] * az + c[1] * fz - c[2] * fy
    ny = J[1][0] * ax + J[1][1] * ay + J[1][2] * az + c[2] * fx - c[0] * fz
    nz = J[2][0] * ax + J[2][1] * ay + J[2][2] * az + c[0] * fy - c[1] * fx
    return fx, fy, fz, nx, ny, nz


# -- small dense solves -------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def cholesky(D, n, dmin):
    """D = L Lᵀ in place (n × n, lower triangle read and written). Returns -1, or the first k whose pivot
    D_kk − Σ_m L_km² is not > dmin (left in D[k, k]): D is singular to working precision there."""
    for k in range(n):
        d = D[k, k]
        for m in range(k):
            d -= D[k, m] * D[k, m]
        if not d > dmin:
            D[k, k] = d
            return k
        d = np.sqrt(d)
        D[k, k] = d
        for r in range(k + 1, n):
            x = D[r, k]
            for m in range(k):
                x -= D[r, m] * D[k, m]
            D[r, k] = x / d
    return -1


@njit(cache=True, inline="always")
def cholesky_solve(L, n, x):
    """x ← D⁻¹ x = L⁻ᵀ L⁻¹ x (x (n,); forward, then back substitution)."""
    for r in range(n):
        y = x[r]
        for m in range(r):
            y -= L[r, m] * x[m]
        x[r] = y / L[r, r]
    for r in range(n - 1, -1, -1):
        y = x[r]
        for m in range(r + 1, n):
            y -= L[m, r] * x[m]
        x[r] = y / L[r, r]


@njit(cache=True, inline="always")
def spd_inverse(M, L, out):
    """out = M⁻¹ = L⁻ᵀ L⁻¹ for a symmetric positive definite M (n, n), by Cholesky M = L Lᵀ (L (n, n) scratch,
    lower triangle), then L⁻¹ (into M's lower triangle: M is overwritten) and the product L⁻ᵀ L⁻¹, as
    LAPACK's potri (trtri, then lauum's product, here by BLAS).
    Returns -1, or the first row k whose pivot is not > 0 (M singular there)."""
    n = M.shape[0]
    for k in range(n):
        d = M[k, k]
        for m in range(k):
            d -= L[k, m] * L[k, m]
        if not d > 0.0:
            return k
        L[k, k] = np.sqrt(d)
        for r in range(k + 1, n):
            x = M[r, k]
            for m in range(k):
                x -= L[r, m] * L[k, m]
            L[r, k] = x / L[k, k]
    # L⁻¹ by row updates (axpy along contiguous rows: independent multiply-adds, which the compiler
    # vectorises), not by dot products (a serial chain of dependent additions, ~3x slower at n = 32).
    for r in range(n):                        # M ← X = L⁻¹ (lower) by forward substitution of L X = 1:
        for c in range(n):                    # row m is final once rows < m are subtracted, then each later
            M[r, c] = 1.0 if r == c else 0.0  # row r takes away L_rm (row m)
    for m in range(n):
        d = 1.0 / L[m, m]
        for c in range(m + 1):
            M[m, c] *= d
        for r in range(m + 1, n):
            x = L[r, m]
            for c in range(m + 1):
                M[r, c] -= x * M[m, c]
    np.dot(M.T, M, out)                       # out = Xᵀ X (BLAS; measured 0.6 µs less than the loops at n = 32),
    for r in range(n):                        # exactly symmetric: the lower triangle mirrored
        for c in range(r):
            out[c, r] = out[r, c]
    return -1


# -- the one finiteness check ------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def first_nonfinite(X, s):
    """The index of the first non-finite entry of row s of the 2-D array X, or -1 (a vector x: ``x[None]``, 0).
    The common case (all finite) is one branch-free pass (x − x is 0 for a finite x, NaN for ±inf and NaN: the
    compiler keeps the loop tight, and no row view is made, which would cost reference counting per state);
    only a bad row is searched for its entry. Every kernel checks its inputs and results with it."""
    bad = 0
    for k in range(X.shape[1]):
        bad += not (X[s, k] - X[s, k] == 0.0)
    if bad == 0:
        return -1
    for k in range(X.shape[1]):
        if not np.isfinite(X[s, k]):
            return k
    return -1


@njit(cache=True, inline="always")
def first_nonfinite_entry(A):
    """The flat index of the first non-finite entry of the matrix A (n, m), or -1: ``first_nonfinite`` row by
    row."""
    for a in range(A.shape[0]):
        k = first_nonfinite(A, a)
        if k >= 0:
            return a * A.shape[1] + k
    return -1


# -- sin and cos in straight-line code (the lane kernels) --------------------------------------------------
# A lane kernel (rnea.rnea_lanes) runs one loop over a block of states; a call to libm's sin or cos inside it
# keeps the loop scalar (and costs ~15 ns a call). ``sincos`` is branch-free arithmetic instead: Cody–Waite
# reduction by π/2 in three parts (π/2 = PIO2_1 + PIO2_2 + PIO2_2T, the first two with 33 significant bits, so
# that k·PIO2_1 and k·PIO2_2 are exact for |k| < 2^20), then the minimax polynomials of sin and cos on
# [−π/4, π/4] (fdlibm's coefficients: the standard, published ones), then the quadrant. Measured against numpy's
# sin and cos (tests/unit/test_sincos.py): within 1 ulp for |x| ≤ 256 (40 turns), within 2 ulp and 1.2e-16 absolute
# up to SINCOS_MAX; a lane kernel runs a block with a larger angle through its one-state form.
SINCOS_MAX = 1.0e5
_ROUND = 6755399441055744.0         # 1.5 · 2^52: (y + _ROUND) − _ROUND is y rounded to an integer for |y| < 2^51,
#                                     in two additions (numpy's floor has no GPU form; CUDA compiles these as they are)
_TWO_OVER_PI = 0.63661977236758134308
_PIO2_1, _PIO2_2, _PIO2_2T = 1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624879595063154e-21
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


@njit(cache=True, inline="always")
def sincos(x):
    """(sin x, cos x) for |x| ≤ SINCOS_MAX, within 1 ulp for |x| ≤ 256 and 2 ulp beyond, without a branch or a
    call (see above)."""
    k = (x * _TWO_OVER_PI + _ROUND) - _ROUND                     # x = k π/2 + r, |r| ≤ π/4 (k: nearest integer)
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_2T
    z = r * r
    s = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    c = w + (((1.0 - w) - hz) + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6))))))
    m = k - 4.0 * (((k - 1.5) * 0.25 + _ROUND) - _ROUND)       # the quadrant k mod 4, 0 … 3 (no tie to round)
    even = m == 0.0 or m == 2.0
    sn, cs = s if even else c, c if even else s
    return (-sn if m >= 2.0 else sn), (-cs if (m == 1.0 or m == 2.0) else cs)
