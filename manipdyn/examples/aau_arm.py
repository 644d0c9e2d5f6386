"""The chapter's Example I: the AAU 5-dof arm along its end-effector path, with a 5 kg payload.

The path (chapter, mm → m), t ∈ [0, 2π] s, rest to rest:
    x = 5 + 400(1 − cos t),  y = −990 + 800(1 − cos(t/2)),  z = 280 + 250(cos(t/2) − 1)
The chapter's orientation ψ = [0, cos(t/180), 0] (ZXZ) changes by less than 2e-4 rad/s: it is held
constant. Five joints cannot follow a 6-D twist, so Eq. 28's J⁻¹ does not exist as printed; the task here is
5-D: the tool point's position (3 rows) and the direction d of the tool's z axis, held pointing down so
the tool plate stays horizontal (2 rows: d·n1, d·n2 with n1, n2 ⊥ d*); the yaw about that axis is left
free (five joints). Its Jacobian is
    J_task = [J_v ; (d × n1)ᵀ J_ω ; (d × n2)ᵀ J_ω]   (5 × 5, J from frame_jacobian(tool), world-aligned)
q̇ = J_task⁻¹ [ẋ; 0] and q̈ = J_task⁻¹([ẍ; 0] − J̇_task q̇) (Eq. 31 corrected: J̇ acts on q̇, not J̇⁻¹ on v),
q by Newton on the pose error at every sample (closed loop, from the previous sample). Near a singularity
(σ_min(J_task) below ``sigma_min`` = 0.05) the solver switches to damped least squares,
J⁺ = Jᵀ(J Jᵀ + λ²1)⁻¹ with λ = 0.05, and flags the sample (along the chapter's path σ_min ≥ 0.198). Torques: Newton–Euler with the payload's weight acting on the arm at ``tool``; the
chapter's f₆ = 5g is the force link 5 exerts on the payload (the opposite sign).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.kinematics import frame_jacobian, frame_jacobian_dot, frame_placement
from ..dynamics.rnea import rnea
from ..extras import require

PAYLOAD_KG = 5.0
G = 9.81
PLOTS = "manipdyn example aau (Figs. 3-4)"   # the feature that needs matplotlib (the plots extra)
D_STAR = np.array([0.0, 0.0, -1.0])       # held direction of the tool's z axis: down, the tool plate level


def path(t):
    """Chapter's end-effector path and its derivatives, metres: x, ẋ, ẍ each (T, 3)."""
    t = np.atleast_1d(np.asarray(t, float))
    c, s, c2, s2 = np.cos(t), np.sin(t), np.cos(t / 2), np.sin(t / 2)
    x = np.column_stack([5 + 400 * (1 - c), -990 + 800 * (1 - c2), 280 + 250 * (c2 - 1)]) * 1e-3
    xd = np.column_stack([400 * s, 400 * s2, -125 * s2]) * 1e-3
    xdd = np.column_stack([400 * c, 200 * c2, -62.5 * c2]) * 1e-3
    return x, xd, xdd


def _basis(d):
    """n1, n2 completing the unit vector d to an orthonormal basis."""
    t = np.eye(3)[np.argmin(np.abs(d))]
    n1 = np.cross(d, t)
    n1 /= np.linalg.norm(n1)
    return n1, np.cross(d, n1)


N1, N2 = _basis(D_STAR)


def task(model, q, v=None, frame="tool"):
    """Task value [p; d·n1; d·n2] (5,), J_task (5, nv) and, with v, J̇_task q̇ (5,)."""
    R, p = frame_placement(model, q, frame)
    J = frame_jacobian(model, q, frame)
    d = R[:, 2]
    rows = np.array([np.cross(d, N1), np.cross(d, N2)])
    Jt = np.vstack([J[:3], rows @ J[3:]])
    value = np.r_[p, d @ N1, d @ N2]
    if v is None:
        return value, Jt, None
    dJ = frame_jacobian_dot(model, q, v, frame)
    w = J[3:] @ v
    d_dot = np.cross(w, d)                  # d/dt of the rows (d × n)ᵀ: (ḋ × n)ᵀ
    drows = np.array([np.cross(d_dot, N1), np.cross(d_dot, N2)])
    bias = np.r_[dJ[:3] @ v, rows @ (dJ[3:] @ v) + drows @ w]
    return value, Jt, bias


