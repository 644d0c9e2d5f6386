"""Playback of models with ball joints: each quaternion is interpolated along the shorter great arc (slerp),
whatever the sign of its samples; the bodies are drawn where forward kinematics puts them; rates from the
samples recover a constant body-frame ω; the plots are labelled by model.q_names / v_names; the demo and the
self-contained page work for a ball/hinge tree and for a closed chain through a ball joint.

References: Rodrigues' formula written here (the rotation after s of the turn between two samples), the body
rate of a uniform rotation, the closure residual Φ of each completed frame."""
import warnings

import numpy as np
import pytest

from ball_models import PENDULUM, RSSR, random_tree

import manipdyn as md
from manipdyn import viz
from manipdyn.constraints import assemble, closure_terms, project
from manipdyn.viz import plots

pytest.importorskip("meshcat")


def _rodrigues(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _quat(R):
    """[x y z w] of a rotation matrix (w > 0 branch; the test's rotations are below π)."""
    w = 0.5 * np.sqrt(1 + np.trace(R))
    return np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1], 4 * w * w]) / (4 * w)


@pytest.mark.parametrize("flip", [False, True], ids=["same-sign", "opposite-sign"])
def test_ball_quaternion_turns_along_the_shorter_arc(flip):
    """Two samples 1 s apart, the second turned 2.5 rad about a body axis (given as −q when flipped, the same
    rotation): the frame at t = s shows R0 · Rodrigues(axis, 2.5 s) — normalised lerp would lag by up to
    0.068 rad (same sign), and towards −q it would take the long way round."""
    m = md.load_mjcf_string(PENDULUM)
    R0, axis = _rodrigues([0.3, -1.0, 0.4], 0.7), np.array([1.0, 2.0, -0.5])
    q0, q1 = _quat(R0), _quat(R0 @ _rodrigues(axis, 2.5))
    Q = np.vstack([q0, -q1 if flip else q1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = viz.scene_for(m, None, np.array([0.0, 1.0]), Q, fps=10.0, plots=False)
    frames = sc.frames[sc.nodes[0]]
    assert len(frames) == 11
    worst = max(np.abs(frames[k][:3, :3] - R0 @ _rodrigues(axis, 0.25 * k)).max() for k in range(11))
    assert worst < 1e-13, worst                                  # measured 5.0e-16


def test_rates_of_a_uniform_rotation_and_the_plot_labels():
    """A ball/hinge tree whose ball joints each turn at a constant body rate ω_j and whose hinges move
    linearly: the finite-difference rates are ω_j and the hinge slopes exactly (up to rounding); the plot
    groups name every entry by model.q_names / v_names and τ by v_names (rnea on those rates)."""
    m = md.load_mjcf_string(random_tree(3))
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 2.0, 41)
    v = rng.normal(0.0, 1.0, m.nv)                                # ω of each ball, slope of each hinge
    q0 = md.random_configuration(m, rng)
    Q = md.integrate(m, np.tile(q0, (len(t), 1)), np.outer(t, v))  # q0 ⊕ t v: uniform turns, linear hinges
    V, _ = plots.rates(m, t, Q)
    assert np.abs(V - v).max() < 1e-12, np.abs(V - v).max()        # measured 1.2e-14
    sig = plots.signals(m, t, Q)
    groups = {g["key"]: g for g in sig["groups"]}
    assert groups["q"]["names"] == list(m.q_names) and len(groups["q"]["series"]) == m.nq
    assert groups["v"]["names"] == list(m.v_names) and len(groups["v"]["series"]) == m.nv
    assert groups["tau"]["names"] == list(m.v_names) and len(groups["tau"]["series"]) == m.nv
    tau = md.rnea(m, Q, V, np.zeros_like(V))                       # a uniform motion: q̈ = 0 on every entry
    assert np.abs(np.array(groups["tau"]["series"]).T - tau).max() <= 5e-5 * np.abs(tau).max()   # 5 digits


def test_ball_tree_demo_page(tmp_path):
    m = md.load_mjcf_string(random_tree(3))
    motion = viz.demo_motion(m, None)
    t, Q = motion["t"], motion["Q"]
    assert Q.shape == (len(t), m.nq)
    for k in m.quat_q:
        assert np.abs(np.linalg.norm(Q[:, k:k + 4], axis=1) - 1).max() < 1e-15       # measured 1.1e-16
    balls = [j for j in range(m.njoints) if m.nqs[j] == 4]
    assert all(np.ptp(Q[:, m.idx_q[j] + 3]) > 0.05 for j in balls)                     # every ball turns
    out = tmp_path / "tree.html"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = viz.export_html(m, None, t, Q, out)
    text = out.read_text()
    assert out.stat().st_size > 10_000 and all(n in text for n in m.q_names + m.v_names)
    # each frame's bodies where forward kinematics puts them at the interpolated configuration
    Qf = viz.scene.interpolate(m, t - t[0], Q, sc.times)
    for b in range(m.njoints):
        for k in range(0, len(sc.times), 10):
            R, p = md.frame_placement(m, Qf[k], m.body_names[b])     # the MJCF body: its frame in the drawn
            f, T = m.frame(m.body_names[b]), sc.frames[sc.nodes[b]][k]  # joint frame (a ball's pos offsets it)
            assert np.abs(T[:3, :3] @ f.R - R).max() < 1e-14                         # measured 0
            assert np.abs(T[:3, :3] @ f.p + T[:3, 3] - p).max() < 1e-14              # measured 2.8e-17


def test_closed_chain_through_a_ball_joint_plays(tmp_path):
    """The RSSR four-bar (a ball joint in the loop) simulated for 1 s: the page plays it, the closure gap
    plotted stays at the simulation's Φ, the quaternion interpolated between samples keeps it small."""
    m = md.load_mjcf_string(RSSR.replace("{d}", "0.9999"))
    rng = np.random.default_rng(2)
    q0 = assemble(m, md.integrate(m, md.neutral(m), rng.normal(0.0, 0.4, m.nv)), fixed=[]).q
    q0, v0 = project(m, q0, rng.normal(0.0, 1.5, m.nv))
    sim = md.simulate(m, q0, v0, (0.0, 1.0), dt=2e-3, stabilization="projection")
    out = tmp_path / "rssr.html"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = viz.export_html(m, None, sim.t[::5], sim.q[::5], out)
    gap = {g["key"]: g for g in sc.plots["groups"]}["gap"]
    assert max(max(s) for s in gap["series"]) < 1e-10            # the samples: measured 1.5e-12 (projection)
    Qf = viz.scene.interpolate(m, sim.t[::5], sim.q[::5], sc.times)
    phi = np.abs(closure_terms(m, Qf)[0]).max()
    assert phi < 5e-3, phi                                        # between samples 10 ms apart: measured 5.0e-4
    assert "torques not shown" in " ".join(sc.plots["notes"])      # MJCF: no actuated joints to solve for
