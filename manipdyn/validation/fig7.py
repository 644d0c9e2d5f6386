"""The chapter's Fig. 7 (SPM actuator torques) by three independent routes, compared sample by sample.

(a) the chapter's own formulation (examples/spm.py, Eqs. 33–61); (b) the generic route, urdf/spm.urdf as a
tree closed by <constraint>s and Lagrange's equations of the 1st kind (examples/spm_routes.py);
(c) Pinocchio's constraintDynamics on constraint models built from the same URDF, its forward map inverted
for the actuator torques, the external moment entering as τ + J_ωᵀ m (constraintDynamics takes no f_ext).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dynamics.kinematics import frame_jacobian
from ..examples import spm as chapter
from ..examples import spm_params as P
from ..examples.spm_routes import generic_torques
from ..examples.spm_urdf import tree_guess
from ..extras import require
from ..io.urdf import load_urdf
from ..paths import bundled_dir
from .closed import PROXIMAL, ClosedReference, actuator_torques_by_inversion
from .measure import error
from .reference import Reference

SPM_URDF = bundled_dir() / "spm.urdf"
SPAN = (0.0, 0.25)            # singularity-free: leg 2's (u₂ × v₂)·w₂ reaches 0 at t ≈ 0.281 s (zero θ̈)
ACCEL_CASE = (5.0, -5.0, 3.0)  # the non-zero constant actuator accelerations we chose, rad/s²
FEATURE = "manipdyn example spm (Fig. 7)"


@dataclass
class Routes:
    t: np.ndarray
    chapter: np.ndarray       # (T, 3) actuator torques, N·m
    generic: np.ndarray
    pinocchio: np.ndarray
    fig: chapter.Fig7
    err_generic: float        # max over samples of the docs/design.md §3 measure against the chapter's route
    err_pinocchio: float


def three_routes(samples=51, theta_ddot=(0.0, 0.0, 0.0), span=SPAN, path=SPM_URDF) -> Routes:
    """Actuator torques along the Fig. 7 span by routes (a), (b), (c) on the same samples."""
    t = np.linspace(*span, samples)
    fig = chapter.fig7(t, theta_ddot)
    model = load_urdf(path)
    th, thd, thdd = fig.q[:, :3], fig.qd[:, :3], fig.qdd[:, :3]
    start = tree_guess(model, chapter.platform_rotation(fig.q[0, 3:]), th[0])
    gen, Q, V, _, _ = generic_torques(model, start, th, thd, thdd, P.MOMENT)
    cref = ClosedReference(Reference(model, path))
    act = [model.joint_index(j) for j in model.actuated]
    pin_tau = np.array([actuator_torques_by_inversion(model, cref, Q[k], V[k], thdd[k], act,
                                                      frame_jacobian(model, Q[k], "platform")[3:].T @ P.MOMENT)
                        for k in range(len(t))])
    e = lambda x: max(error(x[k], fig.tau[k]) for k in range(len(t)))  # noqa: E731
    return Routes(t, fig.tau, gen, pin_tau, fig, e(gen), e(pin_tau))


def write(out_dir, routes_by_case):
    """fig7_actuator_torques.png and one CSV per case (t, tau_chapter_i, tau_generic_i, tau_pinocchio_i)."""
    matplotlib = require("matplotlib", "plots", FEATURE)
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out = Path(out_dir)
    fig, axes = plt.subplots(len(routes_by_case), 1, figsize=(7, 3.4 * len(routes_by_case)), squeeze=False)
    for ax, (label, r) in zip(axes[:, 0], routes_by_case.items()):
        for i in range(3):
            line, = ax.plot(r.t, r.chapter[:, i], label=f"τ{i + 1} chapter (Eqs. 33–61)")
            ax.plot(r.t, r.generic[:, i], "--", color=line.get_color(), label=f"τ{i + 1} URDF + closures")
            ax.plot(r.t[::4], r.pinocchio[::4, i], "x", color=line.get_color(), label=f"τ{i + 1} Pinocchio")
        ax.set_title(f"SPM actuator torques (Fig. 7), {label}")
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("actuator torque τ_a [N·m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=3)
        head = "t," + ",".join(f"tau{i + 1}_{w}" for w in ("chapter", "generic", "pinocchio") for i in range(3))
        np.savetxt(out / f"fig7_{label.split()[0]}.csv", np.column_stack([r.t, r.chapter, r.generic, r.pinocchio]),
                   delimiter=",", header=head, comments="", fmt="%.17g")
    fig.tight_layout()
    fig.savefig(out / "fig7_actuator_torques.png", dpi=120)
    plt.close(fig)


def main(out_dir, samples=51) -> int:
    """`manipdyn example spm`: both cases, the span, conditioning and the three-route agreement."""
    require("pinocchio", "validate", FEATURE)          # both extras checked before any work starts
    require("matplotlib", "plots", FEATURE)
    sing_leg, sing_t = chapter.singular_time()
    print(f"leg {sing_leg}'s (u × v)·w changes sign at t = {sing_t:.3f} s (θ̈ = 0): the chapter's formulation "
          f"divides by it; torques are computed on [{SPAN[0]}, {SPAN[1]}] s")
    cases = {"zero actuator accelerations": three_routes(samples),
             f"accelerations {ACCEL_CASE} rad/s²": three_routes(samples, ACCEL_CASE)}
    for label, r in cases.items():
        print(f"{label}: cond(A) {r.fig.cond_A.min():.2f}…{r.fig.cond_A.max():.2f}, cond(B) "
              f"{r.fig.cond_B.min():.2f}…{r.fig.cond_B.max():.2f}; generic vs chapter {r.err_generic:.1e}, "
              f"Pinocchio vs chapter {r.err_pinocchio:.1e} (ProximalSettings {PROXIMAL})")
    write(out_dir, cases)
    print(f"wrote {Path(out_dir) / 'fig7_actuator_torques.png'} and the CSVs")
    return 0
