"""The Fig. 7 actuator torques of the SPM by the generic route: URDF tree + loop closures.

Given the actuators' motion θ(t), θ̇(t), θ̈(t), each sample is completed (passive coordinates by assembly
from the previous sample, so the assembly branch is kept; rates and accelerations from the closures) and
the actuator torques come from Lagrange's equations of the 1st kind (constrained_inverse_dynamics), with
the external moment m applied on the platform (world axes; a pure moment, so about any point).
"""
from __future__ import annotations

import numpy as np

from ..constraints import complete_state
from ..constraints.dynamics import constrained_inverse_dynamics


def generic_torques(model, q_start, theta, theta_dot, theta_ddot, moment):
    """τ_a (T, 3), full q, q̇, q̈ (T, nv) and per-sample assembly conditions along an actuator motion.

    q_start: a tree configuration near the first sample (e.g. spm_urdf.tree_guess); θ arrays (T, 3).
    """
    act = [model.joint_index(j) for j in model.actuated]
    T = len(theta)
    Q, V, A = (np.empty((T, model.nv)) for _ in range(3))
    tau, cond = np.empty((T, len(act))), np.empty(T)
    guess = np.array(q_start, float)
    fx = {"platform": (np.zeros(3), np.asarray(moment, float))}
    for k in range(T):
        guess[act] = theta[k]
        Q[k], V[k], A[k], asm = complete_state(model, guess, theta_dot[k], theta_ddot[k])
        if not asm.same_branch:
            raise RuntimeError(f"sample {k}: the assembly changed branch (a singularity was crossed)")
        tau[k], _ = constrained_inverse_dynamics(model, Q[k], V[k], A[k], f_ext=fx, f_ext_frame="world")
        cond[k], guess = asm.cond, Q[k].copy()
    return tau, Q, V, A, cond
