"""Playback of a floating robot (free-flyer root): every body is drawn where forward kinematics puts it,
the interpolated quaternions stay unit, and `manipdyn play --root-joint free_flyer` writes a page."""
import subprocess
import sys
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn import viz
from manipdyn.validation.zoo import floating_paths

pytest.importorskip("meshcat")


@pytest.fixture(scope="module")
def solo():
    path = next(p for p in floating_paths() if "solo12" in str(p))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return path, md.load_urdf(path, root_joint="free_flyer")


def test_frames_follow_forward_kinematics(solo):
    """A trajectory that turns the root half a turn: each frame's body transforms are those of
    frame_placement at the interpolated configuration (at the midpoint, slerp and normalised lerp agree)."""
    path, m = solo
    t = np.array([0.0, 1.0])
    q0 = md.random_configuration(m, np.random.default_rng(0))
    q1 = md.integrate(m, q0, np.r_[0.3, 0.0, 0.1, 0.0, 0.0, 1.5, np.zeros(m.nv - 6)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = viz.scene_for(m, path, t, np.vstack([q0, q1]), fps=10.0)
    Q = np.vstack([q0, q1])
    qk = Q[0] + (Q[1] - Q[0]) * 0.5
    qk[3:7] /= np.linalg.norm(qk[3:7])
    R, p = md.frame_placement(m, qk, m.body_names[3])
    T = sc.frames[sc.nodes[3]][5]                               # frame 5 of 11 (fps 10): t = 0.5 s
    assert np.abs(T[:3, :3] - R).max() < 1e-12 and np.abs(T[:3, 3] - p).max() < 1e-12   # measured 0 (same FK)


def test_cli_plays_a_free_flyer(solo, tmp_path):
    path, _ = solo
    out = tmp_path / "solo.html"
    r = subprocess.run([sys.executable, "-m", "manipdyn.cli", "play", str(path), "--root-joint", "free_flyer",
                        "--html", str(out)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 10_000


def test_a_floating_closed_chain_is_completed_by_assembly():
    """The demo of the four-bar on a free flyer: base at its neutral pose, the crank swinging, the passive
    joints assembled so that every frame closes; a trajectory giving only the crank completes the same way
    (the missing base columns stay at the neutral pose)."""
    from conftest import ROOT
    from manipdyn.constraints import closure_terms
    path = ROOT / "urdf" / "fourbar.urdf"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                              # the base link has no <inertial>
        m = md.load_urdf(path, root_joint="free_flyer")
    t, Q = viz.demo(m, path)
    assert Q.shape == (len(t), m.nq) and np.all(Q[:, :7] == md.neutral(m)[:7])
    assert np.abs(closure_terms(m, Q)[0]).max() <= 1e-11            # measured 8.2e-13
    crank = m.joint_index(m.actuated[0])
    given = np.full_like(Q, np.nan)
    given[:, m.idx_q[crank]] = Q[:, m.idx_q[crank]]
    done = viz.complete(m, given)
    assert np.abs(closure_terms(m, done)[0]).max() <= 1e-11        # measured 8.2e-13
    assert np.all(done[:, :7] == md.neutral(m)[:7]) and np.array_equal(done[:, m.idx_q[crank]], Q[:, m.idx_q[crank]])
