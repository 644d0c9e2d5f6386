"""Time series shown beside the robot: q, q̇, τ (and, for a closed chain, the closure gap) against time.

The rates of a trajectory file come from its samples (second-order finite differences on its own time
base); torques from the chapter's Newton–Euler (rnea) along the motion, or, for a closed chain, from the
constrained inverse dynamics (Lagrange's equations of the 1st kind) on the rates completed through the
closures — τ of the actuated joints only. Nothing here draws: the page (viz/page.py) plots the arrays.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ManipdynError
from ..joints import BALL, FREEFLYER

MAX_POINTS = 600          # plotted samples per series at most (a panel is a few hundred pixels wide)
DIGITS = 5                # significant digits kept in the page


def rates(model, t, Q):
    """(V, A) (T, nv) by second-order finite differences of Q (T, nq) on the times t (T,); on a model with
    quaternions (free flyer, ball joint) V by ``difference`` of neighbouring samples (body-frame twist or ω),
    central inside, one-sided at the ends. One sample: zeros."""
    from ..configuration import difference
    T = len(t)
    if T < 2:
        return np.zeros((T, model.nv)), np.zeros((T, model.nv))
    if model.nq != model.nv:          # quaternions, a planar joint's (cos, sin): rates by difference
        lo, hi = np.r_[0, np.arange(T - 1)], np.r_[np.arange(1, T), T - 1]
        V = difference(model, Q[lo], Q[hi]) / (t[hi] - t[lo])[:, None]
    else:
        V = np.gradient(Q, t, axis=0, edge_order=2 if T > 2 else 1)
    return V, np.gradient(V, t, axis=0, edge_order=2 if T > 2 else 1)


def torques(model, t, Q, V=None, A=None, f_ext=None):
    """(τ (T, k), names (k,)) along the motion: rnea for a tree (the entries of v of every joint but the free
    flyers: a free body takes no torque), the
    actuator forces of the constrained inverse dynamics for a closed chain (the rates completed through
    the closures from the actuated joints' finite differences); names are ``model.v_names`` (a ball joint's
    three torques: joint.wx, .wy, .wz)."""
    from ..constraints import complete_state
    from ..constraints.dynamics import actuation, constrained_inverse_dynamics, dofs
    from ..dynamics.rnea import rnea
    if V is None or A is None:
        V, A = rates(model, t, Q)
    if model.constraints:
        act = dofs(model, actuation(model))
        if V.shape[0] > 1:
            Q, V, A, _ = complete_state(model, Q, V[:, act], A[:, act])
        tau, _ = constrained_inverse_dynamics(model, Q, V, A, f_ext=f_ext, f_ext_frame="world")
        return tau, [model.v_names[i] for i in act]
    tau = rnea(model, Q, V, A, f_ext=f_ext, f_ext_frame="world")
    joint = [i for i in range(model.nv) if model.kind[model.v_joint[i]] != FREEFLYER]
    return tau[:, joint], [model.v_names[i] for i in joint]


def _round(x):
    """Values as JSON numbers with DIGITS significant digits (NaN -> None)."""
    return [None if not math.isfinite(v) else float(f"{v:.{DIGITS}g}") for v in np.asarray(x, float).ravel()]


def signals(model, t, Q, V=None, A=None, tau=None, tau_names=None, marks=(), gaps=None, f_ext=None):
    """The page's plot data: {"t": [...], "groups": [{key, title, names, series: [[...], ...]}], "marks":
    [{t, label}], "notes": [...]} on at most MAX_POINTS times of the motion t (T,), Q (T, nq).

    V, A (T, nv) when known (else finite differences); tau (T, k) with tau_names when known (else
    computed: see torques; when that fails, e.g. an under-actuated closed chain, the note says why);
    marks: (time, label) pairs drawn on the time axis (a singularity); gaps: (n_closures, T) or None."""
    t, Q = np.asarray(t, float), np.asarray(Q, float)
    notes = []
    if V is None or A is None:
        V, A = rates(model, t, Q)
    if tau is None:
        try:
            tau, tau_names = torques(model, t, Q, V, A, f_ext=f_ext)
        except ManipdynError as exc:
            tau, tau_names = None, None
            notes.append(f"torques not shown: {exc}")
    keep = np.unique(np.linspace(0, len(t) - 1, min(len(t), MAX_POINTS)).round().astype(int))
    joints = [j for j in range(model.njoints) if model.kind[j] != FREEFLYER]       # free bodies' poses not plotted
    qi = [int(model.idx_q[j]) + k for j in joints for k in range(int(model.nqs[j]))]
    vi = [int(model.idx_v[j]) + k for j in joints for k in range(int(model.nvs[j]))]
    ball = "; ball joints: quaternion" if any(model.kind[j] == BALL for j in joints) else ""
    groups = [dict(key="q", title=f"q — joint positions [rad, m{ball}]",
                   names=[model.q_names[i] for i in qi], series=[_round(Q[keep, i]) for i in qi]),
              dict(key="v", title=f"q̇ — joint rates [rad/s, m/s{ball and '; ball joints: body-frame ω'}]",
                   names=[model.v_names[i] for i in vi], series=[_round(V[keep, i]) for i in vi])]
    if tau is not None:
        tau = np.asarray(tau, float).reshape(len(t), -1)
        groups.append(dict(key="tau", title="τ — joint torques [N·m, N]" if not model.constraints else
                           "τ — actuator torques [N·m, N]", names=list(tau_names),
                           series=[_round(tau[keep, k]) for k in range(tau.shape[1])]))
    if gaps is None and model.constraints:
        from .scene import _closure_gaps
        gaps = _closure_gaps(model, Q)
    if gaps is not None and len(gaps):
        groups.append(dict(key="gap", title="closure gap |p_A − p_B| [m]",
                           names=[c.name for c in model.constraints],
                           series=[_round(np.asarray(g, float)[keep]) for g in gaps]))
    return dict(t=_round(t[keep]), groups=groups, notes=notes,
                marks=[dict(t=float(m), label=str(label)) for m, label in marks])
