"""The chapter's Example I (AAU arm) against Pinocchio and the analytic path."""
import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, assert_close

import manipdyn as md
from manipdyn.examples import aau_arm as ex
from manipdyn.validation.reference import Reference

MODEL = md.load_urdf(AAU)


@pytest.fixture(scope="module")
def example():
    return ex.chapter_example(MODEL, samples=201)


def test_path_is_tracked_and_rest_to_rest(example):
    traj, _ = example
    assert traj.pos_err.max() < 1e-10 and traj.dir_err.max() < 1e-14    # measured 1.4e-12 m, 6.8e-16
    assert not traj.damped.any() and traj.sigma_min.min() > 0.1
    assert_close(traj.v[[0, -1]], np.zeros((2, MODEL.nv)), 1e-14, "rest to rest")  # measured 1.7e-16


def test_torques_equal_pinocchio_with_the_payload(example):
    traj, tau = example
    ref = Reference(MODEL, AAU)
    for k in range(len(traj.t)):
        fx = ref.fext(traj.q[k], {"tool": ([0.0, 0.0, -ex.PAYLOAD_KG * ex.G], [0.0, 0.0, 0.0])}, "world")
        t_pin = pin.rnea(ref.pm, ref.pd, ref.to_pin_q(traj.q[k]), traj.v[k], traj.a[k], fx)
        assert_close(tau[k], t_pin, 5e-14, f"τ at t = {traj.t[k]:.3f}")  # measured 5.8e-16


def test_payload_weight_is_a_downward_load(example):
    # physical check of the sign: the payload adds J_vᵀ (0, 0, −m g) to the torques τ = ... − Jᵀ f_ext
    traj, tau = example
    bare = md.rnea(MODEL, traj.q, traj.v, traj.a)
    J = md.frame_jacobian(MODEL, traj.q, "tool")
    assert_close(tau - bare, np.einsum("nki,k->ni", J[:, :3], [0, 0, ex.PAYLOAD_KG * ex.G]), 5e-14, "payload")  # measured 7.4e-16


def test_csv_round_trip_recomputed_by_pinocchio(example, tmp_path):
    traj, tau = example
    path = tmp_path / "aau.csv"
    ex.write_csv(path, MODEL, traj, tau)
    head, data = ex.read_csv(path)
    names = MODEL.joint_names
    assert head == ["t"] + [f"{b}_{j}" for b in ("q", "v", "a", "tau") for j in names]
    col = {h: data[:, i] for i, h in enumerate(head)}
    Q, V, A, TAU = (np.column_stack([col[f"{b}_{j}"] for j in names]) for b in ("q", "v", "a", "tau"))
    ref = Reference(MODEL, AAU)
    fid = ref.pm.getFrameId("tool")
    x, xd, xdd = ex.path(col["t"])
    for k in range(0, len(col["t"]), 5):
        pq = ref.to_pin_q(Q[k])
        fx = ref.fext(Q[k], {"tool": ([0.0, 0.0, -ex.PAYLOAD_KG * ex.G], [0.0, 0.0, 0.0])}, "world")
        assert_close(TAU[k], pin.rnea(ref.pm, ref.pd, pq, V[k], A[k], fx), 5e-14, "τ from the CSV")  # measured 5.8e-16
        pin.forwardKinematics(ref.pm, ref.pd, pq, V[k], A[k])
        pin.updateFramePlacements(ref.pm, ref.pd)
        LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        vel = pin.getFrameVelocity(ref.pm, ref.pd, fid, LWA)
        acc = pin.getFrameClassicalAcceleration(ref.pm, ref.pd, fid, LWA)
        assert_close(ref.pd.oMf[fid].translation, x[k], 1e-11, "tool position")  # measured 3.0e-13
        assert_close(vel.linear, xd[k], 1e-14, "tool velocity")  # measured 2.8e-16
        assert_close(acc.linear, xdd[k], 1e-14, "tool acceleration")  # measured 2.2e-16
        # the tool axis is held (5 joints: the yaw about it is free): ω ∥ d*, so ω × d* = 0
        assert_close(np.cross(vel.angular, ex.D_STAR), np.zeros(3), 1e-14, "tool axis held")  # measured 1.8e-16


def test_singular_path_is_detected_and_bounded():
    q0 = ex.initial_configuration(MODEL)
    tr = ex.singular_path(MODEL, q0)
    assert np.all(np.isfinite(tr.q)) and np.all(np.isfinite(tr.v)) and np.all(np.isfinite(tr.a))
    assert tr.damped.any() and tr.sigma_min.min() < 1e-3            # detected (σ_min reported), damped
    assert np.abs(tr.v).max() < 10.0                                 # bounded rates
    first = np.argmax(tr.damped)
    assert tr.pos_err[:first].max() < 5e-11                          # measured 8.6e-13; exact until the singular region


def test_cli_writes_figures_and_csv(tmp_path):
    from manipdyn.cli import main
    assert main(["example", "aau", "--out", str(tmp_path), "--samples", "41"]) == 0
    for f in ("aau_arm.csv", "fig3_joint_rates.png", "fig4_joint_torques.png"):
        assert (tmp_path / f).stat().st_size > 1000, f


def test_payload_inertia_option_against_pinocchio(example):
    # the payload as a rigid body: Pinocchio appends the same inertia to joint 5 at the tool placement
    traj, _ = example
    I_p = np.diag([0.02, 0.03, 0.025])
    tau = ex.torques(MODEL, traj, inertia=I_p)
    ref = Reference(MODEL, AAU)
    fid = ref.pm.getFrameId("tool")
    placement = ref.pm.frames[fid].placement
    ref.pm.appendBodyToJoint(ref.pm.frames[fid].parentJoint, pin.Inertia(ex.PAYLOAD_KG, np.zeros(3), I_p), placement)
    ref.pd = ref.pm.createData()
    for k in range(0, len(traj.t), 10):
        assert_close(tau[k], pin.rnea(ref.pm, ref.pd, ref.to_pin_q(traj.q[k]), traj.v[k], traj.a[k]), 1e-12, "τ")
    # at rest the weight alone remains: same as the external-force model
    still = ex.Trajectory(traj.t[:3], traj.q[:3], 0 * traj.v[:3], 0 * traj.a[:3], *(x[:3] for x in
                          (traj.pos_err, traj.dir_err, traj.sigma_min, traj.damped)))
    assert_close(ex.torques(MODEL, still, inertia=I_p), ex.torques(MODEL, still), 1e-12, "static payload")