def _solve(J, b, sigma_min, damping):
    """J⁻¹ b, or damped least squares when σ_min(J) < sigma_min; returns (x, σ_min, damped)."""
    sv = np.linalg.svd(J, compute_uv=False)
    if sv[-1] >= sigma_min:
        return np.linalg.solve(J, b), sv[-1], False
    return J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(len(b)), b), sv[-1], True


def inverse_kinematics(model, target, q_guess, tol=1e-12, max_iter=100):
    """Newton on the task error from a guess: q with [p; d·n1; d·n2] = [target; 0; 0]."""
    q = np.array(q_guess, float)
    for _ in range(max_iter):
        value, J, _ = task(model, q)
        err = value - np.r_[target, 0.0, 0.0]
        if np.max(np.abs(err)) < tol:
            return q, err
        step, _, _ = _solve(J, err, 1e-6, 1e-3)
        q -= step * min(1.0, 0.3 / max(np.max(np.abs(step)), 1e-300))
    return q, err


@dataclass(frozen=True)
class Trajectory:
    """Joint motion along the path: every array (T, ...) sampled at t."""
    t: np.ndarray            # (T,)
    q: np.ndarray            # (T, nv)
    v: np.ndarray
    a: np.ndarray
    pos_err: np.ndarray      # (T,) |p(q) − x(t)|, m
    dir_err: np.ndarray      # (T,) angle between the tool z axis and d*, rad
    sigma_min: np.ndarray    # (T,) smallest singular value of J_task
    damped: np.ndarray       # (T,) bool: damped least squares used


def follow(model, t, x, xd, xdd, q0, sigma_min=0.05, damping=0.05):
    """Joint q, q̇, q̈ along the task samples (x, ẋ, ẍ each (T, 3)) from the configuration guess q0."""
    T, nv = len(t), model.nv
    Q, V, A = np.empty((T, nv)), np.empty((T, nv)), np.empty((T, nv))
    pe, de, sm, dmp = np.empty(T), np.empty(T), np.empty(T), np.zeros(T, bool)
    q = np.array(q0, float)
    for k in range(T):
        q, err = inverse_kinematics(model, x[k], q)
        _, J, _ = task(model, q)
        V[k], sm[k], dmp[k] = _solve(J, np.r_[xd[k], 0.0, 0.0], sigma_min, damping)
        _, _, bias = task(model, q, V[k])
        A[k], _, _ = _solve(J, np.r_[xdd[k], 0.0, 0.0] - bias, sigma_min, damping)
        R, p = frame_placement(model, q, "tool")
        Q[k], pe[k] = q, np.linalg.norm(p - x[k])
        de[k] = np.arctan2(np.linalg.norm(np.cross(R[:, 2], D_STAR)), R[:, 2] @ D_STAR)
    return Trajectory(np.asarray(t, float), Q, V, A, pe, de, sm, dmp)


def payload_wrench(n, mass=PAYLOAD_KG):
    """The payload's weight acting on the arm at ``tool``, world axes: f_ext for rnea (n states)."""
    return {"tool": (np.tile([0.0, 0.0, -mass * G], (n, 1)), np.zeros((n, 3)))}


def torques(model, traj, mass=PAYLOAD_KG, inertia=None):
    """Joint torques along the trajectory with the payload (Newton–Euler, Eqs. 32a–i): its weight as an
    external force at ``tool`` — or, given ``inertia`` (3, 3 about the tool, tool axes), the payload as a
    rigid body merged into link 5, so that its inertial forces act too."""
    if inertia is not None:
        return rnea(with_payload(model, mass, inertia), traj.q, traj.v, traj.a)
    return rnea(model, traj.q, traj.v, traj.a, f_ext=payload_wrench(len(traj.t), mass), f_ext_frame="world")


def chapter_example(model, samples=401, q0=None):
    """The chapter's Example I: trajectory over t ∈ [0, 2π] and torques with the 5 kg payload."""
    t = np.linspace(0.0, 2 * np.pi, samples)
    x, xd, xdd = path(t)
    q0 = initial_configuration(model) if q0 is None else q0
    traj = follow(model, t, x, xd, xdd, q0)
    return traj, torques(model, traj)


def initial_configuration(model, tries=200, seed=0):
    """IK at t = 0 from seeded random guesses; the solution with the best-conditioned task Jacobian."""
    x0 = path(0.0)[0][0]
    rng, best = np.random.default_rng(seed), None
    for _ in range(tries):
        q, err = inverse_kinematics(model, x0, rng.uniform(-np.pi, np.pi, model.nv))
        facing = frame_placement(model, q, "tool")[0][:, 2] @ D_STAR > 0     # not the flipped solution
        if np.max(np.abs(err)) < 1e-10 and facing:
            s = np.linalg.svd(task(model, q)[1], compute_uv=False)[-1]
            if best is None or s > best[0]:
                best = (s, q)
    if best is None:
        raise RuntimeError("no inverse-kinematics solution at t = 0: is the tool path reachable?")
    return best[1]


