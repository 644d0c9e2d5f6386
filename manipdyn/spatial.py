"""3-D helpers shared by every algorithm: rotations, cross products, rigid-body inertia algebra.

Convention owned here: a batch of 3-vectors is an array of shape (N, 3) and a batch of rotations
(N, 3, 3); ``R`` maps coordinates of the child frame into the parent frame (x_parent = R x_child),
so ``rot_t(R, x)`` is the chapter's R^i_{i-1} x (parent coordinates into the child frame).
URDF ``rpy`` means R = Rz(yaw) Ry(pitch) Rx(roll), about fixed axes.
"""
from __future__ import annotations

import numpy as np


def rot(R: np.ndarray, x: np.ndarray) -> np.ndarray:
    """R x for batches: R (N, 3, 3) or (3, 3), x (N, 3) -> (N, 3)."""
    return x @ np.swapaxes(R, -1, -2) if R.ndim == 2 else np.einsum("nij,nj->ni", R, x)


def rot_t(R: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Rᵀ x for batches: R (N, 3, 3) or (3, 3), x (N, 3) -> (N, 3)."""
    return x @ R if R.ndim == 2 else np.einsum("nji,nj->ni", R, x)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for (..., 3) arrays, written out (np.cross is several times slower on small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


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