def write_csv(path, model, traj, tau):
    """CSV with header t, q_<joint>..., v_<joint>..., a_<joint>..., tau_<joint>... (SI units): the format
    ``manipdyn play`` reads."""
    names = model.joint_names
    head = ["t"] + [f"{k}_{j}" for k in ("q", "v", "a", "tau") for j in names]
    data = np.column_stack([traj.t, traj.q, traj.v, traj.a, tau])
    np.savetxt(path, data, delimiter=",", header=",".join(head), comments="", fmt="%.17g")


def read_csv(path):
    """(header names, data (T, columns)) of a CSV written by write_csv."""
    with open(path) as fh:
        head = fh.readline().strip().split(",")
    return head, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def plot(out_dir, model, traj, tau):
    """Fig. 3 (joint rates and accelerations) and Fig. 4 (joint torques) as PNG files."""
    matplotlib = require("matplotlib", "plots", PLOTS)
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for i, j in enumerate(model.joint_names):
        a1.plot(traj.t, traj.v[:, i], label=j)
        a2.plot(traj.t, traj.a[:, i], label=j)
    a1.set_ylabel("joint rate θ̇ [rad/s]")
    a2.set_ylabel("joint acceleration θ̈ [rad/s²]")
    a2.set_xlabel("time t [s]")
    a1.set_title("AAU arm along the chapter's path (Fig. 3)")
    a1.legend(fontsize=8, ncol=5)
    for a in (a1, a2):
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/fig3_joint_rates.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, j in enumerate(model.joint_names):
        ax.plot(traj.t, tau[:, i], label=j)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("joint torque τ [N·m]")
    ax.set_title(f"Joint torques with a {PAYLOAD_KG:g} kg payload (Fig. 4)")
    ax.legend(fontsize=8, ncol=5)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/fig4_joint_torques.png", dpi=120)
    plt.close(fig)


def singular_path(model, q_start, duration=2.0, samples=201, goal=None):
    """A path designed to run into a singularity of the 5-D task: from q_start the tool point moves
    straight towards the base axis. Around that axis lies the edge of the reachable set (the 0.1 m wrist
    offset keeps the tool point off it), where σ_min(J_task) → 0: the solver reports σ_min, switches to
    damped least squares and keeps the rates bounded; the pose error it reports grows where the path
    leaves the reachable set (never NaN, never silent). ``goal`` (3,) replaces that target, e.g. a point
    beyond reach straight out from the shoulder: the elbow straightens (the elbow singularity)."""
    t = np.linspace(0.0, duration, samples)
    _, p0 = frame_placement(model, q_start, "tool")
    shoulder = frame_placement(model, np.zeros(model.nv), model.body_names[1])[1]
    if goal is None:                                          # above/below the base axis: joint 1 singular
        goal = np.array([shoulder[0], shoulder[1], p0[2]])
    s = 0.5 * (1 - np.cos(np.pi * t / duration))             # rest to rest
    sd = 0.5 * np.pi / duration * np.sin(np.pi * t / duration)
    sdd = 0.5 * (np.pi / duration) ** 2 * np.cos(np.pi * t / duration)
    x = p0 + np.outer(s, goal - p0)
    return follow(model, t, x, np.outer(sd, goal - p0), np.outer(sdd, goal - p0), q_start)


def with_payload(model, mass=PAYLOAD_KG, inertia=None, frame="tool"):
    """The model with a rigid payload (mass at the frame's origin, inertia (3, 3) about it in the frame's
    axes, default a point mass) merged into the body carrying ``frame``: its weight *and* inertia then act."""
    import dataclasses

    from ..spatial import combine_inertias
    fr = model.frame(frame)
    b = fr.body
    I_b = np.zeros((3, 3)) if inertia is None else fr.R @ np.asarray(inertia, float) @ fr.R.T
    m, c, I = combine_inertias([(model.mass[b], model.com[b], model.inertia[b]), (float(mass), fr.p, I_b)])
    mass_, com_, inertia_ = model.mass.copy(), model.com.copy(), model.inertia.copy()
    mass_[b], com_[b], inertia_[b] = m, c, I
    return dataclasses.replace(model, mass=mass_, com=com_, inertia=inertia_)
